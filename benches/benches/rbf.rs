//! RBF approximation on adaptive grids (seed 002, sections 3 and 4) on the bundled Puget Sound
//! DEM (1025 x 1025, dx = dy = 160 m, z_scale 0.1).
//!
//! `cargo bench -p relief-benches --bench rbf` runs the criterion groups:
//! - `rbf_build`: adaptive grid, index map and influence sets (E = 20 m, cells 2..64, sigma 1),
//!   against one bilinear pass over every sample as the baseline;
//! - `rbf_discretize`: the CPU discretization of three 1024 x 1024 cascades of one view
//!   (visible texels only; throughput in texels/s), against bilinear interpolation of the DEM at
//!   the same texel centres.
//!
//! `RELIEF_RBF_TABLE=1 cargo bench -p relief-benches --bench rbf -- --list` prints the
//! accuracy-versus-time table over sigma and E first (single timed runs, evaluation at every
//! sample; the bilinear baseline time is measured in the same run).

use criterion::{BenchmarkId, Criterion, Throughput};
use relief_core::glam::{Vec2, Vec3};
use relief_core::rbf::{
    adaptive_grid_bound, build_adaptive_grid, discretize, fit_cascades, AdaptiveGrid,
    CascadeOptions, Cell, GridOptions, InfluenceSets, Rbf, RbfOptions,
};
use relief_core::{Camera, Heightfield, Surface, Terrain};
use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

fn load() -> relief_io::Dem {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/puget_sound_1k.png");
    let mut dem = relief_io::read_dem(&p, &Default::default()).expect("bundled DEM");
    dem.scale = dem.scale.with_spacing(160.0, 160.0).with_z_scale(0.1);
    dem
}

/// Owned grid, index and influence sets for one configuration.
struct Built {
    cells: Vec<Cell>,
    index: Vec<u32>,
    offsets: Vec<u32>,
    entries: Vec<u32>,
}

fn build(hf: &Heightfield<'_, f32>, e: f32, min: u32, max: u32, sigma: f32) -> Built {
    let (w, h) = (hf.width(), hf.height());
    let mut cells = vec![Cell::default(); adaptive_grid_bound(w, h).unwrap()];
    let opts = GridOptions::default()
        .with_max_error(e)
        .with_cells(min, max);
    let n = build_adaptive_grid(hf, &opts, &mut cells).unwrap();
    cells.truncate(n);
    let mut index = vec![0u32; (w * h) as usize];
    let rbf_opts = RbfOptions::default().with_sigma(sigma);
    let grid = AdaptiveGrid::new(w, h, &cells, &mut index).unwrap();
    let mut offsets = vec![0u32; InfluenceSets::offsets_len(&grid)];
    let mut entries = vec![0u32; InfluenceSets::entries_len(&grid, &rbf_opts).unwrap()];
    InfluenceSets::build(&grid, &rbf_opts, &mut offsets, &mut entries).unwrap();
    Built {
        cells,
        index,
        offsets,
        entries,
    }
}

impl Built {
    fn rbf(&mut self, w: u32, h: u32, sigma: f32) -> Rbf<'_> {
        let opts = RbfOptions::default().with_sigma(sigma);
        let grid = AdaptiveGrid::new(w, h, &self.cells, &mut self.index).unwrap();
        let sets =
            InfluenceSets::build(&grid, &opts, &mut self.offsets, &mut self.entries).unwrap();
        Rbf::new(grid, sets, &opts).unwrap()
    }
}

fn bilinear_pass(hf: &Heightfield<'_, f32>) -> f32 {
    let mut acc = 0.0f32;
    for y in 0..hf.height() {
        for x in 0..hf.width() {
            acc += hf
                .surface_height_grid(Surface::Bilinear, x as f32, y as f32)
                .unwrap_or(0.0);
        }
    }
    acc
}

fn bench_build(c: &mut Criterion) {
    let dem = load();
    let hf = dem.heightfield().unwrap();
    let (w, h) = (hf.width(), hf.height());
    let opts = GridOptions::default()
        .with_max_error(20.0)
        .with_cells(2, 64);
    let rbf_opts = RbfOptions::default();
    let mut cells = vec![Cell::default(); adaptive_grid_bound(w, h).unwrap()];
    let n = build_adaptive_grid(&hf, &opts, &mut cells).unwrap();
    let cells_n = cells[..n].to_vec();
    let mut index = vec![0u32; (w * h) as usize];
    let (mut offsets, mut entries) = {
        let grid = AdaptiveGrid::new(w, h, &cells_n, &mut index).unwrap();
        (
            vec![0u32; InfluenceSets::offsets_len(&grid)],
            vec![0u32; InfluenceSets::entries_len(&grid, &rbf_opts).unwrap()],
        )
    };
    let mut g = c.benchmark_group("rbf_build");
    g.sample_size(10);
    g.bench_function("baseline_bilinear_pass", |b| {
        b.iter(|| black_box(bilinear_pass(&hf)))
    });
    g.bench_function("adaptive_grid", |b| {
        b.iter(|| build_adaptive_grid(&hf, &opts, black_box(&mut cells)).unwrap())
    });
    g.bench_function("index_map", |b| {
        b.iter(|| {
            AdaptiveGrid::new(w, h, &cells_n, black_box(&mut index))
                .unwrap()
                .cells()
                .len()
        })
    });
    let mut index2 = vec![0u32; (w * h) as usize];
    let grid = AdaptiveGrid::new(w, h, &cells_n, &mut index2).unwrap();
    g.bench_function("influence_sets", |b| {
        b.iter(|| {
            InfluenceSets::build(&grid, &rbf_opts, black_box(&mut offsets), &mut entries)
                .unwrap()
                .len()
        })
    });
    g.finish();
    eprintln!(
        "rbf_build: {} cells, {} influence entries",
        cells_n.len(),
        entries.len()
    );
}

/// The benchmark view: from the south-west corner towards the middle, 1920 x 1080, fov 60.
fn view() -> Camera {
    Camera::new(
        Vec3::new(20_000.0, 15_000.0, 3_000.0),
        Vec3::new(90_000.0, 80_000.0, 0.0),
        60.0,
        1920,
        1080,
    )
    .unwrap()
}

fn bench_discretize(c: &mut Criterion) {
    let dem = load();
    let hf = dem.heightfield().unwrap();
    let (w, h) = (hf.width(), hf.height());
    let st = dem.stats();
    let mut built = build(&hf, 20.0, 2, 64, 1.0);
    let rbf = built.rbf(w, h, 1.0);
    let t = 1024u32;
    let n = (t * t) as usize;
    let fit = fit_cascades(
        &view(),
        rbf.grid(),
        &hf.scale(),
        (st.min as f32, st.max as f32),
        &CascadeOptions::default().with_resolution(t),
        None,
    )
    .unwrap();
    let mut masks = vec![vec![0u8; n]; 3];
    let mut visible = 0usize;
    for (m, k) in masks.iter_mut().zip(&fit.cascades) {
        visible += k.mask(m).unwrap();
    }
    let mut values = vec![0f32; n];
    let mut weights = vec![0f32; n];
    let mut g = c.benchmark_group("rbf_discretize");
    g.sample_size(10);
    g.throughput(Throughput::Elements(visible as u64));
    g.bench_function(BenchmarkId::new("bilinear_baseline", visible), |b| {
        b.iter(|| {
            let mut acc = 0.0f32;
            for (m, k) in masks.iter().zip(&fit.cascades) {
                for j in 0..t {
                    for i in 0..t {
                        if m[(j * t + i) as usize] == 1 {
                            let p: Vec2 = k.texel_center(i, j);
                            acc += hf
                                .surface_height_grid(Surface::Bilinear, p.x, p.y)
                                .unwrap_or(0.0);
                        }
                    }
                }
            }
            black_box(acc)
        })
    });
    // The visible-texel masks of the three cascades on the CPU (`Cascade::mask`): per-frame
    // work of the GPU cascade ray cast until its masks moved into the discretization shader.
    g.bench_function(BenchmarkId::new("mask_3x1024", visible), |b| {
        b.iter(|| {
            let mut total = 0;
            for (m, k) in masks.iter_mut().zip(&fit.cascades) {
                total += k.mask(m).unwrap();
            }
            black_box(total)
        })
    });
    g.bench_function(BenchmarkId::new("rbf_3x1024", visible), |b| {
        b.iter(|| {
            let mut total = 0;
            for (m, k) in masks.iter().zip(&fit.cascades) {
                total += discretize(&rbf, k, m, &mut values, &mut weights).unwrap();
            }
            black_box(total)
        })
    });
    g.finish();
    eprintln!(
        "rbf_discretize: {} visible texels of 3 x {t}^2, spacings {:?} grid units",
        visible,
        fit.cascades.map(|k| k.spacing)
    );
}

/// Accuracy versus time over sigma and E (single timed runs), printed as a Markdown table.
fn accuracy_table() {
    let dem = load();
    let hf = dem.heightfield().unwrap();
    let (w, h) = (hf.width(), hf.height());
    let t0 = Instant::now();
    black_box(bilinear_pass(&hf));
    let base_ms = t0.elapsed().as_secs_f64() * 1e3;
    println!("bilinear pass over all {} samples: {base_ms:.1} ms", w * h);
    println!("| sigma | E (m) | cells | entries | build ms | eval ms | eval / bilinear | max diff (m) | RMS diff (m) |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for &e in &[5.0f32, 20.0, 50.0] {
        for &sigma in &[0.5f32, 1.0, 2.0] {
            let t0 = Instant::now();
            let mut built = build(&hf, e, 1, 64, sigma);
            let build_ms = t0.elapsed().as_secs_f64() * 1e3;
            let (cells, entries) = (built.cells.len(), built.entries.len());
            let rbf = built.rbf(w, h, sigma);
            let t1 = Instant::now();
            let (mut max_d, mut sq) = (0.0f64, 0.0f64);
            for y in 0..h {
                for x in 0..w {
                    let v = rbf.eval(Vec2::new(x as f32, y as f32)).unwrap();
                    let d = f64::from(v) - f64::from(hf.local_z(x, y));
                    max_d = max_d.max(d.abs());
                    sq += d * d;
                }
            }
            let eval_ms = t1.elapsed().as_secs_f64() * 1e3;
            let rms = (sq / f64::from(w * h)).sqrt();
            println!(
                "| {sigma} | {e} | {cells} | {entries} | {build_ms:.0} | {eval_ms:.0} | {:.1}x | {max_d:.1} | {rms:.2} |",
                eval_ms / base_ms
            );
        }
    }
}

fn main() {
    if std::env::var_os("RELIEF_RBF_TABLE").is_some() {
        accuracy_table();
    }
    let mut c = Criterion::default().configure_from_args();
    bench_build(&mut c);
    bench_discretize(&mut c);
    c.final_summary();
}
