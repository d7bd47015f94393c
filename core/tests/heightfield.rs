//! Heightfield views, scales, surfaces and their error paths.

use proptest::prelude::*;
use relief_core::{Error, Heightfield, Scale, Surface, Terrain};

#[test]
fn constructor_rejects_every_bad_shape() {
    assert_eq!(
        Heightfield::new(&[0u16; 2], 2, 1).unwrap_err(),
        Error::TooSmall {
            width: 2,
            height: 1
        }
    );
    assert_eq!(
        Heightfield::new(&[0u16; 0], 0, 0).unwrap_err(),
        Error::TooSmall {
            width: 0,
            height: 0
        }
    );
    assert_eq!(
        Heightfield::new(&[0u16; 5], 2, 2).unwrap_err(),
        Error::LengthMismatch {
            expected: 4,
            actual: 5
        }
    );
    // width * height overflows usize only on 32-bit targets; on 64-bit it is a mismatch.
    assert!(Heightfield::new(&[0u16; 4], u32::MAX, u32::MAX).is_err());
}

#[test]
fn constructor_rejects_bad_scales() {
    let s = [0i16; 4];
    for (scale, name) in [
        (Scale::default().with_spacing(0.0, 1.0), "dx"),
        (Scale::default().with_spacing(-1.0, 1.0), "dx"),
        (Scale::default().with_spacing(1.0, f32::NAN), "dy"),
        (Scale::default().with_spacing(1.0, f32::INFINITY), "dy"),
        (Scale::default().with_z_scale(0.0), "z_scale"),
        (Scale::default().with_z_scale(-2.0), "z_scale"),
        (Scale::default().with_z_scale(f32::NAN), "z_scale"),
        (Scale::default().with_z_offset(f32::INFINITY), "z_offset"),
        (Scale::default().with_z_offset(2e30), "z_offset"),
    ] {
        match Heightfield::with_scale(&s, 2, 2, scale) {
            Err(Error::InvalidParameter { name: n, .. }) => assert_eq!(n, name, "{scale:?}"),
            other => panic!("{scale:?} gave {other:?}"),
        }
    }
}

#[test]
fn constructor_names_first_bad_sample() {
    let mut v = [1.0f32; 12];
    v[7] = f32::INFINITY;
    v[9] = f32::NAN;
    assert_eq!(
        Heightfield::new(&v, 4, 3).unwrap_err(),
        Error::BadSample { x: 3, y: 1 }
    );
    let big = [0.0f32, 1e31, 0.0, 0.0];
    assert_eq!(
        Heightfield::new(&big, 2, 2).unwrap_err(),
        Error::BadSample { x: 1, y: 0 }
    );
    // Integer samples whose range times z_scale leaves the bound are scanned too.
    let ints = [0u16, 65535, 0, 0];
    let scale = Scale::default().with_z_scale(1e26);
    assert_eq!(
        Heightfield::with_scale(&ints, 2, 2, scale).unwrap_err(),
        Error::BadSample { x: 1, y: 0 }
    );
    // ... but pass when every actual value fits.
    let small = [0u16, 1, 0, 0];
    assert!(Heightfield::with_scale(&small, 2, 2, scale).is_ok());
}

#[test]
fn errors_display_one_line() {
    let errs = [
        Error::TooSmall {
            width: 1,
            height: 1,
        },
        Error::LengthMismatch {
            expected: 4,
            actual: 3,
        },
        Error::SizeOverflow,
        Error::InvalidParameter {
            name: "dx",
            value: f32::NAN,
        },
        Error::BadSample { x: 1, y: 2 },
        Error::InvalidFactor { factor: 3 },
        Error::BufferTooSmall {
            needed: 4,
            actual: 3,
        },
        Error::InvalidCamera { reason: "x" },
        Error::NonFiniteInput { name: "ray" },
        Error::OutOfBounds { x: 9, y: 9 },
    ];
    for e in errs {
        let s = e.to_string();
        assert!(!s.is_empty() && !s.contains('\n'), "{s:?}");
        let _: &dyn std::error::Error = &e;
    }
}

#[test]
fn sample_access_and_world_positions() {
    let s: Vec<i16> = (0..12).map(|v| v as i16 - 5).collect();
    let scale = Scale::default()
        .with_spacing(2.0, 3.0)
        .with_z_scale(0.5)
        .with_z_offset(100.0);
    let hf = Heightfield::with_scale(&s, 4, 3, scale).unwrap();
    assert_eq!(hf.sample(3, 2), Some(6));
    assert_eq!(hf.sample(4, 0), None);
    assert_eq!(hf.sample(0, 3), None);
    assert_eq!(hf.local_z(1, 1), 0.0);
    assert_eq!(hf.z(1, 1), 100.0);
    assert_eq!(hf.position(3, 2), Some(glam::Vec3::new(6.0, 6.0, 103.0)));
    assert_eq!(hf.position(4, 2), None);
    assert_eq!(hf.extent(), glam::Vec2::new(6.0, 6.0));
    assert_eq!(hf.cell_min_max(0, 0), Some((97.5, 100.0)));
    assert_eq!(hf.cell_min_max(3, 0), None);
    assert_eq!(hf.cell_min_max(0, 2), None);
}

#[test]
fn every_sample_type_reads() {
    assert_eq!(Heightfield::new(&[255u8; 4], 2, 2).unwrap().z(1, 1), 255.0);
    assert_eq!(
        Heightfield::new(&[65535u16; 4], 2, 2).unwrap().z(1, 1),
        65535.0
    );
    assert_eq!(
        Heightfield::new(&[-32768i16; 4], 2, 2).unwrap().z(1, 1),
        -32768.0
    );
    assert_eq!(Heightfield::new(&[-7i32; 4], 2, 2).unwrap().z(1, 1), -7.0);
    assert_eq!(Heightfield::new(&[0.25f32; 4], 2, 2).unwrap().z(1, 1), 0.25);
}

#[test]
fn surfaces_in_one_cell() {
    // h00=0, h10=4, h01=2, h11=8
    let hf = Heightfield::new(&[0.0f32, 4.0, 2.0, 8.0], 2, 2).unwrap();
    // Lower-right triangle (fx >= fy): plane through (0,0,0), (1,0,4), (1,1,8).
    assert_eq!(
        hf.surface_height(Surface::Triangles, 0.75, 0.25),
        Some(3.0 + 1.0)
    );
    // Upper-left triangle: plane through (0,0,0), (1,1,8), (0,1,2).
    assert_eq!(
        hf.surface_height(Surface::Triangles, 0.25, 0.75),
        Some(1.5 + 1.5)
    );
    // The diagonal is shared.
    assert_eq!(hf.surface_height(Surface::Triangles, 0.5, 0.5), Some(4.0));
    assert_eq!(hf.surface_height(Surface::Bilinear, 0.5, 0.5), Some(3.5));
    assert_eq!(hf.surface_height(Surface::Nearest, 0.4, 0.6), Some(2.0));
    assert_eq!(hf.surface_height(Surface::Nearest, 0.5, 0.5), Some(8.0));
    for s in [Surface::Triangles, Surface::Bilinear, Surface::Nearest] {
        assert_eq!(hf.surface_height(s, -0.001, 0.5), None);
        assert_eq!(hf.surface_height(s, 0.5, 1.001), None);
        assert_eq!(hf.surface_height(s, f32::NAN, 0.5), None);
        assert_eq!(hf.surface_height(s, 0.5, f32::INFINITY), None);
        assert_eq!(hf.surface_height(s, 1.0, 1.0), Some(8.0));
    }
}

#[test]
fn spacing_and_offset_apply_to_surfaces() {
    let scale = Scale::default()
        .with_spacing(10.0, 20.0)
        .with_z_scale(2.0)
        .with_z_offset(1e6);
    let hf = Heightfield::with_scale(&[0u16, 1, 2, 3], 2, 2, scale).unwrap();
    assert_eq!(
        hf.surface_height(Surface::Bilinear, 5.0, 10.0),
        Some(1e6 + 3.0)
    );
    assert_eq!(
        hf.surface_height_grid(Surface::Bilinear, 0.5, 0.5),
        Some(3.0)
    );
    assert_eq!(hf.surface_height(Surface::Bilinear, 10.5, 0.0), None);
}

#[test]
fn gradient_central_and_one_sided() {
    // z = 3x + 2y on a 4x3 grid with dx = 0.5, dy = 2.
    let mut s = Vec::new();
    for y in 0..3 {
        for x in 0..4 {
            s.push(3.0 * x as f32 * 0.5 + 2.0 * y as f32 * 2.0);
        }
    }
    let hf = Heightfield::with_scale(&s, 4, 3, Scale::default().with_spacing(0.5, 2.0)).unwrap();
    for y in 0..3 {
        for x in 0..4 {
            let g = hf.gradient(x, y).unwrap();
            assert!(
                (g.x - 3.0).abs() < 1e-5 && (g.y - 2.0).abs() < 1e-5,
                "{x},{y}: {g}"
            );
        }
    }
    assert_eq!(hf.gradient(4, 0), None);
}

fn grid() -> impl Strategy<Value = (u32, u32, Vec<f32>)> {
    (2u32..9, 2u32..9).prop_flat_map(|(w, h)| {
        (
            Just(w),
            Just(h),
            prop::collection::vec(-1000.0f32..1000.0, (w * h) as usize),
        )
    })
}

proptest! {
    #[test]
    fn surfaces_equal_samples_at_grid_points((w, h, s) in grid()) {
        let hf = Heightfield::new(&s, w, h).unwrap();
        for y in 0..h {
            for x in 0..w {
                for surf in [Surface::Triangles, Surface::Bilinear, Surface::Nearest] {
                    prop_assert_eq!(hf.surface_height(surf, x as f32, y as f32), Some(hf.z(x, y)));
                }
            }
        }
    }

    #[test]
    fn triangles_and_bilinear_are_continuous_across_cell_edges(
        (w, h, s) in grid(), t in 0.0f32..1.0, cell in 0u32..64)
    {
        let hf = Heightfield::new(&s, w, h).unwrap();
        let eps = 1e-3f32;
        let cx = cell % (w - 1);
        let cy = (cell / (w - 1)) % (h - 1);
        // Points on the cell's right edge and top edge, approached from both sides.
        let edges = [
            ((cx + 1) as f32, cy as f32 + t, (eps, 0.0)),
            (cx as f32 + t, (cy + 1) as f32, (0.0, eps)),
        ];
        for surf in [Surface::Triangles, Surface::Bilinear] {
            for (ex, ey, (ox, oy)) in edges {
                let (Some(a), Some(b)) = (
                    hf.surface_height(surf, ex - ox, ey - oy),
                    hf.surface_height(surf, (ex + ox).min((w - 1) as f32), (ey + oy).min((h - 1) as f32)),
                ) else { continue };
                let on = hf.surface_height(surf, ex, ey).unwrap();
                // Max slope is 2000 per unit; eps = 1e-3 moves at most 2 units plus rounding.
                prop_assert!((a - on).abs() <= 2000.0 * eps * 2.0 + 1e-2, "{surf:?} {a} {on}");
                prop_assert!((b - on).abs() <= 2000.0 * eps * 2.0 + 1e-2, "{surf:?} {b} {on}");
            }
        }
    }

    #[test]
    fn surfaces_lie_within_cell_bounds((w, h, s) in grid(), gx in 0.0f32..1.0, gy in 0.0f32..1.0) {
        let hf = Heightfield::new(&s, w, h).unwrap();
        let (px, py) = (gx * (w - 1) as f32, gy * (h - 1) as f32);
        let cx = (px as u32).min(w - 2);
        let cy = (py as u32).min(h - 2);
        let (lo, hi) = hf.cell_min_max(cx, cy).unwrap();
        for surf in [Surface::Triangles, Surface::Bilinear, Surface::Nearest] {
            let z = hf.surface_height(surf, px, py).unwrap();
            prop_assert!(z >= lo - 1e-3 && z <= hi + 1e-3, "{surf:?} {z} not in [{lo}, {hi}]");
        }
    }
}
