//! # relief-core
//!
//! Terrain algorithms for engines, simulators and embedded displays: `#![no_std]`, no allocator,
//! no panics on any input. Every buffer comes from the caller, every loop has a bound the caller
//! can compute, and bad input returns a typed [`Error`].
//!
//! ## Conventions (CONVENTIONS.md of the project)
//! - A heightfield has `width` columns (x) and `height` rows (y); sample `(x, y)` is element
//!   `y * width + x` of row-major storage.
//! - Sample `(x, y)` sits at world position `(x * dx, y * dy, h * z_scale + z_offset)`; z is up,
//!   the frame right-handed. The domain is `[0, (width-1) dx] x [0, (height-1) dy]`; nothing
//!   exists outside it.
//! - Surfaces between samples: [`Surface::Triangles`] (cell split along the diagonal from
//!   `(x, y)` to `(x+1, y+1)`), [`Surface::Bilinear`], [`Surface::Nearest`].
//! - Algorithms compute in *local* heights (`h * z_scale`) and add `z_offset` at the end, so large
//!   offsets do not cost precision.
//!
//! ## What is here
//! - [`Heightfield`]: a checked view over borrowed `u8`/`u16`/`i16`/`i32`/`f32` samples.
//! - [`Composed`]: a base map plus a tiled detail map (Balogh 2003, chapter 6).
//! - [`Terrain`]: the trait both implement; surfaces, gradients, cell bounds.
//! - [`normal`], [`normal_map`], [`Composed::summed_normal`]: normals from finite differences.
//! - [`ray`]: ray traversal and intersection: cell and run-length DDA, maximum mipmaps, marching
//!   ([`RayTracer`], [`Ray`], [`Hit`]).
//! - [`silhouette`]: the silhouette map and partitioning-tree envelopes of Sakalauskas (seed 000)
//!   on the CPU, a reference for the GPU passes.
//!
//! ```
//! use relief_core::{normal, Heightfield, NormalMethod, Scale, Surface, Terrain};
//! let samples: [u16; 9] = [0, 0, 0, 0, 100, 0, 0, 0, 0];
//! let hf = Heightfield::with_scale(&samples, 3, 3, Scale::default().with_z_scale(0.1)).unwrap();
//! assert_eq!(hf.surface_height(Surface::Bilinear, 1.0, 1.0), Some(10.0));
//! let n = normal(&hf, 0, 1, NormalMethod::Central).unwrap();
//! assert!(n.x < 0.0 && n.z > 0.0); // leaning away from the bump
//! ```
#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]
#![deny(rustdoc::broken_intra_doc_links)]
#![forbid(unsafe_code)]

mod camera;
mod compose;
mod error;
mod heightfield;
mod normals;
pub mod ray;
mod sample;

pub mod rbf;
pub mod refine;
pub mod silhouette;

pub use camera::Camera;
pub use compose::Composed;
pub use error::Error;
pub use heightfield::{Heightfield, Scale, Surface, Terrain, MAX_ABS_HEIGHT, MIN_SCALE};
pub use normals::{normal, normal_from_gradient, normal_map, NormalMethod};
pub use ray::{Hit, Ray, RayTracer, Trace};
pub use rbf::{AdaptiveGrid, Cascades, InfluenceSets, Rbf};
pub use refine::{Hierarchy, RefineGrid, Refiner};
pub use sample::Sample;

pub use glam;
