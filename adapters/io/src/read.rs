//! Decoding elevation files into a [`Dem`].

use crate::{Dem, IoError};
use relief_core::Scale;
use std::collections::VecDeque;
use std::io::Cursor;
use std::path::Path;

/// Largest decoded image accepted, in bytes (keeps a hostile header from asking for more memory
/// than a machine has).
const MAX_DECODED_BYTES: usize = 4 << 30;

/// The most a file of `len` bytes can honestly decode to: deflate expands at most 1032:1 and
/// LZW at most about 2730:1 (4096 bytes per 12-bit code), so a header that claims more than
/// `4096 * len` bytes (plus slack for tiny files) lies about its size, and is rejected before any
/// buffer is allocated.
fn decoded_limit(len: usize) -> usize {
    len.saturating_mul(4096)
        .saturating_add(1 << 20)
        .min(MAX_DECODED_BYTES)
}

/// An elevation file format (CONVENTIONS.md, "Elevation input formats").
///
/// ```
/// use relief_io::Format;
/// assert_eq!(Format::from_name("terrain-rgb"), Some(Format::TerrainRgb));
/// assert_eq!(Format::from_name("jpeg"), None);
/// assert_eq!(Format::TerrainRgb.name(), "terrain-rgb");
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Format {
    /// 8- or 16-bit grayscale PNG, `h = value`.
    Png,
    /// Mapbox Terrain-RGB PNG, `h = -10000 + (R*65536 + G*256 + B) * 0.1`.
    TerrainRgb,
    /// Terrarium PNG, `h = R*256 + G + B/256 - 32768`.
    Terrarium,
    /// Single-band GeoTIFF or TIFF of u8, u16, i16, i32, f32 or f64 samples.
    Tiff,
    /// Raw little-endian f32, row-major; width and height must be given.
    RawF32,
}

impl Format {
    /// All formats, in the order the CLI lists them.
    ///
    /// ```
    /// assert_eq!(relief_io::Format::ALL.len(), 5);
    /// ```
    pub const ALL: [Format; 5] = [
        Format::Png,
        Format::TerrainRgb,
        Format::Terrarium,
        Format::Tiff,
        Format::RawF32,
    ];

    /// The format's name on the command line.
    ///
    /// ```
    /// assert_eq!(relief_io::Format::RawF32.name(), "raw-f32");
    /// ```
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Format::Png => "png",
            Format::TerrainRgb => "terrain-rgb",
            Format::Terrarium => "terrarium",
            Format::Tiff => "tiff",
            Format::RawF32 => "raw-f32",
        }
    }

    /// The format with this command-line name (`geotiff` and `tif` are accepted for `tiff`).
    ///
    /// ```
    /// assert_eq!(relief_io::Format::from_name("geotiff"), Some(relief_io::Format::Tiff));
    /// ```
    #[must_use]
    pub fn from_name(name: &str) -> Option<Format> {
        match name {
            "geotiff" | "tif" => Some(Format::Tiff),
            _ => Format::ALL.into_iter().find(|f| f.name() == name),
        }
    }

    /// Guesses the format from the file's first bytes, then its extension. A colour PNG is not
    /// guessed (Terrain-RGB and Terrarium look alike): the caller must name the format.
    ///
    /// ```
    /// use relief_io::Format;
    /// assert_eq!(Format::guess(b"II*\0rest", "a.bin".as_ref()).unwrap(), Format::Tiff);
    /// assert_eq!(Format::guess(b"\0\0\0\0", "a.f32".as_ref()).unwrap(), Format::RawF32);
    /// assert!(Format::guess(b"hello", "a.txt".as_ref()).is_err());
    /// ```
    pub fn guess(bytes: &[u8], path: &Path) -> Result<Format, IoError> {
        if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
            // Colour type is byte 25 of a well-formed PNG (IHDR first).
            return match bytes.get(25) {
                Some(0) | Some(4) => Ok(Format::Png),
                Some(2) | Some(6) | Some(3) => Err(IoError::Unsupported(
                    "colour PNG: give --format terrain-rgb or --format terrarium".into(),
                )),
                _ => Ok(Format::Png), // let the decoder report what is wrong
            };
        }
        if bytes.starts_with(b"II*\0")
            || bytes.starts_with(b"MM\0*")
            || bytes.starts_with(b"II+\0")
            || bytes.starts_with(b"MM\0+")
        {
            return Ok(Format::Tiff);
        }
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("f32") | Some("raw") | Some("bin") => Ok(Format::RawF32),
            Some("png") => Ok(Format::Png),
            Some("tif") | Some("tiff") => Ok(Format::Tiff),
            _ => Err(IoError::Unsupported(format!(
                "cannot tell the format of {}: give --format ({})",
                path.display(),
                Format::ALL.map(Format::name).join(", ")
            ))),
        }
    }
}

/// What to do with voids (NaN, infinite or no-data samples).
///
/// ```
/// assert_eq!(relief_io::Fill::from_name("nearest"), Some(relief_io::Fill::Nearest));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Fill {
    /// A void is an error naming the first bad sample (the default).
    #[default]
    Error,
    /// Each void takes the height of the nearest valid sample (4-connected grid distance,
    /// breadth-first from all valid samples at once; ties go to the sample reached first).
    Nearest,
    /// Each void takes the lowest valid height.
    Min,
}

impl Fill {
    /// The policy with this command-line name (`error`, `nearest`, `min`).
    ///
    /// ```
    /// assert_eq!(relief_io::Fill::from_name("max"), None);
    /// ```
    #[must_use]
    pub fn from_name(name: &str) -> Option<Fill> {
        match name {
            "error" | "none" => Some(Fill::Error),
            "nearest" => Some(Fill::Nearest),
            "min" => Some(Fill::Min),
            _ => None,
        }
    }
}

/// Options for [`read_dem`] and [`decode_dem`]. Defaults: guess the format, no explicit size,
/// the file's own no-data value, voids are an error.
///
/// ```
/// use relief_io::{Fill, Format, ReadOptions};
/// let o = ReadOptions { format: Some(Format::RawF32), width: Some(2), height: Some(2),
///                       fill: Fill::Min, ..ReadOptions::default() };
/// assert_eq!(o.nodata, None);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ReadOptions {
    /// The format; `None` guesses it ([`Format::guess`]).
    pub format: Option<Format>,
    /// Width, required for raw formats; if given for others it must match the file.
    pub width: Option<u32>,
    /// Height, required for raw formats; if given for others it must match the file.
    pub height: Option<u32>,
    /// No-data value; overrides the file's own (GeoTIFF `GDAL_NODATA`).
    pub nodata: Option<f64>,
    /// What to do with voids.
    pub fill: Fill,
}

/// Reads and decodes an elevation file.
///
/// ```no_run
/// let dem = relief_io::read_dem("dem.tif".as_ref(), &Default::default()).unwrap();
/// ```
pub fn read_dem(path: &Path, opts: &ReadOptions) -> Result<Dem, IoError> {
    let bytes = std::fs::read(path).map_err(|source| IoError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let format = match opts.format {
        Some(f) => f,
        None => Format::guess(&bytes, path)?,
    };
    decode_dem(
        &bytes,
        &ReadOptions {
            format: Some(format),
            ..*opts
        },
    )
}

/// Decodes elevation data from bytes in memory. With `opts.format == None` the format is guessed
/// from the bytes alone.
///
/// ```
/// use relief_io::{decode_dem, Format, ReadOptions};
/// let bytes: Vec<u8> = [1.0f32, 2.0, 3.0, 4.0].iter().flat_map(|v| v.to_le_bytes()).collect();
/// let opts = ReadOptions { format: Some(Format::RawF32), width: Some(2), height: Some(2),
///                          ..ReadOptions::default() };
/// assert_eq!(decode_dem(&bytes, &opts).unwrap().samples, vec![1.0, 2.0, 3.0, 4.0]);
/// ```
pub fn decode_dem(bytes: &[u8], opts: &ReadOptions) -> Result<Dem, IoError> {
    let format = match opts.format {
        Some(f) => f,
        None => Format::guess(bytes, Path::new(""))?,
    };
    let raw = match format {
        Format::Png | Format::TerrainRgb | Format::Terrarium => decode_png(bytes, format)?,
        Format::Tiff => decode_tiff(bytes)?,
        Format::RawF32 => decode_raw(bytes, opts)?,
    };
    for (given, found, what) in [
        (opts.width, raw.width, "columns"),
        (opts.height, raw.height, "rows"),
    ] {
        if let Some(g) = given {
            if g != found {
                return Err(IoError::SizeMismatch {
                    expected: u64::from(g),
                    actual: u64::from(found),
                    what,
                });
            }
        }
    }
    if raw.width < 2 || raw.height < 2 {
        return Err(relief_core::Error::TooSmall {
            width: raw.width,
            height: raw.height,
        }
        .into());
    }
    let nodata = opts.nodata.or(raw.nodata);
    let (samples, nodata_count) = fill_voids(raw.values, raw.width, raw.height, nodata, opts.fill)?;
    let dem = Dem {
        width: raw.width,
        height: raw.height,
        samples,
        scale: raw.scale,
        nodata_count,
    };
    dem.heightfield()?;
    Ok(dem)
}

/// Decoded values before void handling.
struct Raw {
    width: u32,
    height: u32,
    values: Vec<f64>,
    scale: Scale,
    nodata: Option<f64>,
}

fn decode_err(format: Format, e: impl std::fmt::Display) -> IoError {
    IoError::Decode {
        format: format.name(),
        message: e.to_string(),
    }
}

fn decode_png(bytes: &[u8], format: Format) -> Result<Raw, IoError> {
    let limit = decoded_limit(bytes.len());
    let mut decoder =
        png::Decoder::new_with_limits(Cursor::new(bytes), png::Limits { bytes: limit });
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().map_err(|e| decode_err(format, e))?;
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| decode_err(format, "image too large"))?;
    if size > limit {
        return Err(decode_err(
            format,
            format!(
                "header claims {size} bytes of image, more than {} bytes of file can hold",
                bytes.len()
            ),
        ));
    }
    let mut buf = vec![0u8; size];
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| decode_err(format, e))?;
    let (w, h) = (info.width, info.height);
    let channels = info.color_type.samples();
    let sixteen = info.bit_depth == png::BitDepth::Sixteen;
    let bps = if sixteen { 2 } else { 1 };
    let line = info.line_size;
    let get = |row: &[u8], x: usize, c: usize| -> f64 {
        let i = (x * channels + c) * bps;
        if sixteen {
            f64::from(u16::from_be_bytes([row[i], row[i + 1]]))
        } else {
            f64::from(row[i])
        }
    };
    use png::ColorType as C;
    let gray = matches!(info.color_type, C::Grayscale | C::GrayscaleAlpha);
    let rgb = matches!(info.color_type, C::Rgb | C::Rgba);
    let has_alpha = matches!(info.color_type, C::GrayscaleAlpha | C::Rgba);
    match format {
        Format::Png if !gray => {
            return Err(IoError::Unsupported(
                "colour PNG read as grayscale: give --format terrain-rgb or --format terrarium"
                    .into(),
            ))
        }
        Format::TerrainRgb | Format::Terrarium if !rgb || sixteen => {
            return Err(IoError::Unsupported(format!(
                "{} needs an 8-bit RGB or RGBA PNG",
                format.name()
            )))
        }
        _ => {}
    }
    let mut values = Vec::with_capacity(w as usize * h as usize);
    for row in buf.chunks(line).take(h as usize) {
        if row.len() < w as usize * channels * bps {
            return Err(decode_err(format, "short row"));
        }
        for x in 0..w as usize {
            // A fully transparent pixel is a void (how tiled services mark missing data).
            if has_alpha && get(row, x, channels - 1) == 0.0 && !gray {
                values.push(f64::NAN);
                continue;
            }
            let v = match format {
                Format::TerrainRgb => {
                    -10000.0
                        + (get(row, x, 0) * 65536.0 + get(row, x, 1) * 256.0 + get(row, x, 2)) * 0.1
                }
                Format::Terrarium => {
                    get(row, x, 0) * 256.0 + get(row, x, 1) + get(row, x, 2) / 256.0 - 32768.0
                }
                _ => get(row, x, 0),
            };
            values.push(v);
        }
    }
    if values.len() != w as usize * h as usize {
        return Err(decode_err(format, "truncated image data"));
    }
    Ok(Raw {
        width: w,
        height: h,
        values,
        scale: Scale::default(),
        nodata: None,
    })
}

fn decode_tiff(bytes: &[u8]) -> Result<Raw, IoError> {
    use tiff::decoder::{Decoder, DecodingResult, Limits};
    use tiff::tags::Tag;
    let f = Format::Tiff;
    let limit = decoded_limit(bytes.len());
    let mut limits = Limits::default();
    limits.decoding_buffer_size = limit;
    limits.intermediate_buffer_size = limit;
    let mut dec = Decoder::new(Cursor::new(bytes))
        .map_err(|e| decode_err(f, e))?
        .with_limits(limits);
    let (w, h) = dec.dimensions().map_err(|e| decode_err(f, e))?;
    let ct = dec.colortype().map_err(|e| decode_err(f, e))?;
    if !matches!(ct, tiff::ColorType::Gray(_)) {
        return Err(IoError::Unsupported(format!(
            "TIFF with colour type {ct:?}: only single-band elevation is supported"
        )));
    }
    let nodata = dec
        .find_tag(Tag::GdalNodata)
        .ok()
        .flatten()
        .and_then(|v| v.into_string().ok())
        .and_then(|s| {
            s.trim_matches(|c: char| c == '\0' || c.is_whitespace())
                .parse::<f64>()
                .ok()
        });
    let pixel_scale = dec
        .find_tag(Tag::ModelPixelScaleTag)
        .ok()
        .flatten()
        .and_then(|v| v.into_f64_vec().ok());
    let tiepoint = dec
        .find_tag(Tag::ModelTiepointTag)
        .ok()
        .flatten()
        .and_then(|v| v.into_f64_vec().ok());
    let geokeys = dec
        .find_tag(Tag::GeoKeyDirectoryTag)
        .ok()
        .flatten()
        .and_then(|v| v.into_u16_vec().ok());
    let image = dec.read_image().map_err(|e| decode_err(f, e))?;
    let values: Vec<f64> = match image {
        DecodingResult::U8(v) => v.into_iter().map(f64::from).collect(),
        DecodingResult::U16(v) => v.into_iter().map(f64::from).collect(),
        DecodingResult::I16(v) => v.into_iter().map(f64::from).collect(),
        DecodingResult::I32(v) => v.into_iter().map(f64::from).collect(),
        DecodingResult::U32(v) => v.into_iter().map(f64::from).collect(),
        DecodingResult::F32(v) => v.into_iter().map(f64::from).collect(),
        DecodingResult::F64(v) => v,
        DecodingResult::I8(v) => v.into_iter().map(f64::from).collect(),
        other => {
            return Err(IoError::Unsupported(format!(
                "TIFF sample type {:?}",
                std::mem::discriminant(&other)
            )))
        }
    };
    let expected = u64::from(w) * u64::from(h);
    if values.len() as u64 != expected {
        return Err(IoError::SizeMismatch {
            expected,
            actual: values.len() as u64,
            what: "samples",
        });
    }
    let scale = tiff_scale(
        pixel_scale.as_deref(),
        tiepoint.as_deref(),
        geokeys.as_deref(),
        h,
    );
    Ok(Raw {
        width: w,
        height: h,
        values,
        scale,
        nodata,
    })
}

/// Spacing from the GeoTIFF tags: `ModelPixelScale` in metres for projected rasters; for
/// geographic rasters (`GTModelTypeGeoKey` = 2) degrees are turned into metres at the raster's
/// centre latitude on a sphere of the WGS84 mean radius (111 320 m per degree of longitude at
/// the equator, 110 574 m per degree of latitude), good to about 0.5%.
fn tiff_scale(
    pixel_scale: Option<&[f64]>,
    tiepoint: Option<&[f64]>,
    geokeys: Option<&[u16]>,
    rows: u32,
) -> Scale {
    let mut scale = Scale::default();
    let Some([sx, sy, ..]) = pixel_scale else {
        return scale;
    };
    let (mut sx, mut sy) = (*sx, *sy);
    let model_type = geokeys.and_then(|k| {
        k.get(4..)?
            .chunks_exact(4)
            .find(|e| e[0] == 1024 && e[1] == 0)
            .map(|e| e[3])
    });
    if model_type == Some(2) {
        let top = tiepoint.and_then(|t| t.get(4).copied()).unwrap_or(0.0);
        let centre = (top - sy * f64::from(rows) / 2.0).to_radians();
        sx *= 111_320.0 * centre.cos();
        sy *= 110_574.0;
    }
    if sx.is_finite() && sy.is_finite() && sx > 0.0 && sy > 0.0 {
        scale.dx = sx as f32;
        scale.dy = sy as f32;
    }
    scale
}

fn decode_raw(bytes: &[u8], opts: &ReadOptions) -> Result<Raw, IoError> {
    let (Some(w), Some(h)) = (opts.width, opts.height) else {
        return Err(IoError::InvalidOption(
            "raw-f32 needs --width and --height".into(),
        ));
    };
    if w == 0 || h == 0 {
        return Err(IoError::InvalidOption(format!(
            "width and height must be positive, got {w}x{h}"
        )));
    }
    let expected = u64::from(w) * u64::from(h) * 4;
    if bytes.len() as u64 != expected {
        return Err(IoError::SizeMismatch {
            expected,
            actual: bytes.len() as u64,
            what: "bytes",
        });
    }
    let values = bytes
        .chunks_exact(4)
        .map(|c| f64::from(f32::from_le_bytes([c[0], c[1], c[2], c[3]])))
        .collect();
    Ok(Raw {
        width: w,
        height: h,
        values,
        scale: Scale::default(),
        nodata: None,
    })
}

/// Replaces voids according to `fill`; returns the heights and the number of voids.
fn fill_voids(
    values: Vec<f64>,
    width: u32,
    height: u32,
    nodata: Option<f64>,
    fill: Fill,
) -> Result<(Vec<f32>, usize), IoError> {
    let is_void = |v: f64| !v.is_finite() || nodata.is_some_and(|n| v == n) || v.abs() > 1e30;
    let voids = values.iter().filter(|v| is_void(**v)).count();
    if voids == 0 {
        return Ok((values.into_iter().map(|v| v as f32).collect(), 0));
    }
    if voids == values.len() {
        return Err(IoError::AllNoData);
    }
    let w = width as usize;
    match fill {
        Fill::Error => {
            let i = values.iter().position(|v| is_void(*v)).unwrap_or(0);
            Err(IoError::NoData {
                x: (i % w) as u32,
                y: (i / w) as u32,
                value: values[i],
            })
        }
        Fill::Min => {
            let min = values
                .iter()
                .copied()
                .filter(|v| !is_void(*v))
                .fold(f64::INFINITY, f64::min);
            let out = values
                .into_iter()
                .map(|v| if is_void(v) { min as f32 } else { v as f32 })
                .collect();
            Ok((out, voids))
        }
        Fill::Nearest => {
            let mut out: Vec<f32> = values.iter().map(|&v| v as f32).collect();
            let mut done: Vec<bool> = values.iter().map(|&v| !is_void(v)).collect();
            let mut queue: VecDeque<usize> = (0..values.len()).filter(|&i| done[i]).collect();
            let h = height as usize;
            while let Some(i) = queue.pop_front() {
                let (x, y) = (i % w, i / w);
                let mut visit = |j: usize| {
                    if !done[j] {
                        done[j] = true;
                        out[j] = out[i];
                        queue.push_back(j);
                    }
                };
                if x > 0 {
                    visit(i - 1);
                }
                if x + 1 < w {
                    visit(i + 1);
                }
                if y > 0 {
                    visit(i - w);
                }
                if y + 1 < h {
                    visit(i + w);
                }
            }
            Ok((out, voids))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fill_nearest_takes_closest_valid_sample() {
        let n = f64::NAN;
        let (out, count) =
            fill_voids(vec![1.0, n, n, n, n, 9.0], 3, 2, None, Fill::Nearest).unwrap();
        assert_eq!(count, 4);
        assert_eq!(out, vec![1.0, 1.0, 9.0, 1.0, 9.0, 9.0]);
    }

    #[test]
    fn fill_min_and_error() {
        let v = vec![5.0, -9999.0, 3.0, 4.0];
        let (out, _) = fill_voids(v.clone(), 2, 2, Some(-9999.0), Fill::Min).unwrap();
        assert_eq!(out, vec![5.0, 3.0, 3.0, 4.0]);
        match fill_voids(v, 2, 2, Some(-9999.0), Fill::Error) {
            Err(IoError::NoData { x: 1, y: 0, value }) => assert_eq!(value, -9999.0),
            other => panic!("unexpected {other:?}"),
        }
        assert!(matches!(
            fill_voids(vec![f64::NAN; 4], 2, 2, None, Fill::Nearest),
            Err(IoError::AllNoData)
        ));
    }

    #[test]
    fn geographic_spacing_is_converted_to_metres() {
        // GeoKeyDirectory header + GTModelTypeGeoKey = 2 (geographic).
        let keys = [1, 1, 0, 1, 1024, 0, 1, 2];
        let s = tiff_scale(
            Some(&[1.0 / 1200.0, 1.0 / 1200.0, 0.0]),
            Some(&[0.0, 0.0, 0.0, -97.0, 0.0, 0.0]),
            Some(&keys),
            2,
        );
        assert!((s.dx - 92.77).abs() < 0.1, "{}", s.dx); // equator
        assert!((s.dy - 92.145).abs() < 0.1, "{}", s.dy);
    }
}
