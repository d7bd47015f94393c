//! `relief diagram refine|strip|dda|silhouette|rbf|cascades`: debug diagrams of what the core's
//! algorithms did on a DEM, drawn by `relief-skia` over a hillshade (PNG).

use crate::args::DemArgs;
use crate::{print_out, CliError, CliResult};
use clap::{Args, ValueEnum};
use relief_core::glam::{DVec2, Vec2, Vec3};
use relief_core::rbf::{
    adaptive_grid_bound, build_adaptive_grid, fit_cascades, AdaptiveGrid, CascadeOptions, Cell,
    GridOptions, InfluenceSets, Rbf, RbfOptions,
};
use relief_core::refine::{hierarchy_len, preprocess, Criterion, View};
use relief_core::{Camera, Heightfield, Scale, Terrain};
use relief_skia::dda::DdaSpec;
use relief_skia::rbf::CascadeView;
use relief_skia::refine::{refine_state, RefineInput};
use relief_skia::strip::{strip_state, StripKind};
use relief_skia::{hillshade, DiagramOptions, HillshadeOptions};
use std::path::PathBuf;

/// Which diagram.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Kind {
    /// SOAR mesh by level, active vertices, bounding circles, frustum, culled and lazily accepted.
    Refine,
    /// A SOAR triangle strip in its order (in/out-edge, or SOAR's with --soar), joins between
    /// its pieces.
    Strip,
    /// Cell DDA vs run-length DDA of one ray (grid units), short and long runs with intercepts.
    Dda,
    /// Silhouette map and silhouette partitioning-tree levels for a camera.
    Silhouette,
    /// Adaptive RBF cells with the influence circles of chosen cells.
    Rbf,
    /// Frustum, visible hull, logarithmic splits and snapped cascade textures.
    Cascades,
}

/// Options of `relief diagram`.
#[derive(Debug, Args)]
pub struct DiagramArgs {
    /// The diagram to draw.
    #[arg(value_enum)]
    kind: Kind,
    #[command(flatten)]
    dem: DemArgs,
    /// Use only the window X,Y,W,H of the DEM (samples), e.g. to see cells of a large DEM.
    #[arg(long, value_name = "X,Y,W,H", value_parser = parse_u32x4)]
    crop: Option<[u32; 4]>,
    /// Camera eye X,Y,Z in world units (refine, cascades).
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true, value_parser = crate::args::parse_vec3)]
    eye: Option<Vec3>,
    /// Camera target X,Y,Z (refine, cascades).
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true, value_parser = crate::args::parse_vec3)]
    target: Option<Vec3>,
    /// Vertical field of view in degrees.
    #[arg(long, default_value_t = 60.0)]
    fov: f32,
    /// Image size WxH of the camera in pixels.
    #[arg(long, value_name = "WxH", value_parser = crate::args::parse_size, default_value = "640x480")]
    size: (u32, u32),
    /// refine: view-independent threshold (world z units); without --eye the default is 1 % of
    /// the height range.
    #[arg(long, value_name = "E")]
    max_error: Option<f32>,
    /// refine: view-dependent threshold in pixels (with --eye/--target).
    #[arg(long, value_name = "T", default_value_t = 2.0)]
    pixel_error: f32,
    /// refine: finest levels accepted without culling (lazy culling).
    #[arg(long, value_name = "N", default_value_t = 4)]
    lazy_levels: u32,
    /// refine: do not cull against the view frustum.
    #[arg(long)]
    no_cull: bool,
    /// refine: draw the bounding circles of the active vertices at this level.
    #[arg(long, value_name = "L")]
    circle_level: Option<u32>,
    /// strip: SOAR's original strip instead of seed 004's in/out-edge strip.
    #[arg(long)]
    soar: bool,
    /// dda: ray start X,Y in grid units (cell (cx, cy) is [cx, cx+1] x [cy, cy+1]).
    #[arg(long, value_name = "X,Y", allow_hyphen_values = true, value_parser = parse_vec2)]
    ray_start: Option<DVec2>,
    /// dda: ray direction DX,DY.
    #[arg(long, value_name = "DX,DY", allow_hyphen_values = true, value_parser = parse_vec2)]
    ray_dir: Option<DVec2>,
    /// dda: end of the segment X,Y (default: where the ray leaves the grid).
    #[arg(long, value_name = "X,Y", allow_hyphen_values = true, value_parser = parse_vec2)]
    ray_stop: Option<DVec2>,
    /// rbf, cascades: adaptive-grid merge tolerance (local height units).
    #[arg(long, value_name = "E", default_value_t = 1.0)]
    rbf_max_error: f32,
    /// rbf: largest cell size (power of two).
    #[arg(long, value_name = "C", default_value_t = 16)]
    max_cell: u32,
    /// rbf: Gaussian width sigma.
    #[arg(long, default_value_t = 1.0)]
    sigma: f32,
    /// rbf: highlight the cells containing these sample positions X,Y (repeatable; default the
    /// centre of the DEM).
    #[arg(long = "at", value_name = "X,Y", value_parser = parse_vec2)]
    at: Vec<DVec2>,
    /// silhouette: tree levels to draw (0 is the root).
    #[arg(
        long,
        value_name = "L,...",
        value_delimiter = ',',
        default_value = "2,3"
    )]
    levels: Vec<u32>,
    /// silhouette: skip segments closer than this to the eye along the view (world units).
    #[arg(long, value_name = "D", default_value_t = 0.01)]
    near: f32,
    /// cascades: texels per cascade side.
    #[arg(long, value_name = "N", default_value_t = 256)]
    resolution: u32,
    /// Longest side of the plot area in pixels (16..8192).
    #[arg(long, value_name = "PX", default_value_t = 800)]
    max_size: u32,
    /// Do not draw the hillshade under map diagrams.
    #[arg(long)]
    no_hillshade: bool,
    /// Output PNG file.
    #[arg(long, value_name = "PATH")]
    out: PathBuf,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

fn parse_floats<const N: usize>(s: &str, what: &str) -> Result<[f64; N], String> {
    let p: Vec<&str> = s.split(',').collect();
    if p.len() != N {
        return Err(format!("expected {what}, got {s:?}"));
    }
    let mut v = [0.0f64; N];
    for (o, t) in v.iter_mut().zip(p) {
        *o = t.trim().parse::<f64>().map_err(|e| format!("{t:?}: {e}"))?;
        if !o.is_finite() {
            return Err(format!("{t:?} is not finite"));
        }
    }
    Ok(v)
}

fn parse_vec2(s: &str) -> Result<DVec2, String> {
    let v = parse_floats::<2>(s, "X,Y")?;
    Ok(DVec2::new(v[0], v[1]))
}

fn parse_u32x4(s: &str) -> Result<[u32; 4], String> {
    let p: Vec<&str> = s.split(',').collect();
    if p.len() != 4 {
        return Err(format!("expected X,Y,W,H, got {s:?}"));
    }
    let mut v = [0u32; 4];
    for (o, t) in v.iter_mut().zip(p) {
        *o = t.trim().parse::<u32>().map_err(|e| format!("{t:?}: {e}"))?;
    }
    Ok(v)
}

fn camera(a: &DiagramArgs) -> CliResult<Option<Camera>> {
    match (a.eye, a.target) {
        (Some(eye), Some(target)) => Ok(Some(Camera::new(eye, target, a.fov, a.size.0, a.size.1)?)),
        (None, None) => Ok(None),
        _ => Err(CliError("--eye and --target go together".into())),
    }
}

/// Runs `relief diagram`.
pub fn run(a: &DiagramArgs) -> CliResult {
    let (dem, _) = a.dem.load()?;
    let (mut w, mut h) = (dem.width, dem.height);
    let mut samples = dem.samples.clone();
    if let Some([x, y, cw, ch]) = a.crop {
        let fits = cw >= 2
            && ch >= 2
            && x.checked_add(cw).is_some_and(|e| e <= w)
            && y.checked_add(ch).is_some_and(|e| e <= h);
        if !fits {
            return Err(CliError(format!(
                "--crop {x},{y},{cw},{ch} does not fit the {w} x {h} DEM (at least 2 x 2)"
            )));
        }
        samples = (y..y + ch)
            .flat_map(|r| {
                let s = (r * w + x) as usize;
                dem.samples[s..s + cw as usize].iter().copied()
            })
            .collect();
        (w, h) = (cw, ch);
    }
    let scale: Scale = dem.scale;
    let hf = Heightfield::with_scale(&samples, w, h, scale)?;
    let base = if a.no_hillshade || a.kind == Kind::Silhouette {
        None
    } else {
        Some(hillshade(&hf, &HillshadeOptions::default())?)
    };
    let opts = DiagramOptions::default()
        .with_max_size(a.max_size)
        .with_background(base.as_ref());
    let mut stats = serde_json::Map::new();
    let picture = match a.kind {
        Kind::Refine | Kind::Strip => {
            let n = hierarchy_len(w, h);
            let (mut errors, mut radii) = (vec![0.0f32; n], vec![0.0f32; n]);
            let hier = preprocess(&hf, &mut errors, &mut radii)?;
            let cam = camera(a)?;
            let criterion = match (&cam, a.max_error) {
                (Some(_), Some(_)) => {
                    return Err(CliError(
                        "refine: give either --max-error or --eye/--target, not both".into(),
                    ))
                }
                (Some(c), None) => Criterion::View(
                    View::new(c, a.pixel_error)?
                        .with_culling(!a.no_cull)
                        .with_lazy_levels(a.lazy_levels),
                ),
                (None, e) => {
                    let (lo, hi) = (0..h)
                        .flat_map(|y| (0..w).map(move |x| (x, y)))
                        .map(|(x, y)| hf.local_z(x, y))
                        .fold((f32::MAX, f32::MIN), |(l, u), z| (l.min(z), u.max(z)));
                    Criterion::MaxError(e.unwrap_or(0.01 * (hi - lo)))
                }
            };
            let input = RefineInput::new(&hf, &hier, criterion)
                .with_camera(cam.as_ref())
                .with_circle_level(a.circle_level);
            if a.kind == Kind::Strip {
                let kind = if a.soar {
                    StripKind::Soar
                } else {
                    StripKind::InOut
                };
                let st = strip_state(&input, kind)?;
                stats.insert("vertices".into(), st.vertices.len().into());
                stats.insert("triangles".into(), st.triangles.len().into());
                stats.insert("indices".into(), st.counts.indices.into());
                stats.insert("tested".into(), st.counts.tested.into());
                stats.insert("joins".into(), st.joins.len().into());
                relief_skia::strip::strip(&input, kind, &opts)?
            } else {
                let st = refine_state(&input)?;
                stats.insert("vertices".into(), st.vertices.len().into());
                stats.insert("triangles".into(), st.triangles.len().into());
                stats.insert("lazy_accepted".into(), st.lazy_accepted.len().into());
                relief_skia::refine::refine(&input, &opts)?
            }
        }
        Kind::Dda => {
            let (Some(start), Some(dir)) = (a.ray_start, a.ray_dir) else {
                return Err(CliError(
                    "dda needs --ray-start X,Y and --ray-dir DX,DY".into(),
                ));
            };
            let cells = [w - 1, h - 1];
            let stop = a
                .ray_stop
                .unwrap_or_else(|| start + dir.normalize_or_zero() * 4.0 * f64::from(w + h));
            let spec = DdaSpec {
                start,
                dir,
                stop,
                cells,
            };
            let runs = relief_skia::dda::runs(&spec)?;
            stats.insert("cells".into(), spec.line()?.cells().count().into());
            stats.insert("runs".into(), runs.len().into());
            let seq: String = runs.iter().map(|r| r.kind.symbol()).collect();
            stats.insert("run_sequence".into(), seq.into());
            relief_skia::dda::dda(&spec, &opts)?
        }
        Kind::Rbf | Kind::Cascades => {
            let bound = adaptive_grid_bound(w, h)
                .ok_or_else(|| CliError(format!("a {w} x {h} adaptive grid is too large")))?;
            let mut cells = vec![Cell::default(); bound];
            let go = GridOptions::default()
                .with_max_error(a.rbf_max_error)
                .with_cells(1, a.max_cell);
            let n = build_adaptive_grid(&hf, &go, &mut cells)?;
            let mut index = vec![0; hierarchy_len(w, h)];
            let grid = AdaptiveGrid::new(w, h, &cells[..n], &mut index)?;
            stats.insert("cells".into(), n.into());
            if a.kind == Kind::Rbf {
                let o = RbfOptions::default().with_sigma(a.sigma);
                let mut offsets = vec![0; InfluenceSets::offsets_len(&grid)];
                let mut entries = vec![0; InfluenceSets::entries_len(&grid, &o)?];
                let sets = InfluenceSets::build(&grid, &o, &mut offsets, &mut entries)?;
                let rbf = Rbf::new(grid, sets, &o)?;
                let points = if a.at.is_empty() {
                    vec![DVec2::new(f64::from(w / 2), f64::from(h / 2))]
                } else {
                    a.at.clone()
                };
                let mut chosen = Vec::new();
                for p in points {
                    let inside = (0.0..=f64::from(w - 1)).contains(&p.x)
                        && (0.0..=f64::from(h - 1)).contains(&p.y);
                    let c = rbf
                        .grid()
                        .cell_containing(Vec2::new(p.x as f32, p.y as f32))
                        .filter(|_| inside)
                        .ok_or_else(|| {
                            CliError(format!("--at {},{} is outside the {w} x {h} DEM", p.x, p.y))
                        })?;
                    chosen.push(c);
                }
                relief_skia::rbf::rbf(&rbf, &chosen, &opts)?
            } else {
                let cam = camera(a)?.ok_or_else(|| {
                    CliError("cascades needs --eye X,Y,Z and --target X,Y,Z".into())
                })?;
                let (lo, hi) = samples
                    .iter()
                    .fold((f32::MAX, f32::MIN), |(l, u), &z| (l.min(z), u.max(z)));
                let z = (
                    lo * scale.z_scale + scale.z_offset,
                    hi * scale.z_scale + scale.z_offset,
                );
                let z = (z.0.min(z.1), z.0.max(z.1));
                let fit = fit_cascades(
                    &cam,
                    &grid,
                    &scale,
                    z,
                    &CascadeOptions::default().with_resolution(a.resolution),
                    None,
                )?;
                stats.insert("visible".into(), fit.visible.into());
                stats.insert("splits".into(), vec![fit.splits[0], fit.splits[1]].into());
                let view = CascadeView {
                    camera: &cam,
                    scale,
                    size: [w, h],
                };
                relief_skia::rbf::cascades(&fit, &view, &opts)?
            }
        }
        Kind::Silhouette => {
            let cam = camera(a)?.ok_or_else(|| {
                CliError("silhouette needs --eye X,Y,Z and --target X,Y,Z".into())
            })?;
            stats.insert("levels".into(), a.levels.clone().into());
            relief_skia::silhouette::silhouette(&hf, &cam, a.near, &a.levels, &opts)?
        }
    };
    relief_skia::save_png(&picture, &a.out)?;
    let name = a
        .kind
        .to_possible_value()
        .map_or_else(String::new, |v| v.get_name().to_string());
    if a.json {
        stats.insert("diagram".into(), name.into());
        stats.insert("width".into(), picture.width().into());
        stats.insert("height".into(), picture.height().into());
        stats.insert("out".into(), a.out.display().to_string().into());
        print_out(&format!("{}\n", serde_json::Value::Object(stats)))
    } else {
        let extra: Vec<String> = stats.iter().map(|(k, v)| format!("{k} {v}")).collect();
        print_out(&format!(
            "wrote {} diagram {} ({} x {} pixels): {}\n",
            name,
            a.out.display(),
            picture.width(),
            picture.height(),
            extra.join(", ")
        ))
    }
}
