//! View-dependent refinement time against input size (issue 6, out-of-core): the bundled Puget
//! Sound DEM (1025^2, 160 m) upsampled bilinearly to `(1024 f + 1)^2` for each factor `f`
//! given (default 1 4 16: 1025^2, 4097^2, 16385^2), written as raw little-endian f32 under
//! `$SCALE_DIR` (default /tmp; 1 GiB for 16385^2, deleted afterwards unless `KEEP=1`), then
//! **memory-mapped** (relief-io's `MappedGrid`), preprocessed, and refined for the same camera
//! and pixel error (same world extent: the spacing is `160 / f` m) with three data layouts:
//! the `f32` error and radius arrays with the mapped heights (linear), and the 8-byte records in
//! linear and in the hierarchical interleaved layout, in heap memory and in anonymous memory
//! with transparent huge pages requested (relief-io's `HugeBuffer`), and with the refinement
//! scratch (bitmap and rank prefix, indexed row-major) in huge pages too. Times: the fastest of `RUNS` (default 15)
//! back-to-back refinements (warm caches) and the median of `RUNS` refinements each after
//! writing a 256 MiB buffer (cold caches), of the indexed triangle list.
//!
//! `cargo run --release -p relief-benches --example refine_scale -- 1 4 16`

use relief_core::refine::{
    hierarchy_len, pack_records, preprocess, records_len, Criterion, RecordLayout, VertexRecord,
    View,
};
use relief_core::Terrain;
use std::time::Instant;

mod common;
use common::{camera, time, upsample, Args, BENCH_EYE_X};

fn main() {
    let args = Args::get();
    let (runs, dir) = (args.runs, &args.dir);
    let keep = std::env::var_os("KEEP").is_some();
    let base = args.dem.heightfield().unwrap();
    // A low oblique view over the middle of the map, 3 km up, 1280 x 720, 60 degrees.
    let cam = camera(BENCH_EYE_X);
    let taus = [1.0f32, 4.0];
    println!("| grid | data (bytes/vertex) | tau px | triangles | warm ms (fastest) | cold ms (median) | M tris/s warm / cold |");
    println!("|---|---|---|---|---|---|---|");
    for &f in &args.factors {
        let n = (base.width() - 1) * f + 1;
        let path = dir.join(format!("relief_scale_{n}.f32"));
        let t0 = Instant::now();
        upsample(&base, f, &path);
        eprintln!(
            "{n}^2: wrote {} in {:.1} s",
            path.display(),
            t0.elapsed().as_secs_f64()
        );
        let mut g = relief_io::MappedGrid::open(&path, n, n).unwrap();
        let s = 160.0 / f as f32;
        g.scale = g.scale.with_spacing(s, s).with_z_scale(0.1);
        g.advise_random();
        let hf = g.heightfield().unwrap();
        let len = hierarchy_len(n, n);
        let t0 = Instant::now();
        let (mut e, mut r) = (vec![0.0f32; len], vec![0.0f32; len]);
        let full = preprocess(&hf, &mut e, &mut r).unwrap();
        eprintln!("{n}^2: preprocessed in {:.1} s", t0.elapsed().as_secs_f64());
        let mut rl = vec![VertexRecord::default(); records_len(n, n, RecordLayout::Linear)];
        let lin = pack_records(&full, &hf, RecordLayout::Linear, &mut rl).unwrap();
        let mut ri = vec![VertexRecord::default(); records_len(n, n, RecordLayout::Interleaved)];
        let il = pack_records(&full, &hf, RecordLayout::Interleaved, &mut ri).unwrap();
        // The same records in anonymous memory with transparent huge pages requested.
        let mut hl =
            relief_io::HugeBuffer::<VertexRecord>::zeroed(records_len(n, n, RecordLayout::Linear))
                .unwrap();
        let lin_huge = pack_records(&full, &hf, RecordLayout::Linear, hl.as_mut_slice()).unwrap();
        let mut hi = relief_io::HugeBuffer::<VertexRecord>::zeroed(records_len(
            n,
            n,
            RecordLayout::Interleaved,
        ))
        .unwrap();
        let il_huge =
            pack_records(&full, &hf, RecordLayout::Interleaved, hi.as_mut_slice()).unwrap();
        for tau in taus {
            let c = Criterion::View(View::new(&cam, tau).unwrap());
            for (name, h, huge_scratch) in [
                ("f32 arrays + heights, linear (8+4)", &full, false),
                ("records, linear (8)", &lin, false),
                ("records, interleaved (8)", &il, false),
                ("records, linear, huge pages (8)", &lin_huge, false),
                ("records, interleaved, huge pages (8)", &il_huge, false),
                ("records, interleaved, scratch in huge pages (8)", &il, true),
                (
                    "records, interleaved, records and scratch in huge pages (8)",
                    &il_huge,
                    true,
                ),
            ] {
                let (t, best, med) = time(h, &hf, c, runs, huge_scratch);
                println!(
                    "| {n}^2 | {name} | {tau} | {t} | {best:.3} | {med:.3} | {:.1} / {:.1} |",
                    t as f64 / best / 1e3,
                    t as f64 / med / 1e3
                );
            }
        }
        drop((e, r, rl, ri, hl, hi));
        drop(g);
        if !keep {
            let _ = std::fs::remove_file(&path);
        }
    }
}
