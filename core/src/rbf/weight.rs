//! Truncated Gaussian radial basis functions on an adaptive grid (Cornel, Horváth, Waser 2022,
//! section 4): the weight of eq. 1, the per-cell influence sets (Figure 2) and the normalised
//! weighted sum of eq. 2.
//!
//! Distances are in grid units (sample spacing 1 on both axes); a cell's `c_i` is its size.

use super::grid::{AdaptiveGrid, Cell};
use crate::Error;
use glam::Vec2;

/// Truncation radius of the Gaussian in units of `sigma * c_i` (seed 002: 3.5).
///
/// ```
/// assert_eq!(relief_core::rbf::TRUNCATION, 3.5);
/// ```
pub const TRUNCATION: f32 = 3.5;

/// `exp(-3.5^2 / 2)`, the truncation remainder subtracted in eq. 1.
const REMAINDER: f32 = 0.002_187_491_1;

/// Smallest and largest `sigma` accepted.
const SIGMA_RANGE: (f32, f32) = (1e-3, 1e3);

/// The weight of eq. 1 for squared normalised distance `q = (|p_i - p| / c_i)^2`:
/// `exp(-q / (2 sigma^2)) - exp(-3.5^2 / 2)` when `q < (3.5 sigma)^2`, else 0; never negative.
///
/// ```
/// use relief_core::rbf::gaussian_weight;
/// let w0 = gaussian_weight(0.0, 1.0);
/// assert!((w0 - (1.0 - (-6.125f32).exp())).abs() < 1e-6);
/// assert_eq!(gaussian_weight(3.5 * 3.5, 1.0), 0.0);
/// assert!(gaussian_weight(3.4 * 3.4, 1.0) > 0.0);
/// assert_eq!(gaussian_weight(f32::NAN, 1.0), 0.0);
/// ```
#[must_use]
pub fn gaussian_weight(q: f32, sigma: f32) -> f32 {
    let s2 = sigma * sigma;
    let cut = TRUNCATION * TRUNCATION * s2;
    if q.is_nan() || q >= cut || q < 0.0 {
        return 0.0;
    }
    (libm::expf(-q / (2.0 * s2)) - REMAINDER).max(0.0)
}

/// Options of the RBF approximation. Default: `sigma = 1.0` (seed 002's choice).
///
/// ```
/// use relief_core::rbf::RbfOptions;
/// assert_eq!(RbfOptions::default().sigma, 1.0);
/// assert_eq!(RbfOptions::default().with_sigma(2.0).sigma, 2.0);
/// assert!(RbfOptions::default().with_sigma(0.0).validate().is_err());
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RbfOptions {
    /// Width of the Gaussian relative to the cell size (default 1.0); accepted in
    /// `[0.001, 1000]`.
    pub sigma: f32,
}

impl Default for RbfOptions {
    fn default() -> Self {
        RbfOptions { sigma: 1.0 }
    }
}

impl RbfOptions {
    /// Returns the options with `sigma` (default 1.0).
    ///
    /// ```
    /// assert_eq!(relief_core::rbf::RbfOptions::default().with_sigma(0.5).sigma, 0.5);
    /// ```
    #[must_use]
    pub fn with_sigma(mut self, sigma: f32) -> Self {
        self.sigma = sigma;
        self
    }

    /// Checks `sigma` is finite and in `[0.001, 1000]` ([`Error::InvalidParameter`]).
    ///
    /// ```
    /// use relief_core::{rbf::RbfOptions, Error};
    /// assert_eq!(
    ///     RbfOptions::default().with_sigma(-1.0).validate(),
    ///     Err(Error::InvalidParameter { name: "sigma", value: -1.0 })
    /// );
    /// ```
    pub fn validate(&self) -> Result<(), Error> {
        if self.sigma.is_finite() && (SIGMA_RANGE.0..=SIGMA_RANGE.1).contains(&self.sigma) {
            Ok(())
        } else {
            Err(Error::InvalidParameter {
                name: "sigma",
                value: self.sigma,
            })
        }
    }

    /// Radius of influence `3.5 sigma c` of a cell of size `c`, in grid units.
    ///
    /// ```
    /// assert_eq!(relief_core::rbf::RbfOptions::default().radius(4), 14.0);
    /// ```
    #[must_use]
    pub fn radius(&self, size: u32) -> f32 {
        TRUNCATION * self.sigma * size as f32
    }
}

/// Whether cell `i` may influence some point of cell `j`'s closed area: the distance from `i`'s
/// centre to `j`'s area is below `i`'s radius (with a relative slack of `1e-5` so rounding never
/// drops a cell; extra members only cost time, their weights are exact).
fn influences(i: &Cell, j: &Cell, options: &RbfOptions) -> bool {
    let r = options.radius(i.size);
    j.distance_squared_to_area(i.center()) <= r * r * (1.0 + 1e-5)
}

/// Visits every cell `j` whose area the disc of influence of cell `i` reaches, once each, in
/// row-major order of their first sample inside the disc's bounding window. Work: at most the
/// number of cell runs crossing the window's rows.
fn for_each_influenced(
    grid: &AdaptiveGrid<'_>,
    i: &Cell,
    options: &RbfOptions,
    mut f: impl FnMut(usize),
) {
    let c = i.center();
    let r = options.radius(i.size) + 0.5;
    let (wm, hm) = ((grid.width() - 1) as f32, (grid.height() - 1) as f32);
    let x0 = libm::ceilf(c.x - r).max(0.0).min(wm) as u32;
    let x1 = libm::floorf(c.x + r).max(0.0).min(wm) as u32;
    let y0 = libm::ceilf(c.y - r).max(0.0).min(hm) as u32;
    let y1 = libm::floorf(c.y + r).max(0.0).min(hm) as u32;
    let cells = grid.cells();
    for y in y0..=y1 {
        let mut x = x0;
        // Every step moves x past one cell, so at most x1 - x0 + 1 steps.
        while x <= x1 {
            let Some(jx) = grid.cell_at(x, y) else { break };
            let Some(j) = cells.get(jx) else { break };
            if j.x.max(x0) == x && j.y.max(y0) == y && influences(i, j, options) {
                f(jx);
            }
            x = j.x.saturating_add(j.size).max(x + 1);
        }
    }
}

/// Precomputed influence sets in compressed-row form, borrowed from the caller: the cells that
/// may influence any point of cell `j` are `entries[offsets[j]..offsets[j + 1]]`, in increasing
/// index order (seed 002 section 4: the sets depend only on the grid and `sigma`).
///
/// ```
/// use relief_core::rbf::{AdaptiveGrid, Cell, InfluenceSets, RbfOptions};
/// let cells = [Cell::new(0, 0, 1, 0.0), Cell::new(1, 0, 1, 1.0)];
/// let mut index = [0; 2];
/// let grid = AdaptiveGrid::new(2, 1, &cells, &mut index).unwrap();
/// let opts = RbfOptions::default();
/// let (mut offsets, mut entries) = ([0u32; 3], [0u32; 4]);
/// let sets = InfluenceSets::build(&grid, &opts, &mut offsets, &mut entries).unwrap();
/// assert_eq!(sets.of(0), &[0, 1]);
/// assert_eq!(sets.len(), 4);
/// ```
#[derive(Debug, Clone, Copy)]
pub struct InfluenceSets<'a> {
    offsets: &'a [u32],
    entries: &'a [u32],
}

impl<'a> InfluenceSets<'a> {
    /// Length of the `offsets` buffer [`InfluenceSets::build`] needs: cells + 1.
    ///
    /// ```
    /// # use relief_core::rbf::{AdaptiveGrid, Cell, InfluenceSets};
    /// let cells = [Cell::new(0, 0, 1, 0.0)];
    /// let mut index = [0; 1];
    /// let grid = AdaptiveGrid::new(1, 1, &cells, &mut index).unwrap();
    /// assert_eq!(InfluenceSets::offsets_len(&grid), 2);
    /// ```
    #[must_use]
    pub fn offsets_len(grid: &AdaptiveGrid<'_>) -> usize {
        grid.cells().len() + 1
    }

    /// Exact number of entries all influence sets hold together (the `entries` length
    /// [`InfluenceSets::build`] needs). Same work as a build.
    ///
    /// ```
    /// # use relief_core::rbf::{AdaptiveGrid, Cell, InfluenceSets, RbfOptions};
    /// let cells = [Cell::new(0, 0, 1, 0.0), Cell::new(1, 0, 1, 1.0)];
    /// let mut index = [0; 2];
    /// let grid = AdaptiveGrid::new(2, 1, &cells, &mut index).unwrap();
    /// assert_eq!(InfluenceSets::entries_len(&grid, &RbfOptions::default()), Ok(4));
    /// assert!(InfluenceSets::entries_len(&grid, &RbfOptions::default().with_sigma(0.0)).is_err());
    /// ```
    pub fn entries_len(grid: &AdaptiveGrid<'_>, options: &RbfOptions) -> Result<usize, Error> {
        options.validate()?;
        let mut n = 0usize;
        for i in grid.cells() {
            for_each_influenced(grid, i, options, |_| n += 1);
        }
        Ok(n)
    }

    /// Builds the influence sets of every cell into `offsets` (at least
    /// [`InfluenceSets::offsets_len`]) and `entries` (at least [`InfluenceSets::entries_len`]).
    ///
    /// Work: two passes over, for each cell `i`, the cells crossing the rows of its disc of
    /// influence (radius `3.5 sigma c_i + 0.5`). Errors: bad `sigma`
    /// ([`Error::InvalidParameter`]); [`Error::BufferTooSmall`] with the exact need when a
    /// buffer is too short; [`Error::SizeOverflow`] when there are `2^32` entries or more.
    ///
    /// ```
    /// # use relief_core::{rbf::{AdaptiveGrid, Cell, InfluenceSets, RbfOptions}, Error};
    /// let cells = [Cell::new(0, 0, 1, 0.0), Cell::new(1, 0, 1, 1.0)];
    /// let mut index = [0; 2];
    /// let grid = AdaptiveGrid::new(2, 1, &cells, &mut index).unwrap();
    /// let (mut offsets, mut entries) = ([0u32; 3], [0u32; 3]);
    /// let e = InfluenceSets::build(&grid, &RbfOptions::default(), &mut offsets, &mut entries);
    /// assert_eq!(e.unwrap_err(), Error::BufferTooSmall { needed: 4, actual: 3 });
    /// ```
    pub fn build(
        grid: &AdaptiveGrid<'_>,
        options: &RbfOptions,
        offsets: &'a mut [u32],
        entries: &'a mut [u32],
    ) -> Result<InfluenceSets<'a>, Error> {
        options.validate()?;
        let m = grid.cells().len();
        let offsets_len = offsets.len();
        let offsets = offsets.get_mut(..m + 1).ok_or(Error::BufferTooSmall {
            needed: m + 1,
            actual: offsets_len,
        })?;
        // Pass 1: counts into offsets[j + 1].
        offsets.fill(0);
        let mut total = 0usize;
        for i in grid.cells() {
            for_each_influenced(grid, i, options, |j| {
                if let Some(o) = offsets.get_mut(j + 1) {
                    *o = o.saturating_add(1);
                }
                total += 1;
            });
        }
        if total >= u32::MAX as usize {
            return Err(Error::SizeOverflow);
        }
        let entries_len = entries.len();
        let entries = entries.get_mut(..total).ok_or(Error::BufferTooSmall {
            needed: total,
            actual: entries_len,
        })?;
        // Prefix sums: offsets[j] = start of j's set.
        let mut acc = 0u32;
        for o in offsets.iter_mut() {
            acc = acc.saturating_add(*o);
            *o = acc;
        }
        // Pass 2: offsets[j] serves as j's write cursor, then is shifted back by one slot.
        for (ix, i) in grid.cells().iter().enumerate() {
            for_each_influenced(grid, i, options, |j| {
                if let Some(cursor) = offsets.get_mut(j) {
                    if let Some(e) = entries.get_mut(*cursor as usize) {
                        *e = ix as u32;
                    }
                    *cursor = cursor.saturating_add(1);
                }
            });
        }
        // Now offsets[j] = end of j's set = start of j + 1's: shift right.
        for k in (1..=m).rev() {
            let prev = offsets.get(k - 1).copied().unwrap_or(0);
            if let Some(o) = offsets.get_mut(k) {
                *o = prev;
            }
        }
        if let Some(o) = offsets.first_mut() {
            *o = 0;
        }
        Ok(InfluenceSets { offsets, entries })
    }

    /// The cells that may influence some point of cell `j` (empty for an unknown `j`).
    ///
    /// ```
    /// # use relief_core::rbf::{AdaptiveGrid, Cell, InfluenceSets, RbfOptions};
    /// let cells = [Cell::new(0, 0, 1, 0.0)];
    /// let mut index = [0; 1];
    /// let grid = AdaptiveGrid::new(1, 1, &cells, &mut index).unwrap();
    /// let (mut o, mut e) = ([0u32; 2], [0u32; 1]);
    /// let sets = InfluenceSets::build(&grid, &RbfOptions::default(), &mut o, &mut e).unwrap();
    /// assert_eq!((sets.of(0), sets.of(5)), (&[0u32][..], &[][..]));
    /// ```
    #[must_use]
    pub fn of(&self, j: usize) -> &'a [u32] {
        let (Some(&a), Some(&b)) = (self.offsets.get(j), self.offsets.get(j + 1)) else {
            return &[];
        };
        self.entries.get(a as usize..b as usize).unwrap_or(&[])
    }

    /// Total number of entries.
    ///
    /// ```
    /// # use relief_core::rbf::{AdaptiveGrid, Cell, InfluenceSets, RbfOptions};
    /// let cells = [Cell::new(0, 0, 1, 0.0)];
    /// let mut index = [0; 1];
    /// let grid = AdaptiveGrid::new(1, 1, &cells, &mut index).unwrap();
    /// let (mut o, mut e) = ([0u32; 2], [0u32; 1]);
    /// let sets = InfluenceSets::build(&grid, &RbfOptions::default(), &mut o, &mut e).unwrap();
    /// assert!(!sets.is_empty() && sets.len() == 1);
    /// ```
    #[must_use]
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether there are no entries (only for a grid without cells, which cannot be built).
    ///
    /// ```
    /// # use relief_core::rbf::{AdaptiveGrid, Cell, InfluenceSets, RbfOptions};
    /// let cells = [Cell::new(0, 0, 1, 0.0)];
    /// let mut index = [0; 1];
    /// let grid = AdaptiveGrid::new(1, 1, &cells, &mut index).unwrap();
    /// let (mut o, mut e) = ([0u32; 2], [0u32; 1]);
    /// assert!(!InfluenceSets::build(&grid, &RbfOptions::default(), &mut o, &mut e).unwrap().is_empty());
    /// ```
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

/// The RBF approximation `v(p) = sum w_i(p) v_i / sum w_i(p)` (seed 002 eq. 2) over an adaptive
/// grid and its influence sets.
///
/// Evaluation at `p` (sample coordinates, clamped into the domain's area
/// `[-0.5, width - 0.5] x [-0.5, height - 0.5]`) sums over the influence set of the cell
/// containing `p`. It is computed as `v_j + sum w_i (v_i - v_j) / sum w_i` with `v_j` the value
/// of that cell, so a constant field is reproduced exactly, and the result is clamped to the
/// range of the values with positive weight (a no-op in exact arithmetic that keeps rounding
/// inside it). Where no weight is positive (small `sigma`), the value of the influencing cell
/// whose centre is nearest `p` is returned. The result is never NaN or infinite.
///
/// ```
/// use relief_core::rbf::{AdaptiveGrid, Cell, InfluenceSets, Rbf, RbfOptions};
/// let cells = [Cell::new(0, 0, 2, 0.0), Cell::new(2, 0, 2, 10.0),
///              Cell::new(0, 2, 2, 0.0), Cell::new(2, 2, 2, 10.0)];
/// let mut index = [0; 16];
/// let grid = AdaptiveGrid::new(4, 4, &cells, &mut index).unwrap();
/// let opts = RbfOptions::default();
/// let mut o = vec![0; InfluenceSets::offsets_len(&grid)];
/// let mut e = vec![0; InfluenceSets::entries_len(&grid, &opts).unwrap()];
/// let sets = InfluenceSets::build(&grid, &opts, &mut o, &mut e).unwrap();
/// let rbf = Rbf::new(grid, sets, &opts).unwrap();
/// let mid = rbf.eval(glam::Vec2::new(1.5, 1.5)).unwrap();
/// assert!((mid - 5.0).abs() < 1e-4); // halfway between the two columns of cells
/// assert!(rbf.eval(glam::Vec2::new(0.0, 1.5)).unwrap() < 5.0);
/// ```
#[derive(Debug, Clone, Copy)]
pub struct Rbf<'a> {
    grid: AdaptiveGrid<'a>,
    sets: InfluenceSets<'a>,
    sigma: f32,
}

impl<'a> Rbf<'a> {
    /// Combines a grid with its influence sets. Errors: bad `sigma`; [`Error::LengthMismatch`]
    /// when the sets were built for a grid with a different number of cells.
    ///
    /// ```
    /// # use relief_core::rbf::{AdaptiveGrid, Cell, InfluenceSets, Rbf, RbfOptions};
    /// let cells = [Cell::new(0, 0, 1, 4.0)];
    /// let mut index = [0; 1];
    /// let grid = AdaptiveGrid::new(1, 1, &cells, &mut index).unwrap();
    /// let (mut o, mut e) = ([0u32; 2], [0u32; 1]);
    /// let sets = InfluenceSets::build(&grid, &RbfOptions::default(), &mut o, &mut e).unwrap();
    /// let rbf = Rbf::new(grid, sets, &RbfOptions::default()).unwrap();
    /// assert_eq!(rbf.eval(glam::Vec2::ZERO), Ok(4.0));
    /// ```
    pub fn new(
        grid: AdaptiveGrid<'a>,
        sets: InfluenceSets<'a>,
        options: &RbfOptions,
    ) -> Result<Rbf<'a>, Error> {
        options.validate()?;
        let m = grid.cells().len();
        if sets.offsets.len() != m + 1 {
            return Err(Error::LengthMismatch {
                expected: m + 1,
                actual: sets.offsets.len(),
            });
        }
        Ok(Rbf {
            grid,
            sets,
            sigma: options.sigma,
        })
    }

    /// The grid.
    ///
    /// ```
    /// # use relief_core::rbf::{AdaptiveGrid, Cell, InfluenceSets, Rbf, RbfOptions};
    /// # let cells = [Cell::new(0, 0, 1, 4.0)];
    /// # let mut index = [0; 1];
    /// # let grid = AdaptiveGrid::new(1, 1, &cells, &mut index).unwrap();
    /// # let (mut o, mut e) = ([0u32; 2], [0u32; 1]);
    /// # let sets = InfluenceSets::build(&grid, &RbfOptions::default(), &mut o, &mut e).unwrap();
    /// let rbf = Rbf::new(grid, sets, &RbfOptions::default()).unwrap();
    /// assert_eq!(rbf.grid().cells().len(), 1);
    /// ```
    #[must_use]
    pub fn grid(&self) -> &AdaptiveGrid<'a> {
        &self.grid
    }

    /// `sigma`.
    ///
    /// ```
    /// # use relief_core::rbf::{AdaptiveGrid, Cell, InfluenceSets, Rbf, RbfOptions};
    /// # let cells = [Cell::new(0, 0, 1, 4.0)];
    /// # let mut index = [0; 1];
    /// # let grid = AdaptiveGrid::new(1, 1, &cells, &mut index).unwrap();
    /// # let (mut o, mut e) = ([0u32; 2], [0u32; 1]);
    /// # let sets = InfluenceSets::build(&grid, &RbfOptions::default(), &mut o, &mut e).unwrap();
    /// let rbf = Rbf::new(grid, sets, &RbfOptions::default().with_sigma(2.0)).unwrap();
    /// assert_eq!(rbf.sigma(), 2.0);
    /// ```
    #[must_use]
    pub fn sigma(&self) -> f32 {
        self.sigma
    }

    /// The influence set used at `p`, that of the cell containing `p` (clamped into the domain);
    /// empty if `p` is NaN.
    ///
    /// ```
    /// # use relief_core::rbf::{AdaptiveGrid, Cell, InfluenceSets, Rbf, RbfOptions};
    /// # let cells = [Cell::new(0, 0, 1, 4.0)];
    /// # let mut index = [0; 1];
    /// # let grid = AdaptiveGrid::new(1, 1, &cells, &mut index).unwrap();
    /// # let (mut o, mut e) = ([0u32; 2], [0u32; 1]);
    /// # let sets = InfluenceSets::build(&grid, &RbfOptions::default(), &mut o, &mut e).unwrap();
    /// let rbf = Rbf::new(grid, sets, &RbfOptions::default()).unwrap();
    /// assert_eq!(rbf.influencing(glam::Vec2::ZERO), &[0]);
    /// ```
    #[must_use]
    pub fn influencing(&self, p: Vec2) -> &'a [u32] {
        match self.grid.cell_containing(p) {
            Some(j) => self.sets.of(j),
            None => &[],
        }
    }

    /// Weight of cell `i` at `p` (eq. 1; 0 for an unknown cell). `p` is not clamped.
    ///
    /// ```
    /// # use relief_core::rbf::{AdaptiveGrid, Cell, InfluenceSets, Rbf, RbfOptions, gaussian_weight};
    /// # let cells = [Cell::new(0, 0, 2, 4.0)];
    /// # let mut index = [0; 4];
    /// # let grid = AdaptiveGrid::new(2, 2, &cells, &mut index).unwrap();
    /// # let (mut o, mut e) = ([0u32; 2], [0u32; 1]);
    /// # let sets = InfluenceSets::build(&grid, &RbfOptions::default(), &mut o, &mut e).unwrap();
    /// let rbf = Rbf::new(grid, sets, &RbfOptions::default()).unwrap();
    /// // centre (0.5, 0.5), c = 2: at (2.5, 0.5) the normalised distance is 1
    /// assert_eq!(rbf.weight(0, glam::Vec2::new(2.5, 0.5)), gaussian_weight(1.0, 1.0));
    /// ```
    #[must_use]
    pub fn weight(&self, i: usize, p: Vec2) -> f32 {
        match self.grid.cells().get(i) {
            Some(c) => {
                let cs = c.size as f32;
                gaussian_weight((c.center() - p).length_squared() / (cs * cs), self.sigma)
            }
            None => 0.0,
        }
    }

    /// Clamps `p` into the domain's area.
    fn clamp(&self, p: Vec2) -> Vec2 {
        let hi = Vec2::new(
            self.grid.width() as f32 - 0.5,
            self.grid.height() as f32 - 0.5,
        );
        p.max(Vec2::splat(-0.5)).min(hi)
    }

    /// The approximation at `p` (sample coordinates; clamped into the domain's area).
    /// [`Error::NonFiniteInput`] if `p` is NaN or infinite.
    ///
    /// ```
    /// # use relief_core::rbf::{AdaptiveGrid, Cell, InfluenceSets, Rbf, RbfOptions};
    /// # let cells = [Cell::new(0, 0, 1, 4.0)];
    /// # let mut index = [0; 1];
    /// # let grid = AdaptiveGrid::new(1, 1, &cells, &mut index).unwrap();
    /// # let (mut o, mut e) = ([0u32; 2], [0u32; 1]);
    /// # let sets = InfluenceSets::build(&grid, &RbfOptions::default(), &mut o, &mut e).unwrap();
    /// let rbf = Rbf::new(grid, sets, &RbfOptions::default()).unwrap();
    /// assert_eq!(rbf.eval(glam::Vec2::new(100.0, -3.0)), Ok(4.0));
    /// assert!(rbf.eval(glam::Vec2::new(f32::NAN, 0.0)).is_err());
    /// ```
    pub fn eval(&self, p: Vec2) -> Result<f32, Error> {
        if !p.is_finite() {
            return Err(Error::NonFiniteInput { name: "point" });
        }
        let p = self.clamp(p);
        let cells = self.grid.cells();
        let Some(j) = self.grid.cell_containing(p) else {
            return Err(Error::NonFiniteInput { name: "point" });
        };
        let v_ref = cells.get(j).map_or(0.0, |c| c.value);
        let (mut sw, mut swv) = (0.0f32, 0.0f32);
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        let (mut nearest, mut nearest_d) = (v_ref, f32::INFINITY);
        for &i in self.sets.of(j) {
            let Some(c) = cells.get(i as usize) else {
                continue;
            };
            let d2 = (c.center() - p).length_squared();
            let cs = c.size as f32;
            let w = gaussian_weight(d2 / (cs * cs), self.sigma);
            if w > 0.0 {
                sw += w;
                swv += w * (c.value - v_ref);
                lo = lo.min(c.value);
                hi = hi.max(c.value);
            }
            if d2 < nearest_d {
                nearest_d = d2;
                nearest = c.value;
            }
        }
        if sw.is_nan() || sw <= 0.0 {
            return Ok(nearest);
        }
        let v = v_ref + swv / sw;
        Ok(if v.is_finite() {
            v.max(lo).min(hi)
        } else {
            nearest
        })
    }
}
