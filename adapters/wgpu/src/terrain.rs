//! Heightfield upload, deformations and the maximum-mipmap build (compute).
//!
//! The maximum mipmap is that of Tevs, Ihrke and Seidel, *Maximum Mipmaps for Fast, Accurate,
//! and Scalable Dynamic Height Field Rendering* (I3D 2008), section 4, which Cornel et al.
//! (seed 002, section 5) build once per cascade; the levels are exactly
//! [`relief_core::ray::MaxMip`]'s (level 0 = maximum of each cell's four corners, then 2 x 2
//! maxima, odd sizes rounding up), stored row-major one level after another, so the GPU pyramid
//! can be compared with the CPU one node for node (through [`relief_core::ray::MaxMip::node`]:
//! the CPU may tile its storage). Deformations (craters, Kentie 2009, seed 003, section 3.8) rewrite the
//! working heights from the uploaded base every frame, after which the pyramid is rebuilt: one
//! dispatch per level, 8 x 8 workgroups (`shaders/maxmip.wgsl`, `shaders/deform.wgsl`).

use crate::util::{self, bind_buffers, compute_pipeline, groups, storage_entry, uniform_entry};
use crate::Error;
use relief_core::{Scale, Terrain};

/// Most craters a [`GpuTerrain`] applies per frame.
pub const MAX_CRATERS: usize = 64;

/// A crater: lowers the surface by `depth * (1 - (r / radius)^2)` within `radius` of `center`
/// (grid units horizontally, local height units vertically).
///
/// ```
/// let c = relief_wgpu::terrain::Crater { center: [10.0, 12.0], radius: 5.0, depth: 2.0 };
/// assert_eq!(c.lowering(10.0, 12.0), 2.0);
/// assert_eq!(c.lowering(20.0, 12.0), 0.0);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Crater {
    /// Centre `(x, y)` in grid units.
    pub center: [f32; 2],
    /// Radius in grid units (> 0).
    pub radius: f32,
    /// Depth at the centre, in local height units (`h * z_scale`).
    pub depth: f32,
}

impl Crater {
    /// How much this crater lowers the sample at grid position `(x, y)` (the CPU reference of
    /// `shaders/deform.wgsl`).
    ///
    /// ```
    /// let c = relief_wgpu::terrain::Crater { center: [0.0, 0.0], radius: 2.0, depth: 4.0 };
    /// assert_eq!(c.lowering(1.0, 0.0), 3.0);
    /// ```
    #[must_use]
    pub fn lowering(&self, x: f32, y: f32) -> f32 {
        let d = [x - self.center[0], y - self.center[1]];
        let q = (d[0] * d[0] + d[1] * d[1]) / (self.radius * self.radius);
        if q < 1.0 {
            self.depth * (1.0 - q)
        } else {
            0.0
        }
    }
}

/// A heightfield on the GPU: local heights (`h * z_scale`, `f32`), optionally a working copy
/// deformed every frame, and its maximum mipmap (unless made by [`GpuTerrain::without_maxmip`]).
///
/// ```no_run
/// use relief_core::{ray::MaxMip, Heightfield};
/// let gpu = relief_wgpu::headless()?;
/// let hf = Heightfield::new(&[0.0f32, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0], 3, 3)?;
/// let t = relief_wgpu::GpuTerrain::new(&gpu.device, &gpu.queue, &hf, false)?;
/// let mut enc = gpu.device.create_command_encoder(&Default::default());
/// t.encode_maxmip(&mut enc);
/// gpu.queue.submit([enc.finish()]);
/// let mip = t.read_maxmip(&gpu.device, &gpu.queue)?;
/// assert_eq!(mip, vec![4.0, 5.0, 7.0, 8.0, 8.0]); // 2 x 2 cells, then the top
/// # let _ = MaxMip::len(3, 3);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug)]
pub struct GpuTerrain {
    width: u32,
    height: u32,
    scale: Scale,
    zmin: f32,
    zmax: f32,
    crater_depth: f32,
    base: wgpu::Buffer,
    current: Option<wgpu::Buffer>,
    /// The pyramid's layout, kept without the pyramid too (ray casting's step bound).
    mip_len: usize,
    offsets: Vec<u32>,
    dims: Vec<(u32, u32)>,
    mip: Option<Pyramid>,
    deform: Option<Deform>,
}

/// The max-mip buffer and its build.
#[derive(Debug)]
struct Pyramid {
    buffer: wgpu::Buffer,
    pipeline: wgpu::ComputePipeline,
    groups: Vec<wgpu::BindGroup>,
}

#[derive(Debug)]
struct Deform {
    pipeline: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    params: wgpu::Buffer,
    craters: wgpu::Buffer,
}

impl GpuTerrain {
    /// Uploads `terrain`'s local heights and allocates its max-mip pyramid. With `dynamic`,
    /// keeps a second working copy that [`GpuTerrain::encode_deform`] rewrites from the base
    /// every frame. Nothing is dispatched: record [`GpuTerrain::encode_maxmip`] before tracing
    /// with the pyramid. [`Error::Core`] for a grid smaller than 2 x 2, [`Error::TooLarge`]
    /// when its heights (4 bytes a sample) or max-mip pyramid (about 5.3 bytes a sample) do not
    /// fit one storage buffer binding of the device (a 128 MiB binding holds 5793 x 5793
    /// heights, a pyramid of about 5017 x 5017 samples).
    pub fn new<T: Terrain>(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        terrain: &T,
        dynamic: bool,
    ) -> Result<GpuTerrain, Error> {
        Self::upload(device, queue, terrain, dynamic, true)
    }

    /// [`GpuTerrain::new`] without the max-mip pyramid, for passes that read only the heights
    /// (the march and silhouette methods): [`GpuTerrain::maxmip`] is `None` and
    /// [`GpuTerrain::encode_maxmip`] records nothing. A 128 MiB binding then holds terrains up
    /// to 5793 x 5793 samples.
    ///
    /// ```no_run
    /// use relief_core::Heightfield;
    /// let gpu = relief_wgpu::headless()?;
    /// let hf = Heightfield::new(&[0.0f32, 1.0, 2.0, 3.0], 2, 2)?;
    /// let t = relief_wgpu::GpuTerrain::without_maxmip(&gpu.device, &gpu.queue, &hf, false)?;
    /// assert!(t.maxmip().is_none());
    /// assert!(t.read_maxmip(&gpu.device, &gpu.queue).is_err());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn without_maxmip<T: Terrain>(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        terrain: &T,
        dynamic: bool,
    ) -> Result<GpuTerrain, Error> {
        Self::upload(device, queue, terrain, dynamic, false)
    }

    fn upload<T: Terrain>(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        terrain: &T,
        dynamic: bool,
        pyramid: bool,
    ) -> Result<GpuTerrain, Error> {
        let (w, h) = (terrain.width(), terrain.height());
        if w < 2 || h < 2 {
            return Err(relief_core::Error::TooSmall {
                width: w,
                height: h,
            }
            .into());
        }
        // Checked before the heights are gathered: 4 bytes a sample (a normal map, 8 a sample,
        // is checked by the `NormalPass` a lit scene builds).
        util::check_storage(device, "relief heights", w as u64 * h as u64 * 4)?;
        let mut local = Vec::with_capacity(w as usize * h as usize);
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for y in 0..h {
            for x in 0..w {
                let z = terrain.local_z(x, y);
                lo = lo.min(z);
                hi = hi.max(z);
                local.push(z);
            }
        }
        let base = util::storage_init(device, "relief heights", bytemuck::cast_slice(&local))?;
        let current = dynamic
            .then(|| {
                util::storage_init(
                    device,
                    "relief deformed heights",
                    bytemuck::cast_slice(&local),
                )
            })
            .transpose()?;
        let t = Self::build(
            device,
            base,
            current,
            (w, h),
            terrain.scale(),
            (lo, hi),
            pyramid,
        )?;
        if let Some(d) = &t.deform {
            queue.write_buffer(&d.params, 0, bytemuck::cast_slice(&[w, h, 0u32, 0u32]));
        }
        Ok(t)
    }

    /// A terrain whose local heights are already on the GPU: `heights` holds `width * height`
    /// `f32` (row-major, `STORAGE` usage), for example a cascade discretized by
    /// [`crate::rbf::RbfPass`]; `range` must contain every height (it clips rays). Static (no
    /// deformations). [`Error::Core`] for a grid smaller than 2 x 2.
    pub fn from_buffer(
        device: &wgpu::Device,
        heights: wgpu::Buffer,
        width: u32,
        height: u32,
        scale: Scale,
        range: (f32, f32),
    ) -> Result<GpuTerrain, Error> {
        if width < 2 || height < 2 {
            return Err(relief_core::Error::TooSmall { width, height }.into());
        }
        if heights.size() < u64::from(width) * u64::from(height) * 4 {
            return Err(Error::Unsupported(
                "height buffer smaller than width * height f32",
            ));
        }
        Self::build(device, heights, None, (width, height), scale, range, true)
    }

    fn build(
        device: &wgpu::Device,
        base: wgpu::Buffer,
        current: Option<wgpu::Buffer>,
        (w, h): (u32, u32),
        scale: Scale,
        (lo, hi): (f32, f32),
        pyramid: bool,
    ) -> Result<GpuTerrain, Error> {
        // The max-mip build and deformations dispatch over the samples (the pyramid's levels
        // are smaller).
        util::check_dispatch(device, w, h)?;
        // Pyramid layout as MaxMip's.
        let (nx, ny) = (w - 1, h - 1);
        let mut offsets = Vec::new();
        let mut dims = Vec::new();
        let mut total = 0u32;
        let mut k = 0;
        loop {
            let (lw, lh) = (((nx - 1) >> k) + 1, ((ny - 1) >> k) + 1);
            offsets.push(total);
            dims.push((lw, lh));
            total = total
                .checked_add(lw * lh)
                .ok_or(Error::Unsupported("max-mip pyramid too large"))?;
            k += 1;
            if lw == 1 && lh == 1 {
                break;
            }
        }
        let mip_len = total as usize;
        let src = current.as_ref().unwrap_or(&base);
        let mip = if pyramid {
            Some(Pyramid::new(device, src, w, h, mip_len, &offsets, &dims)?)
        } else {
            None
        };
        let cs = wgpu::ShaderStages::COMPUTE;
        let deform = current.as_ref().map(|cur| -> Result<Deform, Error> {
            let module =
                device.create_shader_module(wgpu::include_wgsl!("../../../shaders/deform.wgsl"));
            let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("relief deform"),
                entries: &[
                    storage_entry(0, true, cs),
                    storage_entry(1, false, cs),
                    uniform_entry(2, cs),
                    storage_entry(3, true, cs),
                ],
            });
            let pipeline =
                compute_pipeline(device, "relief deform", &layout, &module, "deform", &[]);
            let params = util::uniform(device, "relief deform params", 16);
            let craters = util::storage(device, "relief craters", MAX_CRATERS as u64 * 16)?;
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("relief deform"),
                layout: &layout,
                entries: &bind_buffers(&[&base, cur, &params, &craters]),
            });
            Ok(Deform {
                pipeline,
                group,
                params,
                craters,
            })
        });
        let deform = deform.transpose()?;
        Ok(GpuTerrain {
            width: w,
            height: h,
            scale,
            zmin: lo,
            zmax: hi,
            crater_depth: 0.0,
            base,
            current,
            mip_len,
            offsets,
            dims,
            mip,
            deform,
        })
    }

    /// Sample grid size `(width, height)`.
    #[must_use]
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// The terrain's scale.
    #[must_use]
    pub fn scale(&self) -> Scale {
        self.scale
    }

    /// Local height range `(min, max)` that contains every height, deformed ones included.
    #[must_use]
    pub fn height_range(&self) -> (f32, f32) {
        (self.zmin - self.crater_depth, self.zmax)
    }

    /// Local height range of the uploaded (undeformed) heights.
    #[must_use]
    pub fn base_range(&self) -> (f32, f32) {
        (self.zmin, self.zmax)
    }

    /// The heights the passes read: the deformed working copy for a dynamic terrain, else the
    /// uploaded base (`width * height` `f32`, row-major).
    #[must_use]
    pub fn heights(&self) -> &wgpu::Buffer {
        self.current.as_ref().unwrap_or(&self.base)
    }

    /// The maximum-mipmap buffer ([`GpuTerrain::mip_len`] `f32`); `None` for a terrain made by
    /// [`GpuTerrain::without_maxmip`].
    #[must_use]
    pub fn maxmip(&self) -> Option<&wgpu::Buffer> {
        self.mip.as_ref().map(|m| &m.buffer)
    }

    /// Elements of the pyramid (the sum of its row-major levels; the layout's, also without
    /// the pyramid).
    #[must_use]
    pub fn mip_len(&self) -> usize {
        self.mip_len
    }

    /// Offset of each level in the pyramid buffer.
    #[must_use]
    pub fn mip_offsets(&self) -> &[u32] {
        &self.offsets
    }

    /// Whether this terrain has a working copy for deformations.
    #[must_use]
    pub fn is_dynamic(&self) -> bool {
        self.current.is_some()
    }

    /// Sets the craters of the next [`GpuTerrain::encode_deform`] (a queue write, no wait).
    /// [`Error::Unsupported`] for a static terrain or more than [`MAX_CRATERS`];
    /// [`relief_core::Error::InvalidParameter`] for a non-finite value or a radius `<= 0`.
    pub fn set_craters(&mut self, queue: &wgpu::Queue, craters: &[Crater]) -> Result<(), Error> {
        let Some(d) = &self.deform else {
            return Err(Error::Unsupported("craters need a dynamic terrain"));
        };
        if craters.len() > MAX_CRATERS {
            return Err(Error::Unsupported("more than MAX_CRATERS craters"));
        }
        let mut data = Vec::with_capacity(craters.len() * 4);
        let mut total = 0.0f32;
        for c in craters {
            let v = [c.center[0], c.center[1], c.radius, c.depth];
            if v.iter().any(|x| !x.is_finite()) || c.radius <= 0.0 {
                return Err(relief_core::Error::InvalidParameter {
                    name: "crater",
                    value: c.radius,
                }
                .into());
            }
            total += c.depth.max(0.0);
            data.extend_from_slice(&v);
        }
        if !data.is_empty() {
            queue.write_buffer(&d.craters, 0, bytemuck::cast_slice(&data));
        }
        queue.write_buffer(
            &d.params,
            0,
            bytemuck::cast_slice(&[self.width, self.height, craters.len() as u32, 0]),
        );
        self.crater_depth = total;
        Ok(())
    }

    /// Records the deformation pass (working heights = base minus craters). Does nothing for a
    /// static terrain.
    pub fn encode_deform(&self, encoder: &mut wgpu::CommandEncoder) {
        let Some(d) = &self.deform else { return };
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("relief deform"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&d.pipeline);
        pass.set_bind_group(0, &d.group, &[]);
        pass.dispatch_workgroups(groups(self.width, 8), groups(self.height, 8), 1);
    }

    /// Records the maximum-mipmap build: one dispatch per level in one compute pass (each
    /// dispatch sees the previous one's writes). Nothing without a pyramid.
    pub fn encode_maxmip(&self, encoder: &mut wgpu::CommandEncoder) {
        let Some(mip) = &self.mip else { return };
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("relief maxmip"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&mip.pipeline);
        for (g, &(lw, lh)) in mip.groups.iter().zip(&self.dims) {
            pass.set_bind_group(0, g, &[]);
            pass.dispatch_workgroups(groups(lw, 8), groups(lh, 8), 1);
        }
    }

    /// Reads the pyramid back (waits for the GPU; for tests and tools). [`Error::Unsupported`]
    /// without a pyramid.
    pub fn read_maxmip(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> Result<Vec<f32>, Error> {
        let mip = self
            .maxmip()
            .ok_or(Error::Unsupported("this terrain has no max-mip pyramid"))?;
        let b = util::read_buffer(device, queue, mip, self.mip_len as u64 * 4)?;
        Ok(util::f32s(&b))
    }

    /// Reads the heights the passes see back (waits for the GPU; for tests and tools).
    pub fn read_heights(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> Result<Vec<f32>, Error> {
        let n = self.width as u64 * self.height as u64 * 4;
        Ok(util::f32s(&util::read_buffer(
            device,
            queue,
            self.heights(),
            n,
        )?))
    }
}

impl Pyramid {
    /// The pyramid buffer of a `w x h` sample grid read from `src`, and one bind group a level.
    fn new(
        device: &wgpu::Device,
        src: &wgpu::Buffer,
        w: u32,
        h: u32,
        len: usize,
        offsets: &[u32],
        dims: &[(u32, u32)],
    ) -> Result<Pyramid, Error> {
        let mip = util::storage(device, "relief maxmip", len as u64 * 4)?;
        let module =
            device.create_shader_module(wgpu::include_wgsl!("../../../shaders/maxmip.wgsl"));
        let cs = wgpu::ShaderStages::COMPUTE;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("relief maxmip"),
            entries: &[
                storage_entry(0, true, cs),
                storage_entry(1, false, cs),
                uniform_entry(2, cs),
            ],
        });
        let mip_pipeline = compute_pipeline(
            device,
            "relief maxmip",
            &layout,
            &module,
            "build_level",
            &[],
        );
        let mut mip_groups = Vec::new();
        for (level, &(lw, lh)) in dims.iter().enumerate() {
            let (so, (sw, sh)) = if level == 0 {
                (0, (w, h))
            } else {
                (offsets[level - 1], dims[level - 1])
            };
            let params: [u32; 8] = [w, level as u32, so, offsets[level], sw, sh, lw, lh];
            let ub = wgpu::util::DeviceExt::create_buffer_init(
                device,
                &wgpu::util::BufferInitDescriptor {
                    label: Some("relief maxmip level"),
                    contents: bytemuck::cast_slice(&params),
                    usage: wgpu::BufferUsages::UNIFORM,
                },
            );
            mip_groups.push(device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("relief maxmip level"),
                layout: &layout,
                entries: &bind_buffers(&[src, &mip, &ub]),
            }));
        }
        Ok(Pyramid {
            buffer: mip,
            pipeline: mip_pipeline,
            groups: mip_groups,
        })
    }
}
