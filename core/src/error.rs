//! The crate's one error type.

use core::fmt;

/// Everything that can go wrong in `relief-core`.
///
/// Every variant carries enough to name the problem (the offending sample, the parameter and its
/// value, the size that was needed). No variant allocates.
///
/// ```
/// use relief_core::{Error, Heightfield};
/// let err = Heightfield::new(&[1u16, 2, 3], 2, 2).unwrap_err();
/// assert_eq!(err, Error::LengthMismatch { expected: 4, actual: 3 });
/// assert_eq!(err.to_string(), "sample count 3 does not match width x height = 4");
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum Error {
    /// The grid is smaller than 2 x 2 samples (a heightfield needs at least one cell).
    TooSmall {
        /// Columns given.
        width: u32,
        /// Rows given.
        height: u32,
    },
    /// The number of samples does not equal `width * height`.
    LengthMismatch {
        /// `width * height`.
        expected: usize,
        /// Samples given.
        actual: usize,
    },
    /// A size computation overflowed (`width * height`, or a composed grid's size).
    SizeOverflow,
    /// A scalar parameter is NaN, infinite, not positive, or outside its documented range.
    InvalidParameter {
        /// The parameter's name as in the API (`dx`, `z_scale`, ...).
        name: &'static str,
        /// The value given.
        value: f32,
    },
    /// A sample is NaN or infinite, or its world height `h * z_scale + z_offset` is outside
    /// `±MAX_ABS_HEIGHT`.
    BadSample {
        /// Column of the first bad sample.
        x: u32,
        /// Row of the first bad sample.
        y: u32,
    },
    /// A detail subdivision factor that is zero or not a power of two.
    InvalidFactor {
        /// The factor given.
        factor: u32,
    },
    /// A caller-provided buffer is too small.
    BufferTooSmall {
        /// Elements needed.
        needed: usize,
        /// Elements provided.
        actual: usize,
    },
    /// A camera that cannot be used: non-finite input, eye equal to target, or a view straight
    /// up or down (CONVENTIONS.md).
    InvalidCamera {
        /// What is wrong.
        reason: &'static str,
    },
    /// An input vector or point (a ray origin or direction, a position) is NaN or infinite, or a
    /// direction is zero.
    NonFiniteInput {
        /// Which input.
        name: &'static str,
    },
    /// A grid coordinate lies outside the heightfield.
    OutOfBounds {
        /// Column asked for.
        x: u32,
        /// Row asked for.
        y: u32,
    },
    /// An adaptive-grid cell size parameter (`min_cell`, `max_cell`) that is zero, not a power
    /// of two, above [`MAX_CELL_SIZE`](crate::rbf::MAX_CELL_SIZE), or out of order.
    InvalidCellSize {
        /// The parameter's name (`min_cell`, `max_cell`).
        name: &'static str,
        /// The value given.
        value: u32,
        /// What is wrong.
        reason: &'static str,
    },
    /// A cell of an adaptive-grid cell list that cannot be used: its size is not a power of two,
    /// it leaves the domain, it overlaps another cell, or its value is not finite.
    InvalidCell {
        /// Position of the cell in the list.
        index: usize,
        /// What is wrong.
        reason: &'static str,
    },
    /// A cell list does not tile the domain: no cell covers this sample.
    UncoveredSample {
        /// Column of the first uncovered sample.
        x: u32,
        /// Row of the first uncovered sample.
        y: u32,
    },
    /// The operation does not support this input (for example uninitialised output buffers
    /// for a list that reads its output back).
    Unsupported {
        /// What is not supported.
        what: &'static str,
    },
    /// An internal consistency check failed: a bug in `relief-core`, reported instead of a
    /// result that would break a documented guarantee.
    Internal {
        /// Which check.
        what: &'static str,
    },
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Error::TooSmall { width, height } => {
                write!(
                    f,
                    "grid of {width}x{height} samples is too small (at least 2x2)"
                )
            }
            Error::LengthMismatch { expected, actual } => write!(
                f,
                "sample count {actual} does not match width x height = {expected}"
            ),
            Error::SizeOverflow => f.write_str("grid size overflows"),
            Error::InvalidParameter { name, value } => {
                write!(
                    f,
                    "invalid {name}: {value} (must be finite, positive and in range)"
                )
            }
            Error::BadSample { x, y } => {
                write!(f, "sample at x={x}, y={y} is NaN, infinite or out of range")
            }
            Error::InvalidFactor { factor } => write!(
                f,
                "detail factor {factor} is not a power of two of at least 1"
            ),
            Error::BufferTooSmall { needed, actual } => {
                write!(f, "buffer holds {actual} elements, {needed} needed")
            }
            Error::InvalidCamera { reason } => write!(f, "invalid camera: {reason}"),
            Error::NonFiniteInput { name } => {
                write!(f, "{name} is NaN, infinite, zero or out of range")
            }
            Error::OutOfBounds { x, y } => {
                write!(f, "grid coordinate ({x}, {y}) is outside the heightfield")
            }
            Error::InvalidCellSize {
                name,
                value,
                reason,
            } => write!(f, "invalid {name}: {value} ({reason})"),
            Error::InvalidCell { index, reason } => write!(f, "invalid cell {index}: {reason}"),
            Error::UncoveredSample { x, y } => {
                write!(
                    f,
                    "no cell covers sample ({x}, {y}): the cells do not tile the domain"
                )
            }
            Error::Unsupported { what } => write!(f, "not supported: {what}"),
            Error::Internal { what } => {
                write!(f, "internal check failed (a bug in relief-core): {what}")
            }
        }
    }
}

impl core::error::Error for Error {}
