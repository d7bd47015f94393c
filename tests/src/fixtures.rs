//! Shared inputs of the cross-crate tests: the bundled Puget Sound DEM at the scale every test
//! and CONVENTIONS.md use (160 m spacing, heights in decimetres, z scale 0.1), and the two views
//! the ray tests trace over it.

use relief_core::glam::Vec3;
use relief_core::Camera;
use std::path::Path;

/// The bundled Puget Sound DEM (`data/puget_sound_1k.png`, 1025 x 1025) with spacing 160 m and
/// z scale 0.1 (the PNG stores decimetres).
///
/// ```
/// let dem = relief_tests::fixtures::puget();
/// assert_eq!((dem.width, dem.height), (1025, 1025));
/// assert_eq!(dem.scale.dx, 160.0);
/// ```
///
/// # Panics
/// When the bundled file is missing or unreadable (a broken checkout).
pub fn puget() -> relief_io::Dem {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/puget_sound_1k.png");
    let mut dem = relief_io::read_dem(&p, &Default::default()).expect("bundled DEM");
    dem.scale = dem.scale.with_spacing(160.0, 160.0).with_z_scale(0.1);
    dem
}

/// The two views of [`puget`] the ray tests trace, at `width x height` pixels: an oblique view
/// from 9 km up (fov 60), and a grazing one 30 m above the highest peak (4379.8 m) looking
/// along it (fov 30).
///
/// ```
/// let [oblique, grazing] = relief_tests::fixtures::puget_views(48, 32);
/// assert_eq!((oblique.width, grazing.height), (48, 32));
/// ```
///
/// # Panics
/// When `width` or `height` is zero.
pub fn puget_views(width: u32, height: u32) -> [Camera; 2] {
    [
        Camera::new(
            Vec3::new(20_000.0, 15_000.0, 9_000.0),
            Vec3::new(90_000.0, 100_000.0, 0.0),
            60.0,
            width,
            height,
        )
        .expect("oblique view"),
        Camera::new(
            Vec3::new(2_000.0, 3_000.0, 4_410.0),
            Vec3::new(160_000.0, 150_000.0, 4_390.0),
            30.0,
            width,
            height,
        )
        .expect("grazing view"),
    ]
}
