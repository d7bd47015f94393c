//! Cascade ray cast (compute): seed 002, Cornel, Horvath and Waser, *Interactive Visualization
//! of Large Heightfields with RBF Approximation* (2022), section 5.
//!
//! The RBF approximation is discretized into three cascades on the GPU
//! ([`crate::rbf::RbfPass`], invisible texels set far below the terrain so rays fall through
//! them); each cascade gets its own maximum mipmap ([`GpuTerrain::from_buffer`]) and every
//! pixel's ray is traced through each ([`RayCastPass`], the camera translated to the cascade's
//! origin, which leaves directions and distances unchanged). The blend pass
//! (`shaders/cascade_blend.wgsl`) takes, nearest cascade first, the first hit on a visible
//! texel, and in the overlap with the next cascade blends the two hits by the convex
//! combination of their blend weights. Blend weights per texel come from the CPU
//! ([`relief_core::rbf::Cascade::blend_weight`]).

use crate::raycast::{RayEffects, Shading};
use crate::rbf::RbfPass;
use crate::util::{self, bind_buffers, compute_pipeline, groups, storage_entry, uniform_entry};
use crate::{Error, GpuTerrain, Method, RayCastPass};
use glam::Vec3;
use relief_core::rbf::{Cascades, CASCADES};
use relief_core::{Camera, Scale};

/// The cascades of one view on the GPU, ready to be traced from that view's camera.
///
/// ```no_run
/// # fn demo(gpu: &relief_wgpu::Gpu, pass: &relief_wgpu::rbf::RbfPass, c: &relief_core::rbf::Cascades, cam: &relief_core::Camera) -> Result<(), relief_wgpu::Error> {
/// use relief_wgpu::cascade::CascadeRayCast;
/// let rc = CascadeRayCast::new(&gpu.device, &gpu.queue, pass, c, relief_core::Scale::default(), (0.0, 100.0), cam)?;
/// let mut enc = gpu.device.create_command_encoder(&Default::default());
/// rc.encode(&gpu.queue, &mut enc, cam)?;
/// gpu.queue.submit([enc.finish()]);
/// let depth = rc.read_depth(&gpu.device, &gpu.queue)?;
/// # Ok(()) }
/// ```
#[derive(Debug)]
pub struct CascadeRayCast {
    layers: Vec<(GpuTerrain, RayCastPass, [f32; 3])>,
    pipeline: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    params: wgpu::Buffer,
    depth: wgpu::Buffer,
    cascades: Cascades,
    scale: Scale,
    width: u32,
    height: u32,
}

impl CascadeRayCast {
    /// Discretizes `cascades` with `rbf` (one submission) and prepares the traces for images of
    /// `camera`'s size. `scale` is the base grid's (texel spacing times `dx`, `dy`); heights are
    /// the RBF values as they are (z_offset 0) and `z_range` must contain them.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        rbf: &RbfPass,
        cascades: &Cascades,
        scale: Scale,
        z_range: (f32, f32),
        camera: &Camera,
    ) -> Result<CascadeRayCast, Error> {
        let (w, h) = (camera.width, camera.height);
        let floor = z_range.0 - 10.0 * (z_range.1 - z_range.0).abs() - 1000.0;
        let mut enc = device.create_command_encoder(&Default::default());
        let mut values = Vec::new();
        let mut all_weights = Vec::new();
        for c in &cascades.cascades {
            let res = c.resolution;
            let mut mask = vec![0u8; res as usize * res as usize];
            c.mask(&mut mask)?;
            values.push(rbf.encode(device, queue, &mut enc, c, &mask, floor)?);
            for j in 0..res {
                for i in 0..res {
                    let k = (j * res + i) as usize;
                    all_weights.push(if mask[k] != 0 {
                        c.blend_weight(i, j)
                    } else {
                        0.0
                    });
                }
            }
        }
        queue.submit([enc.finish()]);
        let mut layers = Vec::new();
        for (c, v) in cascades.cascades.iter().zip(values) {
            let cs = scale
                .with_spacing(scale.dx * c.spacing, scale.dy * c.spacing)
                .with_z_scale(1.0)
                .with_z_offset(0.0);
            let t = GpuTerrain::from_buffer(
                device,
                v,
                c.resolution,
                c.resolution,
                cs,
                (floor, z_range.1),
            )?;
            let rays = RayCastPass::new(
                device,
                &t,
                None,
                None,
                Method::MaxMip,
                RayEffects::default(),
                w,
                h,
            )?;
            let o = [
                c.origin[0] as f32 * c.spacing * scale.dx,
                c.origin[1] as f32 * c.spacing * scale.dy,
                0.0,
            ];
            layers.push((t, rays, o));
        }
        let module =
            device.create_shader_module(wgpu::include_wgsl!("../../../shaders/cascade_blend.wgsl"));
        let cs = wgpu::ShaderStages::COMPUTE;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("relief cascade blend"),
            entries: &[
                uniform_entry(0, cs),
                storage_entry(1, true, cs),
                storage_entry(2, true, cs),
                storage_entry(3, true, cs),
                storage_entry(4, true, cs),
                storage_entry(5, false, cs),
            ],
        });
        let pipeline = compute_pipeline(
            device,
            "relief cascade blend",
            &layout,
            &module,
            "blend",
            &[],
        );
        let params = util::uniform(device, "relief cascade blend params", 160);
        let weights = util::storage_init(
            device,
            "relief cascade weights",
            bytemuck::cast_slice(&all_weights),
        );
        let depth = util::storage(
            device,
            "relief cascade depth",
            u64::from(w) * u64::from(h) * 4,
        );
        let d = |k: usize| &layers[k].1.outputs().depth;
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("relief cascade blend"),
            layout: &layout,
            entries: &bind_buffers(&[&params, d(0), d(1), d(2), &weights, &depth]),
        });
        Ok(CascadeRayCast {
            layers,
            pipeline,
            group,
            params,
            depth,
            cascades: *cascades,
            scale,
            width: w,
            height: h,
        })
    }

    /// Records, for every cascade, its max-mip build and ray cast, then the blend.
    pub fn encode(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        camera: &Camera,
    ) -> Result<(), Error> {
        if camera.width != self.width || camera.height != self.height {
            return Err(Error::Unsupported(
                "camera image size differs from the pass's",
            ));
        }
        for (t, rays, o) in &self.layers {
            let o = Vec3::from_array(*o);
            let cam = Camera::new(
                camera.eye - o,
                camera.target - o,
                camera.fov_deg,
                camera.width,
                camera.height,
            )?;
            t.encode_maxmip(encoder);
            rays.encode(queue, encoder, t, &cam, &Shading::default())?;
        }
        let (f, r, u) = camera.basis();
        let mut p = [0u32; 40];
        let fl = [
            camera.eye.x,
            camera.eye.y,
            camera.eye.z,
            0.0,
            f.x,
            f.y,
            f.z,
            0.0,
            r.x,
            r.y,
            r.z,
            0.0,
            u.x,
            u.y,
            u.z,
            0.0,
            camera.tan_half_fov(),
            camera.width as f32 / camera.height as f32,
            self.scale.dx,
            self.scale.dy,
        ];
        for (i, v) in fl.iter().enumerate() {
            p[i] = v.to_bits();
        }
        p[20] = camera.width;
        p[21] = camera.height;
        for (k, c) in self.cascades.cascades.iter().enumerate().take(CASCADES) {
            let ox = i32::try_from(c.origin[0])
                .map_err(|_| Error::Unsupported("cascade origin beyond i32"))?;
            let oy = i32::try_from(c.origin[1])
                .map_err(|_| Error::Unsupported("cascade origin beyond i32"))?;
            p[24 + 4 * k] = ox as u32;
            p[25 + 4 * k] = oy as u32;
            p[26 + 4 * k] = c.resolution;
            p[36 + k] = c.spacing.to_bits();
        }
        queue.write_buffer(&self.params, 0, bytemuck::cast_slice(&p));
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("relief cascade blend"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.group, &[]);
        pass.dispatch_workgroups(groups(self.width, 8), groups(self.height, 8), 1);
        Ok(())
    }

    /// Reads the blended depth image back (distance along the unit ray, `+inf` for a miss).
    pub fn read_depth(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> Result<Vec<f32>, Error> {
        let n = u64::from(self.width) * u64::from(self.height) * 4;
        Ok(util::f32s(&util::read_buffer(
            device,
            queue,
            &self.depth,
            n,
        )?))
    }

    /// Reads cascade `k`'s own depth image back (before blending; `None` past the last).
    pub fn read_cascade_depth(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        k: usize,
    ) -> Option<Result<Vec<f32>, Error>> {
        self.layers
            .get(k)
            .map(|l| l.1.outputs().read_depth(device, queue))
    }
}
