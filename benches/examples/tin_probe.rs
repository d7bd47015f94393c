//! Greedy TIN builds (`relief_tin::Tin::build`) on one DEM, fastest of `RUNS` (default 5) builds
//! per error target, with the mesh's size: a probe for profilers (`perf`, `valgrind
//! --tool=callgrind`, which the `relief` CLI's thread-CPU clock does not run under).
//!
//! `DEM=../shared/data/pymartini_terrarium.png FORMAT=terrarium ES="1 5" cargo run --release -p
//! relief-benches --example tin_probe` (defaults: the bundled Puget Sound DEM, 160 m spacing,
//! z scale 0.1, `ES="50 20"`; `FORMAT` one of png, terrain-rgb, terrarium, tiff).
//!
//! `SPADE=1` also times spade alone on each mesh's vertices: inserted in the build's order (the
//! corners, then the greedy order) into an empty `DelaunayTriangulation` with spade's hierarchy
//! hint generator, fastest of `RUNS`. That is the triangulation work every greedy build with
//! spade does, without choosing the points, scanning the samples or keeping the heap.

use relief_tin::{Tin, TinOptions};
use spade::{DelaunayTriangulation, HierarchyHintGenerator, Point2, Triangulation};
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
        let mut vertices = Vec::new();
        for _ in 0..runs.max(1) {
            let s = Instant::now();
            let tin = black_box(Tin::build(&hf, &o).unwrap());
            best = best.min(s.elapsed().as_secs_f64() * 1e3);
            size = (tin.vertices().len(), tin.triangles().len());
            vertices = tin.vertices().to_vec();
        }
        print!(
            "E={e:<8} {:>9} vertices {:>9} triangles {best:9.2} ms",
            size.0, size.1
        );
        if env("SPADE").is_some_and(|v| v == "1") {
            type Dt = DelaunayTriangulation<Point2<f32>, (), (), (), HierarchyHintGenerator<f32>>;
            let mut best_s = f64::INFINITY;
            let mut faces = 0;
            for _ in 0..runs.max(1) {
                let s = Instant::now();
                let mut dt = Dt::new();
                for &[x, y] in &vertices {
                    dt.insert(Point2::new(x as f32, y as f32)).unwrap();
                }
                best_s = best_s.min(s.elapsed().as_secs_f64() * 1e3);
                faces = black_box(&dt).num_inner_faces();
            }
            print!("  | spade alone {faces:>9} triangles {best_s:9.2} ms");
        }
        println!();
    }
}
