//! `relief mesh ... --tile-size N --out-dir DIR`: the DEM cut into tiles of `N = 2^k + 1`
//! samples sharing their border rows and columns, each preprocessed and meshed on its own, made
//! to agree on their border vertices by the border protocol of relief_core::refine (export,
//! merge, re-nest until nothing is raised; issue 6 part 2), so the union of the tile meshes is
//! crack-free without skirts, view-independent (`--max-error`) or view-dependent (`--eye ...`:
//! one camera in map coordinates, each tile refined with its grid origin and the map's height
//! range), in the full or the compact layout. Optional skirts (`--skirt DEPTH`,
//! relief_core::refine::skirt) for users who want them.

use crate::{print_out, CliError, CliResult};
use relief_core::refine::{
    border_len, coverage_len, export_border, export_border_compact, hierarchy_len, merge_border,
    merge_border_compact, preprocess_compact_pyramid, preprocess_pyramid, pyramid_len, renest,
    renest_compact, scratch_len, skirt, skirt_bound, vertical_error_partial, Criterion,
    PreprocessOptions, Refiner, Side, View,
};
use relief_core::{Heightfield, Scale, Terrain};
use relief_io::Dem;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Errors and radii (full layout) or error codes (compact) one tile exported for one side.
type Exported = HashMap<(usize, usize, Side), (Vec<f32>, Vec<f32>, Vec<u16>)>;
/// One tile's OBJ: path, vertices, triangles.
type TileObj = (PathBuf, Vec<[f32; 3]>, Vec<[u32; 3]>);

/// One tile: its place in the map, its samples and its preprocessed data.
struct Tile {
    col: usize,
    row: usize,
    x0: u32,
    y0: u32,
    w: u32,
    h: u32,
    samples: Vec<f32>,
    errors: Vec<f32>,
    radii: Vec<f32>,
    /// Compact layout: bfloat16 error codes (then `errors` and `radii` are empty).
    codes: Vec<u16>,
}

/// Options of a tiled run.
pub struct TileOptions<'p> {
    /// Samples per tile side (`2^k + 1`).
    pub tile_size: u32,
    /// Largest vertical error (view-independent).
    pub max_error: f32,
    /// View-dependent refinement for this camera, in the map's world coordinates (each tile gets
    /// its grid origin and the map's height range), instead of `max_error`.
    pub view: Option<View>,
    /// Compact layout (bfloat16 errors, level-only radii) instead of the full one.
    pub compact: bool,
    /// Output folder.
    pub out_dir: &'p Path,
    /// Skirt depth (world z units) or none.
    pub skirt: Option<f32>,
    /// Print JSON.
    pub json: bool,
}

fn starts(n: u32, step: u32) -> Vec<u32> {
    (0..)
        .map(|k: u32| k.saturating_mul(step))
        .take_while(|&s| s.saturating_add(1) < n)
        .collect()
}

fn neighbour(rows: usize, cols: usize, r: usize, c: usize, side: Side) -> Option<(usize, usize)> {
    match side {
        Side::XMin => c.checked_sub(1).map(|c| (r, c)),
        Side::XMax => (c + 1 < cols).then_some((r, c + 1)),
        Side::YMin => r.checked_sub(1).map(|r| (r, c)),
        Side::YMax => (r + 1 < rows).then_some((r + 1, c)),
    }
}

/// Runs the border protocol on the tiles (row-major, `cols` per row); returns the rounds.
fn exchange(tiles: &mut [Tile], cols: usize, scale: Scale, compact: bool) -> CliResult<usize> {
    let rows = tiles.len() / cols.max(1);
    for round in 1..=64 {
        let mut out: Exported = HashMap::new();
        for t in tiles.iter() {
            for side in Side::ALL {
                if neighbour(rows, cols, t.row, t.col, side).is_some() {
                    let n = border_len(t.w, t.h, side);
                    if compact {
                        let mut bc = vec![0u16; n];
                        export_border_compact(t.w, t.h, &t.codes, side, &mut bc)?;
                        out.insert((t.row, t.col, side), (Vec::new(), Vec::new(), bc));
                    } else {
                        let (mut be, mut br) = (vec![0.0; n], vec![0.0; n]);
                        export_border(t.w, t.h, &t.errors, &t.radii, side, &mut be, &mut br)?;
                        out.insert((t.row, t.col, side), (be, br, Vec::new()));
                    }
                }
            }
        }
        let mut raised = 0usize;
        for t in tiles.iter_mut() {
            let mut merged = Vec::new();
            for side in Side::ALL {
                if let Some((nr, nc)) = neighbour(rows, cols, t.row, t.col, side) {
                    let Some((be, br, bc)) = out.get(&(nr, nc, side.opposite())) else {
                        continue;
                    };
                    let k = if compact {
                        merge_border_compact(t.w, t.h, &mut t.codes, side, bc)?
                    } else {
                        merge_border(t.w, t.h, &mut t.errors, &mut t.radii, side, be, br)?
                    };
                    if k > 0 {
                        merged.push(side);
                        raised += k;
                    }
                }
            }
            if !merged.is_empty() {
                let hf = Heightfield::with_scale(&t.samples, t.w, t.h, scale)?;
                if compact {
                    renest_compact(&hf, &mut t.codes, &merged)?;
                } else {
                    renest(
                        &hf,
                        &mut t.errors,
                        &mut t.radii,
                        &merged,
                        PreprocessOptions::default(),
                    )?;
                }
            }
        }
        if raised == 0 {
            return Ok(round);
        }
    }
    Err(CliError(
        "internal error: the tile border protocol did not settle in 64 rounds".into(),
    ))
}

/// Appends a skirt (relief_core::refine::skirt): for every mesh edge on the tile's border, two
/// triangles hanging `depth` below it (facing outwards).
fn add_skirt(
    v: &mut Vec<[f32; 3]>,
    t: &mut Vec<[u32; 3]>,
    w: u32,
    h: u32,
    s: Scale,
    depth: f32,
) -> CliResult<()> {
    let n = skirt_bound(w, h);
    let (mut sv, mut st) = (vec![[0.0f32; 3]; n], vec![[0u32; 3]; n]);
    let (nv, nt) = skirt(w, h, s, v, t, &Side::ALL, depth, &mut sv, &mut st)?;
    v.extend_from_slice(&sv[..nv]);
    t.extend_from_slice(&st[..nt]);
    Ok(())
}

/// Meshes `dem` in tiles and writes `DIR/tile_<col>_<row>.obj`.
pub fn run(dem: &Dem, o: &TileOptions<'_>) -> CliResult {
    let size = o.tile_size;
    if size < 3 || !(size - 1).is_power_of_two() {
        return Err(CliError(format!(
            "--tile-size must be 2^k + 1 samples (3, 5, 9, ..., 257, ...), got {size}"
        )));
    }
    if !(o.max_error.is_finite() && o.max_error >= 0.0) {
        return Err(CliError(format!(
            "--max-error must be finite and >= 0, got {}",
            o.max_error
        )));
    }
    if let Some(d) = o.skirt {
        if !(d.is_finite() && d > 0.0) {
            return Err(CliError(format!(
                "--skirt must be positive and finite, got {d}"
            )));
        }
    }
    std::fs::create_dir_all(o.out_dir)
        .map_err(|e| CliError(format!("cannot create {}: {e}", o.out_dir.display())))?;
    let (w, h, scale) = (dem.width, dem.height, dem.scale);
    let step = size - 1;
    let (xs, ys) = (starts(w, step), starts(h, step));
    let cols = xs.len();
    let t0 = Instant::now();
    let mut tiles = Vec::with_capacity(xs.len() * ys.len());
    for (row, &y0) in ys.iter().enumerate() {
        for (col, &x0) in xs.iter().enumerate() {
            let (tw, th) = (size.min(w - x0), size.min(h - y0));
            let mut samples = Vec::with_capacity((tw * th) as usize);
            for y in y0..y0 + th {
                let i = (y as usize) * (w as usize) + x0 as usize;
                samples.extend_from_slice(&dem.samples[i..i + tw as usize]);
            }
            let n = hierarchy_len(tw, th);
            let nf = if o.compact { 0 } else { n };
            let (mut errors, mut radii) = (vec![0.0f32; nf], vec![0.0f32; nf]);
            let mut codes = vec![0u16; n - nf];
            let mut pyr = vec![0.0f32; pyramid_len(tw, th)];
            let hf = Heightfield::with_scale(&samples, tw, th, scale)?;
            if o.compact {
                preprocess_compact_pyramid(&hf, &mut codes, &mut pyr)?;
            } else {
                preprocess_pyramid(
                    &hf,
                    &mut errors,
                    &mut radii,
                    &mut pyr,
                    PreprocessOptions::default(),
                )?;
            }
            tiles.push(Tile {
                col,
                row,
                x0,
                y0,
                w: tw,
                h: th,
                samples,
                errors,
                radii,
                codes,
            });
        }
    }
    let preprocess_ms = t0.elapsed().as_secs_f64() * 1e3;
    let t1 = Instant::now();
    let rounds = exchange(&mut tiles, cols, scale, o.compact)?;
    // The map's height range (local z), shared by every tile's view-dependent test.
    let hf_map = dem.heightfield()?;
    let (mut z_lo, mut z_hi) = (f32::INFINITY, f32::NEG_INFINITY);
    if o.view.is_some() {
        for y in 0..h {
            for x in 0..w {
                let z = hf_map.local_z(x, y);
                z_lo = z_lo.min(z);
                z_hi = z_hi.max(z);
            }
        }
    }
    let exchange_ms = t1.elapsed().as_secs_f64() * 1e3;
    // Mesh each tile; keep the welded union for the error scan.
    let t2 = Instant::now();
    let mut at: HashMap<(u32, u32), u32> = HashMap::new();
    let (mut uv, mut ut) = (Vec::new(), Vec::new());
    let mut per_tile = Vec::with_capacity(tiles.len());
    let mut files: Vec<TileObj> = Vec::new();
    for t in &mut tiles {
        let hf = Heightfield::with_scale(&t.samples, t.w, t.h, scale)?;
        let hier = if o.compact {
            renest_compact(&hf, &mut t.codes, &[])?
        } else {
            renest(
                &hf,
                &mut t.errors,
                &mut t.radii,
                &[],
                PreprocessOptions::default(),
            )?
        };
        let criterion = match o.view {
            Some(v) => Criterion::View(v.with_grid_origin(t.x0, t.y0).with_z_range(z_lo, z_hi)),
            None => Criterion::MaxError(o.max_error),
        };
        let r = Refiner::new(&hier, &hf, criterion)?;
        let mut sc = vec![0u64; scratch_len(t.w, t.h)];
        let c = r.count(&mut sc)?;
        let mut v = vec![[0.0f32; 3]; c.vertices];
        let mut tr = vec![[0u32; 3]; c.triangles];
        r.triangles(&mut sc, &mut v, &mut tr)?;
        let map: Vec<u32> = v
            .iter()
            .map(|p| {
                let gx = (p[0] / scale.dx).round() as u32 + t.x0;
                let gy = (p[1] / scale.dy).round() as u32 + t.y0;
                *at.entry((gx, gy)).or_insert_with(|| {
                    uv.push([gx as f32 * scale.dx, gy as f32 * scale.dy, p[2]]);
                    (uv.len() - 1) as u32
                })
            })
            .collect();
        ut.extend(tr.iter().map(|k| k.map(|i| map[i as usize])));
        if let Some(d) = o.skirt {
            add_skirt(&mut v, &mut tr, t.w, t.h, scale, d)?;
        }
        // World coordinates of the whole map.
        for p in &mut v {
            let gx = (p[0] / scale.dx).round() as u32 + t.x0;
            let gy = (p[1] / scale.dy).round() as u32 + t.y0;
            p[0] = gx as f32 * scale.dx;
            p[1] = gy as f32 * scale.dy;
        }
        per_tile.push(serde_json::json!({
            "col": t.col,
            "row": t.row,
            "x0": t.x0,
            "y0": t.y0,
            "width": t.w,
            "height": t.h,
            "vertices": v.len(),
            "triangles": tr.len(),
        }));
        let path = o.out_dir.join(format!("tile_{}_{}.obj", t.col, t.row));
        files.push((path, v, tr));
    }
    let refine_ms = t2.elapsed().as_secs_f64() * 1e3;
    let mut cov = vec![0u64; coverage_len(w, h)];
    let (max_err, uncovered) = vertical_error_partial(&hf_map, &uv, &ut, &mut cov)?;
    if o.view.is_none() {
        if let Some(u) = uncovered {
            return Err(CliError(format!(
                "internal error: the union of the tiles leaves sample {u:?} uncovered"
            )));
        }
    }
    for (path, v, tr) in &files {
        relief_io::write_obj(path, v, tr)?;
    }
    let total_v: usize = files.iter().map(|f| f.1.len()).sum();
    let total_t: usize = files.iter().map(|f| f.2.len()).sum();
    if o.json {
        let v = serde_json::json!({
            "width": w,
            "height": h,
            "mode": if o.view.is_some() { "view-dependent" } else { "view-independent" },
            "layout": if o.compact { "compact" } else { "full" },
            "tile_size": size,
            "tiles_x": cols,
            "tiles_y": ys.len(),
            "tiles": per_tile,
            "vertices": total_v,
            "triangles": total_t,
            "union_vertices": uv.len(),
            "union_triangles": ut.len(),
            "skirt": o.skirt,
            "border_rounds": rounds,
            "max_error_measured": max_err,
            "preprocess_ms": preprocess_ms,
            "border_exchange_ms": exchange_ms,
            "refine_ms": refine_ms,
            "out_dir": o.out_dir.display().to_string(),
        });
        print_out(&format!("{v}\n"))
    } else {
        print_out(&format!(
            "{dir}\n  tiles       {cols} x {rows} of {size} samples ({total_t} triangles, {total_v} vertices{skirt})\n  union       {ut} triangles, max error {max_err:.4} (measured over the samples the union covers)\n  borders     {rounds} exchange rounds, {exchange_ms:.1} ms\n  preprocess  {preprocess_ms:.1} ms\n  refine      {refine_ms:.1} ms\n",
            dir = o.out_dir.display(),
            rows = ys.len(),
            ut = ut.len(),
            skirt = if o.skirt.is_some() { ", skirts included" } else { "" },
        ))
    }
}
