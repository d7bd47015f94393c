//! # relief-skia
//!
//! tiny-skia debug diagrams of what relief's algorithms did.
//!
//! This crate is a placeholder in the workspace layout: it compiles and depends on
//! `relief-core`, and its functionality is built by a later issue (see the repository's
//! issue tracker). It exports only the core's version it was built against.
//!
//! ```
//! assert_eq!(relief_skia::CORE_CRATE, "relief-core");
//! ```
#![deny(missing_docs)]

/// Name of the core crate this adapter builds on.
pub const CORE_CRATE: &str = "relief-core";
