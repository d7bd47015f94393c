//! A short fly-through over the bundled DEM rendered on the GPU with `relief-wgpu`, the way an
//! engine embeds the crate: the application owns the device and queue (here from
//! `relief_wgpu::headless`, in an engine from its window setup), the renderer borrows them, and
//! each frame is recorded into the application's command encoder and submitted with its work.
//! Frames are read back only to write PNG files.
//!
//! ```sh
//! cargo run --release -p relief-examples --example flythrough -- data/puget_sound_1k.png out/flythrough 8
//! # the RBF cascade ray cast (seed 002) instead, cascades refitted every frame:
//! cargo run --release -p relief-examples --example flythrough -- data/puget_sound_1k.png out/cascades 8 cascades
//! ```

use relief_core::glam::Vec3;
use relief_core::{Camera, Terrain};
use relief_io::{read_dem, write_atomic, ReadOptions};
use relief_wgpu::{headless, Effect, Method, Renderer, Scene};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let input = PathBuf::from(
        args.next()
            .unwrap_or_else(|| "data/puget_sound_1k.png".into()),
    );
    let out_dir = PathBuf::from(args.next().unwrap_or_else(|| "out/flythrough".into()));
    let frames: u32 = args.next().map_or(Ok(6), |s| s.parse())?;
    let cascades = args.next().is_some_and(|m| m == "cascades");
    let mut dem = read_dem(&input, &ReadOptions::default())?;
    if input.ends_with("puget_sound_1k.png") {
        // The bundled map: 160 m spacing, 0.1 m per unit.
        dem.scale = dem.scale.with_spacing(160.0, 160.0).with_z_scale(0.1);
    }
    let hf = dem.heightfield()?;
    let ext = hf.extent();

    // The application's device (an engine would pass its own).
    let gpu = headless()?;
    eprintln!("rendering on {} ({:?})", gpu.info.name, gpu.info.backend);
    let scene = if cascades {
        Scene::new().with_method(Method::cascades())
    } else {
        Scene::new().with_effects(&[Effect::Lighting, Effect::Shadows, Effect::Fog])
    };
    let mut renderer = Renderer::new(&gpu.device, &gpu.queue, &hf, scene)?;

    std::fs::create_dir_all(&out_dir)?;
    let (w, h) = (640u32, 360u32);
    for k in 0..frames {
        // Fly diagonally across the map, 3 km up, looking ahead and down.
        let s = 0.1 + 0.6 * k as f32 / frames.max(1) as f32;
        let eye = Vec3::new(s * ext.x, s * ext.y, 3000.0);
        let target = Vec3::new((s + 0.2) * ext.x, (s + 0.15) * ext.y, 200.0);
        let camera = Camera::new(eye, target, 60.0, w, h)?;
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        let passes = renderer.encode_frame(&gpu.device, &gpu.queue, &mut encoder, &camera)?;
        gpu.queue.submit([encoder.finish()]);
        let frame = renderer.read_frame(&gpu.device, &gpu.queue)?;
        let path = out_dir.join(format!("frame_{k:03}.png"));
        write_atomic(&path, |out| {
            let mut enc = png::Encoder::new(out, frame.width, frame.height);
            enc.set_color(png::ColorType::Rgba);
            enc.set_depth(png::BitDepth::Eight);
            let mut wr = enc.write_header().map_err(std::io::Error::other)?;
            wr.write_image_data(frame.color.as_flattened())
                .map_err(std::io::Error::other)?;
            wr.finish().map_err(std::io::Error::other)
        })?;
        let names: Vec<&str> = passes.iter().map(|p| p.as_str()).collect();
        eprintln!("{} ({})", path.display(), names.join(", "));
        if let Some(c) = renderer.cascades() {
            let spacing: Vec<f32> = c.cascades.iter().map(|k| k.spacing).collect();
            eprintln!("  cascade texel spacings (grid units): {spacing:?}");
        }
    }
    Ok(())
}
