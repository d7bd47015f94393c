//! Ray traversal and tracing benchmarks (issue 4).
//!
//! `cargo bench -p relief-benches --bench rays`
//!
//! - `rays_traversal/*`: the run-length DDA (yielding whole runs) against the cell DDA (yielding
//!   cells) over the same 256 lines in uniformly spread orientations across a 1024 x 1024 grid,
//!   and by run length (slopes `1 / L`), both walked by `for_each` (the DDAs' own `fold`); the
//!   `*-next` rows walk them by `for` loops calling `next`.
//! - `rays_trace_*`: full tracing of camera rays on the bundled Puget Sound DEM (1025 x 1025,
//!   160 m spacing, z 0.1), one thread, triangles surface: cell DDA, run DDA (whole-run
//!   rejection), max-mip, and max-mip through sixteen-wide nodes where the CPU has AVX-512F
//!   (`maxmip-wide`); for a camera view and a grazing view.
//!
//! With `RELIEF_RAYS_TABLE=1` it first prints a table of interleaved measurements (A, B, A, B,
//! ... 31 rounds for traversal, 15 for tracing; the fastest round of each and their ratio), which
//! is robust against load from other processes on a shared machine; then march error by sample
//! count; then max-mip ray by ray against the AVX-512 packet path and against the sixteen-wide
//! walk (where the CPU has them; their hits are checked against ray by ray first), in rounds
//! and in chunks of 512 rays (fastest of 9 per chunk, summed: see [`chunked`]); the
//! criterion groups follow. `RELIEF_RAYS_TRAVERSAL=1` prints only the traversal rows,
//! `RELIEF_RAYS_MIP=1` only the max-mip packet and wide rows.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use relief_core::glam::{DVec2, Vec3};
use relief_core::ray::{
    GridLine, MarchOptions, MaxMip, Ray, RayTracer, RunAccel, Trace, PACKET_LANES,
};
use relief_core::{Camera, Heightfield, Surface};
use std::hint::black_box;
use std::path::Path;

fn load() -> relief_io::Dem {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/puget_sound_1k.png");
    let mut dem = relief_io::read_dem(&p, &Default::default()).expect("bundled DEM");
    dem.scale = dem.scale.with_spacing(160.0, 160.0).with_z_scale(0.1);
    dem
}

const N: u32 = 1024;

/// Lines from near the centre to the border in `n` orientations spread over the full circle.
fn orientation_lines(n: usize) -> Vec<GridLine> {
    let c = DVec2::new(512.37, 511.71);
    (0..n)
        .map(|i| {
            let a = (i as f64 + 0.5) / n as f64 * std::f64::consts::TAU;
            let d = DVec2::new(a.cos(), a.sin());
            GridLine::new(c, d, c + d * 4096.0, [N, N]).unwrap()
        })
        .collect()
}

/// Lines with slope `1 / len` (mean run length `len`), from the lower-left area.
fn slope_lines(len: f64) -> Vec<GridLine> {
    (0..32)
        .map(|i| {
            let s = DVec2::new(1.3 + i as f64 * 0.71, 2.1 + i as f64 * 0.37);
            let d = DVec2::new(len, 1.0);
            GridLine::new(s, d, s + d * 4096.0, [N, N]).unwrap()
        })
        .collect()
}

/// The textbook floating-point Amanatides & Woo loop (f64 `tMax` / `tDelta`), as a second
/// baseline: bench-only code, not in the library (the library's cell DDA is exact fixed point).
fn walk_float_aw(rays: &[(DVec2, DVec2)]) -> u64 {
    let mut acc = 0u64;
    for &(s, d) in rays {
        let (mut x, mut y) = (s.x.floor() as i64, s.y.floor() as i64);
        let (sx, sy) = (
            if d.x >= 0.0 { 1 } else { -1 },
            if d.y >= 0.0 { 1 } else { -1 },
        );
        let next = |c: i64, st: i64| (c + i64::from(st > 0)) as f64;
        let (ddx, ddy) = (1.0 / d.x.abs(), 1.0 / d.y.abs());
        let mut tx = if d.x != 0.0 {
            (next(x, sx) - s.x) / d.x
        } else {
            f64::INFINITY
        };
        let mut ty = if d.y != 0.0 {
            (next(y, sy) - s.y) / d.y
        } else {
            f64::INFINITY
        };
        let n = N as i64;
        while x >= 0 && y >= 0 && x < n && y < n {
            acc = acc.wrapping_add((x ^ y) as u64);
            if tx < ty {
                x += sx;
                tx += ddx;
            } else if ty < tx {
                y += sy;
                ty += ddy;
            } else {
                x += sx;
                y += sy;
                tx += ddx;
                ty += ddy;
            }
        }
    }
    acc
}

fn orientation_rays(n: usize) -> Vec<(DVec2, DVec2)> {
    let c = DVec2::new(512.37, 511.71);
    (0..n)
        .map(|i| {
            let a = (i as f64 + 0.5) / n as f64 * std::f64::consts::TAU;
            (c, DVec2::new(a.cos(), a.sin()))
        })
        .collect()
}

/// Both DDAs by internal iteration (`for_each`, which runs their `Iterator::fold`: the loops
/// that test only the row). Not inlined (nor `walk_runs`): every traversal row times the same
/// machine code of each side.
/// Inlined into each timing closure, the cell DDA's loop landed at different offsets in its
/// 64-byte line and ran at 0.6-0.75 or 1.0-1.15 ns/cell depending on the closure (see
/// BENCHMARKS.md, Rays); build with `RUSTFLAGS="-C llvm-args=-align-loops=64"` to pin the
/// loops' alignment as well.
#[inline(never)]
fn walk_cells(lines: &[GridLine]) -> u64 {
    let mut acc = 0u64;
    for l in lines {
        l.cells()
            .for_each(|[x, y]| acc = acc.wrapping_add((x ^ y) as u64));
    }
    acc
}

#[inline(never)]
fn walk_runs(lines: &[GridLine]) -> u64 {
    let mut acc = 0u64;
    for l in lines {
        l.runs()
            .for_each(|r| acc = acc.wrapping_add((r.start[0] ^ r.start[1]) as u64 + r.len as u64));
    }
    acc
}

/// The cell DDA by external iteration (a `for` loop calling `next`), as `walk_cells` was
/// written before the DDAs had their own `fold`.
#[inline(never)]
fn walk_cells_next(lines: &[GridLine]) -> u64 {
    let mut acc = 0u64;
    for l in lines {
        for [x, y] in l.cells() {
            acc = acc.wrapping_add((x ^ y) as u64);
        }
    }
    acc
}

/// The run DDA by external iteration, as `walk_cells_next`.
#[inline(never)]
fn walk_runs_next(lines: &[GridLine]) -> u64 {
    let mut acc = 0u64;
    for l in lines {
        for r in l.runs() {
            acc = acc.wrapping_add((r.start[0] ^ r.start[1]) as u64 + r.len as u64);
        }
    }
    acc
}

fn traversal(c: &mut Criterion) {
    let lines = orientation_lines(256);
    let cells: u64 = lines.iter().map(|l| l.cells().count() as u64).sum();
    let mut g = c.benchmark_group("rays_traversal");
    g.throughput(Throughput::Elements(cells));
    g.bench_function("all_orientations/cell-dda", |b| {
        b.iter(|| walk_cells(black_box(&lines)))
    });
    g.bench_function("all_orientations/run-dda", |b| {
        b.iter(|| walk_runs(black_box(&lines)))
    });
    g.bench_function("all_orientations/cell-dda-next", |b| {
        b.iter(|| walk_cells_next(black_box(&lines)))
    });
    g.bench_function("all_orientations/run-dda-next", |b| {
        b.iter(|| walk_runs_next(black_box(&lines)))
    });
    for len in [1.1f64, 2.0, 4.0, 8.0, 25.0, 100.0] {
        let lines = slope_lines(len + 0.013);
        let cells: u64 = lines.iter().map(|l| l.cells().count() as u64).sum();
        g.throughput(Throughput::Elements(cells));
        g.bench_with_input(
            BenchmarkId::new("run_length/cell-dda", len),
            &lines,
            |b, l| b.iter(|| walk_cells(black_box(l))),
        );
        g.bench_with_input(
            BenchmarkId::new("run_length/run-dda", len),
            &lines,
            |b, l| b.iter(|| walk_runs(black_box(l))),
        );
    }
    g.finish();
}

fn camera_rays(cam: &Camera) -> Vec<Ray> {
    let mut v = Vec::with_capacity((cam.width * cam.height) as usize);
    for j in 0..cam.height {
        for i in 0..cam.width {
            let (o, d) = cam.ray(i, j);
            v.push(Ray::new(o, d).unwrap());
        }
    }
    v
}

fn tracing(c: &mut Criterion) {
    let dem = load();
    let hf = dem.heightfield().unwrap();
    let tracer = RayTracer::new(&hf, Surface::Triangles);
    let (lo, hi) = tracer.height_range();
    let mut rbuf = vec![0.0f32; RunAccel::len(dem.width, dem.height).unwrap()];
    let acc = RunAccel::build(&hf, &mut rbuf).unwrap();
    let mut mbuf = vec![0.0f32; MaxMip::len(dem.width, dem.height).unwrap()];
    let mip = MaxMip::build(&hf, &mut mbuf).unwrap();
    let views = views(lo, hi);
    for (name, cam) in views {
        let rays = camera_rays(&cam);
        let mut g = c.benchmark_group(format!("rays_trace_{name}"));
        g.throughput(Throughput::Elements(rays.len() as u64));
        g.sample_size(10);
        g.bench_function("cell-dda", |b| {
            b.iter(|| {
                let mut hits = 0u32;
                for r in &rays {
                    hits += tracer.trace_cell_dda(black_box(r)).hit.is_some() as u32;
                }
                hits
            })
        });
        g.bench_function("run-dda", |b| {
            b.iter(|| {
                let mut hits = 0u32;
                for r in &rays {
                    hits += tracer
                        .trace_run_dda(black_box(r), &acc)
                        .unwrap()
                        .hit
                        .is_some() as u32;
                }
                hits
            })
        });
        g.bench_function("maxmip", |b| {
            b.iter(|| {
                let mut hits = 0u32;
                for r in &rays {
                    hits += tracer
                        .trace_maxmip(black_box(r), &mip)
                        .unwrap()
                        .hit
                        .is_some() as u32;
                }
                hits
            })
        });
        for (label, wide) in wide_forms(&tracer, &mip) {
            g.bench_function(label, |b| {
                b.iter(|| {
                    let mut hits = 0u32;
                    for r in &rays {
                        hits += wide(black_box(r)).hit.is_some() as u32;
                    }
                    hits
                })
            });
        }
        g.finish();
    }
}

/// One sixteen-wide walk of a view's rays.
type Wide<'a> = Box<dyn Fn(&Ray) -> Trace + 'a>;

/// The sixteen-wide walk in every form this CPU runs: the portable one, and AVX2 and AVX-512
/// where detected.
fn wide_forms<'a>(
    tracer: &'a RayTracer<'a, Heightfield<'a, f32>>,
    mip: &'a MaxMip<'a>,
) -> Vec<(&'static str, Wide<'a>)> {
    let mut wides: Vec<(&str, Wide)> = vec![(
        "maxmip-wide-portable",
        Box::new(|r: &Ray| tracer.trace_maxmip_wide(r, mip).unwrap()),
    )];
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        wides.push((
            "maxmip-wide-avx2",
            // SAFETY: AVX2 detected above.
            Box::new(|r: &Ray| unsafe { tracer.trace_maxmip_wide_avx2(r, mip) }.unwrap()),
        ));
    }
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx512f") {
        wides.push((
            "maxmip-wide",
            // SAFETY: AVX-512F detected above.
            Box::new(|r: &Ray| unsafe { tracer.trace_maxmip_wide_avx512(r, mip) }.unwrap()),
        ));
    }
    wides
}

/// Fastest round of A and of B (seconds) and their ratio, alternating A and B.
fn interleaved(
    rounds: usize,
    mut a: impl FnMut() -> u64,
    mut b: impl FnMut() -> u64,
) -> (f64, f64, f64) {
    let (mut ta, mut tb, mut r) = (Vec::new(), Vec::new(), Vec::new());
    // One untimed round of each first (caches, frequency, lazy page faults).
    let mut sink = a().wrapping_add(b());
    for _ in 0..rounds {
        let t = std::time::Instant::now();
        sink = sink.wrapping_add(a());
        let x = t.elapsed().as_secs_f64();
        let t = std::time::Instant::now();
        sink = sink.wrapping_add(b());
        let y = t.elapsed().as_secs_f64();
        ta.push(x);
        tb.push(y);
        r.push(x / y);
    }
    black_box(sink);
    // Other processes only ever add time: the fastest round is the best estimate of the cost.
    let min = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
    let (ma, mb) = (min(&ta), min(&tb));
    let _ = r;
    (ma, mb, ma / mb)
}

fn table() {
    if std::env::var("RELIEF_RAYS_TABLE").is_err() {
        return;
    }
    println!("| comparison | A (fastest round) | B (fastest round) | A / B |");
    println!("|---|---|---|---|");
    traversal_table();
    tracing_table();
}

/// One traversal row: `rep` passes of `fa` (A) and `fb` (B) interleaved over 31 rounds, fastest
/// round of each, per cell of one pass.
fn traversal_row(label: &str, cells: u64, fa: impl Fn() -> u64, fb: impl Fn() -> u64) {
    let rep = 100;
    let (a, b, r) = interleaved(
        31,
        || (0..rep).map(|_| fa()).sum(),
        || (0..rep).map(|_| fb()).sum(),
    );
    let per = (rep as u64 * cells) as f64;
    println!(
        "| traversal, {label} | {:.2} ns/cell | {:.2} ns/cell | {r:.2} |",
        a / per * 1e9,
        b / per * 1e9
    );
}

/// Run DDA against cell DDA traversal rows of the table.
fn traversal_table() {
    let lines = orientation_lines(256);
    let cells: u64 = lines.iter().map(|l| l.cells().count() as u64).sum();
    traversal_row(
        &format!("256 orientations ({cells} cells), internal iteration (`for_each`): cell DDA (A) vs run DDA (B)"),
        cells,
        || walk_cells(black_box(&lines)),
        || walk_runs(black_box(&lines)),
    );
    // The same comparison timed in short pieces (16 lines x 10 passes, about 0.1 ms), fastest
    // of 15 per piece, summed: robust against preemption on a loaded machine.
    let (a, b, r) = chunked(
        lines.len(),
        16,
        15,
        |rg| {
            (0..10)
                .map(|_| walk_cells(black_box(&lines[rg.clone()])))
                .sum()
        },
        |rg| {
            (0..10)
                .map(|_| walk_runs(black_box(&lines[rg.clone()])))
                .sum()
        },
    );
    let per = (10 * cells) as f64;
    println!(
        "| traversal, 256 orientations, chunks of 16 lines (fastest of 15 each): cell DDA (A) vs run DDA (B) | {:.2} ns/cell | {:.2} ns/cell | {r:.2} |",
        a / per * 1e9,
        b / per * 1e9
    );
    assert_eq!(walk_cells_next(&lines), walk_cells(&lines));
    assert_eq!(walk_runs_next(&lines), walk_runs(&lines));
    traversal_row(
        "256 orientations, external iteration (`for` loops calling `next`): cell DDA (A) vs run DDA (B)",
        cells,
        || walk_cells_next(black_box(&lines)),
        || walk_runs_next(black_box(&lines)),
    );
    let frays = orientation_rays(256);
    traversal_row(
        "256 orientations: textbook f64 Amanatides & Woo (A, bench-only) vs run DDA (B)",
        cells,
        || walk_float_aw(black_box(&frays)),
        || walk_runs(black_box(&lines)),
    );
    for len in [1.1f64, 2.0, 4.0, 8.0, 25.0, 100.0] {
        let lines = slope_lines(len + 0.013);
        let cells: u64 = lines.iter().map(|l| l.cells().count() as u64).sum();
        traversal_row(
            &format!("run length {len}: cell DDA (A) vs run DDA (B)"),
            cells,
            || walk_cells(black_box(&lines)),
            || walk_runs(black_box(&lines)),
        );
    }
}

/// Full tracing rows of the table and the march tables.
fn tracing_table() {
    let dem = load();
    let hf = dem.heightfield().unwrap();
    let tracer = RayTracer::new(&hf, Surface::Triangles);
    let (lo, hi) = tracer.height_range();
    let mut rbuf = vec![0.0f32; RunAccel::len(dem.width, dem.height).unwrap()];
    let acc = RunAccel::build(&hf, &mut rbuf).unwrap();
    let mut mbuf = vec![0.0f32; MaxMip::len(dem.width, dem.height).unwrap()];
    let mip = MaxMip::build(&hf, &mut mbuf).unwrap();
    for (name, cam) in views(lo, hi) {
        let rays = camera_rays(&cam);
        let n = rays.len() as f64;
        let cell = || {
            rays.iter()
                .map(|r| tracer.trace_cell_dda(r).hit.is_some() as u64)
                .sum::<u64>()
        };
        let run = || {
            rays.iter()
                .map(|r| tracer.trace_run_dda(r, &acc).unwrap().hit.is_some() as u64)
                .sum::<u64>()
        };
        let mm = || {
            rays.iter()
                .map(|r| tracer.trace_maxmip(r, &mip).unwrap().hit.is_some() as u64)
                .sum::<u64>()
        };
        let (a, b, r) = interleaved(15, cell, run);
        println!(
            "| full tracing, {name} view, {} rays: cell DDA (A) vs run DDA (B) | {:.0} rays/s | {:.0} rays/s | {r:.2} |",
            rays.len(),
            n / a,
            n / b
        );
        let (a, b, r) = interleaved(15, cell, mm);
        println!(
            "| full tracing, {name} view: cell DDA (A) vs max-mip (B) | {:.0} rays/s | {:.0} rays/s | {r:.2} |",
            n / a,
            n / b
        );
    }
    for (name, cam) in views(lo, hi) {
        march_table(&tracer, name, &camera_rays(&cam));
    }
}

/// March error against the exact cell DDA (triangles) and time, by sample count.
fn march_table(
    tracer: &RayTracer<'_, relief_core::Heightfield<'_, f32>>,
    name: &str,
    rays: &[Ray],
) {
    let exact: Vec<Option<f64>> = rays
        .iter()
        .map(|r| tracer.trace_cell_dda(r).hit.map(|h| h.t))
        .collect();
    println!();
    println!(
        "March on the {name} view ({} rays, triangles, 8 binary steps) against the exact cell DDA:",
        rays.len()
    );
    println!();
    println!("| samples | time per ray | wrong hit/miss | median rel. error | 99th pct rel. error | max step (cells) |");
    println!("|---|---|---|---|---|---|");
    for n in [32u32, 128, 512, 2048] {
        let opts = MarchOptions::default().with_samples(n);
        let t = std::time::Instant::now();
        let res: Vec<_> = rays
            .iter()
            .map(|r| tracer.trace_march(r, &opts).unwrap())
            .collect();
        let per = t.elapsed().as_secs_f64() / rays.len() as f64;
        let mut wrong = 0usize;
        let mut errs = Vec::new();
        let mut step = 0.0f64;
        for (m, e) in res.iter().zip(&exact) {
            step = step.max(m.step_cells);
            match (m.trace.hit, e) {
                (Some(h), Some(e)) => errs.push((h.t - e).abs() / e),
                (None, None) => {}
                _ => wrong += 1,
            }
        }
        errs.sort_by(|a, b| a.total_cmp(b));
        let pct = |q: f64| {
            errs.get(((errs.len() as f64 - 1.0) * q) as usize)
                .copied()
                .unwrap_or(0.0)
        };
        println!(
            "| {n} | {:.2} us | {wrong} | {:.1e} | {:.1e} | {step:.2} |",
            per * 1e6,
            pct(0.5),
            pct(0.99)
        );
    }
}

fn views(lo: f32, hi: f32) -> [(&'static str, Camera); 2] {
    [
        (
            "camera",
            Camera::new(
                Vec3::new(20_000.0, 15_000.0, hi + 3_000.0),
                Vec3::new(90_000.0, 100_000.0, lo),
                60.0,
                192,
                128,
            )
            .unwrap(),
        ),
        (
            "grazing",
            Camera::new(
                Vec3::new(2_000.0, 3_000.0, hi + 30.0),
                Vec3::new(160_000.0, 150_000.0, hi + 10.0),
                30.0,
                192,
                128,
            )
            .unwrap(),
        ),
    ]
}

/// Fastest of `reps` alternating timings of A and of B on each chunk of `chunk` rays, summed
/// over the chunks: each timing is short (about 0.1 ms), so most run without being preempted on
/// a loaded machine. Chunks are traced repeatedly, so their pyramid nodes are warmer in the
/// caches than in one pass over the image. Returns the seconds of A and B and A / B.
fn chunked(
    n: usize,
    chunk: usize,
    reps: usize,
    mut a: impl FnMut(std::ops::Range<usize>) -> u64,
    mut b: impl FnMut(std::ops::Range<usize>) -> u64,
) -> (f64, f64, f64) {
    let (mut ta, mut tb, mut sink) = (0.0, 0.0, 0u64);
    for s in (0..n).step_by(chunk) {
        let r = s..(s + chunk).min(n);
        let (mut ma, mut mb) = (f64::INFINITY, f64::INFINITY);
        for _ in 0..reps {
            let t = std::time::Instant::now();
            sink = sink.wrapping_add(a(r.clone()));
            ma = ma.min(t.elapsed().as_secs_f64());
            let t = std::time::Instant::now();
            sink = sink.wrapping_add(b(r.clone()));
            mb = mb.min(t.elapsed().as_secs_f64());
        }
        ta += ma;
        tb += mb;
    }
    black_box(sink);
    (ta, tb, ta / tb)
}

/// Max-mip ray by ray (A) against the AVX-512 packet path (B) on both views, where the CPU has
/// AVX-512; the packet results are checked to equal the scalar ones before timing.
fn mip_table() {
    let dem = load();
    let hf = dem.heightfield().unwrap();
    let tracer = RayTracer::new(&hf, Surface::Triangles);
    let (lo, hi) = tracer.height_range();
    let mut mbuf = vec![0.0f32; MaxMip::len(dem.width, dem.height).unwrap()];
    let mip = MaxMip::build(&hf, &mut mbuf).unwrap();
    for (name, cam) in views(lo, hi) {
        let rays = camera_rays(&cam);
        let n = rays.len() as f64;
        let scalar: Vec<Trace> = rays
            .iter()
            .map(|r| tracer.trace_maxmip(r, &mip).unwrap())
            .collect();

        let mut out = vec![Trace::default(); rays.len()];
        tracer.trace_maxmip_packet(&rays, &mip, &mut out).unwrap();
        assert_eq!(out, scalar, "packet path differs from ray by ray");
        // Ray by ray (the A side of every row): hits of a slice of the rays.
        let by_ray = |rs: &[Ray]| {
            rs.iter()
                .map(|r| tracer.trace_maxmip(r, &mip).unwrap().hit.is_some() as u64)
                .sum::<u64>()
        };
        let mm = || by_ray(&rays);
        // The two rows of one B side: whole views in rounds, and chunks of 512 rays.
        let rows = |b_side: &str, whole: (f64, f64, f64), chunks: (f64, f64, f64)| {
            let (a, b, r) = whole;
            println!(
                "| max-mip, {name} view: ray by ray (A) vs {b_side} (B) | {:.0} rays/s | {:.0} rays/s | {r:.2} |",
                n / a,
                n / b
            );
            let (a, b, r) = chunks;
            println!(
                "| max-mip, {name} view, chunks of 512 rays (fastest of 9 each): ray by ray (A) vs {b_side} (B) | {:.0} rays/s | {:.0} rays/s | {r:.2} |",
                n / a,
                n / b
            );
        };
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx512f") && std::is_x86_feature_detected!("avx512dq") {
            let mut o3 = vec![Trace::default(); rays.len()];
            // SAFETY: AVX-512F and DQ detected above.
            unsafe { tracer.trace_maxmip_packet_avx512(&rays, &mip, &mut o3) }.unwrap();
            assert_eq!(o3, scalar, "AVX-512 packet path differs from ray by ray");
            let pk3 = || {
                // SAFETY: as above.
                unsafe { tracer.trace_maxmip_packet_avx512(&rays, &mip, &mut o3) }.unwrap();
                o3.iter().filter(|t| t.hit.is_some()).count() as u64
            };
            let whole = interleaved(15, mm, pk3);
            let mut o4 = vec![Trace::default(); rays.len()];
            let chunks = chunked(
                rays.len(),
                512,
                9,
                |rg| by_ray(&rays[rg]),
                |rg| {
                    let (rs, os) = (&rays[rg.clone()], &mut o4[rg]);
                    // SAFETY: as above.
                    unsafe { tracer.trace_maxmip_packet_avx512(rs, &mip, os) }.unwrap();
                    os.iter().filter(|t| t.hit.is_some()).count() as u64
                },
            );
            rows(&format!("packet of {PACKET_LANES}, AVX-512"), whole, chunks);
        }
        // The sixteen-wide walk in every form this CPU runs.
        let wides = wide_forms(&tracer, &mip);
        for (label, wide) in &wides {
            for (r, s) in rays.iter().zip(&scalar) {
                let w = wide(r);
                assert_eq!(w.hit, s.hit, "the wide walk's hit differs from ray by ray");
                assert!(w.cells <= s.cells);
            }
            let by_wide = |rs: &[Ray]| rs.iter().map(|r| wide(r).hit.is_some() as u64).sum::<u64>();
            let whole = interleaved(15, mm, || by_wide(&rays));
            let chunks = chunked(
                rays.len(),
                512,
                9,
                |rg| by_ray(&rays[rg]),
                |rg| by_wide(&rays[rg]),
            );
            rows(&format!("sixteen-wide walk, {label}"), whole, chunks);
        }
        // The slice form of the wide walk (two rays' walks interleaved), AVX2 where detected.
        let wide_rays = |rs: &[Ray], os: &mut [Trace]| {
            #[cfg(target_arch = "x86_64")]
            if std::is_x86_feature_detected!("avx2") {
                // SAFETY: AVX2 detected above.
                return unsafe { tracer.trace_maxmip_wide_rays_avx2(rs, &mip, os) }.unwrap();
            }
            tracer.trace_maxmip_wide_rays(rs, &mip, os).unwrap();
        };
        let mut ow = vec![Trace::default(); rays.len()];
        wide_rays(&rays, &mut ow);
        // The portable form's hits and cells (the AVX2 form's conservative `f32` node test
        // may take more steps).
        for (r, w) in rays.iter().zip(&ow) {
            let p = tracer.trace_maxmip_wide(r, &mip).unwrap();
            assert_eq!((w.hit, w.cells), (p.hit, p.cells));
            assert!(w.steps >= p.steps);
        }
        let by_rays = |rs: &[Ray], os: &mut [Trace]| {
            wide_rays(rs, os);
            os.iter().filter(|t| t.hit.is_some()).count() as u64
        };
        let whole = interleaved(15, mm, || by_rays(&rays, &mut ow));
        let mut ow2 = vec![Trace::default(); rays.len()];
        let chunks = chunked(
            rays.len(),
            512,
            9,
            |rg| by_ray(&rays[rg]),
            |rg| by_rays(&rays[rg.clone()], &mut ow2[rg]),
        );
        rows(
            "sixteen-wide walk, two rays interleaved (AVX2 where detected)",
            whole,
            chunks,
        );
    }
}

fn table_bench(_c: &mut Criterion) {
    if std::env::var("RELIEF_RAYS_TRAVERSAL").is_ok() {
        traversal_table();
        return;
    }
    if std::env::var("RELIEF_RAYS_MIP").is_ok() {
        mip_table();
        return;
    }
    table();
    if std::env::var("RELIEF_RAYS_TABLE").is_ok() {
        mip_table();
    }
}

criterion_group!(benches, table_bench, traversal, tracing);
criterion_main!(benches);
