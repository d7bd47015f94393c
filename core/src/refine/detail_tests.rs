//! Tests of detail refinement (std): the measured per-level bounds hold (and are tight where
//! the base is planar), and the refinement decision is nested across base and detail levels.

use super::super::preprocess::triangle_error;
use super::super::{preprocess, preprocess_compact, Hierarchy, View};
use super::*;
use crate::{Camera, Composed, Heightfield, Scale};
use glam::Vec3;

/// A small deterministic generator (no dependency needed for these loops).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 40) as f32) / (1u64 << 24) as f32
    }
}

fn noise(n: usize, amp: f32, seed: u64) -> Vec<f32> {
    let mut g = Lcg(seed);
    (0..n).map(|_| (g.next() - 0.5) * amp).collect()
}

/// Largest true error of each detail level's triangles over the whole virtual grid.
fn true_level_errors<B: Sample, D: Sample>(c: &Composed<'_, B, D>, base_levels: u32) -> Vec<f64> {
    let g = RefineGrid::new(c.width(), c.height()).unwrap();
    let mut worst = vec![0.0f64; (g.levels() - base_levels) as usize];
    for y in 0..c.height() {
        for x in 0..c.width() {
            let Some(l) = g.level(x, y) else { continue };
            if l < base_levels {
                continue;
            }
            for t in g.diamond(x, y).iter().flatten() {
                let e = triangle_error(c, &g, *t);
                assert!(e.is_finite(), "a detail triangle straddles the border");
                let w = &mut worst[(l - base_levels) as usize];
                *w = w.max(e);
            }
        }
    }
    worst
}

#[test]
fn measured_bounds_hold_on_every_detail_triangle() {
    // Non-square base, detail sizes that divide the pattern period and sizes that do not.
    for (bw, bh, dw, dh, k, seed) in [
        (9u32, 7u32, 8u32, 8u32, 4u32, 1u64),
        (5, 6, 6, 10, 8, 2),
        (4, 4, 16, 16, 16, 3),
        (6, 5, 3, 5, 2, 4),
    ] {
        let bs = noise((bw * bh) as usize, 40.0, seed);
        let ds = noise((dw * dh) as usize, 3.0, seed + 10);
        let base =
            Heightfield::with_scale(&bs, bw, bh, Scale::default().with_spacing(2.0, 3.0)).unwrap();
        let detail = Heightfield::new(&ds, dw, dh).unwrap();
        let c = Composed::new(base, detail, k).unwrap();
        let b = DetailBounds::measure(&c);
        assert_eq!(b.detail_levels(), 2 * k.trailing_zeros());
        let base_levels = RefineGrid::new(bw, bh).unwrap().levels();
        let truth = true_level_errors(&c, base_levels);
        let mut suffix = 0.0f64;
        for j in (0..b.detail_levels()).rev() {
            suffix = suffix.max(truth[j as usize]);
            let e = f64::from(b.error(j).unwrap());
            assert!(
                e >= suffix,
                "{bw}x{bh} detail {dw}x{dh} factor {k}: level {j} bound {e} < true {suffix}"
            );
            if j > 0 {
                assert!(b.error(j - 1).unwrap() >= b.error(j).unwrap(), "not nested");
            }
        }
    }
}

#[test]
fn measured_bounds_are_exact_on_a_planar_base() {
    // Planar base: twist 0, so the bound is the detail scan alone, which covers every offset of
    // the tiled map: it must equal the true nested maximum (up to the ulp margin).
    let bs: Vec<f32> = (0..9 * 9)
        .map(|i| (i % 9) as f32 * 2.0 + (i / 9) as f32)
        .collect();
    let ds = noise(16 * 16, 5.0, 7);
    let base = Heightfield::new(&bs, 9, 9).unwrap();
    let detail = Heightfield::new(&ds, 16, 16).unwrap();
    let c = Composed::new(base, detail, 8).unwrap();
    let b = DetailBounds::measure(&c);
    assert!(b.is_measured());
    assert_eq!(b.base_twist(), 0.0);
    let truth = true_level_errors(&c, 6);
    let mut suffix = 0.0f64;
    for j in (0..6u32).rev() {
        suffix = suffix.max(truth[j as usize]);
        let e = f64::from(b.error(j).unwrap());
        assert!(
            e >= suffix && e <= suffix * 1.0001 + 1e-3,
            "level {j}: {e} vs {suffix}"
        );
    }
}

#[test]
fn height_range_fallback_when_the_period_is_too_large() {
    // lcm(2 * 64, 127) = 16256 per axis: far more than 16 detail maps, so the range is used.
    let ds = noise(127 * 3, 2.0, 9);
    let base = Heightfield::new(&[0.0f32; 4], 2, 2).unwrap();
    let detail = Heightfield::new(&ds, 127, 3).unwrap();
    let c = Composed::new(base, detail, 64).unwrap();
    let b = DetailBounds::measure(&c);
    assert!(!b.is_measured());
    let (lo, hi) = b.detail_range();
    assert!(b.error(0).unwrap() >= hi - lo);
    assert!(b.error(11).unwrap() >= hi - lo);
}

fn check_nesting<B: Sample, D: Sample>(
    h: &Hierarchy<'_>,
    c: &Composed<'_, B, D>,
    b: &DetailBounds,
    seed: u64,
) {
    let g = RefineGrid::new(c.width(), c.height()).unwrap();
    let mut rng = Lcg(seed);
    let ext = (
        (c.width() - 1) as f32 * c.scale().dx,
        (c.height() - 1) as f32 * c.scale().dy,
    );
    let mut actives = 0usize;
    for _ in 0..12 {
        let eye = Vec3::new(
            rng.next() * ext.0 * 1.4 - 0.2 * ext.0,
            rng.next() * ext.1 * 1.4 - 0.2 * ext.1,
            rng.next() * 30.0 + 0.5,
        );
        let target = Vec3::new(rng.next() * ext.0, rng.next() * ext.1, 0.0);
        let Ok(cam) = Camera::new(eye, target, 20.0 + rng.next() * 100.0, 320, 200) else {
            continue;
        };
        let tau = 0.25 + rng.next() * 4.0;
        let view = View::new(&cam, tau).unwrap().with_culling(false);
        let dr = DetailRefiner::new(h, c, b, &view).unwrap();
        for y in 0..c.height() {
            for x in 0..c.width() {
                let Some(l) = g.level(x, y) else { continue };
                let m = (i64::from(x), i64::from(y));
                if !dr.active(m, l) {
                    continue;
                }
                actives += 1;
                for t in g.diamond(x, y).iter().flatten() {
                    // The parent is the right-angle corner: the other two are the hypotenuse.
                    let apex = (0..3)
                        .find(|&k| {
                            let (p, q) = (t[(k + 1) % 3], t[(k + 2) % 3]);
                            p.0 + q.0 == 2 * m.0 && p.1 + q.1 == 2 * m.1
                        })
                        .map(|k| t[k])
                        .unwrap();
                    if !g.in_domain(apex.0, apex.1) {
                        continue;
                    }
                    let Some(lp) = g.level(apex.0 as u32, apex.1 as u32) else {
                        continue; // a square corner: always in the mesh
                    };
                    assert_eq!(lp + 1, l);
                    assert!(
                        dr.active(apex, lp),
                        "vertex {m:?} (level {l}) active but its parent {apex:?} is not \
                         (eye {eye:?}, tau {tau})"
                    );
                }
            }
        }
    }
    assert!(
        actives > 0,
        "no view refined anything: the test tests nothing"
    );
}

#[test]
fn refinement_decision_is_nested_across_base_and_detail_levels() {
    let bs = noise(9 * 7, 30.0, 21);
    let ds = noise(8 * 8, 4.0, 22);
    let base = Heightfield::with_scale(&bs, 9, 7, Scale::default().with_spacing(8.0, 8.0)).unwrap();
    let detail = Heightfield::new(&ds, 8, 8).unwrap();
    let c = Composed::new(base, detail, 8).unwrap();
    let (mut e, mut r) = (vec![0.0; 63], vec![0.0; 63]);
    let h = preprocess(c.base(), &mut e, &mut r).unwrap();
    let measured = DetailBounds::measure(&c);
    check_nesting(&h, &c, &measured, 5);
    let constant = DetailBounds::constant(&c, 0.7).unwrap();
    check_nesting(&h, &c, &constant, 6);
    let mut ec = vec![0u16; 63];
    let hc = preprocess_compact(c.base(), &mut ec).unwrap();
    check_nesting(&hc, &c, &measured, 7);
    let mut buf = vec![0.0f32; local_bounds_len(9, 7)];
    let local = DetailBounds::measure_local(&c, &mut buf).unwrap();
    check_nesting(&h, &c, &local, 8);
    check_nesting(&hc, &c, &local, 9);
}

/// The right-angle corner of triangle `t` split at `m`: the parent of `m` through `t`.
fn apex(t: &[(i64, i64); 3], m: (i64, i64)) -> (i64, i64) {
    (0..3)
        .find(|&k| {
            let (p, q) = (t[(k + 1) % 3], t[(k + 2) % 3]);
            p.0 + q.0 == 2 * m.0 && p.1 + q.1 == 2 * m.1
        })
        .map(|k| t[k])
        .unwrap()
}

#[test]
fn local_bounds_hold_per_vertex_and_nest() {
    for (bw, bh, dw, dh, k, seed) in [
        (9u32, 7u32, 8u32, 8u32, 4u32, 51u64),
        (6, 9, 6, 10, 8, 52),
        (5, 5, 16, 16, 16, 53),
    ] {
        let bs = noise((bw * bh) as usize, 40.0, seed);
        let ds = noise((dw * dh) as usize, 3.0, seed + 10);
        let base =
            Heightfield::with_scale(&bs, bw, bh, Scale::default().with_spacing(2.0, 3.0)).unwrap();
        let detail = Heightfield::new(&ds, dw, dh).unwrap();
        let c = Composed::new(base, detail, k).unwrap();
        let mut buf = vec![0.0f32; local_bounds_len(bw, bh)];
        let b = DetailBounds::measure_local(&c, &mut buf).unwrap();
        let (mut e, mut r) = (vec![0.0; (bw * bh) as usize], vec![0.0; (bw * bh) as usize]);
        let h = preprocess(&base, &mut e, &mut r).unwrap();
        let cam = Camera::new(
            Vec3::new(0.0, 0.0, 9.0),
            Vec3::new(5.0, 5.0, 0.0),
            60.0,
            64,
            64,
        )
        .unwrap();
        let dr = DetailRefiner::new(&h, &c, &b, &View::new(&cam, 1.0).unwrap()).unwrap();
        let g = dr.grid();
        let base_levels = dr.base_levels();
        for y in 0..c.height() {
            for x in 0..c.width() {
                let Some(l) = g.level(x, y) else { continue };
                let m = (i64::from(x), i64::from(y));
                let own = dr.circle_error(m, l);
                for t in g.diamond(x, y).iter().flatten() {
                    if l >= base_levels {
                        let truth = triangle_error(&c, &g, *t);
                        assert!(
                            own >= truth,
                            "vertex {m:?} level {l}: bound {own} < {truth}"
                        );
                    }
                    let p = apex(t, m);
                    if !g.in_domain(p.0, p.1) {
                        continue;
                    }
                    let Some(lp) = g.level(p.0 as u32, p.1 as u32) else {
                        continue;
                    };
                    let pe = dr.circle_error(p, lp);
                    assert!(pe >= own, "parent {p:?} ({pe}) < child {m:?} ({own})");
                }
            }
        }
    }
}

#[test]
fn local_bounds_ignore_a_steep_cell_far_away() {
    // Flat base but one twisted cell at the origin: the global bound carries its twist
    // everywhere, the local one only near it.
    let mut bs = vec![0.0f32; 17 * 17];
    bs[0] = 100.0;
    let ds = noise(8 * 8, 0.2, 61);
    let base = Heightfield::new(&bs, 17, 17).unwrap();
    let detail = Heightfield::new(&ds, 8, 8).unwrap();
    let c = Composed::new(base, detail, 8).unwrap();
    let global = DetailBounds::measure(&c);
    let mut buf = vec![0.0f32; local_bounds_len(17, 17)];
    let local = DetailBounds::measure_local(&c, &mut buf).unwrap();
    let (mut e, mut r) = (vec![0.0; 289], vec![0.0; 289]);
    let h = preprocess(&base, &mut e, &mut r).unwrap();
    let cam = Camera::new(
        Vec3::new(0.0, 0.0, 9.0),
        Vec3::new(5.0, 5.0, 0.0),
        60.0,
        64,
        64,
    )
    .unwrap();
    let v = View::new(&cam, 1.0).unwrap();
    let dg = DetailRefiner::new(&h, &c, &global, &v).unwrap();
    let dl = DetailRefiner::new(&h, &c, &local, &v).unwrap();
    let bl = dl.base_levels();
    // A cell centre far from the origin (detail level 0) and one next to the steep cell.
    let far = dl.circle_error((100, 100), bl);
    let near = dl.circle_error((4, 4), bl);
    let g0 = dg.circle_error((100, 100), bl);
    assert!(g0 >= 25.0, "global level-0 bound carries the twist: {g0}");
    assert!(
        far < 1.0,
        "far from the steep cell the local bound is the detail part: {far}"
    );
    assert!(
        near >= 25.0,
        "the steep cell's own centre keeps its twist: {near}"
    );
}

#[test]
fn capacity_errors_name_what_is_needed() {
    let bs = noise(17 * 17, 1.0, 31);
    let ds = noise(4 * 4, 0.1, 32);
    let base = Heightfield::new(&bs, 17, 17).unwrap();
    let detail = Heightfield::new(&ds, 4, 4).unwrap();
    let c = Composed::new(base, detail, 4).unwrap();
    let (mut e, mut r) = (vec![0.0; 289], vec![0.0; 289]);
    let h = preprocess(c.base(), &mut e, &mut r).unwrap();
    let cam = Camera::new(
        Vec3::new(0.2, 0.2, 1.5),
        Vec3::new(8.0, 8.0, 0.0),
        60.0,
        100,
        100,
    )
    .unwrap();
    let b = DetailBounds::measure(&c);
    let dr = DetailRefiner::new(&h, &c, &b, &View::new(&cam, 4.0).unwrap()).unwrap();
    let t = dr.triangle_count();
    let mut s = vec![0u64; detail_scratch_len(3 * t)];
    let n = dr.count(&mut s).unwrap();
    assert_eq!(n.triangles, t);
    assert!(n.detail_triangles() > 0 && n.base_triangles() > 0, "{n:?}");
    // A scratch too small for the vertices: an error with a length that works.
    let mut small = vec![0u64; detail_scratch_len(n.vertices / 4)];
    let Err(Error::BufferTooSmall { needed, actual }) = dr.count(&mut small) else {
        panic!("expected a capacity error");
    };
    assert_eq!(actual, small.len());
    let mut enough = vec![0u64; needed];
    assert_eq!(dr.count(&mut enough).unwrap(), n);
    // Vertex and triangle buffers one short.
    let mut v = vec![[0.0f32; 3]; n.vertices];
    let mut tr = vec![[0u32; 3]; n.triangles];
    assert_eq!(
        dr.triangles(&mut s, &mut v[..n.vertices - 1], &mut tr),
        Err(Error::BufferTooSmall {
            needed: n.vertices,
            actual: n.vertices - 1
        })
    );
    assert_eq!(
        dr.triangles(&mut s, &mut v, &mut tr[..n.triangles - 1]),
        Err(Error::BufferTooSmall {
            needed: n.triangles,
            actual: n.triangles - 1
        })
    );
    assert_eq!(dr.triangles(&mut s, &mut v, &mut tr).unwrap(), n);
    // Mismatched bounds.
    let other = Composed::new(base, detail, 8).unwrap();
    let b8 = DetailBounds::measure(&other);
    assert!(matches!(
        DetailRefiner::new(&h, &c, &b8, &View::new(&cam, 0.5).unwrap()),
        Err(Error::InvalidFactor { factor: 8 })
    ));
}

#[test]
fn factor_one_is_base_refinement() {
    // No detail levels: the same triangles as the base refiner (culling off), detail of zero.
    let bs = noise(17 * 17, 20.0, 41);
    let zero = [0.0f32; 4];
    let base = Heightfield::new(&bs, 17, 17).unwrap();
    let detail = Heightfield::new(&zero, 2, 2).unwrap();
    let c = Composed::new(base, detail, 1).unwrap();
    let (mut e, mut r) = (vec![0.0; 289], vec![0.0; 289]);
    let h = preprocess(&base, &mut e, &mut r).unwrap();
    let cam = Camera::new(
        Vec3::new(-2.0, -2.0, 15.0),
        Vec3::new(8.0, 8.0, 0.0),
        60.0,
        300,
        300,
    )
    .unwrap();
    let view = View::new(&cam, 2.0).unwrap();
    let dr = DetailRefiner::new(&h, &c, &DetailBounds::measure(&c), &view).unwrap();
    let rf = super::super::Refiner::new(&h, &base, super::super::Criterion::View(view)).unwrap();
    let base_n = rf
        .count(&mut vec![0; super::super::scratch_len(17, 17)])
        .unwrap();
    let n = dr
        .count(&mut vec![0; detail_scratch_len(3 * dr.triangle_count())])
        .unwrap();
    assert_eq!(
        (n.vertices, n.triangles),
        (base_n.vertices, base_n.triangles)
    );
    assert_eq!(n.detail_triangles(), 0);
}
