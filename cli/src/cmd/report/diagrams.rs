//! Diagrams from relief-skia that explain the results above: the run-length DDA on seed 001's
//! example line, a view-dependent refinement seen from above, and the RBF's adaptive cells.

use super::model::{Figure, Section};
use super::Ctx;
use crate::{CliError, CliResult};
use relief_core::glam::Vec3;
use relief_core::rbf::{
    adaptive_grid_bound, build_adaptive_grid, AdaptiveGrid, Cell, GridOptions, InfluenceSets, Rbf,
    RbfOptions,
};
use relief_core::refine::{preprocess, vertex_bound, Criterion, View};
use relief_core::{Camera, Heightfield, Terrain};
use relief_skia::dda::DdaSpec;
use relief_skia::refine::RefineInput;
use relief_skia::{hillshade, DiagramOptions, HillshadeOptions};
use serde_json::json;

fn err(e: impl std::fmt::Display) -> CliError {
    CliError(format!("diagram: {e}"))
}

/// A crop of at most 129 x 129 samples from the DEM's centre, so diagram details stay visible.
fn crop(ctx: &Ctx<'_>) -> (Vec<f32>, u32, u32) {
    let d = ctx.dem;
    let (w, h) = (d.width.min(129), d.height.min(129));
    let (x0, y0) = ((d.width - w) / 2, (d.height - h) / 2);
    let mut v = Vec::with_capacity((w * h) as usize);
    for y in y0..y0 + h {
        let r = (y * d.width + x0) as usize;
        v.extend_from_slice(&d.samples[r..r + w as usize]);
    }
    (v, w, h)
}

/// The section.
pub fn diagrams(ctx: &Ctx<'_>) -> CliResult<Section> {
    let mut s = Section::new("diagrams", "Diagrams of what the algorithms did");
    s.text.push(
        "Drawn by relief-skia from the core's own state (never re-computed in the adapter).".into(),
    );
    let opts = DiagramOptions::default().with_max_size(640);

    let spec = DdaSpec::seed001_figure6();
    let runs = relief_skia::dda::runs(&spec).map_err(err)?;
    let pm = relief_skia::dda::dda(&spec, &opts).map_err(err)?;
    relief_skia::save_png(&pm, &ctx.fig("diagram_dda.png")).map_err(err)?;
    s.figures.push(Figure {
        file: "diagram_dda.png".into(),
        caption: format!("Cell DDA against the run-length DDA on seed 001's line y = 17/41 x: {} runs instead of {} cell steps", runs.len(), 41 + 16),
    });

    let (samples, w, h) = crop(ctx);
    let hf = Heightfield::with_scale(&samples, w, h, ctx.dem.scale)?;
    let shade = hillshade(&hf, &HillshadeOptions::default()).map_err(err)?;
    let under = opts.with_background(Some(&shade));
    let (mut e, mut r) = (
        vec![0.0f32; vertex_bound(w, h)],
        vec![0.0f32; vertex_bound(w, h)],
    );
    let hier = preprocess(&hf, &mut e, &mut r)?;
    let ext = hf.extent();
    let (lo, hi) = (ctx.dem.stats().min as f32, ctx.dem.stats().max as f32);
    let cam = Camera::new(
        Vec3::new(0.2 * ext.x, -0.05 * ext.y, hi + 0.05 * ext.x),
        Vec3::new(0.6 * ext.x, 0.8 * ext.y, lo),
        50.0,
        640,
        480,
    )?;
    let input = RefineInput::new(&hf, &hier, Criterion::View(View::new(&cam, 2.0)?))
        .with_camera(Some(&cam))
        .with_circle_level(Some(6));
    let pm = relief_skia::refine::refine(&input, &under).map_err(err)?;
    relief_skia::save_png(&pm, &ctx.fig("diagram_refine.png")).map_err(err)?;
    s.figures.push(Figure {
        file: "diagram_refine.png".into(),
        caption: format!("View-dependent refinement (2 pixels) of a {w} x {h} crop seen from above: triangles by level, the frustum wedge, culled regions and lazily accepted vertices, bounding circles of level 6"),
    });

    let bound = adaptive_grid_bound(w, h).ok_or_else(|| err("grid too large"))?;
    let mut cells = vec![Cell::default(); bound];
    let n = build_adaptive_grid(
        &hf,
        &GridOptions::default()
            .with_max_error(10.0)
            .with_cells(1, 32),
        &mut cells,
    )?;
    let mut index = vec![0u32; bound];
    let grid = AdaptiveGrid::new(w, h, &cells[..n], &mut index)?;
    let ro = RbfOptions::default();
    let mut offsets = vec![0u32; InfluenceSets::offsets_len(&grid)];
    let mut entries = vec![0u32; InfluenceSets::entries_len(&grid, &ro)?];
    let sets = InfluenceSets::build(&grid, &ro, &mut offsets, &mut entries)?;
    let rbf = Rbf::new(grid, sets, &ro)?;
    let biggest = (0..n).max_by_key(|&i| cells[i].size).unwrap_or(0);
    let pm = relief_skia::rbf::rbf(&rbf, &[biggest, n / 2], &under).map_err(err)?;
    relief_skia::save_png(&pm, &ctx.fig("diagram_rbf.png")).map_err(err)?;
    s.figures.push(Figure {
        file: "diagram_rbf.png".into(),
        caption: format!("The RBF's adaptive cells (E = 10 m, sizes 1..32) on the crop: {n} cells, with the influence circles of two of them"),
    });
    s.data = json!({"dda_runs": runs.len(), "crop": [w, h], "rbf_cells": n});
    s.summary = format!("{} diagrams", s.figures.len());
    Ok(s)
}
