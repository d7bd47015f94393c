//! Unit tests of preprocessing, refinement, strips and the error scan (std only in tests).

use super::*;
use crate::{Camera, Heightfield, Scale, Terrain};
use glam::Vec3;
use proptest::prelude::*;
use std::vec;
use std::vec::Vec;

/// A xorshift64 generator for test data (`seed | 1`, so never stuck at zero).
pub(crate) fn rng(seed: u64) -> impl FnMut() -> u64 {
    let mut s = seed | 1;
    move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s
    }
}

pub(crate) struct Mesh {
    pub v: Vec<[f32; 3]>,
    pub t: Vec<[u32; 3]>,
}

pub(crate) fn list<T: Terrain>(h: &Hierarchy<'_>, t: &T, c: Criterion) -> Mesh {
    let r = Refiner::new(h, t, c).unwrap();
    let (w, hh) = (t.width(), t.height());
    let mut s = vec![0; scratch_len(w, hh)];
    let n = r.count(&mut s).unwrap();
    let mut v = vec![[0.0; 3]; n.vertices];
    let mut tr = vec![[0; 3]; n.triangles];
    let c2 = r.triangles(&mut s, &mut v, &mut tr).unwrap();
    assert_eq!(c2, n);
    Mesh { v, t: tr }
}

fn scan<T: Terrain>(t: &T, m: &Mesh) -> f64 {
    let mut cov = vec![0; coverage_len(t.width(), t.height())];
    vertical_error(t, &m.v, &m.t, &mut cov).unwrap()
}

fn ccw(m: &Mesh) -> bool {
    m.t.iter().all(|t| {
        let [a, b, c] = t.map(|i| m.v[i as usize]);
        (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]) > 0.0
    })
}

fn area(m: &Mesh) -> f64 {
    m.t.iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| m.v[i as usize].map(|x| x as f64));
            0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
        })
        .sum()
}

fn grid(w: u32, h: u32, seed: u64, amp: f32) -> Vec<f32> {
    let mut s = seed | 1;
    (0..w * h)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            ((s >> 11) % 1000) as f32 / 1000.0 * amp
        })
        .collect()
}

fn check_vi(samples: &[f32], w: u32, h: u32, e: f32) {
    let hf = Heightfield::new(samples, w, h).unwrap();
    let n = hierarchy_len(w, h);
    let (mut er, mut ra) = (vec![0.0; n], vec![0.0; n]);
    let full = preprocess(&hf, &mut er, &mut ra).unwrap();
    let mut ec = vec![0u16; n];
    let compact = preprocess_compact(&hf, &mut ec).unwrap();
    for hier in [&full, &compact] {
        let m = list(hier, &hf, Criterion::MaxError(e));
        let err = scan(&hf, &m);
        assert!(err <= e as f64, "{w}x{h} E={e}: measured {err}");
        assert!(ccw(&m), "{w}x{h}: a triangle is not counter-clockwise");
        let want = (w - 1) as f64 * (h - 1) as f64;
        assert!((area(&m) - want).abs() < 1e-6 * want.max(1.0));
    }
}

#[test]
fn spike_flat_and_full_resolution() {
    // Flat: two triangles whatever the size.
    for (w, h) in [(2, 2), (3, 3), (9, 9), (17, 5), (6, 11)] {
        let s = vec![3.0f32; (w * h) as usize];
        let hf = Heightfield::new(&s, w, h).unwrap();
        let mut e = vec![0u16; (w * h) as usize];
        let hi = preprocess_compact(&hf, &mut e).unwrap();
        let m = list(&hi, &hf, Criterion::MaxError(0.0));
        assert_eq!(scan(&hf, &m), 0.0);
        if hi.grid().is_square() {
            assert_eq!(m.t.len(), 2, "{w}x{h}");
        }
    }
    // E = 0 on noise: every sample is a vertex.
    let (w, h) = (13, 10);
    let s = grid(w, h, 7, 50.0);
    let hf = Heightfield::new(&s, w, h).unwrap();
    let (mut e, mut r) = (vec![0.0; 130], vec![0.0; 130]);
    let hi = preprocess(&hf, &mut e, &mut r).unwrap();
    let m = list(&hi, &hf, Criterion::MaxError(0.0));
    assert_eq!(m.v.len(), 130);
    assert_eq!(m.t.len(), triangle_bound(w, h));
    assert_eq!(scan(&hf, &m), 0.0);
}

#[test]
fn errors_are_nested_and_radii_contain_children() {
    let (w, h) = (33, 33);
    let s = grid(w, h, 3, 100.0);
    let hf = Heightfield::with_scale(&s, w, h, Scale::default().with_spacing(2.0, 3.0)).unwrap();
    let (mut e, mut r) = (vec![0.0; 33 * 33], vec![0.0; 33 * 33]);
    let hi = preprocess(&hf, &mut e, &mut r).unwrap();
    let g = hi.grid();
    for y in 0..h {
        for x in 0..w {
            for c in g.children(x, y).iter().flatten() {
                let (cx, cy) = (c.0 as u32, c.1 as u32);
                assert!(hi.error(x, y).unwrap() >= hi.error(cx, cy).unwrap());
                let p = hf.position(x, y).unwrap();
                let q = hf.position(cx, cy).unwrap();
                let d = p.distance(q) + hi.radius(cx, cy).unwrap();
                assert!(hi.radius(x, y).unwrap() >= d, "radius nesting at {x},{y}");
            }
        }
    }
}

#[test]
fn buffer_one_too_small_is_an_error() {
    let (w, h) = (17, 17);
    let s = grid(w, h, 9, 20.0);
    let hf = Heightfield::new(&s, w, h).unwrap();
    let mut e = vec![0u16; 289];
    let hi = preprocess_compact(&hf, &mut e).unwrap();
    let r = Refiner::new(&hi, &hf, Criterion::MaxError(2.0)).unwrap();
    let mut sc = vec![0; scratch_len(w, h)];
    let c = r.count(&mut sc).unwrap();
    let mut v = vec![[0.0; 3]; c.vertices];
    let mut t = vec![[0; 3]; c.triangles - 1];
    assert_eq!(
        r.triangles(&mut sc, &mut v, &mut t),
        Err(Error::BufferTooSmall {
            needed: c.triangles,
            actual: c.triangles - 1
        })
    );
    let mut v2 = vec![[0.0; 3]; c.vertices - 1];
    let mut t2 = vec![[0; 3]; c.triangles];
    assert!(r.triangles(&mut sc, &mut v2, &mut t2).is_err());
    assert!(r.count(&mut sc[1..]).is_err());
    // A longer error buffer than needed changes nothing.
    let mut long = vec![0u16; 300];
    let hl = preprocess_compact(&hf, &mut long).unwrap();
    let rl = Refiner::new(&hl, &hf, Criterion::MaxError(2.0)).unwrap();
    assert_eq!(rl.count(&mut sc).unwrap(), c);
    let mut e2 = vec![0u16; 288];
    assert!(preprocess_compact(&hf, &mut e2).is_err());
}

/// SOAR's strip (`soar`) or the in/out-edge strip of `r` into bound-sized buffers: vertices,
/// strip indices, counts.
pub(crate) fn strip<T: Terrain>(
    r: &Refiner<'_, '_, T>,
    soar: bool,
) -> (Vec<[f32; 3]>, Vec<u32>, StripCounts) {
    let (w, h) = (r.g.width(), r.g.height());
    let mut sc = vec![0; scratch_len(w, h)];
    let mut v = vec![[0.0; 3]; (w * h) as usize];
    let mut st = vec![0; strip_bound(w, h)];
    let c = if soar {
        r.soar_strip(&mut sc, &mut v, &mut st).unwrap()
    } else {
        r.inout_strip(&mut sc, &mut v, &mut st).unwrap()
    };
    (v, st, c)
}

#[test]
fn inout_strip_draws_the_list_mesh() {
    strips_draw_the_list_mesh(false);
}

#[test]
fn soar_strip_draws_the_list_mesh() {
    strips_draw_the_list_mesh(true);
}

fn strips_draw_the_list_mesh(soar: bool) {
    for (n, m, seed, e) in [
        (3u32, 3u32, 1u64, 0.0f32),
        (5, 5, 2, 0.0),
        (9, 9, 3, 5.0),
        (33, 33, 4, 10.0),
        (65, 65, 5, 3.0),
        (129, 129, 6, 20.0),
        // Any size: the domain's edge splits.
        (2, 3, 7, 0.0),
        (3, 2, 8, 1e9),
        (7, 5, 9, 0.0),
        (13, 10, 10, 5.0),
        (40, 17, 11, 1e9),
        (100, 37, 12, 10.0),
        (66, 65, 13, 3.0),
        (129, 200, 14, 20.0),
    ] {
        strip_draws_the_list_mesh(n, m, seed, e, soar);
    }
}

/// The strips' geomorph data: one entry per strip vertex, at its position, and the same data
/// as the list's morph for a vertex both meshes have (all of them view-independently off the
/// square, where both strips draw the list's mesh).
#[test]
fn strip_morph_follows_the_strip_vertices_and_the_lists_morph() {
    for (w, h) in [(65u32, 49u32), (65, 65), (40, 17)] {
        let s = grid(w, h, 31, 60.0);
        let hf =
            Heightfield::with_scale(&s, w, h, Scale::default().with_spacing(10.0, 10.0)).unwrap();
        let n = hierarchy_len(w, h);
        let (mut er, mut ra) = (vec![0.0; n], vec![0.0; n]);
        let full = preprocess(&hf, &mut er, &mut ra).unwrap();
        let cam = Camera::new(
            Vec3::new(-50.0, -50.0, 150.0),
            Vec3::new(320.0, 240.0, 0.0),
            60.0,
            320,
            240,
        )
        .unwrap();
        let view = View::new(&cam, 2.0).unwrap().with_geomorph(Some(3.0));
        for c in [Criterion::MaxError(5.0), Criterion::View(view)] {
            let r = Refiner::new(&full, &hf, c).unwrap();
            let mut sc = vec![0; scratch_len(w, h)];
            let mut list_morph = vec![MorphVertex::default(); n];
            let ln = r.morph(&mut sc, &mut list_morph).unwrap();
            let by_position: std::collections::HashMap<[u32; 3], MorphVertex> = list_morph[..ln]
                .iter()
                .map(|m| (m.position.map(f32::to_bits), *m))
                .collect();
            let mut mid_morph = 0;
            for soar in [false, true] {
                let (v, _, counts) = strip(&r, soar);
                let mut out = vec![MorphVertex::default(); counts.vertices];
                let morph = |sc: &mut [u64], out: &mut [MorphVertex]| {
                    if soar {
                        r.soar_strip_morph(sc, out)
                    } else {
                        r.inout_strip_morph(sc, out)
                    }
                };
                assert_eq!(morph(&mut sc, &mut out).unwrap(), counts.vertices);
                // One element short: an error, and the scratch is left clean for the next call.
                assert!(morph(&mut sc, &mut out[..counts.vertices - 1]).is_err());
                let mut shared = 0;
                for (m, p) in out.iter().zip(&v) {
                    assert_eq!(&m.position, p);
                    assert!((0.0..=1.0).contains(&m.morph));
                    if m.morph > 0.0 && m.morph < 1.0 {
                        mid_morph += 1;
                    }
                    if let Some(l) = by_position.get(&m.position.map(f32::to_bits)) {
                        assert_eq!(l, m);
                        shared += 1;
                    }
                }
                let square = w == h;
                if matches!(c, Criterion::MaxError(_)) && !square {
                    assert_eq!(shared, ln);
                    assert_eq!(counts.vertices, ln);
                }
                assert!(
                    shared > counts.vertices / 2,
                    "{w}x{h}: {shared} of {}",
                    counts.vertices
                );
            }
            std::println!("{w}x{h}: {mid_morph} strip vertices in mid-morph");
            if matches!(c, Criterion::View(_)) {
                assert!(
                    mid_morph > 0,
                    "{w}x{h}: no vertex in mid-morph, the test shows nothing"
                );
            }
        }
    }
}

/// Seed 004's claim for its strip (chapter 5.1): the in/out-edge strip never tests a vertex
/// that cannot be active, so it makes far fewer decisions than SOAR's strip for the same mesh.
#[test]
fn inout_strip_tests_fewer_vertices_than_soars() {
    for (w, h, e) in [
        (129u32, 129u32, 10.0f32),
        (129, 129, 2.0),
        (100, 37, 5.0),
        (65, 200, 20.0),
    ] {
        let s = grid(w, h, 21, 100.0);
        let hf = Heightfield::new(&s, w, h).unwrap();
        let mut er = vec![0u16; (w * h) as usize];
        let hi = preprocess_compact(&hf, &mut er).unwrap();
        let r = Refiner::new(&hi, &hf, Criterion::MaxError(e)).unwrap();
        let mut sc = vec![0; scratch_len(w, h)];
        let inout = r.inout_strip_counts(&mut sc).unwrap();
        let soar = r.soar_strip_counts(&mut sc).unwrap();
        std::println!(
            "{w}x{h} E={e}: tested {} (in/out) vs {} (SOAR)",
            inout.tested,
            soar.tested
        );
        assert!(inout.tested > 0);
        assert!(
            3 * inout.tested <= 2 * soar.tested,
            "{w}x{h} E={e}: {inout:?} vs {soar:?}"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]
    /// Both strips draw the list's mesh on grids of any size, within [`strip_bound`].
    #[test]
    fn strips_of_any_size_draw_the_list_mesh(
        w in 2u32..48, h in 2u32..48, seed in 1u64..1000, e in prop::sample::select(vec![0.0f32, 1.0, 5.0, 20.0, 1e9]),
        soar in prop::bool::ANY,
    ) {
        strip_draws_the_list_mesh(w, h, seed, e, soar);
    }
}

/// Both strips of an `n x nh` noise grid at threshold `e`: the list's mesh (where no level is
/// forced), counter-clockwise, within E, covering the domain, within [`strip_bound`].
fn strip_draws_the_list_mesh(n: u32, nh: u32, seed: u64, e: f32, soar: bool) {
    let s = grid(n, nh, seed, 100.0);
    let hf = Heightfield::new(&s, n, nh).unwrap();
    let mut er = vec![0u16; (n * nh) as usize];
    let hi = preprocess_compact(&hf, &mut er).unwrap();
    let r = Refiner::new(&hi, &hf, Criterion::MaxError(e)).unwrap();
    let (v, st, c) = strip(&r, soar);
    assert!(c.indices <= strip_bound(n, nh), "{n}x{nh}: {c:?}");
    let mut sc = vec![0; scratch_len(n, nh)];
    let counted = if soar {
        r.soar_strip_counts(&mut sc)
    } else {
        r.inout_strip_counts(&mut sc)
    };
    assert_eq!(counted.unwrap(), c);
    // With grid coordinates: the same strip, each vertex's column and row.
    let mut g = vec![[0u16; 2]; (n * nh) as usize];
    let mut st2 = vec![0; strip_bound(n, nh)];
    let c2 = if soar {
        r.soar_strip(&mut sc, &mut g, &mut st2).unwrap()
    } else {
        r.inout_strip(&mut sc, &mut g, &mut st2).unwrap()
    };
    assert_eq!(c2, c);
    assert_eq!(st2[..c.indices], st[..c.indices]);
    for (g, p) in g[..c.vertices].iter().zip(&v) {
        assert_eq!([g[0] as f32, g[1] as f32], [p[0], p[1]]);
    }
    let tris: Vec<[u32; 3]> = strip_triangles(&st[..c.indices]).collect();
    assert_eq!(tris.len(), c.triangles);
    // Against the fewest indices any strip of these triangles in this order needs: the strip
    // itself is one such strip; on a square grid (one piece) it is the fewest up to its start
    // (the entry vertex twice).
    let fewest = strip_fewest_indices(&st[..c.indices], true).unwrap();
    assert!(fewest <= c.indices, "{n}x{nh}: {fewest} > {c:?}");
    let mut back = vec![0u8; strip_fewest_scratch_len(c.indices)];
    let mut re = vec![0u32; c.indices];
    let k = strip_fewest(&st[..c.indices], true, &mut back, &mut re).unwrap();
    assert_eq!(k, fewest);
    assert!(same_triangles(&re[..k], &st[..c.indices], true), "{n}x{nh}");
    let square = n == nh && (n - 1).is_power_of_two();
    if square {
        assert!(c.indices <= fewest + 3, "{n}x{nh}: {c:?}, fewest {fewest}");
    }
    let m = Mesh {
        v: v[..c.vertices].to_vec(),
        t: tris.clone(),
    };
    assert!(ccw(&m), "{n}x{nh}: strip triangle not counter-clockwise");
    assert!(scan(&hf, &m) <= e as f64);
    let want = ((n - 1) * (nh - 1)) as f64;
    assert!(
        (area(&m) - want).abs() < 1e-6 * want,
        "{n}x{nh}: area {} vs {want}",
        area(&m)
    );
    // Same as the list when the top levels are refined anyway (always on a grid that does
    // not fill its square: no forced levels there).
    let l = list(&hi, &hf, Criterion::MaxError(e));
    if l.t.len() == tris.len() || !square {
        let key = |mm: &Mesh, t: [u32; 3]| {
            let p = t.map(|i| mm.v[i as usize].map(f32::to_bits));
            let k = (0..3).min_by_key(|&i| p[i]).unwrap();
            [p[k], p[(k + 1) % 3], p[(k + 2) % 3]]
        };
        let mut x: Vec<_> = tris.iter().map(|&t| key(&m, t)).collect();
        let mut y: Vec<_> = l.t.iter().map(|&t| key(&l, t)).collect();
        x.sort();
        y.sort();
        assert_eq!(x, y, "{n}x{nh}");
    }
    std::println!(
        "{n}x{nh} E={e}: {} indices for {} triangles ({:.3}), fewest for this order {fewest}",
        c.indices,
        c.triangles,
        c.indices_per_triangle()
    );
}

/// `t` turned so that its smallest index comes first (the same triangle, same winding).
fn rotated(t: [u32; 3]) -> [u32; 3] {
    let k = (0..3).min_by_key(|&i| t[i]).unwrap();
    [t[k], t[(k + 1) % 3], t[(k + 2) % 3]]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]
    /// `strip_fewest` on longer random strips (beyond the brute force): as many indices as
    /// `strip_fewest_indices` says, the same triangles in the same order, both ways.
    #[test]
    fn strip_fewest_rewrites_long_random_strips(
        strip in prop::collection::vec(0u32..7, 3..80), winding in prop::bool::ANY,
    ) {
        let mut scratch = vec![0u8; strip_fewest_scratch_len(strip.len())];
        let mut out = vec![0u32; strip.len()];
        let n = strip_fewest(&strip, winding, &mut scratch, &mut out).unwrap();
        prop_assert_eq!(n, strip_fewest_indices(&strip, winding).unwrap_or(0));
        prop_assert!(n <= strip.len());
        prop_assert!(same_triangles(&out[..n], &strip, winding));
        // Rewriting again changes nothing in length.
        let mut again = vec![0u32; n];
        let mut scratch2 = vec![0u8; strip_fewest_scratch_len(n)];
        prop_assert_eq!(strip_fewest(&out[..n], winding, &mut scratch2, &mut again), Ok(n));
    }
}

/// Triangle `t` as a strip draws it: turned so that its smallest index comes first with
/// `winding`, its indices sorted without (either way round the same).
fn drawn(t: [u32; 3], winding: bool) -> [u32; 3] {
    if winding {
        rotated(t)
    } else {
        let mut u = t;
        u.sort_unstable();
        u
    }
}

/// Whether strips `a` and `b` draw the same triangles in the same order (each the same way
/// round with `winding`).
fn same_triangles(a: &[u32], b: &[u32], winding: bool) -> bool {
    let key = |t| drawn(t, winding);
    strip_triangles(a).map(key).eq(strip_triangles(b).map(key))
}

/// Every strip of at most `len` indices from `0..k`, by brute force: the fewest that draws
/// `want` (in order, nothing else; counter-clockwise with `winding`, either way without), if
/// any.
fn fewest_by_search(want: &[[u32; 3]], k: u32, len: usize, winding: bool) -> Option<usize> {
    let key = |t| drawn(t, winding);
    let mut s = vec![0u32; len];
    for n in 3..=len {
        let total = (k as u64).pow(n as u32);
        for code in 0..total {
            let mut c = code;
            for v in s.iter_mut().take(n) {
                *v = (c % k as u64) as u32;
                c /= k as u64;
            }
            if strip_triangles(&s[..n])
                .map(key)
                .eq(want.iter().copied().map(key))
            {
                return Some(n);
            }
        }
    }
    None
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// `strip_fewest_indices` equals a brute-force search over all short strips, on the
    /// triangles of random short strips over four or five vertices, with and without winding.
    #[test]
    fn fewest_strip_indices_match_a_brute_force_search(
        k in 4u32..6, strip in prop::collection::vec(0u32..5, 3..8), winding in prop::bool::ANY,
    ) {
        let strip: Vec<u32> = strip.into_iter().map(|v| v % k).collect();
        let want: Vec<[u32; 3]> = strip_triangles(&strip).collect();
        let fewest = strip_fewest_indices(&strip, winding);
        let mut scratch = vec![0u8; strip_fewest_scratch_len(strip.len())];
        let mut out = vec![0u32; strip.len()];
        let n = strip_fewest(&strip, winding, &mut scratch, &mut out).unwrap();
        if want.is_empty() {
            prop_assert_eq!(fewest, None);
            prop_assert_eq!(n, 0);
        } else {
            let f = fewest.unwrap();
            prop_assert!(f <= strip.len());
            prop_assert_eq!(fewest_by_search(&want, k, f, winding), Some(f), "{:?}", strip);
            // The rewritten strip: that many indices, the same triangles in the same order.
            prop_assert_eq!(n, f);
            prop_assert!(same_triangles(&out[..n], &strip, winding), "{:?} -> {:?}", strip, &out[..n]);
            if n > 0 {
                prop_assert!(strip_fewest(&strip, winding, &mut scratch, &mut out[..n - 1]).is_err());
                prop_assert!(strip_fewest(&strip, winding, &mut scratch[1..], &mut out).is_err());
            }
        }
    }
}

fn view_mesh<T: Terrain>(h: &Hierarchy<'_>, t: &T, v: View) -> Mesh {
    list(h, t, Criterion::View(v))
}

/// Every in-frustum sample's vertical error, projected at its distance, is at most `tau`.
fn screen_check<T: Terrain>(t: &T, m: &Mesh, cam: &Camera, tau: f32, near: f32) {
    let planes = cam.frustum_planes(near, near * 1e6).unwrap();
    let s = t.scale();
    let (w, h) = (t.width() as i64, t.height() as i64);
    let mut best = vec![f64::NAN; (w * h) as usize];
    for tri in &m.t {
        let p = tri.map(|i| {
            let v = m.v[i as usize];
            (
                (v[0] / s.dx).round() as i64,
                (v[1] / s.dy).round() as i64,
                v[2] as f64,
            )
        });
        let Some(pl) = raster::Plane::new(p) else {
            continue;
        };
        raster::for_each_span(
            (p[0].0, p[0].1),
            (p[1].0, p[1].1),
            (p[2].0, p[2].1),
            |y, lo, hi| {
                for x in lo..=hi {
                    let e = (t.z(x as u32, y as u32) as f64 - pl.at(x, y)).abs();
                    let b = &mut best[(y * w + x) as usize];
                    if b.is_nan() || *b < e {
                        *b = e;
                    }
                }
            },
        );
    }
    let kappa = cam.kappa() as f64;
    for y in 0..h {
        for x in 0..w {
            let p = t.position(x as u32, y as u32).unwrap();
            if !planes[..5].iter().all(|pl| pl.dot(p.extend(1.0)) >= 0.0) {
                continue;
            }
            let e = best[(y * w + x) as usize];
            assert!(!e.is_nan(), "in-view sample {x},{y} not covered");
            let d = (p - cam.eye).length() as f64;
            let px = e * kappa / d;
            assert!(
                px <= tau as f64 * (1.0 + 1e-5) + 1e-9,
                "sample {x},{y}: {px} px > {tau}"
            );
        }
    }
}

#[test]
fn view_dependent_meets_pixel_threshold() {
    let (w, h) = (65, 49);
    let s = grid(w, h, 11, 30.0);
    let hf = Heightfield::with_scale(&s, w, h, Scale::default().with_spacing(10.0, 10.0)).unwrap();
    let n = hierarchy_len(w, h);
    let (mut er, mut ra) = (vec![0.0; n], vec![0.0; n]);
    let full = preprocess(&hf, &mut er, &mut ra).unwrap();
    let mut ec = vec![0u16; n];
    let compact = preprocess_compact(&hf, &mut ec).unwrap();
    let cams = [
        (Vec3::new(-50.0, -50.0, 200.0), Vec3::new(320.0, 240.0, 0.0)),
        (Vec3::new(320.0, 240.0, 40.0), Vec3::new(600.0, 300.0, 10.0)),
        (Vec3::new(320.0, 240.0, 5.0), Vec3::new(0.0, 240.0, 5.0)), // along the ground
    ];
    for (eye, target) in cams {
        let cam = Camera::new(eye, target, 60.0, 320, 240).unwrap();
        for hier in [&full, &compact] {
            for lazy in [0, 4] {
                let v = View::new(&cam, 2.0).unwrap().with_lazy_levels(lazy);
                let m = view_mesh(hier, &hf, v);
                assert!(ccw(&m));
                screen_check(&hf, &m, &cam, 2.0, 0.1);
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]
    #[test]
    fn view_independent_error_is_bounded(
        w in 2u32..40, h in 2u32..40, seed in 1u64..1000, amp in 0.0f32..100.0, frac in 0.0f32..1.0,
        quant in prop::bool::ANY,
    ) {
        let mut s = grid(w, h, seed, amp);
        if quant {
            for v in &mut s { *v = (*v * 10.0).round() / 10.0; }
        }
        let e = if quant { (frac * amp * 10.0).round() / 10.0 } else { frac * amp };
        check_vi(&s, w, h, e);
    }
}

#[test]
fn finest_level_fast_path_equals_rasterising() {
    let (w, h) = (17u32, 12u32);
    let s = grid(w, h, 23, 77.0);
    let hf = Heightfield::with_scale(&s, w, h, Scale::default().with_z_scale(0.37)).unwrap();
    let g = RefineGrid::new(w, h).unwrap();
    let mut checked = 0;
    for y in 0..h {
        for x in 0..w {
            for tri in g.diamond(x, y).iter().flatten() {
                if g.classify(*tri) != grid::Class::Inside
                    || raster::orient(tri[0], tri[1], tri[2]).abs() != 2
                {
                    continue;
                }
                let fast = preprocess::triangle_error(&hf, &g, *tri);
                let z = |p: (i64, i64)| hf.local_z(p.0 as u32, p.1 as u32) as f64;
                let pl = raster::Plane::new(tri.map(|p| (p.0, p.1, z(p)))).unwrap();
                let mut slow = 0.0f64;
                raster::for_each_span(tri[0], tri[1], tri[2], |yy, lo, hi| {
                    for xx in lo..=hi {
                        slow = slow.max((z((xx, yy)) - pl.at(xx, yy)).abs());
                    }
                });
                assert_eq!(fast.to_bits(), slow.to_bits());
                checked += 1;
            }
        }
    }
    assert!(checked > 100);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// The view-independent selection's two ways (traversal of the kept part, one pass over
    /// the errors) mark the same vertices with the same ranks, for every error store, and the
    /// traversal leaves the scratch clean after release.
    #[test]
    fn sparse_and_dense_view_independent_selections_agree(
        w in 2u32..40, h in 2u32..40, seed in 1u64..1000, amp in 0.0f32..100.0, frac in 0.0f32..1.0,
        square in prop::bool::ANY,
    ) {
        let (w, h) = if square { let k = 1 + (w % 5); (1 << k | 1, 1 << k | 1) } else { (w, h) };
        let s = grid(w, h, seed, amp);
        let hf = Heightfield::new(&s, w, h).unwrap();
        let n = hierarchy_len(w, h);
        let (mut er, mut ra) = (vec![0.0; n], vec![0.0; n]);
        let full = preprocess(&hf, &mut er, &mut ra).unwrap();
        let mut ec = vec![0u16; n];
        let compact = preprocess_compact(&hf, &mut ec).unwrap();
        let mut rl = vec![VertexRecord::default(); records_len(w, h, RecordLayout::Linear)];
        let lin = pack_records(&full, &hf, RecordLayout::Linear, &mut rl).unwrap();
        let mut ri = vec![VertexRecord::default(); records_len(w, h, RecordLayout::Interleaved)];
        let il = pack_records(&full, &hf, RecordLayout::Interleaved, &mut ri).unwrap();
        let e = frac * amp;
        let len = scratch_len(w, h);
        let words = (w as usize * h as usize).div_ceil(64);
        let summary = words.div_ceil(64);
        for hier in [&full, &compact, &lin, &il] {
            let r = Refiner::new(hier, &hf, Criterion::MaxError(e)).unwrap();
            // Both scratches start with garbage: any initial contents work.
            let (mut a, mut b) = (vec![u64::MAX; len], vec![u64::MAX; len]);
            let sa = r.select_within(&mut a, usize::MAX).unwrap();
            let sb = r.select_within(&mut b, 0).unwrap();
            // Every grid of fewer than 2^32 samples may select sparsely.
            prop_assert!(sa.sparse && !sb.sparse);
            prop_assert_eq!(sa.counts, sb.counts);
            for k in 0..words {
                // Sparse marks summarise the words they touch; the others stay zero.
                let touched = (a[2 * words + k / 64] >> (k % 64)) & 1 == 1;
                prop_assert!(touched || a[k] == 0 || !sa.sparse);
                prop_assert_eq!(a[k], b[k], "bitmap word {}", k);
                if a[k] != 0 {
                    prop_assert_eq!(a[words + k], b[words + k], "rank prefix of word {}", k);
                }
            }
            r.release(&mut a, sa);
            if sa.sparse {
                // Released sparse marks leave the bitmap and summaries zero (dense ones leave
                // the scratch unknown: the next selection clears what it needs).
                prop_assert!(a[2 * words..2 * words + summary].iter().all(|&x| x == 0));
                prop_assert!(a[..words].iter().all(|&x| x == 0));
            }
            // A released scratch stays usable: the next selection and mesh are the same, and
            // the same as from a zeroed scratch.
            let again = r.select(&mut a).unwrap();
            prop_assert_eq!(again.counts, sa.counts);
            r.release(&mut a, again);
            // Whole meshes: dense from a zeroed scratch against sparse from a released and
            // from a garbage one, all walked (a dense selection may write a dense mesh row by
            // row, a sparse one never does: `rows_and_walk_write_the_same_triangles`).
            select::VI_ROWS.with(|c| c.set(Some(false)));
            select::VI_LIMIT.with(|c| c.set(Some(0)));
            let m = list(hier, &hf, Criterion::MaxError(e));
            select::VI_LIMIT.with(|c| c.set(Some(usize::MAX)));
            let (mut v, mut t) = (vec![[0.0f32; 3]; m.v.len()], vec![[0u32; 3]; m.t.len()]);
            let ok = r.triangles(&mut a, &mut v, &mut t).is_ok();
            let mut g = vec![u64::MAX; len];
            let (mut v2, mut t2) = (v.clone(), t.clone());
            let ok2 = r.triangles(&mut g, &mut v2, &mut t2).is_ok();
            select::VI_LIMIT.with(|c| c.set(None));
            select::VI_ROWS.with(|c| c.set(None));
            prop_assert!(ok && ok2);
            prop_assert_eq!((&v, &t), (&m.v, &m.t));
            prop_assert_eq!((&v2, &t2), (&m.v, &m.t));
        }
        // View-dependent frames (sparse marks) from a garbage scratch equal those from a
        // zeroed one, and so do their strips and morph data.
        let cam = Camera::new(
            Vec3::new(-3.0, -2.0, amp + 5.0),
            Vec3::new(w as f32 / 2.0, h as f32 / 2.0, 0.0),
            60.0,
            320,
            200,
        )
        .unwrap();
        let view = View::new(&cam, 0.5).unwrap().with_geomorph(Some(2.0));
        for hier in [&full, &compact, &lin, &il] {
            let r = Refiner::new(hier, &hf, Criterion::View(view)).unwrap();
            let (mut z, mut g) = (vec![0u64; len], vec![u64::MAX; len]);
            let n = w as usize * h as usize;
            let out = |s: &mut [u64]| {
                let (mut v, mut t) = (vec![[0.0f32; 3]; n], vec![[0u32; 3]; 2 * n]);
                let c = r.triangles(s, &mut v, &mut t).unwrap();
                let mut mv = vec![MorphVertex::default(); n];
                let k = r.morph(s, &mut mv).unwrap();
                (c, v, t, k, mv)
            };
            let (first, second) = (out(&mut z), out(&mut g));
            prop_assert!(first == second);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    /// Dense view-independent meshes of square grids written row by row are the walk's mesh:
    /// the same vertices, the same triangles (each with the same corners in the same order) in
    /// another order, for every error store, sizes from 2^2 to 257^2 (rows of one to five
    /// words, the last column at every position of a word's first bits) and kept shares from
    /// everything to almost nothing; and the row-by-row mesh is a mesh of the grid in its own
    /// right (counter-clockwise, the domain's area, within E by the full-grid scan).
    #[test]
    fn rows_and_walk_write_the_same_triangles(
        k in 0u32..9, seed in 1u64..1000, amp in 0.0f32..100.0, frac in 0.0f32..1.0,
        quant in prop::bool::ANY,
    ) {
        let w = (1u32 << k) + 1;
        let mut s = grid(w, w, seed, amp);
        if quant {
            for v in &mut s { *v = (*v * 10.0).round() / 10.0; }
        }
        let e = frac * frac * amp;
        let hf = Heightfield::new(&s, w, w).unwrap();
        let n = hierarchy_len(w, w);
        let (mut er, mut ra) = (vec![0.0; n], vec![0.0; n]);
        let full = preprocess(&hf, &mut er, &mut ra).unwrap();
        let mut ec = vec![0u16; n];
        let compact = preprocess_compact(&hf, &mut ec).unwrap();
        let mut lin = vec![VertexRecord::default(); records_len(w, w, RecordLayout::Linear)];
        let lin = pack_records(&full, &hf, RecordLayout::Linear, &mut lin).unwrap();
        let mut il = vec![VertexRecord::default(); records_len(w, w, RecordLayout::Interleaved)];
        let il = pack_records(&full, &hf, RecordLayout::Interleaved, &mut il).unwrap();
        for hier in [&full, &compact, &lin, &il] {
            let by = |rows: bool| {
                select::VI_ROWS.with(|c| c.set(Some(rows)));
                select::VI_LIMIT.with(|c| c.set(Some(0)));
                let m = list(hier, &hf, Criterion::MaxError(e));
                select::VI_ROWS.with(|c| c.set(None));
                select::VI_LIMIT.with(|c| c.set(None));
                m
            };
            let (walk, rows) = (by(false), by(true));
            prop_assert_eq!(&walk.v, &rows.v);
            let sorted = |t: &[[u32; 3]]| {
                let mut t = t.to_vec();
                t.sort_unstable();
                t
            };
            prop_assert_eq!(sorted(&walk.t), sorted(&rows.t));
            prop_assert!(ccw(&rows));
            prop_assert!((area(&rows) - f64::from((w - 1) * (w - 1))).abs() < 1e-6);
            prop_assert!(scan(&hf, &rows) <= f64::from(e) + 1e-4);
        }
    }
}
