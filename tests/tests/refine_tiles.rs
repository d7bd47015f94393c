//! Tiles without skirts (issue 6, part 2): a DEM cut into tiles sharing border rows and columns,
//! each preprocessed and meshed on its own; after the border protocol (export_border,
//! merge_border, renest until nothing is raised) the union of the tile meshes passes the crack
//! checker and the full-grid error scan. Without the protocol it cracks (the control).

use relief_core::glam::Vec3;
use relief_core::refine::{
    border_len, coverage_len, export_border, export_border_compact, hierarchy_len, merge_border,
    merge_border_compact, preprocess_compact, preprocess_pyramid, pyramid_len, renest,
    renest_compact, scratch_len, skirt, skirt_bound, vertical_error, Criterion, Hierarchy,
    PreprocessOptions, Refiner, Side, View,
};
use relief_core::{Camera, Heightfield, Scale, Terrain};
use relief_tests::mesh_check::{check_mesh, CheckOptions};
use std::collections::HashMap;

struct Tile {
    x0: u32,
    y0: u32,
    w: u32,
    h: u32,
    s: Vec<f32>,
    e: Vec<f32>,
    r: Vec<f32>,
}

fn puget() -> (Vec<f32>, u32, u32, Scale) {
    let dem = relief_tests::fixtures::puget();
    (dem.samples, dem.width, dem.height, dem.scale)
}

fn starts(n: u32, size: u32) -> Vec<u32> {
    let step = size - 1;
    (0..).map(|k| k * step).take_while(|&s| s + 1 < n).collect()
}

/// Cuts `samples` (`w x h`) into tiles of `size` samples sharing borders; each preprocessed.
fn cut(samples: &[f32], w: u32, h: u32, size: u32, scale: Scale) -> Vec<Vec<Tile>> {
    let o = PreprocessOptions::default();
    starts(h, size)
        .into_iter()
        .map(|y0| {
            starts(w, size)
                .into_iter()
                .map(|x0| {
                    let (tw, th) = (size.min(w - x0), size.min(h - y0));
                    let mut s = Vec::with_capacity((tw * th) as usize);
                    for y in y0..y0 + th {
                        let row = (y * w + x0) as usize;
                        s.extend_from_slice(&samples[row..row + tw as usize]);
                    }
                    let n = hierarchy_len(tw, th);
                    let (mut e, mut r) = (vec![0.0; n], vec![0.0; n]);
                    let mut p = vec![0.0; pyramid_len(tw, th)];
                    let hf = Heightfield::with_scale(&s, tw, th, scale).unwrap();
                    preprocess_pyramid(&hf, &mut e, &mut r, &mut p, o).unwrap();
                    Tile {
                        x0,
                        y0,
                        w: tw,
                        h: th,
                        s,
                        e,
                        r,
                    }
                })
                .collect()
        })
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

/// Runs the border protocol until no merge raises a value; returns the number of rounds.
fn exchange(tiles: &mut [Vec<Tile>], scale: Scale) -> usize {
    protocol(
        tiles,
        |t, side| {
            let n = border_len(t.w, t.h, side);
            let (mut be, mut br) = (vec![0.0; n], vec![0.0; n]);
            export_border(t.w, t.h, &t.e, &t.r, side, &mut be, &mut br).unwrap();
            (be, br)
        },
        |t, side, (be, br)| merge_border(t.w, t.h, &mut t.e, &mut t.r, side, be, br).unwrap(),
        |t, merged| {
            let hf = Heightfield::with_scale(&t.s, t.w, t.h, scale).unwrap();
            renest(
                &hf,
                &mut t.e,
                &mut t.r,
                merged,
                PreprocessOptions::default(),
            )
            .unwrap();
        },
    )
}

/// Runs a border protocol (`export` a side, `merge` a neighbour's export into a side, returning
/// how many values it raised, `renest` the merged sides) until no merge raises a value; returns
/// the number of rounds.
fn protocol<T, B>(
    tiles: &mut [Vec<T>],
    export: impl Fn(&T, Side) -> B,
    mut merge: impl FnMut(&mut T, Side, &B) -> usize,
    mut renest: impl FnMut(&mut T, &[Side]),
) -> usize {
    let (rows, cols) = (tiles.len(), tiles[0].len());
    for round in 1..=32 {
        let mut out: HashMap<(usize, usize, Side), B> = HashMap::new();
        for (r, row) in tiles.iter().enumerate() {
            for (c, t) in row.iter().enumerate() {
                for side in Side::ALL {
                    if neighbour(rows, cols, r, c, side).is_some() {
                        out.insert((r, c, side), export(t, side));
                    }
                }
            }
        }
        let mut raised = 0;
        for (r, row) in tiles.iter_mut().enumerate() {
            for (c, t) in row.iter_mut().enumerate() {
                let mut merged = Vec::new();
                for side in Side::ALL {
                    if let Some((nr, nc)) = neighbour(rows, cols, r, c, side) {
                        let k = merge(t, side, &out[&(nr, nc, side.opposite())]);
                        if k > 0 {
                            merged.push(side);
                        }
                        raised += k;
                    }
                }
                if !merged.is_empty() {
                    renest(t, &merged);
                }
            }
        }
        if raised == 0 {
            return round;
        }
    }
    panic!("the border protocol did not settle in 32 rounds");
}

/// The welded union of tile meshes: vertices keyed by their map grid index.
#[derive(Default)]
struct Weld {
    at: HashMap<(u32, u32), u32>,
    v: Vec<[f32; 3]>,
    t: Vec<[u32; 3]>,
    /// The most triangles one tile contributed.
    per_tile_max: usize,
}

impl Weld {
    /// Meshes the tile at grid origin `(x0, y0)` with criterion `c` and adds it to the union.
    fn add(&mut self, h: &Hierarchy, hf: &Heightfield<f32>, c: Criterion, (x0, y0): (u32, u32)) {
        let scale = hf.scale();
        let r = Refiner::new(h, hf, c).unwrap();
        let mut sc = vec![0; scratch_len(hf.width(), hf.height())];
        let n = r.count(&mut sc).unwrap();
        let mut tv = vec![[0.0; 3]; n.vertices];
        let mut tt = vec![[0; 3]; n.triangles];
        r.triangles(&mut sc, &mut tv, &mut tt).unwrap();
        self.per_tile_max = self.per_tile_max.max(n.triangles);
        let map: Vec<u32> = tv
            .iter()
            .map(|p| {
                let gx = (p[0] / scale.dx).round() as u32 + x0;
                let gy = (p[1] / scale.dy).round() as u32 + y0;
                *self.at.entry((gx, gy)).or_insert_with(|| {
                    self.v
                        .push([gx as f32 * scale.dx, gy as f32 * scale.dy, p[2]]);
                    (self.v.len() - 1) as u32
                })
            })
            .collect();
        self.t
            .extend(tt.iter().map(|tri| tri.map(|i| map[i as usize])));
    }
}

/// Meshes every tile at `e` and welds the union (world coordinates of the whole map).
fn union(tiles: &[Vec<Tile>], scale: Scale, e: f32) -> (Vec<[f32; 3]>, Vec<[u32; 3]>, usize) {
    let mut weld = Weld::default();
    for tile in tiles.iter().flatten() {
        let hf = Heightfield::with_scale(&tile.s, tile.w, tile.h, scale).unwrap();
        // The merged data as a hierarchy (`renest` with no side only wraps the arrays).
        let (mut te, mut tr) = (tile.e.clone(), tile.r.clone());
        let h = renest(&hf, &mut te, &mut tr, &[], PreprocessOptions::default()).unwrap();
        weld.add(&h, &hf, Criterion::MaxError(e), (tile.x0, tile.y0));
    }
    (weld.v, weld.t, weld.per_tile_max)
}

fn check_union(samples: &[f32], w: u32, h: u32, scale: Scale, tiles: &[Vec<Tile>], e: f32) {
    let (v, t, _) = union(tiles, scale, e);
    let o = CheckOptions::grid(w, h, scale.dx as f64, scale.dy as f64);
    let rep = check_mesh(&v, &t, &o).unwrap_or_else(|m| panic!("{w}x{h} E={e}: {m}"));
    assert_eq!(rep.triangles, t.len());
    let hf = Heightfield::with_scale(samples, w, h, scale).unwrap();
    let mut cov = vec![0; coverage_len(w, h)];
    let err = vertical_error(&hf, &v, &t, &mut cov).unwrap();
    assert!(err <= e as f64, "{w}x{h} E={e}: measured {err}");
}

#[test]
fn bundled_dem_in_257_tiles_is_crack_free_and_within_e() {
    let (s, w, h, scale) = puget();
    let mut tiles = cut(&s, w, h, 257, scale);
    assert_eq!((tiles.len(), tiles[0].len()), (4, 4));
    // Control: the tiles' own data (no exchange) crack along the shared borders.
    let (v, t, _) = union(&tiles, scale, 5.0);
    let o = CheckOptions::grid(w, h, scale.dx as f64, scale.dy as f64);
    assert!(
        check_mesh(&v, &t, &o).is_err(),
        "expected cracks without the protocol"
    );
    let rounds = exchange(&mut tiles, scale);
    eprintln!("border protocol: {rounds} rounds");
    assert!(rounds <= 4, "{rounds} rounds");
    for e in [5.0, 20.0] {
        check_union(&s, w, h, scale, &tiles, e);
    }
}

#[test]
fn non_multiple_size_with_smaller_last_tiles() {
    let (s, w, _, scale) = puget();
    // A 1000 x 700 crop in tiles of 129: the last column is 104 wide, the last row 60 high.
    let (cw, ch) = (1000u32, 700u32);
    let mut crop = Vec::with_capacity((cw * ch) as usize);
    for y in 0..ch {
        let row = (y * w) as usize;
        crop.extend_from_slice(&s[row..row + cw as usize]);
    }
    let mut tiles = cut(&crop, cw, ch, 129, scale);
    let last = tiles.last().unwrap().last().unwrap();
    assert_eq!((last.w, last.h), (104, 60));
    let rounds = exchange(&mut tiles, scale);
    eprintln!("border protocol: {rounds} rounds");
    assert!(rounds <= 4, "{rounds} rounds");
    for e in [2.0, 10.0] {
        check_union(&crop, cw, ch, scale, &tiles, e);
    }
}

#[test]
fn random_small_maps_in_tiles() {
    let mut st = 12345u64;
    let mut rnd = || {
        st ^= st << 13;
        st ^= st >> 7;
        st ^= st << 17;
        st
    };
    for (w, h, size) in [
        (33u32, 33u32, 9u32),
        (40, 27, 17),
        (21, 50, 5),
        (64, 64, 33),
    ] {
        let s: Vec<f32> = (0..w * h).map(|_| (rnd() % 1000) as f32 * 0.05).collect();
        let scale = Scale::default();
        let mut tiles = cut(&s, w, h, size, scale);
        exchange(&mut tiles, scale);
        for e in [0.0, 3.0, 15.0] {
            check_union(&s, w, h, scale, &tiles, e);
        }
    }
}

/// Meshes every tile view-dependently for the same `view` (the map's world coordinates; each
/// tile gets its grid origin) and welds the union.
fn union_view(tiles: &[Vec<Tile>], scale: Scale, view: View) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let mut weld = Weld::default();
    for tile in tiles.iter().flatten() {
        let hf = Heightfield::with_scale(&tile.s, tile.w, tile.h, scale).unwrap();
        let (mut te, mut tr) = (tile.e.clone(), tile.r.clone());
        let h = renest(&hf, &mut te, &mut tr, &[], PreprocessOptions::default()).unwrap();
        let c = Criterion::View(view.with_grid_origin(tile.x0, tile.y0));
        weld.add(&h, &hf, c, (tile.x0, tile.y0));
    }
    (weld.v, weld.t)
}

#[test]
fn view_dependent_tiles_weld_crack_free() {
    let (s, w, h, scale) = puget();
    let mut tiles = cut(&s, w, h, 129, scale);
    exchange(&mut tiles, scale);
    let (ex, ey) = ((w - 1) as f32 * scale.dx, (h - 1) as f32 * scale.dy);
    let top = s.iter().fold(f32::MIN, |a, &b| a.max(b)) * scale.z_scale + scale.z_offset;
    let domain = ex as f64 * ey as f64;
    // Eyes inside the tiled area: exactly above a tile corner (128, 128 samples from it), above a
    // shared border looking along it, and low inside a tile looking across several borders.
    let corner = Vec3::new(256.0 * scale.dx, 256.0 * scale.dy, top + 200.0);
    let cams = [
        (corner, Vec3::new(0.8 * ex, 0.7 * ey, 0.0)),
        (
            Vec3::new(384.0 * scale.dx, 0.3 * ey, top + 50.0),
            Vec3::new(384.0 * scale.dx, 0.9 * ey, 0.0),
        ),
        (
            Vec3::new(0.55 * ex, 0.45 * ey, top + 20.0),
            Vec3::new(0.1 * ex, 0.2 * ey, 0.0),
        ),
    ];
    for (eye, target) in cams {
        let cam = Camera::new(eye, target, 60.0, 1024, 768).unwrap();
        for (tau, culling, lazy) in [(1.0, false, 0), (2.0, true, 0), (0.5, true, 4)] {
            let view = View::new(&cam, tau)
                .unwrap()
                .with_near_far(1.0, None)
                .with_culling(culling)
                .with_lazy_levels(lazy);
            let (v, t) = union_view(&tiles, scale, view);
            let mut o = CheckOptions::grid(w, h, scale.dx as f64, scale.dy as f64);
            o.allow_holes = culling;
            o.t_junctions = lazy == 0; // lazy culling may leave T-junctions outside the view
            let what = format!("eye {eye} tau {tau} culling {culling} lazy {lazy}");
            let rep = check_mesh(&v, &t, &o).unwrap_or_else(|m| panic!("{what}: {m}"));
            if culling {
                // The frustum crosses tile borders: part of the map is culled, part kept.
                assert!(rep.area < 0.9 * domain, "{what}: area {}", rep.area);
                assert!(rep.area > 0.01 * domain, "{what}: area {}", rep.area);
            } else {
                assert!((rep.area - domain).abs() < 1e-6 * domain, "{what}");
            }
        }
    }
}

/// Decisions exactly at the pixel threshold: for every vertex on the border shared by two
/// tiles, the threshold at which its projected error equals `tau` (computed in the map's frame),
/// and the `f32` thresholds around it; at each, both tiles must keep or both split the vertex.
/// Control (checked by hand when this test was written): with each tile's camera moved by the
/// tile's origin in `f32` instead of `View::with_grid_origin`, this test fails (eye
/// `[43.27, 5.29, 1001.64]`, tau `5.283691`: a crack at edge `(32, 1)-(32, 0)`).
#[test]
fn view_dependent_tiles_decide_shared_vertices_alike_at_the_threshold() {
    let (w, h, size) = (65u32, 33u32, 33u32);
    let mut st = 99u64;
    let mut rnd = || {
        st ^= st << 13;
        st ^= st >> 7;
        st ^= st << 17;
        st
    };
    let s: Vec<f32> = (0..w * h).map(|_| (rnd() % 1000) as f32 * 0.01).collect();
    // Spacing and offsets that are not exact in binary, so tile-local and map coordinates round
    // differently.
    let scale = Scale::default()
        .with_spacing(0.3, 0.7)
        .with_z_scale(0.1)
        .with_z_offset(1000.1);
    let mut tiles = cut(&s, w, h, size, scale);
    exchange(&mut tiles, scale);
    let mut total = 0;
    for trial in 0..12 {
        let eye = Vec3::new(
            25.01 + trial as f32 * 9.13,
            (3.0 + trial as f32 * 2.3) * 0.7 - 0.03,
            1001.3 + trial as f32 * 0.17,
        );
        let cam = Camera::new(eye, Vec3::new(0.0, 0.0, 1000.0), 70.0, 800, 600).unwrap();
        let kappa = cam.kappa() as f64;
        let t0 = &tiles[0][0];
        let mut taus = Vec::new();
        for y in 0..h {
            let k = (y * size + size - 1) as usize;
            let (e, r) = (t0.e[k] as f64, t0.r[k] as f64);
            let z = s[(y * w + size - 1) as usize] as f64 * 0.1f32 as f64;
            let (dx, dy) = (
                eye.x as f64 - (size - 1) as f64 * 0.3f32 as f64,
                eye.y as f64 - y as f64 * 0.7f32 as f64,
            );
            let dz = eye.z as f64 - 1000.1f32 as f64 - z;
            let d = (dx * dx + dy * dy + dz * dz).sqrt() - r;
            if e.is_finite() && e > 0.0 && d > 0.0 {
                let c = (e * kappa / d) as f32;
                taus.extend([c.next_down(), c, c.next_up(), c.next_up().next_up()]);
            }
        }
        total += taus.len();
        for tau in taus {
            let view = View::new(&cam, tau).unwrap().with_culling(false);
            let (v, t) = union_view(&tiles, scale, view);
            let o = CheckOptions::grid(w, h, scale.dx as f64, scale.dy as f64);
            check_mesh(&v, &t, &o).unwrap_or_else(|m| panic!("eye {eye} tau {tau}: {m}"));
        }
    }
    assert!(total >= 400, "{total} thresholds");
}

/// `skirt` on real tile meshes: one quad (two triangles) per mesh edge on the tile border, none
/// elsewhere; every skirt triangle vertical, facing away from the tile, `depth` deep.
#[test]
fn skirts_hang_below_every_border_edge_and_face_outwards() {
    let (s, w, h, scale) = puget();
    let tiles = cut(&s[..], w, h, 129, scale);
    for tile in [&tiles[0][0], &tiles[3][5], &tiles[7][7]] {
        let hf = Heightfield::with_scale(&tile.s, tile.w, tile.h, scale).unwrap();
        let (mut te, mut tr) = (tile.e.clone(), tile.r.clone());
        let hi = renest(&hf, &mut te, &mut tr, &[], PreprocessOptions::default()).unwrap();
        let r = Refiner::new(&hi, &hf, Criterion::MaxError(8.0)).unwrap();
        let mut sc = vec![0; scratch_len(tile.w, tile.h)];
        let n = r.count(&mut sc).unwrap();
        let mut v = vec![[0.0; 3]; n.vertices];
        let mut t = vec![[0; 3]; n.triangles];
        r.triangles(&mut sc, &mut v, &mut t).unwrap();
        // Boundary edges of the mesh (one triangle): exactly the tile's border edges.
        let mut count: HashMap<(u32, u32), i32> = HashMap::new();
        for tri in &t {
            for (a, b) in [(tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])] {
                *count.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        let boundary = count.values().filter(|&&c| c == 1).count();
        let bound = skirt_bound(tile.w, tile.h);
        let (mut sv, mut st) = (vec![[0.0; 3]; bound], vec![[0; 3]; bound]);
        let depth = 50.0;
        let (nv, nt) = skirt(
            tile.w,
            tile.h,
            scale,
            &v,
            &t,
            &Side::ALL,
            depth,
            &mut sv,
            &mut st,
        )
        .unwrap();
        assert_eq!((nv, nt), (2 * boundary, 2 * boundary));
        let all: Vec<[f32; 3]> = v.iter().chain(&sv[..nv]).copied().collect();
        let (cx, cy) = (
            (tile.w - 1) as f32 * scale.dx / 2.0,
            (tile.h - 1) as f32 * scale.dy / 2.0,
        );
        for tri in &st[..nt] {
            let p = tri.map(|i| all[i as usize]);
            let u = [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]];
            let q = [p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]];
            let nrm = [
                u[1] * q[2] - u[2] * q[1],
                u[2] * q[0] - u[0] * q[2],
                u[0] * q[1] - u[1] * q[0],
            ];
            assert_eq!(nrm[2], 0.0, "vertical");
            let mid = [
                (p[0][0] + p[1][0]) / 2.0 - cx,
                (p[0][1] + p[1][1]) / 2.0 - cy,
            ];
            assert!(nrm[0] * mid[0] + nrm[1] * mid[1] > 0.0, "faces outwards");
        }
        for k in 0..nv / 2 {
            assert_eq!(sv[2 * k][2], all[st[2 * k][1] as usize][2] - depth);
        }
        // Bad input: depth, a buffer too small, an index outside the vertices.
        let e = skirt(
            tile.w,
            tile.h,
            scale,
            &v,
            &t,
            &Side::ALL,
            f32::NAN,
            &mut sv,
            &mut st,
        );
        assert!(e.is_err());
        let e = skirt(
            tile.w,
            tile.h,
            scale,
            &v,
            &t,
            &Side::ALL,
            depth,
            &mut sv[..nv - 1],
            &mut st,
        );
        assert!(matches!(e, Err(relief_core::Error::BufferTooSmall { .. })));
        let e = skirt(
            tile.w,
            tile.h,
            scale,
            &v[..1],
            &t,
            &Side::ALL,
            depth,
            &mut sv,
            &mut st,
        );
        assert!(matches!(e, Err(relief_core::Error::BufferTooSmall { .. })));
    }
}

/// A tile in the compact layout: samples and bfloat16 error codes.
struct CompactTile {
    x0: u32,
    y0: u32,
    w: u32,
    h: u32,
    s: Vec<f32>,
    e: Vec<u16>,
}

fn cut_compact(samples: &[f32], w: u32, h: u32, size: u32, scale: Scale) -> Vec<Vec<CompactTile>> {
    cut(samples, w, h, size, scale)
        .into_iter()
        .map(|row| {
            row.into_iter()
                .map(|t| {
                    let hf = Heightfield::with_scale(&t.s, t.w, t.h, scale).unwrap();
                    let mut e = vec![0u16; hierarchy_len(t.w, t.h)];
                    preprocess_compact(&hf, &mut e).unwrap();
                    CompactTile {
                        x0: t.x0,
                        y0: t.y0,
                        w: t.w,
                        h: t.h,
                        s: t.s,
                        e,
                    }
                })
                .collect()
        })
        .collect()
}

/// The border protocol in the compact layout; returns the number of rounds.
fn exchange_compact(tiles: &mut [Vec<CompactTile>], scale: Scale) -> usize {
    protocol(
        tiles,
        |t, side| {
            let mut be = vec![0; border_len(t.w, t.h, side)];
            export_border_compact(t.w, t.h, &t.e, side, &mut be).unwrap();
            be
        },
        |t, side, be| merge_border_compact(t.w, t.h, &mut t.e, side, be).unwrap(),
        |t, merged| {
            let hf = Heightfield::with_scale(&t.s, t.w, t.h, scale).unwrap();
            renest_compact(&hf, &mut t.e, merged).unwrap();
        },
    )
}

/// Meshes every compact tile (`view` given: view-dependent with the tile's grid origin and the
/// map's height range; else view-independent at `e`) and welds the union.
fn union_compact(
    tiles: &[Vec<CompactTile>],
    scale: Scale,
    e: f32,
    view: Option<View>,
) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let mut weld = Weld::default();
    for tile in tiles.iter().flatten() {
        let hf = Heightfield::with_scale(&tile.s, tile.w, tile.h, scale).unwrap();
        let mut te = tile.e.clone();
        let h = renest_compact(&hf, &mut te, &[]).unwrap();
        let c = match view {
            Some(v) => Criterion::View(v.with_grid_origin(tile.x0, tile.y0)),
            None => Criterion::MaxError(e),
        };
        weld.add(&h, &hf, c, (tile.x0, tile.y0));
    }
    (weld.v, weld.t)
}

#[test]
fn compact_tiles_are_crack_free_and_within_e() {
    let (s, w, h, scale) = puget();
    let mut tiles = cut_compact(&s, w, h, 129, scale);
    let o = CheckOptions::grid(w, h, scale.dx as f64, scale.dy as f64);
    // Control: without the protocol the compact tiles crack too.
    let (v, t) = union_compact(&tiles, scale, 5.0, None);
    assert!(check_mesh(&v, &t, &o).is_err(), "expected cracks");
    let rounds = exchange_compact(&mut tiles, scale);
    eprintln!("compact border protocol: {rounds} rounds");
    assert!(rounds <= 4, "{rounds} rounds");
    let hf = Heightfield::with_scale(&s, w, h, scale).unwrap();
    for e in [5.0, 20.0] {
        let (v, t) = union_compact(&tiles, scale, e, None);
        check_mesh(&v, &t, &o).unwrap_or_else(|m| panic!("E={e}: {m}"));
        let mut cov = vec![0; coverage_len(w, h)];
        let err = vertical_error(&hf, &v, &t, &mut cov).unwrap();
        assert!(err <= e as f64, "E={e}: measured {err}");
    }
    // View-dependent, the map's local height range shared by every tile. Control (checked by
    // hand when written): without `with_z_range` each tile bounds its vertices by its own height
    // range and the union cracks at tau 4 (edge (480, 512)-(512, 512)).
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    for y in 0..h {
        for x in 0..w {
            lo = lo.min(hf.local_z(x, y));
            hi = hi.max(hf.local_z(x, y));
        }
    }
    let (ex, ey) = ((w - 1) as f32 * scale.dx, (h - 1) as f32 * scale.dy);
    let eye = Vec3::new(
        384.0 * scale.dx,
        256.0 * scale.dy,
        hi + scale.z_offset + 150.0,
    );
    let cam = Camera::new(eye, Vec3::new(0.9 * ex, 0.8 * ey, 0.0), 60.0, 1024, 768).unwrap();
    for (tau, culling) in [
        (1.0, false),
        (2.0, true),
        (4.0, false),
        (8.0, false),
        (16.0, true),
    ] {
        let view = View::new(&cam, tau)
            .unwrap()
            .with_near_far(1.0, None)
            .with_culling(culling)
            .with_lazy_levels(0)
            .with_z_range(lo, hi);
        let (v, t) = union_compact(&tiles, scale, 0.0, Some(view));
        let mut o = o;
        o.allow_holes = culling;
        let rep = check_mesh(&v, &t, &o).unwrap_or_else(|m| panic!("tau {tau}: {m}"));
        eprintln!(
            "compact view-dependent tau {tau}: {} triangles",
            rep.triangles
        );
        assert!(
            rep.triangles > 200,
            "tau {tau}: {} triangles",
            rep.triangles
        );
    }
}

#[test]
fn compact_random_small_maps_in_tiles() {
    let mut st = 777u64;
    let mut rnd = || {
        st ^= st << 13;
        st ^= st >> 7;
        st ^= st << 17;
        st
    };
    for (w, h, size) in [(33u32, 33u32, 9u32), (40, 27, 17), (21, 50, 5)] {
        let s: Vec<f32> = (0..w * h).map(|_| (rnd() % 1000) as f32 * 0.05).collect();
        let scale = Scale::default();
        let mut tiles = cut_compact(&s, w, h, size, scale);
        exchange_compact(&mut tiles, scale);
        let hf = Heightfield::with_scale(&s, w, h, scale).unwrap();
        let o = CheckOptions::grid(w, h, 1.0, 1.0);
        for e in [0.0, 3.0, 15.0] {
            let (v, t) = union_compact(&tiles, scale, e, None);
            check_mesh(&v, &t, &o).unwrap_or_else(|m| panic!("{w}x{h} E={e}: {m}"));
            let mut cov = vec![0; coverage_len(w, h)];
            let err = vertical_error(&hf, &v, &t, &mut cov).unwrap();
            assert!(err <= e as f64, "{w}x{h} E={e}: measured {err}");
        }
    }
}

/// Compact view-dependent tiles when the last tiles are smaller (embedded in smaller squares,
/// so their level-only radii come from another root size, computed with exact powers of two so
/// that the same half-size gets the same radius): still crack-free.
#[test]
fn compact_view_dependent_smaller_last_tiles() {
    let (s, w, _, scale) = puget();
    let (cw, ch) = (1000u32, 700u32);
    let mut crop = Vec::with_capacity((cw * ch) as usize);
    for y in 0..ch {
        let row = (y * w) as usize;
        crop.extend_from_slice(&s[row..row + cw as usize]);
    }
    let mut tiles = cut_compact(&crop, cw, ch, 129, scale);
    let last = tiles.last().unwrap().last().unwrap();
    assert_eq!((last.w, last.h), (104, 60));
    exchange_compact(&mut tiles, scale);
    let hf = Heightfield::with_scale(&crop, cw, ch, scale).unwrap();
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    for y in 0..ch {
        for x in 0..cw {
            lo = lo.min(hf.local_z(x, y));
            hi = hi.max(hf.local_z(x, y));
        }
    }
    let (ex, ey) = ((cw - 1) as f32 * scale.dx, (ch - 1) as f32 * scale.dy);
    let eye = Vec3::new(0.93 * ex, 0.9 * ey, hi + scale.z_offset + 100.0);
    let cam = Camera::new(eye, Vec3::new(0.2 * ex, 0.3 * ey, 0.0), 60.0, 1024, 768).unwrap();
    let o = CheckOptions::grid(cw, ch, scale.dx as f64, scale.dy as f64);
    for tau in [0.5f32, 1.0, 2.0, 4.0, 8.0] {
        let view = View::new(&cam, tau)
            .unwrap()
            .with_culling(false)
            .with_z_range(lo, hi);
        let (v, t) = union_compact(&tiles, scale, 0.0, Some(view));
        check_mesh(&v, &t, &o).unwrap_or_else(|m| panic!("tau {tau}: {m}"));
    }
}
