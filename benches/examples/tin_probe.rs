//! Greedy TIN builds (`relief_tin::Tin::build`) on one DEM, fastest of `RUNS` (default 5) builds
//! per error target, with the mesh's size: a probe for profilers (`perf`, `valgrind
//! --tool=callgrind`, which the `relief` CLI's thread-CPU clock does not run under).
//!
//! `DEM=../shared/data/pymartini_terrarium.png FORMAT=terrarium ES="1 5" cargo run --release -p
//! relief-benches --example tin_probe` (defaults: the bundled Puget Sound DEM, 160 m spacing,
//! z scale 0.1, `ES="50 20"`; `FORMAT` one of png, terrain-rgb, terrarium, tiff)

use relief_tin::{Tin, TinOptions};
use std::hint::black_box;
use std::path::PathBuf;
use std::time::Instant;

fn main() {
    let env = |k: &str| std::env::var(k).ok();
    let runs: usize = env("RUNS").and_then(|s| s.parse().ok()).unwrap_or(5);
    let bundled = env("DEM").is_none();
    let path = env("DEM").map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../data/puget_sound_1k.png"),
        PathBuf::from,
    );
    let format = env("FORMAT").map(|f| match f.as_str() {
        "png" => relief_io::Format::Png,
        "terrain-rgb" => relief_io::Format::TerrainRgb,
        "terrarium" => relief_io::Format::Terrarium,
        "tiff" => relief_io::Format::Tiff,
        other => panic!("FORMAT {other}: png, terrain-rgb, terrarium or tiff"),
    });
    let opts = relief_io::ReadOptions {
        format,
        ..Default::default()
    };
    let mut dem = relief_io::read_dem(&path, &opts).expect("readable DEM");
    if bundled {
        dem.scale = dem.scale.with_spacing(160.0, 160.0).with_z_scale(0.1);
    }
    let hf = dem.heightfield().unwrap();
    let es: Vec<f32> = env("ES")
        .unwrap_or_else(|| "50 20".into())
        .split_whitespace()
        .map(|s| s.parse().expect("ES: numbers"))
        .collect();
    for e in es {
        let o = TinOptions::default().with_max_error(e);
        let mut best = f64::INFINITY;
        let mut size = (0, 0);
        for _ in 0..runs.max(1) {
            let s = Instant::now();
            let tin = black_box(Tin::build(&hf, &o).unwrap());
            best = best.min(s.elapsed().as_secs_f64() * 1e3);
            size = (tin.vertices().len(), tin.triangles().len());
        }
        println!(
            "E={e:<8} {:>9} vertices {:>9} triangles {best:9.2} ms",
            size.0, size.1
        );
    }
}
