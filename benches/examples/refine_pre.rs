//! Preprocessing timings on the bundled Puget Sound DEM (1025 x 1025): fastest of `RUNS`
//! (default 20) runs of `preprocess` (full layout, f32 error and radius) and
//! `preprocess_compact` (bfloat16 error), each also with the min/max block pyramid that prunes
//! the large triangles' scans (`preprocess_pyramid`, `preprocess_compact_pyramid`, the pyramid
//! built inside the timing), and a checksum of the output (the same checksum means the same
//! bits; the pruned variants must give the same bits, asserted).
//!
//! `cargo run --release -p relief-benches --example refine_pre` (`RUNS=n`; `DEM=path`, optionally
//! `FORMAT=name` as `relief --format` takes it, times that grid instead, the pyramid variants
//! included; the first call of each layout is reported too; `ONLY=compact` or `ONLY=full` times
//! that layout alone, for profiles)

use relief_core::refine::{
    hierarchy_len, preprocess, preprocess_compact, preprocess_compact_pyramid, preprocess_pyramid,
    pyramid_len, PreprocessOptions,
};
use relief_core::Heightfield;
use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

fn fastest(runs: usize, mut f: impl FnMut()) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..runs {
        let s = Instant::now();
        f();
        best = best.min(s.elapsed().as_secs_f64() * 1e3);
    }
    best
}

fn main() {
    let runs: usize = std::env::var("RUNS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(20);
    // DEM=path (FORMAT=name) times another grid; the bundled Puget Sound DEM otherwise.
    let dem = match std::env::var("DEM") {
        Ok(path) => {
            let format = std::env::var("FORMAT")
                .ok()
                .map(|f| relief_io::Format::from_name(&f).expect("a format name"));
            let opts = relief_io::ReadOptions {
                format,
                ..Default::default()
            };
            relief_io::read_dem(Path::new(&path), &opts).expect("DEM")
        }
        Err(_) => {
            let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/puget_sound_1k.png");
            let mut dem = relief_io::read_dem(&p, &Default::default()).expect("bundled DEM");
            dem.scale = dem.scale.with_spacing(160.0, 160.0).with_z_scale(0.1);
            dem
        }
    };
    let hf: Heightfield<'_, f32> = dem.heightfield().unwrap();
    let n = hierarchy_len(dem.width, dem.height);
    let (mut e, mut r) = (vec![0.0f32; n], vec![0.0f32; n]);
    let mut c = vec![0u16; n];
    // The first call of each (cold caches and branch predictors, fresh pages), as a one-shot
    // tool such as `relief mesh` times it.
    let t = Instant::now();
    black_box(preprocess_compact(&hf, &mut c).unwrap());
    let compact_first = t.elapsed().as_secs_f64() * 1e3;
    let t = Instant::now();
    black_box(preprocess(&hf, &mut e, &mut r).unwrap());
    let full_first = t.elapsed().as_secs_f64() * 1e3;
    // ONLY=compact or ONLY=full: that layout alone (for profiles).
    let only = std::env::var("ONLY")
        .ok()
        .filter(|o| o == "full" || o == "compact");
    let wanted = |layout: &str| only.as_deref().is_none_or(|o| o == layout);
    let full = if wanted("full") {
        fastest(runs, || {
            black_box(preprocess(&hf, &mut e, &mut r).unwrap());
        })
    } else {
        f64::NAN
    };
    let compact = if wanted("compact") {
        fastest(runs, || {
            black_box(preprocess_compact(&hf, &mut c).unwrap());
        })
    } else {
        f64::NAN
    };
    if let Some(layout) = only.as_deref() {
        let (best, first) = if layout == "full" {
            (full, full_first)
        } else {
            (compact, compact_first)
        };
        println!("preprocess {layout} {best:8.3} ms  first call {first:8.3} ms");
        return;
    }
    let mut pyr = vec![0.0f32; pyramid_len(dem.width, dem.height)];
    let (mut e2, mut r2, mut c2) = (vec![0.0f32; n], vec![0.0f32; n], vec![0u16; n]);
    let full_pyr = fastest(runs, || {
        let o = PreprocessOptions::default();
        black_box(preprocess_pyramid(&hf, &mut e2, &mut r2, &mut pyr, o).unwrap());
    });
    let compact_pyr = fastest(runs, || {
        black_box(preprocess_compact_pyramid(&hf, &mut c2, &mut pyr).unwrap());
    });
    assert!(
        e == e2 && r == r2 && c == c2,
        "the pruned preprocessing differs"
    );
    let mut sum = 0u64;
    for ((a, b), k) in e.iter().zip(&r).zip(&c) {
        sum = sum
            .rotate_left(5)
            .wrapping_add(u64::from(a.to_bits()) ^ (u64::from(b.to_bits()) << 32) ^ u64::from(*k));
    }
    println!(
        "preprocess full {full:8.3} ms  compact {compact:8.3} ms  with the pyramid: full {full_pyr:8.3} ms  compact {compact_pyr:8.3} ms  first calls: full {full_first:8.3} ms  compact {compact_first:8.3} ms  checksum {sum:016x}"
    );
}
