//! Detail levels (relief_core::refine::DetailRefiner, seed 004 chapter 6.3) on seed 004's demo
//! size: the bundled 1025^2 Puget Sound DEM (160 m, 0.1 m units) plus a generated 1024^2
//! tileable detail map at factor 64 (a 65537^2 virtual grid, 2.5 m spacing), for low flyover
//! views. Triangles/s of detail refinement (constant and measured detail errors) against
//! base-only SOAR refinement (relief_core::refine::Refiner) of the same views and pixel error,
//! in the same run; plus the one-off DetailBounds::measure(_local). Prints the triangle counts per mode
//! to stderr.
//!
//! `cargo bench -p relief-benches --bench detail`

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use relief_core::glam::Vec3;
use relief_core::refine::{
    detail_scratch_len, hierarchy_len, local_bounds_len, preprocess, scratch_len,
    Criterion as Crit, DetailBounds, DetailRefiner, Hierarchy, Refiner, View,
};
use relief_core::{Camera, Composed, Heightfield, Surface, Terrain};
use std::hint::black_box;
use std::path::Path;

fn load() -> relief_io::Dem {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/puget_sound_1k.png");
    let mut dem = relief_io::read_dem(&p, &Default::default()).expect("bundled DEM");
    dem.scale = dem.scale.with_spacing(160.0, 160.0).with_z_scale(0.1);
    dem
}

/// Tileable value noise (16-sample lattice, wrapping) plus a periodic ripple, about +-2.5 m.
fn tileable(n: u32) -> Vec<f32> {
    let lat = n / 16;
    let hash = |x: u32, y: u32| {
        let mut z = 2003u64 ^ (u64::from(x % lat) << 32 | u64::from(y % lat));
        z = z.wrapping_mul(0x9E37_79B9_7F4A_7C15);
        z ^= z >> 29;
        z = z.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        ((z >> 40) as f32 / (1u64 << 24) as f32) - 0.5
    };
    let mut out = Vec::with_capacity((n * n) as usize);
    for y in 0..n {
        for x in 0..n {
            let (cx, cy, fx, fy) = (
                x / 16,
                y / 16,
                (x % 16) as f32 / 16.0,
                (y % 16) as f32 / 16.0,
            );
            let a = hash(cx, cy) * (1.0 - fx) + hash(cx + 1, cy) * fx;
            let b = hash(cx, cy + 1) * (1.0 - fx) + hash(cx + 1, cy + 1) * fx;
            let ripple = (std::f32::consts::TAU * 3.0 * x as f32 / n as f32).sin()
                * (std::f32::consts::TAU * 5.0 * y as f32 / n as f32).cos();
            out.push(4.0 * (a * (1.0 - fy) + b * fy) + ripple);
        }
    }
    out
}

/// Low flyover views (150 m above the ground, looking 5 km ahead), 1280 x 720, 60 degrees.
fn cameras<T: Terrain>(c: &T) -> Vec<Camera> {
    (0..4)
        .map(|k| {
            let a = k as f32 * 1.3;
            let (ex, ey) = (82_000.0 + 30_000.0 * a.cos(), 82_000.0 + 30_000.0 * a.sin());
            let ground = c.surface_height(Surface::Bilinear, ex, ey).unwrap_or(0.0);
            let (tx, ty) = (
                ex + 5_000.0 * (a + 2.0).cos(),
                ey + 5_000.0 * (a + 2.0).sin(),
            );
            Camera::new(
                Vec3::new(ex, ey, ground.max(0.0) + 150.0),
                Vec3::new(tx, ty, ground.max(0.0)),
                60.0,
                1280,
                720,
            )
            .unwrap()
        })
        .collect()
}

const TAU: f32 = 2.0;

fn detail_frame<'a>(
    h: &'a Hierarchy<'a>,
    c: &'a Composed<'a, f32, f32>,
    b: &DetailBounds<'a>,
    cam: &Camera,
    buf: &mut (Vec<u64>, Vec<[f32; 3]>, Vec<[u32; 3]>),
) -> usize {
    let dr = DetailRefiner::new(h, c, b, &View::new(cam, TAU).unwrap()).unwrap();
    dr.triangles(&mut buf.0, &mut buf.1, &mut buf.2)
        .unwrap()
        .triangles
}

fn benches(crit: &mut Criterion) {
    let dem = load();
    let hf: Heightfield<'_, f32> = dem.heightfield().unwrap();
    let ds = tileable(1024);
    let detail = Heightfield::new(&ds, 1024, 1024).unwrap();
    let c = Composed::new(hf, detail, 64).unwrap();
    let n = hierarchy_len(dem.width, dem.height);
    let (mut e, mut r) = (vec![0.0f32; n], vec![0.0f32; n]);
    let hier = preprocess(&hf, &mut e, &mut r).unwrap();
    let measured = DetailBounds::measure(&c);
    let constant = DetailBounds::constant(&c, 0.5).unwrap();
    let mut local_buf = vec![0.0f32; local_bounds_len(dem.width, dem.height)];
    let local = DetailBounds::measure_local(&c, &mut local_buf).unwrap();
    let cams = cameras(&c);

    // Triangle counts per mode over the views (for the throughput and the report).
    let mut base_tris = 0usize;
    let mut base_buf = (
        vec![0u64; scratch_len(dem.width, dem.height)],
        vec![[0.0f32; 3]; n],
        vec![[0u32; 3]; 2 * n],
    );
    for cam in &cams {
        let rf = Refiner::new(&hier, &hf, Crit::View(View::new(cam, TAU).unwrap())).unwrap();
        base_tris += rf
            .triangles(&mut base_buf.0, &mut base_buf.1, &mut base_buf.2)
            .unwrap()
            .triangles;
    }
    let mut counts = Vec::new();
    let (mut max_t, mut max_v) = (0usize, 0usize);
    for b in [&constant, &measured, &local] {
        let mut total = 0usize;
        for cam in &cams {
            let dr = DetailRefiner::new(&hier, &c, b, &View::new(cam, TAU).unwrap()).unwrap();
            let t = dr.triangle_count();
            let n = dr
                .count(&mut vec![0u64; detail_scratch_len(3 * t)])
                .unwrap();
            max_t = max_t.max(t);
            max_v = max_v.max(n.vertices);
            total += t;
        }
        counts.push(total);
    }
    // Buffers sized for the largest frame (the table is cleared every frame: O(its length)).
    let mut dbuf = (
        vec![0u64; detail_scratch_len(max_v)],
        vec![[0.0f32; 3]; max_v],
        vec![[0u32; 3]; max_t],
    );
    eprintln!(
        "detail bench, {} views, tau {TAU} px: base-only {base_tris} triangles; detail (constant 0.5 m) {}; detail (measured, global twist) {} (level-0 bound {:.2} m); detail (measured, local twist) {}",
        cams.len(),
        counts[0],
        counts[1],
        measured.error(0).unwrap_or(0.0),
        counts[2]
    );

    let mut g = crit.benchmark_group("detail_flyover_65537");
    g.sample_size(10);
    g.throughput(Throughput::Elements(base_tris as u64));
    g.bench_function("base_only_1025", |bch| {
        bch.iter(|| {
            let mut t = 0;
            for cam in &cams {
                let rf =
                    Refiner::new(&hier, &hf, Crit::View(View::new(cam, TAU).unwrap())).unwrap();
                t += rf
                    .triangles(&mut base_buf.0, &mut base_buf.1, &mut base_buf.2)
                    .unwrap()
                    .triangles;
            }
            black_box(t)
        })
    });
    g.throughput(Throughput::Elements(counts[0] as u64));
    g.bench_function("detail_constant_error", |bch| {
        bch.iter(|| {
            let mut t = 0;
            for cam in &cams {
                t += detail_frame(&hier, &c, &constant, cam, &mut dbuf);
            }
            black_box(t)
        })
    });
    g.throughput(Throughput::Elements(counts[1] as u64));
    g.bench_function("detail_measured_error", |bch| {
        bch.iter(|| {
            let mut t = 0;
            for cam in &cams {
                t += detail_frame(&hier, &c, &measured, cam, &mut dbuf);
            }
            black_box(t)
        })
    });
    g.throughput(Throughput::Elements(counts[2] as u64));
    g.bench_function("detail_local_bound", |bch| {
        bch.iter(|| {
            let mut t = 0;
            for cam in &cams {
                t += detail_frame(&hier, &c, &local, cam, &mut dbuf);
            }
            black_box(t)
        })
    });
    g.finish();

    let mut g = crit.benchmark_group("detail_bounds_1024");
    g.sample_size(10);
    g.bench_function("measure", |bch| {
        bch.iter(|| black_box(DetailBounds::measure(black_box(&c))))
    });
    g.bench_function("measure_local", |bch| {
        let mut buf = vec![0.0f32; local_bounds_len(dem.width, dem.height)];
        bch.iter(|| {
            black_box(
                DetailBounds::measure_local(black_box(&c), &mut buf)
                    .unwrap()
                    .error(0),
            )
        })
    });
    g.finish();
}

criterion_group!(detail, benches);
criterion_main!(detail);
