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
//! combination of their blend weights. The blend weights are computed on the GPU, in the blend
//! shader, from each cascade's fade ramps and visible-texel mask exactly as
//! [`relief_core::rbf::Cascade::blend_weight`] defines them (the weight of the texel nearest
//! the hit); the tests compare the result with the same construction on the CPU using the
//! core's weights.
//!
//! Per frame (the `Method::Cascades` passes of a [`crate::Scene`], in this order): the
//! discretization of the three cascades ([`CascadeRayCast::encode_discretize`]), their maximum
//! mipmaps ([`CascadeRayCast::encode_maxmip`]), the three ray casts
//! ([`CascadeRayCast::encode_rays`]) and the blend ([`CascadeRayCast::encode_blend`]). The
//! buffers and pipelines are created once; a frame only writes parameters and the cascades'
//! polygons (the visible-texel masks are computed on the GPU).

use crate::raycast::{RayEffects, RayOutputs, Shading};
use crate::rbf::{RbfPass, RbfTarget};
use crate::util::{self, bind_buffers, compute_pipeline, groups, storage_entry, uniform_entry};
use crate::{Error, GpuTerrain, Method, RayCastPass};
use glam::Vec3;
use relief_core::rbf::{Cascade, Cascades, CASCADES};
use relief_core::{Camera, Scale};

const PARAM_WORDS: usize = 60;

#[derive(Debug)]
struct Layer {
    target: RbfTarget,
    terrain: GpuTerrain,
    rays: RayCastPass,
}

/// The cascade ray cast for one RBF approximation, cascade resolution and image size.
///
/// ```no_run
/// # fn demo(gpu: &relief_wgpu::Gpu, pass: &relief_wgpu::rbf::RbfPass, c: &relief_core::rbf::Cascades, cam: &relief_core::Camera) -> Result<(), relief_wgpu::Error> {
/// use relief_wgpu::cascade::CascadeRayCast;
/// let rc = CascadeRayCast::new(&gpu.device, pass, c.cascades[0].resolution, relief_core::Scale::default(), (0.0, 100.0), cam.width, cam.height)?;
/// let mut enc = gpu.device.create_command_encoder(&Default::default());
/// rc.encode(&gpu.queue, &mut enc, pass, c, cam)?;
/// gpu.queue.submit([enc.finish()]);
/// let depth = rc.read_depth(&gpu.device, &gpu.queue)?;
/// # Ok(()) }
/// ```
#[derive(Debug)]
pub struct CascadeRayCast {
    layers: Vec<Layer>,
    pipeline: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    params: wgpu::Buffer,
    out: RayOutputs,
    resolution: u32,
    scale: Scale,
    z_range: (f32, f32),
    floor: f32,
}

impl CascadeRayCast {
    /// Buffers and pipelines for cascades of `resolution x resolution` texels of `rbf`'s
    /// approximation and `width x height` images. `scale` is the base grid's (`dx`, `dy` per
    /// sample and the `z_offset` added to the RBF values, which are local heights; `z_scale`
    /// is not applied); `z_range` (local) must contain every RBF value.
    /// [`Error::Unsupported`] for an empty image or a resolution below 2.
    pub fn new(
        device: &wgpu::Device,
        rbf: &RbfPass,
        resolution: u32,
        scale: Scale,
        z_range: (f32, f32),
        width: u32,
        height: u32,
    ) -> Result<CascadeRayCast, Error> {
        if resolution < 2 {
            return Err(Error::Unsupported("cascade resolution below 2"));
        }
        if width == 0 || height == 0 {
            return Err(Error::Unsupported("empty image"));
        }
        let floor = z_range.0 - 10.0 * (z_range.1 - z_range.0).abs() - 1000.0;
        let mut layers = Vec::new();
        for _ in 0..CASCADES {
            let target = rbf.target(device, resolution)?;
            let terrain = GpuTerrain::from_buffer(
                device,
                target.values().clone(),
                resolution,
                resolution,
                scale.with_z_scale(1.0),
                (floor, z_range.1),
            )?;
            let rays = RayCastPass::new(
                device,
                &terrain,
                None,
                None,
                Method::MaxMip,
                RayEffects::default(),
                width,
                height,
            )?;
            layers.push(Layer {
                target,
                terrain,
                rays,
            });
        }
        let module =
            device.create_shader_module(wgpu::include_wgsl!("../../../shaders/cascade_blend.wgsl"));
        let cs = wgpu::ShaderStages::COMPUTE;
        let mut entries = vec![uniform_entry(0, cs)];
        entries.extend((1..7).map(|b| storage_entry(b, true, cs)));
        entries.extend((7..9).map(|b| storage_entry(b, false, cs)));
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("relief cascade blend"),
            entries: &entries,
        });
        let pipeline = compute_pipeline(
            device,
            "relief cascade blend",
            &layout,
            &module,
            "blend",
            &[],
        );
        let params = util::uniform(
            device,
            "relief cascade blend params",
            PARAM_WORDS as u64 * 4,
        );
        let out = RayOutputs::new(device, width, height, false)?;
        let d = |k: usize| &layers[k].rays.outputs().depth;
        let m = |k: usize| layers[k].target.mask();
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("relief cascade blend"),
            layout: &layout,
            entries: &bind_buffers(&[
                &params,
                d(0),
                d(1),
                d(2),
                m(0),
                m(1),
                m(2),
                &out.depth,
                &out.color,
            ]),
        });
        Ok(CascadeRayCast {
            layers,
            pipeline,
            group,
            params,
            out,
            resolution,
            scale,
            z_range,
            floor,
        })
    }

    /// Texels per side of each cascade.
    #[must_use]
    pub fn resolution(&self) -> u32 {
        self.resolution
    }

    /// The local height given to invisible texels (far below `z_range`, so rays fall through
    /// them).
    #[must_use]
    pub fn floor(&self) -> f32 {
        self.floor
    }

    /// The blended output: depth and colour (normals are not written).
    #[must_use]
    pub fn outputs(&self) -> &RayOutputs {
        &self.out
    }

    fn check(&self, cascades: &Cascades, camera: Option<&Camera>) -> Result<(), Error> {
        if cascades
            .cascades
            .iter()
            .any(|c| c.resolution != self.resolution)
        {
            return Err(Error::Unsupported(
                "cascade resolution differs from the pass's",
            ));
        }
        if let Some(camera) = camera {
            if camera.width != self.out.width || camera.height != self.out.height {
                return Err(Error::Unsupported(
                    "camera image size differs from the pass's",
                ));
            }
        }
        Ok(())
    }

    /// Records, for each of the three cascades, its visible-texel mask (the test of
    /// [`Cascade::mask`], computed on the GPU from the cascade's polygon) and its
    /// discretization ([`RbfPass::encode_into_gpu_mask`]): the CPU only writes parameters and
    /// polygons.
    pub fn encode_discretize(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        rbf: &RbfPass,
        cascades: &Cascades,
    ) -> Result<(), Error> {
        self.check(cascades, None)?;
        for (layer, c) in self.layers.iter().zip(&cascades.cascades) {
            rbf.encode_into_gpu_mask(queue, encoder, &layer.target, c, self.floor)?;
        }
        Ok(())
    }

    /// Records the three cascades' maximum-mipmap builds.
    pub fn encode_maxmip(&self, encoder: &mut wgpu::CommandEncoder) {
        for layer in &self.layers {
            layer.terrain.encode_maxmip(encoder);
        }
    }

    fn cascade_scale(&self, c: &Cascade) -> Scale {
        self.scale
            .with_spacing(self.scale.dx * c.spacing, self.scale.dy * c.spacing)
            .with_z_scale(1.0)
    }

    /// Records the three ray casts: each cascade is traced with its own maximum mipmap, the
    /// camera translated to the cascade's origin (directions and distances unchanged).
    pub fn encode_rays(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        cascades: &Cascades,
        camera: &Camera,
    ) -> Result<(), Error> {
        self.check(cascades, Some(camera))?;
        for (layer, c) in self.layers.iter().zip(&cascades.cascades) {
            let o = Vec3::new(
                c.origin[0] as f32 * c.spacing * self.scale.dx,
                c.origin[1] as f32 * c.spacing * self.scale.dy,
                0.0,
            );
            let cam = Camera::new(
                camera.eye - o,
                camera.target - o,
                camera.fov_deg,
                camera.width,
                camera.height,
            )?;
            layer.rays.encode_scaled(
                queue,
                encoder,
                &layer.terrain,
                self.cascade_scale(c),
                &cam,
                &Shading::default(),
            )?;
        }
        Ok(())
    }

    /// Writes the blend parameters (the cascades' lattices and fade ramps, the camera) and
    /// records the blend: per pixel the first cascade hit on a visible texel, blended with the
    /// next cascade's hit in their overlap by the convex combination of the two blend weights
    /// (computed in the shader).
    pub fn encode_blend(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        cascades: &Cascades,
        camera: &Camera,
    ) -> Result<(), Error> {
        self.check(cascades, Some(camera))?;
        let (f, r, u) = camera.basis();
        let view = glam::DVec2::new(f64::from(f.x), f64::from(f.y))
            .normalize_or(glam::DVec2::X)
            .as_vec2();
        let mut p = [0u32; PARAM_WORDS];
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
        for (k, c) in cascades.cascades.iter().enumerate().take(CASCADES) {
            let ox = i32::try_from(c.origin[0])
                .map_err(|_| Error::Unsupported("cascade origin beyond i32"))?;
            let oy = i32::try_from(c.origin[1])
                .map_err(|_| Error::Unsupported("cascade origin beyond i32"))?;
            p[24 + 4 * k] = ox as u32;
            p[25 + 4 * k] = oy as u32;
            p[26 + 4 * k] = c.resolution;
            p[36 + k] = c.spacing.to_bits();
            let fade = [c.fade_in[0], c.fade_in[1], c.fade_out[0], c.fade_out[1]];
            for (i, v) in fade.iter().enumerate() {
                p[44 + 4 * k + i] = v.to_bits();
            }
        }
        let ground = [camera.eye.x, camera.eye.y, view.x, view.y];
        for (i, v) in ground.iter().enumerate() {
            p[40 + i] = v.to_bits();
        }
        let z0 = self.scale.z_offset;
        p[56] = (self.z_range.0 + z0).to_bits();
        p[57] = (self.z_range.1 + z0).to_bits();
        queue.write_buffer(&self.params, 0, bytemuck::cast_slice(&p));
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("relief cascade blend"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.group, &[]);
        pass.dispatch_workgroups(groups(self.out.width, 8), groups(self.out.height, 8), 1);
        Ok(())
    }

    /// Records the whole cascade ray cast of one frame: discretization, max-mips, ray casts,
    /// blend.
    pub fn encode(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        rbf: &RbfPass,
        cascades: &Cascades,
        camera: &Camera,
    ) -> Result<(), Error> {
        self.encode_discretize(queue, encoder, rbf, cascades)?;
        self.encode_maxmip(encoder);
        self.encode_rays(queue, encoder, cascades, camera)?;
        self.encode_blend(queue, encoder, cascades, camera)
    }

    /// Reads the blended depth image back (distance along the unit ray, `+inf` for a miss).
    pub fn read_depth(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> Result<Vec<f32>, Error> {
        self.out.read_depth(device, queue)
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
            .map(|l| l.rays.outputs().read_depth(device, queue))
    }
}
