//! SOAR refinement of a heightfield by longest-edge bisection (Lindstrom & Pascucci, "Visualization
//! of large terrains made easy", 2001, and "Terrain simplification simplified", 2002; Balogh 2003,
//! seed 004, chapters 4.5 (SOAR), 5.1 (in/out-edge strip), 5.2 (lazy frustum culling) and 6.3
//! (level-only bounding circles)).
//!
//! Two steps, both into caller buffers, no allocation:
//! 1. **Preprocessing** ([`preprocess`], [`preprocess_compact`]): a nested L-infinity
//!    object-space error per vertex (a *true* bound: every grid sample a triangle covers is within
//!    the error of its split vertex) and nested bounding spheres, or the compact layout with
//!    bfloat16 errors rounded up and seed 004's level-only bounding circles
//!    `r_i = l_0 (1/sqrt 2)^i / (1 - 1/sqrt 2)`.
//! 2. **Refinement** ([`Refiner`]), stateless, every frame from scratch: view-independent
//!    (every vertex with error `> E`) or view-dependent (SOAR's projected error from the nearest
//!    point of the bounding volume against a pixel threshold), with hierarchical frustum culling
//!    (active-plane mask) and lazy culling below a chosen level. Output: an indexed triangle list,
//!    SOAR's generalized triangle strip, or seed 004's in/out-edge strip, with vertices as
//!    positions or as grid coordinates ([`MeshVertex`]).
//!
//! Bytes per vertex of preprocessed data (besides the heights, which stay in the caller's
//! heightfield): 8 for [`preprocess`] (`f32` error and `f32` radius), 2 for
//! [`preprocess_compact`] (`u16` error; radii come from the level), 8 for [`pack_records`]'s
//! records, which hold the height too (bfloat16 error and radius), in a linear or a
//! hierarchical interleaved layout for grids larger than the caches (SOAR's out-of-core
//! indexing). See [`Hierarchy::bytes_per_vertex`].
//!
//! Any `width x height` grid works: it is embedded in the enclosing `(2^k+1)^2` square; triangles
//! outside the domain are never emitted and those crossing its border are always split, so the
//! mesh covers exactly the domain (at the price of full-resolution triangles along a border whose
//! coordinate is not a multiple of a large power of two).
//!
//! ```
//! use relief_core::refine::{coverage_len, preprocess, scratch_len, triangle_bound};
//! use relief_core::refine::{vertical_error, Criterion, Refiner};
//! use relief_core::Heightfield;
//! let samples: Vec<f32> = (0..25).map(|i| if i == 12 { 5.0 } else { 0.0 }).collect();
//! let hf = Heightfield::new(&samples, 5, 5).unwrap();
//! let (mut err, mut rad) = (vec![0.0; 25], vec![0.0; 25]);
//! let h = preprocess(&hf, &mut err, &mut rad).unwrap();
//! let r = Refiner::new(&h, &hf, Criterion::MaxError(1.0)).unwrap();
//! let mut scratch = vec![0u64; scratch_len(5, 5)];
//! let mut verts = vec![[0.0f32; 3]; 25];
//! let mut tris = vec![[0u32; 3]; triangle_bound(5, 5)];
//! let c = r.triangles(&mut scratch, &mut verts, &mut tris).unwrap();
//! assert!(c.triangles < 32); // fewer than full resolution
//! let (v, t) = (&verts[..c.vertices], &tris[..c.triangles]);
//! let measured = vertical_error(&hf, v, t, &mut vec![0; coverage_len(5, 5)]).unwrap();
//! assert!(measured <= 1.0);
//! ```

mod detail;
mod grid;
mod layout;
#[cfg(test)]
mod layout_tests;
mod preprocess;
mod pyramid;
mod raster;
mod scan;
mod select;
mod strip;
#[cfg(test)]
mod tests;
mod tile;
mod update;
#[cfg(test)]
mod update_tests;

pub use detail::{
    detail_scratch_len, local_bounds_len, DetailBounds, DetailCounts, DetailRefiner,
    MEASURE_PERIOD_LIMIT,
};
pub use grid::RefineGrid;
pub use layout::{
    check_records, pack_records, record_position, records_hierarchy, records_len, RecordLayout,
    VertexRecord,
};
pub use scan::{coverage_len, vertical_error, vertical_error_partial, Uncovered};
pub use select::{
    Criterion, FrameCounts, MeshVertex, MorphVertex, Refiner, StripCounts, UninitBuffers, View,
};
pub use strip::{strip_fewest, strip_fewest_indices, strip_fewest_scratch_len, strip_triangles};
pub use tile::{
    border_len, export_border, export_border_compact, merge_border, merge_border_compact, renest,
    renest_compact, skirt, skirt_bound, Side,
};
pub use update::{
    crater, preprocess_compact_pyramid, preprocess_pyramid, pyramid_len, update, update_compact,
    Region,
};

use crate::{Error, Scale, Terrain};

/// Length of the per-vertex arrays ([`preprocess`]'s `errors` and `radii`,
/// [`preprocess_compact`]'s `errors`): `width * height` (saturating).
///
/// ```
/// assert_eq!(relief_core::refine::hierarchy_len(1025, 1025), 1025 * 1025);
/// ```
#[must_use]
pub const fn hierarchy_len(width: u32, height: u32) -> usize {
    (width as usize).saturating_mul(height as usize)
}

/// Length of the `u64` scratch every refinement call needs: a bitmap of kept vertices, its
/// rank prefix, a summary bitmap of the marked words, a summary of the summary and a marker,
/// `2 w + s + ceil(s / 64) + 1` with `w = ceil(width * height / 64)` and `s = ceil(w / 64)`.
/// Any initial contents work; between calls leave it as refinement left it (or zero it):
/// view-dependent refinement clears only the words its mesh touched (its cost follows the
/// output, not the grid), and the marker word tells it when a full clear is needed.
///
/// ```
/// assert_eq!(relief_core::refine::scratch_len(8, 8), 5);
/// assert_eq!(relief_core::refine::scratch_len(1025, 1025), 2 * 16417 + 257 + 5 + 1);
/// ```
#[must_use]
pub const fn scratch_len(width: u32, height: u32) -> usize {
    select::marks_len(hierarchy_len(width, height))
}

/// Most vertices a mesh can have: `width * height`.
///
/// ```
/// assert_eq!(relief_core::refine::vertex_bound(3, 3), 9);
/// ```
#[must_use]
pub const fn vertex_bound(width: u32, height: u32) -> usize {
    hierarchy_len(width, height)
}

/// Most triangles a mesh can have: `2 (width - 1) (height - 1)` (full resolution).
///
/// ```
/// assert_eq!(relief_core::refine::triangle_bound(3, 3), 8);
/// ```
#[must_use]
pub const fn triangle_bound(width: u32, height: u32) -> usize {
    2usize
        .saturating_mul(width.saturating_sub(1) as usize)
        .saturating_mul(height.saturating_sub(1) as usize)
}

/// Most indices a triangle strip can have: `3 * triangle_bound + 8` on a grid that fills its
/// square, `(2^k+1) x (2^k+1)` (never reached: both strips need about 1.6 indices per triangle
/// on real DEMs, the fewest their triangle order allows ([`strip_fewest_indices`]); seed 004
/// reports 1.3 for its in/out-edge strip, below that fewest, BENCHMARKS.md).
///
/// On any other grid the strip is made of pieces, one per triangle inside the domain whose
/// parent crosses the domain's edge, joined by at most 4 indices each (a piece of one
/// triangle takes at most 6 with its join, no more than 4 + 2), so the bound adds
/// `4 (6 (width + height - 2 + 2 k) + 2)` for the enclosing square of `2^k` cells: a triangle
/// across the edge at a level where the square is cut into squares of side `s` crosses the
/// line `x = width - 1` inside one of the `ceil((height - 1) / s)` squares of one column (or
/// the line `y = height - 1` inside one of a row), at most 6 per square over the two levels of
/// that size (2 halves, 4 quarters); summed over the sizes that is below
/// `6 (width + height - 2 + 2 k)`, and the pieces number at most two more than the triangles
/// across the edge. On thin grids that is most of the bound; on big ones little (1197 x 643:
/// 1%).
///
/// ```
/// use relief_core::refine::strip_bound;
/// assert_eq!(strip_bound(3, 3), 32);
/// // 3 x 2: 4 triangles, k = 1.
/// assert_eq!(strip_bound(3, 2), 3 * 4 + 8 + 4 * (6 * (3 + 2 - 2 + 2) + 2));
/// ```
#[must_use]
pub const fn strip_bound(width: u32, height: u32) -> usize {
    let square = triangle_bound(width, height)
        .saturating_mul(3)
        .saturating_add(8);
    let cells = if width > height { width } else { height }.saturating_sub(1);
    if width == height && cells.is_power_of_two() {
        return square;
    }
    let k = match cells.checked_next_power_of_two() {
        Some(side) => side.trailing_zeros() as usize,
        None => 32,
    };
    let crossing = (width as usize + height as usize)
        .saturating_sub(2)
        .saturating_add(2 * k)
        .saturating_mul(6);
    square.saturating_add(crossing.saturating_add(2).saturating_mul(4))
}

/// Per-vertex errors: `f32`, or bfloat16 codes rounded up.
#[derive(Debug, Clone, Copy)]
pub(crate) enum ErrorStore<'a> {
    F32(&'a [f32]),
    Bf16(&'a [u16]),
    /// 8-byte records (height, error, radius) in a layout (see [`pack_records`]).
    Records(&'a [VertexRecord], RecordLayout),
}

/// Preprocessed refinement data borrowed from caller arrays (see [`preprocess`]).
///
/// ```
/// use relief_core::{refine::preprocess_compact, Heightfield};
/// let hf = Heightfield::new(&[0.0f32; 9], 3, 3).unwrap();
/// let mut e = [0u16; 9];
/// let h = preprocess_compact(&hf, &mut e).unwrap();
/// assert_eq!(h.bytes_per_vertex(), 2);
/// assert_eq!(h.error(1, 1), Some(0.0));
/// ```
#[derive(Debug, Clone, Copy)]
pub struct Hierarchy<'a> {
    grid: RefineGrid,
    scale: Scale,
    pub(crate) errors: ErrorStore<'a>,
    radii: Option<&'a [f32]>,
    z_min: f32,
    z_max: f32,
    /// Level-only circle radius per level (world units, rounded up, with a margin).
    level_radius: [f32; 64],
}

impl<'a> Hierarchy<'a> {
    pub(crate) fn assemble(
        grid: RefineGrid,
        scale: Scale,
        errors: ErrorStore<'a>,
        radii: Option<&'a [f32]>,
        z_min: f32,
        z_max: f32,
    ) -> Self {
        let mut level_radius = [0.0f32; 64];
        let l0 = grid.side() as f64 * 0.5 * scale.dx.max(scale.dy) as f64;
        let q = core::f64::consts::FRAC_1_SQRT_2;
        // l_i = l_0 q^i as l_0 2^-(i/2) (times q for odd i): exact powers of two, so a tile
        // embedded in a square half the size (l_0 / 2, two levels fewer) gets bit-identical radii
        // for the same half-size, and tiles decide shared vertices alike (see `tile.rs`).
        let mut even = l0;
        for (i, r) in level_radius
            .iter_mut()
            .take(grid.levels() as usize)
            .enumerate()
        {
            let li = if i % 2 == 0 { even } else { even * q };
            *r = preprocess::round_up(li / (1.0 - q) * (1.0 + preprocess::CIRCLE_MARGIN));
            if i % 2 == 1 {
                even *= 0.5;
            }
        }
        Hierarchy {
            grid,
            scale,
            errors,
            radii,
            z_min,
            z_max,
            level_radius,
        }
    }

    /// The grid and its enclosing square.
    ///
    /// ```
    /// # use relief_core::{refine::preprocess_compact, Heightfield};
    /// # let hf = Heightfield::new(&[0.0f32; 6], 3, 2).unwrap();
    /// # let mut e = [0u16; 6];
    /// let h = preprocess_compact(&hf, &mut e).unwrap();
    /// assert_eq!(h.grid().side(), 2);
    /// ```
    #[must_use]
    pub fn grid(&self) -> RefineGrid {
        self.grid
    }

    /// Bytes of preprocessed data per vertex, heights not counted: 8 (`f32` error and radius)
    /// or 2 (bfloat16 error, radius from the level); 8 for [`pack_records`]'s records, which
    /// hold the height too.
    ///
    /// ```
    /// # use relief_core::{refine::preprocess, Heightfield};
    /// # let hf = Heightfield::new(&[0.0f32; 4], 2, 2).unwrap();
    /// let (mut e, mut r) = ([0.0; 4], [0.0; 4]);
    /// assert_eq!(preprocess(&hf, &mut e, &mut r).unwrap().bytes_per_vertex(), 8);
    /// ```
    #[must_use]
    pub fn bytes_per_vertex(&self) -> usize {
        match (self.errors, self.radii) {
            (ErrorStore::F32(_), Some(_)) => 8,
            (ErrorStore::F32(_), None) => 4,
            (ErrorStore::Bf16(_), Some(_)) => 6,
            (ErrorStore::Bf16(_), None) => 2,
            (ErrorStore::Records(..), _) => 8,
        }
    }

    /// Stored (nested, rounded-up) error of vertex `(x, y)` in world z units; `+inf` for
    /// vertices that must always be in the mesh; `None` outside the grid.
    ///
    /// ```
    /// # use relief_core::{refine::preprocess, Heightfield};
    /// let hf = Heightfield::new(&[0.0f32, 0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 0.0, 0.0], 3, 3).unwrap();
    /// let (mut e, mut r) = ([0.0; 9], [0.0; 9]);
    /// let h = preprocess(&hf, &mut e, &mut r).unwrap();
    /// assert_eq!(h.error(1, 1), Some(4.0));
    /// assert_eq!(h.error(0, 0), Some(f32::INFINITY));
    /// ```
    #[must_use]
    pub fn error(&self, x: u32, y: u32) -> Option<f32> {
        if x >= self.grid.width() || y >= self.grid.height() {
            return None;
        }
        Some(self.err_at(y as usize * self.grid.width() as usize + x as usize))
    }

    /// Bounding radius of vertex `(x, y)` in world units: its sphere (full layout) or its
    /// level's circle (compact layout); `None` outside the grid or for the square's corners.
    ///
    /// ```
    /// # use relief_core::{refine::preprocess_compact, Heightfield};
    /// # let hf = Heightfield::new(&[0.0f32; 9], 3, 3).unwrap();
    /// # let mut e = [0u16; 9];
    /// let h = preprocess_compact(&hf, &mut e).unwrap();
    /// // Level 0 (the centre), l_0 = 1: r_0 = 1 / (1 - 1/sqrt 2) = 3.414...
    /// assert!((h.radius(1, 1).unwrap() - 3.41421).abs() < 1e-3);
    /// ```
    #[must_use]
    pub fn radius(&self, x: u32, y: u32) -> Option<f32> {
        if x >= self.grid.width() || y >= self.grid.height() {
            return None;
        }
        let level = self.grid.level(x, y)?;
        Some(self.radius_at(y as usize * self.grid.width() as usize + x as usize, level))
    }

    #[inline(always)]
    pub(crate) fn err_at(&self, i: usize) -> f32 {
        match self.errors {
            ErrorStore::F32(e) => e.get(i).copied().unwrap_or(f32::INFINITY),
            ErrorStore::Bf16(e) => e
                .get(i)
                .map_or(f32::INFINITY, |&c| preprocess::decode_bf16(c)),
            ErrorStore::Records(r, layout) => r
                .get(self.record_of(i, layout))
                .map_or(f32::INFINITY, |r| r.error_value()),
        }
    }

    /// The record of vertex `(x, y)` for a hierarchy of records ([`pack_records`],
    /// [`records_hierarchy`]); `None` for other layouts and outside the grid.
    ///
    /// ```
    /// use relief_core::refine::{pack_records, preprocess, records_len, RecordLayout, VertexRecord};
    /// use relief_core::Heightfield;
    /// let hf = Heightfield::new(&[0.0f32, 1.0, 2.0, 3.0], 2, 2).unwrap();
    /// let (mut e, mut r) = ([0.0; 4], [0.0; 4]);
    /// let h = preprocess(&hf, &mut e, &mut r).unwrap();
    /// assert!(h.record(1, 1).is_none());
    /// let mut rec = vec![VertexRecord::default(); records_len(2, 2, RecordLayout::Interleaved)];
    /// let p = pack_records(&h, &hf, RecordLayout::Interleaved, &mut rec).unwrap();
    /// assert_eq!(p.record(1, 1).unwrap().z, 3.0);
    /// assert!(p.record(2, 0).is_none());
    /// ```
    #[must_use]
    pub fn record(&self, x: u32, y: u32) -> Option<VertexRecord> {
        let ErrorStore::Records(r, layout) = self.errors else {
            return None;
        };
        if x >= self.grid.width() || y >= self.grid.height() {
            return None;
        }
        r.get(layout::record_index(layout, &self.grid, x as u64, y as u64))
            .copied()
    }

    /// Record index of row-major vertex `i`.
    #[inline(always)]
    fn record_of(&self, i: usize, layout: RecordLayout) -> usize {
        let w = (self.grid.width() as usize).max(1); // never 0; the max keeps a panic path out
        layout::record_index(layout, &self.grid, (i % w) as u64, (i / w) as u64)
    }

    #[inline(always)]
    pub(crate) fn radius_at(&self, i: usize, level: u32) -> f32 {
        if let ErrorStore::Records(r, layout) = self.errors {
            return r
                .get(self.record_of(i, layout))
                .map_or(f32::INFINITY, |r| r.radius_value());
        }
        match self.radii {
            Some(r) => r.get(i).copied().unwrap_or(f32::INFINITY),
            None => self
                .level_radius
                .get(level as usize)
                .copied()
                .unwrap_or(f32::INFINITY),
        }
    }

    /// The level-only circle radii, by level (used where there are no per-vertex spheres).
    pub(crate) fn level_radii(&self) -> &[f32; 64] {
        &self.level_radius
    }

    /// The per-vertex radii of the full layout, if any.
    pub(crate) fn radii(&self) -> Option<&'a [f32]> {
        self.radii
    }

    pub(crate) fn spheres(&self) -> bool {
        self.radii.is_some() || matches!(self.errors, ErrorStore::Records(..))
    }

    /// The spacing and vertical scale of the terrain the hierarchy was built from.
    ///
    /// ```
    /// # use relief_core::{refine::preprocess, Heightfield, Scale};
    /// let sc = Scale::default().with_spacing(30.0, 30.0);
    /// let hf = Heightfield::with_scale(&[0.0f32; 4], 2, 2, sc).unwrap();
    /// let (mut e, mut r) = ([0.0; 4], [0.0; 4]);
    /// assert_eq!(preprocess(&hf, &mut e, &mut r).unwrap().scale(), sc);
    /// ```
    #[must_use]
    pub fn scale(&self) -> Scale {
        self.scale
    }

    /// The 8-byte records and their layout, for a hierarchy made by
    /// [`pack_records`] or [`records_hierarchy`] (to store them, for example in a file that is
    /// memory-mapped later); `None` for the `f32` and bfloat16 layouts.
    ///
    /// ```
    /// # use relief_core::{refine::preprocess, Heightfield};
    /// let hf = Heightfield::new(&[0.0f32; 4], 2, 2).unwrap();
    /// let (mut e, mut r) = ([0.0; 4], [0.0; 4]);
    /// assert!(preprocess(&hf, &mut e, &mut r).unwrap().records().is_none());
    /// ```
    #[must_use]
    pub fn records(&self) -> Option<(&'a [VertexRecord], RecordLayout)> {
        match self.errors {
            ErrorStore::Records(r, layout) => Some((r, layout)),
            _ => None,
        }
    }

    /// The smallest and largest local height of the terrain the hierarchy was built from
    /// (world z without `z_offset`); store it beside packed records for [`records_hierarchy`].
    ///
    /// ```
    /// # use relief_core::{refine::preprocess, Heightfield};
    /// let hf = Heightfield::new(&[1.0f32, 2.0, 3.0, 4.0], 2, 2).unwrap();
    /// let (mut e, mut r) = ([0.0; 4], [0.0; 4]);
    /// assert_eq!(preprocess(&hf, &mut e, &mut r).unwrap().z_range(), (1.0, 4.0));
    /// ```
    #[must_use]
    pub fn z_range(&self) -> (f32, f32) {
        (self.z_min, self.z_max)
    }
}

/// Options of [`preprocess_with`].
///
/// ```
/// use relief_core::refine::PreprocessOptions;
/// assert!(PreprocessOptions::default().contain_diamond);
/// assert!(!PreprocessOptions::default().with_contain_diamond(false).contain_diamond);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PreprocessOptions {
    /// Make each bounding sphere contain its diamond's corners as well as its descendants'
    /// spheres (default `true`). With `false` the spheres are SOAR 2002's (descendants only):
    /// culling a finest-level vertex can then coarsen a triangle that is still in view (the
    /// culling "pop" of seed 004, chapter 5.2), which lazy culling removes.
    pub contain_diamond: bool,
}

impl Default for PreprocessOptions {
    fn default() -> Self {
        PreprocessOptions {
            contain_diamond: true,
        }
    }
}

impl PreprocessOptions {
    /// Sets [`PreprocessOptions::contain_diamond`].
    ///
    /// ```
    /// let o = relief_core::refine::PreprocessOptions::default().with_contain_diamond(false);
    /// assert!(!o.contain_diamond);
    /// ```
    #[must_use]
    pub fn with_contain_diamond(mut self, yes: bool) -> Self {
        self.contain_diamond = yes;
        self
    }
}

/// Full-layout preprocessing: `errors` and `radii` (each at least [`hierarchy_len`] long)
/// receive the nested L-infinity error (world z units, rounded up) and the nested
/// bounding-sphere radius (world units, with a relative margin of `2^-20` so that nesting holds
/// in floating point) of every vertex. 8 bytes per vertex.
///
/// Cost: about `levels * 2 * width * height` sample visits. Stack: the vertices of the four
/// finest half-sizes (1, 2, 4, 8) read their `(2h + 1)^2` neighbourhood into a stack array of
/// `f64`: the largest frame, a row of half-size 8, is about 7.2 KiB on x86-64
/// (`python3 ci/stack-frames.py target/release/relief`); the same holds for
/// [`preprocess_compact`] and the pyramid variants.
///
/// ```
/// use relief_core::{refine::preprocess, Error, Heightfield};
/// let hf = Heightfield::new(&[0.0f32; 9], 3, 3).unwrap();
/// let (mut e, mut r) = ([0.0; 9], [0.0; 8]);
/// assert_eq!(
///     preprocess(&hf, &mut e, &mut r).unwrap_err(),
///     Error::BufferTooSmall { needed: 9, actual: 8 }
/// );
/// ```
pub fn preprocess<'a, T: Terrain>(
    terrain: &T,
    errors: &'a mut [f32],
    radii: &'a mut [f32],
) -> Result<Hierarchy<'a>, Error> {
    preprocess_with(terrain, errors, radii, PreprocessOptions::default())
}

/// [`preprocess`] with options.
///
/// ```
/// use relief_core::refine::{preprocess_with, PreprocessOptions};
/// use relief_core::Heightfield;
/// let hf = Heightfield::new(&[0.0f32; 9], 3, 3).unwrap();
/// let (mut e, mut r) = ([0.0; 9], [0.0; 9]);
/// let o = PreprocessOptions::default().with_contain_diamond(false);
/// let h = preprocess_with(&hf, &mut e, &mut r, o).unwrap();
/// let r11 = h.radius(1, 1).unwrap(); // reaches the children (1 away), plus a margin
/// assert!(r11 > 1.0 && r11 < 1.00001);
/// ```
pub fn preprocess_with<'a, T: Terrain>(
    terrain: &T,
    errors: &'a mut [f32],
    radii: &'a mut [f32],
    options: PreprocessOptions,
) -> Result<Hierarchy<'a>, Error> {
    let g = preprocess::check(terrain, errors.len())?;
    preprocess::check(terrain, radii.len())?;
    preprocess::build(
        terrain,
        &g,
        &mut *errors,
        Some(&mut *radii),
        options.contain_diamond,
        None,
    );
    Ok(preprocess::finish(
        terrain,
        g,
        ErrorStore::F32(errors),
        Some(radii),
    ))
}

/// Compact-layout preprocessing: `errors` (at least [`hierarchy_len`] long) receives each
/// vertex's nested L-infinity error as a bfloat16 code rounded up (relative step `2^-7`, never
/// below the true error); bounding volumes are seed 004's level-only circles, extended over the
/// terrain's height range. 2 bytes per vertex.
///
/// ```
/// use relief_core::{refine::preprocess_compact, Heightfield};
/// let hf = Heightfield::new(&[0.0f32, 0.0, 0.0, 0.0, 3.3, 0.0, 0.0, 0.0, 0.0], 3, 3).unwrap();
/// let mut e = [0u16; 9];
/// let h = preprocess_compact(&hf, &mut e).unwrap();
/// let stored = h.error(1, 1).unwrap();
/// assert!(stored >= 3.3 && stored < 3.3 * 1.01);
/// ```
pub fn preprocess_compact<'a, T: Terrain>(
    terrain: &T,
    errors: &'a mut [u16],
) -> Result<Hierarchy<'a>, Error> {
    let g = preprocess::check(terrain, errors.len())?;
    preprocess::build(terrain, &g, &mut *errors, None, true, None);
    Ok(preprocess::finish(
        terrain,
        g,
        ErrorStore::Bf16(errors),
        None,
    ))
}
