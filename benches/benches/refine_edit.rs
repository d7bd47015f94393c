//! Live edits and pruned preprocessing on the bundled Puget Sound DEM (1025 x 1025, 160 m,
//! 0.1 m units): `update` after a crater of radius 1, 32 and 256 samples against a full
//! preprocessing of the edited map (plain rasterising `preprocess` and the pruned
//! `preprocess_pyramid`), both layouts.
//!
//! `cargo bench -p relief-benches --bench refine_edit`

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use relief_core::refine::{
    crater, hierarchy_len, preprocess, preprocess_compact, preprocess_compact_pyramid,
    preprocess_pyramid, pyramid_len, update, update_compact, PreprocessOptions,
};
use relief_core::Heightfield;
use std::path::Path;

fn load() -> relief_io::Dem {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/puget_sound_1k.png");
    let mut dem = relief_io::read_dem(&p, &Default::default()).expect("bundled DEM");
    dem.scale = dem.scale.with_spacing(160.0, 160.0).with_z_scale(0.1);
    dem
}

fn benches(c: &mut Criterion) {
    let dem = load();
    let (w, h) = (dem.width, dem.height);
    let n = hierarchy_len(w, h);
    let o = PreprocessOptions::default();
    let hf = dem.heightfield().unwrap();

    let mut g = c.benchmark_group("refine_preprocess_pruned_1025");
    g.sample_size(10);
    g.throughput(Throughput::Elements(n as u64));
    let (mut e, mut r, mut p) = (
        vec![0.0f32; n],
        vec![0.0f32; n],
        vec![0.0f32; pyramid_len(w, h)],
    );
    let mut ec = vec![0u16; n];
    g.bench_function("full_rasterise", |b| {
        b.iter(|| preprocess(&hf, &mut e, &mut r).unwrap().bytes_per_vertex())
    });
    g.bench_function("full_pyramid", |b| {
        b.iter(|| {
            preprocess_pyramid(&hf, &mut e, &mut r, &mut p, o)
                .unwrap()
                .bytes_per_vertex()
        })
    });
    g.bench_function("compact_rasterise", |b| {
        b.iter(|| preprocess_compact(&hf, &mut ec).unwrap().bytes_per_vertex())
    });
    g.bench_function("compact_pyramid", |b| {
        b.iter(|| {
            preprocess_compact_pyramid(&hf, &mut ec, &mut p)
                .unwrap()
                .bytes_per_vertex()
        })
    });
    g.finish();

    let mut g = c.benchmark_group("refine_update_1025");
    g.sample_size(10);
    for radius in [1.0f32, 32.0, 256.0] {
        // The original map's data, then a crater 50 m deep in the middle of the map.
        let mut s = dem.samples.clone();
        let (mut e, mut r, mut p) = (
            vec![0.0f32; n],
            vec![0.0f32; n],
            vec![0.0f32; pyramid_len(w, h)],
        );
        let (mut ec, mut pc) = (vec![0u16; n], vec![0.0f32; pyramid_len(w, h)]);
        preprocess_pyramid(&hf, &mut e, &mut r, &mut p, o).unwrap();
        preprocess_compact_pyramid(&hf, &mut ec, &mut pc).unwrap();
        let region = crater(&mut s, w, h, 512.0, 512.0, radius, 500.0)
            .unwrap()
            .unwrap();
        let edited = Heightfield::with_scale(&s, w, h, dem.scale).unwrap();
        // Repeating the update on the edited map redoes all of its work every iteration.
        g.bench_with_input(BenchmarkId::new("update_full", radius), &radius, |b, _| {
            b.iter(|| {
                update(&edited, &mut e, &mut r, &mut p, region, o)
                    .unwrap()
                    .bytes_per_vertex()
            })
        });
        g.bench_with_input(
            BenchmarkId::new("update_compact", radius),
            &radius,
            |b, _| {
                b.iter(|| {
                    update_compact(&edited, &mut ec, &mut pc, region)
                        .unwrap()
                        .bytes_per_vertex()
                })
            },
        );
    }
    g.finish();
}

criterion_group!(edit, benches);
criterion_main!(edit);
