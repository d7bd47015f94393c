//! View-dependent refinement time against input size (issue 6, out-of-core): the bundled Puget
//! Sound DEM (1025^2, 160 m) upsampled bilinearly to `(1024 f + 1)^2` for each factor `f`
//! given (default 1 4 16: 1025^2, 4097^2, 16385^2), written as raw little-endian f32 under
//! `$SCALE_DIR` (default /tmp; 1 GiB for 16385^2, deleted afterwards unless `KEEP=1`), then
//! **memory-mapped** (relief-io's `MappedGrid`), preprocessed, and refined for the same camera
//! and pixel error (same world extent: the spacing is `160 / f` m) with three data layouts:
//! the `f32` error and radius arrays with the mapped heights (linear), and the 8-byte records in
//! linear and in the hierarchical interleaved layout, in heap memory and in anonymous memory
//! with transparent huge pages requested (relief-io's `HugeBuffer`). Times: the fastest of `RUNS` (default 15)
//! back-to-back refinements (warm caches) and the median of `RUNS` refinements each after
//! writing a 256 MiB buffer (cold caches), of the indexed triangle list.
//!
//! `cargo run --release -p relief-benches --example refine_scale -- 1 4 16`

use relief_core::glam::Vec3;
use relief_core::refine::{
    hierarchy_len, pack_records, preprocess, records_len, scratch_len, Criterion, Hierarchy,
    RecordLayout, Refiner, VertexRecord, View,
};
use relief_core::{Camera, Heightfield, Terrain};
use std::hint::black_box;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

fn upsample(src: &Heightfield<'_, f32>, f: u32, out: &Path) {
    let n0 = src.width();
    let n = (n0 - 1) * f + 1;
    let mut w = std::io::BufWriter::with_capacity(1 << 20, std::fs::File::create(out).unwrap());
    let mut row = vec![0.0f32; n as usize];
    let mut bytes = Vec::with_capacity(4 * n as usize);
    for y in 0..n {
        let (y0, fy) = (y / f, (y % f) as f32 / f as f32);
        let y1 = (y0 + 1).min(n0 - 1);
        for (x, o) in row.iter_mut().enumerate() {
            let x = x as u32;
            let (x0, fx) = (x / f, (x % f) as f32 / f as f32);
            let x1 = (x0 + 1).min(n0 - 1);
            let a = src.local_z(x0, y0) * (1.0 - fx) + src.local_z(x1, y0) * fx;
            let b = src.local_z(x0, y1) * (1.0 - fx) + src.local_z(x1, y1) * fx;
            *o = a * (1.0 - fy) + b * fy;
        }
        bytes.clear();
        for v in &row {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        w.write_all(&bytes).unwrap();
    }
    w.flush().unwrap();
}

/// Triangles, fastest ms of `runs` back-to-back refinements (warm caches), and median ms of
/// `runs` refinements each after writing a 256 MiB buffer (cold caches: a frame after other
/// work, or out-of-core).
fn time<T: Terrain>(h: &Hierarchy<'_>, t: &T, c: Criterion, runs: usize) -> (usize, f64, f64) {
    let (w, hh) = (t.width(), t.height());
    let r = Refiner::new(h, t, c).unwrap();
    let mut scratch = vec![0u64; scratch_len(w, hh)];
    let cnt = r.count(&mut scratch).unwrap();
    let mut verts = vec![[0.0f32; 3]; cnt.vertices];
    let mut tris = vec![[0u32; 3]; cnt.triangles];
    let mut evict = vec![0u64; 32 << 20];
    let mut warm = f64::INFINITY;
    let mut cold: Vec<f64> = Vec::with_capacity(runs);
    for k in 0..2 * runs {
        if k % 2 == 1 {
            for (i, x) in evict.iter_mut().enumerate() {
                *x = x.wrapping_add(i as u64);
            }
            black_box(&evict);
        }
        let s = Instant::now();
        black_box(r.triangles(&mut scratch, &mut verts, &mut tris).unwrap());
        let ms = s.elapsed().as_secs_f64() * 1e3;
        if k % 2 == 1 {
            cold.push(ms);
        } else {
            warm = warm.min(ms);
        }
    }
    cold.sort_by(f64::total_cmp);
    (cnt.triangles, warm, cold[runs / 2])
}

fn main() {
    let runs: usize = std::env::var("RUNS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(15);
    let dir = PathBuf::from(std::env::var("SCALE_DIR").unwrap_or_else(|_| "/tmp".into()));
    let keep = std::env::var_os("KEEP").is_some();
    let factors: Vec<u32> = std::env::args()
        .skip(1)
        .map(|a| a.parse().expect("factor"))
        .collect();
    let factors = if factors.is_empty() {
        vec![1, 4, 16]
    } else {
        factors
    };
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/puget_sound_1k.png");
    let dem = relief_io::read_dem(&p, &Default::default()).expect("bundled DEM");
    let base = dem.heightfield().unwrap();
    // A low oblique view over the middle of the map, 3 km up, 1280 x 720, 60 degrees.
    let cam = Camera::new(
        Vec3::new(112_000.0, 82_000.0, 3_000.0),
        Vec3::new(82_000.0, 82_000.0, 0.0),
        60.0,
        1280,
        720,
    )
    .unwrap();
    let taus = [1.0f32, 4.0];
    println!("| grid | data (bytes/vertex) | tau px | triangles | warm ms (fastest) | cold ms (median) | M tris/s warm / cold |");
    println!("|---|---|---|---|---|---|---|");
    for f in factors {
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
            for (name, h) in [
                ("f32 arrays + heights, linear (8+4)", &full),
                ("records, linear (8)", &lin),
                ("records, interleaved (8)", &il),
                ("records, linear, huge pages (8)", &lin_huge),
                ("records, interleaved, huge pages (8)", &il_huge),
            ] {
                let (t, best, med) = time(h, &hf, c, runs);
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
