//! Cross-crate tests live in `tests/tests/`.
#![deny(missing_docs)]

pub mod fixtures;
pub mod mesh_check;
pub mod ray_check;
