//! Smooth approximation of heightfields on adaptive grids with truncated Gaussian radial basis
//! functions, and the view-dependent cascades it is discretized into.
//!
//! Implements Cornel, Horváth, Waser, *Adaptive Heightfield Rendering with Complex Interpolants
//! Using Ray Casting* (2022): section 4 (the adaptive grid [`AdaptiveGrid`], the truncated
//! Gaussian of eq. 1 [`gaussian_weight`], [`InfluenceSets`], the normalised sum of eq. 2
//! [`Rbf::eval`]) and section 3 (cascade fitting with logarithmic splits and texel snapping,
//! [`fit_cascades`]), plus a CPU discretization into the cascade rasters ([`discretize`]), the
//! reference for a GPU pass.
//!
//! Coordinates: cells, influence radii and evaluation points are in *sample coordinates*
//! (grid units, spacing 1 on both axes; sample `(x, y)` at `(x, y)`). Cascade fitting works in
//! world units (`x * dx`, `y * dy`) with the [`Camera`](crate::Camera) and hands back texel
//! positions in sample coordinates.
//!
//! Pipeline, every buffer from the caller:
//! 1. [`build_adaptive_grid`] (at most [`adaptive_grid_bound`] cells) or a cell list of your own;
//! 2. [`AdaptiveGrid::new`] validates the cells and fills a `width * height` index map;
//! 3. [`InfluenceSets::build`] (sizes from [`InfluenceSets::offsets_len`] and
//!    [`InfluenceSets::entries_len`]);
//! 4. [`Rbf::eval`] at any point, or [`fit_cascades`] + [`discretize`] for the visible area.
//!
//! ```
//! use relief_core::{Heightfield, rbf::*};
//! let h: Vec<f32> = (0..64).map(|i| ((i % 8) / 4) as f32).collect(); // a step
//! let hf = Heightfield::new(&h, 8, 8).unwrap();
//! let mut cells = vec![Cell::default(); adaptive_grid_bound(8, 8).unwrap()];
//! let n = build_adaptive_grid(&hf, &GridOptions::default().with_cells(1, 4), &mut cells).unwrap();
//! let mut index = vec![0; 64];
//! let grid = AdaptiveGrid::new(8, 8, &cells[..n], &mut index).unwrap();
//! let opts = RbfOptions::default();
//! let mut offsets = vec![0; InfluenceSets::offsets_len(&grid)];
//! let mut entries = vec![0; InfluenceSets::entries_len(&grid, &opts).unwrap()];
//! let sets = InfluenceSets::build(&grid, &opts, &mut offsets, &mut entries).unwrap();
//! let rbf = Rbf::new(grid, sets, &opts).unwrap();
//! let v = rbf.eval(glam::Vec2::new(3.5, 2.0)).unwrap();
//! assert!(v > 0.0 && v < 1.0); // smooth across the step
//! ```

mod cascade;
mod discretize;
mod grid;
mod weight;

pub use cascade::{
    fit_cascades, Cascade, CascadeOptions, Cascades, GridExtent, CASCADES, MAX_POLYGON,
};
pub use discretize::discretize;
pub use grid::{
    adaptive_grid_bound, build_adaptive_grid, AdaptiveGrid, Cell, GridOptions, MAX_CELL_SIZE,
};
pub use weight::{gaussian_weight, InfluenceSets, Rbf, RbfOptions, TRUNCATION};
