//! Base map + tiled detail map composition.
//!
//! Implements Balogh, *Real-time visualization of detailed terrain* (2003), chapter 6 ("Extending
//! SOAR with detail geometry"): the base map is refined `factor` times (a power of two) by
//! bilinear interpolation, and a tileable detail map is *added* to it (section 6.3 compares
//! displacement with simple addition and picks addition). Section 7.3 gives the normal of the
//! composed surface by summing height differences of base and detail before forming the normal,
//! which [`Composed::summed_normal`] implements.

use crate::heightfield::{lerp, Scale, Terrain};
use crate::normals::{central_gradient, normal_from_gradient};
use crate::{Error, Heightfield, Sample};
use glam::Vec3;

/// A base heightfield refined by a power-of-two `factor` with a tiled detail map added.
///
/// Composed sample `(X, Y)`, for `X` in `0..=(base_width-1)*factor`, has local height
///
/// `bilinear_base(X / factor, Y / factor) + detail(X mod detail_width, Y mod detail_height)`
///
/// where the detail's world height (`d * z_scale + z_offset` of the detail view) is added to the
/// base's local height. The composed spacing is the base spacing divided by `factor`; the detail
/// view's own spacing is ignored. The composed grid implements [`Terrain`], so it can be used
/// wherever a plain heightfield can (surfaces, normals, refinement, rays).
///
/// ```
/// use relief_core::{Composed, Heightfield, Terrain};
/// let base = Heightfield::new(&[0.0f32, 4.0, 0.0, 4.0], 2, 2).unwrap();
/// let detail = Heightfield::new(&[1.0f32, -1.0, -1.0, 1.0], 2, 2).unwrap();
/// let c = Composed::new(base, detail, 4).unwrap();
/// assert_eq!((c.width(), c.height()), (5, 5));
/// assert_eq!(c.z(1, 0), 1.0 + -1.0); // base 1.0 at x = 1/4, detail column 1
/// assert_eq!(c.z(2, 0), 2.0 + 1.0); // detail wraps: column 2 mod 2 = 0
/// ```
#[derive(Debug, Clone, Copy)]
pub struct Composed<'a, B: Sample, D: Sample> {
    base: Heightfield<'a, B>,
    detail: Heightfield<'a, D>,
    shift: u32,
    width: u32,
    height: u32,
}

impl<'a, B: Sample, D: Sample> Composed<'a, B, D> {
    /// Composes `base` and `detail` with the subdivision `factor` (a power of two, at least 1).
    ///
    /// Errors: [`Error::InvalidFactor`] if `factor` is zero or not a power of two,
    /// [`Error::SizeOverflow`] if the composed grid would have more than `u32::MAX` columns or
    /// rows or more than `usize::MAX` samples.
    ///
    /// ```
    /// use relief_core::{Composed, Error, Heightfield};
    /// let b = Heightfield::new(&[0u16; 4], 2, 2).unwrap();
    /// let d = Heightfield::new(&[0i16; 4], 2, 2).unwrap();
    /// assert_eq!(Composed::new(b, d, 3).unwrap_err(), Error::InvalidFactor { factor: 3 });
    /// ```
    pub fn new(
        base: Heightfield<'a, B>,
        detail: Heightfield<'a, D>,
        factor: u32,
    ) -> Result<Self, Error> {
        if !factor.is_power_of_two() {
            return Err(Error::InvalidFactor { factor });
        }
        let shift = factor.trailing_zeros();
        let width = (base.width() - 1)
            .checked_mul(factor)
            .and_then(|v| v.checked_add(1))
            .ok_or(Error::SizeOverflow)?;
        let height = (base.height() - 1)
            .checked_mul(factor)
            .and_then(|v| v.checked_add(1))
            .ok_or(Error::SizeOverflow)?;
        (width as usize)
            .checked_mul(height as usize)
            .ok_or(Error::SizeOverflow)?;
        Ok(Composed {
            base,
            detail,
            shift,
            width,
            height,
        })
    }

    /// The base heightfield.
    ///
    /// ```
    /// # use relief_core::{Composed, Heightfield, Terrain};
    /// # let b = Heightfield::new(&[0u16; 4], 2, 2).unwrap();
    /// # let d = Heightfield::new(&[0i16; 4], 2, 2).unwrap();
    /// let c = Composed::new(b, d, 8).unwrap();
    /// assert_eq!(c.base().width(), 2);
    /// ```
    #[must_use]
    pub fn base(&self) -> &Heightfield<'a, B> {
        &self.base
    }

    /// The detail heightfield.
    ///
    /// ```
    /// # use relief_core::{Composed, Heightfield, Terrain};
    /// # let b = Heightfield::new(&[0u16; 4], 2, 2).unwrap();
    /// # let d = Heightfield::new(&[0i16; 6], 3, 2).unwrap();
    /// let c = Composed::new(b, d, 8).unwrap();
    /// assert_eq!(c.detail().width(), 3);
    /// ```
    #[must_use]
    pub fn detail(&self) -> &Heightfield<'a, D> {
        &self.detail
    }

    /// The subdivision factor (composed samples per base cell along each axis).
    ///
    /// ```
    /// # use relief_core::{Composed, Heightfield};
    /// # let b = Heightfield::new(&[0u16; 4], 2, 2).unwrap();
    /// # let d = Heightfield::new(&[0i16; 4], 2, 2).unwrap();
    /// assert_eq!(Composed::new(b, d, 16).unwrap().factor(), 16);
    /// ```
    #[must_use]
    pub fn factor(&self) -> u32 {
        1 << self.shift
    }

    /// Local height of the bilinear base alone at composed sample `(x, y)` (clamped).
    ///
    /// ```
    /// # use relief_core::{Composed, Heightfield};
    /// let b = Heightfield::new(&[0.0f32, 2.0, 0.0, 2.0], 2, 2).unwrap();
    /// let d = Heightfield::new(&[5.0f32; 4], 2, 2).unwrap();
    /// assert_eq!(Composed::new(b, d, 2).unwrap().base_z(1, 1), 1.0);
    /// ```
    #[must_use]
    pub fn base_z(&self, x: u32, y: u32) -> f32 {
        let (bx, fx) = self.split(x.min(self.width - 1), self.base.width());
        let (by, fy) = self.split(y.min(self.height - 1), self.base.height());
        let [h00, h10, h01, h11] = self.base.cell_corners(bx, by);
        lerp(lerp(h00, h10, fx), lerp(h01, h11, fx), fy)
    }

    /// World height of the tiled detail alone at composed sample `(x, y)` (wrapping).
    ///
    /// ```
    /// # use relief_core::{Composed, Heightfield};
    /// let b = Heightfield::new(&[0u16; 4], 2, 2).unwrap();
    /// let d = Heightfield::new(&[1i16, 2, 3, 4, 5, 6], 3, 2).unwrap();
    /// let c = Composed::new(b, d, 4).unwrap();
    /// assert_eq!(c.detail_z(4, 3), 5.0); // (4 mod 3, 3 mod 2) = (1, 1)
    /// ```
    #[must_use]
    pub fn detail_z(&self, x: u32, y: u32) -> f32 {
        // Widths are at least 2; `checked_rem` keeps a division-by-zero panic path out of
        // callers that cannot see the heightfield's construction.
        let dw = self.detail.width();
        let dh = self.detail.height();
        self.detail.z(
            x.checked_rem(dw).unwrap_or(0),
            y.checked_rem(dh).unwrap_or(0),
        )
    }

    /// Base cell and fraction for composed coordinate `c` along an axis with `n` base samples.
    #[inline]
    fn split(&self, c: u32, n: u32) -> (u32, f32) {
        let cell = c >> self.shift;
        let frac = (c & ((1 << self.shift) - 1)) as f32 / (1u32 << self.shift) as f32;
        if cell >= n - 1 {
            (n - 2, 1.0)
        } else {
            (cell, frac)
        }
    }

    /// The unit normal at composed sample `(x, y)` from summed height differences (seed 004,
    /// section 7.3): the base's central-difference gradient, bilinearly interpolated to the
    /// composed sample, plus the detail map's central-difference gradient at the composed spacing
    /// (wrapping, since the detail tiles), turned into a normal only after the addition.
    /// `None` outside the grid.
    ///
    /// This needs only the base gradients at the four surrounding base samples and two detail
    /// differences, never the composed grid itself. Inside the domain and on a planar base it
    /// equals the central-difference normal of the composed surface.
    ///
    /// ```
    /// use relief_core::{Composed, Heightfield};
    /// let b = Heightfield::new(&[0u16; 4], 2, 2).unwrap();
    /// let d = Heightfield::new(&[0i16; 4], 2, 2).unwrap();
    /// let c = Composed::new(b, d, 4).unwrap();
    /// assert_eq!(c.summed_normal(2, 2), Some(glam::Vec3::Z));
    /// ```
    #[must_use]
    pub fn summed_normal(&self, x: u32, y: u32) -> Option<Vec3> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let (bx, fx) = self.split(x, self.base.width());
        let (by, fy) = self.split(y, self.base.height());
        let (fx, fy) = (f64::from(fx), f64::from(fy));
        let g = |x, y| central_gradient(&self.base, x, y);
        let (g00, g10, g01, g11) = (g(bx, by), g(bx + 1, by), g(bx, by + 1), g(bx + 1, by + 1));
        let lerp2 = |a: f64, b: f64, c: f64, d: f64| {
            let top = a + fx * (b - a);
            let bottom = c + fx * (d - c);
            top + fy * (bottom - top)
        };
        let bgx = lerp2(g00.0, g10.0, g01.0, g11.0);
        let bgy = lerp2(g00.1, g10.1, g01.1, g11.1);
        let (dw, dh) = (self.detail.width(), self.detail.height());
        let d = |x: u32, y: u32| f64::from(self.detail.local_z(x % dw, y % dh));
        let s = self.scale();
        let (xm, xp) = ((x % dw + dw - 1) % dw, (x + 1) % dw);
        let (ym, yp) = ((y % dh + dh - 1) % dh, (y + 1) % dh);
        let dgx = (d(xp, y) - d(xm, y)) / (2.0 * f64::from(s.dx));
        let dgy = (d(x, yp) - d(x, ym)) / (2.0 * f64::from(s.dy));
        Some(normal_from_gradient(bgx + dgx, bgy + dgy))
    }
}

impl<B: Sample, D: Sample> Terrain for Composed<'_, B, D> {
    #[inline]
    fn width(&self) -> u32 {
        self.width
    }
    #[inline]
    fn height(&self) -> u32 {
        self.height
    }
    /// Base spacing divided by the factor; `z_scale` 1 (already applied to base and detail);
    /// the base's `z_offset`.
    fn scale(&self) -> Scale {
        let b = self.base.scale();
        let k = (1u32 << self.shift) as f32;
        Scale {
            dx: b.dx / k,
            dy: b.dy / k,
            z_scale: 1.0,
            z_offset: b.z_offset,
        }
    }
    #[inline]
    fn local_z(&self, x: u32, y: u32) -> f32 {
        self.base_z(x, y) + self.detail_z(x, y)
    }
}
