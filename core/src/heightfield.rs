//! Heightfield views over borrowed samples, the [`Terrain`] trait every algorithm reads through,
//! and surface evaluation (`triangles`, `bilinear`, `nearest`) as defined in the project's
//! CONVENTIONS.md.

use crate::{Error, Sample};
use glam::{Vec2, Vec3};

/// Largest magnitude a world height (`h * z_scale + z_offset`), a spacing or a scale may have.
///
/// Keeping heights within `±1e30` guarantees that differences, interpolation and products of
/// heights with fractions never overflow `f32`, so no algorithm can produce an infinity or NaN
/// from accepted input. Real terrain is 1e4 metres; even in micrometres it stays below 1e11.
///
/// ```
/// assert!(relief_core::MAX_ABS_HEIGHT > 1e20);
/// ```
pub const MAX_ABS_HEIGHT: f32 = 1e30;

/// Smallest spacing or scale accepted (keeps reciprocals finite).
///
/// ```
/// assert!(relief_core::MIN_SCALE < 1e-20);
/// ```
pub const MIN_SCALE: f32 = 1e-30;

/// Horizontal spacing and vertical scale and offset of a grid, as in CONVENTIONS.md:
/// sample `(x, y)` sits at `(x * dx, y * dy, h * z_scale + z_offset)`.
///
/// Defaults: `dx = dy = 1`, `z_scale = 1`, `z_offset = 0`.
///
/// ```
/// use relief_core::Scale;
/// let s = Scale::default().with_spacing(160.0, 160.0).with_z_scale(0.1);
/// assert_eq!((s.dx, s.dy, s.z_scale, s.z_offset), (160.0, 160.0, 0.1, 0.0));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scale {
    /// Distance between columns in world units (default 1).
    pub dx: f32,
    /// Distance between rows in world units (default 1).
    pub dy: f32,
    /// World units per stored height unit (default 1).
    pub z_scale: f32,
    /// World height of a stored 0 (default 0).
    pub z_offset: f32,
}

impl Default for Scale {
    fn default() -> Self {
        Scale {
            dx: 1.0,
            dy: 1.0,
            z_scale: 1.0,
            z_offset: 0.0,
        }
    }
}

impl Scale {
    /// Returns the scale with spacing `dx`, `dy`.
    ///
    /// ```
    /// let s = relief_core::Scale::default().with_spacing(2.0, 3.0);
    /// assert_eq!((s.dx, s.dy), (2.0, 3.0));
    /// ```
    #[must_use]
    pub fn with_spacing(mut self, dx: f32, dy: f32) -> Self {
        self.dx = dx;
        self.dy = dy;
        self
    }

    /// Returns the scale with vertical scale `z_scale`.
    ///
    /// ```
    /// assert_eq!(relief_core::Scale::default().with_z_scale(0.5).z_scale, 0.5);
    /// ```
    #[must_use]
    pub fn with_z_scale(mut self, z_scale: f32) -> Self {
        self.z_scale = z_scale;
        self
    }

    /// Returns the scale with vertical offset `z_offset`.
    ///
    /// ```
    /// assert_eq!(relief_core::Scale::default().with_z_offset(-3.0).z_offset, -3.0);
    /// ```
    #[must_use]
    pub fn with_z_offset(mut self, z_offset: f32) -> Self {
        self.z_offset = z_offset;
        self
    }

    /// Checks every field: spacings and `z_scale` finite and in `[MIN_SCALE, MAX_ABS_HEIGHT]`,
    /// `z_offset` finite and within `±MAX_ABS_HEIGHT`.
    ///
    /// ```
    /// use relief_core::{Error, Scale};
    /// assert!(Scale::default().validate().is_ok());
    /// assert_eq!(
    ///     Scale::default().with_spacing(0.0, 1.0).validate(),
    ///     Err(Error::InvalidParameter { name: "dx", value: 0.0 })
    /// );
    /// ```
    pub fn validate(&self) -> Result<(), Error> {
        let positive = |name: &'static str, value: f32| {
            if value.is_finite() && (MIN_SCALE..=MAX_ABS_HEIGHT).contains(&value) {
                Ok(())
            } else {
                Err(Error::InvalidParameter { name, value })
            }
        };
        positive("dx", self.dx)?;
        positive("dy", self.dy)?;
        positive("z_scale", self.z_scale)?;
        if !(self.z_offset.is_finite() && self.z_offset.abs() <= MAX_ABS_HEIGHT) {
            return Err(Error::InvalidParameter {
                name: "z_offset",
                value: self.z_offset,
            });
        }
        Ok(())
    }
}

/// The surface a ray hits or a mesh approximates between samples (CONVENTIONS.md).
///
/// ```
/// use relief_core::{Heightfield, Surface, Terrain};
/// let hf = Heightfield::new(&[0.0f32, 1.0, 1.0, 3.0], 2, 2).unwrap();
/// assert_eq!(hf.surface_height(Surface::Bilinear, 0.5, 0.5), Some(1.25));
/// assert_eq!(hf.surface_height(Surface::Triangles, 0.5, 0.5), Some(1.5));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Surface {
    /// Each cell split along the diagonal from `(x, y)` to `(x+1, y+1)` into two planar triangles
    /// (the reference surface).
    Triangles,
    /// The bilinear patch through the cell's four corners.
    Bilinear,
    /// The height of the nearest sample (sample boxes), for comparison only.
    Nearest,
    /// The linear-plane reconstruction of Henning & Stephenson (2004, section 3): along a ray,
    /// the surface heights on the two cell faces the ray crosses, linearly interpolated between
    /// them. It depends on the ray; as a height function ([`Terrain::surface_height`]) it is
    /// evaluated as [`Surface::Triangles`], which agrees with it on every cell face.
    Plane,
}

/// Read access to a regular grid of heights: what every algorithm in the crate works on.
///
/// Implemented by [`Heightfield`] and by the base + detail [`Composed`](crate::Composed) surface,
/// so a composed terrain can be used everywhere a plain one can. Implementors provide the five
/// required methods; everything else is derived from them.
///
/// Grid accessors take sample coordinates and clamp them into the grid (they never panic);
/// the `try_` forms return `None` outside. Heights are *local* (`h * z_scale`) or *world*
/// (`local + z_offset`); algorithms compute in local heights, which keeps precision when
/// `z_offset` is large.
///
/// ```
/// use relief_core::{Heightfield, Terrain};
/// let hf = Heightfield::new(&[1u16, 2, 3, 4], 2, 2).unwrap();
/// assert_eq!((hf.width(), hf.height()), (2, 2));
/// assert_eq!(hf.z(1, 1), 4.0);
/// assert_eq!(hf.z(9, 9), 4.0); // clamped
/// assert_eq!(hf.try_z(9, 9), None);
/// ```
pub trait Terrain {
    /// Number of columns (x), at least 2.
    fn width(&self) -> u32;
    /// Number of rows (y), at least 2.
    fn height(&self) -> u32;
    /// Spacing and vertical scale; `z_scale` is already applied by [`Terrain::local_z`].
    fn scale(&self) -> Scale;
    /// Local height `h * z_scale` of sample `(x, y)`, coordinates clamped into the grid.
    fn local_z(&self, x: u32, y: u32) -> f32;
    /// Local heights of `out.len()` consecutive samples of row `y` from column `x0`:
    /// `out[k] = local_z(x0 + k, y)`, bit for bit (coordinates clamped the same way). The
    /// default calls [`Terrain::local_z`] per sample; [`Heightfield`] copies from its row in
    /// one vectorisable loop, which row-wise algorithms (refinement preprocessing) use.
    ///
    /// ```
    /// use relief_core::{Heightfield, Scale, Terrain};
    /// let s: Vec<u16> = (0..12).collect();
    /// let hf = Heightfield::with_scale(&s, 4, 3, Scale::default().with_z_scale(0.5)).unwrap();
    /// let mut row = [0.0f32; 3];
    /// hf.local_z_row(1, 2, &mut row);
    /// assert_eq!(row, [4.5, 5.0, 5.5]);
    /// hf.local_z_row(3, 0, &mut row); // past the last column: clamped like local_z
    /// assert_eq!(row, [1.5, 1.5, 1.5]);
    /// ```
    fn local_z_row(&self, x0: u32, y: u32, out: &mut [f32]) {
        row_per_sample(self, x0, y, out);
    }

    /// Folds the local heights of `n` consecutive samples of row `y` from column `x0` (those of
    /// [`Terrain::local_z_row`], bit for bit, in order) into `acc`: four at a time with `quad`,
    /// then the last `n % 4` one at a time with `one`. The default reads each four through
    /// [`Terrain::local_z_row`]; [`Heightfield`] converts them straight from its row, so a
    /// row-wise reduction (refinement preprocessing) keeps them in registers instead of storing
    /// and reloading them. Loops `n / 4 + n % 4` times.
    ///
    /// ```
    /// use relief_core::{Heightfield, Terrain};
    /// let s: Vec<u16> = (0..12).collect();
    /// let hf = Heightfield::new(&s, 6, 2).unwrap();
    /// // Row 1 holds 6..=11: one quad (6, 7, 8, 9), then 10 alone.
    /// let quad = |(n, a): (u32, f32), q: [f32; 4]| (n + 1, a + q.iter().sum::<f32>());
    /// let one = |(n, a): (u32, f32), z: f32| (n, a + z);
    /// let (quads, sum) = hf.fold_local_z_row(0, 1, 5, (0, 0.0), quad, one);
    /// assert_eq!((quads, sum), (1, 6.0 + 7.0 + 8.0 + 9.0 + 10.0));
    /// ```
    fn fold_local_z_row<A>(
        &self,
        x0: u32,
        y: u32,
        n: usize,
        acc: A,
        quad: impl FnMut(A, [f32; 4]) -> A,
        one: impl FnMut(A, f32) -> A,
    ) -> A
    where
        Self: Sized,
    {
        fold_by_quads(self, x0, y, n, acc, quad, one)
    }

    /// Local heights of the four corners of cell `(cx, cy)`, in the order
    /// `(cx, cy), (cx+1, cy), (cx, cy+1), (cx+1, cy+1)`; cell coordinates clamped to
    /// `[0, width-2] x [0, height-2]`.
    fn cell_corners(&self, cx: u32, cy: u32) -> [f32; 4] {
        let cx = cx.min(self.width().saturating_sub(2));
        let cy = cy.min(self.height().saturating_sub(2));
        [
            self.local_z(cx, cy),
            self.local_z(cx + 1, cy),
            self.local_z(cx, cy + 1),
            self.local_z(cx + 1, cy + 1),
        ]
    }

    /// World height of sample `(x, y)`, coordinates clamped into the grid.
    fn z(&self, x: u32, y: u32) -> f32 {
        self.local_z(x, y) + self.scale().z_offset
    }

    /// World height of sample `(x, y)`, `None` outside the grid.
    fn try_z(&self, x: u32, y: u32) -> Option<f32> {
        (x < self.width() && y < self.height()).then(|| self.z(x, y))
    }

    /// World position `(x * dx, y * dy, z)` of sample `(x, y)`, `None` outside the grid.
    fn position(&self, x: u32, y: u32) -> Option<Vec3> {
        let s = self.scale();
        let z = self.try_z(x, y)?;
        Some(Vec3::new(x as f32 * s.dx, y as f32 * s.dy, z))
    }

    /// World extent of the domain: `((width-1) * dx, (height-1) * dy)`.
    fn extent(&self) -> Vec2 {
        let s = self.scale();
        Vec2::new(
            (self.width() - 1) as f32 * s.dx,
            (self.height() - 1) as f32 * s.dy,
        )
    }

    /// Minimum and maximum world height of cell `(cx, cy)`'s four corners (which bound the
    /// `triangles`, `bilinear` and `nearest` surfaces over the cell); `None` if the cell does not
    /// exist.
    fn cell_min_max(&self, cx: u32, cy: u32) -> Option<(f32, f32)> {
        if cx + 1 >= self.width() || cy + 1 >= self.height() {
            return None;
        }
        let c = self.cell_corners(cx, cy);
        let off = self.scale().z_offset;
        let lo = c[0].min(c[1]).min(c[2]).min(c[3]);
        let hi = c[0].max(c[1]).max(c[2]).max(c[3]);
        Some((lo + off, hi + off))
    }

    /// World height of `surface` at world position `(px, py)`; `None` outside the domain or for
    /// NaN coordinates.
    fn surface_height(&self, surface: Surface, px: f32, py: f32) -> Option<f32> {
        let s = self.scale();
        let (gx, gy) = (px / s.dx, py / s.dy);
        self.surface_height_grid(surface, gx, gy)
            .map(|h| h + s.z_offset)
    }

    /// Local height of `surface` at grid coordinates `(gx, gy)` (world position divided by the
    /// spacing); `None` outside `[0, width-1] x [0, height-1]` or for NaN coordinates.
    fn surface_height_grid(&self, surface: Surface, gx: f32, gy: f32) -> Option<f32> {
        let (w1, h1) = ((self.width() - 1) as f32, (self.height() - 1) as f32);
        if !(gx >= 0.0 && gx <= w1 && gy >= 0.0 && gy <= h1) {
            return None;
        }
        if let Surface::Nearest = surface {
            let x = libm::floorf(gx + 0.5) as u32;
            let y = libm::floorf(gy + 0.5) as u32;
            return Some(self.local_z(x, y));
        }
        let cx = (libm::floorf(gx) as u32).min(self.width() - 2);
        let cy = (libm::floorf(gy) as u32).min(self.height() - 2);
        let fx = gx - cx as f32;
        let fy = gy - cy as f32;
        let [h00, h10, h01, h11] = self.cell_corners(cx, cy);
        Some(match surface {
            Surface::Bilinear => lerp(lerp(h00, h10, fx), lerp(h01, h11, fx), fy),
            // Triangles, and Plane as a height function (see Surface::Plane). Barycentric
            // weights, exact at the corners.
            _ => {
                if fx >= fy {
                    // (x,y) (x+1,y) (x+1,y+1)
                    (1.0 - fx) * h00 + (fx - fy) * h10 + fy * h11
                } else {
                    // (x,y) (x+1,y+1) (x,y+1)
                    (1.0 - fy) * h00 + (fy - fx) * h01 + fx * h11
                }
            }
        })
    }

    /// Height gradient `(dz/dx, dz/dy)` in world units at sample `(x, y)` by central differences
    /// (one-sided on the border); `None` outside the grid. Computed in `f64`, so it is finite for
    /// every accepted heightfield.
    fn gradient(&self, x: u32, y: u32) -> Option<Vec2> {
        if x >= self.width() || y >= self.height() {
            return None;
        }
        let (gx, gy) = crate::normals::central_gradient(self, x, y);
        Some(Vec2::new(gx as f32, gy as f32))
    }
}

/// A read-only heightfield over borrowed samples of type `S` (`u8`, `u16`, `i16`, `i32`, `f32`).
///
/// Constructed with a checked constructor: at least 2 x 2 samples, `samples.len() == width *
/// height`, a valid [`Scale`], and (for `f32` samples, or integer samples whose range times
/// `z_scale` could exceed [`MAX_ABS_HEIGHT`]) every sample finite with a world height within
/// `±MAX_ABS_HEIGHT`. The view is `Copy` and costs nothing to pass around.
///
/// ```
/// use relief_core::{Heightfield, Scale, Terrain};
/// let samples = [0u16, 10, 20, 30, 40, 50];
/// let hf = Heightfield::with_scale(&samples, 3, 2, Scale::default().with_z_scale(0.1)).unwrap();
/// assert_eq!(hf.z(2, 1), 5.0);
/// assert_eq!(hf.sample(1, 1), Some(40));
/// ```
#[derive(Debug, Clone, Copy)]
pub struct Heightfield<'a, S: Sample> {
    samples: &'a [S],
    width: u32,
    height: u32,
    scale: Scale,
}

impl<'a, S: Sample> Heightfield<'a, S> {
    /// The stored samples `x0..x0 + n` of row `y` (clamped into the grid), `None` if they run
    /// past the last column.
    #[inline(always)]
    fn row_samples(&self, x0: u32, y: u32, n: usize) -> Option<&[S]> {
        if (x0 as usize).saturating_add(n) > self.width as usize {
            return None;
        }
        let start = y.min(self.height - 1) as usize * self.width as usize + x0 as usize;
        self.samples.get(start..start + n)
    }

    /// A heightfield with the default [`Scale`] (unit spacing and scale).
    ///
    /// ```
    /// use relief_core::{Error, Heightfield};
    /// assert!(Heightfield::new(&[0i16; 4], 2, 2).is_ok());
    /// assert_eq!(
    ///     Heightfield::new(&[0i16; 3], 3, 1).unwrap_err(),
    ///     Error::TooSmall { width: 3, height: 1 }
    /// );
    /// ```
    pub fn new(samples: &'a [S], width: u32, height: u32) -> Result<Self, Error> {
        Self::with_scale(samples, width, height, Scale::default())
    }

    /// A heightfield with the given spacing and vertical scale.
    ///
    /// ```
    /// use relief_core::{Error, Heightfield, Scale};
    /// let bad = [0.0f32, f32::NAN, 0.0, 0.0];
    /// assert_eq!(
    ///     Heightfield::with_scale(&bad, 2, 2, Scale::default()).unwrap_err(),
    ///     Error::BadSample { x: 1, y: 0 }
    /// );
    /// ```
    pub fn with_scale(
        samples: &'a [S],
        width: u32,
        height: u32,
        scale: Scale,
    ) -> Result<Self, Error> {
        if width < 2 || height < 2 {
            return Err(Error::TooSmall { width, height });
        }
        let expected = (width as usize)
            .checked_mul(height as usize)
            .ok_or(Error::SizeOverflow)?;
        if samples.len() != expected {
            return Err(Error::LengthMismatch {
                expected,
                actual: samples.len(),
            });
        }
        scale.validate()?;
        // Integer types whose whole range stays in bounds need no per-sample scan.
        let range_ok = S::MAX_ABS * scale.z_scale + scale.z_offset.abs() <= MAX_ABS_HEIGHT;
        if !range_ok {
            if let Some(i) = samples.iter().position(|s| {
                let z = s.to_f32() * scale.z_scale + scale.z_offset;
                !(z.is_finite() && z.abs() <= MAX_ABS_HEIGHT)
            }) {
                return Err(Error::BadSample {
                    x: (i % width as usize) as u32,
                    y: (i / width as usize) as u32,
                });
            }
        }
        Ok(Heightfield {
            samples,
            width,
            height,
            scale,
        })
    }

    /// The borrowed samples, row-major.
    ///
    /// ```
    /// let s = [1u8, 2, 3, 4];
    /// assert_eq!(relief_core::Heightfield::new(&s, 2, 2).unwrap().samples(), &s);
    /// ```
    #[must_use]
    pub fn samples(&self) -> &'a [S] {
        self.samples
    }

    /// The stored sample at `(x, y)`, `None` outside the grid.
    ///
    /// ```
    /// let hf = relief_core::Heightfield::new(&[1u8, 2, 3, 4], 2, 2).unwrap();
    /// assert_eq!(hf.sample(0, 1), Some(3));
    /// assert_eq!(hf.sample(2, 0), None);
    /// ```
    #[must_use]
    pub fn sample(&self, x: u32, y: u32) -> Option<S> {
        if x >= self.width || y >= self.height {
            return None;
        }
        self.samples
            .get(y as usize * self.width as usize + x as usize)
            .copied()
    }
}

impl<S: Sample> Terrain for Heightfield<'_, S> {
    #[inline]
    fn width(&self) -> u32 {
        self.width
    }
    #[inline]
    fn height(&self) -> u32 {
        self.height
    }
    #[inline]
    fn scale(&self) -> Scale {
        self.scale
    }
    #[inline]
    fn local_z(&self, x: u32, y: u32) -> f32 {
        let x = x.min(self.width - 1) as usize;
        let y = y.min(self.height - 1) as usize;
        // The constructor guarantees the index is in range; `get` keeps this panic-free anyway.
        self.samples
            .get(y * self.width as usize + x)
            .map_or(0.0, |s| s.to_f32() * self.scale.z_scale)
    }
    #[inline]
    fn local_z_row(&self, x0: u32, y: u32, out: &mut [f32]) {
        match self.row_samples(x0, y, out.len()) {
            Some(row) => {
                let z = self.scale.z_scale;
                for (o, s) in out.iter_mut().zip(row) {
                    *o = s.to_f32() * z;
                }
            }
            None => row_per_sample(self, x0, y, out),
        }
    }
    #[inline]
    fn fold_local_z_row<A>(
        &self,
        x0: u32,
        y: u32,
        n: usize,
        acc: A,
        mut quad: impl FnMut(A, [f32; 4]) -> A,
        mut one: impl FnMut(A, f32) -> A,
    ) -> A {
        let Some(row) = self.row_samples(x0, y, n) else {
            // Past the last column: the clamping of local_z.
            return fold_by_quads(self, x0, y, n, acc, quad, one);
        };
        let z = self.scale.z_scale;
        let mut acc = acc;
        let mut quads = row.chunks_exact(4);
        for q in &mut quads {
            if let &[a, b, c, d] = q {
                acc = quad(
                    acc,
                    [
                        a.to_f32() * z,
                        b.to_f32() * z,
                        c.to_f32() * z,
                        d.to_f32() * z,
                    ],
                );
            }
        }
        for s in quads.remainder() {
            acc = one(acc, s.to_f32() * z);
        }
        acc
    }
}

/// [`Terrain::fold_local_z_row`] through [`Terrain::local_z_row`], four samples at a time.
fn fold_by_quads<T: Terrain, A>(
    t: &T,
    x0: u32,
    y: u32,
    n: usize,
    acc: A,
    mut quad: impl FnMut(A, [f32; 4]) -> A,
    mut one: impl FnMut(A, f32) -> A,
) -> A {
    let mut acc = acc;
    let mut k = 0usize;
    while n - k >= 4 {
        let mut q = [0.0f32; 4];
        t.local_z_row(column(x0, k), y, &mut q);
        acc = quad(acc, q);
        k += 4;
    }
    while k < n {
        acc = one(acc, t.local_z(column(x0, k), y));
        k += 1;
    }
    acc
}

/// [`Terrain::local_z_row`] by one [`Terrain::local_z`] call per sample.
#[inline]
fn row_per_sample<T: Terrain + ?Sized>(t: &T, x0: u32, y: u32, out: &mut [f32]) {
    for (k, o) in out.iter_mut().enumerate() {
        *o = t.local_z(column(x0, k), y);
    }
}

/// Column `x0 + k`, saturated (columns past the grid clamp to its last one anyway).
#[inline(always)]
fn column(x0: u32, k: usize) -> u32 {
    u32::try_from(k).map_or(u32::MAX, |k| x0.saturating_add(k))
}

/// `(1 - t) a + t b`: exact at `t = 0` and `t = 1`, so interpolated surfaces pass exactly
/// through the samples.
#[inline(always)]
pub(crate) fn lerp(a: f32, b: f32, t: f32) -> f32 {
    (1.0 - t) * a + t * b
}

#[cfg(test)]
mod row_tests {
    use crate::{Composed, Heightfield, Scale, Terrain};
    use std::vec::Vec;

    /// `local_z_row` equals `local_z` sample by sample, bit for bit, for heightfields (their own
    /// row copy) and composed terrains (the default), inside the grid, across its right edge,
    /// past its last row and at the largest column; and so does `fold_local_z_row`.
    #[test]
    fn local_z_row_is_local_z_per_sample() {
        fn check<T: Terrain>(t: &T) {
            let mut out = [0.0f32; 23];
            for y in [0, 1, t.height() - 1, t.height() + 4] {
                for x0 in [
                    0,
                    3,
                    t.width() - 5,
                    t.width() - 1,
                    t.width() + 2,
                    u32::MAX - 4,
                ] {
                    for n in [0usize, 1, 5, 23] {
                        t.local_z_row(x0, y, &mut out[..n]);
                        for (k, v) in out[..n].iter().enumerate() {
                            let x = x0.saturating_add(k as u32);
                            assert_eq!(v.to_bits(), t.local_z(x, y).to_bits(), "{x0}+{k}, {y}");
                        }
                        // The fold sees the same values in the same order, n / 4 quads.
                        let (quads, seen) = t.fold_local_z_row(
                            x0,
                            y,
                            n,
                            (0usize, Vec::new()),
                            |(q, mut seen), z4| {
                                seen.extend(z4.map(f32::to_bits));
                                (q + 1, seen)
                            },
                            |(q, mut seen), z| {
                                seen.push(z.to_bits());
                                (q, seen)
                            },
                        );
                        let want: Vec<u32> = out[..n].iter().map(|v| v.to_bits()).collect();
                        assert_eq!((quads, seen), (n / 4, want), "fold {x0}, {y}, {n}");
                    }
                }
            }
        }
        let s: Vec<f32> = (0..21 * 9)
            .map(|i| (i * 37 % 101) as f32 * 0.37 - 9.0)
            .collect();
        let sc = Scale::default().with_z_scale(0.3);
        check(&Heightfield::with_scale(&s, 21, 9, sc).unwrap());
        let u: Vec<u16> = (0..21 * 9).map(|i| (i * 7919 % 65521) as u16).collect();
        check(&Heightfield::with_scale(&u, 21, 9, sc).unwrap());
        let b = Heightfield::new(&s[..6 * 3], 6, 3).unwrap();
        let d: Vec<i16> = (0..21 * 9).map(|i| (i % 13) as i16 - 6).collect();
        let comp = Composed::new(b, Heightfield::new(&d, 21, 9).unwrap(), 4).unwrap();
        check(&comp);
    }
}
