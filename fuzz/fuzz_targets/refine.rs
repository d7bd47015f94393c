//! SOAR refinement with random grids, thresholds, cameras and capacities.
//! Invariants: view-independent meshes are crack-free (the std crack checker of relief-tests) and
//! their measured vertical error is at most E; view-dependent meshes without culling are
//! crack-free, with culling they have no flipped or overlapping triangles; a buffer one element
//! too small is an error, never a truncated mesh; `triangles_uninit` and the `popcnt` and
//! AVX-512 builds write what `triangles` writes, and grid-coordinate vertices give the same
//! triangles; both triangle strips are crack-free with or without culling (culled triangles
//! drawn coarse), within `strip_bound` (and, on a square grid, within three indices of
//! `strip_fewest_indices`), counted alike by their count functions, with one geomorph entry
//! per vertex, and draw the list's triangles view-independently off the `(2^k+1)^2` square.
#![no_main]

use libfuzzer_sys::fuzz_target;
use relief_core::glam::Vec3;
use relief_core::refine::{
    coverage_len, preprocess, scratch_len, strip_bound, strip_fewest, strip_fewest_indices,
    strip_fewest_scratch_len, strip_triangles, triangle_bound, vertex_bound, vertical_error,
    Criterion, MorphVertex, Refiner, View,
};
use relief_core::{Camera, Heightfield, Scale, Terrain};
use relief_tests::mesh_check::{check_mesh, CheckOptions};

fn f32_at(d: &[u8], i: usize) -> f32 {
    f32::from_le_bytes([0, 1, 2, 3].map(|k| d.get(i + k).copied().unwrap_or(0)))
}

/// Both strips of `r` decoded into counter-clockwise triangles, each checked with `opts`;
/// returns their triangle counts (in/out-edge, SOAR's).
fn strips<T: Terrain>(r: &Refiner<'_, '_, T>, w: u32, h: u32, opts: &CheckOptions) -> [usize; 2] {
    let mut counts = [0; 2];
    for (k, soar) in [false, true].into_iter().enumerate() {
        let mut scratch = vec![0u64; scratch_len(w, h)];
        let mut v = vec![[0.0f32; 3]; vertex_bound(w, h)];
        let mut s = vec![0u32; strip_bound(w, h)];
        let c = if soar {
            r.soar_strip(&mut scratch, &mut v, &mut s)
        } else {
            r.inout_strip(&mut scratch, &mut v, &mut s)
        }
        .unwrap();
        // The counts alone, and the geomorph data: one entry per strip vertex, at its place.
        let mut morph = vec![MorphVertex::default(); c.vertices];
        let (counted, morphed) = if soar {
            let k = r.soar_strip_counts(&mut scratch).unwrap();
            (k, r.soar_strip_morph(&mut scratch, &mut morph).unwrap())
        } else {
            let k = r.inout_strip_counts(&mut scratch).unwrap();
            (k, r.inout_strip_morph(&mut scratch, &mut morph).unwrap())
        };
        assert_eq!(counted, c);
        assert_eq!(morphed, c.vertices);
        for (m, p) in morph.iter().zip(&v) {
            assert_eq!(&m.position, p);
        }
        let s = &s[..c.indices];
        let t: Vec<[u32; 3]> = strip_triangles(s).collect();
        assert_eq!(t.len(), c.triangles);
        check_mesh(&v[..c.vertices], &t, opts).unwrap();
        // No strip of these triangles in this order is shorter than the fewest; on a square
        // grid (one piece) the strip is the fewest up to its start.
        if let Some(fewest) = strip_fewest_indices(s, true) {
            assert!(fewest <= c.indices);
            assert!(strip_fewest_indices(s, false).is_some_and(|f| f <= fewest));
            if w == h && (w - 1).is_power_of_two() {
                assert!(c.indices <= fewest + 3, "{c:?}, fewest {fewest}");
            }
            // Rewritten as that fewest: the same triangles in the same order.
            let mut back = vec![0u8; strip_fewest_scratch_len(s.len())];
            let mut re = vec![0u32; s.len()];
            let n = strip_fewest(s, true, &mut back, &mut re).unwrap();
            assert_eq!(n, fewest);
            let turn = |t: [u32; 3]| {
                let k = (0..3).min_by_key(|&i| t[i]).unwrap();
                [t[k], t[(k + 1) % 3], t[(k + 2) % 3]]
            };
            assert!(strip_triangles(&re[..n])
                .map(turn)
                .eq(strip_triangles(s).map(turn)));
        }
        counts[k] = c.triangles;
    }
    counts
}

fuzz_target!(|data: &[u8]| {
    if data.len() < 40 {
        return;
    }
    let w = u32::from(data[0] % 19) + 2;
    let h = u32::from(data[1] % 19) + 2;
    let dx = f32::from(data[2] % 7 + 1) * 0.5;
    let e = f32::from(data[3]) * 0.25;
    let samples: Vec<f32> = (0..w * h)
        .map(|i| f32::from(data.get(40 + i as usize).copied().unwrap_or(0)) * 0.5)
        .collect();
    let hf =
        Heightfield::with_scale(&samples, w, h, Scale::default().with_spacing(dx, dx)).unwrap();
    let (mut err, mut rad) = (
        vec![0.0f32; vertex_bound(w, h)],
        vec![0.0f32; vertex_bound(w, h)],
    );
    let hier = preprocess(&hf, &mut err, &mut rad).unwrap();
    let mut scratch = vec![0u64; scratch_len(w, h)];
    let mut verts = vec![[0.0f32; 3]; vertex_bound(w, h)];
    let mut tris = vec![[0u32; 3]; triangle_bound(w, h)];
    let grid = CheckOptions::grid(w, h, f64::from(dx), f64::from(dx));

    // View-independent.
    let r = Refiner::new(&hier, &hf, Criterion::MaxError(e)).unwrap();
    let c = r.triangles(&mut scratch, &mut verts, &mut tris).unwrap();
    let (v, t) = (&verts[..c.vertices], &tris[..c.triangles]);
    check_mesh(v, t, &grid).unwrap();
    let measured = vertical_error(&hf, v, t, &mut vec![0; coverage_len(w, h)]).unwrap();
    assert!(measured <= f64::from(e), "measured {measured} > E = {e}");
    // Into uninitialised capacity: the same vertices and triangles (bit for bit).
    let (mut uv, mut ut) = (Vec::<[f32; 3]>::new(), Vec::<[u32; 3]>::new());
    let (vb, tb) = (&mut uv, &mut ut);
    let cu = r
        .triangles_uninit(&mut scratch, move |k| {
            let (vb, tb) = (vb, tb);
            vb.reserve_exact(k.vertices);
            tb.reserve_exact(k.triangles);
            (vb.spare_capacity_mut(), tb.spare_capacity_mut())
        })
        .unwrap();
    assert_eq!(cu, c);
    // SAFETY: `triangles_uninit` wrote the first `c.vertices` and `c.triangles` elements.
    unsafe {
        uv.set_len(c.vertices);
        ut.set_len(c.triangles);
    }
    let bits = |x: &[[f32; 3]]| x.iter().map(|p| p.map(f32::to_bits)).collect::<Vec<_>>();
    assert_eq!(bits(&uv), bits(v));
    assert_eq!(ut, t);
    // Grid coordinates: the same triangles, each vertex's column and row.
    let mut gv = vec![[0u16; 2]; c.vertices];
    let mut gt = vec![[0u32; 3]; c.triangles];
    assert_eq!(r.triangles(&mut scratch, &mut gv, &mut gt).unwrap(), c);
    assert_eq!(gt, t);
    for (g, p) in gv.iter().zip(v) {
        assert_eq!([g[0] as f32 * dx, g[1] as f32 * dx], [p[0], p[1]]);
    }
    // The popcnt and AVX-512 builds, where the CPU has them: the same vertices and triangles.
    #[cfg(target_arch = "x86_64")]
    {
        let popcnt = std::is_x86_feature_detected!("popcnt");
        let avx512 = popcnt
            && std::is_x86_feature_detected!("avx512f")
            && std::is_x86_feature_detected!("avx512bw");
        let (mut bv, mut bt) = (vec![[0.0f32; 3]; c.vertices], vec![[0u32; 3]; c.triangles]);
        if popcnt {
            // SAFETY: the CPU has popcnt.
            let cb = unsafe { r.triangles_popcnt(&mut scratch, &mut bv, &mut bt) }.unwrap();
            assert_eq!((cb, bits(&bv), &bt[..]), (c, bits(v), t));
        }
        if avx512 {
            // SAFETY: the CPU has popcnt, AVX-512F and AVX-512BW.
            let cb = unsafe { r.triangles_avx512(&mut scratch, &mut bv, &mut bt) }.unwrap();
            assert_eq!((cb, bits(&bv), &bt[..]), (c, bits(v), t));
        }
    }
    // One element too small: an error, not a silent truncation.
    if c.triangles > 0 {
        let mut short = vec![[0u32; 3]; c.triangles - 1];
        assert!(r.triangles(&mut scratch, &mut verts, &mut short).is_err());
    }
    // The strips: off the square, no level is forced, so they draw the list's triangles.
    let strip_triangles = strips(&r, w, h, &grid);
    let square = w == h && (w - 1).is_power_of_two();
    assert!(square || strip_triangles == [c.triangles; 2]);

    // View-dependent, from a camera made of the input bytes.
    let eye = Vec3::new(f32_at(data, 4), f32_at(data, 8), f32_at(data, 12));
    let target = Vec3::new(f32_at(data, 16), f32_at(data, 20), f32_at(data, 24));
    let fov = f32_at(data, 28);
    let tau = f32_at(data, 32);
    let Ok(cam) = Camera::new(eye, target, fov, 64, 48) else {
        return;
    };
    let Ok(view) = View::new(&cam, tau) else {
        return;
    };
    for (culling, opts) in [
        (false, grid),
        (
            true,
            CheckOptions {
                allow_holes: true,
                t_junctions: false,
                ..grid
            },
        ),
    ] {
        let Ok(r) = Refiner::new(&hier, &hf, Criterion::View(view.with_culling(culling))) else {
            return;
        };
        let c = r.triangles(&mut scratch, &mut verts, &mut tris).unwrap();
        check_mesh(&verts[..c.vertices], &tris[..c.triangles], &opts).unwrap();
        // The strips draw culled triangles coarse and cull at every level: whole meshes.
        strips(&r, w, h, &grid);
    }
});
