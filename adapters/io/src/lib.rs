//! # relief-io
//!
//! Reading and writing the elevation formats of the project's CONVENTIONS.md, for `std` users of
//! [`relief_core`]:
//!
//! | format | [`Format`] | decoding |
//! |---|---|---|
//! | 8/16-bit grayscale PNG | `Png` | `h = value` |
//! | Mapbox Terrain-RGB PNG | `TerrainRgb` | `h = -10000 + (R*65536 + G*256 + B) * 0.1` |
//! | Terrarium PNG | `Terrarium` | `h = R*256 + G + B/256 - 32768` |
//! | GeoTIFF / TIFF, one band of u8, u16, i16, i32 or f32 | `Tiff` | `h = sample`; spacing from `ModelPixelScale`, no-data from `GDAL_NODATA` |
//! | raw little-endian f32 | `RawF32` | `h = value`; needs width and height |
//!
//! Voids (NaN, infinite, or equal to the no-data value) are an error naming the first bad sample
//! unless a [`Fill`] policy is chosen. Decoding uses the `png` and `tiff` crates; nothing is
//! hand-decoded. Every writer ([`write_raw_f32`], [`write_png16`], [`write_obj`]) writes to a
//! temporary file in the destination folder and renames it into place, so a failed or
//! interrupted run never leaves a truncated file and never destroys the previous good output.
//! [`MappedGrid`] memory-maps a raw f32 grid instead of reading it (grids larger than memory);
//! [`write_records`] and [`MappedRecords`] store and map preprocessed refinement records.
//!
//! ```no_run
//! use relief_io::{read_dem, ReadOptions};
//! use relief_core::Terrain;
//! let dem = read_dem("data/puget_sound_1k.png".as_ref(), &ReadOptions::default()).unwrap();
//! let hf = dem.heightfield().unwrap();
//! println!("{} x {}, max {}", hf.width(), hf.height(), dem.stats().max);
//! ```
#![deny(missing_docs)]

mod dem;
mod error;
mod mmap;
mod read;
mod records;
mod write;

pub use dem::{Dem, Stats};
pub use error::IoError;
pub use mmap::{HugeBuffer, MappedGrid};
pub use read::{decode_dem, read_dem, Fill, Format, ReadOptions};
pub use records::{write_records, MappedRecords};
pub use write::{write_atomic, write_obj, write_png16, write_png_rgb8, write_raw_f32};
