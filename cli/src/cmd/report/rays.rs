//! The report's ray section: every traversal method and surface against the exact `triangles`
//! trace, and the march's samples sweep, on one camera over the DEM.

use super::model::{num, Figure, Section, Table};
use super::plot::{self, Chart, Series};
use super::Ctx;
use crate::{CliError, CliResult};
use rayon::prelude::*;
use relief_core::glam::Vec3;
use relief_core::ray::{MarchOptions, MaxMip, Ray, RayTracer, RunAccel, Trace};
use relief_core::{Camera, Heightfield, Surface, Terrain};
use serde_json::json;
use std::time::Instant;

/// One rendered depth image: distance and hit cell per pixel.
struct Render {
    depth: Vec<f32>,
    cell: Vec<[u32; 2]>,
    ms: f64,
}

#[derive(Clone, Copy, PartialEq)]
enum Method {
    CellDda,
    RunDda,
    Maxmip,
    March(u32),
}

impl Method {
    fn name(self) -> String {
        match self {
            Method::CellDda => "cell-dda".into(),
            Method::RunDda => "run-dda".into(),
            Method::Maxmip => "maxmip".into(),
            Method::March(n) => format!("march-{n}"),
        }
    }
}

/// The report's camera: from just beyond the first row, above the highest peak, looking across
/// the DEM at a shallow angle (so rays graze the far terrain).
pub fn camera(hf: &Heightfield<'_, f32>, w: u32, h: u32) -> CliResult<Camera> {
    let ext = hf.extent();
    let (lo, hi) = (0..hf.height())
        .flat_map(|y| (0..hf.width()).map(move |x| (x, y)))
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), (x, y)| {
            let z = hf.z(x, y);
            (a.min(z), b.max(z))
        });
    let span = ext.x.max(ext.y);
    let eye = Vec3::new(0.5 * ext.x, -0.1 * ext.y, hi + 0.05 * span);
    let target = Vec3::new(0.5 * ext.x, 0.7 * ext.y, 0.5 * (lo + hi));
    Ok(Camera::new(eye, target, 50.0, w, h)?)
}

fn render(
    hf: &Heightfield<'_, f32>,
    cam: &Camera,
    surface: Surface,
    method: Method,
    run: &RunAccel<'_>,
    mipv: &MaxMip<'_>,
) -> CliResult<Render> {
    let tracer = RayTracer::new(hf, surface);
    let (w, h) = (cam.width as usize, cam.height as usize);
    let mut depth = vec![f32::INFINITY; w * h];
    let mut cell = vec![[u32::MAX; 2]; w * h];
    let t = Instant::now();
    depth
        .par_chunks_mut(w)
        .zip(cell.par_chunks_mut(w))
        .enumerate()
        .try_for_each(|(j, (drow, crow))| -> Result<(), String> {
            for i in 0..w {
                let (o, d) = cam.ray(i as u32, j as u32);
                let ray = Ray::new(o, d).map_err(|e| e.to_string())?;
                let tr: Trace = match method {
                    Method::CellDda => tracer.trace_cell_dda(&ray),
                    Method::RunDda => tracer.trace_run_dda(&ray, run).map_err(|e| e.to_string())?,
                    Method::Maxmip => tracer.trace_maxmip(&ray, mipv).map_err(|e| e.to_string())?,
                    Method::March(n) => {
                        tracer
                            .trace_march(&ray, &MarchOptions::default().with_samples(n))
                            .map_err(|e| e.to_string())?
                            .trace
                    }
                };
                if let Some(hit) = tr.hit {
                    drow[i] = hit.t as f32;
                    crow[i] = hit.cell;
                }
            }
            Ok(())
        })
        .map_err(CliError)?;
    Ok(Render {
        depth,
        cell,
        ms: t.elapsed().as_secs_f64() * 1e3,
    })
}

/// Errors of `r` against the reference: mean, 95th percentile and max relative depth error over
/// pixels where both hit, and the share of pixels whose hit cell (or hit/miss) differs.
fn compare(r: &Render, reference: &Render) -> (f64, f64, f64, f64) {
    let mut rel = Vec::new();
    let mut differ = 0usize;
    for k in 0..r.depth.len() {
        let (a, b) = (r.depth[k], reference.depth[k]);
        if a.is_finite() != b.is_finite() || r.cell[k] != reference.cell[k] {
            differ += 1;
        }
        if a.is_finite() && b.is_finite() && b > 0.0 {
            rel.push((f64::from(a) - f64::from(b)).abs() / f64::from(b));
        }
    }
    rel.sort_by(f64::total_cmp);
    let mean = rel.iter().sum::<f64>() / rel.len().max(1) as f64;
    let p95 = rel
        .get(((rel.len() as f64 * 0.95) as usize).min(rel.len().saturating_sub(1)))
        .copied()
        .unwrap_or(0.0);
    let max = rel.last().copied().unwrap_or(0.0);
    (mean, p95, max, differ as f64 / r.depth.len().max(1) as f64)
}

/// Per-pixel relative depth error of `r` against `reference`; a hit/miss disagreement counts 1.
fn relative_error(r: &Render, reference: &Render) -> Vec<f32> {
    r.depth
        .iter()
        .zip(&reference.depth)
        .map(|(a, b)| {
            if a.is_finite() && b.is_finite() {
                (a - b).abs() / b
            } else if a.is_finite() != b.is_finite() {
                1.0
            } else {
                0.0
            }
        })
        .collect()
}

fn depth_image(ctx: &Ctx<'_>, name: &str, r: &Render, w: u32, h: u32) -> CliResult {
    let finite: Vec<f32> = r.depth.iter().copied().filter(|d| d.is_finite()).collect();
    let lo = finite.iter().copied().fold(f32::INFINITY, f32::min);
    let hi = finite.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    plot::image(&ctx.fig(name), w, h, &r.depth, lo.into(), hi.into(), |t| {
        if t.is_finite() {
            plot::viridis(1.0 - t)
        } else {
            [235, 235, 235]
        }
    })
}

/// The section.
pub fn rays(ctx: &Ctx<'_>) -> CliResult<Section> {
    let hf = ctx.dem.heightfield()?;
    let (w, h) = if ctx.quick { (160, 120) } else { (400, 300) };
    let cam = camera(&hf, w, h)?;
    let t = Instant::now();
    let mut accel = vec![
        0.0f32;
        RunAccel::len(hf.width(), hf.height())
            .ok_or_else(|| CliError("grid too large".into()))?
    ];
    let accel = RunAccel::build(&hf, &mut accel)?;
    let run_ms = t.elapsed().as_secs_f64() * 1e3;
    let t = Instant::now();
    let mut mip = vec![
        0.0f32;
        MaxMip::len(hf.width(), hf.height())
            .ok_or_else(|| CliError("grid too large".into()))?
    ];
    let mip = MaxMip::build(&hf, &mut mip)?;
    let mip_ms = t.elapsed().as_secs_f64() * 1e3;

    let reference = render(&hf, &cam, Surface::Triangles, Method::CellDda, &accel, &mip)?;
    let mut s = Section::new("rays", "Ray casting: accuracy against time");
    let threads = rayon::current_num_threads();
    s.text.push(format!(
        "A {w} x {h} camera over the DEM, rows traced in parallel on {threads} threads. The reference is the exact `triangles` surface traced with the cell DDA; errors are relative depth errors over pixels where both hit, and the share of pixels whose hit cell (or hit/miss) differs from the reference. Preprocessing: run-length DDA row/column maxima {run_ms:.1} ms, maximum mipmap {mip_ms:.1} ms."
    ));
    let mut t = Table::new(
        "Every method and surface against exact triangles",
        &[
            "method",
            "surface",
            "ms",
            "M rays/s",
            "mean rel. error",
            "p95 rel. error",
            "max rel. error",
            "pixels on another cell",
        ],
    );
    let mut rows = Vec::new();
    let surfaces = [
        (Surface::Triangles, "triangles"),
        (Surface::Bilinear, "bilinear"),
        (Surface::Plane, "plane"),
        (Surface::Nearest, "nearest"),
    ];
    let rays = f64::from(w * h);
    let mut shown = None;
    for (surf, sname) in surfaces {
        for m in [Method::CellDda, Method::RunDda, Method::Maxmip] {
            let r = render(&hf, &cam, surf, m, &accel, &mip)?;
            let (mean, p95, max, differ) = compare(&r, &reference);
            t.row(vec![
                m.name(),
                sname.into(),
                num(r.ms, 1),
                num(rays / r.ms / 1e3, 2),
                num(mean, 6),
                num(p95, 6),
                num(max, 6),
                format!("{:.3}%", differ * 100.0),
            ]);
            rows.push(json!({"method": m.name(), "surface": sname, "ms": r.ms, "mean_rel": mean, "p95_rel": p95, "max_rel": max, "differ": differ}));
            if surf == Surface::Nearest && m == Method::CellDda {
                shown = Some(r);
            }
        }
    }
    s.tables.push(t);

    // The march's samples sweep.
    let counts: &[u32] = if ctx.quick {
        &[8, 32, 128]
    } else {
        &[8, 16, 32, 64, 128, 256, 512]
    };
    let mut mt = Table::new(
        "Linear + binary search march (triangles) against exact triangles",
        &[
            "samples",
            "ms",
            "mean rel. error",
            "p95 rel. error",
            "max rel. error",
            "pixels on another cell",
        ],
    );
    let (mut err_pts, mut time_pts) = (Vec::new(), Vec::new());
    let mut worst = None;
    for &n in counts {
        let r = render(
            &hf,
            &cam,
            Surface::Triangles,
            Method::March(n),
            &accel,
            &mip,
        )?;
        let (mean, p95, max, differ) = compare(&r, &reference);
        mt.row(vec![
            n.to_string(),
            num(r.ms, 1),
            num(mean, 6),
            num(p95, 6),
            num(max, 6),
            format!("{:.3}%", differ * 100.0),
        ]);
        err_pts.push((f64::from(n), differ * 100.0));
        time_pts.push((f64::from(n), r.ms));
        rows.push(json!({"method": format!("march-{n}"), "surface": "triangles", "ms": r.ms, "mean_rel": mean, "p95_rel": p95, "max_rel": max, "differ": differ}));
        if worst.is_none() {
            worst = Some(r);
        }
    }
    s.tables.push(mt);
    plot::line_chart(
        &ctx.fig("rays_march_sweep.png"),
        640,
        420,
        &Chart {
            title: "March: wrong pixels and time against samples",
            x_label: "samples per ray",
            y_label: "% pixels on another cell / ms",
            log_x: true,
            log_y: true,
            series: &[
                Series {
                    label: "% pixels on another cell".into(),
                    points: err_pts,
                },
                Series {
                    label: "time (ms)".into(),
                    points: time_pts,
                },
            ],
        },
    )?;
    s.figures.push(Figure {
        file: "rays_march_sweep.png".into(),
        caption: "The march's accuracy and cost against its sample count (log-log)".into(),
    });
    depth_image(ctx, "rays_depth_reference.png", &reference, w, h)?;
    s.figures.push(Figure {
        file: "rays_depth_reference.png".into(),
        caption: "Depth, exact triangles (near = yellow, far = purple, grey = miss)".into(),
    });
    if let Some(r) = worst {
        depth_image(ctx, "rays_depth_march.png", &r, w, h)?;
        s.figures.push(Figure {
            file: "rays_depth_march.png".into(),
            caption: format!("Depth, march with {} samples", counts[0]),
        });
        let err = relative_error(&r, &reference);
        plot::image(
            &ctx.fig("rays_error_march.png"),
            w,
            h,
            &err,
            0.0,
            0.05,
            plot::viridis,
        )?;
        s.figures.push(Figure { file: "rays_error_march.png".into(), caption: format!("Relative depth error of the {}-sample march, viridis 0 to 5% (hit/miss disagreements at full scale)", counts[0]) });
    }
    if let Some(r) = shown {
        let err = relative_error(&r, &reference);
        plot::image(
            &ctx.fig("rays_error_nearest.png"),
            w,
            h,
            &err,
            0.0,
            0.01,
            plot::viridis,
        )?;
        s.figures.push(Figure { file: "rays_error_nearest.png".into(), caption: "Relative depth error of the nearest (sample box) surface against triangles, viridis 0 to 1%".into() });
    }
    s.summary = format!("{} traces of {w} x {h}", rows.len() + 1);
    s.data = json!({"width": w, "height": h, "threads": threads, "run_accel_ms": run_ms, "maxmip_ms": mip_ms, "reference_ms": reference.ms, "runs": rows});
    Ok(s)
}
