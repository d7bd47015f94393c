//! Normal map pass (compute, `shaders/normals.wgsl`).
//!
//! Normals from finite differences as [`relief_core::normal_map`] computes them: Balogh 2003
//! (seed 004), section 2.3 (`(-dz/dx, -dz/dy, 1)` normalised, central differences), the Sobel
//! operator Kentie 2009 (seed 003, section 3.6) uses for smoother shading, and, with a detail
//! map, the composed base + detail surface of Balogh's section 7.3 (the detail map tiled over the
//! base and added before differencing, as [`relief_core::Composed`] does; with
//! [`NormalPass::new_composed`] the base is first refined by a power-of-two factor with bilinear
//! interpolation, as `Composed` refines it; non-power-of-two factors are not supported, as in
//! the core). Same border rule as the CPU: a missing neighbour is the sample itself. One
//! invocation per sample, 8 x 8 workgroups; output the gradient `(dz/dx, dz/dy)` per sample
//! (`vec2<f32>`, 8 bytes), from which the ray caster computes the unit normal
//! `normalize(-dz/dx, -dz/dy, 1)` where it reads it (half the memory of a stored `vec4`
//! normal, the same values: [`NormalPass::read`] does the same operations).

use crate::util::{self, bind_buffers, compute_pipeline, groups, storage_entry, uniform_entry};
use crate::{Error, GpuTerrain};
use relief_core::NormalMethod;

/// A normal map of a [`GpuTerrain`]'s current heights, optionally with a tiled detail map.
///
/// ```no_run
/// use relief_core::{Heightfield, NormalMethod};
/// let gpu = relief_wgpu::headless()?;
/// let hf = Heightfield::new(&[0.0f32, 1.0, 2.0, 0.0, 1.0, 2.0], 3, 2)?;
/// let t = relief_wgpu::GpuTerrain::new(&gpu.device, &gpu.queue, &hf, false)?;
/// let pass = relief_wgpu::NormalPass::new(&gpu.device, &gpu.queue, &t, NormalMethod::Central, None)?;
/// let mut enc = gpu.device.create_command_encoder(&Default::default());
/// pass.encode(&mut enc);
/// gpu.queue.submit([enc.finish()]);
/// let n = pass.read(&gpu.device, &gpu.queue)?;
/// assert!((n[1][0] + std::f32::consts::FRAC_1_SQRT_2).abs() < 1e-6);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug)]
pub struct NormalPass {
    width: u32,
    height: u32,
    normals: wgpu::Buffer,
    pipeline: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
}

impl NormalPass {
    /// A pass writing the normals of `terrain` with `method`. `detail` is an optional tiled
    /// detail map `(samples, width, height)` in local height units, added to the base (the
    /// composed surface). [`Error::Unsupported`] for an empty or mis-sized detail map,
    /// [`Error::TooLarge`] when the gradients (8 bytes a sample) do not fit one storage buffer
    /// binding of the device.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        terrain: &GpuTerrain,
        method: NormalMethod,
        detail: Option<(&[f32], u32, u32)>,
    ) -> Result<NormalPass, Error> {
        Self::build(device, queue, terrain, method, detail, 0)
    }

    /// The normals of the composed surface of [`relief_core::Composed`] with `factor`: the
    /// terrain refined `factor` times by bilinear interpolation (a power of two, at least 1)
    /// plus `detail` tiled over the refined grid, on the refined grid of
    /// `((width - 1) * factor + 1) x ((height - 1) * factor + 1)` samples at the base spacing
    /// divided by `factor`. [`Error::Core`] with [`relief_core::Error::InvalidFactor`] for
    /// a factor that is not a power of two; [`Error::Unsupported`] for an empty or mis-sized
    /// detail map; [`Error::TooLarge`] for a refined grid whose gradients (8 bytes a sample)
    /// do not fit one storage buffer binding of the device.
    ///
    /// ```no_run
    /// use relief_core::{Heightfield, NormalMethod};
    /// let gpu = relief_wgpu::headless()?;
    /// let hf = Heightfield::new(&[0.0f32, 1.0, 2.0, 0.0, 1.0, 2.0], 3, 2)?;
    /// let t = relief_wgpu::GpuTerrain::new(&gpu.device, &gpu.queue, &hf, false)?;
    /// let detail = [0.5f32, -0.5, -0.5, 0.5];
    /// let pass = relief_wgpu::NormalPass::new_composed(
    ///     &gpu.device, &gpu.queue, &t, NormalMethod::Sobel, (&detail, 2, 2), 4)?;
    /// assert_eq!(pass.size(), (9, 5));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn new_composed(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        terrain: &GpuTerrain,
        method: NormalMethod,
        detail: (&[f32], u32, u32),
        factor: u32,
    ) -> Result<NormalPass, Error> {
        if !factor.is_power_of_two() {
            return Err(relief_core::Error::InvalidFactor { factor }.into());
        }
        Self::build(
            device,
            queue,
            terrain,
            method,
            Some(detail),
            factor.trailing_zeros(),
        )
    }

    fn build(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        terrain: &GpuTerrain,
        method: NormalMethod,
        detail: Option<(&[f32], u32, u32)>,
        shift: u32,
    ) -> Result<NormalPass, Error> {
        let (bw, bh) = terrain.size();
        let refined = |n: u32| {
            (n - 1)
                .checked_mul(1u32.checked_shl(shift)?)
                .and_then(|v| v.checked_add(1))
        };
        let (Some(w), Some(h)) = (refined(bw), refined(bh)) else {
            return Err(relief_core::Error::SizeOverflow.into());
        };
        util::check_dispatch(device, w, h)?;
        let s = terrain.scale();
        let k = (1u32 << shift) as f32;
        let (dx, dy) = (s.dx / k, s.dy / k);
        let (dw, dh) = match detail {
            Some((d, dw, dh)) => {
                if dw == 0 || dh == 0 || d.len() != dw as usize * dh as usize {
                    return Err(Error::Unsupported(
                        "detail map size does not match its samples",
                    ));
                }
                (dw, dh)
            }
            None => (1, 1),
        };
        let detail_buf = match detail {
            Some((d, _, _)) => {
                util::storage_init(device, "relief detail", bytemuck::cast_slice(d))?
            }
            None => util::storage(device, "relief detail (unused)", 4)?,
        };
        let normals = util::storage(device, "relief normal map", w as u64 * h as u64 * 8)?;
        let params = util::uniform(device, "relief normal params", 32);
        let p: [u32; 8] = [w, h, dw, dh, dx.to_bits(), dy.to_bits(), shift, 0];
        queue.write_buffer(&params, 0, bytemuck::cast_slice(&p));
        let module =
            device.create_shader_module(wgpu::include_wgsl!("../../../shaders/normals.wgsl"));
        let cs = wgpu::ShaderStages::COMPUTE;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("relief normals"),
            entries: &[
                storage_entry(0, true, cs),
                storage_entry(1, false, cs),
                uniform_entry(2, cs),
                storage_entry(3, true, cs),
            ],
        });
        let sobel = matches!(method, NormalMethod::Sobel);
        let pipeline = compute_pipeline(
            device,
            "relief normals",
            &layout,
            &module,
            "normal_map",
            &[
                ("SOBEL", f64::from(u8::from(sobel))),
                ("DETAIL", f64::from(u8::from(detail.is_some()))),
            ],
        );
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("relief normals"),
            layout: &layout,
            entries: &bind_buffers(&[terrain.heights(), &normals, &params, &detail_buf]),
        });
        Ok(NormalPass {
            width: w,
            height: h,
            normals,
            pipeline,
            group,
        })
    }

    /// The size of the normal map (the terrain's, or the refined grid's for
    /// [`NormalPass::new_composed`]).
    #[must_use]
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// The normal map buffer: `width * height` gradients `(dz/dx, dz/dy)` (`vec2<f32>`,
    /// row-major, world height units per world unit); the normal is
    /// `normalize(-dz/dx, -dz/dy, 1)`.
    #[must_use]
    pub fn buffer(&self) -> &wgpu::Buffer {
        &self.normals
    }

    /// Records the pass.
    pub fn encode(&self, encoder: &mut wgpu::CommandEncoder) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("relief normal map"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.group, &[]);
        pass.dispatch_workgroups(groups(self.width, 8), groups(self.height, 8), 1);
    }

    /// Reads the normals back (waits for the GPU; for tests and tools): each computed from the
    /// stored gradient with the ray caster's operations ([`gradient_normal`]).
    pub fn read(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<Vec<[f32; 3]>, Error> {
        Ok(self
            .read_gradients(device, queue)?
            .into_iter()
            .map(gradient_normal)
            .collect())
    }

    /// Reads the stored gradients `(dz/dx, dz/dy)` back (waits for the GPU; for tests and
    /// tools).
    pub fn read_gradients(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> Result<Vec<[f32; 2]>, Error> {
        let n = self.width as u64 * self.height as u64 * 8;
        let v = util::f32s(&util::read_buffer(device, queue, &self.normals, n)?);
        Ok(v.chunks_exact(2).map(|c| [c[0], c[1]]).collect())
    }
}

/// The unit normal `normalize(-gx, -gy, 1)` of a surface with gradient `[gx, gy]`, scaled by
/// the largest component first so that the squares cannot overflow: what the ray caster
/// (`shaders/raycast.wgsl`, `gradient_normal`) computes from a [`NormalPass`] sample.
///
/// ```
/// let n = relief_wgpu::normals::gradient_normal([1.0, 0.0]);
/// assert!((n[0] + std::f32::consts::FRAC_1_SQRT_2).abs() < 1e-7 && n[1] == 0.0);
/// let steep = relief_wgpu::normals::gradient_normal([1e30, 0.0]);
/// assert_eq!(steep, [-1.0, 0.0, 1e-30]);
/// ```
#[must_use]
pub fn gradient_normal([gx, gy]: [f32; 2]) -> [f32; 3] {
    let m = gx.abs().max(gy.abs()).max(1.0);
    let v = [-gx / m, -gy / m, 1.0 / m];
    let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / len, v[1] / len, v[2] / len]
}
