//! Effects on demand: a [`Scene`] names its effects and the [`Renderer`] builds each frame from
//! only the passes and shader variants those effects need.
//!
//! Kentie (seed 003, section 4, table 1) measured by hand what each feature of a GPU ray caster
//! costs; here the cost of an effect that a scene does not name is zero by construction: its
//! pass is not recorded and its shader code is compiled out (WGSL override constants,
//! [`crate::raycast::RayEffects::constants`]). [`Scene::frame_passes`] is the exact list of
//! passes a frame dispatches, tested for several scenes.
//!
//! | effect | passes it adds | shader variant |
//! |---|---|---|
//! | none (bare frame, [`Method::MaxMip`]) | `maxmip_build` once, `raycast` per frame | all effects off |
//! | [`Effect::Lighting`] | `normal_map` once | `LIGHTING` |
//! | [`Effect::Shadows`] | none (shadow rays in `raycast`) | `SHADOWS` |
//! | [`Effect::Detail`] | none (`normal_map` composed with the detail when lit) | `DETAIL` |
//! | [`Effect::Deformations`] | `deform` per frame; `maxmip_build`, `normal_map` move to every frame | none |
//! | [`Effect::Fog`] | none | `FOG` |
//! | [`Effect::Water`] | none | `WATER` (plane), `WATER_SURFACE` (a heightfield, e.g. an RBF approximation) |
//! | [`Effect::DepthOutput`] | `depth_resolve` per frame | none |
//! | [`Effect::NormalOutput`] | none (the ray cast writes 16 bytes more a pixel) | `NORMALS` |
//!
//! The method picks the frame's core passes:
//!
//! | method | setup passes | passes per frame | effects it takes |
//! |---|---|---|---|
//! | [`Method::MaxMip`] | `maxmip_build` (+ `normal_map` when lit) | `raycast` | all |
//! | [`Method::March`] | (`normal_map` when lit) | `raycast` | all |
//! | [`Method::Silhouette`] (seed 000) | none | `silhouette_map`, `silhouette_tree`, `silhouette_trace` | depth output |
//! | [`Method::Cascades`] (seed 002 sec. 5) | none (the RBF approximation is built on the CPU by [`Renderer::new`]) | `rbf_discretize`, `cascade_maxmip`, `cascade_raycast`, `cascade_blend` | depth output |
//!
//! Buffers follow the same rule: the terrain's max-mip pyramid (about 5.3 bytes a sample) is
//! allocated for [`Method::MaxMip`] only ([`GpuTerrain::without_maxmip`] otherwise), the normal
//! map for lit scenes only, per-pixel normals for [`Effect::NormalOutput`] only.
//!
//! Silhouette partitioning reads a fixed number of texels per pixel,
//! [`crate::silhouette::reads_per_pixel`] (8 for a 1025 x 1025 grid).
//!
//! Pass times ([`Renderer::render_profiled`]) come from GPU timestamp queries written between
//! the passes of one submission when the device has [`wgpu::Features::TIMESTAMP_QUERY`] and
//! [`wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS`], else from the wall clock around one
//! submission per pass ([`Clock`]). [`crate::headless`] requests the features from hardware
//! adapters only: Mesa's lavapipe offers them, but its timestamps do not wait for running
//! compute work (measured: with several renderers on one device, a 640 x 360 ray-cast pass
//! that takes about 150 ms read 0.03 ms), so on a CPU adapter the wall clock is the honest one.
//! Each pass also reports the CPU's own time recording it ([`PassTiming::cpu_ms`]), which
//! GPU timestamps do not see: a pass whose CPU side is heavy shows there on any device.

use crate::cascade::CascadeRayCast;
use crate::mesh::{DepthTarget, ResolvePass};
use crate::raycast::{RayEffects, RayOutputs, Shading};
use crate::rbf::RbfPass;
use crate::silhouette::SilhouettePass;
use crate::terrain::Crater;
use crate::{util, Error, GpuTerrain, Method, NormalPass, RayCastPass};
use relief_core::rbf::{
    adaptive_grid_bound, build_adaptive_grid, fit_cascades, AdaptiveGrid, CascadeOptions, Cascades,
    Cell, GridExtent, GridOptions, InfluenceSets, Rbf, RbfOptions,
};
use relief_core::{Camera, NormalMethod, Terrain};
use std::time::Instant;

/// An effect a scene can name.
///
/// ```
/// use relief_wgpu::Effect;
/// assert_eq!(Effect::parse("fog"), Some(Effect::Fog));
/// assert_eq!(Effect::DepthOutput.name(), "depth");
/// assert_eq!(Effect::ALL.len(), 8);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Effect {
    /// Directional (sun) diffuse lighting from a Sobel normal map.
    Lighting,
    /// Shadow rays against the heightfield towards the sun.
    Shadows,
    /// A tiled detail map (colour; composed into the normal map when lit).
    Detail,
    /// Craters applied on the GPU every frame, with the pyramid rebuilt.
    Deformations,
    /// Distance fog.
    Fog,
    /// A water plane, or a water heightfield ([`Scene::with_water_surface`]).
    Water,
    /// A reversed-Z depth buffer (and colour target) for compositing with meshes.
    DepthOutput,
    /// Each pixel's world normal in the ray caster's outputs ([`Renderer::outputs`],
    /// [`RayOutputs::read_normals`]), e.g. for deferred shading: 16 bytes a pixel written per
    /// frame, and allocated only with this effect.
    NormalOutput,
}

impl Effect {
    /// Every effect, in order.
    pub const ALL: [Effect; 8] = [
        Effect::Lighting,
        Effect::Shadows,
        Effect::Detail,
        Effect::Deformations,
        Effect::Fog,
        Effect::Water,
        Effect::DepthOutput,
        Effect::NormalOutput,
    ];

    /// The effect's name on the command line.
    ///
    /// ```
    /// assert_eq!(relief_wgpu::Effect::Deformations.name(), "deformations");
    /// ```
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Effect::Lighting => "lighting",
            Effect::Shadows => "shadows",
            Effect::Detail => "detail",
            Effect::Deformations => "deformations",
            Effect::Fog => "fog",
            Effect::Water => "water",
            Effect::DepthOutput => "depth",
            Effect::NormalOutput => "normals",
        }
    }

    /// The effect of a name ([`Effect::name`]); `None` for an unknown one.
    ///
    /// ```
    /// assert_eq!(relief_wgpu::Effect::parse("craters"), None);
    /// ```
    #[must_use]
    pub fn parse(name: &str) -> Option<Effect> {
        Effect::ALL.into_iter().find(|e| e.name() == name)
    }
}

/// A pass a frame can dispatch.
///
/// ```
/// assert_eq!(relief_wgpu::PassName::RayCast.as_str(), "raycast");
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PassName {
    /// Craters applied to the working heights ([`GpuTerrain::encode_deform`]).
    Deform,
    /// The maximum-mipmap build ([`GpuTerrain::encode_maxmip`]).
    MaxMipBuild,
    /// The normal map ([`NormalPass`]).
    NormalMap,
    /// The ray caster ([`RayCastPass`]).
    RayCast,
    /// Depth output ([`ResolvePass`]).
    DepthResolve,
    /// Silhouette partitioning: the silhouette map ([`SilhouettePass::encode_map`]).
    SilhouetteMap,
    /// Silhouette partitioning: the packed tree ([`SilhouettePass::encode_tree`]).
    SilhouetteTree,
    /// Silhouette partitioning: the fixed-cost trace ([`SilhouettePass::encode_trace`]).
    SilhouetteTrace,
    /// Cascade ray cast: the three cascades discretized
    /// ([`CascadeRayCast::encode_discretize`]).
    RbfDiscretize,
    /// Cascade ray cast: a maximum mipmap per cascade ([`CascadeRayCast::encode_maxmip`]).
    CascadeMaxMip,
    /// Cascade ray cast: a ray cast per cascade ([`CascadeRayCast::encode_rays`]).
    CascadeRayCast,
    /// Cascade ray cast: overlap hits blended, weights computed on the GPU
    /// ([`CascadeRayCast::encode_blend`]).
    CascadeBlend,
}

impl PassName {
    /// Its name in `relief render --json`.
    ///
    /// ```
    /// assert_eq!(relief_wgpu::PassName::DepthResolve.as_str(), "depth_resolve");
    /// ```
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            PassName::Deform => "deform",
            PassName::MaxMipBuild => "maxmip_build",
            PassName::NormalMap => "normal_map",
            PassName::RayCast => "raycast",
            PassName::DepthResolve => "depth_resolve",
            PassName::SilhouetteMap => "silhouette_map",
            PassName::SilhouetteTree => "silhouette_tree",
            PassName::SilhouetteTrace => "silhouette_trace",
            PassName::RbfDiscretize => "rbf_discretize",
            PassName::CascadeMaxMip => "cascade_maxmip",
            PassName::CascadeRayCast => "cascade_raycast",
            PassName::CascadeBlend => "cascade_blend",
        }
    }
}

/// What to render: the method, the effects and their parameters.
///
/// Defaults ([`Scene::new`]): [`Method::MaxMip`], no effects, [`Shading::default`], no craters,
/// a procedural 64 x 64 detail map (used only with [`Effect::Detail`]).
///
/// ```
/// use relief_wgpu::{Effect, PassName, Scene};
/// let s = Scene::new().with_effect(Effect::Fog);
/// assert!(s.has(Effect::Fog) && !s.has(Effect::Lighting));
/// assert_eq!(s.setup_passes(), vec![PassName::MaxMipBuild]);
/// assert_eq!(s.frame_passes(), vec![PassName::RayCast]); // fog is a shader variant only
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    effects: Vec<Effect>,
    method: Method,
    shading: Shading,
    craters: Vec<Crater>,
    detail: Option<(Vec<f32>, u32, u32)>,
    water_surface: Option<Vec<f32>>,
    rbf_grid: Option<GridOptions>,
}

impl Default for Scene {
    fn default() -> Self {
        Scene::new()
    }
}

impl Scene {
    /// The bare scene: max-mip ray casting, no effects.
    #[must_use]
    pub fn new() -> Scene {
        Scene {
            effects: Vec::new(),
            method: Method::MaxMip,
            shading: Shading::default(),
            craters: Vec::new(),
            detail: None,
            water_surface: None,
            rbf_grid: None,
        }
    }

    /// Sets the adaptive grid of [`Method::Cascades`]' RBF approximation of the terrain
    /// (default: cells of 1 to 64 samples, `max_error` 1 % of the terrain's height range).
    ///
    /// ```
    /// use relief_core::rbf::GridOptions;
    /// let s = relief_wgpu::Scene::new().with_rbf_grid(GridOptions::default().with_max_error(2.0));
    /// assert_eq!(s.rbf_grid().map(|g| g.max_error), Some(2.0));
    /// ```
    #[must_use]
    pub fn with_rbf_grid(mut self, g: GridOptions) -> Scene {
        self.rbf_grid = Some(g);
        self
    }

    /// The adaptive grid options set with [`Scene::with_rbf_grid`].
    #[must_use]
    pub fn rbf_grid(&self) -> Option<&GridOptions> {
        self.rbf_grid.as_ref()
    }

    /// Whether the method can render the named effects: silhouette partitioning and the
    /// cascade ray cast take only [`Effect::DepthOutput`]; [`Error::Unsupported`] otherwise.
    ///
    /// ```
    /// use relief_wgpu::{Effect, Method, Scene};
    /// assert!(Scene::new().with_method(Method::Silhouette).with_effect(Effect::DepthOutput).check().is_ok());
    /// assert!(Scene::new().with_method(Method::cascades()).with_effect(Effect::Fog).check().is_err());
    /// ```
    pub fn check(&self) -> Result<(), Error> {
        let exotic = matches!(self.method, Method::Silhouette | Method::Cascades { .. });
        if exotic && self.effects.iter().any(|&e| e != Effect::DepthOutput) {
            return Err(Error::Unsupported(
                "silhouette partitioning and the cascade ray cast take only the depth output effect",
            ));
        }
        Ok(())
    }

    /// Adds an effect (once).
    #[must_use]
    pub fn with_effect(mut self, e: Effect) -> Scene {
        if !self.effects.contains(&e) {
            self.effects.push(e);
            self.effects.sort();
        }
        self
    }

    /// Adds several effects.
    ///
    /// ```
    /// use relief_wgpu::{Effect, Scene};
    /// let s = Scene::new().with_effects(&[Effect::Water, Effect::Fog, Effect::Water]);
    /// assert_eq!(s.effects(), &[Effect::Fog, Effect::Water]);
    /// ```
    #[must_use]
    pub fn with_effects(self, es: &[Effect]) -> Scene {
        es.iter().fold(self, |s, &e| s.with_effect(e))
    }

    /// Sets the ray casting method (default [`Method::MaxMip`]).
    #[must_use]
    pub fn with_method(mut self, m: Method) -> Scene {
        self.method = m;
        self
    }

    /// Sets the shading parameters (default [`Shading::default`]).
    #[must_use]
    pub fn with_shading(mut self, s: Shading) -> Scene {
        self.shading = s;
        self
    }

    /// Sets the craters of [`Effect::Deformations`] (default none).
    #[must_use]
    pub fn with_craters(mut self, c: &[Crater]) -> Scene {
        self.craters = c.to_vec();
        self
    }

    /// Sets the tiled detail map of [`Effect::Detail`] (`samples` local heights, row-major,
    /// `width x height`; default a procedural 64 x 64 map).
    #[must_use]
    pub fn with_detail_map(mut self, samples: Vec<f32>, width: u32, height: u32) -> Scene {
        self.detail = Some((samples, width, height));
        self
    }

    /// Sets the water surface of [`Effect::Water`]: one world height per terrain sample
    /// (row-major), for example the RBF approximation of a flood simulation's water levels
    /// (seed 002; `relief rbf --out` writes one). Default: a plane at
    /// [`Shading::water_level`].
    #[must_use]
    pub fn with_water_surface(mut self, heights: Vec<f32>) -> Scene {
        self.water_surface = Some(heights);
        self
    }

    /// The effects named, sorted.
    #[must_use]
    pub fn effects(&self) -> &[Effect] {
        &self.effects
    }

    /// Whether `e` is named.
    #[must_use]
    pub fn has(&self, e: Effect) -> bool {
        self.effects.contains(&e)
    }

    /// The method.
    #[must_use]
    pub fn method(&self) -> Method {
        self.method
    }

    /// The shading parameters.
    #[must_use]
    pub fn shading(&self) -> &Shading {
        &self.shading
    }

    fn needs_mip(&self) -> bool {
        self.method == Method::MaxMip
    }

    /// The ray caster's shader variant for this scene.
    ///
    /// ```
    /// use relief_wgpu::{Effect, Scene};
    /// let v = Scene::new().with_effect(Effect::Shadows).ray_effects();
    /// assert!(v.shadows && !v.lighting && !v.fog);
    /// ```
    #[must_use]
    pub fn ray_effects(&self) -> RayEffects {
        RayEffects {
            lighting: self.has(Effect::Lighting),
            shadows: self.has(Effect::Shadows),
            detail: self.has(Effect::Detail),
            fog: self.has(Effect::Fog),
            water: self.has(Effect::Water),
            water_surface: self.water_surface.is_some(),
            normals: self.has(Effect::NormalOutput),
        }
    }

    /// Passes dispatched once, by the first frame, before [`Scene::frame_passes`]: the pyramid
    /// (max-mip only) and the normal map (lighting only), unless deformations make them
    /// per-frame passes.
    ///
    /// ```
    /// use relief_wgpu::{Effect, Method, PassName, Scene};
    /// assert_eq!(Scene::new().with_method(Method::march()).setup_passes(), vec![]);
    /// assert_eq!(
    ///     Scene::new().with_effect(Effect::Lighting).setup_passes(),
    ///     vec![PassName::MaxMipBuild, PassName::NormalMap]
    /// );
    /// ```
    #[must_use]
    pub fn setup_passes(&self) -> Vec<PassName> {
        if self.has(Effect::Deformations)
            || matches!(self.method, Method::Silhouette | Method::Cascades { .. })
        {
            return Vec::new();
        }
        self.terrain_passes()
    }

    fn terrain_passes(&self) -> Vec<PassName> {
        let mut v = Vec::new();
        if self.needs_mip() {
            v.push(PassName::MaxMipBuild);
        }
        if self.has(Effect::Lighting) {
            v.push(PassName::NormalMap);
        }
        v
    }

    /// The exact passes every frame dispatches, in order.
    ///
    /// ```
    /// use relief_wgpu::{Effect, Method, PassName, Scene};
    /// let s = Scene::new().with_effects(&[Effect::Deformations, Effect::DepthOutput]);
    /// assert_eq!(
    ///     s.frame_passes(),
    ///     vec![PassName::Deform, PassName::MaxMipBuild, PassName::RayCast, PassName::DepthResolve]
    /// );
    /// assert_eq!(
    ///     Scene::new().with_method(Method::Silhouette).frame_passes(),
    ///     vec![PassName::SilhouetteMap, PassName::SilhouetteTree, PassName::SilhouetteTrace]
    /// );
    /// ```
    #[must_use]
    pub fn frame_passes(&self) -> Vec<PassName> {
        let mut v = Vec::new();
        match self.method {
            Method::Silhouette => v.extend([
                PassName::SilhouetteMap,
                PassName::SilhouetteTree,
                PassName::SilhouetteTrace,
            ]),
            Method::Cascades { .. } => v.extend([
                PassName::RbfDiscretize,
                PassName::CascadeMaxMip,
                PassName::CascadeRayCast,
                PassName::CascadeBlend,
            ]),
            Method::MaxMip | Method::March { .. } => {
                if self.has(Effect::Deformations) {
                    v.push(PassName::Deform);
                    v.extend(self.terrain_passes());
                }
                v.push(PassName::RayCast);
            }
        }
        if self.has(Effect::DepthOutput) {
            v.push(PassName::DepthResolve);
        }
        v
    }
}

/// A procedural tileable detail map: `n x n` local heights in `[-amp, amp]` (sums of sines with
/// whole periods, so it tiles).
///
/// ```
/// let d = relief_wgpu::scene::procedural_detail(64, 2.0);
/// assert_eq!(d.len(), 64 * 64);
/// assert!(d.iter().all(|v| v.abs() <= 2.0));
/// ```
#[must_use]
pub fn procedural_detail(n: u32, amp: f32) -> Vec<f32> {
    let tau = std::f32::consts::TAU;
    let mut v = Vec::with_capacity(n as usize * n as usize);
    for y in 0..n {
        for x in 0..n {
            let (u, w) = (x as f32 / n as f32, y as f32 / n as f32);
            let s = (tau * 3.0 * u).sin() * 0.4
                + (tau * (5.0 * w + 2.0 * u)).sin() * 0.35
                + (tau * (7.0 * u - 4.0 * w)).cos() * 0.25;
            v.push(amp * s);
        }
    }
    v
}

/// Where pass times come from.
///
/// ```
/// assert_eq!(relief_wgpu::scene::Clock::Gpu.as_str(), "gpu");
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Clock {
    /// GPU timestamp queries written between the passes of one submission.
    Gpu,
    /// The wall clock around one submission per pass, each waited for (the adapter lacks
    /// timestamp queries).
    Wall,
}

impl Clock {
    /// Its name in `relief render --json` (`"gpu"` or `"wall"`).
    ///
    /// ```
    /// assert_eq!(relief_wgpu::scene::Clock::Wall.as_str(), "wall");
    /// ```
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Clock::Gpu => "gpu",
            Clock::Wall => "wall",
        }
    }
}

/// The time one pass took in [`Renderer::render_profiled`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PassTiming {
    /// The pass.
    pub pass: PassName,
    /// Milliseconds: between the GPU timestamps before and after the pass, or wall-clock from
    /// submission until the GPU finished it ([`PassTiming::clock`]).
    pub ms: f64,
    /// Where the time comes from.
    pub clock: Clock,
    /// Milliseconds the CPU spent recording the pass: its queue writes, its CPU-side work
    /// (for example the cascades' parameters) and the command recording, wall-clock, without
    /// waiting for the GPU. The frame's preparation before the first pass (fitting the
    /// cascades) is not included.
    pub cpu_ms: f64,
}

/// A frame read back to the CPU.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Distance along each unit ray, `+inf` for a miss (CONVENTIONS.md depth image).
    pub depth: Vec<f32>,
    /// RGBA8 colour.
    pub color: Vec<[u8; 4]>,
}

/// The pass that finds the surface, by method.
#[derive(Debug)]
enum Caster {
    Rays(RayCastPass),
    Silhouette(SilhouettePass),
    Cascades(CascadeRayCast),
}

impl Caster {
    fn outputs(&self) -> &RayOutputs {
        match self {
            Caster::Rays(r) => r.outputs(),
            Caster::Silhouette(s) => s.outputs(),
            Caster::Cascades(c) => c.outputs(),
        }
    }
}

/// [`Method::Cascades`]: the RBF approximation on the GPU and what fitting the cascades needs.
#[derive(Debug)]
struct CascadeSource {
    rbf: RbfPass,
    /// The adaptive grid's size and smallest cell (all that fitting needs: the grid itself is
    /// validated once, at setup, not every frame).
    extent: GridExtent,
    options: CascadeOptions,
    /// World height range of the approximation.
    z_range: (f32, f32),
    /// This frame's cascades (fitted by `prepare`).
    current: Option<Cascades>,
}

/// GPU timestamps around every pass of a frame.
#[derive(Debug)]
struct Timestamps {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    staging: wgpu::Buffer,
    count: u32,
}

const MAX_TIMESTAMPS: u32 = 32;

/// Renders a terrain as its [`Scene`] says, on the caller's device.
///
/// ```no_run
/// use relief_core::{Camera, Heightfield};
/// use relief_wgpu::{Effect, PassName, Renderer, Scene};
/// use glam::Vec3;
/// let gpu = relief_wgpu::headless()?;
/// let s: Vec<f32> = (0..32 * 32).map(|i| (i % 7) as f32).collect();
/// let hf = Heightfield::new(&s, 32, 32)?;
/// let mut r = Renderer::new(&gpu.device, &gpu.queue, &hf, Scene::new().with_effect(Effect::Shadows))?;
/// let cam = Camera::new(Vec3::new(-5.0, -5.0, 20.0), Vec3::new(16.0, 16.0, 0.0), 50.0, 64, 48)?;
/// let frame = r.render(&gpu.device, &gpu.queue, &cam)?;
/// assert_eq!(r.last_passes(), &[PassName::MaxMipBuild, PassName::RayCast]);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug)]
pub struct Renderer {
    scene: Scene,
    terrain: GpuTerrain,
    normals: Option<NormalPass>,
    detail: Option<(wgpu::Buffer, u32, u32)>,
    water: Option<wgpu::Buffer>,
    caster: Option<Caster>,
    cascades: Option<CascadeSource>,
    resolve: Option<ResolvePass>,
    target: Option<DepthTarget>,
    timestamps: Option<Timestamps>,
    setup_done: bool,
    last: Vec<PassName>,
}

/// Near plane of the depth output (world units).
pub const NEAR: f32 = 1.0;

impl Renderer {
    /// Uploads `terrain` and creates the passes `scene` needs (pipelines specialised for its
    /// effects). Nothing is dispatched until the first frame. For [`Method::Cascades`] this
    /// builds the terrain's RBF approximation on the CPU (adaptive grid, influence sets;
    /// [`Scene::with_rbf_grid`]) and uploads it. [`Error::Unsupported`] for effects the
    /// method does not take ([`Scene::check`]).
    pub fn new<T: Terrain>(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        terrain: &T,
        scene: Scene,
    ) -> Result<Renderer, Error> {
        scene.check()?;
        let dynamic = scene.has(Effect::Deformations);
        // The pyramid only for the method that traces with it (march and silhouette read the
        // heights; the cascades build their own).
        let mut gt = if scene.needs_mip() {
            GpuTerrain::new(device, queue, terrain, dynamic)?
        } else {
            GpuTerrain::without_maxmip(device, queue, terrain, dynamic)?
        };
        if dynamic {
            gt.set_craters(queue, &scene.craters)?;
        }
        let detail_map = scene.has(Effect::Detail).then(|| {
            scene.detail.clone().unwrap_or_else(|| {
                let (lo, hi) = gt.base_range();
                (procedural_detail(64, 0.01 * (hi - lo).max(1.0)), 64, 64)
            })
        });
        let normals = if scene.has(Effect::Lighting) {
            let d = detail_map.as_ref().map(|(s, w, h)| (s.as_slice(), *w, *h));
            Some(NormalPass::new(device, queue, &gt, NormalMethod::Sobel, d)?)
        } else {
            None
        };
        let water = match (&scene.water_surface, scene.has(Effect::Water)) {
            (Some(ws), true) => {
                let (w, h) = gt.size();
                if ws.len() != w as usize * h as usize {
                    return Err(Error::Unsupported(
                        "water surface size differs from the terrain's",
                    ));
                }
                let z0 = gt.scale().z_offset;
                let local: Vec<f32> = ws.iter().map(|z| z - z0).collect();
                Some(util::storage_init(
                    device,
                    "relief water surface",
                    bytemuck::cast_slice(&local),
                )?)
            }
            _ => None,
        };
        let detail = detail_map
            .map(|(s, w, h)| {
                util::storage_init(device, "relief detail", bytemuck::cast_slice(&s))
                    .map(|b| (b, w, h))
            })
            .transpose()?;
        let cascades = match scene.method {
            Method::Cascades { resolution } => Some(Self::approximate(
                device,
                terrain,
                &gt,
                scene.rbf_grid.as_ref(),
                resolution,
            )?),
            _ => None,
        };
        let features = device.features();
        let timestamps = features
            .contains(
                wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS,
            )
            .then(|| Timestamps {
                set: device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("relief pass timestamps"),
                    ty: wgpu::QueryType::Timestamp,
                    count: MAX_TIMESTAMPS,
                }),
                resolve: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("relief timestamps resolve"),
                    size: u64::from(MAX_TIMESTAMPS) * 8,
                    usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                }),
                staging: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("relief timestamps readback"),
                    size: u64::from(MAX_TIMESTAMPS) * 8,
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }),
                count: MAX_TIMESTAMPS,
            });
        Ok(Renderer {
            scene,
            terrain: gt,
            normals,
            detail,
            water,
            caster: None,
            cascades,
            resolve: None,
            target: None,
            timestamps,
            setup_done: false,
            last: Vec::new(),
        })
    }

    /// The RBF approximation of `terrain` (seed 002 sections 2-4) on the GPU.
    fn approximate<T: Terrain>(
        device: &wgpu::Device,
        terrain: &T,
        gt: &GpuTerrain,
        grid: Option<&GridOptions>,
        resolution: u32,
    ) -> Result<CascadeSource, Error> {
        let (w, h) = gt.size();
        let (lo, hi) = gt.base_range();
        let grid_opts = grid.copied().unwrap_or_else(|| {
            GridOptions::default()
                .with_max_error(0.01 * (hi - lo).max(1e-3))
                .with_cells(1, 64)
        });
        let bound = adaptive_grid_bound(w, h).ok_or(Error::Unsupported("grid too large"))?;
        let mut cells = vec![Cell::default(); bound];
        let n = build_adaptive_grid(terrain, &grid_opts, &mut cells)?;
        cells.truncate(n);
        let mut index = vec![0u32; bound];
        let ropts = RbfOptions::default();
        let (rbf, extent) = {
            let grid = AdaptiveGrid::new(w, h, &cells, &mut index)?;
            let mut offsets = vec![0u32; InfluenceSets::offsets_len(&grid)];
            let mut entries = vec![0u32; InfluenceSets::entries_len(&grid, &ropts)?];
            let sets = InfluenceSets::build(&grid, &ropts, &mut offsets, &mut entries)?;
            let rbf = Rbf::new(grid, sets, &ropts)?;
            (RbfPass::new(device, &rbf, &sets)?, GridExtent::from(&grid))
        };
        let z0 = gt.scale().z_offset;
        Ok(CascadeSource {
            rbf,
            extent,
            options: CascadeOptions::default().with_resolution(resolution),
            z_range: (lo + z0, hi + z0),
            current: None,
        })
    }

    /// The scene.
    #[must_use]
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The terrain on the GPU.
    #[must_use]
    pub fn terrain(&self) -> &GpuTerrain {
        &self.terrain
    }

    /// The passes the last frame recorded, in order (setup passes included on the first frame).
    #[must_use]
    pub fn last_passes(&self) -> &[PassName] {
        &self.last
    }

    /// The depth target of [`Effect::DepthOutput`] (after the first frame), for drawing meshes
    /// over the terrain with [`crate::MeshPass`] (`clear = false`).
    #[must_use]
    pub fn depth_target(&self) -> Option<&DepthTarget> {
        self.target.as_ref()
    }

    /// The ray caster of [`Method::MaxMip`] and [`Method::March`] (after the first frame).
    #[must_use]
    pub fn ray_pass(&self) -> Option<&RayCastPass> {
        match &self.caster {
            Some(Caster::Rays(r)) => Some(r),
            _ => None,
        }
    }

    /// The silhouette passes of [`Method::Silhouette`] (after the first frame).
    #[must_use]
    pub fn silhouette_pass(&self) -> Option<&SilhouettePass> {
        match &self.caster {
            Some(Caster::Silhouette(s)) => Some(s),
            _ => None,
        }
    }

    /// The cascade ray cast of [`Method::Cascades`] (after the first frame).
    #[must_use]
    pub fn cascade_pass(&self) -> Option<&CascadeRayCast> {
        match &self.caster {
            Some(Caster::Cascades(c)) => Some(c),
            _ => None,
        }
    }

    /// The cascades of the last frame ([`Method::Cascades`]).
    #[must_use]
    pub fn cascades(&self) -> Option<&Cascades> {
        self.cascades.as_ref().and_then(|c| c.current.as_ref())
    }

    /// The frame's output buffers, whatever the method (after the first frame).
    #[must_use]
    pub fn outputs(&self) -> Option<&RayOutputs> {
        self.caster.as_ref().map(Caster::outputs)
    }

    /// Where [`Renderer::render_profiled`]'s times come from on this device.
    #[must_use]
    pub fn clock(&self) -> Clock {
        if self.timestamps.is_some() {
            Clock::Gpu
        } else {
            Clock::Wall
        }
    }

    /// Times passes with the wall clock even when the device has timestamp queries (for
    /// comparing the two).
    pub fn use_wall_clock(&mut self) {
        self.timestamps = None;
    }

    fn prepare(&mut self, device: &wgpu::Device, camera: &Camera) -> Result<(), Error> {
        let size = (camera.width, camera.height);
        let stale = self.caster.as_ref().is_none_or(|c| {
            let o = c.outputs();
            (o.width, o.height) != size
        });
        if stale {
            let caster = match self.scene.method {
                Method::Silhouette => {
                    Caster::Silhouette(SilhouettePass::new(device, &self.terrain, size.0, size.1)?)
                }
                Method::Cascades { resolution } => {
                    let Some(src) = &self.cascades else {
                        return Err(Error::Unsupported("cascades without an RBF approximation"));
                    };
                    let (lo, hi) = self.terrain.base_range();
                    Caster::Cascades(CascadeRayCast::new(
                        device,
                        &src.rbf,
                        resolution,
                        self.terrain.scale(),
                        (lo, hi),
                        size.0,
                        size.1,
                    )?)
                }
                Method::MaxMip | Method::March { .. } => Caster::Rays(RayCastPass::new_with_water(
                    device,
                    &self.terrain,
                    self.normals.as_ref().map(|n| n.buffer()),
                    self.detail.as_ref().map(|(b, w, h)| (b, *w, *h)),
                    self.water.as_ref(),
                    self.scene.method,
                    self.scene.ray_effects(),
                    size.0,
                    size.1,
                )?),
            };
            if self.scene.has(Effect::DepthOutput) {
                let target = DepthTarget::new(device, size.0, size.1)?;
                self.resolve = Some(ResolvePass::new(device, caster.outputs(), NEAR));
                self.target = Some(target);
            }
            self.caster = Some(caster);
        }
        if let Some(src) = &mut self.cascades {
            let fit = fit_cascades(
                camera,
                src.extent,
                &self.terrain.scale(),
                src.z_range,
                &src.options,
                src.current.as_ref(),
            )?;
            src.current = Some(fit);
        }
        Ok(())
    }

    /// [`Self::encode_pass`] and the milliseconds the CPU spent in it ([`PassTiming::cpu_ms`]).
    fn encode_pass_timed(
        &self,
        pass: PassName,
        queue: &wgpu::Queue,
        enc: &mut wgpu::CommandEncoder,
        camera: &Camera,
    ) -> Result<f64, Error> {
        let start = Instant::now();
        self.encode_pass(pass, queue, enc, camera)?;
        Ok(start.elapsed().as_secs_f64() * 1e3)
    }

    fn encode_pass(
        &self,
        pass: PassName,
        queue: &wgpu::Queue,
        enc: &mut wgpu::CommandEncoder,
        camera: &Camera,
    ) -> Result<(), Error> {
        let fitted = self
            .cascades
            .as_ref()
            .and_then(|c| c.current.as_ref().map(|f| (&c.rbf, f)));
        match (pass, &self.caster) {
            (PassName::Deform, _) => self.terrain.encode_deform(enc),
            (PassName::MaxMipBuild, _) => self.terrain.encode_maxmip(enc),
            (PassName::NormalMap, _) => {
                if let Some(n) = &self.normals {
                    n.encode(enc);
                }
            }
            (PassName::RayCast, Some(Caster::Rays(r))) => {
                r.encode(queue, enc, &self.terrain, camera, &self.scene.shading)?;
            }
            (PassName::SilhouetteMap, Some(Caster::Silhouette(s))) => {
                s.write_params(queue, &self.terrain, camera)?;
                s.encode_map(enc);
            }
            (PassName::SilhouetteTree, Some(Caster::Silhouette(s))) => s.encode_tree(enc),
            (PassName::SilhouetteTrace, Some(Caster::Silhouette(s))) => s.encode_trace(enc),
            (PassName::RbfDiscretize, Some(Caster::Cascades(c))) => {
                if let Some((rbf, fit)) = fitted {
                    c.encode_discretize(queue, enc, rbf, fit)?;
                }
            }
            (PassName::CascadeMaxMip, Some(Caster::Cascades(c))) => c.encode_maxmip(enc),
            (PassName::CascadeRayCast, Some(Caster::Cascades(c))) => {
                if let Some((_, fit)) = fitted {
                    c.encode_rays(queue, enc, fit, camera)?;
                }
            }
            (PassName::CascadeBlend, Some(Caster::Cascades(c))) => {
                if let Some((_, fit)) = fitted {
                    c.encode_blend(queue, enc, fit, camera)?;
                }
            }
            (PassName::DepthResolve, _) => {
                if let (Some(r), Some(t)) = (&self.resolve, &self.target) {
                    r.encode(queue, enc, t, camera)?;
                }
            }
            _ => return Err(Error::Unsupported("pass does not belong to this method")),
        }
        Ok(())
    }

    fn plan(&self) -> Vec<PassName> {
        let mut v = if self.setup_done {
            Vec::new()
        } else {
            self.scene.setup_passes()
        };
        v.extend(self.scene.frame_passes());
        v
    }

    /// Records one frame into `encoder` (setup passes too on the first frame) and returns the
    /// passes recorded. Only queue writes and recording: nothing waits for the GPU, so an
    /// application submits this with its own work.
    pub fn encode_frame(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        camera: &Camera,
    ) -> Result<Vec<PassName>, Error> {
        self.prepare(device, camera)?;
        let plan = self.plan();
        for &p in &plan {
            self.encode_pass(p, queue, encoder, camera)?;
        }
        self.setup_done = true;
        self.last.clone_from(&plan);
        Ok(plan)
    }

    /// Renders one frame (one submission) and reads depth and colour back.
    pub fn render(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        camera: &Camera,
    ) -> Result<FrameImage, Error> {
        let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("relief frame"),
        });
        self.encode_frame(device, queue, &mut enc, camera)?;
        queue.submit([enc.finish()]);
        self.read_frame(device, queue)
    }

    /// Renders one frame and returns each pass's time ([`Renderer::clock`]): with GPU
    /// timestamps the frame is one submission with a timestamp written between passes (no CPU
    /// round trip inside the frame; the timestamps are read back with the image); without them
    /// each pass is submitted and waited for separately, which makes the frame slower than
    /// [`Renderer::render`].
    pub fn render_profiled(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        camera: &Camera,
    ) -> Result<(FrameImage, Vec<PassTiming>), Error> {
        self.prepare(device, camera)?;
        let plan = self.plan();
        let times = match &self.timestamps {
            Some(ts) if plan.len() < ts.count as usize => {
                let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("relief frame (timed)"),
                });
                enc.write_timestamp(&ts.set, 0);
                let mut cpu = Vec::with_capacity(plan.len());
                for (k, &p) in plan.iter().enumerate() {
                    cpu.push(self.encode_pass_timed(p, queue, &mut enc, camera)?);
                    enc.write_timestamp(&ts.set, k as u32 + 1);
                }
                let n = plan.len() as u32 + 1;
                enc.resolve_query_set(&ts.set, 0..n, &ts.resolve, 0);
                enc.copy_buffer_to_buffer(&ts.resolve, 0, &ts.staging, 0, u64::from(n) * 8);
                queue.submit([enc.finish()]);
                let bytes = util::map_and_read(device, &ts.staging, u64::from(n) * 8)?;
                let ticks: Vec<u64> = bytes
                    .chunks_exact(8)
                    .map(|c| u64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]))
                    .collect();
                let period = f64::from(queue.get_timestamp_period());
                plan.iter()
                    .zip(ticks.windows(2))
                    .zip(cpu)
                    .map(|((&pass, t), cpu_ms)| PassTiming {
                        pass,
                        ms: t[1].saturating_sub(t[0]) as f64 * period * 1e-6,
                        clock: Clock::Gpu,
                        cpu_ms,
                    })
                    .collect()
            }
            _ => {
                // Drain earlier work so it is not charged to the first pass.
                device
                    .poll(wgpu::PollType::wait_indefinitely())
                    .map_err(|e| Error::Readback(e.to_string()))?;
                let mut times = Vec::with_capacity(plan.len());
                for &p in &plan {
                    let start = Instant::now();
                    let mut enc = device.create_command_encoder(&Default::default());
                    let cpu_ms = self.encode_pass_timed(p, queue, &mut enc, camera)?;
                    queue.submit([enc.finish()]);
                    device
                        .poll(wgpu::PollType::wait_indefinitely())
                        .map_err(|e| Error::Readback(e.to_string()))?;
                    times.push(PassTiming {
                        pass: p,
                        ms: start.elapsed().as_secs_f64() * 1e3,
                        clock: Clock::Wall,
                        cpu_ms,
                    });
                }
                times
            }
        };
        self.setup_done = true;
        self.last.clone_from(&plan);
        Ok((self.read_frame(device, queue)?, times))
    }

    /// Reads the last frame's depth and colour back (waits for the GPU).
    pub fn read_frame(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> Result<FrameImage, Error> {
        let Some(c) = &self.caster else {
            return Err(Error::Unsupported("no frame rendered yet"));
        };
        let o = c.outputs();
        Ok(FrameImage {
            width: o.width,
            height: o.height,
            depth: o.read_depth(device, queue)?,
            color: o.read_color(device, queue)?,
        })
    }
}
