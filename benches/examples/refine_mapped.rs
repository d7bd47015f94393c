//! View-dependent refinement straight from memory-mapped files (issue 6, out-of-core), with
//! the growth from the smallest grid to the others measured **in the same run**: the bundled
//! Puget Sound DEM upsampled to `(1024 f + 1)^2` for each factor `f` given (as in
//! `refine_scale`), preprocessed once, packed into interleaved 8-byte records and written with
//! `relief_io::write_records` under `$SCALE_DIR` (default /tmp; kept between runs, so later runs
//! start at once: delete `relief_scale_*.{f32,rec}` to rebuild). All grids are then mapped
//! (`MappedGrid`, `MappedRecords`: nothing is read up front) and refined for the same camera as
//! `refine_scale` at 1 and 4 px, grid after grid in each of `RUNS` rounds (default 15), so that
//! load from other work falls on every grid alike:
//! - warm: two back-to-back frames per round, the second timed; fastest over the rounds;
//! - cold: one frame after writing a 256 MiB buffer (evicts the caches and the TLB); median;
//! - fly-over: a new view every round along a 20 km straight path across the map at 3 km
//!   (frames touch new records, new pages of the mappings and of the scratch); mean.
//!
//! Variants: the records in the mapped file with the refinement scratch in a `Vec` or in huge
//! pages (`relief_io::HugeBuffer`), and the records copied into huge pages with a huge-page
//! scratch. One untimed fly-over of every grid comes first (so the mapped files' page faults on
//! the path are not in the numbers).
//! Ratios are against the first factor's grid.
//!
//! `RUNS=21 cargo run --release -p relief-benches --example refine_mapped -- 1 4 16`

use relief_core::refine::{scratch_len, Criterion, RecordLayout, Refiner, VertexRecord, View};
use std::hint::black_box;
use std::time::Instant;

mod common;
use common::{camera, mapped_grid, Args, Scratch, BENCH_EYE_X};

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let args = Args::get();
    let (runs, dir) = (args.runs, &args.dir);
    let base = args.dem.heightfield().unwrap();
    // Map every grid (writing the files first where they are missing).
    let maps: Vec<_> = args
        .factors
        .iter()
        .map(|&f| mapped_grid(&base, f, dir))
        .collect();
    // The same records copied into anonymous memory with huge pages requested.
    let copies: Vec<_> = maps
        .iter()
        .map(|(_, _, m)| {
            let mut b = relief_io::HugeBuffer::<VertexRecord>::zeroed(m.records().len()).unwrap();
            b.as_mut_slice().copy_from_slice(m.records());
            b
        })
        .collect();
    if let Ok(s) = std::fs::read_to_string("/proc/self/smaps_rollup") {
        for l in s.lines().filter(|l| l.starts_with("AnonHugePages")) {
            eprintln!("after the huge-page copies: {l}");
        }
    }
    // Heightfields validate the mapped samples once (a sequential read of each grid file).
    let grids: Vec<_> = maps
        .iter()
        .map(|(n, g, m)| (*n, g.heightfield().unwrap(), m.hierarchy().unwrap()))
        .collect();
    let copied: Vec<_> = grids
        .iter()
        .zip(&copies)
        .map(|((n, hf, h), b)| {
            let h = relief_core::refine::records_hierarchy(
                b.as_slice(),
                RecordLayout::Interleaved,
                *n,
                *n,
                h.scale(),
                h.z_range(),
            )
            .unwrap();
            (*n, *hf, h)
        })
        .collect();
    // One untimed fly-over on every grid first, so that page faults of the mapped files on the
    // path fall outside the measurements (and on the first variant no more than the others).
    for (n, hf, h) in &grids {
        let mut scratch = vec![0u64; scratch_len(*n, *n)];
        let (mut v, mut t) = (vec![[0.0f32; 3]; 1 << 20], vec![[0u32; 3]; 1 << 21]);
        for k in 0..runs {
            let x = 122_000.0 - 20_000.0 * k as f32 / runs as f32;
            for tau in [1.0f32, 4.0] {
                let c = Criterion::View(View::new(&camera(x), tau).unwrap());
                let r = Refiner::new(h, hf, c).unwrap();
                black_box(r.triangles(&mut scratch, &mut v, &mut t).unwrap());
            }
        }
    }
    let mut evict = vec![0u64; 32 << 20];
    let mut evict_caches = || {
        for (i, x) in evict.iter_mut().enumerate() {
            *x = x.wrapping_add(i as u64);
        }
        black_box(&evict);
    };
    println!("| grid | records | scratch | tau px | triangles | warm ms (fastest) | cold ms (median) | fly-over ms (mean) | warm / cold / fly-over vs first grid |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for (records, grids, huge) in [
        ("mapped file", &grids, false),
        ("mapped file", &grids, true),
        ("huge-page copy", &copied, true),
    ] {
        for tau in [1.0f32, 4.0] {
            let view = |x: f32| Criterion::View(View::new(&camera(x), tau).unwrap());
            let mut state: Vec<_> = grids
                .iter()
                .map(|(n, hf, h)| {
                    let r = Refiner::new(h, hf, view(BENCH_EYE_X)).unwrap();
                    let mut scratch = Scratch::new(scratch_len(*n, *n), huge);
                    let tris = r.count(scratch.as_mut_slice()).unwrap().triangles;
                    (scratch, tris, f64::INFINITY, Vec::new(), 0.0)
                })
                .collect();
            let mut verts = vec![[0.0f32; 3]; 1 << 20];
            let mut tris = vec![[0u32; 3]; 1 << 21];
            for k in 0..runs {
                let x = 122_000.0 - 20_000.0 * k as f32 / runs as f32;
                for ((_, hf, h), st) in grids.iter().zip(state.iter_mut()) {
                    let scratch = st.0.as_mut_slice();
                    let r = Refiner::new(h, hf, view(BENCH_EYE_X)).unwrap();
                    let mut frame = || {
                        let s = Instant::now();
                        black_box(r.triangles(scratch, &mut verts, &mut tris).unwrap());
                        s.elapsed().as_secs_f64() * 1e3
                    };
                    frame();
                    st.2 = f64::min(st.2, frame());
                    evict_caches();
                    let cold = frame();
                    st.3.push(cold);
                    let fly = Refiner::new(h, hf, view(x)).unwrap();
                    let s = Instant::now();
                    black_box(fly.triangles(scratch, &mut verts, &mut tris).unwrap());
                    st.4 += s.elapsed().as_secs_f64() * 1e3 / runs as f64;
                }
            }
            let first = (state[0].2, median(&mut state[0].3.clone()), state[0].4);
            for ((n, _, _), st) in grids.iter().zip(state.iter_mut()) {
                let cold = median(&mut st.3);
                println!(
                    "| {n}^2 | {records} | {} | {tau} | {} | {:.3} | {cold:.3} | {:.3} | {:.2}x / {:.2}x / {:.2}x |",
                    if huge { "huge pages" } else { "Vec" },
                    st.1,
                    st.2,
                    st.4,
                    st.2 / first.0,
                    cold / first.1,
                    st.4 / first.2
                );
            }
        }
    }
}
