//! The CONVENTIONS.md camera.

use glam::{Vec3, Vec4};
use relief_core::{Camera, Error};

#[test]
fn rejects_invalid_cameras() {
    let e = Vec3::new(1.0, 2.0, 3.0);
    assert!(matches!(
        Camera::new(e, e, 60.0, 4, 4),
        Err(Error::InvalidCamera { .. })
    ));
    assert!(matches!(
        Camera::new(e, e + Vec3::Z, 60.0, 4, 4),
        Err(Error::InvalidCamera { .. })
    ));
    assert!(matches!(
        Camera::new(e, e - Vec3::Z * 5.0, 60.0, 4, 4),
        Err(Error::InvalidCamera { .. })
    ));
    for fov in [0.0, -10.0, 180.0, f32::NAN, f32::INFINITY] {
        assert!(matches!(
            Camera::new(e, Vec3::ZERO, fov, 4, 4),
            Err(Error::InvalidParameter { name: "fov", .. })
        ));
    }
    assert!(Camera::new(e, Vec3::ZERO, 60.0, 0, 4).is_err());
    assert!(Camera::new(Vec3::new(f32::INFINITY, 0.0, 0.0), Vec3::ZERO, 60.0, 4, 4).is_err());
    let cam = Camera::new(e, Vec3::ZERO, 60.0, 4, 4).unwrap();
    assert!(cam.view_projection(0.0, 10.0).is_err());
    assert!(cam.view_projection(1.0, 1.0).is_err());
    assert!(cam.frustum_planes(f32::NAN, 10.0).is_err());
}

#[test]
fn pixel_rays_follow_the_conventions() {
    let cam = Camera::new(Vec3::ZERO, Vec3::new(0.0, 10.0, 0.0), 90.0, 4, 2).unwrap();
    let (f, r, u) = cam.basis();
    assert!((f - Vec3::Y).length() < 1e-7);
    assert!((r - Vec3::X).length() < 1e-7); // cross(+y, +z) = +x
    assert!((u - Vec3::Z).length() < 1e-7);
    // a = 2, s = 1: pixel (0, 0) -> px = (2*0.5/4 - 1)*2 = -1.5, py = 1 - 2*0.5/2 = 0.5.
    let (_, d) = cam.ray(0, 0);
    let want = Vec3::new(-1.5, 1.0, 0.5).normalize();
    assert!((d - want).length() < 1e-6, "{d} vs {want}");
    for j in 0..2 {
        for i in 0..4 {
            let (o, d) = cam.ray(i, j);
            assert_eq!(o, Vec3::ZERO);
            assert!((d.length() - 1.0).abs() < 1e-6);
        }
    }
}

#[test]
fn frustum_planes_agree_with_pixel_rays() {
    let cam = Camera::new(
        Vec3::new(100.0, 50.0, 30.0),
        Vec3::new(0.0, 0.0, 0.0),
        50.0,
        64,
        48,
    )
    .unwrap();
    let planes = cam.frustum_planes(1.0, 1000.0).unwrap();
    // Points along corner-pixel rays at distance 10 are inside (pixel centres are inside).
    for (i, j) in [(0, 0), (63, 0), (0, 47), (63, 47), (32, 24)] {
        let (o, d) = cam.ray(i, j);
        let p = (o + d * 10.0).extend(1.0);
        for pl in &planes {
            assert!(pl.dot(p) > 0.0, "pixel ({i},{j}) outside plane {pl}");
        }
    }
    // A point behind the eye and one beyond far are outside.
    let (f, _, _) = cam.basis();
    let behind = (cam.eye - f * 5.0).extend(1.0);
    assert!(planes.iter().any(|p| p.dot(behind) < 0.0));
    let beyond = (cam.eye + f * 2000.0).extend(1.0);
    assert!(planes[5].dot(beyond) < 0.0);
    // Planes are normalised: the near plane is 1 unit in front of the eye.
    let near_pt: Vec4 = (cam.eye + f * 1.0).extend(1.0);
    assert!(planes[4].dot(near_pt).abs() < 1e-3);
}

#[test]
fn far_from_origin_eye_is_precise_enough() {
    let eye = Vec3::new(1e6, 1e6, 2000.0);
    let cam = Camera::new(eye, eye + Vec3::new(1.0, 0.0, -0.1), 60.0, 8, 8).unwrap();
    let (f, _, _) = cam.basis();
    assert!((f - Vec3::new(1.0, 0.0, -0.1).normalize()).length() < 1e-3);
}
