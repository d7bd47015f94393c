//! Ray traversal with random grids and rays, including extreme and non-finite values.
//! Invariants: the run-length DDA implies exactly the cell DDA's cells; every traversal stays
//! within its step bound; a hit has finite `t >= 0`, lies inside the domain's prism and has a
//! unit normal; the exact methods (cell DDA, run DDA, max-mip) agree on hit or miss and on `t`
//! except for rays that graze the surface (checked by re-tracing the other method's answer); the
//! max-mip packet paths (portable, and AVX-512 where the CPU has it) give the max-mip traces
//! exactly, and the sixteen-wide walk its hits.
#![no_main]

use libfuzzer_sys::fuzz_target;
use relief_core::glam::{DVec2, Vec3};
use relief_core::ray::{GridLine, MarchOptions, MaxMip, Ray, RayTracer, RunAccel, Trace};
use relief_core::{Heightfield, Terrain};
use relief_tests::ray_check::{corner_passes, RaysInput};

fuzz_target!(|data: &[u8]| {
    let Some(RaysInput {
        w,
        h,
        surface,
        origin: o,
        dir: d,
        samples,
    }) = RaysInput::decode(data)
    else {
        return;
    };

    // Digital lines: run DDA cells == cell DDA cells, for any finite input.
    let (s2, d2) = (
        DVec2::new(o.x.into(), o.y.into()),
        DVec2::new(d.x.into(), d.y.into()),
    );
    if let Ok(line) = GridLine::new(s2, d2, s2 + d2 * 64.0, [w - 1, h - 1]) {
        let cells: Vec<[u32; 2]> = line.cells().take(10_000).collect();
        let from_runs: Vec<[u32; 2]> = line.runs().flat_map(|r| r.cells()).take(10_000).collect();
        assert_eq!(cells, from_runs);
        assert!(cells.len() as u64 <= line.step_bound());
        // Internal iteration (`fold`) walks the same cells and runs.
        if cells.len() < 10_000 {
            let folded = line.cells().fold(Vec::new(), |mut o, c| {
                o.push(c);
                o
            });
            assert_eq!(cells, folded);
            let runs: Vec<_> = line.runs().collect();
            let folded = line.runs().fold(Vec::new(), |mut o, r| {
                o.push(r);
                o
            });
            assert_eq!(runs, folded);
        }
    }

    let hf = Heightfield::new(&samples, w, h).unwrap();
    let Ok(ray) = Ray::new(o, d) else {
        return;
    };
    let tracer = RayTracer::new(&hf, surface);
    let mut acc = vec![0.0f32; RunAccel::len(w, h).unwrap()];
    let acc = RunAccel::build(&hf, &mut acc).unwrap();
    let mut mip = vec![0.0f32; MaxMip::len(w, h).unwrap()];
    let mip = MaxMip::build(&hf, &mut mip).unwrap();
    let a = tracer.trace_cell_dda(&ray);
    let b = tracer.trace_run_dda(&ray, &acc).unwrap();
    let c = tracer.trace_maxmip(&ray, &mip).unwrap();
    let m = tracer
        .trace_march(&ray, &MarchOptions::default().with_samples(64))
        .unwrap();
    // The packet paths give the max-mip trace exactly, alone and among other rays.
    // Eleven more rays, the fuzzed one shifted, so that the AVX-512 path clips two batches.
    let down = Ray::new(Vec3::new(0.5, 0.5, 1e3), -Vec3::Z).unwrap();
    let mut rays = vec![ray, down, ray];
    rays.extend((1..12u8).filter_map(|k| {
        let s = f32::from(k) * 0.37;
        Ray::new(o + Vec3::new(s, -0.5 * s, 0.25 * s), d).ok()
    }));
    let mut out = vec![Trace::default(); rays.len()];
    tracer.trace_maxmip_packet(&rays, &mip, &mut out).unwrap();
    assert_eq!((out[0], out[2]), (c, c));
    for (r, t) in rays.iter().zip(&out) {
        assert_eq!(*t, tracer.trace_maxmip(r, &mip).unwrap());
    }
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx512f") && std::is_x86_feature_detected!("avx512dq") {
        let mut simd = vec![Trace::default(); rays.len()];
        // SAFETY: the CPU has AVX-512F and AVX-512DQ.
        unsafe { tracer.trace_maxmip_packet_avx512(&rays, &mip, &mut simd) }.unwrap();
        assert_eq!(simd, out);
    }
    // The sixteen-wide walk: the same hit, the same cells tested or fewer (cells the ray only
    // touches at a point are skipped; one more for each vertex the ray passes within a
    // rounding unit of, below); its AVX-512 form the portable one's traces, its AVX2
    // form (a conservative `f32` node test) the portable one's hits and cells in as many steps
    // or more, and its slice forms (two walks interleaved) each ray's trace alone.
    let mut wides = vec![Trace::default(); rays.len()];
    tracer.trace_maxmip_wide_rays(&rays, &mip, &mut wides).unwrap();
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        let mut w2 = vec![Trace::default(); rays.len()];
        // SAFETY: the CPU has AVX2.
        unsafe { tracer.trace_maxmip_wide_rays_avx2(&rays, &mip, &mut w2) }.unwrap();
        for ((r, a), p) in rays.iter().zip(&w2).zip(&wides) {
            // SAFETY: the CPU has AVX2.
            assert_eq!(*a, unsafe { tracer.trace_maxmip_wide_avx2(r, &mip) }.unwrap());
            assert_eq!((a.hit, a.cells), (p.hit, p.cells));
            assert!(a.steps >= p.steps);
        }
    }
    for ((r, t), sliced) in rays.iter().zip(&out).zip(&wides) {
        let wide = tracer.trace_maxmip_wide(r, &mip).unwrap();
        assert_eq!(*sliced, wide);
        assert_eq!(wide.hit, t.hit);
        // The same cells or fewer, except one more for each grid vertex the ray passes within
        // a rounding unit of: the wide walk may test a cell crossed there for a rounding unit
        // of `t` that the neighbour walk's descent (flooring its entry position) skips
        // (`tests/tests/rays_packet.rs::wide_walk_may_test_a_cell_crossed_for_a_rounding_unit_at_a_vertex`).
        let corners = corner_passes(r.origin(), r.dir(), w, h);
        assert!(
            wide.cells as usize <= t.cells as usize + corners,
            "{wide:?} {t:?} {corners}"
        );
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512F.
            assert_eq!(unsafe { tracer.trace_maxmip_wide_avx512(r, &mip) }.unwrap(), wide);
        }
    }
    let ext = (f64::from(w - 1), f64::from(h - 1));
    for tr in [a, b, c, m.trace] {
        if let Some(hit) = tr.hit {
            assert!(hit.t.is_finite() && hit.t >= 0.0, "{hit:?}");
            let p = hit.position;
            // Positions come from the world-space origin in f64: rounding grows with |origin|.
            let tol =
                1e-6 * (1.0 + p.x.abs().max(p.y.abs())) + 1e-15 * f64::from(o.abs().max_element());
            assert!(
                p.x >= -tol && p.x <= ext.0 + tol && p.y >= -tol && p.y <= ext.1 + tol,
                "{hit:?} outside the domain"
            );
            assert!(
                hit.normal.is_finite() && (hit.normal.length() - 1.0).abs() < 1e-4,
                "{hit:?}"
            );
        }
    }
    assert!(u64::from(a.steps) <= tracer.step_bound());
    // Exact methods agree, up to rays that graze: compare t where both hit. Checked on rays of
    // realistic scale (origin within 1e6, direction components 0 or between 1e-6 and 1e6 of the
    // largest): beyond that the entry point into the domain is not resolvable in f64 and the
    // methods may legitimately differ (every input above is still checked for validity).
    let dmax = d.abs().max_element();
    let realistic = o.abs().max_element() <= 1e6
        && d.to_array()
            .iter()
            .all(|c| *c == 0.0 || (c.abs() >= 1e-6 * dmax && c.abs() <= 1e6 * dmax))
        && dmax >= 1e-6
        && dmax <= 1e6;
    if !realistic {
        return;
    }
    for other in [b, c] {
        match (a.hit, other.hit) {
            (Some(x), Some(y)) => {
                let scale = 1.0 + x.t.abs();
                if (x.t - y.t).abs() > 1e-6 * scale {
                    // Allowed only when the ray skims the surface: the point the other method
                    // found must itself be within rounding of the surface.
                    let z = hf.surface_height(surface, y.position.x as f32, y.position.y as f32);
                    if let Some(z) = z {
                        assert!(
                            (f64::from(z) - y.position.z).abs()
                                <= 1e-3 * (1.0 + y.position.z.abs()),
                            "{x:?} vs {y:?}"
                        );
                    }
                }
            }
            (Some(_), None) | (None, Some(_)) => {
                // A miss against a hit is a grazing disagreement only if the hit is at the
                // surface within rounding; anything else is a bug.
                let hit = a.hit.or(other.hit).unwrap();
                if let Some(z) =
                    hf.surface_height(surface, hit.position.x as f32, hit.position.y as f32)
                {
                    assert!(
                        (f64::from(z) - hit.position.z).abs()
                            <= 1e-3 * (1.0 + hit.position.z.abs()),
                        "{a:?} vs {other:?}"
                    );
                }
            }
            (None, None) => {}
        }
    }
});
