//! View-dependent refinement straight from a memory-mapped records file (issue 6, out-of-core):
//! the bundled Puget Sound DEM upsampled to `(1024 f + 1)^2` for each factor `f` given (as in
//! `refine_scale`), preprocessed once, packed into interleaved 8-byte records and written with
//! `relief_io::write_records` under `$SCALE_DIR` (default /tmp; kept between runs, so later runs
//! start at once: delete `relief_scale_*.{f32,rec}` to rebuild). Then both files are mapped
//! (`MappedGrid`, `MappedRecords`: nothing is read up front) and the same camera as
//! `refine_scale` is refined at 1 and 4 px: warm (fastest of `RUNS` back-to-back frames) and cold
//! (median of `RUNS` frames each after writing a 256 MiB buffer), plus a fly-over: `RUNS` frames
//! along a 20 km straight path across the map at 3 km (new view every frame; mean ms). Each
//! with the refinement scratch in a `Vec` and in huge pages (`relief_io::HugeBuffer`).
//!
//! `cargo run --release -p relief-benches --example refine_mapped -- 1 4 16`

use relief_core::glam::Vec3;
use relief_core::refine::{
    hierarchy_len, pack_records, preprocess, records_len, scratch_len, Criterion, RecordLayout,
    Refiner, VertexRecord, View,
};
use relief_core::{Camera, Terrain};
use std::hint::black_box;
use std::time::Instant;

mod common;
use common::{time, upsample, Args, Scratch};

fn camera(eye_x: f32) -> Camera {
    Camera::new(
        Vec3::new(eye_x, 82_000.0, 3_000.0),
        Vec3::new(eye_x - 30_000.0, 82_000.0, 0.0),
        60.0,
        1280,
        720,
    )
    .unwrap()
}

fn main() {
    let args = Args::get();
    let (runs, dir) = (args.runs, &args.dir);
    let base = args.dem.heightfield().unwrap();
    println!("| grid | scratch | tau px | triangles | warm ms (fastest) | cold ms (median) | fly-over ms (mean) |");
    println!("|---|---|---|---|---|---|---|");
    for &f in &args.factors {
        let n = (base.width() - 1) * f + 1;
        let grid_path = dir.join(format!("relief_scale_{n}.f32"));
        let rec_path = dir.join(format!("relief_scale_{n}.rec"));
        let s = 160.0 / f as f32;
        let open_grid = || {
            let mut g = relief_io::MappedGrid::open(&grid_path, n, n).unwrap();
            g.scale = g.scale.with_spacing(s, s).with_z_scale(0.1);
            g.advise_random();
            g
        };
        if !grid_path.exists() {
            upsample(&base, f, &grid_path);
        }
        if !rec_path.exists() {
            let g = open_grid();
            let hf = g.heightfield().unwrap();
            let t0 = Instant::now();
            let len = hierarchy_len(n, n);
            let (mut e, mut r) = (vec![0.0f32; len], vec![0.0f32; len]);
            let full = preprocess(&hf, &mut e, &mut r).unwrap();
            let mut ri =
                vec![VertexRecord::default(); records_len(n, n, RecordLayout::Interleaved)];
            let il = pack_records(&full, &hf, RecordLayout::Interleaved, &mut ri).unwrap();
            relief_io::write_records(&rec_path, &il).unwrap();
            eprintln!(
                "{n}^2: preprocessed and wrote {} in {:.1} s",
                rec_path.display(),
                t0.elapsed().as_secs_f64()
            );
        }
        let g = open_grid();
        // Sizes checked, samples validated once (sequential read of the grid file).
        let hf = g.heightfield().unwrap();
        let t0 = Instant::now();
        let m = relief_io::MappedRecords::open(&rec_path).unwrap();
        m.advise_random();
        let h = m.hierarchy().unwrap();
        eprintln!(
            "{n}^2: records mapped in {:.3} ms",
            t0.elapsed().as_secs_f64() * 1e3
        );
        for (tau, huge) in [(1.0f32, false), (4.0, false), (1.0, true), (4.0, true)] {
            let c = Criterion::View(View::new(&camera(112_000.0), tau).unwrap());
            let (t, best, med) = time(&h, &hf, c, runs, huge);
            // Fly-over: each frame a new view, 20 km along x in `runs` steps.
            let mut scratch = Scratch::new(scratch_len(n, n), huge);
            let scratch = scratch.as_mut_slice();
            let mut verts = vec![[0.0f32; 3]; 1 << 20];
            let mut tris = vec![[0u32; 3]; 1 << 21];
            let mut total = 0.0;
            for k in 0..runs {
                let x = 122_000.0 - 20_000.0 * k as f32 / runs as f32;
                let view = View::new(&camera(x), tau).unwrap();
                let r = Refiner::new(&h, &hf, Criterion::View(view)).unwrap();
                let s0 = Instant::now();
                black_box(r.triangles(scratch, &mut verts, &mut tris).unwrap());
                total += s0.elapsed().as_secs_f64() * 1e3;
            }
            println!(
                "| {n}^2 | {} | {tau} | {t} | {best:.3} | {med:.3} | {:.3} |",
                if huge { "huge pages" } else { "Vec" },
                total / runs as f64
            );
        }
    }
}
