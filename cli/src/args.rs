//! Options shared by every subcommand that reads a DEM.

use crate::{CliError, CliResult};
use clap::Args;
use relief_core::glam::Vec3;
use relief_io::{read_dem, Dem, Fill, Format, ReadOptions};
use std::path::PathBuf;

/// `--dem PATH` and the options that say how to read it (CONVENTIONS.md).
#[derive(Debug, Args, Clone)]
pub struct DemArgs {
    /// Elevation file: 16-bit PNG, Terrain-RGB/Terrarium PNG, GeoTIFF, raw f32.
    #[arg(long, value_name = "PATH")]
    pub dem: PathBuf,
    /// Format: png, terrain-rgb, terrarium, tiff, raw-f32 (guessed when absent).
    #[arg(long, value_name = "F", value_parser = parse_format)]
    pub format: Option<Format>,
    /// Columns (required for raw-f32; must match the file otherwise).
    #[arg(long, value_name = "W")]
    pub width: Option<u32>,
    /// Rows (required for raw-f32; must match the file otherwise).
    #[arg(long, value_name = "H")]
    pub height: Option<u32>,
    /// No-data value (overrides the file's own).
    #[arg(long, value_name = "V", allow_negative_numbers = true)]
    pub nodata: Option<f64>,
    /// Void policy: error (default), nearest, min.
    #[arg(long, value_name = "P", value_parser = parse_fill, default_value = "error")]
    pub fill: Fill,
    /// Column spacing in world units (default from the file, else 1).
    #[arg(long, allow_negative_numbers = true)]
    pub dx: Option<f32>,
    /// Row spacing in world units (default from the file, else 1).
    #[arg(long, allow_negative_numbers = true)]
    pub dy: Option<f32>,
    /// World units per stored height unit (default 1).
    #[arg(long, allow_negative_numbers = true)]
    pub z_scale: Option<f32>,
    /// World height of a stored 0 (default 0).
    #[arg(long, allow_negative_numbers = true)]
    pub z_offset: Option<f32>,
}

/// Parses `X,Y,Z` into a finite vector (the camera options of every subcommand).
pub fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let parts: Vec<&str> = s.split(',').collect();
    if parts.len() != 3 {
        return Err(format!("expected X,Y,Z, got '{s}'"));
    }
    let mut v = [0.0f32; 3];
    for (o, p) in v.iter_mut().zip(&parts) {
        *o = p
            .trim()
            .parse::<f32>()
            .map_err(|_| format!("'{p}' is not a number"))?;
        if !o.is_finite() {
            return Err(format!("'{p}' is not finite"));
        }
    }
    Ok(Vec3::from_array(v))
}

/// Parses `WxH` with both sides at least 1 (a camera's image size).
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("expected WxH, got '{s}'"))?;
    let w: u32 = w.trim().parse().map_err(|_| format!("bad width '{w}'"))?;
    let h: u32 = h.trim().parse().map_err(|_| format!("bad height '{h}'"))?;
    if w == 0 || h == 0 {
        return Err(format!("image size {w}x{h} must be at least 1x1"));
    }
    Ok((w, h))
}

/// Most pixels an image a subcommand renders may have: 2^26 (8192 x 8192), so that its depth
/// and colour buffers stay within memory.
pub const MAX_IMAGE_PIXELS: u64 = 1 << 26;

/// [`parse_size`] for images the subcommand allocates: at most [`MAX_IMAGE_PIXELS`].
pub fn parse_image_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = parse_size(s)?;
    if u64::from(w) * u64::from(h) > MAX_IMAGE_PIXELS {
        return Err(format!("image size {w}x{h} exceeds 2^26 pixels"));
    }
    Ok((w, h))
}

fn parse_format(s: &str) -> Result<Format, String> {
    Format::from_name(s).ok_or_else(|| {
        format!(
            "unknown format '{s}' (expected one of {})",
            Format::ALL.map(Format::name).join(", ")
        )
    })
}

fn parse_fill(s: &str) -> Result<Fill, String> {
    Fill::from_name(s)
        .ok_or_else(|| format!("unknown fill policy '{s}' (expected error, nearest, min)"))
}

impl DemArgs {
    /// Reads the DEM and applies the scale overrides, validating everything.
    pub fn load(&self) -> CliResult<(Dem, Format)> {
        if let Some(nd) = self.nodata {
            if nd.is_nan() {
                return Err(CliError("--nodata must not be NaN".into()));
            }
        }
        let bytes = std::fs::read(&self.dem)
            .map_err(|e| CliError(format!("{}: {e}", self.dem.display())))?;
        let format = match self.format {
            Some(f) => f,
            None => Format::guess(&bytes, &self.dem)?,
        };
        let opts = ReadOptions {
            format: Some(format),
            width: self.width,
            height: self.height,
            nodata: self.nodata,
            fill: self.fill,
        };
        let mut dem = relief_io::decode_dem(&bytes, &opts)
            .map_err(|e| CliError(format!("{}: {e}", self.dem.display())))?;
        let s = &mut dem.scale;
        if let Some(v) = self.dx {
            s.dx = v;
        }
        if let Some(v) = self.dy {
            s.dy = v;
        }
        if let Some(v) = self.z_scale {
            s.z_scale = v;
        }
        if let Some(v) = self.z_offset {
            s.z_offset = v;
        }
        dem.scale.validate()?;
        dem.heightfield()?;
        // keep `read_dem` linked for users grepping the CLI for the library entry point
        let _ = read_dem as fn(&std::path::Path, &ReadOptions) -> _;
        Ok((dem, format))
    }

    /// Memory-maps a raw-f32 input (given as `--format raw-f32` or guessed) instead of reading
    /// it, with the scale overrides applied, so grids larger than memory work (issue 6). `None`
    /// for other formats and when `--nodata` or a `--fill` policy asks for void handling (which
    /// needs a copy: use [`DemArgs::load`]).
    pub fn map_raw_f32(&self) -> CliResult<Option<relief_io::MappedGrid>> {
        if self.nodata.is_some() || self.fill != Fill::Error {
            return Ok(None);
        }
        let format = match self.format {
            Some(f) => f,
            None => {
                use std::io::Read;
                let mut head = Vec::new();
                std::fs::File::open(&self.dem)
                    .and_then(|f| f.take(16).read_to_end(&mut head))
                    .map_err(|e| CliError(format!("{}: {e}", self.dem.display())))?;
                Format::guess(&head, &self.dem)?
            }
        };
        if format != Format::RawF32 {
            return Ok(None);
        }
        let (Some(w), Some(h)) = (self.width, self.height) else {
            return Err(CliError("raw-f32 needs --width and --height".into()));
        };
        let mut g = relief_io::MappedGrid::open(&self.dem, w, h)
            .map_err(|e| CliError(format!("{}: {e}", self.dem.display())))?;
        let s = &mut g.scale;
        for (o, v) in [
            (&mut s.dx, self.dx),
            (&mut s.dy, self.dy),
            (&mut s.z_scale, self.z_scale),
            (&mut s.z_offset, self.z_offset),
        ] {
            if let Some(v) = v {
                *o = v;
            }
        }
        g.scale.validate()?;
        g.heightfield()
            .map_err(|e| CliError(format!("{}: {e}", self.dem.display())))?;
        g.advise_random();
        Ok(Some(g))
    }
}
