//! The report's sections. Each measures what it shows, in this run.

use super::model::{num, Figure, Section, Table};
use super::plot::{self, Chart, Series};
use super::Ctx;
use crate::CliResult;
use relief_core::glam::Vec3;
use relief_core::rbf::{GridOptions, RbfOptions};
use relief_core::{normal_map, NormalMethod, Terrain};
use serde_json::json;
use std::time::Instant;

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// The DEM itself: size, range, a height image and a hillshade.
pub fn terrain(ctx: &Ctx<'_>) -> CliResult<Section> {
    let dem = ctx.dem;
    let hf = dem.heightfield()?;
    let st = dem.stats();
    let mut s = Section::new("terrain", "Terrain");
    let mut t = Table::new(
        "The DEM as read",
        &[
            "width", "height", "dx", "dy", "min (m)", "max (m)", "mean (m)",
        ],
    );
    let sc = hf.scale();
    t.row(vec![
        dem.width.to_string(),
        dem.height.to_string(),
        num(sc.dx.into(), 2),
        num(sc.dy.into(), 2),
        num(st.min, 1),
        num(st.max, 1),
        num(st.mean, 1),
    ]);
    s.tables.push(t);
    let world: Vec<f32> = (0..hf.height())
        .flat_map(|y| (0..hf.width()).map(move |x| (x, y)))
        .map(|(x, y)| hf.z(x, y))
        .collect();
    plot::image(
        &ctx.fig("terrain_height.png"),
        hf.width(),
        hf.height(),
        &world,
        st.min,
        st.max,
        plot::viridis,
    )?;
    s.figures.push(Figure {
        file: "terrain_height.png".into(),
        caption: format!(
            "Height, viridis from {:.0} m (dark) to {:.0} m (yellow)",
            st.min, st.max
        ),
    });
    let mut n = vec![Vec3::ZERO; world.len()];
    normal_map(&hf, NormalMethod::Sobel, &mut n)?;
    let sun = Vec3::new(-1.0, -1.0, 1.414).normalize();
    let shade: Vec<f32> = n.iter().map(|v| v.dot(sun).max(0.0)).collect();
    plot::image(
        &ctx.fig("terrain_hillshade.png"),
        hf.width(),
        hf.height(),
        &shade,
        0.0,
        1.0,
        |t| {
            let g = (t * 255.0).round() as u8;
            [g, g, g]
        },
    )?;
    s.figures.push(Figure {
        file: "terrain_hillshade.png".into(),
        caption: "Hillshade from relief-core Sobel normals, sun from the north-west at 45 degrees"
            .into(),
    });
    s.data = json!({"width": dem.width, "height": dem.height, "min": st.min, "max": st.max, "mean": st.mean});
    s.summary = format!(
        "{} x {}, {:.0}..{:.0} m",
        dem.width, dem.height, st.min, st.max
    );
    Ok(s)
}

/// Normals: what Sobel smoothing costs over central differences, and how far apart they are.
pub fn normals(ctx: &Ctx<'_>) -> CliResult<Section> {
    let hf = ctx.dem.heightfield()?;
    let count = (hf.width() * hf.height()) as usize;
    let reps = if ctx.quick { 3 } else { 5 };
    let mut out = [vec![Vec3::ZERO; count], vec![Vec3::ZERO; count]];
    let mut best = [f64::INFINITY; 2];
    for (k, m) in [NormalMethod::Central, NormalMethod::Sobel]
        .into_iter()
        .enumerate()
    {
        for _ in 0..reps {
            let t = Instant::now();
            normal_map(&hf, m, &mut out[k])?;
            best[k] = best[k].min(ms(t));
        }
    }
    let (mut sum, mut max) = (0.0f64, 0.0f64);
    for (a, b) in out[0].iter().zip(&out[1]) {
        let ang = f64::from(a.dot(*b).clamp(-1.0, 1.0)).acos().to_degrees();
        sum += ang;
        max = max.max(ang);
    }
    let mean = sum / count as f64;
    let mut s = Section::new("normals", "Normals");
    s.text.push(format!(
        "Central differences against the Sobel operator on all {count} samples (best of {reps} runs each). The angle between the two normals is what the smoothing changes."
    ));
    let mut t = Table::new(
        "Normal map cost and difference",
        &[
            "method",
            "ms",
            "ns per sample",
            "ratio to central",
            "mean angle to central (deg)",
            "max angle (deg)",
        ],
    );
    for (k, name) in ["central", "sobel"].iter().enumerate() {
        t.row(vec![
            (*name).into(),
            num(best[k], 2),
            num(best[k] * 1e6 / count as f64, 1),
            num(best[k] / best[0], 2),
            if k == 0 { "0".into() } else { num(mean, 3) },
            if k == 0 { "0".into() } else { num(max, 2) },
        ]);
    }
    s.tables.push(t);
    s.data = json!({"central_ms": best[0], "sobel_ms": best[1], "mean_angle_deg": mean, "max_angle_deg": max, "samples": count});
    s.summary = format!(
        "sobel {:.2}x central time, mean {:.2} deg apart",
        best[1] / best[0],
        mean
    );
    Ok(s)
}

/// RBF on adaptive grids: approximation error against sigma and the merge threshold E, and
/// what each costs.
pub fn rbf(ctx: &Ctx<'_>) -> CliResult<Section> {
    let hf = ctx.dem.heightfield()?;
    let (sigmas, errors): (&[f32], &[f32]) = if ctx.quick {
        (&[0.5, 1.0, 2.0], &[5.0, 20.0])
    } else {
        (&[0.25, 0.5, 1.0, 2.0], &[2.0, 5.0, 20.0, 50.0])
    };
    let (min_cell, max_cell) = (1, 64);
    let mut s = Section::new(
        "rbf",
        "RBF approximation (truncated Gaussians on adaptive grids)",
    );
    s.text.push(format!(
        "Seed 002's weighting: quadtree cells of {min_cell}..{max_cell} samples merged while every sample stays within E of the cell mean, each cell a truncated Gaussian of width sigma x cell size. Error is measured at every sample against the DEM (world metres). Build covers the grid and influence sets; eval covers evaluating all samples on one core."
    ));
    let mut t = Table::new(
        "RBF error and cost",
        &[
            "E (m)",
            "sigma",
            "cells",
            "build ms",
            "eval ms",
            "max error (m)",
            "RMS error (m)",
        ],
    );
    let mut rows = Vec::new();
    let mut by_sigma: Vec<Series> = errors
        .iter()
        .map(|e| Series {
            label: format!("E = {e} m"),
            points: vec![],
        })
        .collect();
    let mut cost: Vec<Series> = sigmas
        .iter()
        .map(|sg| Series {
            label: format!("sigma = {sg}"),
            points: vec![],
        })
        .collect();
    let mut best: Option<(f64, f32, f32, Vec<f32>)> = None;
    for (ei, &e) in errors.iter().enumerate() {
        for (si, &sigma) in sigmas.iter().enumerate() {
            let r = crate::cmd::rbf::approximate(
                &hf,
                &GridOptions::default()
                    .with_max_error(e)
                    .with_cells(min_cell, max_cell),
                &RbfOptions::default().with_sigma(sigma),
            )?;
            let (cells, max_err, rms_err) = (r.cells.len(), r.max_diff, r.rms_diff);
            t.row(vec![
                num(e.into(), 1),
                num(sigma.into(), 2),
                cells.to_string(),
                num(r.build_ms, 1),
                num(r.eval_ms, 1),
                num(max_err, 2),
                num(rms_err, 3),
            ]);
            by_sigma[ei].points.push((f64::from(sigma), rms_err));
            cost[si].points.push((r.build_ms + r.eval_ms, rms_err));
            rows.push(json!({"max_error": e, "sigma": sigma, "cells": cells, "build_ms": r.build_ms, "eval_ms": r.eval_ms, "max_err": max_err, "rms_err": rms_err}));
            if ei == 0 && best.as_ref().is_none_or(|b| rms_err < b.0) {
                best = Some((rms_err, e, sigma, r.approx));
            }
        }
    }
    s.tables.push(t);
    plot::line_chart(
        &ctx.fig("rbf_rms_vs_sigma.png"),
        640,
        420,
        &Chart {
            title: "RBF: RMS error against sigma",
            x_label: "sigma (x cell size)",
            y_label: "RMS error (m)",
            log_x: true,
            log_y: true,
            series: &by_sigma,
        },
    )?;
    s.figures.push(Figure {
        file: "rbf_rms_vs_sigma.png".into(),
        caption: "RMS error of the RBF approximation against sigma, one line per merge threshold E"
            .into(),
    });
    plot::line_chart(
        &ctx.fig("rbf_error_vs_time.png"),
        640,
        420,
        &Chart {
            title: "RBF: accuracy against time",
            x_label: "build + eval (ms)",
            y_label: "RMS error (m)",
            log_x: true,
            log_y: true,
            series: &cost,
        },
    )?;
    s.figures.push(Figure { file: "rbf_error_vs_time.png".into(), caption: "What smoothness and accuracy cost: RMS error against build + evaluation time, one line per sigma (points are thresholds E)".into() });
    if let Some((rms, e, sigma, approx)) = best {
        let (w, h) = (hf.width(), hf.height());
        let diff: Vec<f32> = approx
            .iter()
            .enumerate()
            .map(|(k, v)| (v - hf.local_z(k as u32 % w, k as u32 / w)).abs())
            .collect();
        let hi = diff.iter().fold(0.0f32, |a, b| a.max(*b)).max(1e-6);
        plot::image(
            &ctx.fig("rbf_error_map.png"),
            w,
            h,
            &diff,
            0.0,
            f64::from(hi),
            plot::viridis,
        )?;
        s.figures.push(Figure { file: "rbf_error_map.png".into(), caption: format!("|RBF - DEM| for E = {e} m, sigma = {sigma} (RMS {rms:.3} m), viridis from 0 to {hi:.2} m") });
    }
    s.summary = format!("{} runs over sigma x E", rows.len());
    s.data = json!({"runs": rows, "min_cell": min_cell, "max_cell": max_cell});
    Ok(s)
}
