//! # relief-skia
//!
//! Debug diagrams of what relief's algorithms did, drawn with
//! [tiny-skia](https://github.com/linebender/tiny-skia). Every diagram is a function that takes
//! the state computed by `relief-core` (cells visited by its DDAs, the mesh its refiner emitted,
//! the adaptive grid and cascades it fitted) and returns a [`Pixmap`]; nothing here re-runs or
//! re-implements an algorithm, it only draws what the core hands back.
//!
//! | diagram | function | reproduces |
//! |---|---|---|
//! | hillshade base, usable under every map diagram | [`hillshade`] | — (normals from [`relief_core::normal_map`]) |
//! | cell DDA vs run-length DDA | [`dda::dda`] | Henning & Stephenson 2004 (seed 001), figure 6 |
//! | adaptive cells and influence circles | [`rbf::rbf`] | Cornel et al. 2022 (seed 002), figure 2 |
//! | frustum, hull, splits, snapped cascades | [`rbf::cascades`] | seed 002, figure 1a |
//! | refined mesh by level, circles, frustum, culling | [`refine::refine`] | Balogh 2003 (seed 004), figures 5-11 |
//! | triangle strip in its order, joins between pieces | [`strip::strip`] | Balogh 2003 (seed 004), chapter 5.1; Lindstrom & Pascucci 2001 |
//! | silhouette map and partitioning-tree levels | [`silhouette::silhouette`] | Sakalauskas (seed 000), figure 9 (c)-(e) |
//!
//! Colours are the Okabe-Ito palette ([`style`]), readable with the common colour-vision
//! deficiencies, and viridis for scalar fields. Labels are set in the bundled DejaVu Sans
//! (`assets/fonts/DejaVuSans.ttf`, licence beside it) with `ab_glyph`.
//!
//! Map diagrams draw in *sample coordinates* (sample `(x, y)` at `(x, y)`), row 0 at the top,
//! like the DEM image; the DDA diagram draws the paper's frame, y up.
//!
//! ```
//! use relief_core::Heightfield;
//! let samples: Vec<f32> = (0..64).map(|i| ((i % 8) * (i / 8)) as f32).collect();
//! let hf = Heightfield::new(&samples, 8, 8).unwrap();
//! let base = relief_skia::hillshade(&hf, &relief_skia::HillshadeOptions::default()).unwrap();
//! assert_eq!((base.width(), base.height()), (8, 8));
//! let dir = tempfile::tempdir().unwrap();
//! relief_skia::save_png(&base, &dir.path().join("base.png")).unwrap();
//! ```
//!
//! ## Golden images
//! `tests/golden.rs` compares every diagram with `tests/golden/*.png` pixel by pixel (a channel
//! may differ by at most 2 of 255 on at most 0.5 % of the pixels, for rasteriser differences
//! between CPUs). Regenerate them after an intended change with
//! `RELIEF_BLESS=1 cargo test -p relief-skia --test golden` and look at the result before
//! committing.
#![deny(missing_docs)]
#![deny(rustdoc::broken_intra_doc_links)]
#![forbid(unsafe_code)]

mod canvas;
pub mod dda;
mod overlay;
pub mod rbf;
pub mod refine;
pub mod silhouette;
pub mod strip;
pub mod style;
mod text;

pub use canvas::DiagramOptions;
pub use overlay::{hillshade, HillshadeOptions};
pub use text::{draw_text, text_width};
pub use tiny_skia::Pixmap;

use std::fmt;
use std::path::Path;

/// Name of the core crate this adapter builds on.
///
/// ```
/// assert_eq!(relief_skia::CORE_CRATE, "relief-core");
/// ```
pub const CORE_CRATE: &str = "relief-core";

/// What can go wrong while drawing or saving a diagram.
///
/// ```
/// let e = relief_skia::DiagramError::from(relief_core::Error::SizeOverflow);
/// assert!(e.to_string().contains("relief-core"));
/// ```
#[derive(Debug)]
#[non_exhaustive]
pub enum DiagramError {
    /// The core rejected the input (bad ray, buffer sizes, camera ...).
    Core(relief_core::Error),
    /// Writing the PNG failed.
    Io(relief_io::IoError),
    /// PNG encoding failed.
    Png(String),
    /// The requested picture is empty or too large (`width x height` pixels).
    Size {
        /// Requested width in pixels.
        width: u32,
        /// Requested height in pixels.
        height: u32,
    },
    /// A diagram parameter is out of range.
    InvalidParameter {
        /// Which parameter.
        name: &'static str,
        /// Why.
        reason: &'static str,
    },
}

impl fmt::Display for DiagramError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DiagramError::Core(e) => write!(f, "relief-core: {e}"),
            DiagramError::Io(e) => write!(f, "{e}"),
            DiagramError::Png(e) => write!(f, "PNG encoding failed: {e}"),
            DiagramError::Size { width, height } => {
                write!(
                    f,
                    "diagram size {width} x {height} pixels is empty or too large"
                )
            }
            DiagramError::InvalidParameter { name, reason } => write!(f, "{name}: {reason}"),
        }
    }
}

impl std::error::Error for DiagramError {}

impl From<relief_core::Error> for DiagramError {
    fn from(e: relief_core::Error) -> Self {
        DiagramError::Core(e)
    }
}

impl From<relief_io::IoError> for DiagramError {
    fn from(e: relief_io::IoError) -> Self {
        DiagramError::Io(e)
    }
}

/// Encodes `pixmap` as an 8-bit RGBA PNG and writes it atomically (through
/// [`relief_io::write_atomic`]: a crash never leaves a half-written file).
///
/// ```
/// let mut p = relief_skia::Pixmap::new(4, 3).unwrap();
/// p.fill(tiny_skia::Color::WHITE);
/// let dir = tempfile::tempdir().unwrap();
/// let path = dir.path().join("p.png");
/// relief_skia::save_png(&p, &path).unwrap();
/// let back = relief_skia::Pixmap::load_png(&path).unwrap();
/// assert_eq!(back, p);
/// ```
pub fn save_png(pixmap: &Pixmap, path: &Path) -> Result<(), DiagramError> {
    let bytes = pixmap
        .encode_png()
        .map_err(|e| DiagramError::Png(e.to_string()))?;
    relief_io::write_atomic(path, |w| w.write_all(&bytes))?;
    Ok(())
}
