//! Times `Tin::build` in-process on a raw little-endian f32 DEM, for profiling and quick A/B
//! checks (the peer comparison itself goes through `relief mesh`, see BENCHMARKS.md).
//!
//! usage: `cargo run --release -p relief-tin --example tin_time -- RAW.f32 W H REPS E [E ...]`
//! prints `E triangles max_error best_ms hash` per E (`hash`: FNV-1a of the vertex and triangle
//! lists, to check that a change leaves the mesh as it was).

use relief_core::Heightfield;
use relief_tin::{Tin, TinOptions};
use std::time::Instant;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    if a.len() < 6 {
        eprintln!("usage: tin_time RAW.f32 W H REPS E [E ...]");
        std::process::exit(2);
    }
    let bytes = std::fs::read(&a[1]).expect("read DEM");
    let s: Vec<f32> = bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    let (w, h): (u32, u32) = (a[2].parse().expect("W"), a[3].parse().expect("H"));
    let reps: usize = a[4].parse().expect("REPS");
    let hf = Heightfield::new(&s, w, h).expect("size");
    for e in &a[5..] {
        let e: f32 = e.parse().expect("E");
        let mut best = f64::INFINITY;
        let mut tin = None;
        for _ in 0..reps {
            let t = Instant::now();
            let t_ = Tin::build(&hf, &TinOptions::default().with_max_error(e)).expect("build");
            best = best.min(t.elapsed().as_secs_f64() * 1e3);
            tin = Some(t_);
        }
        let tin = tin.expect("reps > 0");
        let mut hash = 0xcbf2_9ce4_8422_2325u64;
        let words = tin.vertices().iter().flatten();
        for &w in words.chain(tin.triangles().iter().flatten()) {
            hash = (hash ^ u64::from(w)).wrapping_mul(0x0100_0000_01b3);
        }
        println!(
            "{e} {} {} {best:.2} {hash:016x}",
            tin.triangles().len(),
            tin.max_error()
        );
    }
}
