//! Adaptive grids (Cornel, Horváth, Waser 2022, sections 2 and 4): square cells of power-of-two
//! sizes, in grid units, that tile a `width x height` domain, each carrying one value at its
//! centre; a quadtree builder that merges blocks of a heightfield while they are flat enough; and
//! the validation of a cell list given by the caller.
//!
//! A cell `(x, y, size)` covers samples `[x, x + size) x [y, y + size)`, that is the area
//! `[x - 0.5, x + size - 0.5] x [y - 0.5, y + size - 0.5]` in sample coordinates; its centre is
//! at `(x + (size - 1) / 2, y + (size - 1) / 2)`, so a cell of size 1 is centred on its sample.

use crate::{Error, Terrain, MAX_ABS_HEIGHT};
use glam::Vec2;

/// Largest cell size accepted, in grid units (`2^15`).
///
/// ```
/// assert_eq!(relief_core::rbf::MAX_CELL_SIZE, 32768);
/// ```
pub const MAX_CELL_SIZE: u32 = 1 << 15;

/// Index-map value of a sample no cell covers (only seen while validating).
const UNSET: u32 = u32::MAX;

/// One cell of an adaptive grid: it covers samples `[x, x + size) x [y, y + size)` and carries
/// `value` at its centre.
///
/// ```
/// use relief_core::rbf::Cell;
/// let c = Cell::new(4, 8, 4, 2.5);
/// assert_eq!(c.center(), glam::Vec2::new(5.5, 9.5));
/// assert_eq!(Cell::new(3, 3, 1, 0.0).center(), glam::Vec2::new(3.0, 3.0));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Cell {
    /// First column covered.
    pub x: u32,
    /// First row covered.
    pub y: u32,
    /// Side length in samples, a power of two.
    pub size: u32,
    /// Value at the centre (for a heightfield: the mean local height `h * z_scale` of the
    /// samples covered).
    pub value: f32,
}

impl Cell {
    /// A cell covering `[x, x + size) x [y, y + size)` with `value` at its centre (not checked:
    /// [`AdaptiveGrid::new`] validates a cell list).
    ///
    /// ```
    /// let c = relief_core::rbf::Cell::new(0, 0, 2, 1.0);
    /// assert_eq!((c.x, c.y, c.size, c.value), (0, 0, 2, 1.0));
    /// ```
    #[must_use]
    pub const fn new(x: u32, y: u32, size: u32, value: f32) -> Cell {
        Cell { x, y, size, value }
    }

    /// Centre `(x + (size - 1) / 2, y + (size - 1) / 2)` in sample coordinates.
    ///
    /// ```
    /// let c = relief_core::rbf::Cell::new(2, 0, 2, 0.0);
    /// assert_eq!(c.center(), glam::Vec2::new(2.5, 0.5));
    /// ```
    #[must_use]
    pub fn center(&self) -> Vec2 {
        let h = (self.size as f32 - 1.0) * 0.5;
        Vec2::new(self.x as f32 + h, self.y as f32 + h)
    }

    /// Squared distance from `p` (sample coordinates) to the closed area the cell covers,
    /// `[x - 0.5, x + size - 0.5] x [y - 0.5, y + size - 0.5]`; zero inside.
    ///
    /// ```
    /// let c = relief_core::rbf::Cell::new(0, 0, 2, 0.0);
    /// assert_eq!(c.distance_squared_to_area(glam::Vec2::new(1.0, 1.0)), 0.0);
    /// assert_eq!(c.distance_squared_to_area(glam::Vec2::new(3.5, 0.0)), 4.0);
    /// ```
    #[must_use]
    pub fn distance_squared_to_area(&self, p: Vec2) -> f32 {
        let lo = Vec2::new(self.x as f32 - 0.5, self.y as f32 - 0.5);
        let hi = lo + Vec2::splat(self.size as f32);
        let d = (lo - p).max(Vec2::ZERO).max(p - hi);
        d.length_squared()
    }
}

/// Options of [`build_adaptive_grid`]: a quadtree block becomes one cell when all its samples lie
/// within `max_error` of their mean, and its size is within `[min_cell, max_cell]`.
///
/// Defaults: `max_error = 0` (merge only exactly flat blocks), `min_cell = 1`, `max_cell = 64`.
///
/// ```
/// use relief_core::rbf::GridOptions;
/// let o = GridOptions::default().with_max_error(0.5).with_cells(2, 32);
/// assert_eq!((o.max_error, o.min_cell, o.max_cell), (0.5, 2, 32));
/// assert!(o.validate().is_ok());
/// assert!(GridOptions::default().with_cells(8, 4).validate().is_err());
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridOptions {
    /// Largest deviation of a sample from its cell's mean, in local height units (default 0).
    pub max_error: f32,
    /// Smallest cell size, a power of two (default 1). Blocks this small are never split,
    /// except at the right and bottom edges where the domain is not a multiple of it.
    pub min_cell: u32,
    /// Largest cell size, a power of two up to [`MAX_CELL_SIZE`] (default 64).
    pub max_cell: u32,
}

impl Default for GridOptions {
    fn default() -> Self {
        GridOptions {
            max_error: 0.0,
            min_cell: 1,
            max_cell: 64,
        }
    }
}

impl GridOptions {
    /// Returns the options with maximum deviation `max_error` (default 0).
    ///
    /// ```
    /// assert_eq!(relief_core::rbf::GridOptions::default().with_max_error(2.0).max_error, 2.0);
    /// ```
    #[must_use]
    pub fn with_max_error(mut self, max_error: f32) -> Self {
        self.max_error = max_error;
        self
    }

    /// Returns the options with cell sizes in `[min_cell, max_cell]` (defaults 1 and 64).
    ///
    /// ```
    /// let o = relief_core::rbf::GridOptions::default().with_cells(4, 16);
    /// assert_eq!((o.min_cell, o.max_cell), (4, 16));
    /// ```
    #[must_use]
    pub fn with_cells(mut self, min_cell: u32, max_cell: u32) -> Self {
        self.min_cell = min_cell;
        self.max_cell = max_cell;
        self
    }

    /// Checks the options: `max_error` finite and `>= 0` ([`Error::InvalidParameter`]),
    /// `min_cell` and `max_cell` powers of two, at most [`MAX_CELL_SIZE`], with
    /// `min_cell <= max_cell` ([`Error::InvalidCellSize`]).
    ///
    /// ```
    /// use relief_core::{rbf::GridOptions, Error};
    /// assert_eq!(
    ///     GridOptions::default().with_cells(3, 8).validate(),
    ///     Err(Error::InvalidCellSize { name: "min_cell", value: 3, reason: "not a power of two" })
    /// );
    /// ```
    pub fn validate(&self) -> Result<(), Error> {
        if !(self.max_error.is_finite() && self.max_error >= 0.0) {
            return Err(Error::InvalidParameter {
                name: "max_error",
                value: self.max_error,
            });
        }
        check_cell_size("min_cell", self.min_cell)?;
        check_cell_size("max_cell", self.max_cell)?;
        if self.min_cell > self.max_cell {
            return Err(Error::InvalidCellSize {
                name: "min_cell",
                value: self.min_cell,
                reason: "larger than max_cell",
            });
        }
        Ok(())
    }
}

fn check_cell_size(name: &'static str, value: u32) -> Result<(), Error> {
    let reason = if !value.is_power_of_two() {
        "not a power of two"
    } else if value > MAX_CELL_SIZE {
        "larger than MAX_CELL_SIZE"
    } else {
        return Ok(());
    };
    Err(Error::InvalidCellSize {
        name,
        value,
        reason,
    })
}

/// Most cells [`build_adaptive_grid`] can produce for a `width x height` domain (every sample
/// its own cell): `width * height`, or `None` on overflow.
///
/// ```
/// assert_eq!(relief_core::rbf::adaptive_grid_bound(1025, 1025), Some(1025 * 1025));
/// ```
#[must_use]
pub const fn adaptive_grid_bound(width: u32, height: u32) -> Option<usize> {
    (width as usize).checked_mul(height as usize)
}

/// Builds an adaptive grid from a heightfield into `cells` and returns how many it wrote.
///
/// The domain is cut into aligned blocks of `max_cell` samples (row-major); each block is a
/// quadtree. A block that lies inside the domain becomes one cell when its size is at most
/// `min_cell`, or when every sample deviates from the block's mean local height
/// (`h * z_scale`) by at most `max_error`; otherwise it is split into four, top-left first.
/// Blocks that stick out of the domain are split until they fit, so a domain that is not a
/// multiple of `min_cell` gets smaller cells along its right and bottom edges. A cell's value is
/// the mean local height of its samples (accumulated in f64), so a size-1 cell holds its sample.
///
/// Work: every sample is read once per quadtree level, at most `log2(max_cell) + 1` times.
/// Errors: bad options (see [`GridOptions::validate`]); [`Error::BufferTooSmall`] with the exact
/// count needed when `cells` is too short (at most [`adaptive_grid_bound`] is ever needed).
///
/// ```
/// use relief_core::{rbf::{build_adaptive_grid, GridOptions, Cell}, Heightfield};
/// // 4 x 4: a flat left half and a bumpy top-right corner.
/// let h = [0.0f32, 0.0, 1.0, 5.0,
///          0.0, 0.0, 2.0, 3.0,
///          0.0, 0.0, 0.0, 0.0,
///          0.0, 0.0, 0.0, 0.0];
/// let hf = Heightfield::new(&h, 4, 4).unwrap();
/// let mut cells = [Cell::default(); 16];
/// let n = build_adaptive_grid(&hf, &GridOptions::default().with_cells(1, 4), &mut cells).unwrap();
/// assert_eq!(n, 7); // 2x2 top-left, four 1x1 top-right, 2x2 bottom-left and bottom-right
/// assert_eq!(cells[0], Cell::new(0, 0, 2, 0.0));
/// assert_eq!(cells[2], Cell::new(3, 0, 1, 5.0));
/// ```
pub fn build_adaptive_grid<T: Terrain + ?Sized>(
    terrain: &T,
    options: &GridOptions,
    cells: &mut [Cell],
) -> Result<usize, Error> {
    options.validate()?;
    let (w, h) = (terrain.width(), terrain.height());
    let m = options.max_cell;
    let blocks_x = w.div_ceil(m);
    let blocks_y = h.div_ceil(m);
    let mut count = 0usize;
    // DFS stack: at most 3 entries per level plus one, 16 levels.
    let mut stack = [(0u32, 0u32, 0u32); 64];
    for by in 0..blocks_y {
        for bx in 0..blocks_x {
            let mut top = 1usize;
            stack[0] = (bx * m, by * m, m);
            // Each iteration pops one block; a quadtree of depth <= 16 has fewer than
            // 4^16 * 4 / 3 blocks, and the stack never exceeds 3 * 16 + 1 entries.
            while top > 0 {
                top -= 1;
                let Some(&(x, y, s)) = stack.get(top) else {
                    break;
                };
                if x >= w || y >= h {
                    continue;
                }
                let inside = x.checked_add(s).is_some_and(|e| e <= w)
                    && y.checked_add(s).is_some_and(|e| e <= h);
                let leaf_value = if inside {
                    let (mean, dev) = block_stats(terrain, x, y, s);
                    (s <= options.min_cell || dev <= f64::from(options.max_error))
                        .then_some(mean as f32)
                } else {
                    None
                };
                match leaf_value {
                    Some(value) => {
                        if let Some(c) = cells.get_mut(count) {
                            *c = Cell::new(x, y, s, value);
                        }
                        count += 1;
                    }
                    None if s > 1 => {
                        let q = s / 2;
                        // Pushed in reverse so the top-left child is popped first.
                        for (dx, dy) in [(q, q), (0, q), (q, 0), (0, 0)] {
                            if let Some(e) = stack.get_mut(top) {
                                *e = (x.saturating_add(dx), y.saturating_add(dy), q);
                                top += 1;
                            }
                        }
                    }
                    None => {}
                }
            }
        }
    }
    if count > cells.len() {
        return Err(Error::BufferTooSmall {
            needed: count,
            actual: cells.len(),
        });
    }
    Ok(count)
}

/// Mean and largest deviation from the mean (`max(max - mean, mean - min)`) of the local heights
/// in the block `[x, x + s) x [y, y + s)`.
fn block_stats<T: Terrain + ?Sized>(terrain: &T, x: u32, y: u32, s: u32) -> (f64, f64) {
    let (mut lo, mut hi, mut sum) = (f64::INFINITY, f64::NEG_INFINITY, 0.0f64);
    for yy in y..y.saturating_add(s) {
        for xx in x..x.saturating_add(s) {
            let v = f64::from(terrain.local_z(xx, yy));
            lo = lo.min(v);
            hi = hi.max(v);
            sum += v;
        }
    }
    let n = f64::from(s) * f64::from(s);
    // max/min, not clamp: clamp panics on an inverted range.
    let mean = (sum / n).max(lo).min(hi);
    (mean, (hi - mean).max(mean - lo))
}

/// A validated adaptive grid: cells that tile a `width x height` domain exactly, and a map from
/// every sample to the index of the cell covering it (borrowed from the caller).
///
/// ```
/// use relief_core::rbf::{AdaptiveGrid, Cell};
/// let cells = [Cell::new(0, 0, 2, 1.0), Cell::new(2, 0, 1, 2.0), Cell::new(2, 1, 1, 3.0)];
/// let mut index = [0u32; 6];
/// let grid = AdaptiveGrid::new(3, 2, &cells, &mut index).unwrap();
/// assert_eq!(grid.cell_at(2, 1), Some(2));
/// assert_eq!(grid.cell_at(1, 1), Some(0));
/// ```
#[derive(Debug, Clone, Copy)]
pub struct AdaptiveGrid<'a> {
    width: u32,
    height: u32,
    cells: &'a [Cell],
    index: &'a [u32],
    max_size: u32,
    min_size: u32,
}

impl<'a> AdaptiveGrid<'a> {
    /// Checks that `cells` tile the `width x height` domain exactly and fills `index`
    /// (`width * height` entries) with the cell covering each sample.
    ///
    /// Errors: [`Error::TooSmall`] for an empty domain; [`Error::BufferTooSmall`] when `index`
    /// is too short; [`Error::SizeOverflow`] for `u32::MAX` cells or more;
    /// [`Error::InvalidCell`] for a cell whose size is not a power of two up to
    /// [`MAX_CELL_SIZE`], that leaves the domain, overlaps an earlier cell, or whose value is not
    /// finite or exceeds [`MAX_ABS_HEIGHT`]; [`Error::UncoveredSample`] naming the first sample
    /// (row-major) no cell covers. Work: `O(width * height + cells)`.
    ///
    /// ```
    /// use relief_core::{rbf::{AdaptiveGrid, Cell}, Error};
    /// let mut index = [0u32; 4];
    /// let three = [Cell::new(0, 0, 3, 0.0)];
    /// assert!(matches!(AdaptiveGrid::new(2, 2, &three, &mut index), Err(Error::InvalidCell { index: 0, .. })));
    /// let gap = [Cell::new(0, 0, 1, 0.0), Cell::new(1, 0, 1, 0.0), Cell::new(0, 1, 1, 0.0)];
    /// assert_eq!(AdaptiveGrid::new(2, 2, &gap, &mut index).unwrap_err(), Error::UncoveredSample { x: 1, y: 1 });
    /// ```
    pub fn new(
        width: u32,
        height: u32,
        cells: &'a [Cell],
        index: &'a mut [u32],
    ) -> Result<AdaptiveGrid<'a>, Error> {
        if width == 0 || height == 0 {
            return Err(Error::TooSmall { width, height });
        }
        let n = adaptive_grid_bound(width, height).ok_or(Error::SizeOverflow)?;
        if cells.len() >= UNSET as usize {
            return Err(Error::SizeOverflow);
        }
        let actual = index.len();
        let index = index
            .get_mut(..n)
            .ok_or(Error::BufferTooSmall { needed: n, actual })?;
        index.fill(UNSET);
        let (mut min_size, mut max_size) = (u32::MAX, 0u32);
        for (i, c) in cells.iter().enumerate() {
            let bad = |reason| Error::InvalidCell { index: i, reason };
            if !c.size.is_power_of_two() || c.size > MAX_CELL_SIZE {
                return Err(bad("size is not a power of two up to MAX_CELL_SIZE"));
            }
            if !(c.value.is_finite() && c.value.abs() <= MAX_ABS_HEIGHT) {
                return Err(bad("value is not finite or exceeds MAX_ABS_HEIGHT"));
            }
            let fits = c.x.checked_add(c.size).is_some_and(|e| e <= width)
                && c.y.checked_add(c.size).is_some_and(|e| e <= height);
            if !fits {
                return Err(bad("leaves the domain"));
            }
            for y in c.y..c.y + c.size {
                let row = y as usize * width as usize;
                let span = index
                    .get_mut(row + c.x as usize..row + (c.x + c.size) as usize)
                    .ok_or(bad("leaves the domain"))?;
                for e in span {
                    if *e != UNSET {
                        return Err(bad("overlaps another cell"));
                    }
                    *e = i as u32;
                }
            }
            min_size = min_size.min(c.size);
            max_size = max_size.max(c.size);
        }
        if let Some(k) = index.iter().position(|&e| e == UNSET) {
            return Err(Error::UncoveredSample {
                x: (k % width as usize) as u32,
                y: (k / width as usize) as u32,
            });
        }
        Ok(AdaptiveGrid {
            width,
            height,
            cells,
            index,
            max_size,
            min_size,
        })
    }

    /// Columns of the domain.
    ///
    /// ```
    /// # use relief_core::rbf::{AdaptiveGrid, Cell};
    /// let cells = [Cell::new(0, 0, 1, 0.0), Cell::new(1, 0, 1, 0.0)];
    /// let mut index = [0; 2];
    /// let g = AdaptiveGrid::new(2, 1, &cells, &mut index).unwrap();
    /// assert_eq!((g.width(), g.height()), (2, 1));
    /// ```
    #[must_use]
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Rows of the domain.
    ///
    /// ```
    /// # use relief_core::rbf::{AdaptiveGrid, Cell};
    /// let cells = [Cell::new(0, 0, 1, 0.0)];
    /// let mut index = [0; 1];
    /// assert_eq!(AdaptiveGrid::new(1, 1, &cells, &mut index).unwrap().height(), 1);
    /// ```
    #[must_use]
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The cells, in the order given.
    ///
    /// ```
    /// # use relief_core::rbf::{AdaptiveGrid, Cell};
    /// let cells = [Cell::new(0, 0, 2, 7.0)];
    /// let mut index = [0; 4];
    /// assert_eq!(AdaptiveGrid::new(2, 2, &cells, &mut index).unwrap().cells()[0].value, 7.0);
    /// ```
    #[must_use]
    pub fn cells(&self) -> &'a [Cell] {
        self.cells
    }

    /// Smallest and largest cell size present.
    ///
    /// ```
    /// # use relief_core::rbf::{AdaptiveGrid, Cell};
    /// let cells = [Cell::new(0, 0, 2, 0.0), Cell::new(2, 0, 1, 0.0), Cell::new(2, 1, 1, 0.0)];
    /// let mut index = [0; 6];
    /// assert_eq!(AdaptiveGrid::new(3, 2, &cells, &mut index).unwrap().size_range(), (1, 2));
    /// ```
    #[must_use]
    pub fn size_range(&self) -> (u32, u32) {
        (self.min_size, self.max_size)
    }

    /// Index of the cell covering sample `(x, y)`, `None` outside the domain.
    ///
    /// ```
    /// # use relief_core::rbf::{AdaptiveGrid, Cell};
    /// let cells = [Cell::new(0, 0, 1, 0.0), Cell::new(1, 0, 1, 0.0)];
    /// let mut index = [0; 2];
    /// let g = AdaptiveGrid::new(2, 1, &cells, &mut index).unwrap();
    /// assert_eq!((g.cell_at(1, 0), g.cell_at(2, 0)), (Some(1), None));
    /// ```
    #[must_use]
    pub fn cell_at(&self, x: u32, y: u32) -> Option<usize> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let k = y as usize * self.width as usize + x as usize;
        self.index.get(k).map(|&i| i as usize)
    }

    /// Index of the cell whose area contains `p` (sample coordinates); `p` is clamped into the
    /// domain first. `None` if `p` is NaN.
    ///
    /// ```
    /// # use relief_core::rbf::{AdaptiveGrid, Cell};
    /// let cells = [Cell::new(0, 0, 1, 0.0), Cell::new(1, 0, 1, 0.0)];
    /// let mut index = [0; 2];
    /// let g = AdaptiveGrid::new(2, 1, &cells, &mut index).unwrap();
    /// assert_eq!(g.cell_containing(glam::Vec2::new(0.7, 0.0)), Some(1));
    /// assert_eq!(g.cell_containing(glam::Vec2::new(-9.0, 3.0)), Some(0));
    /// ```
    #[must_use]
    pub fn cell_containing(&self, p: Vec2) -> Option<usize> {
        if p.is_nan() {
            return None;
        }
        let sx = libm::floorf(p.x + 0.5)
            .max(0.0)
            .min((self.width - 1) as f32) as u32;
        let sy = libm::floorf(p.y + 0.5)
            .max(0.0)
            .min((self.height - 1) as f32) as u32;
        self.cell_at(sx, sy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Heightfield;
    use proptest::prelude::*;

    fn build(h: &[f32], w: u32, hh: u32, o: GridOptions) -> Vec<Cell> {
        let hf = Heightfield::new(h, w, hh).unwrap();
        let mut cells = vec![Cell::default(); (w * hh) as usize];
        let n = build_adaptive_grid(&hf, &o, &mut cells).unwrap();
        cells.truncate(n);
        cells
    }

    #[test]
    fn flat_field_becomes_max_cells_and_edges_split() {
        // 10 x 6 flat: max 4 -> 4x4 blocks where they fit, smaller cells at the edges.
        let h = vec![3.0f32; 60];
        let cells = build(&h, 10, 6, GridOptions::default().with_cells(1, 4));
        let mut index = vec![0; 60];
        let g = AdaptiveGrid::new(10, 6, &cells, &mut index).unwrap();
        assert_eq!(g.size_range(), (2, 4));
        assert_eq!(cells.iter().filter(|c| c.size == 4).count(), 2);
        assert!(cells.iter().all(|c| c.value == 3.0));
        // 10 = 4+4+2, 6 = 4+2: 2 big, 2x2 cells fill the rest: (60 - 32) / 4 = 7
        assert_eq!(cells.len(), 2 + 7);
    }

    #[test]
    fn odd_domain_needs_unit_cells_at_edges() {
        let h = vec![0.0f32; 5 * 5];
        let cells = build(&h, 5, 5, GridOptions::default().with_cells(4, 4));
        assert_eq!(cells.len(), 1 + 9);
        assert_eq!(cells[0], Cell::new(0, 0, 4, 0.0));
    }

    #[test]
    fn min_cell_forces_merge_and_max_error_controls_split() {
        let mut h = vec![0.0f32; 16];
        h[5] = 8.0; // sample (1, 1)
        let fine = build(&h, 4, 4, GridOptions::default().with_cells(1, 4));
        assert_eq!(fine.len(), 4 + 3);
        assert!(fine.contains(&Cell::new(1, 1, 1, 8.0)));
        let merged = build(&h, 4, 4, GridOptions::default().with_cells(2, 4));
        assert_eq!(merged.len(), 4);
        assert_eq!(merged[0], Cell::new(0, 0, 2, 2.0));
        // block of 4: mean 0.5, deviation 7.5 -> merges with max_error 7.5 only
        let tol = build(
            &h,
            4,
            4,
            GridOptions::default().with_max_error(7.5).with_cells(1, 4),
        );
        assert_eq!(tol, vec![Cell::new(0, 0, 4, 0.5)]);
        // 7.4: the 4x4 block splits, the 2x2 block holding the bump (mean 2, deviation 6)
        // merges; below 6 it splits too.
        let mid = build(
            &h,
            4,
            4,
            GridOptions::default().with_max_error(7.4).with_cells(1, 4),
        );
        assert_eq!(mid.len(), 4);
        assert_eq!(mid[0], Cell::new(0, 0, 2, 2.0));
        let tight = build(
            &h,
            4,
            4,
            GridOptions::default().with_max_error(5.9).with_cells(1, 4),
        );
        assert_eq!(tight.len(), 7);
    }

    #[test]
    fn too_small_buffer_reports_exact_need() {
        let h: Vec<f32> = (0..16).map(|i| i as f32).collect();
        let hf = Heightfield::new(&h, 4, 4).unwrap();
        let mut cells = [Cell::default(); 5];
        let e = build_adaptive_grid(&hf, &GridOptions::default(), &mut cells).unwrap_err();
        assert_eq!(
            e,
            Error::BufferTooSmall {
                needed: 16,
                actual: 5
            }
        );
    }

    #[test]
    fn bad_options_are_typed_errors() {
        let h = [0.0f32; 4];
        let hf = Heightfield::new(&h, 2, 2).unwrap();
        let mut cells = [Cell::default(); 4];
        let mut run = |o: GridOptions| build_adaptive_grid(&hf, &o, &mut cells).unwrap_err();
        assert!(matches!(
            run(GridOptions::default().with_cells(0, 4)),
            Error::InvalidCellSize {
                name: "min_cell",
                ..
            }
        ));
        assert!(matches!(
            run(GridOptions::default().with_cells(1, 6)),
            Error::InvalidCellSize {
                name: "max_cell",
                ..
            }
        ));
        assert!(matches!(
            run(GridOptions::default().with_cells(8, 4)),
            Error::InvalidCellSize {
                name: "min_cell",
                ..
            }
        ));
        assert!(matches!(
            run(GridOptions::default().with_cells(1, 1 << 16)),
            Error::InvalidCellSize {
                name: "max_cell",
                ..
            }
        ));
        assert!(matches!(
            run(GridOptions::default().with_max_error(f32::NAN)),
            Error::InvalidParameter {
                name: "max_error",
                ..
            }
        ));
        assert!(matches!(
            run(GridOptions::default().with_max_error(-1.0)),
            Error::InvalidParameter {
                name: "max_error",
                ..
            }
        ));
    }

    #[test]
    fn validation_catches_overlap_exit_and_bad_values() {
        let mut index = [0u32; 16];
        let overlap = [Cell::new(0, 0, 2, 0.0), Cell::new(1, 1, 2, 0.0)];
        assert_eq!(
            AdaptiveGrid::new(4, 4, &overlap, &mut index).unwrap_err(),
            Error::InvalidCell {
                index: 1,
                reason: "overlaps another cell"
            }
        );
        let out = [Cell::new(3, 0, 2, 0.0)];
        assert_eq!(
            AdaptiveGrid::new(4, 4, &out, &mut index).unwrap_err(),
            Error::InvalidCell {
                index: 0,
                reason: "leaves the domain"
            }
        );
        let huge = [Cell::new(u32::MAX, 0, 2, 0.0)];
        assert!(AdaptiveGrid::new(4, 4, &huge, &mut index).is_err());
        let nan = [Cell::new(0, 0, 4, f32::NAN)];
        assert!(matches!(
            AdaptiveGrid::new(4, 4, &nan, &mut index),
            Err(Error::InvalidCell { index: 0, .. })
        ));
        let ok = [Cell::new(0, 0, 4, 1.0)];
        let mut short = [0u32; 15];
        assert_eq!(
            AdaptiveGrid::new(4, 4, &ok, &mut short).unwrap_err(),
            Error::BufferTooSmall {
                needed: 16,
                actual: 15
            }
        );
        assert_eq!(
            AdaptiveGrid::new(0, 4, &ok, &mut index).unwrap_err(),
            Error::TooSmall {
                width: 0,
                height: 4
            }
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// Built grids always tile the domain, respect the size bounds (except forced edge
        /// cells), and every cell is within max_error of every sample it covers.
        #[test]
        fn built_grid_tiles_and_respects_error(
            w in 1u32..40, hh in 1u32..40, seed in any::<u64>(),
            e in 0.0f32..3.0, lmin in 0u32..3, lspan in 0u32..4,
        ) {
            let w = w.max(2); let hh = hh.max(2);
            let mut s = seed | 1;
            let h: Vec<f32> = (0..w * hh).map(|_| {
                s ^= s << 13; s ^= s >> 7; s ^= s << 17;
                (s % 8) as f32 * 0.5
            }).collect();
            let (mn, mx) = (1u32 << lmin, 1u32 << (lmin + lspan));
            let o = GridOptions::default().with_max_error(e).with_cells(mn, mx);
            let cells = build(&h, w, hh, o);
            let mut index = vec![0; (w * hh) as usize];
            let g = AdaptiveGrid::new(w, hh, &cells, &mut index).unwrap();
            prop_assert!(g.size_range().1 <= mx);
            for c in &cells {
                let fits_min = c.x + mn <= w && c.y + mn <= hh;
                if c.size < mn { prop_assert!(!(fits_min && c.x % mn == 0 && c.y % mn == 0)); }
                if c.size > mn {
                    for y in c.y..c.y + c.size { for x in c.x..c.x + c.size {
                        let v = h[(y * w + x) as usize];
                        prop_assert!((v - c.value).abs() <= e + 1e-5);
                    }}
                }
            }
        }
    }
}
