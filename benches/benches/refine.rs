//! SOAR refinement benchmarks on the bundled Puget Sound DEM (1025 x 1025, 160 m, 0.1 m units):
//! preprocessing (both layouts), view-independent extraction (triangles/s), view-dependent
//! refinement with frustum culling (triangles/s; `f32` arrays, compact, and the 8-byte records
//! in both layouts), the in/out-edge strip, and an
//! error-threshold vs triangles vs milliseconds table for both modes (printed to stderr).
//!
//! `cargo bench -p relief-benches --bench refine`

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use relief_core::glam::Vec3;
use relief_core::refine::{
    hierarchy_len, pack_records, preprocess, preprocess_compact, records_len, scratch_len,
    strip_bound, Criterion as Crit, RecordLayout, Refiner, VertexRecord, View,
};
use relief_core::{Camera, Heightfield};
use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

fn load() -> relief_io::Dem {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/puget_sound_1k.png");
    let mut dem = relief_io::read_dem(&p, &Default::default()).expect("bundled DEM");
    dem.scale = dem.scale.with_spacing(160.0, 160.0).with_z_scale(0.1);
    dem
}

/// A low oblique view over the middle of the map, 1280 x 720, 60 degrees.
fn camera(k: usize) -> Camera {
    let a = k as f32 * 0.7;
    let eye = Vec3::new(
        82_000.0 + 30_000.0 * a.cos(),
        82_000.0 + 30_000.0 * a.sin(),
        3_000.0,
    );
    let target = Vec3::new(82_000.0, 82_000.0, 0.0);
    Camera::new(eye, target, 60.0, 1280, 720).unwrap()
}

fn median_ms(mut f: impl FnMut(), runs: usize) -> f64 {
    let mut t: Vec<f64> = (0..runs)
        .map(|_| {
            let s = Instant::now();
            f();
            s.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[runs / 2]
}

fn benches(c: &mut Criterion) {
    let dem = load();
    let hf: Heightfield<'_, f32> = dem.heightfield().unwrap();
    let (w, h) = (dem.width, dem.height);
    let n = hierarchy_len(w, h);

    let mut g = c.benchmark_group("refine_preprocess_1025");
    g.sample_size(10);
    g.throughput(Throughput::Elements(n as u64));
    g.bench_function("full_8B", |b| {
        let (mut e, mut r) = (vec![0.0f32; n], vec![0.0f32; n]);
        b.iter(|| {
            preprocess(&hf, &mut e, &mut r).unwrap();
        })
    });
    g.bench_function("compact_2B", |b| {
        let mut e = vec![0u16; n];
        b.iter(|| {
            preprocess_compact(&hf, &mut e).unwrap();
        })
    });
    g.finish();

    let (mut ef, mut rf) = (vec![0.0f32; n], vec![0.0f32; n]);
    let full = preprocess(&hf, &mut ef, &mut rf).unwrap();
    let mut ec = vec![0u16; n];
    let compact = preprocess_compact(&hf, &mut ec).unwrap();
    let mut rl = vec![VertexRecord::default(); records_len(w, h, RecordLayout::Linear)];
    let rec_lin = pack_records(&full, &hf, RecordLayout::Linear, &mut rl).unwrap();
    let mut ri = vec![VertexRecord::default(); records_len(w, h, RecordLayout::Interleaved)];
    let rec_il = pack_records(&full, &hf, RecordLayout::Interleaved, &mut ri).unwrap();
    let mut scratch = vec![0u64; scratch_len(w, h)];
    let mut verts = vec![[0.0f32; 3]; n];
    let mut tris = vec![[0u32; 3]; relief_core::refine::triangle_bound(w, h)];
    let mut strip = vec![0u32; strip_bound(w, h)];

    let mut g = c.benchmark_group("refine_extract_vi_1025");
    for e in [1.0f32, 5.0, 20.0, 50.0] {
        for (name, hier) in [("full", &full), ("compact", &compact)] {
            let r = Refiner::new(hier, &hf, Crit::MaxError(e)).unwrap();
            let t = r.count(&mut scratch).unwrap().triangles;
            g.throughput(Throughput::Elements(t as u64));
            g.bench_with_input(BenchmarkId::new(name, format!("E={e}")), &e, |b, _| {
                b.iter(|| black_box(r.triangles(&mut scratch, &mut verts, &mut tris).unwrap()))
            });
        }
    }
    g.finish();

    let mut g = c.benchmark_group("refine_vd_culling_1025");
    for tau in [0.5f32, 1.0, 4.0] {
        for (name, hier) in [
            ("full", &full),
            ("compact", &compact),
            ("records-linear", &rec_lin),
            ("records-interleaved", &rec_il),
        ] {
            let v = View::new(&camera(0), tau).unwrap();
            let r = Refiner::new(hier, &hf, Crit::View(v)).unwrap();
            let t = r.count(&mut scratch).unwrap().triangles;
            g.throughput(Throughput::Elements(t as u64));
            g.bench_with_input(
                BenchmarkId::new(name, format!("tau={tau}")),
                &tau,
                |b, _| {
                    b.iter(|| black_box(r.triangles(&mut scratch, &mut verts, &mut tris).unwrap()))
                },
            );
            // The same frame as indices into the whole grid (no renumbering, no vertices).
            g.bench_with_input(
                BenchmarkId::new(format!("{name}-grid"), format!("tau={tau}")),
                &tau,
                |b, _| b.iter(|| black_box(r.grid_triangles(&mut tris).unwrap())),
            );
        }
    }
    g.finish();

    let mut g = c.benchmark_group("refine_inout_strip_1025");
    for e in [5.0f32, 20.0] {
        let r = Refiner::new(&compact, &hf, Crit::MaxError(e)).unwrap();
        let t = r.count(&mut scratch).unwrap().triangles;
        g.throughput(Throughput::Elements(t as u64));
        g.bench_with_input(BenchmarkId::from_parameter(format!("E={e}")), &e, |b, _| {
            b.iter(|| black_box(r.inout_strip(&mut scratch, &mut verts, &mut strip).unwrap()))
        });
    }
    g.finish();

    // The table: threshold vs triangles vs ms (median of 15 runs), both modes; skipped when
    // RELIEF_BENCH_NO_TABLE is set (for filtered runs).
    if std::env::var_os("RELIEF_BENCH_NO_TABLE").is_some() {
        return;
    }
    eprintln!("\n| mode | threshold | layout | vertices | triangles | ms (median of 15) | M triangles/s |");
    eprintln!("|---|---|---|---|---|---|---|");
    for e in [0.5f32, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0] {
        for (name, hier) in [("full", &full), ("compact", &compact)] {
            let r = Refiner::new(hier, &hf, Crit::MaxError(e)).unwrap();
            let cnt = r.count(&mut scratch).unwrap();
            let ms = median_ms(
                || {
                    black_box(r.triangles(&mut scratch, &mut verts, &mut tris).unwrap());
                },
                15,
            );
            eprintln!(
                "| view-independent | E = {e} m | {name} | {} | {} | {ms:.2} | {:.1} |",
                cnt.vertices,
                cnt.triangles,
                cnt.triangles as f64 / ms / 1e3
            );
        }
    }
    for tau in [0.25f32, 0.5, 1.0, 2.0, 4.0, 8.0] {
        for (name, hier) in [
            ("full", &full),
            ("compact", &compact),
            ("records-interleaved", &rec_il),
        ] {
            let v = View::new(&camera(0), tau).unwrap();
            let r = Refiner::new(hier, &hf, Crit::View(v)).unwrap();
            let cnt = r.count(&mut scratch).unwrap();
            let ms = median_ms(
                || {
                    black_box(r.triangles(&mut scratch, &mut verts, &mut tris).unwrap());
                },
                15,
            );
            eprintln!(
                "| view-dependent, culling | tau = {tau} px | {name} | {} | {} | {ms:.2} | {:.1} |",
                cnt.vertices,
                cnt.triangles,
                cnt.triangles as f64 / ms / 1e3
            );
        }
    }
}

criterion_group!(refine_benches, benches);
criterion_main!(refine_benches);
