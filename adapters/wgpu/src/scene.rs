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

use crate::mesh::{DepthTarget, ResolvePass};
use crate::raycast::{RayEffects, Shading};
use crate::terrain::Crater;
use crate::{util, Error, GpuTerrain, Method, NormalPass, RayCastPass};
use relief_core::{Camera, NormalMethod, Terrain};
use std::time::Instant;

/// An effect a scene can name.
///
/// ```
/// use relief_wgpu::Effect;
/// assert_eq!(Effect::parse("fog"), Some(Effect::Fog));
/// assert_eq!(Effect::DepthOutput.name(), "depth");
/// assert_eq!(Effect::ALL.len(), 7);
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
}

impl Effect {
    /// Every effect, in order.
    pub const ALL: [Effect; 7] = [
        Effect::Lighting,
        Effect::Shadows,
        Effect::Detail,
        Effect::Deformations,
        Effect::Fog,
        Effect::Water,
        Effect::DepthOutput,
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
        }
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
        if self.has(Effect::Deformations) {
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
    /// use relief_wgpu::{Effect, PassName, Scene};
    /// let s = Scene::new().with_effects(&[Effect::Deformations, Effect::DepthOutput]);
    /// assert_eq!(
    ///     s.frame_passes(),
    ///     vec![PassName::Deform, PassName::MaxMipBuild, PassName::RayCast, PassName::DepthResolve]
    /// );
    /// ```
    #[must_use]
    pub fn frame_passes(&self) -> Vec<PassName> {
        let mut v = Vec::new();
        if self.has(Effect::Deformations) {
            v.push(PassName::Deform);
            v.extend(self.terrain_passes());
        }
        v.push(PassName::RayCast);
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

/// The time one pass took in [`Renderer::render_profiled`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PassTiming {
    /// The pass.
    pub pass: PassName,
    /// Wall-clock milliseconds from submission until the GPU finished it.
    pub ms: f64,
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
    rays: Option<RayCastPass>,
    resolve: Option<ResolvePass>,
    target: Option<DepthTarget>,
    setup_done: bool,
    last: Vec<PassName>,
}

/// Near plane of the depth output (world units).
pub const NEAR: f32 = 1.0;

impl Renderer {
    /// Uploads `terrain` and creates the passes `scene` needs (pipelines specialised for its
    /// effects). Nothing is dispatched until the first frame.
    pub fn new<T: Terrain>(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        terrain: &T,
        scene: Scene,
    ) -> Result<Renderer, Error> {
        let dynamic = scene.has(Effect::Deformations);
        let mut gt = GpuTerrain::new(device, queue, terrain, dynamic)?;
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
                ))
            }
            _ => None,
        };
        let detail = detail_map.map(|(s, w, h)| {
            (
                util::storage_init(device, "relief detail", bytemuck::cast_slice(&s)),
                w,
                h,
            )
        });
        Ok(Renderer {
            scene,
            terrain: gt,
            normals,
            detail,
            water,
            rays: None,
            resolve: None,
            target: None,
            setup_done: false,
            last: Vec::new(),
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

    /// The ray caster (after the first frame).
    #[must_use]
    pub fn ray_pass(&self) -> Option<&RayCastPass> {
        self.rays.as_ref()
    }

    fn prepare(&mut self, device: &wgpu::Device, camera: &Camera) -> Result<(), Error> {
        let size = (camera.width, camera.height);
        let stale = self
            .rays
            .as_ref()
            .is_none_or(|r| (r.outputs().width, r.outputs().height) != size);
        if stale {
            let rays = RayCastPass::new_with_water(
                device,
                &self.terrain,
                self.normals.as_ref().map(|n| n.buffer()),
                self.detail.as_ref().map(|(b, w, h)| (b, *w, *h)),
                self.water.as_ref(),
                self.scene.method,
                self.scene.ray_effects(),
                size.0,
                size.1,
            )?;
            if self.scene.has(Effect::DepthOutput) {
                self.resolve = Some(ResolvePass::new(device, rays.outputs(), NEAR));
                self.target = Some(DepthTarget::new(device, size.0, size.1));
            }
            self.rays = Some(rays);
        }
        Ok(())
    }

    fn encode_pass(
        &self,
        pass: PassName,
        queue: &wgpu::Queue,
        enc: &mut wgpu::CommandEncoder,
        camera: &Camera,
    ) -> Result<(), Error> {
        match pass {
            PassName::Deform => self.terrain.encode_deform(enc),
            PassName::MaxMipBuild => self.terrain.encode_maxmip(enc),
            PassName::NormalMap => {
                if let Some(n) = &self.normals {
                    n.encode(enc);
                }
            }
            PassName::RayCast => {
                if let Some(r) = &self.rays {
                    r.encode(queue, enc, &self.terrain, camera, &self.scene.shading)?;
                }
            }
            PassName::DepthResolve => {
                if let (Some(r), Some(t)) = (&self.resolve, &self.target) {
                    r.encode(queue, enc, t, camera)?;
                }
            }
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

    /// Renders one frame submitting and waiting for each pass separately, and returns each
    /// pass's wall-clock time (for benchmarks and `relief render --json`; the waits make it
    /// slower than [`Renderer::render`]).
    pub fn render_profiled(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        camera: &Camera,
    ) -> Result<(FrameImage, Vec<PassTiming>), Error> {
        self.prepare(device, camera)?;
        // Drain earlier work so it is not charged to the first pass.
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| Error::Readback(e.to_string()))?;
        let plan = self.plan();
        let mut times = Vec::with_capacity(plan.len());
        for &p in &plan {
            let start = Instant::now();
            let mut enc = device.create_command_encoder(&Default::default());
            self.encode_pass(p, queue, &mut enc, camera)?;
            queue.submit([enc.finish()]);
            device
                .poll(wgpu::PollType::wait_indefinitely())
                .map_err(|e| Error::Readback(e.to_string()))?;
            times.push(PassTiming {
                pass: p,
                ms: start.elapsed().as_secs_f64() * 1e3,
            });
        }
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
        let Some(r) = &self.rays else {
            return Err(Error::Unsupported("no frame rendered yet"));
        };
        let o = r.outputs();
        Ok(FrameImage {
            width: o.width,
            height: o.height,
            depth: o.read_depth(device, queue)?,
            color: o.read_color(device, queue)?,
        })
    }
}
