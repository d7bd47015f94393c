//! Greedy-insertion TIN (relief-tin) on the bundled Puget Sound DEM and, where present, the real
//! DEMs of `../shared/data`: whole build (`Tin::build`) at several error targets, and the
//! full-grid error scan that measures a mesh.
//!
//! `cargo bench -p relief-benches --bench tin`
//!
//! Peers (pydelatin, JS delatin) are timed by `bench-peers/tin_peers.sh` on the same inputs.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use relief_tin::{mesh_error, Tin, TinOptions};
use std::hint::black_box;
use std::path::Path;

fn puget() -> relief_io::Dem {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/puget_sound_1k.png");
    let mut dem = relief_io::read_dem(&p, &Default::default()).expect("bundled DEM");
    dem.scale = dem.scale.with_spacing(160.0, 160.0).with_z_scale(0.1);
    dem
}

fn shared(name: &str, format: relief_io::Format) -> Option<relief_io::Dem> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data")
        .join(name);
    if !p.is_file() {
        eprintln!("skipped: {} not present", p.display());
        return None;
    }
    let o = relief_io::ReadOptions {
        format: Some(format),
        ..Default::default()
    };
    relief_io::read_dem(&p, &o).ok()
}

fn build(c: &mut Criterion) {
    let mut inputs = vec![("puget_1025", puget(), vec![100.0f32, 50.0, 20.0])];
    if let Some(d) = shared("delatin_14-2625-6369.png", relief_io::Format::TerrainRgb) {
        inputs.push(("bay_hills_512", d, vec![5.0, 1.0, 0.5, 0.1]));
    }
    if let Some(d) = shared("martini_fuji.png", relief_io::Format::TerrainRgb) {
        inputs.push(("fuji_512", d, vec![20.0, 5.0, 1.0]));
    }
    for (name, dem, errors) in &inputs {
        let hf = dem.heightfield().unwrap();
        let mut g = c.benchmark_group(format!("tin_build_{name}"));
        g.sample_size(10);
        g.throughput(Throughput::Elements(
            u64::from(dem.width) * u64::from(dem.height),
        ));
        for &e in errors {
            let o = TinOptions::default().with_max_error(e);
            g.bench_with_input(BenchmarkId::from_parameter(format!("E={e}")), &o, |b, o| {
                b.iter(|| Tin::build(black_box(&hf), o).unwrap())
            });
        }
        g.finish();
    }
}

fn measure(c: &mut Criterion) {
    let dem = puget();
    let hf = dem.heightfield().unwrap();
    let tin = Tin::build(&hf, &TinOptions::default().with_max_error(20.0)).unwrap();
    let mut g = c.benchmark_group("tin_mesh_error_puget_1025");
    g.sample_size(10);
    g.throughput(Throughput::Elements(
        u64::from(dem.width) * u64::from(dem.height),
    ));
    g.bench_function("E=20", |b| {
        b.iter(|| mesh_error(black_box(&hf), tin.vertices(), tin.triangles()).unwrap())
    });
    g.finish();
}

criterion_group!(benches, build, measure);
criterion_main!(benches);
