//! Foundation benchmarks: surface evaluation and normals on the bundled Puget Sound DEM.
//!
//! `cargo bench -p relief-benches --bench core`

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use relief_core::glam::Vec3;
use relief_core::{normal_map, NormalMethod, Surface, Terrain};
use std::hint::black_box;
use std::path::Path;

fn load() -> relief_io::Dem {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/puget_sound_1k.png");
    let mut dem = relief_io::read_dem(&p, &Default::default()).expect("bundled DEM");
    dem.scale = dem.scale.with_spacing(160.0, 160.0).with_z_scale(0.1);
    dem
}

fn normals(c: &mut Criterion) {
    let dem = load();
    let hf = dem.heightfield().unwrap();
    let n = (hf.width() * hf.height()) as usize;
    let mut out = vec![Vec3::ZERO; n];
    let mut g = c.benchmark_group("normal_map_1025");
    g.throughput(Throughput::Elements(n as u64));
    for m in [NormalMethod::Central, NormalMethod::Sobel] {
        g.bench_with_input(
            BenchmarkId::from_parameter(format!("{m:?}")),
            &m,
            |b, &m| b.iter(|| normal_map(&hf, m, black_box(&mut out)).unwrap()),
        );
    }
    g.finish();
}

fn surfaces(c: &mut Criterion) {
    let dem = load();
    let hf = dem.heightfield().unwrap();
    let ext = hf.extent();
    // A fixed pseudo-random set of query points (xorshift, seed 1).
    let mut s = 1u64;
    let pts: Vec<(f32, f32)> = (0..100_000)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let a = (s & 0xffff) as f32 / 65535.0;
            let b = ((s >> 16) & 0xffff) as f32 / 65535.0;
            (a * ext.x, b * ext.y)
        })
        .collect();
    let mut g = c.benchmark_group("surface_height");
    g.throughput(Throughput::Elements(pts.len() as u64));
    for surf in [Surface::Nearest, Surface::Triangles, Surface::Bilinear] {
        g.bench_with_input(
            BenchmarkId::from_parameter(format!("{surf:?}")),
            &surf,
            |b, &surf| {
                b.iter(|| {
                    let mut acc = 0.0f32;
                    for &(x, y) in &pts {
                        acc += hf.surface_height(surf, x, y).unwrap_or(0.0);
                    }
                    black_box(acc)
                })
            },
        );
    }
    g.finish();
}

criterion_group!(benches, normals, surfaces);
criterion_main!(benches);
