//! `relief mesh ... --edit x,y,radius,depth`: crater edits applied through the incremental
//! update of the preprocessed data (relief_core::refine::update, issue 6 part 3), timed against a
//! full preprocessing of the edited map.

use crate::{print_out, CliError, CliResult};
use relief_core::glam::Vec3;
use relief_core::refine::{
    coverage_len, crater, hierarchy_len, preprocess_compact_pyramid, preprocess_pyramid,
    pyramid_len, scratch_len, update, update_compact, vertical_error_partial, Criterion, Hierarchy,
    PreprocessOptions, Refiner, Region, View,
};
use relief_core::{Camera, Heightfield};
use relief_io::Dem;
use std::path::Path;
use std::time::Instant;

/// Parses `x,y,radius,depth` (grid samples; depth in height units before `z_scale`).
pub fn parse_edit(s: &str) -> Result<[f32; 4], String> {
    let parts: Vec<&str> = s.split(',').collect();
    if parts.len() != 4 {
        return Err(format!("expected x,y,radius,depth, got '{s}'"));
    }
    let mut v = [0.0f32; 4];
    for (o, p) in v.iter_mut().zip(&parts) {
        *o = p
            .trim()
            .parse::<f32>()
            .map_err(|_| format!("'{p}' is not a number"))?;
        if !o.is_finite() {
            return Err(format!("'{p}' is not finite"));
        }
    }
    if v[2] <= 0.0 {
        return Err(format!("the crater radius must be positive, got {}", v[2]));
    }
    Ok(v)
}

/// Timings of an edited run.
#[derive(Debug, Clone, Copy)]
pub struct EditReport {
    /// Preprocessing of the map before the edits (pruned, with the pyramid).
    pub preprocess_ms: f64,
    /// All incremental updates together (one per edit, in order).
    pub update_ms: f64,
    /// A full pruned preprocessing of the edited map, for comparison.
    pub full_preprocess_ms: f64,
    /// Union of the regions the edits changed.
    pub region: Region,
}

/// Preprocesses `dem` into the arrays (full layout: `errors_f` and `radii`; else `errors_c`),
/// applies every crater to `dem.samples` followed by the incremental update, and returns the
/// updated hierarchy of the edited map.
pub fn apply<'a>(
    dem: &mut Dem,
    edits: &[[f32; 4]],
    full: bool,
    errors_f: &'a mut [f32],
    radii: &'a mut [f32],
    errors_c: &'a mut [u16],
) -> CliResult<(Hierarchy<'a>, EditReport)> {
    let (w, h, scale) = (dem.width, dem.height, dem.scale);
    let o = PreprocessOptions::default();
    let mut pyr = vec![0.0f32; pyramid_len(w, h)];
    let t0 = Instant::now();
    {
        let hf = Heightfield::with_scale(&dem.samples, w, h, scale)?;
        if full {
            preprocess_pyramid(&hf, &mut *errors_f, &mut *radii, &mut pyr, o)?;
        } else {
            preprocess_compact_pyramid(&hf, &mut *errors_c, &mut pyr)?;
        }
    }
    let preprocess_ms = t0.elapsed().as_secs_f64() * 1e3;
    let Some((last, rest)) = edits.split_last() else {
        return Err(CliError("--edit: no edit given".into()));
    };
    let mut update_ms = 0.0;
    let mut union: Option<Region> = None;
    let mut dig = |dem: &mut Dem, e: &[f32; 4]| -> CliResult<Region> {
        let r = crater(&mut dem.samples, w, h, e[0], e[1], e[2], e[3])?.ok_or_else(|| {
            CliError(format!(
                "--edit {},{},{},{} touches no sample of the {w} x {h} grid",
                e[0], e[1], e[2], e[3]
            ))
        })?;
        union = Some(union.map_or(r, |u| u.union(r)));
        Ok(r)
    };
    for e in rest {
        let region = dig(dem, e)?;
        let hf = Heightfield::with_scale(&dem.samples, w, h, scale)?;
        let t = Instant::now();
        if full {
            update(&hf, &mut *errors_f, &mut *radii, &mut pyr, region, o)?;
        } else {
            update_compact(&hf, &mut *errors_c, &mut pyr, region)?;
        }
        update_ms += t.elapsed().as_secs_f64() * 1e3;
    }
    let region = dig(dem, last)?;
    let hf = Heightfield::with_scale(&dem.samples, w, h, scale)?;
    let t = Instant::now();
    let hier = if full {
        update(&hf, errors_f, radii, &mut pyr, region, o)?
    } else {
        update_compact(&hf, errors_c, &mut pyr, region)?
    };
    update_ms += t.elapsed().as_secs_f64() * 1e3;
    // A full preprocessing of the edited map into fresh arrays, timed for comparison only.
    let n = dem.samples.len();
    let mut p2 = vec![0.0f32; pyr.len()];
    let t = Instant::now();
    if full {
        let (mut e2, mut r2) = (vec![0.0f32; n], vec![0.0f32; n]);
        preprocess_pyramid(&hf, &mut e2, &mut r2, &mut p2, o)?;
    } else {
        let mut e2 = vec![0u16; n];
        preprocess_compact_pyramid(&hf, &mut e2, &mut p2)?;
    }
    let full_preprocess_ms = t.elapsed().as_secs_f64() * 1e3;
    let region = union.unwrap_or(region);
    Ok((
        hier,
        EditReport {
            preprocess_ms,
            update_ms,
            full_preprocess_ms,
            region,
        },
    ))
}

/// What `relief mesh --edit` needs from the command line.
pub struct EditRun<'a> {
    /// The DEM options.
    pub dem: &'a crate::args::DemArgs,
    /// The craters, in order.
    pub edits: &'a [[f32; 4]],
    /// View-independent threshold.
    pub max_error: Option<f32>,
    /// View-dependent eye.
    pub eye: Option<Vec3>,
    /// View-dependent target.
    pub target: Option<Vec3>,
    /// Field of view, degrees.
    pub fov: f32,
    /// Image size.
    pub size: Option<(u32, u32)>,
    /// Pixel threshold.
    pub pixel_error: Option<f32>,
    /// No frustum culling.
    pub no_cull: bool,
    /// Lazy culling levels.
    pub lazy_levels: u32,
    /// Full layout (errors and radii).
    pub full: bool,
    /// Compact layout (bfloat16 errors); neither: an unsupported layout.
    pub compact: bool,
    /// Output OBJ.
    pub out: &'a Path,
    /// Print JSON.
    pub json: bool,
}

/// Runs `relief mesh --edit ...`: preprocess, edit + incremental update, mesh, measure.
pub fn run(r: &EditRun<'_>) -> CliResult {
    if !r.full && !r.compact {
        return Err(CliError(
            "--edit works on the full and compact layouts only".into(),
        ));
    }
    let (mode, criterion) = match (r.max_error, r.eye) {
        (Some(e), None) => ("view-independent", Criterion::MaxError(e)),
        (None, Some(eye)) => {
            let target = r
                .target
                .ok_or_else(|| CliError("--eye needs --target".into()))?;
            let (iw, ih) = r
                .size
                .ok_or_else(|| CliError("--eye needs --size WxH".into()))?;
            let tau = r
                .pixel_error
                .ok_or_else(|| CliError("--eye needs --pixel-error T".into()))?;
            let cam = Camera::new(eye, target, r.fov, iw, ih)?;
            (
                "view-dependent",
                Criterion::View(
                    View::new(&cam, tau)?
                        .with_culling(!r.no_cull)
                        .with_lazy_levels(r.lazy_levels),
                ),
            )
        }
        _ => {
            return Err(CliError(
                "relief mesh needs --max-error E, or --eye/--target/--size/--pixel-error".into(),
            ))
        }
    };
    let (mut dem, _) = r.dem.load()?;
    let (w, h) = (dem.width, dem.height);
    let n = hierarchy_len(w, h);
    let mut errors_f = vec![0.0f32; if r.full { n } else { 0 }];
    let mut radii = vec![0.0f32; if r.full { n } else { 0 }];
    let mut errors_c = vec![0u16; if r.full { 0 } else { n }];
    let (hier, rep) = apply(
        &mut dem,
        r.edits,
        r.full,
        &mut errors_f,
        &mut radii,
        &mut errors_c,
    )?;
    let hf = dem.heightfield()?;
    let refiner = Refiner::new(&hier, &hf, criterion)?;
    let mut scratch = vec![0u64; scratch_len(w, h)];
    let t1 = Instant::now();
    let counts = refiner.count(&mut scratch)?;
    let mut vertices = vec![[0.0f32; 3]; counts.vertices];
    let mut triangles = vec![[0u32; 3]; counts.triangles];
    refiner.triangles(&mut scratch, &mut vertices, &mut triangles)?;
    let refine_ms = t1.elapsed().as_secs_f64() * 1e3;
    let mut cov = vec![0u64; coverage_len(w, h)];
    let (max_err, uncovered) = vertical_error_partial(&hf, &vertices, &triangles, &mut cov)?;
    if mode == "view-independent" && uncovered.is_some() {
        return Err(CliError(format!(
            "internal error: the mesh leaves sample {uncovered:?} uncovered"
        )));
    }
    relief_io::write_obj(r.out, &vertices, &triangles)?;
    let reg = rep.region;
    if r.json {
        let v = serde_json::json!({
            "width": w,
            "height": h,
            "mode": mode,
            "layout": if r.full { "full" } else { "compact" },
            "bytes_per_vertex": hier.bytes_per_vertex(),
            "vertices": counts.vertices,
            "triangles": counts.triangles,
            "max_error_measured": max_err,
            "uncovered_samples": uncovered.map_or(0, |u| u.2),
            "edits": r.edits.len(),
            "edit_region": [reg.x0, reg.y0, reg.x1, reg.y1],
            "preprocess_ms": rep.preprocess_ms,
            "update_ms": rep.update_ms,
            "full_preprocess_ms": rep.full_preprocess_ms,
            "refine_ms": refine_ms,
            "out": r.out.display().to_string(),
        });
        print_out(&format!("{v}\n"))
    } else {
        print_out(&format!(
            "{out}\n  mode        {mode}\n  size        {w} x {h}\n  edits       {k} (samples [{x0}, {x1}] x [{y0}, {y1}])\n  update      {u:.3} ms (a full preprocessing of the edited map: {f:.1} ms)\n  vertices    {v}\n  triangles   {t}\n  max error   {max_err:.4}\n  preprocess  {p:.1} ms (before the edits)\n  refine      {refine_ms:.1} ms\n",
            out = r.out.display(),
            k = r.edits.len(),
            x0 = reg.x0,
            x1 = reg.x1,
            y0 = reg.y0,
            y1 = reg.y1,
            u = rep.update_ms,
            f = rep.full_preprocess_ms,
            v = counts.vertices,
            t = counts.triangles,
            p = rep.preprocess_ms,
        ))
    }
}
