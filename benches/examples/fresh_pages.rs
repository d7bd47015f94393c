//! What fresh output pages cost on this machine, apart from refinement: the first write to each
//! 4 KiB page of a fresh buffer of the size `relief mesh` fills at E = 5 m on the bundled
//! Puget Sound DEM (1,423,369 triangles and 711,685 vertices of 12 bytes: 25.4 MB), three
//! ways, fastest of `ROUNDS` (default 7) rounds, the ways alternating within each round:
//! `vec![0; n]` (zeroed by the allocator, what the CLI's fresh buffers are), an anonymous map
//! faulted in by the writes, and one prefaulted by the kernel (`MAP_POPULATE`) before them.
//!
//! `cargo run --release -p relief-benches --example fresh_pages`

use std::hint::black_box;
use std::time::Instant;

/// Writes one byte per 4 KiB page.
fn touch(b: &mut [u8]) {
    for p in b.chunks_mut(4096) {
        if let Some(x) = p.first_mut() {
            *x = 1;
        }
    }
}

fn ms(f: impl FnOnce()) -> f64 {
    let t = Instant::now();
    f();
    t.elapsed().as_secs_f64() * 1e3
}

fn main() {
    let n = 1_423_369 * 12 + 711_685 * 12;
    let rounds: usize = std::env::var("ROUNDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(7);
    let mut best = [f64::INFINITY; 3];
    for _ in 0..rounds {
        let t = [
            ms(|| {
                let mut v = vec![0u8; n];
                touch(&mut v);
                black_box(&v);
            }),
            ms(|| {
                let mut m = memmap2::MmapOptions::new().len(n).map_anon().unwrap();
                touch(&mut m);
                black_box(&m);
            }),
            ms(|| {
                let mut m = memmap2::MmapOptions::new()
                    .len(n)
                    .populate()
                    .map_anon()
                    .unwrap();
                touch(&mut m);
                black_box(&m);
            }),
        ];
        for (b, t) in best.iter_mut().zip(t) {
            *b = b.min(t);
        }
    }
    let pages = n.div_ceil(4096);
    println!("{n} bytes, {pages} pages of 4 KiB, fastest of {rounds} rounds:");
    for (name, t) in [
        "vec![0; n]",
        "anonymous map, faulted",
        "anonymous map, MAP_POPULATE",
    ]
    .iter()
    .zip(best)
    {
        println!(
            "  {name:30} {t:7.2} ms ({:.2} us per page)",
            t * 1e3 / pages as f64
        );
    }
}
