//! The adapter's error type.

use std::fmt;
use std::path::PathBuf;

/// What can go wrong reading or writing elevation data. `Display` gives one line naming the
/// problem (and the file, where there is one).
///
/// ```
/// use relief_io::{decode_dem, Format, IoError, ReadOptions};
/// let opts = ReadOptions { format: Some(Format::Png), ..ReadOptions::default() };
/// let err = decode_dem(b"not a png", &opts).unwrap_err();
/// assert!(matches!(err, IoError::Decode { .. }));
/// ```
#[derive(Debug)]
#[non_exhaustive]
pub enum IoError {
    /// The file could not be opened, read or written.
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// The format is unknown, cannot be guessed, or the file's layout is not supported (colour
    /// type, band count, sample type).
    Unsupported(String),
    /// The decoder rejected the bytes (corrupt or truncated file).
    Decode {
        /// Which format was being decoded.
        format: &'static str,
        /// The decoder's message.
        message: String,
    },
    /// The data size does not match the given or implied dimensions.
    SizeMismatch {
        /// What was expected (bytes or samples, as `what` says).
        expected: u64,
        /// What was found.
        actual: u64,
        /// What was counted.
        what: &'static str,
    },
    /// A sample is NaN, infinite or the no-data value, and no fill policy was chosen.
    NoData {
        /// Column of the first bad sample.
        x: u32,
        /// Row of the first bad sample.
        y: u32,
        /// The value found there.
        value: f64,
    },
    /// Every sample is a void, so no fill policy can help.
    AllNoData,
    /// A command-line style option is invalid (for example width 0).
    InvalidOption(String),
    /// The core rejected the data.
    Core(relief_core::Error),
}

impl fmt::Display for IoError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            IoError::Io { path, source } => write!(f, "{}: {source}", path.display()),
            IoError::Unsupported(m) => write!(f, "unsupported input: {m}"),
            IoError::Decode { format, message } => {
                write!(f, "cannot decode {format}: {}", one_line(message))
            }
            IoError::SizeMismatch {
                expected,
                actual,
                what,
            } => write!(
                f,
                "size mismatch: expected {expected} {what}, found {actual}"
            ),
            IoError::NoData { x, y, value } => write!(
                f,
                "no-data sample {value} at x={x}, y={y} (choose --fill nearest or --fill min)"
            ),
            IoError::AllNoData => f.write_str("every sample is no-data"),
            IoError::InvalidOption(m) => write!(f, "invalid option: {m}"),
            IoError::Core(e) => write!(f, "{e}"),
        }
    }
}

fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

impl std::error::Error for IoError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            IoError::Io { source, .. } => Some(source),
            IoError::Core(e) => Some(e),
            _ => None,
        }
    }
}

impl From<relief_core::Error> for IoError {
    fn from(e: relief_core::Error) -> Self {
        IoError::Core(e)
    }
}
