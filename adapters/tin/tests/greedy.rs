//! Greedy TIN: measured error within the target on random grids, hard cases and real DEMs;
//! budgets respected; meshes tile the domain. Every mesh is checked here by an independent
//! full-grid scan (barycentric point-in-triangle over all samples, written for this test) and an
//! independent topology check, not only by the crate's own `mesh_error`.

use proptest::prelude::*;
use relief_core::{Composed, Error, Heightfield, Scale, Terrain};
use relief_tin::{mesh_error, StopReason, Tin, TinOptions};
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

/// Independent error scan: for every sample, find a triangle containing it by barycentric
/// coordinates (integer orientation tests) and evaluate the mesh there as the barycentric blend
/// of the corner heights, in f64. Returns (max, rms); panics if a sample is uncovered.
fn independent_error<T: Terrain>(t: &T, v: &[[u32; 2]], tris: &[[u32; 3]]) -> (f64, f64) {
    let (w, h) = (t.width() as usize, t.height() as usize);
    let mut err = vec![f64::NAN; w * h];
    for tri in tris {
        let p = tri.map(|i| {
            let [x, y] = v[i as usize];
            (x as i64, y as i64, f64::from(t.local_z(x, y)))
        });
        let area = (p[1].0 - p[0].0) * (p[2].1 - p[0].1) - (p[1].1 - p[0].1) * (p[2].0 - p[0].0);
        assert!(area > 0, "triangle {tri:?} not counter-clockwise");
        let (x0, x1) = (
            p.iter().map(|q| q.0).min().unwrap(),
            p.iter().map(|q| q.0).max().unwrap(),
        );
        let (y0, y1) = (
            p.iter().map(|q| q.1).min().unwrap(),
            p.iter().map(|q| q.1).max().unwrap(),
        );
        for y in y0..=y1 {
            for x in x0..=x1 {
                let b = |a: (i64, i64, f64), c: (i64, i64, f64)| {
                    (c.0 - a.0) * (y - a.1) - (c.1 - a.1) * (x - a.0)
                };
                let (w0, w1, w2) = (b(p[1], p[2]), b(p[2], p[0]), b(p[0], p[1]));
                if w0 < 0 || w1 < 0 || w2 < 0 {
                    continue;
                }
                let m =
                    (w0 as f64 * p[0].2 + w1 as f64 * p[1].2 + w2 as f64 * p[2].2) / area as f64;
                let d = (f64::from(t.local_z(x as u32, y as u32)) - m).abs();
                let e = &mut err[y as usize * w + x as usize];
                if e.is_nan() || *e < d {
                    *e = d;
                }
            }
        }
    }
    let mut max = 0.0f64;
    let mut sum = 0.0;
    for (i, e) in err.iter().enumerate() {
        assert!(!e.is_nan(), "sample ({}, {}) not covered", i % w, i / w);
        max = max.max(*e);
        sum += e * e;
    }
    (max, (sum / err.len() as f64).sqrt())
}

/// Independent topology check: vertices distinct grid samples, triangles counter-clockwise,
/// every directed edge used once, every edge without a twin on the domain border, areas summing
/// to the domain, no vertex inside any edge (no T-junctions).
fn check_topology(w: u32, h: u32, v: &[[u32; 2]], tris: &[[u32; 3]]) {
    let mut at = HashSet::new();
    for p in v {
        assert!(p[0] < w && p[1] < h, "vertex {p:?} outside");
        assert!(at.insert(*p), "duplicate vertex {p:?}");
    }
    let mut directed = HashSet::new();
    let mut area2: i128 = 0;
    for t in tris {
        let p = t.map(|i| v[i as usize].map(i64::from));
        let o =
            (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0]);
        assert!(o > 0, "triangle {t:?} degenerate or clockwise");
        area2 += i128::from(o);
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            assert!(directed.insert((a, b)), "directed edge {a}->{b} twice");
        }
    }
    assert_eq!(area2, 2 * i128::from(w - 1) * i128::from(h - 1), "area");
    let (w1, h1) = (w - 1, h - 1);
    let mut by_pos: HashMap<[u32; 2], u32> = HashMap::new();
    for (i, p) in v.iter().enumerate() {
        by_pos.insert(*p, i as u32);
    }
    for &(a, b) in &directed {
        let (p, q) = (v[a as usize], v[b as usize]);
        if !directed.contains(&(b, a)) {
            let border = (p[0] == q[0] && (p[0] == 0 || p[0] == w1))
                || (p[1] == q[1] && (p[1] == 0 || p[1] == h1));
            assert!(
                border,
                "edge {p:?}-{q:?} has one triangle but is inside the domain"
            );
        }
        let (ex, ey) = (
            i64::from(q[0]) - i64::from(p[0]),
            i64::from(q[1]) - i64::from(p[1]),
        );
        let g = gcd(ex.unsigned_abs(), ey.unsigned_abs()) as i64;
        for s in 1..g {
            let m = [
                (i64::from(p[0]) + ex / g * s) as u32,
                (i64::from(p[1]) + ey / g * s) as u32,
            ];
            assert!(
                !by_pos.contains_key(&m),
                "T-junction: {m:?} on edge {p:?}-{q:?}"
            );
        }
    }
}

fn gcd(a: u64, b: u64) -> u64 {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

/// Rounding slack of the independent scan against the crate's: both evaluate planes in f64 from
/// f32 heights but by different formulas, so they may differ by a few ulps of the heights.
fn slack<T: Terrain>(t: &T) -> f64 {
    let mut m = 0.0f64;
    for y in 0..t.height() {
        for x in 0..t.width() {
            m = m.max(f64::from(t.local_z(x, y)).abs());
        }
    }
    (m + 1.0) * 1e-12
}

/// Builds, then checks everything that must hold for any TIN; returns it.
fn build_checked<T: Terrain>(t: &T, o: &TinOptions) -> Tin {
    let tin = Tin::build(t, o).unwrap();
    let (v, tris) = (tin.vertices(), tin.triangles());
    check_topology(t.width(), t.height(), v, tris);
    assert!(v.len() <= o.max_vertices as usize);
    assert!(tris.len() <= o.max_triangles as usize);
    let m = mesh_error(t, v, tris).unwrap();
    // The builder's own bookkeeping equals the full-grid scan exactly.
    assert_eq!(m.max, tin.max_error());
    let (imax, irms) = independent_error(t, v, tris);
    let s = slack(t);
    assert!(
        (imax - m.max).abs() <= s,
        "independent max {imax} vs {}",
        m.max
    );
    assert!(
        (irms - m.rms).abs() <= s,
        "independent rms {irms} vs {}",
        m.rms
    );
    if tin.stop_reason() == StopReason::ErrorReached {
        assert!(
            m.max <= f64::from(o.max_error),
            "{} > {}",
            m.max,
            o.max_error
        );
        assert!(
            imax <= f64::from(o.max_error) + s,
            "{imax} > {}",
            o.max_error
        );
    } else {
        assert!(m.max > f64::from(o.max_error));
    }
    tin
}

fn grid(w: u32, h: u32, f: impl Fn(u32, u32) -> f32) -> Vec<f32> {
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| f(x, y))
        .collect()
}

#[test]
fn flat_grid_needs_only_the_corners() {
    for (w, h) in [(2, 2), (2, 9), (17, 3), (64, 64)] {
        let s = vec![7.5f32; (w * h) as usize];
        let hf = Heightfield::new(&s, w, h).unwrap();
        let tin = build_checked(&hf, &TinOptions::default());
        assert_eq!(tin.vertices().len(), 4);
        assert_eq!(tin.triangles().len(), 2);
        assert_eq!(tin.max_error(), 0.0);
    }
}

#[test]
fn tilted_plane_is_exact_with_two_triangles() {
    let s = grid(33, 20, |x, y| 0.25 * x as f32 - 0.5 * y as f32 + 3.0);
    let hf = Heightfield::new(&s, 33, 20).unwrap();
    let tin = build_checked(&hf, &TinOptions::default());
    assert_eq!(tin.triangles().len(), 2);
    assert_eq!(tin.max_error(), 0.0);
}

#[test]
fn two_by_two_grid() {
    let hf = Heightfield::new(&[0.0f32, 1.0, 5.0, -2.0], 2, 2).unwrap();
    let tin = build_checked(&hf, &TinOptions::default());
    assert_eq!(tin.vertices(), &[[0, 0], [1, 0], [1, 1], [0, 1]]);
    assert_eq!(tin.triangles().len(), 2);
    assert_eq!(tin.max_error(), 0.0);
}

#[test]
fn single_spike_anywhere_is_picked_first() {
    let (w, h) = (21u32, 13u32);
    for (sx, sy) in [(10, 6), (0, 6), (10, 0), (20, 12), (1, 1), (19, 11)] {
        let s = grid(w, h, |x, y| if (x, y) == (sx, sy) { 100.0 } else { 0.0 });
        let hf = Heightfield::new(&s, w, h).unwrap();
        let corner = [(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1)].contains(&(sx, sy));
        let tin = build_checked(&hf, &TinOptions::default().with_max_error(0.0));
        assert_eq!(tin.max_error(), 0.0);
        if !corner {
            assert_eq!(tin.vertices()[4], [sx, sy], "spike at ({sx}, {sy})");
        }
        // Budget of 5 vertices: the spike alone, error now from its flanks at most.
        let five = build_checked(&hf, &TinOptions::default().with_max_vertices(5));
        assert!(five.vertices().len() <= 5);
        if !corner {
            assert!(five.vertices().contains(&[sx, sy]));
        }
    }
}

#[test]
fn cliff_is_followed_within_error() {
    let (w, h) = (40u32, 30u32);
    // A diagonal step of 50 units.
    let s = grid(w, h, |x, y| if 2 * x + y > 40 { 50.0 } else { 0.0 });
    let hf = Heightfield::new(&s, w, h).unwrap();
    for e in [0.0f32, 1.0, 10.0, 49.0] {
        build_checked(&hf, &TinOptions::default().with_max_error(e));
    }
    // A straight vertical cliff.
    let s = grid(w, h, |x, _| if x >= 17 { -30.0 } else { 12.0 });
    let hf = Heightfield::new(&s, w, h).unwrap();
    let tin = build_checked(&hf, &TinOptions::default());
    assert_eq!(tin.max_error(), 0.0);
}

#[test]
fn zero_error_reproduces_the_grid_exactly() {
    let (w, h) = (23u32, 17u32);
    let s = grid(w, h, |x, y| {
        ((x * 7 + y * 13) % 11) as f32 * 0.37 - ((x * y) % 5) as f32
    });
    let hf = Heightfield::with_scale(&s, w, h, Scale::default().with_z_scale(3.0)).unwrap();
    let tin = build_checked(&hf, &TinOptions::default().with_max_error(0.0));
    assert_eq!(tin.max_error(), 0.0);
    assert_eq!(tin.measure(&hf).unwrap().max, 0.0);
    let (imax, _) = independent_error(&hf, tin.vertices(), tin.triangles());
    assert!(imax <= slack(&hf), "{imax}");
    // Every OBJ position is the sample's world position.
    for (p, v) in tin.positions(&hf).iter().zip(tin.vertices()) {
        assert_eq!(p[2], hf.z(v[0], v[1]));
    }
}

#[test]
fn bad_options_are_errors() {
    let hf = Heightfield::new(&[0.0f32; 9], 3, 3).unwrap();
    for e in [f32::NAN, f32::INFINITY, -0.5] {
        let r = Tin::build(&hf, &TinOptions::default().with_max_error(e));
        assert!(
            matches!(
                r,
                Err(Error::InvalidParameter {
                    name: "max_error",
                    ..
                })
            ),
            "{e}: {r:?}"
        );
    }
    assert!(matches!(
        Tin::build(&hf, &TinOptions::default().with_max_vertices(3)),
        Err(Error::InvalidParameter {
            name: "max_vertices",
            ..
        })
    ));
    assert!(matches!(
        Tin::build(&hf, &TinOptions::default().with_max_triangles(1)),
        Err(Error::InvalidParameter {
            name: "max_triangles",
            ..
        })
    ));
}

#[test]
fn composed_terrain_works() {
    let base = [0.0f32, 10.0, 5.0, 20.0, 0.0, 3.0, 8.0, 1.0, 4.0];
    let detail = [0.5f32, -0.5, -0.25, 0.25];
    let b = Heightfield::new(&base, 3, 3).unwrap();
    let d = Heightfield::new(&detail, 2, 2).unwrap();
    let c = Composed::new(b, d, 8).unwrap();
    for e in [0.0f32, 0.3, 2.0] {
        build_checked(&c, &TinOptions::default().with_max_error(e));
    }
}

#[test]
fn larger_error_never_needs_more_vertices_and_budgets_give_prefixes() {
    let (w, h) = (50u32, 41u32);
    let s = grid(w, h, |x, y| {
        let (fx, fy) = (x as f32 * 0.21, y as f32 * 0.17);
        20.0 * fx.sin() * fy.cos() + (x * y % 7) as f32 * 0.3
    });
    let hf = Heightfield::new(&s, w, h).unwrap();
    let full = build_checked(&hf, &TinOptions::default());
    let mut last = usize::MAX;
    for e in [0.0f32, 0.1, 0.5, 1.0, 2.0, 5.0, 10.0, 40.0] {
        let t = build_checked(&hf, &TinOptions::default().with_max_error(e));
        assert!(t.vertices().len() <= last);
        last = t.vertices().len();
        // The greedy order does not depend on the target: a coarser mesh's vertices are the
        // first ones of the finest.
        assert_eq!(t.vertices(), &full.vertices()[..t.vertices().len()]);
    }
    for n in [4u32, 5, 6, 10, 57, 300] {
        let t = build_checked(&hf, &TinOptions::default().with_max_vertices(n));
        assert_eq!(t.vertices().len(), n as usize);
        assert_eq!(t.vertices(), &full.vertices()[..n as usize]);
        assert_eq!(t.stop_reason(), StopReason::VertexBudget);
    }
    for n in [2u32, 3, 4, 9, 100, 501] {
        let t = build_checked(&hf, &TinOptions::default().with_max_triangles(n));
        assert!(t.triangles().len() <= n as usize);
        // Stops only when one more insertion could exceed the budget.
        assert!(t.triangles().len() + 2 > n as usize);
        assert_eq!(t.stop_reason(), StopReason::TriangleBudget);
    }
}

fn arb_grid() -> impl Strategy<Value = (u32, u32, Vec<f32>)> {
    (2u32..28, 2u32..28, any::<bool>()).prop_flat_map(|(w, h, ints)| {
        let n = (w * h) as usize;
        let v = if ints {
            prop::collection::vec((-20i32..20).prop_map(|i| i as f32), n).boxed()
        } else {
            prop::collection::vec(-1000.0f32..1000.0, n).boxed()
        };
        (Just(w), Just(h), v)
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    #[test]
    fn random_grids_meet_the_error((w, h, s) in arb_grid(), e in prop_oneof![Just(0.0f32), 0.0f32..50.0], zs in 0.01f32..10.0) {
        let hf = Heightfield::with_scale(&s, w, h, Scale::default().with_z_scale(zs).with_spacing(2.0, 0.5).with_z_offset(-100.0)).unwrap();
        let tin = build_checked(&hf, &TinOptions::default().with_max_error(e));
        prop_assert_eq!(tin.stop_reason(), StopReason::ErrorReached);
    }

    #[test]
    fn random_grids_respect_budgets((w, h, s) in arb_grid(), nv in 4u32..60, nt in 2u32..120) {
        let hf = Heightfield::new(&s, w, h).unwrap();
        build_checked(&hf, &TinOptions::default().with_max_vertices(nv));
        build_checked(&hf, &TinOptions::default().with_max_triangles(nt));
        build_checked(&hf, &TinOptions::default().with_max_vertices(nv).with_max_triangles(nt).with_max_error(1.0));
    }
}

fn read(path: &Path, format: Option<relief_io::Format>) -> relief_io::Dem {
    relief_io::read_dem(
        path,
        &relief_io::ReadOptions {
            format,
            ..Default::default()
        },
    )
    .unwrap()
}

#[test]
fn bundled_dem_meets_the_error() {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/puget_sound_1k.png");
    let mut dem = read(&p, None);
    dem.scale = dem.scale.with_spacing(160.0, 160.0).with_z_scale(0.1);
    let hf = dem.heightfield().unwrap();
    let mut last = usize::MAX;
    for e in [100.0f32, 50.0, 20.0] {
        let tin = Tin::build(&hf, &TinOptions::default().with_max_error(e)).unwrap();
        let m = tin.measure(&hf).unwrap();
        assert!(m.max <= f64::from(e), "E = {e}: {}", m.max);
        assert_eq!(m.max, tin.max_error());
        check_topology(hf.width(), hf.height(), tin.vertices(), tin.triangles());
        // Finer targets need more triangles, and all of them fewer than the full grid.
        assert!(last == usize::MAX || tin.triangles().len() > last);
        assert!(
            tin.triangles().len() < 2 * 1024 * 1024,
            "{}",
            tin.triangles().len()
        );
        eprintln!("puget E = {e} m: {} triangles", tin.triangles().len());
        last = tin.triangles().len();
    }
    // One independent scan on the full-size DEM.
    let tin = Tin::build(&hf, &TinOptions::default().with_max_error(50.0)).unwrap();
    let (imax, _) = independent_error(&hf, tin.vertices(), tin.triangles());
    assert!(imax <= 50.0 + slack(&hf), "{imax}");
}

#[test]
fn shared_real_dems_meet_the_error() {
    use relief_io::Format;
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data");
    if !dir.is_dir() {
        eprintln!("skipped: {} not present", dir.display());
        return;
    }
    let files = [
        ("martini_fuji.png", Some(Format::TerrainRgb), 5.0f32),
        ("delatin_14-2625-6369.png", Some(Format::TerrainRgb), 0.5),
        (
            "pymartini_mapbox_st_helens.png",
            Some(Format::TerrainRgb),
            1.0,
        ),
        ("pymartini_terrarium.png", Some(Format::Terrarium), 5.0),
        ("diligent_ps_height_1k.png", None, 20.0),
        ("topotoolbox_srtm_bigtujunga30m_utm11.tif", None, 5.0),
        ("pysheds_dem.tif", None, 1.0),
    ];
    for (name, format, e) in files {
        let p = dir.join(name);
        if !p.is_file() {
            eprintln!("skipped: {} not present", p.display());
            continue;
        }
        let dem = read(&p, format);
        let hf = dem.heightfield().unwrap();
        let tin = Tin::build(&hf, &TinOptions::default().with_max_error(e)).unwrap();
        let m = tin.measure(&hf).unwrap();
        assert!(m.max <= f64::from(e), "{name}: {} > {e}", m.max);
        assert_eq!(m.max, tin.max_error(), "{name}");
        check_topology(hf.width(), hf.height(), tin.vertices(), tin.triangles());
        let (imax, _) = independent_error(&hf, tin.vertices(), tin.triangles());
        assert!(
            imax <= f64::from(e) + slack(&hf),
            "{name}: independent {imax} > {e}"
        );
    }
}

#[test]
fn comparison_rows_match_the_builds() {
    let (w, h) = (37u32, 29u32);
    let s = grid(w, h, |x, y| {
        ((x as f32 * 0.3).sin() + (y as f32 * 0.2).cos()) * 25.0
    });
    let hf = Heightfield::new(&s, w, h).unwrap();
    let es = [20.0f32, 5.0, 1.0, 0.0];
    let rows = relief_tin::compare_tin(&hf, &es).unwrap();
    assert_eq!(rows.len(), es.len());
    for (r, &e) in rows.iter().zip(&es) {
        let tin = Tin::build(&hf, &TinOptions::default().with_max_error(e)).unwrap();
        assert_eq!(r.method, "tin");
        assert_eq!(r.target_error, e);
        assert_eq!(
            (r.vertices, r.triangles),
            (tin.vertices().len(), tin.triangles().len())
        );
        assert_eq!(r.max_error, tin.max_error());
        let (imax, irms) = independent_error(&hf, tin.vertices(), tin.triangles());
        assert!((r.max_error - imax).abs() <= slack(&hf));
        assert!((r.rms_error - irms).abs() <= slack(&hf));
        assert!(r.rms_error <= r.max_error && r.build_ms >= 0.0);
    }
    // A method whose mesh leaves a gap is an error, not a row.
    let gap = relief_tin::compare_method(&hf, "broken", &[1.0], |_| {
        Ok(relief_tin::GridMesh {
            vertices: vec![[0, 0], [w - 1, 0], [w - 1, h - 1]],
            triangles: vec![[0, 1, 2]],
        })
    });
    assert!(matches!(gap, Err(Error::OutOfBounds { .. })));
    let table = relief_tin::markdown_table(&rows);
    assert_eq!(table.lines().count(), 2 + rows.len());
}

/// FNV-1a of the vertex and triangle lists (as `examples/tin_time` prints it).
fn mesh_hash(tin: &Tin) -> u64 {
    let mut hash = 0xcbf2_9ce4_8422_2325u64;
    let words = tin.vertices().iter().flatten();
    for &w in words.chain(tin.triangles().iter().flatten()) {
        hash = (hash ^ u64::from(w)).wrapping_mul(0x0100_0000_01b3);
    }
    hash
}

/// The speed-ups that followed commit 2eb911d (shape table for small triangles, corners read
/// from the new vertex's ring, the popped face kept at the top of the heap) leave every mesh
/// bit-identical: same vertices in the same order, same triangles. The hashes were printed by
/// `tin_time` built from 2eb911d on these grids (heights with many ties, so that hint and
/// tie-breaking changes would show).
#[test]
fn meshes_are_those_of_the_reference_build() {
    let g1 = grid(120, 90, |x, y| {
        ((x * 7 + y * 13) % 17) as f32 * 0.25 + ((x * x + y) % 5) as f32
    });
    let g2 = grid(131, 77, |x, y| {
        (((x * x * 3 + y * y * 5 + x * y) % 23) + (x / 9) * 2 + (y / 7) * 3) as f32
    });
    let hf1 = Heightfield::new(&g1, 120, 90).unwrap();
    let hf2 = Heightfield::new(&g2, 131, 77).unwrap();
    let cases = [
        (&hf1, 0.0, 19359, 0x789f_cda9_01a0_26ed),
        (&hf1, 0.5, 18555, 0xfc2a_87bf_edc6_49d7),
        (&hf1, 3.0, 7781, 0x5cf5_760f_8e0c_9f1c),
        (&hf2, 0.0, 19760, 0xb164_a9e5_e3d1_c493),
        (&hf2, 2.0, 19156, 0x7f26_b7cf_b977_f80b),
        (&hf2, 6.0, 11786, 0x8e15_f377_a74f_05e3),
    ];
    for (hf, e, tris, hash) in cases {
        let (w, h) = (hf.width(), hf.height());
        let tin = Tin::build(hf, &TinOptions::default().with_max_error(e)).unwrap();
        assert_eq!(tin.triangles().len(), tris, "{w}x{h} E={e}");
        assert_eq!(mesh_hash(&tin), hash, "{w}x{h} E={e}");
    }
}
