//! Cost of each GPU effect as a ratio to the bare frame (seed 003, table 1 measured this by
//! hand): every scene gets its own `Renderer` on one device; frames are rendered round-robin
//! (one frame of each scene per round, so load on a shared machine hits all scenes alike) and
//! each scene reports the median over rounds of its frame time (sum of its per-frame passes,
//! `Renderer::render_profiled`: GPU timestamps between the passes of one submission where the
//! adapter has them, else wall-clock per pass; setup passes excluded). Silhouette partitioning
//! needs the whole terrain in front of the camera, so it is measured from a second camera south
//! of the map against the bare frame from that camera. The last column is the CPU's own time
//! per frame recording the passes (`PassTiming::cpu_ms`: queue writes, CPU-side work, command
//! recording), which GPU timestamps do not see.
//!
//! ```sh
//! cargo run --release -p relief-examples --example gpu_effects -- data/puget_sound_1k.png 640x360 15
//! ```

use relief_core::glam::Vec3;
use relief_core::Camera;
use relief_io::{read_dem, ReadOptions};
use relief_wgpu::{headless, Effect, Method, Renderer, Scene};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let input = PathBuf::from(
        args.next()
            .unwrap_or_else(|| "data/puget_sound_1k.png".into()),
    );
    let size = args.next().unwrap_or_else(|| "640x360".into());
    let (w, h) = size.split_once('x').ok_or("size WxH")?;
    let (w, h): (u32, u32) = (w.parse()?, h.parse()?);
    let rounds: usize = args.next().map_or(Ok(15), |s| s.parse())?;
    let mut dem = read_dem(&input, &ReadOptions::default())?;
    if input.ends_with("puget_sound_1k.png") {
        dem.scale = dem.scale.with_spacing(160.0, 160.0).with_z_scale(0.1);
    }
    let hf = dem.heightfield()?;
    let gpu = headless()?;
    let cam = Camera::new(
        Vec3::new(20_000.0, 15_000.0, 3000.0),
        Vec3::new(90_000.0, 80_000.0, 0.0),
        60.0,
        w,
        h,
    )?;
    let crater = relief_wgpu::terrain::Crater {
        center: [512.0, 512.0],
        radius: 100.0,
        depth: 80.0,
    };
    let south = Camera::new(
        Vec3::new(82_000.0, -20_000.0, 9000.0),
        Vec3::new(82_000.0, 60_000.0, 0.0),
        60.0,
        w,
        h,
    )?;
    // (name, renderer, camera, index of the baseline row)
    let mut scenes: Vec<(String, Renderer, Camera, usize)> = Vec::new();
    let mut add = |name: &str, scene: Scene| -> Result<(), relief_wgpu::Error> {
        scenes.push((
            name.to_string(),
            Renderer::new(&gpu.device, &gpu.queue, &hf, scene)?,
            cam,
            0,
        ));
        Ok(())
    };
    add("bare (maxmip, no effects)", Scene::new())?;
    for e in Effect::ALL {
        add(
            e.name(),
            Scene::new().with_effect(e).with_craters(&[crater]),
        )?;
    }
    add(
        "lighting, shadows, fog",
        Scene::new().with_effects(&[Effect::Lighting, Effect::Shadows, Effect::Fog]),
    )?;
    add(
        "method march, no effects",
        Scene::new().with_method(Method::march()),
    )?;
    add(
        "method cascades (RBF, 3 x 512^2 texels), no effects",
        Scene::new().with_method(Method::cascades()),
    )?;
    let base = scenes.len();
    for (name, scene) in [
        ("bare (maxmip), camera south of the map", Scene::new()),
        (
            "method silhouette, camera south of the map",
            Scene::new().with_method(Method::Silhouette),
        ),
    ] {
        scenes.push((
            name.to_string(),
            Renderer::new(&gpu.device, &gpu.queue, &hf, scene)?,
            south,
            base,
        ));
    }
    // Warm-up frame (setup passes, pipeline compilation), then timed rounds.
    let mut times: Vec<Vec<f64>> = vec![Vec::new(); scenes.len()];
    let mut record: Vec<Vec<f64>> = vec![Vec::new(); scenes.len()];
    let mut passes: Vec<String> = vec![String::new(); scenes.len()];
    for (_, r, c, _) in scenes.iter_mut() {
        r.render(&gpu.device, &gpu.queue, c)?;
    }
    for _ in 0..rounds {
        for (k, (_, r, c, _)) in scenes.iter_mut().enumerate() {
            let (_, t) = r.render_profiled(&gpu.device, &gpu.queue, c)?;
            times[k].push(t.iter().map(|p| p.ms).sum());
            record[k].push(t.iter().map(|p| p.cpu_ms).sum());
            passes[k] = t
                .iter()
                .map(|p| p.pass.as_str())
                .collect::<Vec<_>>()
                .join(", ");
        }
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let meds: Vec<f64> = times.iter_mut().map(median).collect();
    let recs: Vec<f64> = record.iter_mut().map(median).collect();
    println!(
        "device: {} ({:?}) | image {w} x {h} | median of {rounds} round-robin rounds | pass times: {} clock\n",
        gpu.info.name,
        gpu.info.backend,
        scenes[0].1.clock().as_str()
    );
    println!("| scene | passes per frame | frame ms (median) | vs bare frame | CPU recording ms (median) |");
    println!("|---|---|---|---|---|");
    for (k, (name, _, _, b)) in scenes.iter().enumerate() {
        println!(
            "| {name} | {} | {:.1} | {:.2}x | {:.3} |",
            passes[k],
            meds[k],
            meds[k] / meds[*b],
            recs[k]
        );
    }
    Ok(())
}
