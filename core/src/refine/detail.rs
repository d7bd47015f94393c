//! Detail levels below the base grid: view-dependent SOAR refinement of a [`Composed`] surface
//! (bilinear base + tiled detail map) that continues past the base grid's finest level into the
//! composed grid (Balogh 2003, seed 004, chapter 6.3; lazy frustum culling from chapter 5.2).
//!
//! The composed ("virtual") grid of a `factor = 2^d` composition has `(base_width - 1) * 2^d + 1`
//! columns: seed 004's demo, a 1025^2 base with a 1024^2 detail map and `factor = 64`, is a
//! 65537^2 grid. Nothing is preprocessed per virtual sample:
//! - **Base levels** (the first [`RefineGrid::levels`] levels of the base hierarchy) use the base
//!   [`Hierarchy`]: its nested errors and bounding spheres (or level circles), tested exactly as
//!   [`Refiner`](super::Refiner) does, with frustum culling down to the lazy level.
//! - **Detail levels** (`2 d` more) use seed 004's level-only bounding circles
//!   `r_i = l_0 (1/sqrt 2)^i / (1 - 1/sqrt 2)`, extended over the composed surface's height range,
//!   and one error per detail level ([`DetailBounds`]: a constant, or a bound measured once from
//!   the base's bilinear twist and the detail map, nested by a suffix maximum). Seed 004's flat
//!   circles cannot cull (section 6.3); here each circle is extended over the composed height
//!   range into a cylinder, which can: detail vertices are tested against every frustum plane
//!   (so the decision depends on the vertex alone), and lazy culling (chapter 5.2) skips the test
//!   on the finest [`View::with_lazy_levels`] levels of the virtual grid.
//! - A base vertex is refined when its own (sphere) projection **or** the circle projection of
//!   the largest detail error exceeds the threshold: the maximum of the two projections, which
//!   keeps the detail mesh nested with the base mesh, so there are no cracks where detail starts.
//!
//! Output: an indexed triangle list (world positions, counter-clockwise seen from +z) into caller
//! buffers. Vertices are numbered in first-use order through an open-addressing table in the
//! caller's `scratch` ([`detail_scratch_len`]); every buffer that is too small gives
//! [`Error::BufferTooSmall`], never a truncated mesh. [`DetailRefiner::count`] is the count-only
//! mode.
//!
//! ```
//! use relief_core::refine::{detail_scratch_len, preprocess, DetailBounds, DetailRefiner, View};
//! use relief_core::{Camera, Composed, Heightfield};
//! use glam::Vec3;
//! let base_s: Vec<f32> = (0..81).map(|i| ((i * 7) % 5) as f32).collect();
//! let base = Heightfield::new(&base_s, 9, 9).unwrap();
//! let det_s: Vec<f32> = (0..64).map(|i| ((i * 5) % 3) as f32 * 0.1).collect();
//! let detail = Heightfield::new(&det_s, 8, 8).unwrap();
//! let c = Composed::new(base, detail, 8).unwrap(); // 65 x 65 virtual grid
//! let (mut e, mut r) = (vec![0.0; 81], vec![0.0; 81]);
//! let h = preprocess(c.base(), &mut e, &mut r).unwrap();
//! let bounds = DetailBounds::measure(&c);
//! let cam = Camera::new(Vec3::new(1.0, 1.0, 6.0), Vec3::new(4.0, 4.0, 0.0), 60.0, 320, 240).unwrap();
//! let dr = DetailRefiner::new(&h, &c, &bounds, &View::new(&cam, 1.0).unwrap()).unwrap();
//! let t = dr.triangle_count();
//! let mut scratch = vec![0u64; detail_scratch_len(3 * t)];
//! let counts = dr.count(&mut scratch).unwrap();
//! let mut v = vec![[0.0f32; 3]; counts.vertices];
//! let mut tris = vec![[0u32; 3]; counts.triangles];
//! assert_eq!(dr.triangles(&mut scratch, &mut v, &mut tris).unwrap(), counts);
//! assert!(counts.detail_triangles() > 0); // refined below the base grid near the eye
//! ```

use super::grid::{main_diagonal, Class, RefineGrid};
use super::preprocess::{round_up, CIRCLE_MARGIN};
use super::raster::{for_each_span, Plane};
use super::select::{need, Decision, View};
use super::Hierarchy;
use crate::{Composed, Error, Heightfield, Sample, Terrain};

/// Entries of the per-level arrays (a grid has at most 60 levels).
const LEVELS: usize = 64;

/// The period scan of [`DetailBounds::measure`] runs when the joint period of the detail map and
/// the triangle pattern covers at most this many detail maps.
pub const MEASURE_PERIOD_LIMIT: u64 = 16;

/// Per-detail-level errors (nested: non-increasing with the level) and the detail map's height
/// range, computed once per composition; used by [`DetailRefiner`].
///
/// Detail level `j` (`0 <= j < 2 d` for `factor = 2^d`) is level `base_levels + j` of the
/// virtual grid: `j = 0` splits a base cell along its diagonal, `j = 2 d - 1` reaches single
/// composed cells.
///
/// ```
/// use relief_core::{refine::DetailBounds, Composed, Heightfield};
/// let base = Heightfield::new(&[0.0f32; 4], 2, 2).unwrap();
/// let detail = Heightfield::new(&[0.0f32, 1.0, 1.0, 0.0], 2, 2).unwrap();
/// let c = Composed::new(base, detail, 4).unwrap();
/// let b = DetailBounds::constant(&c, 0.5).unwrap();
/// assert_eq!((b.detail_levels(), b.error(0), b.error(3)), (4, Some(0.5), Some(0.5)));
/// assert_eq!(b.error(4), None);
/// assert_eq!(b.detail_range(), (0.0, 1.0));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetailBounds<'a> {
    shift: u32,
    errors: [f32; LEVELS],
    d_lo: f32,
    d_hi: f32,
    twist: f32,
    exact: bool,
    /// Unit-twist error per detail level, nested (non-increasing).
    tau: [f32; LEVELS],
    /// Detail-map part per detail level, nested (suffix maximum).
    delta: [f32; LEVELS],
    /// Largest `|height|` of base plus detail (for the rounding margin).
    max_abs: f32,
    /// [`Self::measure_local`]: nested twist per base vertex, then twist per base cell.
    local: Option<&'a [f32]>,
}

/// Relative and absolute (times the largest height) rounding margin of measured bounds.
const MARGIN: f64 = 1.0 / (1u64 << 20) as f64;

/// Length of the buffer of [`DetailBounds::measure_local`] for a `width x height` base: one
/// `f32` per base vertex and one per base cell, `w h + (w - 1)(h - 1)` (saturating).
///
/// ```
/// assert_eq!(relief_core::refine::local_bounds_len(3, 3), 9 + 4);
/// ```
#[must_use]
pub const fn local_bounds_len(width: u32, height: u32) -> usize {
    (width as usize)
        .saturating_mul(height as usize)
        .saturating_add(
            (width.saturating_sub(1) as usize).saturating_mul(height.saturating_sub(1) as usize),
        )
}

/// Chebyshev reach of the descendants of a level-`level` vertex in a grid of `levels` levels
/// whose enclosing square has `side` cells: the sum over deeper levels of the offset from a vertex
/// to its children (`h` for a centre of half-size `h`, `h / 2` for an edge). Nested exactly:
/// a parent's reach is at least its offset to a child plus the child's reach.
fn reach(side: u64, levels: u32, level: u32) -> i64 {
    let mut r = 0i64;
    for l in level..levels.min(64) {
        let h = side.checked_shr(l / 2 + 1).unwrap_or(0) as i64;
        r = r.saturating_add(if l % 2 == 0 { h } else { h / 2 });
    }
    r
}

/// Cells `lo..=hi` (clamped to `0..cells`) whose closed extent `[c K, (c + 1) K]` meets
/// `[a, b]` (virtual coordinates, `K = 2^shift`); `None` if none.
fn cell_span(a: i64, b: i64, shift: u32, cells: i64) -> Option<(i64, i64)> {
    // ceil(a / K) - 1 and floor(b / K), with arithmetic shifts (floor division).
    let lo = (-((a.saturating_neg()) >> shift)).saturating_sub(1).max(0);
    let hi = (b >> shift).min(cells - 1);
    (lo <= hi).then_some((lo, hi))
}

impl<'a> DetailBounds<'a> {
    /// The same `error` (world z units, finite, `>= 0`) for every detail level: LOD selection by
    /// distance only (seed 004, section 6.3), for static or dynamic detail. Scans the detail map
    /// once for its height range and the base once for its largest bilinear twist.
    ///
    /// ```
    /// use relief_core::{refine::DetailBounds, Composed, Error, Heightfield};
    /// let b = Heightfield::new(&[0.0f32; 4], 2, 2).unwrap();
    /// let c = Composed::new(b, b, 2).unwrap();
    /// assert_eq!(
    ///     DetailBounds::constant(&c, -1.0).unwrap_err(),
    ///     Error::InvalidParameter { name: "detail_error", value: -1.0 }
    /// );
    /// assert!(DetailBounds::constant(&c, f32::NAN).is_err());
    /// ```
    pub fn constant<B: Sample, D: Sample>(
        c: &Composed<'_, B, D>,
        error: f32,
    ) -> Result<DetailBounds<'static>, Error> {
        if !(error.is_finite() && error >= 0.0) {
            return Err(Error::InvalidParameter {
                name: "detail_error",
                value: error,
            });
        }
        let mut b = DetailBounds::scan(c);
        let n = b.detail_levels() as usize;
        for e in b.errors.iter_mut().take(n) {
            *e = error;
        }
        b.exact = false;
        Ok(b)
    }

    /// A true bound per detail level on the vertical distance between every composed sample of
    /// a triangle at that level and the triangle's plane, nested by a suffix maximum.
    ///
    /// The plane of a sum is the sum of the planes, so the bound is the base part plus the detail
    /// part. Base: within one base cell the bilinear base deviates from a plane by its twist
    /// `t = h00 - h10 - h01 + h11` times `u v - plane(u v)`, at most `t (h/K)^2` on the triangles
    /// of a centre vertex of half-size `h` (composed cells, `K = factor`) and `t (h/K)^2 / 4` on
    /// those of an edge vertex; every detail-level triangle lies in one base cell. Detail: the
    /// exact maximum over every triangle of the level at every offset of the tiled map, found by
    /// scanning one joint period `lcm(2K, detail_width) x lcm(2K, detail_height)` (the triangle
    /// pattern repeats every `2K`), when that period covers at most [`MEASURE_PERIOD_LIMIT`]
    /// detail maps; otherwise the detail map's height range, a bound for every triangle.
    /// Cost: about `2 * 2 d * period area` detail samples, plus one pass over the base cells.
    ///
    /// ```
    /// use relief_core::{refine::DetailBounds, Composed, Heightfield};
    /// // A planar base (twist 0) and a planar detail: every level's error is (nearly) zero.
    /// let base = Heightfield::new(&[0.0f32, 1.0, 2.0, 3.0], 2, 2).unwrap();
    /// let det: Vec<f32> = (0..16).map(|i| 0.0 * i as f32).collect();
    /// let d = Heightfield::new(&det, 4, 4).unwrap();
    /// let b = DetailBounds::measure(&Composed::new(base, d, 4).unwrap());
    /// assert!(b.is_measured());
    /// assert!(b.error(0).unwrap() < 1e-5);
    /// ```
    #[must_use]
    pub fn measure<B: Sample, D: Sample>(c: &Composed<'_, B, D>) -> DetailBounds<'static> {
        let mut b = DetailBounds::scan(c);
        let d = c.detail();
        let k = 1u64 << b.shift;
        let (dw, dh) = (u64::from(d.width()), u64::from(d.height()));
        let (px, py) = (lcm(2 * k, dw), lcm(2 * k, dh));
        let periodic = px
            .checked_mul(py)
            .is_some_and(|a| a <= MEASURE_PERIOD_LIMIT.saturating_mul(dw * dh));
        let range = f64::from(b.d_hi) - f64::from(b.d_lo);
        let twist = f64::from(b.twist);
        let kf = k as f64;
        let mut max_abs = f64::from(b.d_lo.abs().max(b.d_hi.abs()));
        let (blo, bhi) = base_range(c.base());
        max_abs += f64::from(blo.abs().max(bhi.abs()));
        let n = b.detail_levels();
        for j in 0..n {
            let h = (k >> (j / 2 + 1)) as i64;
            let centre = j % 2 == 0;
            let q = h as f64 / kf;
            let tau = if centre { q * q } else { q * q * 0.25 };
            let delta = if periodic {
                level_detail_error(d, px as i64, py as i64, h, centre)
            } else {
                range
            };
            // Margin for the f32 arithmetic of the composed heights (a few ulps).
            let e = (twist * tau + delta) * (1.0 + MARGIN) + max_abs * MARGIN;
            if let Some(s) = b.errors.get_mut(j as usize) {
                *s = round_up(e);
            }
            if let Some(s) = b.tau.get_mut(j as usize) {
                *s = round_up(tau);
            }
            if let Some(s) = b.delta.get_mut(j as usize) {
                *s = round_up(delta);
            }
        }
        // Nest: a level's error covers every finer level's.
        let (mut acc, mut at, mut ad) = (0.0f32, 0.0f32, 0.0f32);
        for j in (0..n as usize).rev() {
            if let (Some(s), Some(t), Some(d)) =
                (b.errors.get_mut(j), b.tau.get_mut(j), b.delta.get_mut(j))
            {
                acc = acc.max(*s);
                *s = acc;
                at = at.max(*t);
                *t = at;
                ad = ad.max(*d);
                *d = ad;
            }
        }
        b.max_abs = round_up(max_abs);
        b.exact = periodic;
        b
    }

    /// [`Self::measure`] with the base part made local: instead of the largest twist of the whole
    /// base, a detail vertex uses the largest twist of the base cells within the Chebyshev reach
    /// of its descendants (the cells its and their triangles lie in), and a base vertex the
    /// largest over its descendants, so the bound stays true and nested while a steep cell
    /// somewhere no longer inflates every detail vertex. `buffer` (at least
    /// [`local_bounds_len`] of the base) receives one nested twist per base vertex and the
    /// twist of every base cell; the refiner reads them. Cost: [`Self::measure`] plus a few
    /// passes over the base.
    ///
    /// ```
    /// use relief_core::refine::{local_bounds_len, DetailBounds};
    /// use relief_core::{Composed, Error, Heightfield};
    /// // A flat base with one twisted cell in a corner.
    /// let mut s = vec![0.0f32; 81];
    /// s[0] = 40.0;
    /// let base = Heightfield::new(&s, 9, 9).unwrap();
    /// let d = Heightfield::new(&[0.0f32; 4], 2, 2).unwrap();
    /// let c = Composed::new(base, d, 4).unwrap();
    /// let mut buf = vec![0.0f32; local_bounds_len(9, 9)];
    /// let local = DetailBounds::measure_local(&c, &mut buf).unwrap();
    /// assert!(local.is_local() && local.error(0) == DetailBounds::measure(&c).error(0));
    /// assert!(matches!(
    ///     DetailBounds::measure_local(&c, &mut vec![0.0; 10]),
    ///     Err(Error::BufferTooSmall { .. })
    /// ));
    /// ```
    pub fn measure_local<B: Sample, D: Sample>(
        c: &Composed<'_, B, D>,
        buffer: &'a mut [f32],
    ) -> Result<DetailBounds<'a>, Error> {
        let base = c.base();
        let (bw, bh) = (base.width(), base.height());
        need(local_bounds_len(bw, bh), buffer.len())?;
        let g = RefineGrid::new(bw, bh)?;
        let mut b = DetailBounds::measure(c);
        let n = g.len();
        let cw = (bw - 1) as usize;
        let (tb, cells) = buffer.split_at_mut(n.min(buffer.len()));
        for cy in 0..bh.saturating_sub(1) {
            for cx in 0..bw.saturating_sub(1) {
                let [p, q, r, s] = base.cell_corners(cx, cy);
                let t = (f64::from(p) - f64::from(q) - f64::from(r) + f64::from(s)).abs();
                if let Some(o) = cells.get_mut(cy as usize * cw + cx as usize) {
                    *o = round_up(t);
                }
            }
        }
        tb.fill(0.0);
        let shift = b.shift;
        if shift > 0 {
            let levels = g.levels() + 2 * shift;
            let vside = u64::from(g.side()) << shift;
            let r = reach(vside, levels, g.levels().saturating_sub(1));
            let (wi, hi) = (i64::from(bw), i64::from(bh));
            let idx = |x: i64, y: i64| y as usize * bw as usize + x as usize;
            let mut h = 1i64;
            let nside = i64::from(g.side());
            // Bottom-up over the base hierarchy: the finest level (edges of half-size 1) takes
            // the cells within its reach; every coarser vertex the maximum of its children.
            // Loops: levels x width x height vertices (each finest one over at most 5 x 5 cells).
            while h < nside {
                for pass in 0..3 {
                    let (x0, y0) = match pass {
                        0 => (h, 0),
                        1 => (0, h),
                        _ => (h, h),
                    };
                    let mut y = y0;
                    while y < hi {
                        let mut x = x0;
                        while x < wi {
                            let mut t = 0.0f32;
                            if h == 1 && pass < 2 {
                                let (vx, vy) = (x << shift, y << shift);
                                let cells_x = cell_span(vx - r, vx + r, shift, wi - 1);
                                let cells_y = cell_span(vy - r, vy + r, shift, hi - 1);
                                if let (Some((xl, xh)), Some((yl, yh))) = (cells_x, cells_y) {
                                    for cy in yl..=yh {
                                        for cx in xl..=xh {
                                            let k = cy as usize * cw + cx as usize;
                                            t = t.max(cells.get(k).copied().unwrap_or(0.0));
                                        }
                                    }
                                }
                            } else {
                                for &(cx, cy) in g.children(x as u32, y as u32).iter().flatten() {
                                    if g.in_domain(cx, cy) {
                                        t = t.max(tb.get(idx(cx, cy)).copied().unwrap_or(0.0));
                                    }
                                }
                            }
                            if let Some(o) = tb.get_mut(idx(x, y)) {
                                *o = t;
                            }
                            x += 2 * h;
                        }
                        y += 2 * h;
                    }
                }
                h *= 2;
            }
        }
        b.local = Some(&*buffer);
        Ok(b)
    }

    /// Whether this is [`Self::measure_local`]'s bound (per-vertex base part).
    ///
    /// ```
    /// # use relief_core::{refine::DetailBounds, Composed, Heightfield};
    /// # let b = Heightfield::new(&[0.0f32; 4], 2, 2).unwrap();
    /// let c = Composed::new(b, b, 2).unwrap();
    /// assert!(!DetailBounds::measure(&c).is_local());
    /// ```
    #[must_use]
    pub fn is_local(&self) -> bool {
        self.local.is_some()
    }

    /// Shared part: shift, detail range, base twist; errors zero.
    fn scan<B: Sample, D: Sample>(c: &Composed<'_, B, D>) -> DetailBounds<'static> {
        let d = c.detail();
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for y in 0..d.height() {
            for x in 0..d.width() {
                let z = d.z(x, y);
                lo = lo.min(z);
                hi = hi.max(z);
            }
        }
        let base = c.base();
        let mut twist = 0.0f32;
        for cy in 0..base.height().saturating_sub(1) {
            for cx in 0..base.width().saturating_sub(1) {
                let [a, b, p, q] = base.cell_corners(cx, cy);
                let t = (f64::from(a) - f64::from(b) - f64::from(p) + f64::from(q)).abs();
                twist = twist.max(round_up(t));
            }
        }
        DetailBounds {
            shift: c.factor().trailing_zeros(),
            errors: [0.0; LEVELS],
            d_lo: lo,
            d_hi: hi,
            twist,
            exact: false,
            tau: [0.0; LEVELS],
            delta: [0.0; LEVELS],
            max_abs: 0.0,
            local: None,
        }
    }

    /// Number of detail levels, `2 d` for `factor = 2^d`.
    ///
    /// ```
    /// # use relief_core::{refine::DetailBounds, Composed, Heightfield};
    /// # let b = Heightfield::new(&[0.0f32; 4], 2, 2).unwrap();
    /// let c = Composed::new(b, b, 64).unwrap();
    /// assert_eq!(DetailBounds::constant(&c, 1.0).unwrap().detail_levels(), 12);
    /// ```
    #[must_use]
    pub fn detail_levels(&self) -> u32 {
        2 * self.shift
    }

    /// The (nested) error of detail level `j`, world z units; `None` past the last level.
    ///
    /// ```
    /// # use relief_core::{refine::DetailBounds, Composed, Heightfield};
    /// # let b = Heightfield::new(&[0.0f32; 4], 2, 2).unwrap();
    /// let c = Composed::new(b, b, 2).unwrap();
    /// let d = DetailBounds::constant(&c, 2.0).unwrap();
    /// assert_eq!((d.error(1), d.error(2)), (Some(2.0), None));
    /// ```
    #[must_use]
    pub fn error(&self, j: u32) -> Option<f32> {
        if j < self.detail_levels() {
            self.errors.get(j as usize).copied()
        } else {
            None
        }
    }

    /// Lowest and highest world height of the detail map.
    ///
    /// ```
    /// # use relief_core::{refine::DetailBounds, Composed, Heightfield};
    /// let b = Heightfield::new(&[0.0f32; 4], 2, 2).unwrap();
    /// let d = Heightfield::new(&[-1.0f32, 2.0, 0.0, 0.0], 2, 2).unwrap();
    /// let c = Composed::new(b, d, 2).unwrap();
    /// assert_eq!(DetailBounds::measure(&c).detail_range(), (-1.0, 2.0));
    /// ```
    #[must_use]
    pub fn detail_range(&self) -> (f32, f32) {
        (self.d_lo, self.d_hi)
    }

    /// Largest `|h00 - h10 - h01 + h11|` over the base cells (local heights): how far the
    /// bilinear base bends away from planes.
    ///
    /// ```
    /// # use relief_core::{refine::DetailBounds, Composed, Heightfield};
    /// let b = Heightfield::new(&[0.0f32, 0.0, 0.0, 3.0], 2, 2).unwrap();
    /// let c = Composed::new(b, b, 2).unwrap();
    /// assert_eq!(DetailBounds::measure(&c).base_twist(), 3.0);
    /// ```
    #[must_use]
    pub fn base_twist(&self) -> f32 {
        self.twist
    }

    /// Whether the detail part of the errors is the exact period scan of [`Self::measure`]
    /// (`false` for [`Self::constant`] and for the height-range fallback).
    ///
    /// ```
    /// # use relief_core::{refine::DetailBounds, Composed, Heightfield};
    /// # let b = Heightfield::new(&[0.0f32; 4], 2, 2).unwrap();
    /// let c = Composed::new(b, b, 2).unwrap();
    /// assert!(!DetailBounds::constant(&c, 1.0).unwrap().is_measured());
    /// ```
    #[must_use]
    pub fn is_measured(&self) -> bool {
        self.exact
    }
}

fn base_range<B: Sample>(b: &Heightfield<'_, B>) -> (f32, f32) {
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    for y in 0..b.height() {
        for x in 0..b.width() {
            let z = b.local_z(x, y);
            lo = lo.min(z);
            hi = hi.max(z);
        }
    }
    (lo, hi)
}

fn gcd(mut a: u64, mut b: u64) -> u64 {
    // At most ~92 steps (Fibonacci worst case for 64-bit values).
    for _ in 0..128 {
        if b == 0 {
            break;
        }
        let t = a.checked_rem(b).unwrap_or(0);
        a = b;
        b = t;
    }
    a
}

/// Least common multiple, saturating; `u64::MAX` for zero inputs.
fn lcm(a: u64, b: u64) -> u64 {
    let g = gcd(a, b);
    match a.checked_div(g) {
        Some(q) => q.saturating_mul(b),
        None => u64::MAX,
    }
}

/// The two triangles of the diamond of the level vertex at `(x, y)` with half-size `h`
/// (`centre`: centre of a `2h` square; otherwise an edge midpoint, horizontal when `y` is a
/// multiple of `2h`), on the unbounded lattice.
fn diamond_at(x: i64, y: i64, h: i64, centre: bool) -> [[(i64, i64); 3]; 2] {
    if centre {
        let (c00, c10, c01, c11) = (
            (x - h, y - h),
            (x + h, y - h),
            (x - h, y + h),
            (x + h, y + h),
        );
        if main_diagonal(x - h, y - h, 2 * h) {
            [[c00, c10, c11], [c00, c11, c01]]
        } else {
            [[c00, c10, c01], [c10, c11, c01]]
        }
    } else if y.checked_rem_euclid(2 * h).unwrap_or(0) == 0 {
        let (e0, e1) = ((x - h, y), (x + h, y));
        [[e0, e1, (x, y + h)], [e1, e0, (x, y - h)]]
    } else {
        let (e0, e1) = ((x, y - h), (x, y + h));
        [[e0, e1, (x - h, y)], [e1, e0, (x + h, y)]]
    }
}

/// Largest `|d - plane(d)|` of the tiled detail map over the triangles of one detail level at
/// every position of one `px x py` period.
fn level_detail_error<D: Sample>(
    d: &Heightfield<'_, D>,
    px: i64,
    py: i64,
    h: i64,
    centre: bool,
) -> f64 {
    let (dw, dh) = (i64::from(d.width()).max(1), i64::from(d.height()).max(1));
    let f = |x: i64, y: i64| {
        let (xm, ym) = (
            x.checked_rem_euclid(dw).unwrap_or(0),
            y.checked_rem_euclid(dh).unwrap_or(0),
        );
        f64::from(d.z(xm as u32, ym as u32))
    };
    let h = h.max(1);
    let mut worst = 0.0f64;
    // Vertex rows and columns: centres at odd multiples of h in both; edges at (odd, even) and
    // (even, odd) multiples.
    let kinds: &[(i64, i64)] = if centre { &[(h, h)] } else { &[(h, 0), (0, h)] };
    for &(x0, y0) in kinds {
        // Loops: (py / 2h) x (px / 2h) vertices (h >= 1).
        let mut y = y0;
        while y < py {
            let mut x = x0;
            while x < px {
                for t in diamond_at(x, y, h, centre) {
                    worst = worst.max(triangle_error_fn(t, &f));
                }
                x += 2 * h;
            }
            y += 2 * h;
        }
    }
    worst
}

/// `max |f - plane(f)|` over the grid points of triangle `t`.
fn triangle_error_fn(t: [(i64, i64); 3], f: &impl Fn(i64, i64) -> f64) -> f64 {
    let z = [f(t[0].0, t[0].1), f(t[1].0, t[1].1), f(t[2].0, t[2].1)];
    let Some(plane) = Plane::new([
        (t[0].0, t[0].1, z[0]),
        (t[1].0, t[1].1, z[1]),
        (t[2].0, t[2].1, z[2]),
    ]) else {
        return 0.0;
    };
    let mut e = 0.0f64;
    for_each_span(t[0], t[1], t[2], |y, lo, hi| {
        let mut row = 0.0f64;
        for x in lo..=hi {
            let v = (f(x, y) - plane.at(x, y)).abs();
            row = if v > row { v } else { row };
        }
        if row > e {
            e = row;
        }
    });
    e
}

/// Length of the `u64` scratch that numbers up to `max_vertices` distinct vertices: an
/// open-addressing table of `2^m >= 2 max_vertices` slots (load at most 1/2), two words each.
///
/// ```
/// assert_eq!(relief_core::refine::detail_scratch_len(100), 512);
/// ```
#[must_use]
pub const fn detail_scratch_len(max_vertices: usize) -> usize {
    let want = max_vertices.saturating_mul(2);
    let slots = match want.checked_next_power_of_two() {
        Some(s) => s,
        None => 1usize << (usize::BITS - 1),
    };
    let slots = if slots < 2 { 2 } else { slots };
    slots.saturating_mul(2)
}

/// Sizes of one frame of detail refinement, with triangles counted per level.
///
/// ```
/// use relief_core::refine::DetailCounts;
/// let mut c = DetailCounts::default();
/// c.base_levels = 4;
/// c.by_level[3] = 2; // a base triangle
/// c.by_level[6] = 5; // a detail triangle
/// assert_eq!((c.base_triangles(), c.detail_triangles(), c.finest_level()), (2, 5, Some(6)));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DetailCounts {
    /// Distinct vertices referenced by the triangles.
    pub vertices: usize,
    /// Triangles.
    pub triangles: usize,
    /// Triangles by the level of the vertex that would split them: `by_level[l]` for `l` up to
    /// the virtual grid's level count (`levels`: single composed cells' halves). Levels up to
    /// `base_levels` are base triangles (corners on base samples), deeper ones detail triangles.
    pub by_level: [usize; LEVELS],
    /// Levels of the base hierarchy.
    pub base_levels: u32,
    /// Levels of the virtual grid (`base_levels + 2 d`).
    pub levels: u32,
}

impl Default for DetailCounts {
    fn default() -> Self {
        DetailCounts {
            vertices: 0,
            triangles: 0,
            by_level: [0; LEVELS],
            base_levels: 0,
            levels: 0,
        }
    }
}

impl DetailCounts {
    /// Triangles whose corners are all base samples (level `<= base_levels`).
    ///
    /// ```
    /// let mut c = relief_core::refine::DetailCounts::default();
    /// c.base_levels = 2;
    /// c.by_level[2] = 7;
    /// assert_eq!(c.base_triangles(), 7);
    /// ```
    #[must_use]
    pub fn base_triangles(&self) -> usize {
        self.by_level
            .iter()
            .take(self.base_levels as usize + 1)
            .sum()
    }

    /// Triangles below the base grid (level `> base_levels`).
    ///
    /// ```
    /// let mut c = relief_core::refine::DetailCounts::default();
    /// c.base_levels = 2;
    /// c.by_level[3] = 7;
    /// assert_eq!(c.detail_triangles(), 7);
    /// ```
    #[must_use]
    pub fn detail_triangles(&self) -> usize {
        self.by_level
            .iter()
            .skip(self.base_levels as usize + 1)
            .sum()
    }

    /// The deepest level with a triangle (`levels` means full composed resolution).
    ///
    /// ```
    /// let c = relief_core::refine::DetailCounts::default();
    /// assert_eq!(c.finest_level(), None);
    /// ```
    #[must_use]
    pub fn finest_level(&self) -> Option<u32> {
        self.by_level.iter().rposition(|&n| n > 0).map(|l| l as u32)
    }
}

/// Per-frame view data in local coordinates (`z` without the base's `z_offset`), `f64`.
#[derive(Debug, Clone, Copy)]
struct DView {
    eye: [f64; 3],
    kappa: f64,
    tau: f64,
    kappa_over_tau: f64,
    planes: [[f64; 4]; 6],
    /// Per plane: horizontal norm, and the lowest and highest `n.z z` over the composed range.
    cyl: [[f64; 3]; 6],
    mask: u8,
    lazy_from: u32,
    /// Composed local height range (base range + detail range).
    z_lo: f64,
    z_hi: f64,
    /// Base local height range (the hierarchy's circles).
    bz_lo: f64,
    bz_hi: f64,
    /// Vertical slack of the composed surface around the base's bounding spheres.
    slack_lo: f64,
    slack_hi: f64,
}

/// Per-vertex base part of [`DetailBounds::measure_local`], per virtual level.
#[derive(Debug, Clone, Copy)]
struct Local<'a> {
    /// Nested twist per base vertex, then twist per base cell.
    buf: &'a [f32],
    /// Base vertices (offset of the cell twists).
    n: usize,
    cells_w: i64,
    cells_h: i64,
    /// Chebyshev reach of a vertex's descendants (virtual units).
    reach: [i64; LEVELS],
    /// Nested unit-twist error and detail part of the level.
    tau: [f64; LEVELS],
    delta: [f64; LEVELS],
    /// The level's bound with the largest twist (an upper bound of every vertex's).
    hi: [f64; LEVELS],
    /// Absolute rounding margin.
    abs: f64,
}

/// View-dependent refinement of a [`Composed`] surface through base and detail levels (see the
/// module documentation). Stateless: every call refines from scratch.
///
/// ```
/// use relief_core::refine::{preprocess_compact, DetailBounds, DetailRefiner, View};
/// use relief_core::{Camera, Composed, Error, Heightfield};
/// use glam::Vec3;
/// let base = Heightfield::new(&[0.0f32; 25], 5, 5).unwrap();
/// let detail = Heightfield::new(&[0.0f32, 1.0, 1.0, 0.0], 2, 2).unwrap();
/// let c = Composed::new(base, detail, 4).unwrap();
/// let mut e = [0u16; 25];
/// let h = preprocess_compact(c.base(), &mut e).unwrap();
/// let cam = Camera::new(Vec3::new(0.5, 0.5, 3.0), Vec3::new(2.0, 2.0, 0.0), 60.0, 64, 64).unwrap();
/// let v = View::new(&cam, 0.5).unwrap();
/// let dr = DetailRefiner::new(&h, &c, &DetailBounds::measure(&c), &v).unwrap();
/// assert_eq!((dr.grid().width(), dr.grid().height()), (17, 17));
/// let mut scratch = [0u64; 8];
/// assert!(matches!(dr.count(&mut scratch), Err(Error::BufferTooSmall { .. })));
/// ```
#[derive(Debug, Clone, Copy)]
pub struct DetailRefiner<'r, 'd, B: Sample, D: Sample> {
    h: &'r Hierarchy<'r>,
    c: &'r Composed<'d, B, D>,
    g: RefineGrid,
    base_w: usize,
    base_levels: u32,
    shift: u32,
    v: DView,
    /// Circle-test error per virtual level.
    ec: [f64; LEVELS],
    /// [`DetailBounds::measure_local`]: per-vertex base part (see [`Local`]).
    local: Option<Local<'r>>,
    /// Circle radius per virtual level (world units, rounded up).
    radius: [f64; LEVELS],
    dxv: f64,
    dyv: f64,
    z_offset: f32,
}

trait DSink {
    fn tri(&mut self, a: (i64, i64), b: (i64, i64), c: (i64, i64), level: u32);
}

impl<'r, 'd, B: Sample, D: Sample> DetailRefiner<'r, 'd, B, D> {
    /// A detail refiner for `composed`, whose base `hierarchy` was preprocessed from
    /// ([`Error::LengthMismatch`] if the sizes differ) with `bounds` from the same composition
    /// ([`Error::InvalidFactor`] if its factor differs). The view's culling, near/far planes and
    /// lazy levels apply as in [`Refiner`](super::Refiner), counted on the virtual grid's levels
    /// (base volumes widened by the detail range and twist; detail levels by their cylinders).
    /// [`Error::SizeOverflow`] if the composed grid's enclosing square exceeds
    /// `2^30` cells.
    ///
    /// ```
    /// use relief_core::refine::{preprocess_compact, DetailBounds, DetailRefiner, View};
    /// use relief_core::{Camera, Composed, Error, Heightfield};
    /// use glam::Vec3;
    /// let base = Heightfield::new(&[0.0f32; 9], 3, 3).unwrap();
    /// let c = Composed::new(base, base, 2).unwrap();
    /// let other = Heightfield::new(&[0.0f32; 4], 2, 2).unwrap();
    /// let mut e = [0u16; 4];
    /// let h = preprocess_compact(&other, &mut e).unwrap();
    /// let cam = Camera::new(Vec3::new(0.0, 0.0, 3.0), Vec3::new(1.0, 1.0, 0.0), 60.0, 8, 8).unwrap();
    /// let v = View::new(&cam, 1.0).unwrap();
    /// let b = DetailBounds::measure(&c);
    /// assert!(matches!(DetailRefiner::new(&h, &c, &b, &v), Err(Error::LengthMismatch { .. })));
    /// ```
    pub fn new(
        hierarchy: &'r Hierarchy<'r>,
        composed: &'r Composed<'d, B, D>,
        bounds: &DetailBounds<'r>,
        view: &View,
    ) -> Result<Self, Error> {
        let bg = hierarchy.grid();
        let base = composed.base();
        if base.width() != bg.width() || base.height() != bg.height() {
            return Err(Error::LengthMismatch {
                expected: bg.len(),
                actual: base.width() as usize * base.height() as usize,
            });
        }
        let shift = composed.factor().trailing_zeros();
        if bounds.shift != shift {
            return Err(Error::InvalidFactor {
                factor: 1u32.checked_shl(bounds.shift).unwrap_or(0),
            });
        }
        let g = RefineGrid::new(composed.width(), composed.height())?;
        let base_levels = bg.levels();
        let (camera, near, far, culling, lazy_levels) = view.settings();
        let s = hierarchy.scale();
        let off = f64::from(s.z_offset);
        let far_given = far.is_some();
        let planes4 = camera.frustum_planes(near, far.unwrap_or(near * 1e6))?;
        let mut planes = [[0.0f64; 4]; 6];
        for (o, p) in planes.iter_mut().zip(planes4.iter()) {
            *o = [
                f64::from(p.x),
                f64::from(p.y),
                f64::from(p.z),
                f64::from(p.w) + f64::from(p.z) * off,
            ];
        }
        let mask = if !culling {
            0
        } else if far_given {
            0b11_1111
        } else {
            0b01_1111
        };
        let (bz_lo, bz_hi) = hierarchy.z_range();
        let (d_lo, d_hi) = (f64::from(bounds.d_lo), f64::from(bounds.d_hi));
        let t4 = f64::from(bounds.twist) * 0.25;
        let tau = f64::from(view.pixel_error());
        let kappa = f64::from(camera.kappa());
        let e = camera.eye;
        let (cz_lo, cz_hi) = (f64::from(bz_lo) + d_lo, f64::from(bz_hi) + d_hi);
        let mut cyl = [[0.0f64; 3]; 6];
        for (q, p) in cyl.iter_mut().zip(planes.iter()) {
            let (a, b) = (p[2] * cz_lo, p[2] * cz_hi);
            *q = [libm::sqrt(p[0] * p[0] + p[1] * p[1]), a.min(b), a.max(b)];
        }
        let v = DView {
            eye: [f64::from(e.x), f64::from(e.y), f64::from(e.z) - off],
            kappa,
            tau,
            kappa_over_tau: kappa / tau,
            planes,
            cyl,
            mask,
            lazy_from: g.levels().saturating_sub(lazy_levels),
            z_lo: f64::from(bz_lo) + d_lo,
            z_hi: f64::from(bz_hi) + d_hi,
            bz_lo: f64::from(bz_lo),
            bz_hi: f64::from(bz_hi),
            slack_lo: d_lo.min(0.0) - t4,
            slack_hi: d_hi.max(0.0) + t4,
        };
        let cs = composed.scale();
        let (dxv, dyv) = (f64::from(cs.dx), f64::from(cs.dy));
        // Level-only circles of the virtual grid: l_0 = side/2 cells, each level 1/sqrt 2 less.
        let mut radius = [f64::INFINITY; LEVELS];
        let q = core::f64::consts::FRAC_1_SQRT_2;
        let mut li = f64::from(g.side()) * 0.5 * dxv.max(dyv);
        for r in radius.iter_mut().take(g.levels() as usize) {
            *r = f64::from(round_up(li / (1.0 - q) * (1.0 + CIRCLE_MARGIN)));
            li *= q;
        }
        let mut ec = [0.0f64; LEVELS];
        let top = f64::from(bounds.error(0).unwrap_or(0.0));
        for (l, slot) in ec.iter_mut().enumerate().take(g.levels() as usize) {
            let l = l as u32;
            *slot = if l < base_levels {
                top
            } else {
                f64::from(bounds.error(l - base_levels).unwrap_or(0.0))
            };
        }
        let local = match bounds.local {
            Some(buf) if bounds.shift > 0 => {
                need(local_bounds_len(bg.width(), bg.height()), buf.len())?;
                let mut l = Local {
                    buf,
                    n: bg.len(),
                    cells_w: i64::from(bg.width()) - 1,
                    cells_h: i64::from(bg.height()) - 1,
                    reach: [0; LEVELS],
                    tau: [0.0; LEVELS],
                    delta: [0.0; LEVELS],
                    hi: [0.0; LEVELS],
                    abs: f64::from(bounds.max_abs) * MARGIN,
                };
                let twist = f64::from(bounds.twist);
                for lv in 0..g.levels().min(LEVELS as u32) {
                    let j = lv.saturating_sub(base_levels) as usize;
                    let k = lv as usize;
                    if let (Some(r), Some(t), Some(d), Some(hi)) = (
                        l.reach.get_mut(k),
                        l.tau.get_mut(k),
                        l.delta.get_mut(k),
                        l.hi.get_mut(k),
                    ) {
                        *r = reach(u64::from(g.side()), g.levels(), lv);
                        *t = f64::from(bounds.tau.get(j).copied().unwrap_or(0.0));
                        *d = f64::from(bounds.delta.get(j).copied().unwrap_or(0.0));
                        *hi = (twist * *t + *d) * (1.0 + MARGIN) + l.abs;
                    }
                }
                Some(l)
            }
            _ => None,
        };
        Ok(DetailRefiner {
            h: hierarchy,
            c: composed,
            g,
            base_w: bg.width() as usize,
            base_levels,
            shift,
            v,
            ec,
            local,
            radius,
            dxv,
            dyv,
            z_offset: cs.z_offset,
        })
    }

    /// The virtual (composed) grid and its hierarchy: effective resolution
    /// `grid().width() x grid().height()`, `grid().levels()` levels.
    ///
    /// ```
    /// # use relief_core::refine::{preprocess_compact, DetailBounds, DetailRefiner, View};
    /// # use relief_core::{Camera, Composed, Heightfield};
    /// # use glam::Vec3;
    /// let base = Heightfield::new(&[0.0f32; 9], 3, 3).unwrap();
    /// let c = Composed::new(base, base, 64).unwrap();
    /// let mut e = [0u16; 9];
    /// let h = preprocess_compact(c.base(), &mut e).unwrap();
    /// # let cam = Camera::new(Vec3::new(0.0, 0.0, 3.0), Vec3::new(1.0, 1.0, 0.0), 60.0, 8, 8).unwrap();
    /// let v = View::new(&cam, 1.0).unwrap();
    /// let dr = DetailRefiner::new(&h, &c, &DetailBounds::measure(&c), &v).unwrap();
    /// assert_eq!((dr.grid().width(), dr.grid().levels(), dr.base_levels()), (129, 14, 2));
    /// ```
    #[must_use]
    pub fn grid(&self) -> RefineGrid {
        self.g
    }

    /// Levels of the base hierarchy (the virtual grid's first levels).
    ///
    /// ```
    /// # use relief_core::refine::{preprocess_compact, DetailBounds, DetailRefiner, View};
    /// # use relief_core::{Camera, Composed, Heightfield};
    /// # use glam::Vec3;
    /// # let base = Heightfield::new(&[0.0f32; 25], 5, 5).unwrap();
    /// # let c = Composed::new(base, base, 2).unwrap();
    /// # let mut e = [0u16; 25];
    /// # let h = preprocess_compact(c.base(), &mut e).unwrap();
    /// # let cam = Camera::new(Vec3::new(0.0, 0.0, 3.0), Vec3::new(1.0, 1.0, 0.0), 60.0, 8, 8).unwrap();
    /// # let v = View::new(&cam, 1.0).unwrap();
    /// let dr = DetailRefiner::new(&h, &c, &DetailBounds::measure(&c), &v).unwrap();
    /// assert_eq!(dr.base_levels(), 4);
    /// ```
    #[must_use]
    pub fn base_levels(&self) -> u32 {
        self.base_levels
    }

    /// Triangles of this frame, by one traversal without any buffer (size the scratch of
    /// [`Self::count`] from it: a mesh of `t` triangles has at most `3 t` vertices).
    ///
    /// ```
    /// # use relief_core::refine::{preprocess_compact, DetailBounds, DetailRefiner, View};
    /// # use relief_core::{Camera, Composed, Heightfield};
    /// # use glam::Vec3;
    /// let base = Heightfield::new(&[0.0f32; 9], 3, 3).unwrap();
    /// let c = Composed::new(base, base, 4).unwrap();
    /// let mut e = [0u16; 9];
    /// let h = preprocess_compact(c.base(), &mut e).unwrap();
    /// let cam = Camera::new(Vec3::new(1.0, 1.0, 50.0), Vec3::new(1.0, 1.1, 0.0), 60.0, 8, 8).unwrap();
    /// let dr = DetailRefiner::new(&h, &c, &DetailBounds::measure(&c), &View::new(&cam, 1.0).unwrap()).unwrap();
    /// assert_eq!(dr.triangle_count(), 2); // all flat: the two root triangles
    /// ```
    #[must_use]
    pub fn triangle_count(&self) -> usize {
        struct Count(usize);
        impl DSink for Count {
            fn tri(&mut self, _: (i64, i64), _: (i64, i64), _: (i64, i64), _: u32) {
                self.0 += 1;
            }
        }
        let mut s = Count(0);
        self.walk_all(&mut s);
        s.0
    }

    /// Count-only mode: exact vertex and triangle counts (per level too), numbering vertices in
    /// `scratch` ([`detail_scratch_len`] of the vertex count, or of `3 *` [`Self::triangle_count`]).
    /// [`Error::BufferTooSmall`] (with a sufficient length) if the table fills.
    ///
    /// ```
    /// # use relief_core::refine::{detail_scratch_len, preprocess_compact, DetailBounds, DetailRefiner, View};
    /// # use relief_core::{Camera, Composed, Heightfield};
    /// # use glam::Vec3;
    /// let base = Heightfield::new(&[0.0f32; 9], 3, 3).unwrap();
    /// let c = Composed::new(base, base, 4).unwrap();
    /// let mut e = [0u16; 9];
    /// let h = preprocess_compact(c.base(), &mut e).unwrap();
    /// let cam = Camera::new(Vec3::new(1.0, 1.0, 50.0), Vec3::new(1.0, 1.1, 0.0), 60.0, 8, 8).unwrap();
    /// let dr = DetailRefiner::new(&h, &c, &DetailBounds::measure(&c), &View::new(&cam, 1.0).unwrap()).unwrap();
    /// let n = dr.count(&mut vec![0; detail_scratch_len(6)]).unwrap();
    /// assert_eq!((n.vertices, n.triangles, n.base_triangles()), (4, 2, 2));
    /// ```
    pub fn count(&self, scratch: &mut [u64]) -> Result<DetailCounts, Error> {
        self.run(scratch, &mut [], &mut [])
            .and_then(|(c, full)| self.table_check(c, full, scratch.len()))
    }

    /// The indexed triangle list: world positions of composed samples into `vertices` (in
    /// first-use order) and counter-clockwise index triples into `triangles`.
    /// [`Error::BufferTooSmall`] if `scratch`, `vertices` or `triangles` is too small (contents
    /// then unspecified).
    ///
    /// ```
    /// # use relief_core::refine::{detail_scratch_len, preprocess, DetailBounds, DetailRefiner, View};
    /// # use relief_core::{Camera, Composed, Error, Heightfield, Terrain};
    /// # use glam::Vec3;
    /// let base = Heightfield::new(&[0.0f32, 1.0, 2.0, 3.0], 2, 2).unwrap();
    /// let detail = Heightfield::new(&[0.0f32, 0.5, 0.5, 0.0], 2, 2).unwrap();
    /// let c = Composed::new(base, detail, 2).unwrap();
    /// let (mut e, mut r) = ([0.0; 4], [0.0; 4]);
    /// let h = preprocess(c.base(), &mut e, &mut r).unwrap();
    /// let cam = Camera::new(Vec3::new(0.5, 0.5, 4.0), Vec3::new(0.5, 0.6, 0.0), 60.0, 64, 64).unwrap();
    /// let dr = DetailRefiner::new(&h, &c, &DetailBounds::measure(&c), &View::new(&cam, 0.1).unwrap()).unwrap();
    /// let mut s = vec![0; detail_scratch_len(9)];
    /// let (mut v, mut t) = (vec![[0.0f32; 3]; 9], vec![[0u32; 3]; 8]);
    /// let n = dr.triangles(&mut s, &mut v, &mut t).unwrap();
    /// assert_eq!((n.vertices, n.triangles), (9, 8)); // every composed sample
    /// for p in &v {
    ///     let (x, y) = ((p[0] * 2.0) as u32, (p[1] * 2.0) as u32);
    ///     assert_eq!(p[2], c.z(x, y)); // on the composed surface
    /// }
    /// assert!(matches!(dr.triangles(&mut s, &mut v, &mut t[..7]), Err(Error::BufferTooSmall { .. })));
    /// ```
    pub fn triangles(
        &self,
        scratch: &mut [u64],
        vertices: &mut [[f32; 3]],
        triangles: &mut [[u32; 3]],
    ) -> Result<DetailCounts, Error> {
        let (c, full) = self.run(scratch, vertices, triangles)?;
        let c = self.table_check(c, full, scratch.len())?;
        need(c.vertices, vertices.len())?;
        need(c.triangles, triangles.len())?;
        Ok(c)
    }

    fn table_check(
        &self,
        c: DetailCounts,
        full: bool,
        actual: usize,
    ) -> Result<DetailCounts, Error> {
        if full {
            let needed = detail_scratch_len(c.triangles.saturating_mul(3).max(c.vertices + 1));
            return Err(Error::BufferTooSmall {
                needed: needed.max(actual.saturating_add(1)),
                actual,
            });
        }
        Ok(c)
    }

    fn run(
        &self,
        scratch: &mut [u64],
        vertices: &mut [[f32; 3]],
        triangles: &mut [[u32; 3]],
    ) -> Result<(DetailCounts, bool), Error> {
        // Largest power-of-two slot count that fits.
        let avail = scratch.len() / 2;
        let slots = if avail < 2 {
            0
        } else {
            1usize << (usize::BITS - 1 - avail.leading_zeros())
        };
        let table = scratch.get_mut(..2 * slots).unwrap_or(&mut []);
        table.fill(0);
        let mut sink = MeshSink {
            table,
            slots,
            hash_shift: 64 - slots.trailing_zeros(),
            full: slots == 0,
            verts: vertices,
            tris: triangles,
            nv: 0,
            nt: 0,
            by_level: [0; LEVELS],
            c: self.c,
            dxv: self.dxv,
            dyv: self.dyv,
            z_offset: self.z_offset,
        };
        self.walk_all(&mut sink);
        Ok((
            DetailCounts {
                vertices: sink.nv,
                triangles: sink.nt,
                by_level: sink.by_level,
                base_levels: self.base_levels,
                levels: self.g.levels(),
            },
            sink.full,
        ))
    }

    fn walk_all<S: DSink>(&self, sink: &mut S) {
        let n = i64::from(self.g.side());
        let mask = self.v.mask;
        self.walk(sink, (n, n), (0, 0), (n, 0), mask, 0);
        self.walk(sink, (0, 0), (n, n), (0, n), mask, 0);
    }

    /// Triangle `(l, r, a)`, counter-clockwise, hypotenuse `l-r`, split vertex at `level`.
    /// Recursion depth at most `levels() <= 60`.
    fn walk<S: DSink>(
        &self,
        sink: &mut S,
        l: (i64, i64),
        r: (i64, i64),
        a: (i64, i64),
        planes: u8,
        level: u32,
    ) {
        let class = self.g.classify([l, r, a]);
        if class == Class::Outside {
            return;
        }
        if level >= self.g.levels() {
            sink.tri(l, r, a, level);
            return;
        }
        let m = ((l.0 + r.0) / 2, (l.1 + r.1) / 2);
        let d = if class == Class::Straddle {
            Decision::Split(planes)
        } else {
            self.decide(m, planes, level)
        };
        match d {
            Decision::Split(p) => {
                self.walk(sink, a, l, m, p, level + 1);
                self.walk(sink, r, a, m, p, level + 1);
            }
            Decision::Keep => sink.tri(l, r, a, level),
            Decision::Cull => {}
        }
    }

    /// Whether in-domain vertex `m` (virtual coordinates) at `level` is refined, culling off
    /// (for tests of nesting).
    #[cfg(test)]
    pub(crate) fn active(&self, m: (i64, i64), level: u32) -> bool {
        matches!(self.decide(m, 0, level), Decision::Split(_))
    }

    /// The per-vertex decision.
    #[inline(always)]
    fn decide(&self, m: (i64, i64), planes: u8, level: u32) -> Decision {
        if level >= self.base_levels {
            let mut planes = if level == self.base_levels {
                self.v.mask
            } else {
                planes
            };
            if planes != 0 && level < self.v.lazy_from {
                match self.cull_cylinder(m, level, planes) {
                    Some(p) => planes = p,
                    None => return Decision::Cull,
                }
            }
            return if self.circle_active(m, level) {
                Decision::Split(planes)
            } else {
                Decision::Keep
            };
        }
        // A base vertex: virtual coordinates are multiples of the factor.
        let (bx, by) = (m.0 >> self.shift, m.1 >> self.shift);
        let i = by as usize * self.base_w + bx as usize;
        let e = self.h.err_at(i);
        if e == f32::INFINITY {
            return Decision::Split(planes);
        }
        let z = f64::from(self.c.base().local_z(bx as u32, by as u32));
        let mut planes = planes;
        if planes != 0 && level < self.v.lazy_from {
            match self.cull((bx, by), z, i, level, planes) {
                Some(p) => planes = p,
                None => return Decision::Cull,
            }
        }
        if self.base_active(f64::from(e), (bx, by), z, i, level) || self.circle_active(m, level) {
            Decision::Split(planes)
        } else {
            Decision::Keep
        }
    }

    /// SOAR's test on the base hierarchy, as [`Refiner`](super::Refiner) makes it.
    #[inline(always)]
    fn base_active(&self, e: f64, b: (i64, i64), z: f64, i: usize, level: u32) -> bool {
        let v = &self.v;
        let s = self.h.scale();
        let (dx, dy) = (
            v.eye[0] - b.0 as f64 * f64::from(s.dx),
            v.eye[1] - b.1 as f64 * f64::from(s.dy),
        );
        let r = f64::from(self.h.radius_at(i, level));
        if self.h.spheres() {
            if v.tau > 0.0 {
                let dz = v.eye[2] - z;
                let reach = e * v.kappa_over_tau + r;
                e > 0.0 && reach * reach > dx * dx + dy * dy + dz * dz
            } else {
                e > 0.0
            }
        } else {
            let dh = (libm::sqrt(dx * dx + dy * dy) - r).max(0.0);
            let dz = (v.bz_lo - v.eye[2]).max(v.eye[2] - v.bz_hi).max(0.0);
            e * v.kappa > v.tau * libm::sqrt(dh * dh + dz * dz)
        }
    }

    /// Seed 004's horizontal projection: the level's error from the level's circle, extended
    /// over the composed height range.
    #[inline(always)]
    fn circle_active(&self, m: (i64, i64), level: u32) -> bool {
        let l = level as usize;
        let e = match &self.local {
            None => self.ec.get(l).copied().unwrap_or(0.0),
            Some(loc) => loc.hi.get(l).copied().unwrap_or(0.0),
        };
        if e <= 0.0 {
            return false;
        }
        let v = &self.v;
        let r = self.radius.get(l).copied().unwrap_or(f64::INFINITY);
        let (dx, dy) = (
            v.eye[0] - m.0 as f64 * self.dxv,
            v.eye[1] - m.1 as f64 * self.dyv,
        );
        let dh = (libm::sqrt(dx * dx + dy * dy) - r).max(0.0);
        let dz = (v.z_lo - v.eye[2]).max(v.eye[2] - v.z_hi).max(0.0);
        let d = libm::sqrt(dh * dh + dz * dz);
        if e * v.kappa <= v.tau * d {
            return false;
        }
        match &self.local {
            None => true,
            // The upper bound passed. The bound without any twist is a lower bound: if it passes
            // too, no cell needs reading; otherwise the vertex's own bound decides.
            Some(loc) => {
                let lo = loc.delta.get(l).copied().unwrap_or(0.0) * (1.0 + MARGIN) + loc.abs;
                lo * v.kappa > v.tau * d || self.local_error(loc, m, level) * v.kappa > v.tau * d
            }
        }
    }

    /// [`DetailBounds::measure_local`]'s bound at vertex `m` (virtual coordinates): the nested
    /// twist of a base vertex, or the largest cell twist within a detail vertex's reach, times
    /// the level's unit-twist error, plus the detail part and the rounding margin. Monotone in
    /// each factor, so nested. Loops: at most `(2 reach / K + 2)^2 <= 25` cells.
    fn local_error(&self, loc: &Local<'_>, m: (i64, i64), level: u32) -> f64 {
        let l = level as usize;
        let t = if level < self.base_levels {
            let i = (m.1 >> self.shift) as usize * self.base_w + (m.0 >> self.shift) as usize;
            loc.buf.get(i).copied().unwrap_or(f32::INFINITY)
        } else {
            let r = loc.reach.get(l).copied().unwrap_or(0);
            let mut t = 0.0f32;
            let xs = cell_span(m.0 - r, m.0 + r, self.shift, loc.cells_w);
            let ys = cell_span(m.1 - r, m.1 + r, self.shift, loc.cells_h);
            if let (Some((xl, xh)), Some((yl, yh))) = (xs, ys) {
                for cy in yl..=yh {
                    for cx in xl..=xh {
                        let k = loc.n + (cy * loc.cells_w + cx) as usize;
                        t = t.max(loc.buf.get(k).copied().unwrap_or(f32::INFINITY));
                    }
                }
            }
            t
        };
        let tau = loc.tau.get(l).copied().unwrap_or(0.0);
        let delta = loc.delta.get(l).copied().unwrap_or(0.0);
        (f64::from(t) * tau + delta) * (1.0 + MARGIN) + loc.abs
    }

    /// The detail error the circle test uses at vertex `m` (tests of the bounds).
    #[cfg(test)]
    pub(crate) fn circle_error(&self, m: (i64, i64), level: u32) -> f64 {
        match &self.local {
            None => self.ec.get(level as usize).copied().unwrap_or(0.0),
            Some(loc) => self.local_error(loc, m, level),
        }
    }

    /// Tests a detail vertex's cylinder (its level circle over the composed height range, which
    /// holds its triangles and all its descendants) against the planes in `planes`: `None` if
    /// outside one, else the planes it still crosses. Cylinders are nested, so a plane a parent's
    /// cylinder lies inside of can never put a child outside: the answer does not depend on the
    /// path (the first detail level starts from every plane, base volumes not being nested with
    /// cylinders).
    #[inline(always)]
    fn cull_cylinder(&self, m: (i64, i64), level: u32, planes: u8) -> Option<u8> {
        let v = &self.v;
        let r = self
            .radius
            .get(level as usize)
            .copied()
            .unwrap_or(f64::INFINITY);
        let (px, py) = (m.0 as f64 * self.dxv, m.1 as f64 * self.dyv);
        let mut out = planes;
        for (k, (p, q)) in v.planes.iter().zip(v.cyl.iter()).enumerate() {
            if planes & (1 << k) == 0 {
                continue;
            }
            let c = p[0] * px + p[1] * py + p[3];
            // q = (horizontal norm, lowest and highest z term over the height range).
            if c + r * q[0] + q[2] < 0.0 {
                return None;
            }
            if c - r * q[0] + q[1] > 0.0 {
                out &= !(1 << k);
            }
        }
        Some(out)
    }

    /// Tests a base vertex's volume, widened to hold the composed surface, against the active
    /// planes: `None` if outside one, else the planes it still crosses.
    #[inline(always)]
    fn cull(&self, b: (i64, i64), z: f64, i: usize, level: u32, planes: u8) -> Option<u8> {
        let v = &self.v;
        let s = self.h.scale();
        let (px, py) = (b.0 as f64 * f64::from(s.dx), b.1 as f64 * f64::from(s.dy));
        let r = f64::from(self.h.radius_at(i, level));
        let mut out = planes;
        for (k, p) in v.planes.iter().enumerate() {
            if planes & (1 << k) == 0 {
                continue;
            }
            let (lo, hi) = if self.h.spheres() {
                // The sphere holds the base samples of the diamond; the composed surface lies
                // within it shifted vertically by the detail range and the bilinear twist.
                let c = p[0] * px + p[1] * py + p[2] * z + p[3];
                let (za, zb) = (p[2] * v.slack_lo, p[2] * v.slack_hi);
                (c - r + za.min(zb), c + r + za.max(zb))
            } else {
                let hyp = libm::sqrt(p[0] * p[0] + p[1] * p[1]);
                let c = p[0] * px + p[1] * py + p[3];
                let (za, zb) = (p[2] * v.z_lo, p[2] * v.z_hi);
                (c - r * hyp + za.min(zb), c + r * hyp + za.max(zb))
            };
            if hi < 0.0 {
                return None;
            }
            if lo > 0.0 {
                out &= !(1 << k);
            }
        }
        Some(out)
    }
}

const GOLDEN: u64 = 0x9E37_79B9_7F4A_7C15;

/// Numbers vertices through the open-addressing table, writes positions and triangles while
/// there is room, and counts everything.
struct MeshSink<'s, 'o, 'r, 'd, B: Sample, D: Sample> {
    table: &'s mut [u64],
    slots: usize,
    hash_shift: u32,
    full: bool,
    verts: &'o mut [[f32; 3]],
    tris: &'o mut [[u32; 3]],
    nv: usize,
    nt: usize,
    by_level: [usize; LEVELS],
    c: &'r Composed<'d, B, D>,
    dxv: f64,
    dyv: f64,
    z_offset: f32,
}

impl<B: Sample, D: Sample> MeshSink<'_, '_, '_, '_, B, D> {
    #[inline(always)]
    fn index(&mut self, p: (i64, i64)) -> u32 {
        if self.full {
            return 0;
        }
        let key = (((p.0 as u64) << 32) | (p.1 as u64 & 0xFFFF_FFFF)).wrapping_add(1);
        let mask = self.slots.wrapping_sub(1);
        let mut s = (key.wrapping_mul(GOLDEN).wrapping_shr(self.hash_shift) as usize) & mask;
        for _ in 0..self.slots {
            let k = self.table.get(2 * s).copied().unwrap_or(0);
            if k == key {
                return self.table.get(2 * s + 1).copied().unwrap_or(0) as u32;
            }
            if k == 0 {
                if self.nv >= self.slots / 2 {
                    self.full = true;
                    return 0;
                }
                let idx = self.nv;
                if let Some(slot) = self.table.get_mut(2 * s) {
                    *slot = key;
                }
                if let Some(slot) = self.table.get_mut(2 * s + 1) {
                    *slot = idx as u64;
                }
                if let Some(v) = self.verts.get_mut(idx) {
                    let (x, y) = (p.0 as u32, p.1 as u32);
                    *v = [
                        (p.0 as f64 * self.dxv) as f32,
                        (p.1 as f64 * self.dyv) as f32,
                        self.c.local_z(x, y) + self.z_offset,
                    ];
                }
                self.nv += 1;
                return idx as u32;
            }
            s = (s + 1) & mask;
        }
        self.full = true;
        0
    }
}

impl<B: Sample, D: Sample> DSink for MeshSink<'_, '_, '_, '_, B, D> {
    #[inline(always)]
    fn tri(&mut self, a: (i64, i64), b: (i64, i64), c: (i64, i64), level: u32) {
        let t = [self.index(a), self.index(b), self.index(c)];
        if let Some(o) = self.tris.get_mut(self.nt) {
            *o = t;
        }
        self.nt += 1;
        if let Some(n) = self.by_level.get_mut(level as usize) {
            *n += 1;
        }
    }
}

#[cfg(test)]
#[path = "detail_tests.rs"]
mod tests;
