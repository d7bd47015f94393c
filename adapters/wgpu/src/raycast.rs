//! Ray casting pass (compute, `shaders/raycast.wgsl`): depth, normal and colour per pixel.
//!
//! One invocation per pixel in 8 x 8 workgroups; the camera is [`relief_core::Camera`]'s
//! (CONVENTIONS.md), the depth is the distance `t` along the unit ray (`+inf` for a miss), as the
//! CPU `relief trace` writes it. Two methods, both ported in `f32` from `relief_core::ray` with
//! the same clipping, in heightfield-local coordinates (the eye converted in `f64` on the CPU):
//! - [`Method::MaxMip`]: the maximum-mipmap traversal of Tevs, Ihrke and Seidel (2008), which
//!   Cornel et al. (seed 002, section 5) use per cascade, with the exact `triangles` cell test;
//! - [`Method::March`]: Kentie's linear + binary search (seed 003, sections 3.3-3.4).
//!
//! Effects are WGSL override constants (`LIGHTING`, `SHADOWS`, `DETAIL`, `FOG`, `WATER`) fixed
//! when the pipeline is created: an effect that is off is compiled out (seed 003, section 4 and
//! table 1 measure each feature's cost on its own). Shadows are shadow rays towards the sun
//! traced with the same method; lighting uses the normal map (seed 003, section 3.6).

use crate::util::{self, bind_buffers, compute_pipeline, groups, storage_entry, uniform_entry};
use crate::{Error, GpuTerrain};
use glam::Vec3;
use relief_core::Camera;

/// How rays find the surface.
///
/// ```
/// use relief_wgpu::Method;
/// assert_ne!(Method::MaxMip, Method::march());
/// assert_eq!(Method::march(), Method::March { samples: 256, refine: 8 });
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// Maximum-mipmap traversal, exact (equal to the CPU cell DDA up to `f32` rounding).
    MaxMip,
    /// Linear search with `samples` samples, then `refine` binary steps (approximate).
    March {
        /// Samples along the clipped ray (at least 1).
        samples: u32,
        /// Binary refinement steps (at most 64).
        refine: u32,
    },
    /// Silhouette partitioning (seed 000, [`crate::silhouette`]): approximate, a fixed number
    /// of texture reads per pixel ([`crate::silhouette::reads_per_pixel`]); needs the whole
    /// terrain in front of the camera. A [`crate::Scene`] method only ([`RayCastPass`] rejects
    /// it).
    Silhouette,
    /// The RBF cascade ray cast (seed 002, [`crate::cascade`]): the terrain approximated by
    /// truncated Gaussians on an adaptive grid, discretized every frame into three cascades of
    /// `resolution x resolution` texels, each traced with its own maximum mipmap, overlap hits
    /// blended. A [`crate::Scene`] method only ([`RayCastPass`] rejects it).
    Cascades {
        /// Texels per side of each cascade (at least 2).
        resolution: u32,
    },
}

impl Method {
    /// The cascade ray cast with 512 texels per cascade side.
    ///
    /// ```
    /// assert_eq!(relief_wgpu::Method::cascades(), relief_wgpu::Method::Cascades { resolution: 512 });
    /// ```
    #[must_use]
    pub fn cascades() -> Method {
        Method::Cascades { resolution: 512 }
    }

    /// Its name on the command line (`relief render --method`).
    ///
    /// ```
    /// assert_eq!(relief_wgpu::Method::Silhouette.name(), "silhouette");
    /// ```
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Method::MaxMip => "maxmip",
            Method::March { .. } => "march",
            Method::Silhouette => "silhouette",
            Method::Cascades { .. } => "cascades",
        }
    }

    /// The march with [`relief_core::ray::MarchOptions`]' defaults (256 samples, 8 steps).
    ///
    /// ```
    /// assert!(matches!(relief_wgpu::Method::march(), relief_wgpu::Method::March { .. }));
    /// ```
    #[must_use]
    pub fn march() -> Method {
        let o = relief_core::ray::MarchOptions::default();
        Method::March {
            samples: o.samples,
            refine: o.refine,
        }
    }
}

/// Which effects the ray caster's pipeline is specialised for.
///
/// ```
/// let f = relief_wgpu::raycast::RayEffects { lighting: true, ..Default::default() };
/// assert!(f.lighting && !f.shadows);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RayEffects {
    /// Diffuse sun light from the normal map.
    pub lighting: bool,
    /// Shadow rays towards the sun.
    pub shadows: bool,
    /// Tiled detail map modulating the colour.
    pub detail: bool,
    /// Distance fog.
    pub fog: bool,
    /// A water plane, or with `water_surface` a water heightfield.
    pub water: bool,
    /// The water is a heightfield (one height per sample) instead of a plane.
    pub water_surface: bool,
    /// Each pixel's world normal written to [`RayOutputs::normal`] (read back with
    /// [`RayOutputs::read_normals`]): 16 bytes a pixel, not written or allocated without it.
    pub normals: bool,
}

impl RayEffects {
    /// The override constants of `shaders/raycast.wgsl` for these effects and `method`.
    ///
    /// ```
    /// let c = relief_wgpu::raycast::RayEffects::default().constants(relief_wgpu::Method::MaxMip);
    /// assert!(c.iter().all(|&(_, v)| v == 0.0));
    /// ```
    #[must_use]
    pub fn constants(&self, method: Method) -> Vec<(&'static str, f64)> {
        let b = |x: bool| f64::from(u8::from(x));
        vec![
            (
                "METHOD",
                if matches!(method, Method::March { .. }) {
                    1.0
                } else {
                    0.0
                },
            ),
            ("LIGHTING", b(self.lighting)),
            ("SHADOWS", b(self.shadows)),
            ("DETAIL", b(self.detail)),
            ("FOG", b(self.fog)),
            ("WATER", b(self.water)),
            ("WATER_SURFACE", b(self.water && self.water_surface)),
            ("NORMALS", b(self.normals)),
        ]
    }
}

/// Linear samples of the water-surface march (`WATER_STEPS` in `shaders/raycast.wgsl`).
pub const WATER_STEPS: u32 = 128;
/// Bisections after the first sample below the water (`WATER_REFINE` in the shader).
pub const WATER_REFINE: u32 = 8;

/// The CPU reference of the shader's water-surface march (`trace_water` in
/// `shaders/raycast.wgsl`, in `f64`): the first parameter `t` at which the ray `o + t d` is at
/// or below the water surface, or `None`. Heightfield-local coordinates: `x`, `y` in grid
/// units (world divided by the spacing), `z` local (world minus the terrain's z offset);
/// `water` holds one local height per terrain sample, row-major over `width x height`,
/// interpolated bilinearly and clamped to the grid. The ray is clipped to the grid's extent
/// and to `t <= t_end` (the terrain's hit), then sampled at [`WATER_STEPS`] + 1 evenly spaced
/// points; the first sample below the water is refined by [`WATER_REFINE`] bisections with
/// the sample before it (seed 003's linear + binary search). `None` as well for a grid
/// smaller than 2 x 2, a `water` of another size, or a clipped ray without a finite end (a
/// vertical ray with an infinite `t_end`).
///
/// ```
/// use relief_wgpu::raycast::water_surface_hit;
/// // Water at local height 1 over a 3 x 3 grid; a ray going down from height 3.
/// let water = [1.0f32; 9];
/// let t = water_surface_hit(&water, 3, 3, [0.5, 1.0, 3.0], [0.5, 0.0, -1.0], f64::INFINITY).unwrap();
/// assert!((t - 2.0).abs() < 1e-3);
/// assert_eq!(water_surface_hit(&water, 3, 3, [0.5, 1.0, 3.0], [0.5, 0.0, -1.0], 1.5), None);
/// ```
pub fn water_surface_hit(
    water: &[f32],
    width: u32,
    height: u32,
    o: [f64; 3],
    d: [f64; 3],
    t_end: f64,
) -> Option<f64> {
    if width < 2 || height < 2 || water.len() != width as usize * height as usize {
        return None;
    }
    let (w, h) = (width, height);
    let water_at = |gx: f64, gy: f64| -> f64 {
        let (x, y) = (
            gx.clamp(0.0, f64::from(w - 1)),
            gy.clamp(0.0, f64::from(h - 1)),
        );
        let (x0, y0) = ((x.floor() as u32).min(w - 2), (y.floor() as u32).min(h - 2));
        let (fx, fy) = (x - f64::from(x0), y - f64::from(y0));
        let at = |x: u32, y: u32| {
            f64::from(
                water
                    .get((y as usize) * w as usize + x as usize)
                    .copied()
                    .unwrap_or(f32::NAN),
            )
        };
        let a = at(x0, y0) + (at(x0 + 1, y0) - at(x0, y0)) * fx;
        let b = at(x0, y0 + 1) + (at(x0 + 1, y0 + 1) - at(x0, y0 + 1)) * fx;
        a + (b - a) * fy
    };
    let (mut t0, mut t1) = (0.0f64, t_end);
    for (k, ext) in [f64::from(w - 1), f64::from(h - 1)].into_iter().enumerate() {
        if d[k] == 0.0 {
            if !(o[k] >= 0.0 && o[k] <= ext) {
                return None;
            }
        } else {
            let (a, b) = ((0.0 - o[k]) / d[k], (ext - o[k]) / d[k]);
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
    }
    if !(t0 <= t1 && t1.is_finite()) {
        return None;
    }
    let below = |t: f64| o[2] + t * d[2] <= water_at(o[0] + t * d[0], o[1] + t * d[1]);
    let step = (t1 - t0) / f64::from(WATER_STEPS);
    let mut prev = t0;
    for s in 0..=WATER_STEPS {
        let t = if s == WATER_STEPS {
            t1
        } else {
            t0 + step * f64::from(s)
        };
        if below(t) {
            let (mut lo, mut hi) = (prev, t);
            for _ in 0..WATER_REFINE {
                if hi <= lo {
                    break;
                }
                let mid = 0.5 * (lo + hi);
                if below(mid) {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            return Some(hi);
        }
        prev = t;
    }
    None
}

/// Shading parameters (used only by the effects that are on).
///
/// Defaults: sun from the south-west at 35 degrees elevation, ambient 0.3, fog colour light
/// grey-blue with density `6e-6` per world unit, water blue at world height 0, detail gain 0.05.
///
/// ```
/// let s = relief_wgpu::raycast::Shading::default().with_water_level(12.0);
/// assert_eq!(s.water_level, 12.0);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shading {
    /// Direction towards the sun (world, normalised on use).
    pub sun: Vec3,
    /// Ambient light in `[0, 1]`.
    pub ambient: f32,
    /// Fog colour (linear RGB).
    pub fog_color: Vec3,
    /// Fog density per world unit.
    pub fog_density: f32,
    /// Water colour.
    pub water_color: Vec3,
    /// Water level (world z).
    pub water_level: f32,
    /// Colour change per local height unit of the detail map.
    pub detail_gain: f32,
}

impl Default for Shading {
    fn default() -> Self {
        Shading {
            sun: Vec3::new(-0.58, -0.58, 0.57),
            ambient: 0.3,
            fog_color: Vec3::new(0.75, 0.8, 0.85),
            fog_density: 6e-6,
            water_color: Vec3::new(0.1, 0.25, 0.45),
            water_level: 0.0,
            detail_gain: 0.05,
        }
    }
}

impl Shading {
    /// Sets the water level (world z; default 0).
    ///
    /// ```
    /// assert_eq!(relief_wgpu::raycast::Shading::default().with_water_level(3.0).water_level, 3.0);
    /// ```
    #[must_use]
    pub fn with_water_level(mut self, z: f32) -> Self {
        self.water_level = z;
        self
    }

    /// Sets the fog density per world unit (default `6e-6`).
    ///
    /// ```
    /// assert_eq!(relief_wgpu::raycast::Shading::default().with_fog_density(1e-3).fog_density, 1e-3);
    /// ```
    #[must_use]
    pub fn with_fog_density(mut self, d: f32) -> Self {
        self.fog_density = d;
        self
    }

    /// Sets the direction towards the sun (default south-west, 35 degrees up).
    ///
    /// ```
    /// let s = relief_wgpu::raycast::Shading::default().with_sun(glam::Vec3::Z);
    /// assert_eq!(s.sun, glam::Vec3::Z);
    /// ```
    #[must_use]
    pub fn with_sun(mut self, sun: Vec3) -> Self {
        self.sun = sun;
        self
    }
}

/// The ray caster's output buffers for a `width x height` image, row-major: depth (`f32` bits,
/// `+inf` for a miss), world normal (`vec4<f32>`, `w = 1` on a hit) and colour (RGBA8).
#[derive(Debug)]
pub struct RayOutputs {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Depth (`f32`).
    pub depth: wgpu::Buffer,
    /// Normals (`vec4<f32>`), when requested ([`RayOutputs::has_normals`]); otherwise a
    /// 16-byte placeholder the passes do not write.
    pub normal: wgpu::Buffer,
    /// Colour (RGBA8 packed in a `u32`).
    pub color: wgpu::Buffer,
    normals: bool,
}

impl RayOutputs {
    /// Output buffers for a `width x height` image, with per-pixel normals when `normals` (16
    /// bytes a pixel: [`RayEffects::normals`]; depth and colour take 4 each).
    /// [`Error::TooLarge`] when a buffer does not fit one storage buffer binding of the device
    /// (128 MiB on many adapters, lavapipe included: about 8.4 M pixels with normals, 33.5 M
    /// without); [`Error::Unsupported`] for a side past `8 x
    /// max_compute_workgroups_per_dimension` pixels.
    pub fn new(
        device: &wgpu::Device,
        width: u32,
        height: u32,
        normals: bool,
    ) -> Result<RayOutputs, Error> {
        // Every pass that writes these dispatches one thread a pixel in 8 x 8 workgroups.
        util::check_dispatch(device, width, height)?;
        let n = width as u64 * height as u64;
        Ok(RayOutputs {
            width,
            height,
            depth: util::storage(device, "relief depth", n * 4)?,
            normal: util::storage(
                device,
                "relief normals out",
                if normals { n * 16 } else { 16 },
            )?,
            color: util::storage(device, "relief colour", n * 4)?,
            normals,
        })
    }

    /// Whether the normals are written ([`RayOutputs::new`]).
    #[must_use]
    pub fn has_normals(&self) -> bool {
        self.normals
    }

    /// Reads the depth image back (waits for the GPU).
    pub fn read_depth(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> Result<Vec<f32>, Error> {
        let n = self.width as u64 * self.height as u64 * 4;
        Ok(util::f32s(&util::read_buffer(
            device,
            queue,
            &self.depth,
            n,
        )?))
    }

    /// Reads the normals back (`w = 1` on a hit; waits for the GPU). [`Error::Unsupported`]
    /// when they were not requested.
    pub fn read_normals(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> Result<Vec<[f32; 4]>, Error> {
        if !self.normals {
            return Err(Error::Unsupported(
                "normals were not requested (RayEffects::normals, Effect::NormalOutput)",
            ));
        }
        let n = self.width as u64 * self.height as u64 * 16;
        let v = util::f32s(&util::read_buffer(device, queue, &self.normal, n)?);
        Ok(v.chunks_exact(4)
            .map(|c| [c[0], c[1], c[2], c[3]])
            .collect())
    }

    /// Reads the colours back as RGBA8 (waits for the GPU).
    pub fn read_color(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> Result<Vec<[u8; 4]>, Error> {
        let n = self.width as u64 * self.height as u64 * 4;
        let b = util::read_buffer(device, queue, &self.color, n)?;
        Ok(b.chunks_exact(4)
            .map(|c| [c[0], c[1], c[2], c[3]])
            .collect())
    }
}

/// The ray casting pass for one terrain, method, effect set and image size.
///
/// ```no_run
/// use relief_core::{Camera, Heightfield};
/// use relief_wgpu::{raycast::{RayEffects, Shading}, GpuTerrain, Method, RayCastPass};
/// use glam::Vec3;
/// let gpu = relief_wgpu::headless()?;
/// let hf = Heightfield::new(&[0.0f32; 16], 4, 4)?;
/// let t = GpuTerrain::new(&gpu.device, &gpu.queue, &hf, false)?;
/// let pass = RayCastPass::new(&gpu.device, &t, None, None, Method::MaxMip, RayEffects::default(), 8, 8)?;
/// let cam = Camera::new(Vec3::new(-1.0, -1.0, 3.0), Vec3::new(2.0, 2.0, 0.0), 60.0, 8, 8)?;
/// let mut enc = gpu.device.create_command_encoder(&Default::default());
/// t.encode_maxmip(&mut enc);
/// pass.encode(&gpu.queue, &mut enc, &t, &cam, &Shading::default())?;
/// gpu.queue.submit([enc.finish()]);
/// let depth = pass.outputs().read_depth(&gpu.device, &gpu.queue)?;
/// assert_eq!(depth.len(), 64);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug)]
pub struct RayCastPass {
    method: Method,
    effects: RayEffects,
    detail_size: (u32, u32),
    step_bound: u32,
    pipeline: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    params: wgpu::Buffer,
    out: RayOutputs,
}

const PARAM_WORDS: usize = 12 * 4 + 9 * 4;

impl RayCastPass {
    /// A pass over `terrain` writing a `width x height` image. `normals` (a normal map of the
    /// terrain: a [`crate::NormalPass`]'s gradients, `vec2<f32>` per sample) is needed for
    /// lighting, `detail` (`f32` local heights, width, height) for the detail effect. [`Error::Unsupported`] when an effect lacks its
    /// input, the image is empty, the march options are out of range, or [`Method::MaxMip`]
    /// meets a terrain without its pyramid ([`GpuTerrain::without_maxmip`], which suits
    /// [`Method::March`]).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        device: &wgpu::Device,
        terrain: &GpuTerrain,
        normals: Option<&wgpu::Buffer>,
        detail: Option<(&wgpu::Buffer, u32, u32)>,
        method: Method,
        effects: RayEffects,
        width: u32,
        height: u32,
    ) -> Result<RayCastPass, Error> {
        Self::new_with_water(
            device, terrain, normals, detail, None, method, effects, width, height,
        )
    }

    /// [`RayCastPass::new`] with a water surface: `water` holds one local height per terrain
    /// sample (row-major `f32`; for example the RBF approximation of a flood simulation's water
    /// levels, seed 002), needed when `effects.water_surface` is set.
    #[allow(clippy::too_many_arguments)]
    pub fn new_with_water(
        device: &wgpu::Device,
        terrain: &GpuTerrain,
        normals: Option<&wgpu::Buffer>,
        detail: Option<(&wgpu::Buffer, u32, u32)>,
        water: Option<&wgpu::Buffer>,
        method: Method,
        effects: RayEffects,
        width: u32,
        height: u32,
    ) -> Result<RayCastPass, Error> {
        if effects.water && effects.water_surface && water.is_none() {
            return Err(Error::Unsupported(
                "the water surface effect needs water heights",
            ));
        }
        if width == 0 || height == 0 {
            return Err(Error::Unsupported("empty image"));
        }
        if effects.lighting && normals.is_none() {
            return Err(Error::Unsupported("lighting needs a normal map"));
        }
        if effects.detail && detail.is_none() {
            return Err(Error::Unsupported("the detail effect needs a detail map"));
        }
        if matches!(method, Method::Silhouette | Method::Cascades { .. }) {
            return Err(Error::Unsupported(
                "RayCastPass casts max-mip and march rays only (silhouette and cascades are Scene methods)",
            ));
        }
        if let Method::March { samples, refine } = method {
            if samples == 0 || refine > 64 {
                return Err(Error::Unsupported(
                    "march needs 1+ samples and at most 64 refinement steps",
                ));
            }
        }
        if terrain.mip_offsets().len() > 36 {
            return Err(Error::Unsupported("too many max-mip levels"));
        }
        if method == Method::MaxMip && terrain.maxmip().is_none() {
            return Err(Error::Unsupported(
                "max-mip ray casting needs a terrain with its pyramid (GpuTerrain::new)",
            ));
        }
        let dummy = util::storage(device, "relief unused", 16)?;
        let out = RayOutputs::new(device, width, height, effects.normals)?;
        let params = util::uniform(device, "relief ray params", PARAM_WORDS as u64 * 4);
        let module =
            device.create_shader_module(wgpu::include_wgsl!("../../../shaders/raycast.wgsl"));
        let cs = wgpu::ShaderStages::COMPUTE;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("relief raycast"),
            entries: &[
                uniform_entry(0, cs),
                storage_entry(1, true, cs),
                storage_entry(2, true, cs),
                storage_entry(3, true, cs),
                storage_entry(4, true, cs),
                storage_entry(5, false, cs),
                storage_entry(6, false, cs),
                storage_entry(7, false, cs),
                storage_entry(8, true, cs),
            ],
        });
        let constants = effects.constants(method);
        let pipeline = compute_pipeline(
            device,
            "relief raycast",
            &layout,
            &module,
            "raycast",
            &constants,
        );
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("relief raycast"),
            layout: &layout,
            entries: &bind_buffers(&[
                &params,
                terrain.heights(),
                // March reads only the heights.
                terrain.maxmip().unwrap_or(&dummy),
                normals.unwrap_or(&dummy),
                detail.map_or(&dummy, |d| d.0),
                &out.depth,
                &out.normal,
                &out.color,
                water.unwrap_or(&dummy),
            ]),
        });
        // MaxMip::step_bound.
        let (w, h) = terrain.size();
        let (nx, ny) = (w - 1, h - 1);
        let mut bound = 2u64;
        for k in 0..terrain.mip_offsets().len() as u32 {
            bound += 2 * ((((nx - 1) >> k) + 1) as u64 + (((ny - 1) >> k) + 1) as u64) + 2;
        }
        Ok(RayCastPass {
            method,
            effects,
            detail_size: detail.map_or((1, 1), |d| (d.1, d.2)),
            step_bound: bound.min(u32::MAX as u64) as u32,
            pipeline,
            group,
            params,
            out,
        })
    }

    /// The output buffers.
    #[must_use]
    pub fn outputs(&self) -> &RayOutputs {
        &self.out
    }

    /// The effects this pipeline was specialised for.
    #[must_use]
    pub fn effects(&self) -> RayEffects {
        self.effects
    }

    /// Writes the camera and shading parameters (a queue write) and records the dispatch.
    /// The camera's image size must be the pass's ([`Error::Unsupported`] otherwise).
    pub fn encode(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        terrain: &GpuTerrain,
        camera: &Camera,
        shading: &Shading,
    ) -> Result<(), Error> {
        self.encode_scaled(queue, encoder, terrain, terrain.scale(), camera, shading)
    }

    /// [`RayCastPass::encode`] with the terrain's sample spacing and offset taken from `scale`
    /// instead of [`GpuTerrain::scale`] (a cascade whose texel spacing changes between
    /// frames).
    pub(crate) fn encode_scaled(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        terrain: &GpuTerrain,
        scale: relief_core::Scale,
        camera: &Camera,
        shading: &Shading,
    ) -> Result<(), Error> {
        if camera.width != self.out.width || camera.height != self.out.height {
            return Err(Error::Unsupported(
                "camera image size differs from the pass's",
            ));
        }
        let p = self.params(terrain, scale, camera, shading);
        queue.write_buffer(&self.params, 0, bytemuck::cast_slice(&p));
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("relief raycast"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.group, &[]);
        pass.dispatch_workgroups(groups(self.out.width, 8), groups(self.out.height, 8), 1);
        Ok(())
    }

    fn params(
        &self,
        terrain: &GpuTerrain,
        s: relief_core::Scale,
        camera: &Camera,
        shading: &Shading,
    ) -> [u32; PARAM_WORDS] {
        let (f, r, u) = camera.basis();
        let e = camera.eye.as_dvec3();
        let eye = [
            (e.x / f64::from(s.dx)) as f32,
            (e.y / f64::from(s.dy)) as f32,
            (e.z - f64::from(s.z_offset)) as f32,
        ];
        let (zmin, zmax) = terrain.height_range();
        let margin = 1e-5 * zmin.abs().max(zmax.abs()) + 1e-6;
        let sun = shading.sun.normalize_or(Vec3::Z);
        let aspect = camera.width as f32 / camera.height as f32;
        let (samples, refine) = match self.method {
            Method::March { samples, refine } => (samples, refine),
            _ => (1, 0),
        };
        let fl: [[f32; 4]; 10] = [
            [eye[0], eye[1], eye[2], 0.0],
            [f.x, f.y, f.z, 0.0],
            [r.x, r.y, r.z, 0.0],
            [u.x, u.y, u.z, 0.0],
            [s.dx, s.dy, camera.tan_half_fov(), aspect],
            [zmin - margin, zmax + margin, zmin, zmax],
            [sun.x, sun.y, sun.z, shading.ambient],
            [
                shading.fog_color.x,
                shading.fog_color.y,
                shading.fog_color.z,
                shading.fog_density,
            ],
            [
                shading.water_color.x,
                shading.water_color.y,
                shading.water_color.z,
                shading.water_level - s.z_offset,
            ],
            [
                shading.detail_gain,
                self.detail_size.0 as f32,
                self.detail_size.1 as f32,
                0.0,
            ],
        ];
        let mut p = [0u32; PARAM_WORDS];
        for (i, v) in fl.iter().flatten().enumerate() {
            p[i] = v.to_bits();
        }
        let (w, h) = terrain.size();
        let ints = [
            camera.width,
            camera.height,
            w,
            h,
            terrain.mip_offsets().len() as u32,
            self.step_bound,
            samples,
            refine,
        ];
        p[40..48].copy_from_slice(&ints);
        for (i, &o) in terrain.mip_offsets().iter().enumerate() {
            p[48 + i] = o;
        }
        p
    }
}
