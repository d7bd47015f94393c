//! Hillshade a DEM the way an engine embedding relief would: read it with `relief-io`, compute
//! Sobel normals into a caller-owned buffer with `relief-core`, light them, write a 16-bit PNG.
//!
//! ```sh
//! cargo run --release -p relief-examples --example hillshade -- data/puget_sound_1k.png out/hillshade.png
//! ```

use relief_core::glam::Vec3;
use relief_core::{normal_map, NormalMethod, Terrain};
use relief_io::{read_dem, ReadOptions};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let input = PathBuf::from(
        args.next()
            .unwrap_or_else(|| "data/puget_sound_1k.png".into()),
    );
    let output = PathBuf::from(args.next().unwrap_or_else(|| "out/hillshade.png".into()));
    let mut dem = read_dem(&input, &ReadOptions::default())?;
    if input.ends_with("puget_sound_1k.png") {
        // The bundled map: 160 m spacing, 0.1 m per unit.
        dem.scale = dem.scale.with_spacing(160.0, 160.0).with_z_scale(0.1);
    }
    let hf = dem.heightfield()?;
    let mut normals = vec![Vec3::ZERO; (hf.width() * hf.height()) as usize];
    normal_map(&hf, NormalMethod::Sobel, &mut normals)?;
    // Sun from the north-west (towards -x, -y in grid terms: row 0 is north), 45 degrees up.
    let sun = Vec3::new(-1.0, -1.0, 1.414).normalize();
    let shade: Vec<u16> = normals
        .iter()
        .map(|n| (n.dot(sun).max(0.0) * 65535.0) as u16)
        .collect();
    if let Some(dir) = output.parent() {
        std::fs::create_dir_all(dir)?;
    }
    relief_io::write_png16(&output, hf.width(), hf.height(), &shade)?;
    println!(
        "wrote {} ({} x {})",
        output.display(),
        hf.width(),
        hf.height()
    );
    Ok(())
}
