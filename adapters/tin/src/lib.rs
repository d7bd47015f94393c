//! # relief-tin
//!
//! Greedy-insertion Delaunay TINs (triangulated irregular networks) on
//! [spade](https://docs.rs/spade)'s incremental Delaunay triangulation, to compare relief's
//! regular refinement against.
//!
//! The algorithm is Garland & Heckbert, *Fast polygonal approximation of terrains and height
//! fields*, Technical Report CMU-CS-95-181, Carnegie Mellon University (1995): greedy insertion
//! of the sample with the largest vertical error into a Delaunay triangulation, rescanning only
//! the triangles an insertion changed, with per-triangle candidates in a heap (the same algorithm
//! as `fogleman/hmm`, `mapbox/delatin` and `pydelatin`). See [`Tin::build`].
//!
//! ## Algorithm
//! Implements the optimised greedy insertion of Garland & Heckbert, *Fast polygonal approximation
//! of terrains and height fields*, CMU-CS-95-181 (1995), in its Delaunay variant (only the
//! triangles an insertion changed are rescanned; per-triangle candidates are kept in a heap), on
//! spade's incremental `DelaunayTriangulation`:
//!
//! 1. Triangulate the four corners of the domain (so the mesh covers exactly the domain).
//! 2. For every triangle, scan the grid samples it covers (exact integer rasterisation) and keep
//!    its *candidate*: the sample with the largest vertical error `|h - plane|`. Faces whose
//!    candidate is above the target live in an indexed max-heap keyed by that error; a rescanned
//!    face has its key changed in place (or leaves the heap), so no entry is ever stale.
//! 3. Pop the worst candidate, insert it into the triangulation, and rescan only the faces
//!    incident to the new vertex: Delaunay insertion (split, then Lawson flips) changes no other
//!    face, since every flip it makes creates an edge from the new vertex.
//! 4. Stop when the worst candidate's error is at most the requested error, or before a vertex or
//!    triangle budget would be exceeded.
//!
//! The error a candidate carries is the mesh vertical error of CONVENTIONS.md at that sample, in
//! world z units (`z_scale` applied; `z_offset` cancels), so when the build stops on error the
//! worst remaining candidate *is* the mesh's measured error, bit for bit equal to what
//! [`mesh_error`] reports.
//!
//! ## Comparing methods
//! [`compare_tin`] and [`compare_method`] build meshes for a list of error targets and measure
//! each (triangles, measured maximum and RMS error, build time) as [`ComparisonRow`]s; any method
//! whose vertices are grid samples plugs into [`compare_method`] as a closure.
//!
//! ## Conventions (CONVENTIONS.md of the project)
//! - Vertices are grid samples `[x, y]` (column, row); world positions are
//!   `(x * dx, y * dy, h * z_scale + z_offset)` ([`Tin::positions`]).
//! - Triangles are `[u32; 3]` vertex indices, counter-clockwise seen from +z, and tile the whole
//!   domain `[0, w-1] x [0, h-1]` with no gaps, overlaps or T-junctions.
//! - The mesh vertical error is the maximum over all grid samples of `|h - mesh(x, y)|` in world z
//!   units ([`mesh_error`]).
//!
//! ```
//! use relief_core::Heightfield;
//! use relief_tin::{Tin, TinOptions};
//! let s: Vec<f32> = (0..33 * 33).map(|i| ((i % 33) as f32 * 0.3).sin() * 10.0).collect();
//! let hf = Heightfield::new(&s, 33, 33).unwrap();
//! let tin = Tin::build(&hf, &TinOptions::default().with_max_error(0.5)).unwrap();
//! let e = tin.measure(&hf).unwrap();
//! assert!(e.max <= 0.5 && e.rms <= e.max);
//! assert!(tin.triangles().len() < 2 * 32 * 32);
//! ```
#![deny(missing_docs)]
#![deny(rustdoc::broken_intra_doc_links)]
#![forbid(unsafe_code)]

mod compare;
mod greedy;
mod heap;
mod scan;
mod shapes;

pub use compare::{compare_method, compare_tin, markdown_table, ComparisonRow, GridMesh};
pub use greedy::{StopReason, Tin, TinOptions};
pub use scan::{mesh_error, MeshError};
