//! `relief rbf`: adaptive grid + truncated Gaussian RBF approximation of a DEM (seed 002,
//! section 4). Writes the cells as CSV and the approximation at every grid sample as raw f32.

use crate::args::DemArgs;
use crate::{print_out, CliError, CliResult};
use clap::Args;
use relief_core::rbf::{
    adaptive_grid_bound, build_adaptive_grid, AdaptiveGrid, Cell, GridOptions, InfluenceSets, Rbf,
    RbfOptions,
};
use relief_core::Terrain;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

/// Options of `relief rbf`.
#[derive(Debug, Args)]
pub struct RbfArgs {
    #[command(flatten)]
    dem: DemArgs,
    /// Largest deviation of a sample from its cell's mean height (world z units).
    #[arg(long, value_name = "E", allow_negative_numbers = true)]
    max_error: f32,
    /// Smallest cell size in samples (a power of two).
    #[arg(long, value_name = "C")]
    min_cell: u32,
    /// Largest cell size in samples (a power of two, at most 32768).
    #[arg(long, value_name = "C2")]
    max_cell: u32,
    /// Width of the Gaussians relative to the cell size.
    #[arg(
        long,
        value_name = "S",
        default_value_t = 1.0,
        allow_negative_numbers = true
    )]
    sigma: f32,
    /// Where to write the cells, one `x,y,size,value` line each (value in world units).
    #[arg(long, value_name = "PATH")]
    cells_out: PathBuf,
    /// Where to write the approximation at every grid sample (little-endian f32, row-major,
    /// world units).
    #[arg(long, value_name = "PATH")]
    out: PathBuf,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

/// Runs `relief rbf`.
pub fn run(a: &RbfArgs) -> CliResult {
    let grid_opts = GridOptions::default()
        .with_max_error(a.max_error)
        .with_cells(a.min_cell, a.max_cell);
    grid_opts.validate()?;
    let rbf_opts = RbfOptions::default().with_sigma(a.sigma);
    rbf_opts.validate()?;
    let (dem, _) = a.dem.load()?;
    let hf = dem.heightfield()?;
    let (w, h) = (hf.width(), hf.height());
    let scale = hf.scale();

    let r = approximate(&hf, &grid_opts, &rbf_opts)?;
    let (cells, entries_len, build_ms, eval_ms) = (&r.cells, r.entries, r.build_ms, r.eval_ms);
    let (max_diff, rms_diff) = (r.max_diff, r.rms_diff);
    let approx: Vec<f32> = r.approx.iter().map(|v| v + scale.z_offset).collect();

    relief_io::write_atomic(&a.cells_out, |wr: &mut dyn Write| {
        for c in cells {
            writeln!(
                wr,
                "{},{},{},{}",
                c.x,
                c.y,
                c.size,
                c.value + scale.z_offset
            )?;
        }
        Ok(())
    })?;
    relief_io::write_raw_f32(&a.out, &approx)?;

    let (min_size, max_size) = r.size_range;
    if a.json {
        let v = serde_json::json!({
            "width": w,
            "height": h,
            "cells": cells.len(),
            "min_cell_used": min_size,
            "max_cell_used": max_size,
            "influence_entries": entries_len,
            "sigma": a.sigma,
            "max_error": a.max_error,
            "max_diff": max_diff,
            "rms_diff": rms_diff,
            "build_ms": build_ms,
            "eval_ms": eval_ms,
        });
        print_out(&format!("{v}\n"))
    } else {
        print_out(&format!(
            "{w} x {h} samples -> {cells} cells (sizes {min_size}..{max_size}), {entries_len} influence entries\n  sigma {sigma}, max error {e}\n  max |approx - dem| {max_diff:.4}, rms {rms_diff:.4}\n  build {build_ms:.1} ms, eval {eval_ms:.1} ms\n",
            cells = cells.len(),
            sigma = a.sigma,
            e = a.max_error,
        ))
    }
}

/// An RBF approximation of a whole DEM and what it cost.
pub(crate) struct Approximation {
    /// The adaptive grid's cells (values in local units).
    pub cells: Vec<Cell>,
    /// Smallest and largest cell size used.
    pub size_range: (u32, u32),
    /// Influence-set entries.
    pub entries: usize,
    /// The approximation at every grid sample, row-major, local units (`z_offset` not added).
    pub approx: Vec<f32>,
    /// Grid, index map and influence sets, milliseconds.
    pub build_ms: f64,
    /// Evaluation at every sample, milliseconds.
    pub eval_ms: f64,
    /// Largest `|approx - dem|` over all samples.
    pub max_diff: f64,
    /// RMS of `approx - dem` over all samples.
    pub rms_diff: f64,
}

/// Builds the adaptive grid and influence sets for `hf` and evaluates the RBF at every sample
/// (shared by `relief rbf` and the report).
pub(crate) fn approximate(
    hf: &relief_core::Heightfield<'_, f32>,
    grid_opts: &GridOptions,
    rbf_opts: &RbfOptions,
) -> CliResult<Approximation> {
    let (w, h) = (hf.width(), hf.height());
    let t0 = Instant::now();
    let bound = adaptive_grid_bound(w, h).ok_or_else(|| CliError("grid too large".into()))?;
    let mut cells = vec![Cell::default(); bound];
    let n = build_adaptive_grid(hf, grid_opts, &mut cells)?;
    cells.truncate(n);
    let mut index = vec![0u32; bound];
    let grid = AdaptiveGrid::new(w, h, &cells, &mut index)?;
    let mut offsets = vec![0u32; InfluenceSets::offsets_len(&grid)];
    let entries_len = InfluenceSets::entries_len(&grid, rbf_opts)?;
    let mut entries = Vec::new();
    entries
        .try_reserve_exact(entries_len)
        .map_err(|_| CliError(format!("cannot allocate {entries_len} influence entries")))?;
    entries.resize(entries_len, 0u32);
    let sets = InfluenceSets::build(&grid, rbf_opts, &mut offsets, &mut entries)?;
    let rbf = Rbf::new(grid, sets, rbf_opts)?;
    let build_ms = t0.elapsed().as_secs_f64() * 1e3;
    let t1 = Instant::now();
    let mut approx = Vec::with_capacity(bound);
    for y in 0..h {
        for x in 0..w {
            approx.push(rbf.eval(relief_core::glam::Vec2::new(x as f32, y as f32))?);
        }
    }
    let eval_ms = t1.elapsed().as_secs_f64() * 1e3;
    let (mut max_diff, mut sum_sq) = (0.0f64, 0.0f64);
    for (k, v) in approx.iter().enumerate() {
        let (x, y) = ((k % w as usize) as u32, (k / w as usize) as u32);
        let d = f64::from(*v) - f64::from(hf.local_z(x, y));
        max_diff = max_diff.max(d.abs());
        sum_sq += d * d;
    }
    let size_range = rbf.grid().size_range();
    Ok(Approximation {
        cells,
        size_range,
        entries: entries_len,
        rms_diff: (sum_sq / approx.len().max(1) as f64).sqrt(),
        approx,
        build_ms,
        eval_ms,
        max_diff,
    })
}
