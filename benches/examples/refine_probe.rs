//! Quick refinement timings on the bundled Puget Sound DEM, fastest of `RUNS` (default 30) runs
//! per case (the fastest run is the least disturbed on a shared machine): view-independent
//! extraction at E = 5 and 50 m and view-dependent refinement with culling at 0.5, 1 and 4 px,
//! every layout (and, on the full layout, `Refiner::count` alone: the `full-count` rows, and the
//! list with grid-coordinate vertices: `full-grid-pc`).
//!
//! `cargo run --release -p relief-benches --example refine_probe` (`RUNS=n`, `FILTER="vd tau=1"`)

use relief_core::refine::{
    hierarchy_len, pack_records, preprocess, preprocess_compact, records_len, scratch_len,
    triangle_bound, Criterion, MeshVertex, RecordLayout, Refiner, VertexRecord, View,
};
use relief_core::Heightfield;
use std::hint::black_box;
use std::time::Instant;

mod common;
use common::{camera, Buffer, BENCH_EYE_X};

fn main() {
    let runs = common::runs(30);
    // Optional substring filter on "<case> <layout>", e.g. FILTER="vd tau=1 full".
    let filter = std::env::var("FILTER").unwrap_or_default();
    let dem = common::puget();
    let (w, h) = (dem.width, dem.height);
    // HUGE=1: every per-vertex array (heights, hierarchy, records, scratch, outputs) in
    // anonymous memory with transparent huge pages requested.
    let huge = std::env::var("HUGE").is_ok_and(|v| v == "1");
    let mut heights = Buffer::new(dem.samples.len(), huge);
    heights.as_mut_slice().copy_from_slice(&dem.samples);
    let hf = Heightfield::with_scale(heights.as_slice(), w, h, dem.scale).unwrap();
    let n = hierarchy_len(w, h);
    let (mut ef, mut rf) = (Buffer::<f32>::new(n, huge), Buffer::<f32>::new(n, huge));
    let full = preprocess(&hf, ef.as_mut_slice(), rf.as_mut_slice()).unwrap();
    let mut ec = Buffer::<u16>::new(n, huge);
    let compact = preprocess_compact(&hf, ec.as_mut_slice()).unwrap();
    let mut rl = Buffer::<VertexRecord>::new(records_len(w, h, RecordLayout::Linear), huge);
    let lin = pack_records(&full, &hf, RecordLayout::Linear, rl.as_mut_slice()).unwrap();
    let mut ri = Buffer::<VertexRecord>::new(records_len(w, h, RecordLayout::Interleaved), huge);
    let il = pack_records(&full, &hf, RecordLayout::Interleaved, ri.as_mut_slice()).unwrap();
    let mut scratch = Buffer::<u64>::new(scratch_len(w, h), huge);
    let scratch = scratch.as_mut_slice();
    let mut verts = Buffer::<[f32; 3]>::new(n, huge);
    let verts = verts.as_mut_slice();
    let mut grid = Buffer::<[u16; 2]>::new(n, huge);
    let grid = grid.as_mut_slice();
    let mut tris = Buffer::<[u32; 3]>::new(triangle_bound(w, h), huge);
    let tris = tris.as_mut_slice();
    let cam = camera(BENCH_EYE_X);
    let mut cases: Vec<(String, Criterion)> = Vec::new();
    for e in [5.0f32, 50.0] {
        cases.push((format!("vi E={e}"), Criterion::MaxError(e)));
    }
    for tau in [0.5f32, 1.0, 4.0] {
        cases.push((
            format!("vd tau={tau}"),
            Criterion::View(View::new(&cam, tau).unwrap()),
        ));
    }
    for (name, crit) in &cases {
        for (lname, hier, call) in [
            ("full", &full, Call::Triangles),
            ("full-pc", &full, Call::Popcnt),
            ("full-grid-pc", &full, Call::GridPopcnt),
            ("full-count", &full, Call::Count),
            ("compact", &compact, Call::Triangles),
            ("compact-pc", &compact, Call::Popcnt),
            ("rec-lin", &lin, Call::Triangles),
            ("rec-il", &il, Call::Triangles),
        ] {
            // The `-pc` rows: `triangles_popcnt` (where the CPU has it).
            if matches!(call, Call::Popcnt | Call::GridPopcnt) && !popcnt() {
                continue;
            }
            if !format!("{name} {lname}").contains(&filter) {
                continue;
            }
            let r = Refiner::new(hier, &hf, *crit).unwrap();
            let mut best = f64::INFINITY;
            let mut c = Default::default();
            for _ in 0..runs {
                let s = Instant::now();
                c = black_box(match call {
                    Call::Triangles => r.triangles(scratch, verts, tris).unwrap(),
                    Call::Popcnt => triangles_popcnt(&r, scratch, verts, tris),
                    Call::GridPopcnt => triangles_popcnt(&r, scratch, grid, tris),
                    Call::Count => r.count(scratch).unwrap(),
                });
                best = best.min(s.elapsed().as_secs_f64() * 1e3);
            }
            let c: relief_core::refine::FrameCounts = c;
            println!(
                "{name:12} {lname:12} {:>8} tris {best:8.3} ms {:7.1} M tris/s",
                c.triangles,
                c.triangles as f64 / best / 1e3
            );
        }
    }
}

/// What a row times.
#[derive(Clone, Copy, PartialEq)]
enum Call {
    /// `Refiner::triangles`.
    Triangles,
    /// `Refiner::triangles_popcnt`.
    Popcnt,
    /// `Refiner::triangles_popcnt` with grid-coordinate vertices (`[u16; 2]`, no heights read).
    GridPopcnt,
    /// `Refiner::count` (what a frame needs, no output: the `-count` row).
    Count,
}

fn popcnt() -> bool {
    #[cfg(target_arch = "x86_64")]
    return std::is_x86_feature_detected!("popcnt");
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// `Refiner::triangles_popcnt` (only called where [`popcnt`] said yes).
fn triangles_popcnt<V: MeshVertex>(
    r: &Refiner<'_, '_, Heightfield<'_, f32>>,
    s: &mut [u64],
    v: &mut [V],
    t: &mut [[u32; 3]],
) -> relief_core::refine::FrameCounts {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: called only where the CPU has popcnt.
    return unsafe { r.triangles_popcnt(s, v, t) }.unwrap();
    #[cfg(not(target_arch = "x86_64"))]
    r.triangles(s, v, t).unwrap()
}
