//! The pinhole camera shared by ray tracing, view-dependent refinement and cascade fitting,
//! exactly as CONVENTIONS.md defines it.

use crate::Error;
use glam::{Mat4, Vec3, Vec4};

/// A pinhole camera: eye `E`, target `T`, vertical field of view in degrees, image size.
///
/// `f = normalize(T - E)`, `r = normalize(cross(f, +z))`, `u = cross(r, f)`, `a = w / h`,
/// `s = tan(fov / 2)`; pixel `(i, j)` (column from the left, row from the top) is sampled through
/// its centre: `px = (2 (i + 0.5) / w - 1) a s`, `py = (1 - 2 (j + 0.5) / h) s`,
/// `dir = normalize(f + px r + py u)`, origin `E`.
///
/// ```
/// use relief_core::Camera;
/// use glam::Vec3;
/// let cam = Camera::new(Vec3::new(0.0, 0.0, 10.0), Vec3::new(10.0, 0.0, 10.0), 90.0, 2, 2).unwrap();
/// let (o, d) = cam.ray(0, 0);
/// assert_eq!(o, Vec3::new(0.0, 0.0, 10.0));
/// assert!(d.x > 0.0 && d.y > 0.0 && d.z > 0.0); // top-left pixel looks left (+y) and up
/// assert!(Camera::new(Vec3::ZERO, Vec3::Z, 60.0, 8, 8).is_err()); // straight up
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Eye position `E` (world units).
    pub eye: Vec3,
    /// Target `T` the camera looks at.
    pub target: Vec3,
    /// Vertical field of view in degrees, in `(0, 180)`.
    pub fov_deg: f32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    tan_half: f32,
}

impl Camera {
    /// Builds and checks a camera: every input finite, `fov` in `(0, 180)` degrees, image at
    /// least 1 x 1, eye and target distinct, and the view not parallel to z
    /// ([`Error::InvalidCamera`]).
    ///
    /// ```
    /// use relief_core::{Camera, Error};
    /// use glam::Vec3;
    /// let e = Camera::new(Vec3::NAN, Vec3::ONE, 60.0, 4, 4).unwrap_err();
    /// assert_eq!(e, Error::InvalidCamera { reason: "eye or target is not finite" });
    /// ```
    pub fn new(
        eye: Vec3,
        target: Vec3,
        fov_deg: f32,
        width: u32,
        height: u32,
    ) -> Result<Camera, Error> {
        if !eye.is_finite() || !target.is_finite() {
            return Err(Error::InvalidCamera {
                reason: "eye or target is not finite",
            });
        }
        if !(fov_deg.is_finite() && fov_deg > 0.0 && fov_deg < 180.0) {
            return Err(Error::InvalidParameter {
                name: "fov",
                value: fov_deg,
            });
        }
        if width == 0 || height == 0 {
            return Err(Error::InvalidCamera {
                reason: "image size must be at least 1x1",
            });
        }
        // Differences in f64 so that eye and target far from the origin stay distinct.
        let d = target.as_dvec3() - eye.as_dvec3();
        let len = d.length();
        if !(len > 0.0 && len.is_finite()) {
            return Err(Error::InvalidCamera {
                reason: "eye and target coincide",
            });
        }
        let f = d / len;
        let horizontal = libm::sqrt(f.x * f.x + f.y * f.y);
        if horizontal < 1e-6 {
            return Err(Error::InvalidCamera {
                reason: "camera looks straight up or down",
            });
        }
        let forward = f.as_vec3();
        let right = glam::DVec3::new(f.y, -f.x, 0.0) / horizontal; // normalize(cross(f, +z))
        let up = right.cross(f);
        Ok(Camera {
            eye,
            target,
            fov_deg,
            width,
            height,
            forward,
            right: right.as_vec3(),
            up: up.as_vec3(),
            tan_half: libm::tanf(fov_deg.to_radians() * 0.5),
        })
    }

    /// Unit forward, right and up vectors `(f, r, u)`.
    ///
    /// ```
    /// # use relief_core::Camera; use glam::Vec3;
    /// let cam = Camera::new(Vec3::ZERO, Vec3::X, 60.0, 4, 4).unwrap();
    /// let (f, r, u) = cam.basis();
    /// assert_eq!((f, r, u), (Vec3::X, Vec3::new(0.0, -1.0, 0.0), Vec3::Z));
    /// ```
    #[must_use]
    pub fn basis(&self) -> (Vec3, Vec3, Vec3) {
        (self.forward, self.right, self.up)
    }

    /// `tan(fov / 2)`.
    ///
    /// ```
    /// # use relief_core::Camera; use glam::Vec3;
    /// let cam = Camera::new(Vec3::ZERO, Vec3::X, 90.0, 4, 4).unwrap();
    /// assert!((cam.tan_half_fov() - 1.0).abs() < 1e-6);
    /// ```
    #[must_use]
    pub fn tan_half_fov(&self) -> f32 {
        self.tan_half
    }

    /// Pixels per unit of (error / distance): `kappa = (height / 2) / tan(fov / 2)`, so an
    /// object-space error `e` at distance `d` projects to `e * kappa / d` pixels.
    ///
    /// ```
    /// # use relief_core::Camera; use glam::Vec3;
    /// let cam = Camera::new(Vec3::ZERO, Vec3::X, 90.0, 640, 480).unwrap();
    /// assert!((cam.kappa() - 240.0).abs() < 1e-3);
    /// ```
    #[must_use]
    pub fn kappa(&self) -> f32 {
        self.height as f32 * 0.5 / self.tan_half
    }

    /// Origin and unit direction of the ray through the centre of pixel `(i, j)` (column `i`
    /// from the left, row `j` from the top). Pixels outside the image are extrapolated.
    ///
    /// ```
    /// # use relief_core::Camera; use glam::Vec3;
    /// let cam = Camera::new(Vec3::ZERO, Vec3::X, 60.0, 3, 3).unwrap();
    /// let (_, d) = cam.ray(1, 1);
    /// assert!((d - Vec3::X).length() < 1e-6); // centre pixel looks at the target
    /// ```
    #[must_use]
    pub fn ray(&self, i: u32, j: u32) -> (Vec3, Vec3) {
        let a = self.width as f32 / self.height as f32;
        let px = (2.0 * (i as f32 + 0.5) / self.width as f32 - 1.0) * a * self.tan_half;
        let py = (1.0 - 2.0 * (j as f32 + 0.5) / self.height as f32) * self.tan_half;
        let d = self.forward + px * self.right + py * self.up;
        (self.eye, d.normalize_or(self.forward))
    }

    /// Right-handed view-projection matrix with WebGPU depth range `[0, 1]` for planes at `near`
    /// and `far` (`0 < near < far`), matching [`Camera::ray`]'s pixel mapping.
    ///
    /// ```
    /// # use relief_core::Camera; use glam::{Vec3, Vec4};
    /// let cam = Camera::new(Vec3::ZERO, Vec3::X, 60.0, 4, 4).unwrap();
    /// let m = cam.view_projection(1.0, 100.0).unwrap();
    /// let p = m * Vec4::new(10.0, 0.0, 0.0, 1.0);
    /// assert!((p.x / p.w).abs() < 1e-6 && (p.y / p.w).abs() < 1e-6);
    /// ```
    pub fn view_projection(&self, near: f32, far: f32) -> Result<Mat4, Error> {
        if !(near.is_finite() && near > 0.0) {
            return Err(Error::InvalidParameter {
                name: "near",
                value: near,
            });
        }
        if !(far.is_finite() && far > near) {
            return Err(Error::InvalidParameter {
                name: "far",
                value: far,
            });
        }
        let view = glam::camera::rh::view::look_at_mat4(self.eye, self.eye + self.forward, self.up);
        let aspect = self.width as f32 / self.height as f32;
        let proj = glam::camera::rh::proj::directx::perspective(
            self.fov_deg.to_radians(),
            aspect,
            near,
            far,
        );
        Ok(proj * view)
    }

    /// The six frustum planes `(n, d)` with `n . p + d >= 0` inside, normalised so that
    /// `n . p + d` is a signed distance, in the order left, right, bottom, top, near, far
    /// (Gribb & Hartmann's extraction from the view-projection matrix).
    ///
    /// ```
    /// # use relief_core::Camera; use glam::{Vec3, Vec4};
    /// let cam = Camera::new(Vec3::ZERO, Vec3::X, 60.0, 4, 4).unwrap();
    /// let planes = cam.frustum_planes(1.0, 100.0).unwrap();
    /// let inside = Vec4::new(10.0, 0.0, 0.0, 1.0);
    /// assert!(planes.iter().all(|p| p.dot(inside) > 0.0));
    /// ```
    pub fn frustum_planes(&self, near: f32, far: f32) -> Result<[Vec4; 6], Error> {
        let m = self.view_projection(near, far)?;
        let (r0, r1, r2, r3) = (m.row(0), m.row(1), m.row(2), m.row(3));
        let raw = [r3 + r0, r3 - r0, r3 + r1, r3 - r1, r2, r3 - r2];
        let mut out = [Vec4::ZERO; 6];
        for (o, p) in out.iter_mut().zip(raw) {
            let len = p.truncate().length();
            *o = if len > 0.0 { p / len } else { p };
        }
        Ok(out)
    }
}
