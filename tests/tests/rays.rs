//! Ray tracing on the bundled Puget Sound DEM (1025 x 1025, 160 m, z 0.1): every exact method
//! gives the same depth image for every surface, depths follow CONVENTIONS.md (+inf for a miss,
//! never NaN), hits lie on the surface, and the march stays within its reported error.

use relief_core::glam::Vec3;
use relief_core::ray::{MarchOptions, MaxMip, Ray, RayTracer, RunAccel};
use relief_core::{Camera, Surface, Terrain};
use relief_tests::fixtures::{puget, puget_views};

#[test]
fn exact_methods_agree_on_the_bundled_dem() {
    let dem = puget();
    let hf = dem.heightfield().unwrap();
    let mut rbuf = vec![0.0f32; RunAccel::len(dem.width, dem.height).unwrap()];
    let acc = RunAccel::build(&hf, &mut rbuf).unwrap();
    let mut mbuf = vec![0.0f32; MaxMip::len(dem.width, dem.height).unwrap()];
    let mip = MaxMip::build(&hf, &mut mbuf).unwrap();
    // Oblique view, and a grazing one just above the highest peak (4379.8 m).
    let views = puget_views(48, 32);
    for surface in [
        Surface::Triangles,
        Surface::Bilinear,
        Surface::Plane,
        Surface::Nearest,
    ] {
        let tracer = RayTracer::new(&hf, surface);
        let mut hits = 0;
        for cam in &views {
            for j in 0..cam.height {
                for i in 0..cam.width {
                    let (o, d) = cam.ray(i, j);
                    let ray = Ray::new(o, d).unwrap();
                    let a = tracer.trace_cell_dda(&ray);
                    let b = tracer.trace_run_dda(&ray, &acc).unwrap();
                    let c = tracer.trace_maxmip(&ray, &mip).unwrap();
                    let depth =
                        |t: &relief_core::Trace| t.hit.map_or(f32::INFINITY, |h| h.t as f32);
                    let (da, db, dc) = (depth(&a), depth(&b), depth(&c));
                    assert!(!da.is_nan() && !db.is_nan() && !dc.is_nan());
                    for other in [db, dc] {
                        assert_eq!(
                            da.is_finite(),
                            other.is_finite(),
                            "{surface:?} pixel {i},{j}"
                        );
                        if da.is_finite() {
                            assert!(
                                (da - other).abs() <= 1e-5 * da,
                                "{surface:?} pixel {i},{j}: {da} vs {other}"
                            );
                        }
                    }
                    if let Some(h) = a.hit {
                        hits += 1;
                        // The hit lies on the surface (triangles / bilinear are height functions).
                        if matches!(surface, Surface::Triangles | Surface::Bilinear) {
                            let p = h.position;
                            let z = hf.surface_height(surface, p.x as f32, p.y as f32).unwrap();
                            assert!((p.z - z as f64).abs() < 0.05, "{p:?} vs {z}");
                        }
                        // The run DDA rejects most cells without reading them.
                        assert!(b.cells <= a.cells);
                    }
                }
            }
        }
        assert!(hits > 1000, "{surface:?}: only {hits} hits");
    }
}

#[test]
fn march_is_within_its_reported_bracket_or_misses_thin_features() {
    let dem = puget();
    let hf = dem.heightfield().unwrap();
    let tracer = RayTracer::new(&hf, Surface::Triangles);
    let cam = Camera::new(
        Vec3::new(20_000.0, 15_000.0, 9_000.0),
        Vec3::new(90_000.0, 100_000.0, 0.0),
        60.0,
        32,
        24,
    )
    .unwrap();
    let opts = MarchOptions::default().with_samples(4096).with_refine(20);
    let (mut close, mut total) = (0, 0);
    for j in 0..cam.height {
        for i in 0..cam.width {
            let (o, d) = cam.ray(i, j);
            let ray = Ray::new(o, d).unwrap();
            let exact = tracer.trace_cell_dda(&ray).hit;
            let m = tracer.trace_march(&ray, &opts).unwrap();
            if let (Some(e), Some(h)) = (exact, m.trace.hit) {
                total += 1;
                // Never before the first crossing; after it by at most the bracket unless the
                // march stepped over a feature thinner than its step.
                assert!(h.t >= e.t - 1e-6 * e.t);
                if h.t - e.t <= m.bracket + 1e-6 * e.t {
                    close += 1;
                }
            }
        }
    }
    assert!(total > 300);
    assert!(close * 100 >= total * 99, "{close} of {total}");
    assert!(hf.width() == 1025);
}
