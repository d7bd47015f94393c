//! Base + detail composition and summed-difference normals.

use proptest::prelude::*;
use relief_core::{normal, Composed, Error, Heightfield, NormalMethod, Scale, Surface, Terrain};

#[test]
fn factor_must_be_a_power_of_two() {
    let b = Heightfield::new(&[0u16; 4], 2, 2).unwrap();
    let d = Heightfield::new(&[0u16; 4], 2, 2).unwrap();
    for k in [0, 3, 6, 12, 1000] {
        assert_eq!(
            Composed::new(b, d, k).unwrap_err(),
            Error::InvalidFactor { factor: k }
        );
    }
    for k in [1, 2, 64, 1 << 20] {
        assert!(Composed::new(b, d, k).is_ok());
    }
}

#[test]
fn composed_size_overflow_is_an_error() {
    let s = vec![0u8; 65536 * 2];
    let b = Heightfield::new(&s, 65536, 2).unwrap();
    let d = Heightfield::new(&[0u8; 4], 2, 2).unwrap();
    assert_eq!(
        Composed::new(b, d, 1 << 17).unwrap_err(),
        Error::SizeOverflow
    );
}

#[test]
fn factor_one_with_zero_detail_is_the_base() {
    let s: Vec<f32> = (0..12).map(|i| (i * 7 % 5) as f32).collect();
    let b = Heightfield::with_scale(&s, 4, 3, Scale::default().with_spacing(3.0, 2.0)).unwrap();
    let d = Heightfield::new(&[0.0f32; 4], 2, 2).unwrap();
    let c = Composed::new(b, d, 1).unwrap();
    assert_eq!((c.width(), c.height()), (4, 3));
    assert_eq!(c.scale().dx, 3.0);
    for y in 0..3 {
        for x in 0..4 {
            assert_eq!(c.z(x, y), b.z(x, y));
            for m in [NormalMethod::Central, NormalMethod::Sobel] {
                assert_eq!(normal(&c, x, y, m), normal(&b, x, y, m));
            }
        }
    }
}

#[test]
fn summed_normal_equals_composed_central_normal_on_planar_base() {
    // Planar base z = 2x - y (world), detail of arbitrary bumps, factor 4.
    let base: Vec<f32> = (0..16)
        .map(|i| 2.0 * (i % 4) as f32 - (i / 4) as f32)
        .collect();
    let b = Heightfield::with_scale(&base, 4, 4, Scale::default().with_spacing(8.0, 8.0)).unwrap();
    let det: Vec<i16> = (0..64).map(|i| ((i * 37) % 11) as i16 - 5).collect();
    let d = Heightfield::with_scale(&det, 8, 8, Scale::default().with_z_scale(0.25)).unwrap();
    let c = Composed::new(b, d, 4).unwrap();
    assert_eq!(c.scale().dx, 2.0);
    // Interior samples (one-sided borders differ by construction; the detail wraps).
    for y in 1..c.height() - 1 {
        for x in 1..c.width() - 1 {
            let summed = c.summed_normal(x, y).unwrap();
            let direct = normal(&c, x, y, NormalMethod::Central).unwrap();
            assert!(
                (summed - direct).length() < 1e-5,
                "({x},{y}) {summed} vs {direct}"
            );
            assert!((summed.length() - 1.0).abs() <= 1e-6 && summed.z > 0.0);
        }
    }
    assert_eq!(c.summed_normal(c.width(), 0), None);
}

#[test]
fn composed_surfaces_and_positions_work_like_a_plain_grid() {
    let b = Heightfield::with_scale(
        &[0u16, 100, 200, 300],
        2,
        2,
        Scale::default().with_spacing(4.0, 4.0).with_z_offset(50.0),
    )
    .unwrap();
    let d = Heightfield::new(&[0.0f32; 4], 2, 2).unwrap();
    let c = Composed::new(b, d, 4).unwrap();
    // Bilinear base, zero detail: the composed surface equals the base bilinear surface.
    for (px, py) in [(0.3f32, 0.7f32), (1.9, 3.2), (4.0, 4.0), (2.0, 2.0)] {
        let want = b.surface_height(Surface::Bilinear, px, py).unwrap();
        for s in [Surface::Bilinear, Surface::Triangles] {
            let got = c.surface_height(s, px, py).unwrap();
            assert!(
                (got - want).abs() < 1e-3,
                "{s:?} ({px},{py}) {got} vs {want}"
            );
        }
    }
    assert_eq!(c.position(4, 4), Some(glam::Vec3::new(4.0, 4.0, 350.0)));
    assert_eq!(c.extent(), glam::Vec2::new(4.0, 4.0));
}

proptest! {
    #[test]
    fn composed_equals_base_plus_detail_at_every_detail_sample(
        bw in 2u32..5, bh in 2u32..5, dw in 1u32..6, dh in 1u32..6, shift in 0u32..4,
        base in prop::collection::vec(-500.0f32..500.0, 16),
        detail in prop::collection::vec(-50i16..50, 36),
        dzs in prop::sample::select(vec![0.01f32, 1.0, 3.0]),
    ) {
        let (dw, dh) = (dw.max(2), dh.max(2));
        let b = Heightfield::new(&base[..(bw * bh) as usize], bw, bh).unwrap();
        let d = Heightfield::with_scale(&detail[..(dw * dh) as usize], dw, dh,
            Scale::default().with_z_scale(dzs).with_z_offset(0.5)).unwrap();
        let k = 1u32 << shift;
        let c = Composed::new(b, d, k).unwrap();
        prop_assert_eq!(c.width(), (bw - 1) * k + 1);
        for y in 0..c.height() {
            for x in 0..c.width() {
                let bil = b.surface_height_grid(Surface::Bilinear, x as f32 / k as f32, y as f32 / k as f32).unwrap();
                let det = d.z(x % dw, y % dh);
                let got = c.z(x, y);
                prop_assert!((got - (bil + det)).abs() <= 1e-3, "({x},{y}) {got} vs {bil}+{det}");
                let n = c.summed_normal(x, y).unwrap();
                prop_assert!((n.length() - 1.0).abs() <= 1e-6 && n.z > 0.0);
            }
        }
    }
}
