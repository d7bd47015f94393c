//! Which cache lines (64 B) and 4 KiB pages one view-dependent frame's vertices fall on, in the
//! records and in the marks bitmap, on the grids of `refine_mapped` (same files, same camera):
//! the bitmap indexed row-major (as before record order) and in record order (what
//! view-dependent frames over interleaved records of a square grid use now). Counts of the
//! mesh's vertices only (the traversal also reads the records of vertices it decides to keep
//! out); the rank prefix is indexed like the bitmap (one `u64` per 64 bits) and touches 8x the
//! bytes at the same positions.
//!
//! `cargo run --release -p relief-benches --example refine_pages -- 1 4 16`

use relief_core::refine::{record_position, scratch_len, Criterion, RecordLayout, Refiner, View};
use relief_core::Terrain;
use std::collections::HashSet;

mod common;
use common::{camera, mapped_grid, Args, BENCH_EYE_X};

fn main() {
    let args = Args::get();
    let base = args.dem.heightfield().unwrap();
    let cam = camera(BENCH_EYE_X);
    println!("| grid | tau px | vertices | records: lines / pages | bitmap row-major: lines / pages | bitmap in record order: lines / pages |");
    println!("|---|---|---|---|---|---|");
    for &f in &args.factors {
        let (n, g, m) = mapped_grid(&base, f, &args.dir);
        let hf = g.heightfield().unwrap();
        let h = m.hierarchy().unwrap();
        for tau in [1.0f32, 4.0] {
            let r = Refiner::new(&h, &hf, Criterion::View(View::new(&cam, tau).unwrap())).unwrap();
            let mut sc = vec![0u64; scratch_len(n, n)];
            let c = r.count(&mut sc).unwrap();
            let (mut v, mut t) = (vec![[0f32; 3]; c.vertices], vec![[0u32; 3]; c.triangles]);
            r.triangles(&mut sc, &mut v, &mut t).unwrap();
            let s = hf.scale();
            let mut sets: [HashSet<u64>; 6] = Default::default();
            for q in &v {
                let (x, y) = ((q[0] / s.dx).round() as u32, (q[1] / s.dy).round() as u32);
                let k = record_position(n, n, RecordLayout::Interleaved, x, y).unwrap() as u64;
                let i = y as u64 * n as u64 + x as u64;
                // Records: 8 bytes; bits: 1 bit.
                for (set, v) in sets.iter_mut().zip([
                    k * 8 / 64,
                    k * 8 / 4096,
                    i / 512,
                    i / 32768,
                    k / 512,
                    k / 32768,
                ]) {
                    set.insert(v);
                }
            }
            let l = sets.map(|s| s.len());
            println!(
                "| {n}^2 | {tau} | {} | {} / {} | {} / {} | {} / {} |",
                v.len(),
                l[0],
                l[1],
                l[2],
                l[3],
                l[4],
                l[5]
            );
        }
    }
}
