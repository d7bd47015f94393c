//! Cascade fitting (Cornel, Horváth, Waser 2022, section 3, after Zhang et al.'s parallel-split
//! shadow maps): the potentially visible ground area is split into three cascades at logarithmic
//! distances, each fitted into a square raster whose texels sit on a fixed lattice so that a
//! moving camera does not move sample positions.
//!
//! Steps, as in the paper: the view frustum is intersected with the heightfield's bounding box;
//! the intersection's vertices are projected to the ground and their convex hull taken. Offsets
//! along the normalised ground projection `v` of the view vector are measured from the eye's
//! ground position; the hull's lowest and highest offsets are `n` and `f`, split at
//! `n (f/n)^(1/3)` and `n (f/n)^(2/3)` (with `n` raised to `max(n, f / 1000)` for the split
//! formula when the hull reaches behind or below the eye). Cascade `k` is the hull clipped to
//! `[near_k, far_k]`; the far planes of cascades 0 and 1 are pushed out by `overlap` of their
//! depth so adjacent polygons intersect, and a blending weight ramps linearly across each
//! overlap (the two weights sum to one there).
//!
//! Snapping: each polygon's bounding box, in sample coordinates, is widened outwards to multiples
//! of the grid's minimum cell size. The raster's texel spacing `delta` is a power of two (in grid
//! units, between `2^-16` and `2^20`), and texel `(0, 0)` sits on the lattice `delta * Z^2`;
//! the raster's own box has texel *centres* on its four corners and contains the widened box
//! (whose corners are texel centres too whenever `delta` is at most the minimum cell size).
//! Because `delta` is a power of two and every texel centre an integer multiple of it, sample
//! positions lie on one global lattice and a camera move shifts the raster by whole texels. A
//! fresh fit takes the smallest `delta` that covers the widened box grown by one minimum cell
//! plus `headroom` texels on every side; with the previous frame's fit passed in, its
//! spacing is kept while it still covers the box and is at most twice the fresh choice
//! (hysteresis). The spacing then changes only after the box has outgrown the headroom or
//! shrunk to about a quarter, which a sub-texel camera move does not do. (Deviation from the
//! paper, which scales the widened box into the texture exactly: quantising the spacing trades
//! up to half the texture's resolution for positions that never drift; see HARD_CASES.md.)
//!
//! Visible texels: a texel is visible when its centre lies inside the cascade polygon expanded
//! by one texel diagonal, so every bilinear patch touching the polygon has all four corners.

use super::grid::AdaptiveGrid;
use crate::{Camera, Error, Scale};
use glam::{DVec2, DVec3, Vec2};

/// Number of cascades (seed 002 uses three).
///
/// ```
/// assert_eq!(relief_core::rbf::CASCADES, 3);
/// ```
pub const CASCADES: usize = 3;

/// Most vertices a cascade polygon can have.
///
/// ```
/// assert!(relief_core::rbf::MAX_POLYGON >= 22);
/// ```
pub const MAX_POLYGON: usize = MAX_CANDIDATES + 2;

/// Most candidate vertices of the frustum-box intersection: 8 + 8 corners, 72 + 72 edge-plane
/// crossings.
const MAX_CANDIDATES: usize = 160;

/// Range of texel spacings, as powers of two of grid units.
const SPACING_EXP: (i32, i32) = (-16, 20);

/// Options of [`fit_cascades`].
///
/// Defaults: `resolution = 1024` texels per side, `overlap = 0.05` (far planes of the first two
/// cascades pushed out by 5 % of their depth), `near = None` (the frustum's near plane at
/// `far / 1000`; `far` is always the distance along the view to the farthest corner of the
/// heightfield's bounding box), `headroom = 32` (a fresh fit leaves one minimum cell plus 32
/// texels spare on every side).
///
/// ```
/// use relief_core::rbf::CascadeOptions;
/// let o = CascadeOptions::default().with_resolution(512).with_overlap(0.1).with_near(2.0);
/// assert_eq!((o.resolution, o.overlap, o.near), (512, 0.1, Some(2.0)));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CascadeOptions {
    /// Texels per side of each square raster, in `[2, 16384]` (default 1024).
    pub resolution: u32,
    /// Overlap between adjacent cascades as a fraction of the nearer one's depth, in `[0, 1]`
    /// (default 0.05).
    pub overlap: f32,
    /// Near plane distance of the frustum in world units (default `None`: `far / 1000`).
    pub near: Option<f32>,
    /// Spare texels a fresh fit leaves on every side of each cascade box, beyond one minimum
    /// cell, so that small camera moves do not outgrow the raster (default 32; at most
    /// `resolution / 8` is used).
    pub headroom: u32,
}

impl Default for CascadeOptions {
    fn default() -> Self {
        CascadeOptions {
            resolution: 1024,
            overlap: 0.05,
            near: None,
            headroom: 32,
        }
    }
}

impl CascadeOptions {
    /// Returns the options with `resolution` texels per side (default 1024).
    ///
    /// ```
    /// assert_eq!(relief_core::rbf::CascadeOptions::default().with_resolution(64).resolution, 64);
    /// ```
    #[must_use]
    pub fn with_resolution(mut self, resolution: u32) -> Self {
        self.resolution = resolution;
        self
    }

    /// Returns the options with `overlap` (default 0.05).
    ///
    /// ```
    /// assert_eq!(relief_core::rbf::CascadeOptions::default().with_overlap(0.2).overlap, 0.2);
    /// ```
    #[must_use]
    pub fn with_overlap(mut self, overlap: f32) -> Self {
        self.overlap = overlap;
        self
    }

    /// Returns the options with the frustum's near plane at `near` world units (default: a
    /// thousandth of the far plane).
    ///
    /// ```
    /// assert_eq!(relief_core::rbf::CascadeOptions::default().with_near(0.5).near, Some(0.5));
    /// ```
    #[must_use]
    pub fn with_near(mut self, near: f32) -> Self {
        self.near = Some(near);
        self
    }

    /// Returns the options with `headroom` spare texels per side (default 32).
    ///
    /// ```
    /// assert_eq!(relief_core::rbf::CascadeOptions::default().with_headroom(8).headroom, 8);
    /// ```
    #[must_use]
    pub fn with_headroom(mut self, headroom: u32) -> Self {
        self.headroom = headroom;
        self
    }

    fn validate(&self) -> Result<(), Error> {
        if !(2..=16384).contains(&self.resolution) {
            return Err(Error::InvalidParameter {
                name: "resolution",
                value: self.resolution as f32,
            });
        }
        if !(self.overlap.is_finite() && (0.0..=1.0).contains(&self.overlap)) {
            return Err(Error::InvalidParameter {
                name: "overlap",
                value: self.overlap,
            });
        }
        if let Some(n) = self.near {
            if !(n.is_finite() && n > 0.0) {
                return Err(Error::InvalidParameter {
                    name: "near",
                    value: n,
                });
            }
        }
        Ok(())
    }
}

/// One cascade: a convex ground polygon (world units) and the square raster fitted to it.
///
/// Texel `(i, j)` (column `i`, row `j`, both in `0..resolution`) has its centre at sample
/// coordinates `((origin[0] + i) * spacing, (origin[1] + j) * spacing)`; row `j` runs along +y.
///
/// ```
/// # use relief_core::{Camera, Scale, rbf::*};
/// # let cells = [Cell::new(0, 0, 64, 0.0)];
/// # let mut index = vec![0; 64 * 64];
/// # let grid = AdaptiveGrid::new(64, 64, &cells, &mut index).unwrap();
/// # let cam = Camera::new(glam::Vec3::new(-10.0, 30.0, 20.0), glam::Vec3::new(30.0, 30.0, 0.0), 60.0, 64, 64).unwrap();
/// let c = fit_cascades(&cam, &grid, &Scale::default(), (0.0, 1.0), &CascadeOptions::default().with_resolution(32), None).unwrap();
/// let k = &c.cascades[0];
/// let p = k.texel_center(3, 4);
/// assert_eq!(p, glam::Vec2::new((k.origin[0] + 3) as f32 * k.spacing, (k.origin[1] + 4) as f32 * k.spacing));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cascade {
    /// Texel spacing in grid units, a power of two.
    pub spacing: f32,
    /// Lattice index of texel `(0, 0)`.
    pub origin: [i64; 2],
    /// Texels per side.
    pub resolution: u32,
    /// Lowest offset along the projected view vector covered (world units from the eye's
    /// ground position).
    pub near: f32,
    /// Highest offset covered, overlap included.
    pub far: f32,
    /// Offsets over which the weight ramps up from 0 to 1 (empty for the first cascade).
    pub fade_in: [f32; 2],
    /// Offsets over which the weight ramps down from 1 to 0 (empty for the last cascade).
    pub fade_out: [f32; 2],
    polygon: [Vec2; MAX_POLYGON],
    polygon_len: usize,
    eye: Vec2,
    view: Vec2,
    dx: f32,
    dy: f32,
}

impl Cascade {
    /// The cascade polygon, counter-clockwise, in world units (empty when nothing is visible).
    ///
    /// ```
    /// # use relief_core::{Camera, Scale, rbf::*};
    /// # let cells = [Cell::new(0, 0, 64, 0.0)];
    /// # let mut index = vec![0; 64 * 64];
    /// # let grid = AdaptiveGrid::new(64, 64, &cells, &mut index).unwrap();
    /// # let cam = Camera::new(glam::Vec3::new(-10.0, 30.0, 20.0), glam::Vec3::new(30.0, 30.0, 0.0), 60.0, 64, 64).unwrap();
    /// let c = fit_cascades(&cam, &grid, &Scale::default(), (0.0, 1.0), &CascadeOptions::default(), None).unwrap();
    /// assert!(c.cascades.iter().all(|k| k.polygon().len() >= 3));
    /// ```
    #[must_use]
    pub fn polygon(&self) -> &[Vec2] {
        self.polygon.get(..self.polygon_len).unwrap_or(&[])
    }

    /// Centre of texel `(i, j)` in sample coordinates.
    ///
    /// ```
    /// # use relief_core::{Camera, Scale, rbf::*};
    /// # let cells = [Cell::new(0, 0, 64, 0.0)];
    /// # let mut index = vec![0; 64 * 64];
    /// # let grid = AdaptiveGrid::new(64, 64, &cells, &mut index).unwrap();
    /// # let cam = Camera::new(glam::Vec3::new(-10.0, 30.0, 20.0), glam::Vec3::new(30.0, 30.0, 0.0), 60.0, 64, 64).unwrap();
    /// let c = fit_cascades(&cam, &grid, &Scale::default(), (0.0, 1.0), &CascadeOptions::default(), None).unwrap();
    /// let k = &c.cascades[2];
    /// assert_eq!(k.texel_center(1, 0).x - k.texel_center(0, 0).x, k.spacing);
    /// ```
    #[must_use]
    pub fn texel_center(&self, i: u32, j: u32) -> Vec2 {
        let d = f64::from(self.spacing);
        Vec2::new(
            (self.origin[0].saturating_add(i64::from(i)) as f64 * d) as f32,
            (self.origin[1].saturating_add(i64::from(j)) as f64 * d) as f32,
        )
    }

    /// Offset of a world ground point along the projected view vector, from the eye's ground
    /// position.
    fn offset(&self, q: Vec2) -> f32 {
        (q - self.eye).dot(self.view)
    }

    /// Blending weight of this cascade at texel `(i, j)`: 1 inside, ramping linearly to 0
    /// across the overlaps with the neighbouring cascades. Where two cascades overlap their
    /// weights sum to one.
    ///
    /// ```
    /// # use relief_core::{Camera, Scale, rbf::*};
    /// # let cells = [Cell::new(0, 0, 64, 0.0)];
    /// # let mut index = vec![0; 64 * 64];
    /// # let grid = AdaptiveGrid::new(64, 64, &cells, &mut index).unwrap();
    /// # let cam = Camera::new(glam::Vec3::new(-10.0, 30.0, 20.0), glam::Vec3::new(30.0, 30.0, 0.0), 60.0, 64, 64).unwrap();
    /// let c = fit_cascades(&cam, &grid, &Scale::default(), (0.0, 1.0), &CascadeOptions::default(), None).unwrap();
    /// let w = c.cascades[1].blend_weight(10, 10);
    /// assert!((0.0..=1.0).contains(&w));
    /// ```
    #[must_use]
    pub fn blend_weight(&self, i: u32, j: u32) -> f32 {
        let p = self.texel_center(i, j);
        self.blend_weight_at_offset(self.offset(Vec2::new(p.x * self.dx, p.y * self.dy)))
    }

    /// Blending weight at an offset along the projected view vector.
    fn blend_weight_at_offset(&self, o: f32) -> f32 {
        let ramp = |a: f32, b: f32| {
            if b > a {
                ((o - a) / (b - a)).clamp(0.0, 1.0)
            } else if o >= a {
                1.0
            } else {
                0.0
            }
        };
        let up = if self.fade_in[1] > self.fade_in[0] {
            ramp(self.fade_in[0], self.fade_in[1])
        } else {
            1.0
        };
        let down = if self.fade_out[1] > self.fade_out[0] {
            1.0 - ramp(self.fade_out[0], self.fade_out[1])
        } else {
            1.0
        };
        let w = up * down;
        if w.is_finite() {
            w
        } else {
            0.0
        }
    }

    /// Writes the visible-texel mask (`resolution^2` entries, row-major, 1 visible, 0 not) into
    /// `mask` and returns the number of visible texels. A texel is visible when its centre lies
    /// within one texel diagonal of the cascade polygon. [`Error::BufferTooSmall`] when `mask`
    /// is too short.
    ///
    /// ```
    /// # use relief_core::{Camera, Scale, rbf::*};
    /// # let cells = [Cell::new(0, 0, 64, 0.0)];
    /// # let mut index = vec![0; 64 * 64];
    /// # let grid = AdaptiveGrid::new(64, 64, &cells, &mut index).unwrap();
    /// # let cam = Camera::new(glam::Vec3::new(-10.0, 30.0, 20.0), glam::Vec3::new(30.0, 30.0, 0.0), 60.0, 64, 64).unwrap();
    /// let c = fit_cascades(&cam, &grid, &Scale::default(), (0.0, 1.0), &CascadeOptions::default().with_resolution(64), None).unwrap();
    /// let mut mask = vec![0u8; 64 * 64];
    /// let n = c.cascades[0].mask(&mut mask).unwrap();
    /// assert!(n > 0 && n < 64 * 64);
    /// ```
    pub fn mask(&self, mask: &mut [u8]) -> Result<usize, Error> {
        let t = self.resolution as usize;
        let n = t.checked_mul(t).ok_or(Error::SizeOverflow)?;
        if t == 0 {
            return Ok(0);
        }
        let actual = mask.len();
        let mask = mask
            .get_mut(..n)
            .ok_or(Error::BufferTooSmall { needed: n, actual })?;
        let margin = self.mask_margin();
        let s = self.world_spacing();
        // The edges once per mask, not once per texel (a square root each).
        let mut edges = [(Vec2::ZERO, Vec2::ZERO, 0.0f32); MAX_POLYGON];
        let mut n = 0;
        for (slot, edge) in edges.iter_mut().zip(self.mask_edges()) {
            *slot = edge;
            n += 1;
        }
        let edges = edges.get(..n).unwrap_or(&[]);
        let mut count = 0;
        for (j, row) in mask.chunks_exact_mut(t).enumerate() {
            for (i, m) in row.iter_mut().enumerate() {
                let q = self.texel_center(i as u32, j as u32) * s;
                let inside = n >= 3
                    && edges
                        .iter()
                        .all(|&(a, e, len)| !(len > 0.0 && e.perp_dot(q - a) / len < -margin));
                *m = u8::from(inside);
                count += usize::from(inside);
            }
        }
        Ok(count)
    }

    /// The margin of [`Self::mask`]'s test, in world units: one texel diagonal,
    /// `spacing * max(dx, dy) * sqrt(2)`.
    ///
    /// ```
    /// # use relief_core::{Camera, Scale, rbf::*};
    /// # let cells = [Cell::new(0, 0, 64, 0.0)];
    /// # let mut index = vec![0; 64 * 64];
    /// # let grid = AdaptiveGrid::new(64, 64, &cells, &mut index).unwrap();
    /// # let cam = Camera::new(glam::Vec3::new(-10.0, 30.0, 20.0), glam::Vec3::new(30.0, 30.0, 0.0), 60.0, 64, 64).unwrap();
    /// let c = fit_cascades(&cam, &grid, &Scale::default(), (0.0, 1.0), &CascadeOptions::default(), None).unwrap();
    /// let k = &c.cascades[1];
    /// assert_eq!(k.mask_margin(), k.spacing * core::f32::consts::SQRT_2); // dx = dy = 1
    /// ```
    #[must_use]
    pub fn mask_margin(&self) -> f32 {
        self.spacing * self.dx.max(self.dy) * core::f32::consts::SQRT_2
    }

    /// World units per grid unit in x and y (the heightfield's spacing): a texel centre
    /// ([`Self::texel_center`], grid units) times this is the point [`Self::mask`] tests.
    ///
    /// ```
    /// # use relief_core::{Camera, Scale, rbf::*};
    /// # let cells = [Cell::new(0, 0, 64, 0.0)];
    /// # let mut index = vec![0; 64 * 64];
    /// # let grid = AdaptiveGrid::new(64, 64, &cells, &mut index).unwrap();
    /// # let cam = Camera::new(glam::Vec3::new(-10.0, 30.0, 20.0), glam::Vec3::new(30.0, 30.0, 0.0), 60.0, 64, 64).unwrap();
    /// let scale = Scale::default().with_spacing(2.0, 3.0);
    /// let c = fit_cascades(&cam, &grid, &scale, (0.0, 1.0), &CascadeOptions::default(), None).unwrap();
    /// assert_eq!(c.cascades[0].world_spacing(), glam::Vec2::new(2.0, 3.0));
    /// ```
    #[must_use]
    pub fn world_spacing(&self) -> Vec2 {
        Vec2::new(self.dx, self.dy)
    }

    /// The polygon's edges as [`Self::mask`] tests them, one per vertex: the previous vertex
    /// `a`, the edge vector `e` to this vertex and its length. A texel centre `q` (world
    /// units) is visible when the polygon has at least three vertices and every edge of
    /// nonzero length has `e.perp_dot(q - a) / len >= -margin` ([`Self::mask_margin`]); a GPU
    /// pass computes the mask from these (`relief-wgpu`'s RBF pass).
    ///
    /// ```
    /// # use relief_core::{Camera, Scale, rbf::*};
    /// # let cells = [Cell::new(0, 0, 64, 0.0)];
    /// # let mut index = vec![0; 64 * 64];
    /// # let grid = AdaptiveGrid::new(64, 64, &cells, &mut index).unwrap();
    /// # let cam = Camera::new(glam::Vec3::new(-10.0, 30.0, 20.0), glam::Vec3::new(30.0, 30.0, 0.0), 60.0, 64, 64).unwrap();
    /// let c = fit_cascades(&cam, &grid, &Scale::default(), (0.0, 1.0), &CascadeOptions::default(), None).unwrap();
    /// let k = &c.cascades[0];
    /// assert_eq!(k.mask_edges().count(), k.polygon().len());
    /// let n = k.polygon().len();
    /// // Edge k starts at vertex k - 1 (the last vertex for the first edge).
    /// let starts = k.polygon().iter().cycle().skip(n - 1).take(n).copied();
    /// assert!(k.mask_edges().map(|(a, _, _)| a).eq(starts));
    /// assert!(k.mask_edges().all(|(_, e, len)| len == e.length()));
    /// ```
    pub fn mask_edges(&self) -> impl Iterator<Item = (Vec2, Vec2, f32)> + '_ {
        let poly = self.polygon();
        let last = poly.last().copied().unwrap_or(Vec2::ZERO);
        poly.iter().scan(last, |prev, &b| {
            let a = core::mem::replace(prev, b);
            let e = b - a;
            Some((a, e, e.length()))
        })
    }
}

/// The three cascades of a view, with the split distances.
///
/// ```
/// # use relief_core::{Camera, Scale, rbf::*};
/// # let cells = [Cell::new(0, 0, 64, 0.0)];
/// # let mut index = vec![0; 64 * 64];
/// # let grid = AdaptiveGrid::new(64, 64, &cells, &mut index).unwrap();
/// let cam = Camera::new(glam::Vec3::new(-10.0, 30.0, 20.0), glam::Vec3::new(30.0, 30.0, 0.0), 60.0, 64, 64).unwrap();
/// let c = fit_cascades(&cam, &grid, &Scale::default(), (0.0, 1.0), &CascadeOptions::default(), None).unwrap();
/// assert!(c.near < c.splits[0] && c.splits[0] < c.splits[1] && c.splits[1] < c.far);
/// assert!(c.cascades[0].spacing <= c.cascades[2].spacing);
/// assert!(0.0 < c.frustum[0] && c.frustum[0] < c.frustum[1]);
/// assert_eq!(c.z_range, [0.0, 1.0]);
/// let planes = cam.frustum_planes(c.frustum[0], c.frustum[1]).unwrap();
/// let far_corner = glam::Vec4::new(63.0, 63.0, 0.0, 1.0); // inside the frustum's far plane
/// assert!(planes[5].dot(far_corner) > 0.0);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cascades {
    /// The cascades, nearest first.
    pub cascades: [Cascade; CASCADES],
    /// Lowest offset `n` of the visible hull along the projected view vector (world units).
    pub near: f32,
    /// Highest offset `f`.
    pub far: f32,
    /// The split offsets `n' (f/n')^(1/3)` and `n' (f/n')^(2/3)`, `n' = max(n, f / 1000)`.
    pub splits: [f32; 2],
    /// Whether any part of the heightfield's bounding box is in the frustum.
    pub visible: bool,
    /// Distances of the frustum's near and far planes along the view direction (world units):
    /// the hull is cut from the frustum of [`Camera::frustum_planes`]`(frustum[0], frustum[1])`.
    /// The far plane lies 1 % beyond the farthest corner of the heightfield's bounding box.
    pub frustum: [f32; 2],
    /// The lowest and highest world height of the bounding box the frustum was cut with (the
    /// `z_range` passed to [`fit_cascades`]).
    pub z_range: [f32; 2],
}

/// What [`fit_cascades`] needs of an adaptive grid: the heightfield's size in samples and the
/// smallest cell size (the snapping unit). Taken from an [`AdaptiveGrid`] once
/// (`GridExtent::from(&grid)`), it lets a renderer fit cascades every frame without keeping or
/// re-validating the grid's per-sample index.
///
/// ```
/// use relief_core::rbf::{AdaptiveGrid, Cell, GridExtent};
/// let cells = [Cell::new(0, 0, 2, 0.0), Cell::new(2, 0, 1, 0.0), Cell::new(2, 1, 1, 0.0)];
/// let mut index = [0; 6];
/// let grid = AdaptiveGrid::new(3, 2, &cells, &mut index).unwrap();
/// assert_eq!(GridExtent::from(&grid), GridExtent { width: 3, height: 2, min_cell: 1 });
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GridExtent {
    /// Samples per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Smallest cell size present, in samples (0 is read as 1).
    pub min_cell: u32,
}

impl From<&AdaptiveGrid<'_>> for GridExtent {
    fn from(grid: &AdaptiveGrid<'_>) -> GridExtent {
        GridExtent {
            width: grid.width(),
            height: grid.height(),
            min_cell: grid.size_range().0,
        }
    }
}

/// Fits the three cascades of `camera` over the heightfield described by `grid` (an
/// [`AdaptiveGrid`] or its [`GridExtent`]: its size and minimum cell size), `scale` (spacing)
/// and `z_range` (lowest and highest world height).
/// `previous`, the last frame's fit, enables spacing hysteresis (module docs).
///
/// Errors: [`Error::InvalidParameter`] for bad options, a non-finite or reversed `z_range`, or a
/// bad `scale`; [`Error::TooSmall`] for a grid under 2 x 2. A camera that sees none of the box
/// gives `visible == false` and empty polygons.
///
/// ```
/// use relief_core::{Camera, Scale, rbf::*};
/// let cells = [Cell::new(0, 0, 64, 0.0)];
/// let mut index = vec![0; 64 * 64];
/// let grid = AdaptiveGrid::new(64, 64, &cells, &mut index).unwrap();
/// let cam = Camera::new(glam::Vec3::new(-10.0, 30.0, 20.0), glam::Vec3::new(30.0, 30.0, 0.0), 60.0, 64, 64).unwrap();
/// let c = fit_cascades(&cam, &grid, &Scale::default(), (0.0, 1.0), &CascadeOptions::default(), None).unwrap();
/// assert!(c.visible);
/// let away = Camera::new(glam::Vec3::new(-10.0, 30.0, 20.0), glam::Vec3::new(-50.0, 30.0, 20.0), 60.0, 64, 64).unwrap();
/// assert!(!fit_cascades(&away, &grid, &Scale::default(), (0.0, 1.0), &CascadeOptions::default(), None).unwrap().visible);
/// ```
pub fn fit_cascades(
    camera: &Camera,
    grid: impl Into<GridExtent>,
    scale: &Scale,
    z_range: (f32, f32),
    options: &CascadeOptions,
    previous: Option<&Cascades>,
) -> Result<Cascades, Error> {
    options.validate()?;
    scale.validate()?;
    let grid: GridExtent = grid.into();
    let (w, h) = (grid.width, grid.height);
    if w < 2 || h < 2 {
        return Err(Error::TooSmall {
            width: w,
            height: h,
        });
    }
    let (z0, z1) = z_range;
    if !(z0.is_finite() && z1.is_finite() && z0 <= z1) {
        return Err(Error::InvalidParameter {
            name: "z_range",
            value: if z0.is_finite() { z1 } else { z0 },
        });
    }
    let lo = DVec3::new(0.0, 0.0, f64::from(z0));
    let hi = DVec3::new(
        f64::from(w - 1) * f64::from(scale.dx),
        f64::from(h - 1) * f64::from(scale.dy),
        f64::from(z1),
    );
    let eye = camera.eye.as_dvec3();
    let (f3, r3, u3) = camera.basis();
    let (f3, r3, u3) = (f3.as_dvec3(), r3.as_dvec3(), u3.as_dvec3());
    let view = DVec2::new(f3.x, f3.y).normalize_or(DVec2::X);
    let eye2 = DVec2::new(eye.x, eye.y);
    let min_cell = f64::from(grid.min_cell.max(1));

    // Frustum: far plane at the farthest box corner, near as chosen.
    let box_corners = corners(lo, hi);
    let far_d = box_corners
        .iter()
        .map(|c| (*c - eye).dot(f3))
        .fold(f64::NEG_INFINITY, f64::max)
        * 1.01;
    let near_d = options.near.map_or(far_d * 1e-3, f64::from);
    let empty = |visible| Cascades {
        cascades: [empty_cascade(options.resolution, eye2, view, scale); CASCADES],
        near: 0.0,
        far: 0.0,
        splits: [0.0; 2],
        visible,
        frustum: [near_d as f32, far_d as f32],
        z_range: [z0, z1],
    };
    if !(far_d > near_d && near_d > 0.0) {
        return Ok(empty(false));
    }
    let mut hull = [DVec2::ZERO; MAX_CANDIDATES + 1];
    let hull_len = visible_hull(camera, eye, (f3, r3, u3), near_d, far_d, lo, hi, &mut hull);
    let hull = hull.get(..hull_len).unwrap_or(&[]);
    if hull.len() < 3 {
        return Ok(empty(false));
    }
    let off = |q: DVec2| (q - eye2).dot(view);
    let n = hull.iter().map(|&q| off(q)).fold(f64::INFINITY, f64::min);
    let f = hull
        .iter()
        .map(|&q| off(q))
        .fold(f64::NEG_INFINITY, f64::max);
    let n_log = n.max(f * 1e-3).max(f64::MIN_POSITIVE);
    let (s1, s2) = if f > n_log {
        let ratio = f / n_log;
        (
            n_log * libm::pow(ratio, 1.0 / 3.0),
            n_log * libm::pow(ratio, 2.0 / 3.0),
        )
    } else {
        let d = (f - n) / 3.0;
        (n + d, n + 2.0 * d)
    };
    let ov = f64::from(options.overlap);
    let ranges = [
        (n, s1, s1 + ov * (s1 - n)),
        (s1, s2, s2 + ov * (s2 - s1)),
        (s2, f, f),
    ];
    let mut out = empty(true);
    out.near = n as f32;
    out.far = f as f32;
    out.splits = [s1 as f32, s2 as f32];
    for (k, (c, &(a, split, b))) in out.cascades.iter_mut().zip(ranges.iter()).enumerate() {
        let mut poly = [DVec2::ZERO; MAX_CANDIDATES + 2];
        let mut len = clip(hull, &mut poly, view, eye2, a, 1.0);
        let mut tmp = [DVec2::ZERO; MAX_CANDIDATES + 2];
        len = clip(
            poly.get(..len).unwrap_or(&[]),
            &mut tmp,
            view,
            eye2,
            b,
            -1.0,
        );
        let poly = tmp.get(..len).unwrap_or(&[]);
        if poly.len() > MAX_POLYGON {
            return Err(Error::InvalidCamera {
                reason: "cascade polygon has too many vertices (degenerate view)",
            });
        }
        for (dst, src) in c.polygon.iter_mut().zip(poly) {
            *dst = src.as_vec2();
        }
        c.polygon_len = poly.len();
        c.near = a as f32;
        c.far = b as f32;
        if k > 0 {
            c.fade_in = [a as f32, ranges.get(k - 1).map_or(a, |r| r.2) as f32];
        }
        if k + 1 < CASCADES {
            c.fade_out = [split as f32, b as f32];
        }
        // Bounding box in sample coordinates, widened to multiples of the minimum cell size.
        let (mut bl, mut bh) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for q in poly {
            let g = DVec2::new(q.x / f64::from(scale.dx), q.y / f64::from(scale.dy));
            bl = bl.min(g);
            bh = bh.max(g);
        }
        if poly.is_empty() {
            continue;
        }
        bl = (bl / min_cell).floor() * min_cell;
        bh = (bh / min_cell).ceil() * min_cell;
        let prev = previous.and_then(|p| p.cascades.get(k)).map(|p| p.spacing);
        let (spacing, origin) = snap(
            bl,
            bh,
            options.resolution,
            (
                f64::from(options.headroom.min(options.resolution / 8)),
                min_cell,
            ),
            prev,
        );
        c.spacing = spacing;
        c.origin = origin;
    }
    Ok(out)
}

fn empty_cascade(resolution: u32, eye: DVec2, view: DVec2, scale: &Scale) -> Cascade {
    Cascade {
        spacing: 1.0,
        origin: [0, 0],
        resolution,
        near: 0.0,
        far: 0.0,
        fade_in: [0.0; 2],
        fade_out: [0.0; 2],
        polygon: [Vec2::ZERO; MAX_POLYGON],
        polygon_len: 0,
        eye: eye.as_vec2(),
        view: view.as_vec2(),
        dx: scale.dx,
        dy: scale.dy,
    }
}

/// Whether a raster of `t` texels with spacing `d` and texel (0, 0) at lattice index
/// `floor(bl / d)` covers `[bl, bh]` with texel centres; returns that origin.
fn fits(bl: DVec2, bh: DVec2, t: u32, d: f64) -> Option<[i64; 2]> {
    let o = (bl / d).floor();
    let last = (o + DVec2::splat(f64::from(t - 1))) * d;
    (last.x >= bh.x && last.y >= bh.y).then_some([o.x as i64, o.y as i64])
}

/// Smallest power-of-two spacing `d` (within [`SPACING_EXP`]) whose raster covers `[bl, bh]`
/// grown by `cell + headroom * d` on every side, and that raster's origin.
fn smallest_fit(bl: DVec2, bh: DVec2, t: u32, cell: f64, headroom: f64) -> (f64, [i64; 2]) {
    let extent = (bh - bl).max_element().max(0.0) + 2.0 * cell;
    let guess = libm::ceil(libm::log2(extent / f64::from(t - 1)));
    let start = if guess.is_finite() {
        (guess as i32)
            .saturating_sub(1)
            .max(SPACING_EXP.0)
            .min(SPACING_EXP.1)
    } else {
        SPACING_EXP.0
    };
    let mut best = (libm::ldexp(1.0, SPACING_EXP.1), [0i64, 0]);
    // At most SPACING_EXP.1 - SPACING_EXP.0 + 1 = 37 tries.
    for e in start..=SPACING_EXP.1 {
        let d = libm::ldexp(1.0, e);
        let g = DVec2::splat(cell + headroom * d);
        if let Some(o) = fits(bl - g, bh + g, t, d) {
            best = (d, o);
            break;
        }
    }
    best
}

/// The spacing and origin of a cascade raster for the widened box `[bl, bh]`.
///
/// A fresh fit takes the smallest power of two that covers the box grown by one minimum cell
/// plus `headroom` texels on every side (widening to whole cells makes the box jump by up to a
/// cell on a tiny move). A previous spacing is kept while it covers the box itself and is at
/// most twice the fresh choice, so the spacing changes only after the box has outgrown the
/// headroom or shrunk to about a quarter.
fn snap(
    bl: DVec2,
    bh: DVec2,
    t: u32,
    (headroom, min_cell): (f64, f64),
    previous: Option<f32>,
) -> (f32, [i64; 2]) {
    let fresh = smallest_fit(bl, bh, t, min_cell, headroom);
    let mut best = (fresh.0, fits(bl, bh, t, fresh.0).unwrap_or(fresh.1));
    if let Some(p) = previous {
        let p = f64::from(p);
        if p.is_finite() && p > 0.0 && p <= 2.0 * fresh.0 {
            if let Some(o) = fits(bl, bh, t, p) {
                best = (p, o);
            }
        }
    }
    (best.0 as f32, best.1)
}

fn corners(lo: DVec3, hi: DVec3) -> [DVec3; 8] {
    let mut c = [DVec3::ZERO; 8];
    for (k, p) in c.iter_mut().enumerate() {
        *p = DVec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        );
    }
    c
}

/// The twelve edges of a box (or frustum) given by corners indexed as in [`corners`]: bit 0 is
/// x (or horizontal), bit 1 y (or vertical), bit 2 z (or near/far).
const EDGES: [(usize, usize); 12] = [
    (0, 1),
    (2, 3),
    (4, 5),
    (6, 7),
    (0, 2),
    (1, 3),
    (4, 6),
    (5, 7),
    (0, 4),
    (1, 5),
    (2, 6),
    (3, 7),
];

/// Convex hull, counter-clockwise, of the ground projection of the frustum-box intersection
/// vertices; returns its length in `out`.
#[allow(clippy::too_many_arguments)]
fn visible_hull(
    camera: &Camera,
    eye: DVec3,
    (f, r, u): (DVec3, DVec3, DVec3),
    near: f64,
    far: f64,
    lo: DVec3,
    hi: DVec3,
    out: &mut [DVec2; MAX_CANDIDATES + 1],
) -> usize {
    let s = f64::from(camera.tan_half_fov());
    let a = f64::from(camera.width) / f64::from(camera.height);
    // Frustum corners: bit 0 right, bit 1 up, bit 2 far.
    let mut fc = [DVec3::ZERO; 8];
    for (k, p) in fc.iter_mut().enumerate() {
        let sx = if k & 1 == 0 { -1.0 } else { 1.0 };
        let sy = if k & 2 == 0 { -1.0 } else { 1.0 };
        let d = if k & 4 == 0 { near } else { far };
        *p = eye + d * (f + sx * a * s * r + sy * s * u);
    }
    // Inward planes (n, c) with n . p + c >= 0 inside.
    let dir = |k: usize| fc.get(k | 4).copied().unwrap_or(eye) - eye;
    let side = |k0: usize, k1: usize| {
        let mut n = dir(k0).cross(dir(k1)).normalize_or_zero();
        if n.dot(f) < 0.0 {
            n = -n;
        }
        (n, -n.dot(eye))
    };
    let planes = [
        side(0, 2), // left
        side(1, 3), // right
        side(0, 1), // bottom
        side(2, 3), // top
        (f, -f.dot(eye + near * f)),
        (-f, f.dot(eye + far * f)),
    ];
    let scale = (hi - lo).length() + (eye - (lo + hi) * 0.5).length() + far;
    let eps = scale * 1e-9;
    let in_frustum = |p: DVec3| planes.iter().all(|(n, c)| n.dot(p) + c >= -eps);
    let in_box =
        |p: DVec3| p.cmpge(lo - DVec3::splat(eps)).all() && p.cmple(hi + DVec3::splat(eps)).all();
    let bc = corners(lo, hi);
    let mut pts = [DVec2::ZERO; MAX_CANDIDATES];
    let mut len = 0usize;
    let mut push = |p: DVec3| {
        if let Some(slot) = pts.get_mut(len) {
            *slot = DVec2::new(p.x, p.y);
            len += 1;
        }
    };
    for &p in &bc {
        if in_frustum(p) {
            push(p);
        }
    }
    for &p in &fc {
        if in_box(p) {
            push(p);
        }
    }
    for &(i, j) in &EDGES {
        let (Some(&p), Some(&q)) = (bc.get(i), bc.get(j)) else {
            continue;
        };
        for (n, c) in &planes {
            let (dp, dq) = (n.dot(p) + c, n.dot(q) + c);
            if (dp < 0.0) != (dq < 0.0) && dp != dq {
                let x = p + (q - p) * (dp / (dp - dq));
                if in_frustum(x) {
                    push(x);
                }
            }
        }
    }
    for &(i, j) in &EDGES {
        let (Some(&p), Some(&q)) = (fc.get(i), fc.get(j)) else {
            continue;
        };
        let (pa, qa) = (p.to_array(), q.to_array());
        let axes = lo
            .to_array()
            .into_iter()
            .zip(hi.to_array())
            .zip(pa.into_iter().zip(qa));
        for ((l, h), (pc, qc)) in axes {
            for bound in [l, h] {
                let (dp, dq) = (pc - bound, qc - bound);
                if (dp < 0.0) != (dq < 0.0) && dp != dq {
                    let x = p + (q - p) * (dp / (dp - dq));
                    if in_box(x) {
                        push(x);
                    }
                }
            }
        }
    }
    // Merge near-duplicates (the same vertex found as a corner and as a crossing), so that the
    // hull can use an exact turn test: a tolerance on the turn would drop extreme points of
    // nearly collinear runs whose sort order rounding has flipped (measured: the far box corner
    // vanished for one camera and reappeared 0.4 units away).
    let tol2 = (scale * 1e-9) * (scale * 1e-9);
    let mut unique = 0usize;
    for k in 0..len {
        let Some(&p) = pts.get(k) else { break };
        let seen = pts
            .get(..unique)
            .is_some_and(|u| u.iter().any(|q| q.distance_squared(p) <= tol2));
        if !seen {
            if let Some(slot) = pts.get_mut(unique) {
                *slot = p;
                unique += 1;
            }
        }
    }
    let pts = pts.get_mut(..unique).unwrap_or(&mut []);
    convex_hull(pts, out)
}

/// Andrew's monotone chain: counter-clockwise hull, popping points that do not turn left
/// (exact test, no tolerance). Returns the hull length written to `out`.
fn convex_hull(pts: &mut [DVec2], out: &mut [DVec2; MAX_CANDIDATES + 1]) -> usize {
    // Insertion sort by (x, y): at most MAX_CANDIDATES^2 / 2 steps, and unlike the standard
    // sorts it has no panic path for the compiler to keep.
    for k in 1..pts.len() {
        let mut m = k;
        while m > 0 {
            let (Some(a), Some(b)) = (pts.get(m - 1), pts.get(m)) else {
                break;
            };
            if a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)).is_gt() {
                pts.swap(m - 1, m);
                m -= 1;
            } else {
                break;
            }
        }
    }
    if pts.len() < 3 {
        return 0;
    }
    let cross = |o: DVec2, a: DVec2, b: DVec2| (a - o).perp_dot(b - o);
    let mut k = 0usize;
    // Lower hull left to right, then upper hull right to left; every point is pushed once per
    // pass and popped at most once, so each pass takes at most 2 * len steps.
    let lower = pts.iter();
    let upper = pts.iter().rev().skip(1);
    let mut floor = 2usize;
    for (pass, p) in lower.map(|p| (0, p)).chain(upper.map(|p| (1, p))) {
        if pass == 1 && floor == 2 {
            // Upper hull must not pop the lower hull: keep at least its points plus one.
            floor = k + 1;
        }
        while k >= floor {
            let (Some(&o), Some(&a)) = (out.get(k - 2), out.get(k - 1)) else {
                break;
            };
            if cross(o, a, *p) <= 0.0 {
                k -= 1;
            } else {
                break;
            }
        }
        if let Some(slot) = out.get_mut(k) {
            *slot = *p;
            k += 1;
        }
    }
    // The last point repeats the first.
    k.saturating_sub(1)
}

/// Sutherland-Hodgman clip of a convex polygon by the half-plane `sign * (offset(q) - at) >= 0`.
fn clip(
    poly: &[DVec2],
    out: &mut [DVec2; MAX_CANDIDATES + 2],
    view: DVec2,
    eye: DVec2,
    at: f64,
    sign: f64,
) -> usize {
    let d = |q: DVec2| sign * ((q - eye).dot(view) - at);
    let mut len = 0usize;
    let Some(&last) = poly.last() else { return 0 };
    let mut prev = last;
    let mut push = |q: DVec2| {
        if let Some(slot) = out.get_mut(len) {
            *slot = q;
            len += 1;
        }
    };
    for &q in poly {
        let (dp, dq) = (d(prev), d(q));
        if dq >= 0.0 {
            if dp < 0.0 {
                push(prev + (q - prev) * (dp / (dp - dq)));
            }
            push(q);
        } else if dp >= 0.0 {
            push(prev + (q - prev) * (dp / (dp - dq)));
        }
        prev = q;
    }
    len
}
