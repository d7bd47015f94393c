//! `relief mesh --detail PATH --detail-factor K`: view-dependent refinement that continues below
//! the base grid into a tiled detail map added to the bilinear base (relief_core::Composed and
//! relief_core::refine::DetailRefiner; seed 004 chapter 6.3). The OBJ holds samples of the
//! composed surface in world units; `--json` reports triangles per level range and the effective
//! resolution.

use crate::args::DemArgs;
use crate::{print_out, CliError, CliResult};
use clap::Args;
use relief_core::glam::Vec3;
use relief_core::refine::{
    detail_scratch_len, hierarchy_len, local_bounds_len, preprocess, preprocess_compact,
    DetailBounds, DetailCounts, DetailRefiner, Hierarchy, View,
};
use relief_core::{Camera, Composed, Heightfield, Scale, Terrain};
use relief_io::{read_dem, ReadOptions};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Detail-level options of `relief mesh`.
#[derive(Debug, Args, Clone)]
pub struct DetailArgs {
    /// Tiled detail map added to the bilinearly refined base (PNG, TIFF or raw f32 with
    /// --detail-size); enables detail levels (view-dependent only).
    #[arg(long, value_name = "PATH")]
    pub detail: Option<PathBuf>,
    /// Detail samples per base cell along each axis (a power of two): the composed grid has
    /// (W-1)*K+1 x (H-1)*K+1 samples, spacing dx/K, dy/K; detail sample (X mod w, Y mod h) is
    /// added at composed sample (X, Y).
    #[arg(long, value_name = "K", requires = "detail")]
    pub detail_factor: Option<u32>,
    /// Size WxH of a raw-f32 detail file.
    #[arg(long, value_name = "WxH", value_parser = crate::args::parse_size, requires = "detail")]
    pub detail_size: Option<(u32, u32)>,
    /// World units per stored detail value (default 1).
    #[arg(
        long,
        default_value_t = 1.0,
        allow_negative_numbers = true,
        requires = "detail"
    )]
    pub detail_z_scale: f32,
    /// World height added to every detail value (default 0).
    #[arg(
        long,
        default_value_t = 0.0,
        allow_negative_numbers = true,
        requires = "detail"
    )]
    pub detail_z_offset: f32,
    /// Constant error of every detail level (world z units), LOD by distance only; default: a
    /// true bound measured from the base's bilinear twist near each vertex and the detail map
    /// (DetailBounds::measure_local).
    #[arg(long, value_name = "E", requires = "detail")]
    pub detail_error: Option<f32>,
}

/// The `relief mesh` options the detail path uses (from `MeshArgs`).
pub struct Common<'a> {
    /// The base DEM.
    pub dem: &'a DemArgs,
    /// `--eye`.
    pub eye: Option<Vec3>,
    /// `--target`.
    pub target: Option<Vec3>,
    /// `--fov`.
    pub fov: f32,
    /// `--size`.
    pub size: Option<(u32, u32)>,
    /// `--pixel-error`.
    pub pixel_error: Option<f32>,
    /// `--no-cull`.
    pub no_cull: bool,
    /// `--lazy-levels`.
    pub lazy_levels: u32,
    /// `--layout compact`.
    pub compact: bool,
    /// `--max-error` given (not allowed with detail levels).
    pub max_error: bool,
    /// `--method tin` (not allowed with detail levels).
    pub tin: bool,
    /// `--out`.
    pub out: &'a Path,
    /// `--json`.
    pub json: bool,
}

const VIEW_ONLY: &str =
    "relief mesh --detail is view-dependent: give --eye/--target/--size/--pixel-error (not --max-error or --method tin)";

/// Runs `relief mesh --detail ...`.
pub fn run(d: &DetailArgs, a: Common<'_>) -> CliResult {
    let Some(path) = &d.detail else {
        return Err(CliError("--detail-* options need --detail PATH".into()));
    };
    if a.max_error || a.tin {
        return Err(CliError(VIEW_ONLY.into()));
    }
    let (Some(eye), Some(target), Some((iw, ih)), Some(tau)) =
        (a.eye, a.target, a.size, a.pixel_error)
    else {
        return Err(CliError(VIEW_ONLY.into()));
    };
    let factor = d
        .detail_factor
        .ok_or_else(|| CliError("--detail needs --detail-factor K (a power of two)".into()))?;
    let (dem, _) = a.dem.load()?;
    let base = dem.heightfield()?;
    let ddem = read_dem(
        path,
        &ReadOptions {
            width: d.detail_size.map(|s| s.0),
            height: d.detail_size.map(|s| s.1),
            ..Default::default()
        },
    )?;
    let dscale = Scale::default()
        .with_z_scale(d.detail_z_scale)
        .with_z_offset(d.detail_z_offset);
    let detail = Heightfield::with_scale(&ddem.samples, ddem.width, ddem.height, dscale)?;
    let c = Composed::new(base, detail, factor)?;
    let (w, h) = (dem.width, dem.height);
    let n = hierarchy_len(w, h);
    let mut errors_f = vec![0.0f32; if a.compact { 0 } else { n }];
    let mut radii = vec![0.0f32; if a.compact { 0 } else { n }];
    let mut errors_c = vec![0u16; if a.compact { n } else { 0 }];
    let t0 = Instant::now();
    let hier: Hierarchy<'_> = if a.compact {
        preprocess_compact(&base, &mut errors_c)?
    } else {
        preprocess(&base, &mut errors_f, &mut radii)?
    };
    let preprocess_ms = t0.elapsed().as_secs_f64() * 1e3;
    let t1 = Instant::now();
    let mut local = vec![
        0.0f32;
        if d.detail_error.is_some() {
            0
        } else {
            local_bounds_len(w, h)
        }
    ];
    let bounds = match d.detail_error {
        Some(e) => DetailBounds::constant(&c, e)?,
        None => DetailBounds::measure_local(&c, &mut local)?,
    };
    let detail_bounds_ms = t1.elapsed().as_secs_f64() * 1e3;
    let cam = Camera::new(eye, target, a.fov, iw, ih)?;
    let view = View::new(&cam, tau)?
        .with_culling(!a.no_cull)
        .with_lazy_levels(a.lazy_levels);
    let dr = DetailRefiner::new(&hier, &c, &bounds, &view)?;
    let t2 = Instant::now();
    let t = dr.triangle_count();
    // Vertices of a connected mesh are about half its triangles; retry once with the length the
    // capacity error names (at most 3 per triangle) if this guess is short.
    let mut scratch = vec![0u64; detail_scratch_len(t + t / 2 + 64)];
    let counts = match dr.count(&mut scratch) {
        Ok(c) => c,
        Err(relief_core::Error::BufferTooSmall { needed, .. }) => {
            scratch = vec![0u64; needed];
            dr.count(&mut scratch)?
        }
        Err(e) => return Err(e.into()),
    };
    let mut vertices = vec![[0.0f32; 3]; counts.vertices];
    let mut triangles = vec![[0u32; 3]; counts.triangles];
    dr.triangles(&mut scratch, &mut vertices, &mut triangles)?;
    let refine_ms = t2.elapsed().as_secs_f64() * 1e3;
    relief_io::write_obj(a.out, &vertices, &triangles)?;
    let g = dr.grid();
    let ranges = level_ranges(&counts, factor);
    if a.json {
        let errs: Vec<f32> = (0..bounds.detail_levels())
            .filter_map(|j| bounds.error(j))
            .collect();
        let v = serde_json::json!({
            "width": w,
            "height": h,
            "mode": "view-dependent",
            "layout": if a.compact { "compact" } else { "full" },
            "detail_width": ddem.width,
            "detail_height": ddem.height,
            "detail_factor": factor,
            "effective_width": g.width(),
            "effective_height": g.height(),
            "effective_resolution": format!("{}x{}", g.width(), g.height()),
            "effective_dx": c.scale().dx,
            "effective_dy": c.scale().dy,
            "levels": g.levels(),
            "base_levels": dr.base_levels(),
            "finest_level": counts.finest_level(),
            "vertices": counts.vertices,
            "triangles": counts.triangles,
            "base_triangles": counts.base_triangles(),
            "detail_triangles": counts.detail_triangles(),
            "triangles_by_level_range": ranges.iter().map(|r| serde_json::json!({
                "levels": [r.0, r.1],
                "cell_fraction": r.2,
                "triangles": r.3,
            })).collect::<Vec<_>>(),
            "detail_errors": errs,
            "detail_errors_measured": bounds.is_measured(),
            "detail_bounds": if bounds.is_local() { "local" } else { "constant" },
            "max_error_measured": serde_json::Value::Null,
            "preprocess_ms": preprocess_ms,
            "detail_bounds_ms": detail_bounds_ms,
            "refine_ms": refine_ms,
            "out": a.out.display().to_string(),
        });
        print_out(&format!("{v}\n"))
    } else {
        let mut lines = String::new();
        for r in &ranges {
            lines.push_str(&format!(
                "  levels {:>2}-{:<2}  {:<8} {}\n",
                r.0, r.1, r.2, r.3
            ));
        }
        print_out(&format!(
            "{out}\n  mode        view-dependent, detail levels\n  base        {w} x {h}\n  detail      {dw} x {dh}, factor {factor}\n  effective   {ew} x {eh} (spacing {edx} x {edy})\n  vertices    {v}\n  triangles   {t} ({bt} base, {dt} detail)\n{lines}  preprocess  {preprocess_ms:.1} ms (+ {detail_bounds_ms:.1} ms detail bounds)\n  refine      {refine_ms:.1} ms\n",
            out = a.out.display(),
            dw = ddem.width,
            dh = ddem.height,
            ew = g.width(),
            eh = g.height(),
            edx = c.scale().dx,
            edy = c.scale().dy,
            v = counts.vertices,
            t = counts.triangles,
            bt = counts.base_triangles(),
            dt = counts.detail_triangles(),
        ))
    }
}

/// Triangle counts grouped by level range: the base levels, then two levels per halving of the
/// base cell (`cell_fraction` 1/2, 1/4, ... 1/K: the finest composed spacing the range reaches).
fn level_ranges(c: &DetailCounts, factor: u32) -> Vec<(u32, u32, String, usize)> {
    let sum = |lo: u32, hi: u32| -> usize {
        c.by_level
            .iter()
            .skip(lo as usize)
            .take((hi - lo + 1) as usize)
            .sum()
    };
    let mut out = vec![(0, c.base_levels, "base".to_string(), sum(0, c.base_levels))];
    let steps = factor.trailing_zeros();
    for i in 0..steps {
        let (lo, hi) = (c.base_levels + 2 * i + 1, c.base_levels + 2 * i + 2);
        out.push((lo, hi, format!("1/{}", 1u64 << (i + 1)), sum(lo, hi)));
    }
    out
}
