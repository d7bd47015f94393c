//! `relief info`: size and height statistics of a DEM.

use crate::args::DemArgs;
use crate::{print_out, CliResult};
use clap::Args;
use std::time::Instant;

/// Options of `relief info`.
#[derive(Debug, Args)]
pub struct InfoArgs {
    #[command(flatten)]
    dem: DemArgs,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

/// Runs `relief info`.
pub fn run(a: &InfoArgs) -> CliResult {
    let t0 = Instant::now();
    let (dem, format) = a.dem.load()?;
    let load_ms = t0.elapsed().as_secs_f64() * 1e3;
    let st = dem.stats();
    let s = dem.scale;
    if a.json {
        let v = serde_json::json!({
            "path": a.dem.dem.display().to_string(),
            "format": format.name(),
            "width": dem.width,
            "height": dem.height,
            "min": st.min,
            "max": st.max,
            "mean": st.mean,
            "nodata_count": dem.nodata_count,
            "dx": s.dx,
            "dy": s.dy,
            "z_scale": s.z_scale,
            "z_offset": s.z_offset,
            "load_ms": load_ms,
        });
        print_out(&format!("{v}\n"))
    } else {
        print_out(&format!(
            "{path}\n  format   {fmt}\n  size     {w} x {h} samples\n  spacing  dx {dx}, dy {dy}\n  z        scale {zs}, offset {zo}\n  min      {min:.3}\n  max      {max:.3}\n  mean     {mean:.3}\n  no-data  {nd}\n",
            path = a.dem.dem.display(),
            fmt = format.name(),
            w = dem.width,
            h = dem.height,
            dx = s.dx,
            dy = s.dy,
            zs = s.z_scale,
            zo = s.z_offset,
            min = st.min,
            max = st.max,
            mean = st.mean,
            nd = dem.nodata_count,
        ))
    }
}
