//! Cross-crate: the bundled DEM read by relief-io and used by relief-core.

use relief_core::glam::Vec3;
use relief_core::{normal, normal_map, Composed, Heightfield, NormalMethod, Surface, Terrain};
use relief_tests::fixtures::puget;

#[test]
fn bundled_dem_has_documented_size_and_range() {
    let dem = puget();
    assert_eq!((dem.width, dem.height), (1025, 1025));
    let s = dem.stats();
    assert_eq!(s.min, 0.0);
    assert!((s.max - 4379.8).abs() < 1e-3, "{}", s.max);
    let hf = dem.heightfield().unwrap();
    assert_eq!(
        hf.extent(),
        relief_core::glam::Vec2::new(163_840.0, 163_840.0)
    );
}

#[test]
fn normals_on_real_terrain_are_unit_and_up() {
    let dem = puget();
    let hf = dem.heightfield().unwrap();
    let mut out = vec![Vec3::ZERO; (hf.width() * hf.height()) as usize];
    for m in [NormalMethod::Central, NormalMethod::Sobel] {
        normal_map(&hf, m, &mut out).unwrap();
        let mut tilted = 0;
        for n in &out {
            assert!(
                n.is_finite() && (n.length() - 1.0).abs() <= 1e-6 && n.z > 0.0,
                "{n}"
            );
            if n.z < 0.99 {
                tilted += 1;
            }
        }
        // Mountains: a good share of the map slopes by more than 8 degrees.
        assert!(
            tilted > out.len() / 50,
            "{m:?}: only {tilted} tilted normals"
        );
    }
}

#[test]
fn surfaces_bounded_by_cell_extremes_on_real_terrain() {
    let dem = puget();
    let hf = dem.heightfield().unwrap();
    let mut s = 7u32;
    for _ in 0..20_000 {
        s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        let gx = (s >> 8) as f32 / (1u32 << 24) as f32 * 1024.0;
        s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        let gy = (s >> 8) as f32 / (1u32 << 24) as f32 * 1024.0;
        let (lo, hi) = hf.cell_min_max(gx as u32, gy as u32).unwrap();
        for surf in [Surface::Triangles, Surface::Bilinear, Surface::Nearest] {
            let z = hf.surface_height(surf, gx * 160.0, gy * 160.0).unwrap();
            assert!(
                z >= lo - 1e-2 && z <= hi + 1e-2,
                "{surf:?} at ({gx},{gy}): {z} not in {lo}..{hi}"
            );
        }
    }
}

#[test]
fn real_base_with_detail_composes_and_shades() {
    let dem = puget();
    // A 64 x 64 crop as base, a synthetic tileable ripple as detail, 8x subdivision.
    let crop: Vec<f32> = (0..64 * 64)
        .map(|i| dem.samples[(i / 64 + 500) * 1025 + i % 64 + 500])
        .collect();
    let base = Heightfield::with_scale(&crop, 64, 64, dem.scale).unwrap();
    let ripple: Vec<i16> = (0..32 * 32)
        .map(|i| {
            let (x, y) = ((i % 32) as f32, (i / 32) as f32);
            (100.0
                * (x * std::f32::consts::TAU / 32.0).sin()
                * (y * std::f32::consts::TAU / 32.0).cos()) as i16
        })
        .collect();
    let detail = Heightfield::with_scale(
        &ripple,
        32,
        32,
        relief_core::Scale::default().with_z_scale(0.01),
    )
    .unwrap();
    let c = Composed::new(base, detail, 8).unwrap();
    assert_eq!((c.width(), c.height()), (505, 505));
    assert_eq!(c.scale().dx, 20.0);
    for y in (0..c.height()).step_by(7) {
        for x in (0..c.width()).step_by(5) {
            let n = c.summed_normal(x, y).unwrap();
            assert!((n.length() - 1.0).abs() <= 1e-6 && n.z > 0.0);
            let m = normal(&c, x, y, NormalMethod::Central).unwrap();
            assert!(m.is_finite());
            // At base samples the composed surface is the base plus the detail there.
            if x % 8 == 0 && y % 8 == 0 {
                let want = base.z(x / 8, y / 8) + detail.z(x % 32, y % 32);
                assert!((c.z(x, y) - want).abs() < 1e-3);
            }
        }
    }
}
