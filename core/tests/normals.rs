//! Normals: unit length, pointing up, correct signs, stable at extremes.

use proptest::prelude::*;
use relief_core::{normal, normal_map, Error, Heightfield, NormalMethod, Scale};

const METHODS: [NormalMethod; 2] = [NormalMethod::Central, NormalMethod::Sobel];

fn assert_unit_up(n: glam::Vec3) {
    assert!(n.is_finite(), "{n}");
    assert!((n.length() - 1.0).abs() <= 1e-6, "|{n}| = {}", n.length());
    assert!(n.z > 0.0, "{n} does not point up");
}

#[test]
fn flat_ground_is_straight_up_everywhere() {
    for zs in [1e-3f32, 1.0, 1e4] {
        let hf = Heightfield::with_scale(&[1234u16; 25], 5, 5, Scale::default().with_z_scale(zs))
            .unwrap();
        for y in 0..5 {
            for x in 0..5 {
                for m in METHODS {
                    assert_eq!(normal(&hf, x, y, m), Some(glam::Vec3::Z));
                }
            }
        }
    }
}

#[test]
fn sign_conventions_follow_the_slope() {
    // Rising towards +x: normal leans to -x. Rising towards +y (later rows): leans to -y.
    let rise_x: Vec<f32> = (0..9).map(|i| (i % 3) as f32).collect();
    let rise_y: Vec<f32> = (0..9).map(|i| (i / 3) as f32).collect();
    for m in METHODS {
        let nx = normal(&Heightfield::new(&rise_x, 3, 3).unwrap(), 1, 1, m).unwrap();
        assert!(nx.x < 0.0 && nx.y.abs() < 1e-7, "{m:?} {nx}");
        let ny = normal(&Heightfield::new(&rise_y, 3, 3).unwrap(), 1, 1, m).unwrap();
        assert!(ny.y < 0.0 && ny.x.abs() < 1e-7, "{m:?} {ny}");
        // 45 degrees: n = (-1, 0, 1) / sqrt 2.
        let expect = glam::Vec3::new(-1.0, 0.0, 1.0).normalize();
        assert!((nx - expect).length() < 1e-6);
    }
}

#[test]
fn eighty_degree_slopes_and_extreme_scales() {
    let slope = 80f64.to_radians().tan(); // rise per unit run
    for zs in [1e-3f32, 1.0, 1e4] {
        // Heights chosen so that h * z_scale rises `slope` per unit of x.
        let s: Vec<f32> = (0..16)
            .map(|i| ((i % 4) as f64 * slope / zs as f64) as f32)
            .collect();
        let hf = Heightfield::with_scale(&s, 4, 4, Scale::default().with_z_scale(zs)).unwrap();
        for m in METHODS {
            for y in 0..4 {
                for x in 0..4 {
                    let n = normal(&hf, x, y, m).unwrap();
                    assert_unit_up(n);
                    let angle = (n.z as f64).acos().to_degrees();
                    assert!((angle - 80.0).abs() < 1e-3, "{zs} {m:?} tilt {angle}");
                }
            }
        }
    }
}

#[test]
fn vertical_cliffs_and_huge_gradients_stay_finite() {
    // A 1e29-high wall between tiny spacings: gradient ~1e59, beyond f32.
    let s = [0.0f32, 1e29, 0.0, 1e29];
    let hf =
        Heightfield::with_scale(&s, 2, 2, Scale::default().with_spacing(1e-30, 1e-30)).unwrap();
    for m in METHODS {
        let n = normal(&hf, 0, 0, m).unwrap();
        assert_unit_up(n);
        assert!(n.x < -0.99);
    }
}

#[test]
fn normal_map_fills_and_checks_the_buffer() {
    let s: Vec<u16> = (0..20).map(|i| (i * i) as u16).collect();
    let hf = Heightfield::new(&s, 5, 4).unwrap();
    let mut out = vec![glam::Vec3::ZERO; 21];
    normal_map(&hf, NormalMethod::Sobel, &mut out).unwrap();
    for y in 0..4 {
        for x in 0..5 {
            assert_eq!(
                out[(y * 5 + x) as usize],
                normal(&hf, x, y, NormalMethod::Sobel).unwrap()
            );
        }
    }
    assert_eq!(out[20], glam::Vec3::ZERO, "extra element untouched");
    let mut short = vec![glam::Vec3::ZERO; 19];
    assert_eq!(
        normal_map(&hf, NormalMethod::Central, &mut short),
        Err(Error::BufferTooSmall {
            needed: 20,
            actual: 19
        })
    );
    assert_eq!(normal(&hf, 5, 0, NormalMethod::Central), None);
}

proptest! {
    #[test]
    fn normals_are_unit_and_point_up(
        w in 2u32..7, h in 2u32..7,
        seed in prop::collection::vec(-1e6f32..1e6, 49),
        zs in prop::sample::select(vec![1e-3f32, 0.1, 1.0, 10.0, 1e4]),
        dx in prop::sample::select(vec![1e-3f32, 1.0, 160.0]),
    ) {
        let s = &seed[..(w * h) as usize];
        let hf = Heightfield::with_scale(s, w, h, Scale::default().with_z_scale(zs).with_spacing(dx, dx)).unwrap();
        for y in 0..h {
            for x in 0..w {
                for m in METHODS {
                    let n = normal(&hf, x, y, m).unwrap();
                    prop_assert!(n.is_finite());
                    prop_assert!((n.length() - 1.0).abs() <= 1e-6, "{}", n.length());
                    prop_assert!(n.z > 0.0);
                }
            }
        }
    }
}
