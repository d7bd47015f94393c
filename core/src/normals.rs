//! Surface normals from finite differences.
//!
//! Implements the normals of Balogh, *Real-time visualization of detailed terrain* (2003),
//! section 2.3 (the normal as the cross product of the two tangents `(1, 0, dz/dx)` and
//! `(0, 1, dz/dy)`, i.e. `(-dz/dx, -dz/dy, 1)` normalised) and section 7.3 (the normal of a base +
//! detail surface from *summed* height differences, see
//! [`Composed::summed_normal`](crate::Composed::summed_normal)), and the Sobel operator used by
//! Kentie, *On-GPU ray traced terrain*, for smoother normals.
//!
//! Conventions: x along columns, y along rows, z up, right-handed; normals point up (`z > 0`) and
//! have unit length to 1e-6. Differences are taken in `f64` and the gradient is normalised there,
//! so flat ground, near-vertical cliffs and any accepted z scale give a finite unit vector.
//! On the border the missing neighbour is replaced by the sample itself (one-sided differences,
//! divided by the spacing actually spanned).

use crate::{Error, Terrain};
use glam::Vec3;

/// How a normal is estimated from the samples around a grid point.
///
/// ```
/// use relief_core::{normal, Heightfield, NormalMethod};
/// let hf = Heightfield::new(&[0u16; 9], 3, 3).unwrap();
/// assert_eq!(normal(&hf, 1, 1, NormalMethod::Sobel), Some(glam::Vec3::Z));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[non_exhaustive]
pub enum NormalMethod {
    /// Central differences of the four edge neighbours.
    #[default]
    Central,
    /// The 3 x 3 Sobel operator (weights 1, 2, 1 across the difference direction).
    Sobel,
}

/// Neighbour columns/rows around `i` in a grid of `n` samples, clamped, and the number of
/// spacings between them (1 on the border, 2 inside).
#[inline]
fn span(i: u32, n: u32) -> (u32, u32, f64) {
    let lo = i.saturating_sub(1);
    let hi = (i + 1).min(n - 1);
    (lo, hi, f64::from(hi - lo))
}

/// `(dz/dx, dz/dy)` in world units by central differences, one-sided on the border.
pub(crate) fn central_gradient<T: Terrain + ?Sized>(t: &T, x: u32, y: u32) -> (f64, f64) {
    let s = t.scale();
    let (xl, xr, sx) = span(x, t.width());
    let (yl, yr, sy) = span(y, t.height());
    let gx = (f64::from(t.local_z(xr, y)) - f64::from(t.local_z(xl, y))) / (sx * f64::from(s.dx));
    let gy = (f64::from(t.local_z(x, yr)) - f64::from(t.local_z(x, yl))) / (sy * f64::from(s.dy));
    (gx, gy)
}

/// `(dz/dx, dz/dy)` in world units by the Sobel operator, clamped on the border.
pub(crate) fn sobel_gradient<T: Terrain + ?Sized>(t: &T, x: u32, y: u32) -> (f64, f64) {
    let s = t.scale();
    let (xl, xr, sx) = span(x, t.width());
    let (yl, yr, sy) = span(y, t.height());
    let z = |x: u32, y: u32| f64::from(t.local_z(x, y));
    let gx = (z(xr, yl) + 2.0 * z(xr, y) + z(xr, yr)) - (z(xl, yl) + 2.0 * z(xl, y) + z(xl, yr));
    let gy = (z(xl, yr) + 2.0 * z(x, yr) + z(xr, yr)) - (z(xl, yl) + 2.0 * z(x, yl) + z(xr, yl));
    (
        gx / (4.0 * sx * f64::from(s.dx)),
        gy / (4.0 * sy * f64::from(s.dy)),
    )
}

/// The unit normal `(-gx, -gy, 1) / |.|` of a surface with gradient `(gx, gy)`, computed in
/// `f64`; a non-finite gradient (impossible for accepted heightfields) gives `+Z`.
///
/// ```
/// let n = relief_core::normal_from_gradient(1.0, 0.0);
/// assert!((n - glam::Vec3::new(-1.0, 0.0, 1.0).normalize()).length() < 1e-6);
/// ```
#[must_use]
pub fn normal_from_gradient(gx: f64, gy: f64) -> Vec3 {
    // Scale by the largest component first so the squares cannot overflow.
    let m = gx.abs().max(gy.abs()).max(1.0);
    if !m.is_finite() {
        return Vec3::Z;
    }
    let (a, b, c) = (-gx / m, -gy / m, 1.0 / m);
    let len = libm::sqrt(a * a + b * b + c * c);
    let (nx, ny, nz) = (a / len, b / len, c / len);
    // Rounding to f32 can leave |n| off by an ulp; renormalising in f32 keeps it within 1e-6.
    let n = Vec3::new(nx as f32, ny as f32, nz as f32);
    // A slope beyond ~1e7 (the f32 z component underflows relative to 1): keep z tiny but
    // positive so the normal still points up.
    if n.z > 0.0 {
        n
    } else {
        Vec3::new(n.x, n.y, f32::MIN_POSITIVE)
    }
}

/// The unit normal at sample `(x, y)`; `None` outside the grid.
///
/// ```
/// use relief_core::{normal, Heightfield, NormalMethod, Scale};
/// // z rises by 1 per unit of x: the normal leans towards -x.
/// let hf = Heightfield::new(&[0.0f32, 1.0, 2.0, 0.0, 1.0, 2.0], 3, 2).unwrap();
/// let n = normal(&hf, 1, 0, NormalMethod::Central).unwrap();
/// assert!((n - glam::Vec3::new(-1.0, 0.0, 1.0).normalize()).length() < 1e-6);
/// ```
#[must_use]
pub fn normal<T: Terrain + ?Sized>(t: &T, x: u32, y: u32, method: NormalMethod) -> Option<Vec3> {
    if x >= t.width() || y >= t.height() {
        return None;
    }
    let (gx, gy) = match method {
        NormalMethod::Central => central_gradient(t, x, y),
        NormalMethod::Sobel => sobel_gradient(t, x, y),
    };
    Some(normal_from_gradient(gx, gy))
}

/// Writes the normal of every sample, row-major, into `out` (at least `width * height`
/// elements; extra elements are left untouched).
///
/// ```
/// use relief_core::{normal_map, Heightfield, NormalMethod};
/// let hf = Heightfield::new(&[0u8; 6], 3, 2).unwrap();
/// let mut out = [glam::Vec3::ZERO; 6];
/// normal_map(&hf, NormalMethod::Central, &mut out).unwrap();
/// assert!(out.iter().all(|n| *n == glam::Vec3::Z));
/// let mut small = [glam::Vec3::ZERO; 5];
/// assert!(normal_map(&hf, NormalMethod::Central, &mut small).is_err());
/// ```
pub fn normal_map<T: Terrain + ?Sized>(
    t: &T,
    method: NormalMethod,
    out: &mut [Vec3],
) -> Result<(), Error> {
    let (w, h) = (t.width(), t.height());
    let needed = (w as usize)
        .checked_mul(h as usize)
        .ok_or(Error::SizeOverflow)?;
    if out.len() < needed {
        return Err(Error::BufferTooSmall {
            needed,
            actual: out.len(),
        });
    }
    for (y, row) in out
        .chunks_exact_mut(w as usize)
        .take(h as usize)
        .enumerate()
    {
        for (x, n) in row.iter_mut().enumerate() {
            *n = normal(t, x as u32, y as u32, method).unwrap_or(Vec3::Z);
        }
    }
    Ok(())
}
