//! `relief render`: render a DEM from a camera to a PNG (and optionally a depth image) on the
//! GPU (relief-wgpu: a `Scene` with max-mip or march ray casting, silhouette partitioning or the
//! RBF cascade ray cast, or SOAR refinement drawn by the mesh pass) or on the CPU (relief-core
//! tracing, rows in parallel), with the effects named by `--effects`. JSON lists the passes run
//! with their times and where the times come from (`timing`: `gpu` timestamp queries or `wall`
//! clock).

use crate::args::DemArgs;
use crate::{print_out, CliError, CliResult};
use clap::{Args, ValueEnum};
use rayon::prelude::*;
use relief_core::glam::Vec3;
use relief_core::ray::{MarchOptions, MaxMip, Ray, RayTracer};
use relief_core::refine::{preprocess_compact, scratch_len, Criterion, Refiner, View};
use relief_core::{normal_map, Camera, Composed, Heightfield, NormalMethod, Surface, Terrain};
use relief_wgpu::mesh::{depth_to_distance, MeshStyle};
use relief_wgpu::raycast::water_surface_hit;
use relief_wgpu::terrain::Crater;
use relief_wgpu::{DepthTarget, Effect, MeshPass, Renderer, Scene};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Where to render.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Backend {
    /// relief-wgpu on the first adapter wgpu finds (WGPU_BACKEND etc. apply).
    Gpu,
    /// relief-core on the CPU.
    Cpu,
}

/// Rendering method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum RenderMethod {
    /// Maximum-mipmap ray casting (exact).
    Maxmip,
    /// Linear + binary search ray marching (approximate).
    March,
    /// Silhouette partitioning (seed 000), GPU only, approximate, a fixed number of texel
    /// reads per pixel (`reads_per_pixel` in JSON); the terrain must be entirely in front of
    /// the camera.
    Silhouette,
    /// The RBF cascade ray cast (seed 002 section 5), GPU only: the DEM approximated by
    /// Gaussians on an adaptive grid, discretized into three cascades each frame.
    Cascades,
    /// View-dependent SOAR refinement drawn as triangles (GPU only).
    Mesh,
}

/// Options of `relief render`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    #[command(flatten)]
    dem: DemArgs,
    /// Eye position X,Y,Z in world units.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true, value_parser = crate::args::parse_vec3)]
    eye: Vec3,
    /// Point looked at X,Y,Z.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true, value_parser = crate::args::parse_vec3)]
    target: Vec3,
    /// Vertical field of view in degrees.
    #[arg(long, default_value_t = 60.0)]
    fov: f32,
    /// Image size WxH in pixels.
    #[arg(long, value_name = "WxH", value_parser = crate::args::parse_image_size)]
    size: (u32, u32),
    /// Where to render.
    #[arg(long, value_enum, default_value = "gpu")]
    backend: Backend,
    /// Rendering method.
    #[arg(long, value_enum, default_value = "maxmip")]
    method: RenderMethod,
    /// Comma-separated effects: lighting, shadows, detail, deformations, fog, water, depth,
    /// normals.
    #[arg(long, value_name = "LIST", default_value = "")]
    effects: String,
    /// Water surface for the `water` effect: little-endian f32, one world height per DEM
    /// sample, row-major (for example the RBF approximation `relief rbf --out` writes); default
    /// a plane.
    #[arg(long, value_name = "PATH")]
    water_surface: Option<PathBuf>,
    /// Texels per cascade side for `--method cascades`.
    #[arg(long, value_name = "N", default_value_t = 512)]
    cascade_resolution: u32,
    /// Largest deviation of a DEM sample from its adaptive-grid cell's mean height for
    /// `--method cascades` (world z units; default 1 % of the DEM's height range).
    #[arg(long, value_name = "E")]
    rbf_max_error: Option<f32>,
    /// Screen-space error in pixels for `--method mesh`.
    #[arg(long, value_name = "PX", default_value_t = 1.0)]
    pixel_error: f32,
    /// Testing aid for `--method mesh`: draw every frame as an indexed list (counted, with the
    /// frame's own vertices), the path of a grid whose vertices do not fit one buffer of the
    /// device, even where they fit. The picture is the same.
    #[arg(long, hide = true)]
    mesh_list: bool,
    /// Frames to render; pass times are the median over them (the first frame's setup passes
    /// are reported separately).
    #[arg(long, value_name = "N", default_value_t = 1)]
    repeat: u32,
    /// PNG image (8-bit RGBA).
    #[arg(long, value_name = "PATH")]
    out: PathBuf,
    /// Depth image: little-endian f32, row-major, distance along the ray, +inf for a miss.
    #[arg(long, value_name = "PATH")]
    depth_out: Option<PathBuf>,
    /// World normals of the hits: little-endian f32, three per pixel (x, y, z), row-major,
    /// zeros for a miss (needs `--effects normals`; ray casting, either backend).
    #[arg(long, value_name = "PATH")]
    normals_out: Option<PathBuf>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

fn parse_effects(s: &str) -> CliResult<Vec<Effect>> {
    let mut v = Vec::new();
    for name in s.split(',').map(str::trim).filter(|n| !n.is_empty()) {
        let e = Effect::parse(name).ok_or_else(|| {
            let all: Vec<&str> = Effect::ALL.iter().map(|e| e.name()).collect();
            CliError(format!(
                "unknown effect '{name}' (known: {})",
                all.join(", ")
            ))
        })?;
        if !v.contains(&e) {
            v.push(e);
        }
    }
    v.sort();
    Ok(v)
}

/// A rendered frame and what it cost.
pub(crate) struct Rendered {
    width: u32,
    height: u32,
    depth: Vec<f32>,
    color: Vec<[u8; 4]>,
    device: String,
    /// Where the pass times come from: "gpu" (timestamp queries) or "wall".
    timing: &'static str,
    /// Texel reads per pixel of `--method silhouette`.
    reads_per_pixel: Option<u32>,
    /// The last frame's cascades of `--method cascades` (JSON objects).
    cascades: Option<serde_json::Value>,
    setup: Vec<(String, f64)>,
    /// Per-frame passes with their milliseconds.
    pub(crate) passes: Vec<(String, f64)>,
    /// GPU scenes: the CPU's time recording a frame's passes (`PassTiming::cpu_ms` summed,
    /// median over frames).
    record_ms: Option<f64>,
    /// The last frame's world normals, with the `normals` effect.
    normals: Option<Vec<[f32; 3]>>,
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        0.0
    } else {
        v[v.len() / 2]
    }
}

/// Per-pass medians over frames (each frame the same pass list).
fn medians(frames: &[Vec<(String, f64)>]) -> Vec<(String, f64)> {
    let Some(first) = frames.first() else {
        return Vec::new();
    };
    (0..first.len())
        .map(|k| {
            let mut t: Vec<f64> = frames
                .iter()
                .filter_map(|f| f.get(k).map(|p| p.1))
                .collect();
            (first[k].0.clone(), median(&mut t))
        })
        .collect()
}

fn render_gpu(
    hf: &Heightfield<'_, f32>,
    camera: &Camera,
    a: &RenderArgs,
    effects: &[Effect],
) -> CliResult<Rendered> {
    let gpu = relief_wgpu::headless()?;
    let device = format!("{} ({:?})", gpu.info.name, gpu.info.backend);
    let (w, h) = a.size;
    if a.method == RenderMethod::Mesh {
        if let Some(e) = effects
            .iter()
            .find(|e| !matches!(e, Effect::Lighting | Effect::DepthOutput))
        {
            return Err(CliError(format!(
                "effect '{}' is not available with --method mesh (lighting, depth are)",
                e.name()
            )));
        }
        let (hw, hh) = (hf.width(), hf.height());
        let t0 = Instant::now();
        let mut errors = vec![0u16; relief_core::refine::hierarchy_len(hw, hh)];
        let hier = preprocess_compact(hf, &mut errors)?;
        let mut setup = vec![("preprocess".to_string(), t0.elapsed().as_secs_f64() * 1e3)];
        let view = View::new(camera, a.pixel_error)?;
        let rf = Refiner::new(&hier, hf, Criterion::View(view))?;
        let mut scratch = vec![0u64; scratch_len(hw, hh)];
        let mut mesh = MeshPass::new(&gpu.device);
        let target = DepthTarget::new(&gpu.device, w, h)?;
        let lo = local_min(hf) + hf.scale().z_offset;
        let (zmin, zmax) = (lo, lo + z_span(hf));
        let style = MeshStyle::Terrain {
            lighting: effects.contains(&Effect::Lighting),
        };
        // Every sample a vertex, uploaded once; each frame then writes only its triangles as
        // grid indices (`Refiner::grid_triangles`: one traversal, nothing renumbered, no
        // vertices). A grid whose vertices do not fit one buffer of the device takes the
        // indexed list instead (counted, then the frame's own vertices).
        let t0 = Instant::now();
        let on_grid = !a.mesh_list
            && match mesh.upload_grid_vertices(&gpu.device, &gpu.queue, hf) {
                Ok(()) => true,
                Err(relief_wgpu::Error::TooLarge { .. }) => false,
                Err(e) => return Err(e.into()),
            };
        if on_grid {
            setup.push((
                "grid_vertices".to_string(),
                t0.elapsed().as_secs_f64() * 1e3,
            ));
        }
        // Room for the most triangles a frame can have, so that no frame traverses twice (a
        // short buffer costs a whole traversal before its error); zeroed lazily by the
        // allocator, so only the pages a frame writes are ever touched. Reused across frames.
        let mut grid: Vec<[u32; 3]> = if on_grid {
            vec![[0; 3]; relief_core::refine::triangle_bound(hw, hh)]
        } else {
            Vec::new()
        };
        let mut frames = Vec::new();
        for _ in 0..a.repeat {
            let t = Instant::now();
            // The indexed list's vertices and triangles, or `None` for grid indices in `grid[..n]`.
            let (list, n) = if on_grid {
                (None, rf.grid_triangles(&mut grid)?)
            } else {
                let c = rf.count(&mut scratch)?;
                let mut verts = vec![[0.0f32; 3]; c.vertices];
                let mut tris = vec![[0u32; 3]; c.triangles];
                rf.triangles(&mut scratch, &mut verts, &mut tris)?;
                (Some((verts, tris)), 0)
            };
            let refine_ms = t.elapsed().as_secs_f64() * 1e3;
            let t = Instant::now();
            match &list {
                Some((v, t)) => mesh.upload(&gpu.device, &gpu.queue, v, t.as_flattened())?,
                None => {
                    let i = grid.get(..n).unwrap_or(&[]).as_flattened();
                    mesh.upload_grid_triangles(&gpu.device, &gpu.queue, i)?
                }
            }
            let mut enc = gpu.device.create_command_encoder(&Default::default());
            mesh.encode(
                &gpu.queue,
                &mut enc,
                &target,
                camera,
                style,
                (zmin, zmax),
                true,
            )?;
            gpu.queue.submit([enc.finish()]);
            gpu.device
                .poll(wgpu::PollType::wait_indefinitely())
                .map_err(|e| CliError(e.to_string()))?;
            frames.push(vec![
                ("refine".to_string(), refine_ms),
                ("mesh".to_string(), t.elapsed().as_secs_f64() * 1e3),
            ]);
        }
        let color = target.read_color(&gpu.device, &gpu.queue)?;
        let d = target.read_depth(&gpu.device, &gpu.queue)?;
        let depth = (0..h)
            .flat_map(|j| (0..w).map(move |i| (i, j)))
            .map(|(i, j)| {
                depth_to_distance(
                    camera,
                    relief_wgpu::scene::NEAR,
                    i,
                    j,
                    d[(j * w + i) as usize],
                )
            })
            .collect();
        return Ok(Rendered {
            width: w,
            height: h,
            depth,
            color,
            device,
            timing: "wall",
            reads_per_pixel: None,
            cascades: None,
            setup,
            passes: medians(&frames),
            record_ms: None,
            normals: None,
        });
    }
    let method = match a.method {
        RenderMethod::March => relief_wgpu::Method::march(),
        RenderMethod::Silhouette => relief_wgpu::Method::Silhouette,
        RenderMethod::Cascades => relief_wgpu::Method::Cascades {
            resolution: a.cascade_resolution,
        },
        RenderMethod::Maxmip | RenderMethod::Mesh => relief_wgpu::Method::MaxMip,
    };
    let mut scene = Scene::new().with_effects(effects).with_method(method);
    if let Some(e) = a.rbf_max_error {
        scene = scene.with_rbf_grid(
            relief_core::rbf::GridOptions::default()
                .with_max_error(e)
                .with_cells(1, 64),
        );
    }
    if effects.contains(&Effect::Deformations) {
        scene = scene.with_craters(&craters(hf));
    }
    if let Some(path) = &a.water_surface {
        scene = scene.with_water_surface(read_water_surface(path, hf)?);
    }
    if effects.contains(&Effect::Water) {
        let s = *scene.shading();
        scene = scene.with_shading(s.with_water_level(water_level(hf)));
    }
    let mut r = Renderer::new(&gpu.device, &gpu.queue, hf, scene)?;
    let mut frames = Vec::new();
    let mut setup = Vec::new();
    let mut image = None;
    let mut record = Vec::new();
    for k in 0..a.repeat.max(1) {
        let (img, times) = r.render_profiled(&gpu.device, &gpu.queue, camera)?;
        let n_setup = if k == 0 {
            r.scene().setup_passes().len()
        } else {
            0
        };
        record.push(times.iter().skip(n_setup).map(|t| t.cpu_ms).sum::<f64>());
        let named: Vec<(String, f64)> = times
            .iter()
            .map(|t| (t.pass.as_str().to_string(), t.ms))
            .collect();
        if k == 0 {
            setup = named[..n_setup].to_vec();
        }
        frames.push(named[n_setup..].to_vec());
        image = Some(img);
    }
    let img = image.ok_or_else(|| CliError("no frame rendered".into()))?;
    let normals = match r.outputs() {
        Some(o) if effects.contains(&Effect::NormalOutput) => Some(
            o.read_normals(&gpu.device, &gpu.queue)?
                .into_iter()
                .map(|n| [n[0], n[1], n[2]])
                .collect(),
        ),
        _ => None,
    };
    Ok(Rendered {
        width: img.width,
        height: img.height,
        depth: img.depth,
        color: img.color,
        device,
        timing: r.clock().as_str(),
        reads_per_pixel: r.silhouette_pass().map(|p| p.reads_per_pixel()),
        cascades: r.cascades().map(|c| {
            c.cascades
                .iter()
                .map(|k| {
                    serde_json::json!({
                        "spacing": k.spacing,
                        "origin": k.origin,
                        "resolution": k.resolution,
                        "near": k.near,
                        "far": k.far,
                    })
                })
                .collect()
        }),
        setup,
        passes: medians(&frames),
        record_ms: Some(median(&mut record)),
        normals,
    })
}

/// The craters of the deformations effect (both backends): two in the middle of the map, a
/// tenth and a twentieth of it across, a fifth of the height range deep.
fn craters(hf: &Heightfield<'_, f32>) -> Vec<Crater> {
    let (cw, ch) = (hf.width() as f32, hf.height() as f32);
    let depth = 0.2 * z_span(hf).max(1.0);
    vec![
        Crater {
            center: [0.5 * cw, 0.5 * ch],
            radius: 0.1 * cw,
            depth,
        },
        Crater {
            center: [0.6 * cw, 0.4 * ch],
            radius: 0.05 * cw,
            depth,
        },
    ]
}

/// The water plane of the water effect (world z; both backends): 15 % up the height range.
fn water_level(hf: &Heightfield<'_, f32>) -> f32 {
    hf.scale().z_offset + local_min(hf) + 0.15 * z_span(hf)
}

fn z_span(hf: &Heightfield<'_, f32>) -> f32 {
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    for y in 0..hf.height() {
        for x in 0..hf.width() {
            let z = hf.local_z(x, y);
            lo = lo.min(z);
            hi = hi.max(z);
        }
    }
    (hi - lo).max(0.0)
}

fn local_min(hf: &Heightfield<'_, f32>) -> f32 {
    let mut lo = f32::INFINITY;
    for y in 0..hf.height() {
        for x in 0..hf.width() {
            lo = lo.min(hf.local_z(x, y));
        }
    }
    lo
}

/// The ray caster's colour ramp (shaders/raycast.wgsl `albedo`), for the CPU backend.
fn albedo(s: f32) -> Vec3 {
    let low = Vec3::new(0.25, 0.45, 0.2);
    let mid = Vec3::new(0.55, 0.45, 0.3);
    let high = Vec3::new(0.95, 0.95, 0.95);
    let s = s.clamp(0.0, 1.0);
    if s < 0.6 {
        low.lerp(mid, s / 0.6)
    } else {
        mid.lerp(high, (s - 0.6) / 0.4)
    }
}

/// The colour, depth and normal of a pixel whose ray meets the water at `tw`, in front of the
/// terrain's hit at `depth` (`inf` for none), as shaders/raycast.wgsl shades it: the colour
/// mixed halfway to the water's, then darkened with the depth of water above the ground; the
/// water faces up.
fn under_water(
    c: Vec3,
    depth: f32,
    tw: f32,
    shading: &relief_wgpu::raycast::Shading,
) -> (Vec3, f32, [f32; 3]) {
    let below = if depth.is_finite() {
        ((depth - tw) * 0.002).min(1.0)
    } else {
        0.0
    };
    let wc = shading.water_color;
    (c.lerp(wc, 0.5).lerp(wc * 0.6, below), tw, [0.0, 0.0, 1.0])
}

/// Reads `--water-surface`: little-endian `f32`, one finite world height per DEM sample.
fn read_water_surface(path: &Path, hf: &Heightfield<'_, f32>) -> CliResult<Vec<f32>> {
    let bytes = std::fs::read(path).map_err(|e| CliError(format!("{}: {e}", path.display())))?;
    let n = hf.width() as usize * hf.height() as usize;
    if bytes.len() != n * 4 {
        return Err(CliError(format!(
            "{}: {} bytes, expected {} (one f32 per DEM sample)",
            path.display(),
            bytes.len(),
            n * 4
        )));
    }
    let heights: Vec<f32> = bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    if heights.iter().any(|z| !z.is_finite()) {
        return Err(CliError(format!(
            "{}: non-finite water height",
            path.display()
        )));
    }
    Ok(heights)
}

/// The CPU backend: max-mip (or march) tracing with the effects that need only core functions
/// and the GPU shader's CPU references: lighting (the core's Sobel normal map of the traced
/// heights, with the detail map composed when named, sampled bilinearly at the hit as the
/// shader samples the GPU's), shadows, fog, the detail map's colour, the water plane or a water
/// surface (`water_surface`, world heights per sample, marched as the shader marches it:
/// [`relief_wgpu::raycast::water_surface_hit`]) and deformations (the craters applied to the
/// heights with [`Crater::lowering`], then traced).
/// Like the GPU it builds only what the scene names: the pyramid for max-mip tracing, the
/// normal map for lighting.
/// Not on the CPU: depth output (a GPU depth buffer for meshes), the
/// cascade ray cast and the mesh method (it would need a CPU rasteriser); silhouette
/// partitioning has its own CPU path ([`render_cpu_silhouette`]). Also the report's fallback for effect costs where no GPU adapter exists.
pub(crate) fn render_cpu(
    hf: &Heightfield<'_, f32>,
    camera: &Camera,
    march: bool,
    effects: &[Effect],
    water_surface: Option<&[f32]>,
) -> CliResult<Rendered> {
    if let Some(e) = effects.iter().find(|e| **e == Effect::DepthOutput) {
        return Err(CliError(format!(
            "effect '{}' needs --backend gpu (the CPU renders lighting, shadows, detail, deformations, fog, water, normals)",
            e.name()
        )));
    }
    let has = |e: Effect| effects.contains(&e);
    let (w, h) = (camera.width, camera.height);
    let t0 = Instant::now();
    let scale = hf.scale();
    let (base_lo, base_hi) = (local_min(hf), local_min(hf) + z_span(hf));
    // Deformations: the craters applied to the local heights (as shaders/deform.wgsl does).
    let mut crater_depth = 0.0f32;
    let deformed: Option<Vec<f32>> = has(Effect::Deformations).then(|| {
        let cs = craters(hf);
        crater_depth = cs.iter().map(|c| c.depth.max(0.0)).sum();
        (0..hf.height())
            .flat_map(|y| (0..hf.width()).map(move |x| (x, y)))
            .map(|(x, y)| {
                cs.iter()
                    .fold(hf.local_z(x, y), |z, c| z - c.lowering(x as f32, y as f32))
            })
            .collect()
    });
    let dhf = match &deformed {
        Some(v) => Heightfield::with_scale(v, hf.width(), hf.height(), scale.with_z_scale(1.0))?,
        None => *hf,
    };
    let deform_ms = t0.elapsed().as_secs_f64() * 1e3;
    let t0 = Instant::now();
    let mut buf = Vec::new();
    let mip = if march {
        None
    } else {
        let len = MaxMip::len(dhf.width(), dhf.height())
            .ok_or_else(|| CliError("grid too small".into()))?;
        buf.resize(len, 0.0f32);
        Some(MaxMip::build(&dhf, &mut buf)?)
    };
    let build_ms = t0.elapsed().as_secs_f64() * 1e3;
    let tracer = RayTracer::new(&dhf, Surface::Triangles);
    // The GPU's colour range: the uploaded heights' range, lowered by the craters' depths.
    let (zmin, zmax) = (base_lo - crater_depth, base_hi);
    let shading = relief_wgpu::raycast::Shading::default();
    let sun = shading.sun.normalize();
    let detail = has(Effect::Detail).then(|| {
        (
            relief_wgpu::scene::procedural_detail(64, 0.01 * (base_hi - base_lo).max(1.0)),
            64u32,
        )
    });
    // Lighting: the normal map the GPU's `normal_map` pass makes (Sobel, the detail composed).
    let t0 = Instant::now();
    let lit_normals = if has(Effect::Lighting) {
        let mut n = vec![Vec3::ZERO; dhf.width() as usize * dhf.height() as usize];
        match &detail {
            Some((map, k)) => {
                let d = Heightfield::new(map, *k, *k)?;
                normal_map(&Composed::new(dhf, d, 1)?, NormalMethod::Sobel, &mut n)?;
            }
            None => normal_map(&dhf, NormalMethod::Sobel, &mut n)?,
        }
        Some(n)
    } else {
        None
    };
    let normals_ms = t0.elapsed().as_secs_f64() * 1e3;
    let water = has(Effect::Water).then(|| water_level(hf));
    // The water surface in local heights, as the GPU uploads it.
    let water_local: Option<Vec<f32>> = water_surface
        .filter(|_| has(Effect::Water))
        .map(|ws| ws.iter().map(|z| z - scale.z_offset).collect());
    let extent = (
        f64::from(dhf.width() - 1) * f64::from(scale.dx),
        f64::from(dhf.height() - 1) * f64::from(scale.dy),
    );
    let opts = MarchOptions::default();
    // The pyramid exists exactly for max-mip tracing.
    let trace = |ray: &Ray| -> Result<Option<relief_core::Hit>, String> {
        match &mip {
            Some(mip) => Ok(tracer
                .trace_maxmip(ray, mip)
                .map_err(|e| e.to_string())?
                .hit),
            None => Ok(tracer
                .trace_march(ray, &opts)
                .map_err(|e| e.to_string())?
                .trace
                .hit),
        }
    };
    let (shadows, fog) = (has(Effect::Shadows), has(Effect::Fog));
    let t1 = Instant::now();
    let rows: Result<Vec<Vec<Pixel>>, String> = (0..h)
        .into_par_iter()
        .map(|j| {
            (0..w)
                .map(|i| {
                    let (o, d) = camera.ray(i, j);
                    let ray = Ray::new(o, d).map_err(|e| e.to_string())?;
                    let sky = Vec3::new(0.55, 0.7, 0.9);
                    let mut c = sky;
                    let mut depth = f32::INFINITY;
                    let mut normal = [0.0f32; 3];
                    if let Some(hit) = trace(&ray)? {
                        normal = hit.normal.to_array();
                        let local = hit.position.z as f32 - scale.z_offset;
                        c = albedo((local - zmin) / (zmax - zmin).max(1e-6));
                        if let Some((map, n)) = &detail {
                            // shaders/raycast.wgsl: the detail texel under the hit, tiled.
                            let gx = (hit.position.x / f64::from(scale.dx)).floor() as i64;
                            let gy = (hit.position.y / f64::from(scale.dy)).floor() as i64;
                            let n = i64::from(*n);
                            let k = (gy.rem_euclid(n) * n + gx.rem_euclid(n)) as usize;
                            let v = map.get(k).copied().unwrap_or(0.0);
                            c *= 1.0 + (v * shading.detail_gain).clamp(-0.3, 0.3);
                        }
                        let mut lit = 1.0;
                        if shadows {
                            let lift = 1e-3 * (zmax - zmin).max(1.0);
                            let p = hit.position.as_vec3() + Vec3::new(0.0, 0.0, lift);
                            let sray = Ray::new(p, sun).map_err(|e| e.to_string())?;
                            if trace(&sray)?.is_some() {
                                lit = 0.0;
                            }
                        }
                        if let Some(n) = &lit_normals {
                            let sn = sample_normals(
                                n,
                                dhf.width(),
                                dhf.height(),
                                (hit.position.x / f64::from(scale.dx)) as f32,
                                (hit.position.y / f64::from(scale.dy)) as f32,
                            );
                            let diffuse = sn.dot(sun).max(0.0) * lit;
                            c *= shading.ambient + (1.0 - shading.ambient) * diffuse;
                        } else if shadows {
                            c *= 0.55 + 0.45 * lit;
                        }
                        depth = hit.t as f32;
                    }
                    if let Some(ws) = &water_local {
                        // The water surface, marched up to the terrain's hit in local
                        // coordinates (grid units horizontally), as shaders/raycast.wgsl does.
                        let (o, d) = (o.as_dvec3(), d.as_dvec3());
                        let (sx, sy) = (f64::from(scale.dx), f64::from(scale.dy));
                        let ol = [o.x / sx, o.y / sy, o.z - f64::from(scale.z_offset)];
                        let dl = [d.x / sx, d.y / sy, d.z];
                        let (dw, dh) = (dhf.width(), dhf.height());
                        let tw = water_surface_hit(ws, dw, dh, ol, dl, f64::from(depth));
                        if let Some(tw) = tw.filter(|&tw| (tw as f32) < depth) {
                            (c, depth, normal) = under_water(c, depth, tw as f32, &shading);
                        }
                    } else if let Some(level) = water {
                        // The water plane, inside the terrain's extent, in front of the hit.
                        let (o, d) = (o.as_dvec3(), d.as_dvec3());
                        let level = f64::from(level);
                        if d.z < 0.0 && o.z > level {
                            let tw = (level - o.z) / d.z;
                            let p = o + tw * d;
                            let inside =
                                p.x >= 0.0 && p.y >= 0.0 && p.x <= extent.0 && p.y <= extent.1;
                            if inside && (tw as f32) < depth {
                                (c, depth, normal) = under_water(c, depth, tw as f32, &shading);
                            }
                        }
                    }
                    if fog && depth.is_finite() {
                        let f = 1.0 - (-shading.fog_density * depth).exp();
                        c = c.lerp(shading.fog_color, f);
                    }
                    Ok((depth, rgba(c), normal))
                })
                .collect()
        })
        .collect();
    let rows = rows.map_err(CliError)?;
    let trace_ms = t1.elapsed().as_secs_f64() * 1e3;
    // The normals are kept only when the scene names them.
    let want_normals = has(Effect::NormalOutput);
    let n = w as usize * h as usize;
    let (mut depth, mut color) = (Vec::with_capacity(n), Vec::with_capacity(n));
    let mut normals = Vec::with_capacity(if want_normals { n } else { 0 });
    for (d, c, nm) in rows.into_iter().flatten() {
        depth.push(d);
        color.push(c);
        if want_normals {
            normals.push(nm);
        }
    }
    let mut setup = Vec::new();
    let mut passes = Vec::new();
    // Deformed every frame, as on the GPU: then the pyramid and the normal map are per frame.
    let per_frame = deformed.is_some();
    if per_frame {
        passes.push(("deform".to_string(), deform_ms));
    }
    let built = if per_frame { &mut passes } else { &mut setup };
    if !march {
        built.push(("maxmip_build".to_string(), build_ms));
    }
    if lit_normals.is_some() {
        built.push(("normal_map".to_string(), normals_ms));
    }
    passes.push(("trace".to_string(), trace_ms));
    Ok(Rendered {
        width: w,
        height: h,
        depth,
        color,
        device: format!("cpu ({} threads)", rayon::current_num_threads()),
        timing: "wall",
        reads_per_pixel: None,
        cascades: None,
        setup,
        passes,
        record_ms: None,
        normals: want_normals.then_some(normals),
    })
}

/// The CPU backend of `--method silhouette`: the silhouette-partitioning model of the GPU pass
/// in `f64` ([`relief_wgpu::silhouette::trace_cpu`]), coloured by the same height ramp. No
/// effects.
fn render_cpu_silhouette(
    hf: &Heightfield<'_, f32>,
    camera: &Camera,
    effects: &[Effect],
) -> CliResult<Rendered> {
    if let Some(e) = effects.first() {
        return Err(CliError(format!(
            "effect '{}' is not available with --method silhouette on the CPU",
            e.name()
        )));
    }
    let t0 = Instant::now();
    let t = relief_wgpu::silhouette::trace_cpu(hf, camera)?;
    let trace_ms = t0.elapsed().as_secs_f64() * 1e3;
    let (lo, hi) = (local_min(hf), local_min(hf) + z_span(hf));
    let sky = Vec3::new(0.55, 0.7, 0.9);
    let color = t
        .depth
        .iter()
        .zip(&t.height)
        .map(|(d, z)| {
            if d.is_finite() {
                rgba(albedo((z - lo) / (hi - lo).max(1e-6)))
            } else {
                rgba(sky)
            }
        })
        .collect();
    Ok(Rendered {
        width: camera.width,
        height: camera.height,
        depth: t.depth,
        color,
        device: "cpu (1 thread)".into(),
        timing: "wall",
        reads_per_pixel: None,
        cascades: None,
        setup: Vec::new(),
        passes: vec![("silhouette_trace".to_string(), trace_ms)],
        record_ms: None,
        normals: None,
    })
}

/// Depth and colour of one pixel.
/// The normal map `n` (`w x h`) at grid position `(gx, gy)`, interpolated bilinearly and
/// normalised: `sample_normal_map` of `shaders/raycast.wgsl`.
fn sample_normals(n: &[Vec3], w: u32, h: u32, gx: f32, gy: f32) -> Vec3 {
    let x0 = (gx.floor().max(0.0) as u32).min(w - 1);
    let y0 = (gy.floor().max(0.0) as u32).min(h - 1);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let fx = (gx - x0 as f32).clamp(0.0, 1.0);
    let fy = (gy - y0 as f32).clamp(0.0, 1.0);
    let at = |x: u32, y: u32| n.get((y * w + x) as usize).copied().unwrap_or(Vec3::Z);
    let a = at(x0, y0).lerp(at(x1, y0), fx);
    let b = at(x0, y1).lerp(at(x1, y1), fx);
    a.lerp(b, fy).normalize_or(Vec3::Z)
}

/// Depth, colour and world normal (zero for a miss) of a CPU-rendered pixel.
type Pixel = (f32, [u8; 4], [f32; 3]);

fn rgba(c: Vec3) -> [u8; 4] {
    let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
    [q(c.x), q(c.y), q(c.z), 255]
}

fn write_png(path: &Path, w: u32, h: u32, color: &[[u8; 4]]) -> CliResult {
    relief_io::write_atomic(path, |out| {
        let mut enc = png::Encoder::new(out, w, h);
        enc.set_color(png::ColorType::Rgba);
        enc.set_depth(png::BitDepth::Eight);
        let mut wr = enc.write_header().map_err(std::io::Error::other)?;
        wr.write_image_data(color.as_flattened())
            .map_err(std::io::Error::other)?;
        wr.finish().map_err(std::io::Error::other)
    })?;
    Ok(())
}

/// Runs `relief render`.
pub fn run(a: &RenderArgs) -> CliResult {
    let effects = parse_effects(&a.effects)?;
    if a.repeat == 0 {
        return Err(CliError("--repeat must be at least 1".into()));
    }
    if !(a.pixel_error.is_finite() && a.pixel_error > 0.0) {
        return Err(CliError("--pixel-error must be positive".into()));
    }
    if a.water_surface.is_some() && !effects.contains(&Effect::Water) {
        return Err(CliError("--water-surface needs --effects water".into()));
    }
    if a.normals_out.is_some() && !effects.contains(&Effect::NormalOutput) {
        return Err(CliError("--normals-out needs --effects normals".into()));
    }
    let (w, h) = a.size;
    let camera = Camera::new(a.eye, a.target, a.fov, w, h)?;
    let (dem, _) = a.dem.load()?;
    let hf: Heightfield<'_, f32> = dem.heightfield()?;
    let r = match a.backend {
        Backend::Gpu => render_gpu(&hf, &camera, a, &effects)?,
        Backend::Cpu => {
            if matches!(a.method, RenderMethod::Mesh | RenderMethod::Cascades) {
                return Err(CliError(
                    "--method mesh and cascades need --backend gpu".into(),
                ));
            }
            if a.method == RenderMethod::Silhouette {
                render_cpu_silhouette(&hf, &camera, &effects)?
            } else {
                let water = match &a.water_surface {
                    Some(path) => Some(read_water_surface(path, &hf)?),
                    None => None,
                };
                let march = a.method == RenderMethod::March;
                render_cpu(&hf, &camera, march, &effects, water.as_deref())?
            }
        }
    };
    write_png(&a.out, r.width, r.height, &r.color)?;
    if let Some(p) = &a.depth_out {
        relief_io::write_raw_f32(p, &r.depth)?;
    }
    if let (Some(p), Some(n)) = (&a.normals_out, &r.normals) {
        relief_io::write_raw_f32(p, n.as_flattened())?;
    }
    let hits = r.depth.iter().filter(|d| d.is_finite()).count();
    let frame_ms: f64 = r.passes.iter().map(|p| p.1).sum();
    let method = match a.method {
        RenderMethod::Maxmip => "maxmip",
        RenderMethod::March => "march",
        RenderMethod::Silhouette => "silhouette",
        RenderMethod::Cascades => "cascades",
        RenderMethod::Mesh => "mesh",
    };
    let backend = match a.backend {
        Backend::Gpu => "gpu",
        Backend::Cpu => "cpu",
    };
    let names: Vec<&str> = effects.iter().map(|e| e.name()).collect();
    if a.json {
        let list = |v: &[(String, f64)]| -> Vec<serde_json::Value> {
            v.iter()
                .map(|(n, ms)| serde_json::json!({ "name": n, "ms": ms }))
                .collect()
        };
        let v = serde_json::json!({
            "width": r.width,
            "height": r.height,
            "backend": backend,
            "device": r.device,
            "method": method,
            "effects": names,
            "rays": r.width as u64 * r.height as u64,
            "hits": hits,
            "frames": a.repeat,
            "timing": r.timing,
            "reads_per_pixel": r.reads_per_pixel,
            "cascades": r.cascades,
            "setup_passes": list(&r.setup),
            "passes": list(&r.passes),
            "frame_ms": frame_ms,
            "record_ms": r.record_ms,
        });
        print_out(&format!("{v}\n"))
    } else {
        let mut s = format!(
            "rendered {}x{} with {method} on {} ({backend}), effects [{}]: {hits} of {} pixels hit\n",
            r.width,
            r.height,
            r.device,
            names.join(", "),
            r.width as u64 * r.height as u64
        );
        if let Some(n) = r.reads_per_pixel {
            s.push_str(&format!("  {n} texel reads per pixel (fixed)\n"));
        }
        s.push_str(&format!("  pass times: {} clock\n", r.timing));
        for (n, ms) in &r.setup {
            s.push_str(&format!("  setup {n:<14} {ms:9.2} ms\n"));
        }
        for (n, ms) in &r.passes {
            s.push_str(&format!("  pass  {n:<14} {ms:9.2} ms\n"));
        }
        s.push_str(&format!("  frame total          {frame_ms:9.2} ms\n"));
        if let Some(ms) = r.record_ms {
            s.push_str(&format!(
                "  CPU recording        {ms:9.2} ms (queue writes and commands)\n"
            ));
        }
        print_out(&s)
    }
}
