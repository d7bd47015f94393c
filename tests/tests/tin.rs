//! Cross-crate: greedy TIN meshes (relief-tin) checked by the project's crack checker
//! (`relief_tests::mesh_check`) and measured by the core's full-grid error scan
//! (`relief_core::refine::vertical_error`), on random grids and the bundled DEM.

use proptest::prelude::*;
use relief_core::refine::{coverage_len, vertical_error};
use relief_core::{Heightfield, Scale, Terrain};
use relief_tests::mesh_check::{check_mesh, CheckOptions};
use relief_tin::{Tin, TinOptions};

/// Builds a TIN, checks it is crack-free and that the core's scan of the OBJ positions gives
/// exactly the error the builder reports, within the target when it stopped on error.
fn check<T: Terrain>(t: &T, o: &TinOptions) -> Tin {
    let tin = Tin::build(t, o).unwrap();
    let s = t.scale();
    let pos = tin.positions(t);
    let opts = CheckOptions::grid(t.width(), t.height(), f64::from(s.dx), f64::from(s.dy));
    let r = check_mesh(&pos, tin.triangles(), &opts).unwrap();
    assert_eq!(r.triangles, tin.triangles().len());
    assert_eq!(r.used_vertices, tin.vertices().len());
    let mut cov = vec![0u64; coverage_len(t.width(), t.height())];
    let e = vertical_error(t, &pos, tin.triangles(), &mut cov).unwrap();
    assert_eq!(e, tin.max_error());
    if tin.stop_reason() == relief_tin::StopReason::ErrorReached {
        assert!(e <= f64::from(o.max_error), "{e} > {}", o.max_error);
    }
    tin
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn random_grids_are_crack_free_and_within_error(
        w in 2u32..40,
        h in 2u32..40,
        seed in any::<u64>(),
        e in prop_oneof![Just(0.0f32), 0.0f32..30.0],
        budget in prop_oneof![Just(u32::MAX), 4u32..80],
        dx in prop_oneof![Just(1.0f32), Just(0.5f32), Just(30.0f32)],
    ) {
        let mut s = seed | 1;
        let samples: Vec<f32> = (0..w * h)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                (s % 2000) as f32 * 0.05 - 50.0
            })
            .collect();
        let hf = Heightfield::with_scale(&samples, w, h, Scale::default().with_spacing(dx, 2.0 * dx)).unwrap();
        check(&hf, &TinOptions::default().with_max_error(e).with_max_vertices(budget));
    }
}

#[test]
fn bundled_dem_tins_are_crack_free_and_within_error() {
    let dem = relief_tests::fixtures::puget();
    let hf = dem.heightfield().unwrap();
    let mut last = 0;
    for e in [200.0f32, 50.0, 20.0] {
        let tin = check(&hf, &TinOptions::default().with_max_error(e));
        assert!(tin.triangles().len() > last);
        last = tin.triangles().len();
    }
}
