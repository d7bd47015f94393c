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

mod greedy;
mod scan;

pub use greedy::{StopReason, Tin, TinOptions};
pub use scan::{mesh_error, MeshError};
