//! Tests of the pruned preprocessing and of live edits: bit-identical to a full preprocessing.

use super::tests::{list, rng};
use super::*;
use crate::Heightfield;
use std::vec;
use std::vec::Vec;

/// Smooth hills plus noise (pruning matters on smooth terrain, noise keeps the maxima varied).
fn terrain(w: u32, h: u32, seed: u64, noise: f32) -> Vec<f32> {
    let mut r = rng(seed);
    let mut v = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let (fx, fy) = (x as f32 * 0.11, y as f32 * 0.07);
            let n = ((r() >> 11) % 1000) as f32 / 1000.0 * noise;
            v.push(30.0 * libm::sinf(fx) * libm::cosf(fy) + 0.3 * x as f32 + n);
        }
    }
    v
}

fn full(s: &[f32], w: u32, h: u32, o: PreprocessOptions) -> (Vec<f32>, Vec<f32>) {
    let hf = Heightfield::new(s, w, h).unwrap();
    let n = hierarchy_len(w, h);
    let (mut e, mut r) = (vec![0.0; n], vec![0.0; n]);
    preprocess_with(&hf, &mut e, &mut r, o).unwrap();
    (e, r)
}

const SIZES: [(u32, u32); 7] = [
    (2, 2),
    (5, 5),
    (17, 17),
    (33, 33),
    (30, 19),
    (65, 40),
    (129, 129),
];

#[test]
fn pruned_preprocessing_is_bit_identical() {
    for (k, &(w, h)) in SIZES.iter().enumerate() {
        for noise in [0.0, 0.5, 40.0] {
            let s = terrain(w, h, k as u64 + 7, noise);
            let hf = Heightfield::new(&s, w, h).unwrap();
            for cd in [true, false] {
                let o = PreprocessOptions::default().with_contain_diamond(cd);
                let (e0, r0) = full(&s, w, h, o);
                let n = hierarchy_len(w, h);
                let (mut e, mut r) = (vec![0.0; n], vec![0.0; n]);
                let mut p = vec![0.0; pyramid_len(w, h)];
                let hp = preprocess_pyramid(&hf, &mut e, &mut r, &mut p, o).unwrap();
                let _ = hp;
                assert_eq!(e, e0, "{w}x{h} noise {noise}");
                assert_eq!(r, r0, "{w}x{h} noise {noise}");
            }
            let (mut c0, mut c1) = (vec![0u16; (w * h) as usize], vec![0u16; (w * h) as usize]);
            let mut p = vec![0.0; pyramid_len(w, h)];
            let a = preprocess_compact(&hf, &mut c0).unwrap();
            let b = preprocess_compact_pyramid(&hf, &mut c1, &mut p).unwrap();
            assert_eq!(a.z_range(), b.z_range());
            assert_eq!(c0, c1, "{w}x{h} compact");
        }
    }
}

#[test]
fn pyramid_buffer_too_small_is_an_error() {
    let s = vec![0.0f32; 81];
    let hf = Heightfield::new(&s, 9, 9).unwrap();
    let (mut e, mut r) = (vec![0.0; 81], vec![0.0; 81]);
    let need = pyramid_len(9, 9);
    let mut p = vec![0.0; need - 1];
    let o = PreprocessOptions::default();
    assert_eq!(
        preprocess_pyramid(&hf, &mut e, &mut r, &mut p, o).unwrap_err(),
        Error::BufferTooSmall {
            needed: need,
            actual: need - 1
        }
    );
    let region = Region::new(0, 0, 0, 0).unwrap();
    assert!(update(&hf, &mut e, &mut r, &mut p, region, o).is_err());
    let mut p = vec![0.0; need];
    preprocess_pyramid(&hf, &mut e, &mut r, &mut p, o).unwrap();
    let outside = Region::new(9, 0, 9, 0).unwrap();
    assert_eq!(
        update(&hf, &mut e, &mut r, &mut p, outside, o).unwrap_err(),
        Error::OutOfBounds { x: 9, y: 0 }
    );
}

/// Random craters (one at a time and several at once), both layouts, several sizes: the
/// updated errors, radii, pyramid and meshes equal those of preprocessing the edited map.
#[test]
fn random_craters_update_equals_full_preprocessing() {
    let mut r = rng(99);
    for (k, &(w, h)) in SIZES.iter().enumerate() {
        let mut s = terrain(w, h, k as u64 + 1, 2.0);
        let n = hierarchy_len(w, h);
        let o = PreprocessOptions::default();
        let (mut e, mut rad, mut p) = (vec![0.0; n], vec![0.0; n], vec![0.0; pyramid_len(w, h)]);
        let (mut ec, mut pc) = (vec![0u16; n], vec![0.0; pyramid_len(w, h)]);
        {
            let hf = Heightfield::new(&s, w, h).unwrap();
            preprocess_pyramid(&hf, &mut e, &mut rad, &mut p, o).unwrap();
            preprocess_compact_pyramid(&hf, &mut ec, &mut pc).unwrap();
        }
        for round in 0..6 {
            let mut region: Option<Region> = None;
            // Rounds 0-3: one crater; 4-5: three craters at once (union of their regions).
            for _ in 0..if round < 4 { 1 } else { 3 } {
                let cx = (r() % w as u64) as f32 + 0.3;
                let cy = (r() % h as u64) as f32;
                let radius = [0.5f32, 1.0, 2.5, 6.0, 40.0][(r() % 5) as usize];
                let depth = (r() % 50) as f32 - 10.0;
                if let Some(g) = crater(&mut s, w, h, cx, cy, radius, depth).unwrap() {
                    region = Some(region.map_or(g, |a| a.union(g)));
                }
            }
            let Some(region) = region else { continue };
            let hf = Heightfield::new(&s, w, h).unwrap();
            let hu = update(&hf, &mut e, &mut rad, &mut p, region, o).unwrap();
            let (e0, r0) = full(&s, w, h, o);
            let hier0 = {
                // A fresh full preprocessing of the edited map, for the mesh comparison.
                let mut p0 = vec![0.0; pyramid_len(w, h)];
                let (mut e1, mut r1) = (vec![0.0; n], vec![0.0; n]);
                preprocess_pyramid(&hf, &mut e1, &mut r1, &mut p0, o).unwrap();
                assert_eq!(p0, p, "{w}x{h} pyramid");
                (e1, r1)
            };
            assert_eq!(hier0.0, e0);
            let mut e0b = e0.clone();
            let mut r0b = r0.clone();
            let h0 = preprocess(&hf, &mut e0b, &mut r0b).unwrap();
            assert_eq!(hu.z_range(), h0.z_range());
            for eps in [0.0, 1.0, 5.0] {
                let (a, b) = (
                    list(&hu, &hf, Criterion::MaxError(eps)),
                    list(&h0, &hf, Criterion::MaxError(eps)),
                );
                assert_eq!(a.v, b.v);
                assert_eq!(a.t, b.t);
            }
            let eq_e = e.iter().zip(&e0).all(|(a, b)| a.to_bits() == b.to_bits());
            let eq_r = rad.iter().zip(&r0).all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(eq_e && eq_r, "{w}x{h} round {round} region {region:?}");
            // Compact layout.
            let hc = update_compact(&hf, &mut ec, &mut pc, region).unwrap();
            let mut ec0 = vec![0u16; n];
            let hc0 = preprocess_compact(&hf, &mut ec0).unwrap();
            assert_eq!(hc.z_range(), hc0.z_range());
            let (a, b) = (
                list(&hc, &hf, Criterion::MaxError(2.0)),
                list(&hc0, &hf, Criterion::MaxError(2.0)),
            );
            assert_eq!((a.v, a.t), (b.v, b.t));
            assert_eq!(ec, ec0, "{w}x{h} compact round {round}");
        }
    }
}

#[test]
fn small_triangle_fast_paths_equal_rasterising() {
    use crate::{Scale, Terrain};
    let (w, h) = (17u32, 12u32);
    let s = terrain(w, h, 5, 60.0);
    let hf = Heightfield::with_scale(&s, w, h, Scale::default().with_z_scale(0.37)).unwrap();
    let g = RefineGrid::new(w, h).unwrap();
    let mut checked = [0usize; 2];
    for y in 0..h {
        for x in 0..w {
            for tri in g.diamond(x, y).iter().flatten() {
                let o = raster::orient(tri[0], tri[1], tri[2]).abs();
                if g.classify(*tri) != grid::Class::Inside || o > 4 {
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
                checked[(o / 4) as usize] += 1;
            }
        }
    }
    assert!(checked[0] > 100 && checked[1] > 50, "{checked:?}");
}

#[test]
fn pass_shapes_equal_the_grid_diamonds_and_children() {
    for (w, h) in [(2u32, 2u32), (5, 5), (17, 9), (30, 19), (65, 65), (100, 37)] {
        let g = RefineGrid::new(w, h).unwrap();
        let n = g.side() as i64;
        let mut hh = 1i64;
        let mut seen = 0;
        while hh < n {
            for (pass, (x0, y0, _)) in preprocess::passes(hh).into_iter().enumerate() {
                let (mut y, mut count) = (y0, 0);
                while y < h as i64 {
                    let mut x = x0;
                    while x < w as i64 {
                        let (d, k) = preprocess::shape(&g, x, y, hh, pass);
                        let key = |t: &[(i64, i64); 3]| {
                            let mut v = t.to_vec();
                            v.sort();
                            v
                        };
                        let mut a: Vec<_> = d.iter().flatten().map(key).collect();
                        let mut b: Vec<_> = g
                            .diamond(x as u32, y as u32)
                            .iter()
                            .flatten()
                            .map(key)
                            .collect();
                        a.sort();
                        b.sort();
                        assert_eq!(a, b, "{w}x{h} ({x},{y}) h={hh}");
                        let mut ka: Vec<_> = k.iter().flatten().collect();
                        let gk = g.children(x as u32, y as u32);
                        let mut kb: Vec<_> = gk.iter().flatten().collect();
                        ka.sort();
                        kb.sort();
                        assert_eq!(ka, kb, "{w}x{h} ({x},{y}) h={hh}");
                        count += 1;
                        x += 2 * hh;
                    }
                    y += 2 * hh;
                }
                seen += count;
            }
            hh *= 2;
        }
        // Every grid point but the square's corners is one pass's vertex exactly once.
        let corners = [(0, 0), (n, 0), (0, n), (n, n)]
            .iter()
            .filter(|&&(x, y)| x < w as i64 && y < h as i64)
            .count();
        assert_eq!(seen + corners, g.len(), "{w}x{h}");
    }
}
