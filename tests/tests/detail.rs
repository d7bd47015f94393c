//! Detail levels (relief_core::refine::DetailRefiner, seed 004 chapter 6.3) checked with the crack
//! checker: conforming meshes where detail starts, vertices on the Composed surface, the
//! effective resolution reached near the eye, and seed 004's demo size (a 1025^2 base with a
//! 1024^2 detail map at factor 64: a 65537^2 virtual grid) on the bundled Puget Sound DEM.

use proptest::prelude::*;
use relief_core::glam::Vec3;
use relief_core::refine::{
    detail_scratch_len, local_bounds_len, preprocess, preprocess_compact, DetailBounds,
    DetailCounts, DetailRefiner, Hierarchy, View,
};
use relief_core::{Camera, Composed, Heightfield, Sample, Scale, Terrain};
use relief_tests::mesh_check::{check_mesh, CheckOptions};
use std::collections::HashMap;

/// A tileable detail map: periodic value noise (lattice of `cell` samples, wrapping) plus a
/// finer periodic ripple, amplitude about `amp`.
fn tileable(w: u32, h: u32, cell: u32, amp: f32, seed: u64) -> Vec<f32> {
    let (lw, lh) = ((w / cell).max(1), (h / cell).max(1));
    let hash = |x: u32, y: u32| {
        let mut z = seed ^ (u64::from(x % lw) << 32 | u64::from(y % lh));
        z = z.wrapping_mul(0x9E37_79B9_7F4A_7C15);
        z ^= z >> 29;
        z = z.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        ((z >> 40) as f32 / (1u64 << 24) as f32) - 0.5
    };
    let mut out = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let (cx, cy) = (x / cell, y / cell);
            let (fx, fy) = (
                (x % cell) as f32 / cell as f32,
                (y % cell) as f32 / cell as f32,
            );
            let a = hash(cx, cy) * (1.0 - fx) + hash(cx + 1, cy) * fx;
            let b = hash(cx, cy + 1) * (1.0 - fx) + hash(cx + 1, cy + 1) * fx;
            let ripple = (std::f32::consts::TAU * 3.0 * x as f32 / w as f32).sin()
                * (std::f32::consts::TAU * 5.0 * y as f32 / h as f32).cos();
            out.push(amp * ((a * (1.0 - fy) + b * fy) + 0.25 * ripple));
        }
    }
    out
}

struct Mesh {
    v: Vec<[f32; 3]>,
    t: Vec<[u32; 3]>,
    n: DetailCounts,
}

fn refine<B: Sample, D: Sample>(dr: &DetailRefiner<'_, '_, B, D>) -> Mesh {
    let t = dr.triangle_count();
    // A mesh of t triangles has at most 3t vertices.
    let mut s = vec![0u64; detail_scratch_len(3 * t)];
    let n = dr.count(&mut s).unwrap();
    assert_eq!(n.triangles, t);
    let mut v = vec![[0.0f32; 3]; n.vertices];
    let mut tr = vec![[0u32; 3]; n.triangles];
    assert_eq!(dr.triangles(&mut s, &mut v, &mut tr).unwrap(), n);
    Mesh { v, t: tr, n }
}

fn opts<T: Terrain>(c: &T) -> CheckOptions {
    let s = c.scale();
    CheckOptions::grid(c.width(), c.height(), s.dx as f64, s.dy as f64)
}

/// Virtual grid coordinates of each vertex.
fn lattice<T: Terrain>(c: &T, v: &[[f32; 3]]) -> Vec<(u32, u32)> {
    let s = c.scale();
    v.iter()
        .map(|p| {
            let (x, y) = (p[0] as f64 / s.dx as f64, p[1] as f64 / s.dy as f64);
            assert!((x - x.round()).abs() < 1e-6 && (y - y.round()).abs() < 1e-6);
            (x.round() as u32, y.round() as u32)
        })
        .collect()
}

/// Every vertex is a sample of the composed surface, bit for bit.
fn assert_on_surface<B: Sample, D: Sample>(c: &Composed<'_, B, D>, m: &Mesh) {
    for (p, (x, y)) in m.v.iter().zip(lattice(c, &m.v)) {
        assert_eq!(
            p[2],
            c.z(x, y),
            "vertex ({x}, {y}) is off the composed surface"
        );
    }
}

/// Edges shared by a base triangle (all corners on base samples) and a detail triangle: where
/// detail starts.
fn transition_edges(m: &Mesh, grid: &[(u32, u32)], factor: u32) -> usize {
    let is_base = |t: &[u32; 3]| {
        t.iter().all(|&i| {
            let (x, y) = grid[i as usize];
            x % factor == 0 && y % factor == 0
        })
    };
    let mut owner: HashMap<(u32, u32), bool> = HashMap::new();
    for t in &m.t {
        let b = is_base(t);
        for k in 0..3 {
            owner.insert((t[k], t[(k + 1) % 3]), b);
        }
    }
    owner
        .iter()
        .filter(|(&(p, q), &b)| owner.get(&(q, p)).is_some_and(|&o| o != b))
        .count()
        / 2
}

fn hierarchy_pair(base: &Heightfield<'_, f32>) -> (Vec<f32>, Vec<f32>) {
    let n = (base.width() * base.height()) as usize;
    (vec![0.0; n], vec![0.0; n])
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Random composed maps and views, culling off: the whole domain is covered with no cracks,
    /// overlaps or T-junctions, detail starts somewhere inside, every vertex is on the surface.
    #[test]
    fn detail_mesh_is_crack_free_where_detail_starts(
        bw in 3u32..14, bh in 3u32..14, shift in 1u32..5, dsz in 2u32..12,
        seed in 0u64..1000, ex in -0.2f32..1.2, ey in -0.2f32..1.2, ez in 0.5f32..20.0,
        tau in 0.3f32..6.0, compact in any::<bool>(), mode in 0u8..3,
    ) {
        let factor = 1u32 << shift;
        let bs = tileable(bw, bh, 1, 30.0, seed);
        let ds = tileable(dsz, dsz + 1, 2, 2.0, seed + 1);
        let base = Heightfield::with_scale(&bs, bw, bh, Scale::default().with_spacing(16.0, 12.0)).unwrap();
        let detail = Heightfield::new(&ds, dsz, dsz + 1).unwrap();
        let c = Composed::new(base, detail, factor).unwrap();
        let (mut e, mut r) = hierarchy_pair(&base);
        let mut q = vec![0u16; e.len()];
        let h: Hierarchy<'_> = if compact {
            preprocess_compact(&base, &mut q).unwrap()
        } else {
            preprocess(&base, &mut e, &mut r).unwrap()
        };
        let mut buf = vec![0.0f32; local_bounds_len(bw, bh)];
        let bounds = match mode {
            0 => DetailBounds::constant(&c, 0.3).unwrap(),
            1 => DetailBounds::measure(&c),
            _ => DetailBounds::measure_local(&c, &mut buf).unwrap(),
        };
        let ext = c.extent();
        let eye = Vec3::new(ex * ext.x, ey * ext.y, ez);
        let target = Vec3::new(ext.x * 0.5, ext.y * 0.5, 0.0);
        let Ok(cam) = Camera::new(eye, target, 60.0, 400, 300) else { return Ok(()); };
        let view = View::new(&cam, tau).unwrap().with_culling(false);
        let dr = DetailRefiner::new(&h, &c, &bounds, &view).unwrap();
        let m = refine(&dr);
        let rep = check_mesh(&m.v, &m.t, &opts(&c)).map_err(TestCaseError::fail)?;
        prop_assert_eq!(rep.used_vertices, m.n.vertices);
        assert_on_surface(&c, &m);
        if m.n.detail_triangles() > 0 && m.n.base_triangles() > 0 {
            let grid = lattice(&c, &m.v);
            prop_assert!(transition_edges(&m, &grid, factor) > 0);
        }
    }
}

/// A fixed case where both kinds of triangles meet (so the transition is certainly checked),
/// with culling on: holes only where the view does not reach, no T-junctions anywhere.
#[test]
fn detail_starts_inside_the_view_without_cracks() {
    let bs = tileable(33, 33, 8, 40.0, 5);
    let ds = tileable(16, 16, 4, 1.0, 6);
    let base =
        Heightfield::with_scale(&bs, 33, 33, Scale::default().with_spacing(32.0, 32.0)).unwrap();
    let detail = Heightfield::new(&ds, 16, 16).unwrap();
    let c = Composed::new(base, detail, 16).unwrap();
    let (mut e, mut r) = hierarchy_pair(&base);
    let h = preprocess(&base, &mut e, &mut r).unwrap();
    let mut buf = vec![0.0f32; local_bounds_len(33, 33)];
    let bounds = DetailBounds::measure_local(&c, &mut buf).unwrap();
    let cam = Camera::new(
        Vec3::new(500.0, 480.0, 45.0),
        Vec3::new(900.0, 800.0, 0.0),
        60.0,
        640,
        480,
    )
    .unwrap();
    for culling in [false, true] {
        let view = View::new(&cam, 3.0).unwrap().with_culling(culling);
        let dr = DetailRefiner::new(&h, &c, &bounds, &view).unwrap();
        let m = refine(&dr);
        let mut o = opts(&c);
        o.allow_holes = culling;
        check_mesh(&m.v, &m.t, &o).unwrap();
        assert_on_surface(&c, &m);
        assert!(
            m.n.base_triangles() > 0 && m.n.detail_triangles() > 0,
            "{:?}",
            m.n
        );
        let grid = lattice(&c, &m.v);
        assert!(transition_edges(&m, &grid, 16) > 0);
        if culling {
            // Culling removed something behind the camera.
            let full =
                refine(&DetailRefiner::new(&h, &c, &bounds, &view.with_culling(false)).unwrap());
            assert!(m.n.triangles < full.n.triangles);
            // Detail levels are culled too (their cylinders), not only base levels.
            assert!(
                m.n.detail_triangles() < full.n.detail_triangles(),
                "{:?} vs {:?}",
                m.n,
                full.n
            );
        }
    }
}

/// Near the eye the mesh reaches single composed cells: a vertex at 1/64 of a base cell.
#[test]
fn effective_resolution_is_reached_near_the_eye() {
    let bs = tileable(17, 17, 2, 200.0, 11);
    let ds = tileable(64, 64, 8, 2.0, 12);
    let base =
        Heightfield::with_scale(&bs, 17, 17, Scale::default().with_spacing(64.0, 64.0)).unwrap();
    let detail = Heightfield::new(&ds, 64, 64).unwrap();
    let c = Composed::new(base, detail, 64).unwrap(); // 1025^2 virtual grid, spacing 1
    let (mut e, mut r) = hierarchy_pair(&base);
    let h = preprocess(&base, &mut e, &mut r).unwrap();
    let bounds = DetailBounds::measure(&c);
    let (ex, ey) = (500.0f32, 420.0f32);
    let ez = c.z(500, 420) + 3.0;
    let cam = Camera::new(
        Vec3::new(ex, ey, ez),
        Vec3::new(900.0, 900.0, c.z(900, 900)),
        60.0,
        800,
        600,
    )
    .unwrap();
    let dr = DetailRefiner::new(&h, &c, &bounds, &View::new(&cam, 1.0).unwrap()).unwrap();
    assert_eq!((dr.grid().width(), dr.grid().levels()), (1025, 20));
    let m = refine(&dr);
    assert_eq!(m.n.finest_level(), Some(dr.grid().levels()));
    let finest = lattice(&c, &m.v)
        .into_iter()
        .filter(|&(x, y)| x % 2 == 1 || y % 2 == 1)
        .map(|(x, y)| ((x as f32 - ex).powi(2) + (y as f32 - ey).powi(2)).sqrt())
        .fold(f32::INFINITY, f32::min);
    assert!(
        finest < 20.0,
        "no finest-level vertex within 20 of the eye: {finest}"
    );
    let mut o = opts(&c);
    o.allow_holes = true;
    check_mesh(&m.v, &m.t, &o).unwrap();
}

/// Seed 004's demo: the bundled 1025^2 Puget Sound DEM (160 m, 0.1 m) with a 1024^2 tileable
/// detail map at factor 64: a 65537^2 virtual grid (2.5 m spacing), meshed for a low flyover.
#[test]
fn puget_sound_65537_virtual_grid() {
    let dem = relief_tests::fixtures::puget();
    let base = dem.heightfield().unwrap();
    let ds = tileable(1024, 1024, 16, 4.0, 2003);
    let detail = Heightfield::new(&ds, 1024, 1024).unwrap();
    let c = Composed::new(base, detail, 64).unwrap();
    assert_eq!((c.width(), c.height()), (65537, 65537));
    let mut q = vec![0u16; 1025 * 1025];
    let h = preprocess_compact(&base, &mut q).unwrap();
    let bounds = DetailBounds::constant(&c, 0.5).unwrap();
    let (ex, ey) = (80_000.0f32, 60_000.0f32);
    let ground = c
        .surface_height(relief_core::Surface::Bilinear, ex, ey)
        .unwrap();
    let cam = Camera::new(
        Vec3::new(ex, ey, ground + 150.0),
        Vec3::new(ex + 4000.0, ey + 3000.0, ground),
        60.0,
        1024,
        768,
    )
    .unwrap();
    let dr = DetailRefiner::new(&h, &c, &bounds, &View::new(&cam, 2.0).unwrap()).unwrap();
    assert_eq!(dr.grid().levels(), 32);
    let m = refine(&dr);
    assert_eq!(m.n.finest_level(), Some(32), "{:?}", m.n);
    let mut o = opts(&c);
    o.allow_holes = true;
    check_mesh(&m.v, &m.t, &o).unwrap();
    assert_on_surface(&c, &m);
}
