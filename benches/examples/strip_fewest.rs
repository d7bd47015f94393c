//! How far the two strips are from the fewest indices their triangle order allows (issue 3,
//! seed 004 chapter 5.1): for each mesh, the in/out-edge strip's and SOAR's strip's lengths
//! against [`strip_fewest_indices`] of the same triangles in the same order, counter-clockwise
//! (as drawn with back-face culling) and either way round (without); and what it costs to
//! reach that fewest: the in/out-edge strip built (`inout_strip`, fastest of 5) against the
//! same strip then rewritten by [`strip_fewest`] (fastest of 5, the rewrite alone).
//!
//! Meshes: the bundled Puget Sound DEM (1025^2, a square grid: one piece) at E = 1, 5, 20 and
//! 50 m and the view-dependent 1 px frame of BENCHMARKS.md; Big Tujunga (1197 x 643) and the
//! pysheds DEM (367 x 359) from `../shared/data` when present (grids of any size: one piece per
//! triangle inside the domain whose parent crosses its edge) at E = 1, 5 and 20 m.
//!
//! `cargo run --release -p relief-benches --example strip_fewest`

use relief_core::glam::Vec3;
use relief_core::refine::{
    hierarchy_len, preprocess, scratch_len, strip_bound, strip_fewest, strip_fewest_indices,
    strip_fewest_scratch_len, Criterion, Refiner, View,
};
use relief_core::{Camera, Heightfield, Terrain};
use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

mod common;

fn row<T: Terrain>(name: &str, h: &relief_core::refine::Hierarchy<'_>, t: &T, c: Criterion) {
    let (w, hh) = (t.width(), t.height());
    let r = Refiner::new(h, t, c).unwrap();
    let mut scratch = vec![0u64; scratch_len(w, hh)];
    let mut v = vec![[0u16; 2]; hierarchy_len(w, hh)];
    let mut s = vec![0u32; strip_bound(w, hh)];
    let mut s2 = vec![0u32; strip_bound(w, hh)];
    let mut cells = Vec::new();
    let mut tris = 0;
    let mut times = String::new();
    for soar in [false, true] {
        let c = if soar {
            r.soar_strip(&mut scratch, &mut v, &mut s)
        } else {
            r.inout_strip(&mut scratch, &mut v, &mut s)
        }
        .unwrap();
        let strip = &s[..c.indices];
        let ccw = strip_fewest_indices(strip, true).unwrap();
        let any = strip_fewest_indices(strip, false).unwrap();
        let per = |n: usize| n as f64 / c.triangles as f64;
        tris = c.triangles;
        if !soar {
            // The cost of the fewest: building the strip, and rewriting it.
            let mut build = f64::INFINITY;
            for _ in 0..5 {
                let t0 = Instant::now();
                black_box(r.inout_strip(&mut scratch, &mut v, &mut s2).unwrap());
                build = build.min(t0.elapsed().as_secs_f64() * 1e3);
            }
            let mut back = vec![0u8; strip_fewest_scratch_len(c.indices)];
            let mut out = vec![0u32; c.indices];
            let mut rewrite = f64::INFINITY;
            for _ in 0..5 {
                let t0 = Instant::now();
                let n = strip_fewest(strip, true, &mut back, &mut out).unwrap();
                rewrite = rewrite.min(t0.elapsed().as_secs_f64() * 1e3);
                assert_eq!(n, ccw);
            }
            times = format!("{build:.2} | {rewrite:.2}");
        }
        cells.push(format!(
            "{} ({:.3}) | {} ({:.3}) | {} ({:.3})",
            c.indices,
            per(c.indices),
            ccw,
            per(ccw),
            any,
            per(any)
        ));
    }
    println!("| {name} | {tris} | {} | {times} |", cells.join(" | "));
}

fn main() {
    println!("| mesh | triangles | in/out-edge strip (per triangle) | fewest for its order, counter-clockwise | fewest, either way round | SOAR's strip | fewest for its order, counter-clockwise | fewest, either way round | `inout_strip` ms | `strip_fewest` ms |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let dem = common::puget();
    let hf = dem.heightfield().unwrap();
    let (w, h) = (dem.width, dem.height);
    let n = hierarchy_len(w, h);
    let (mut e, mut r) = (vec![0.0f32; n], vec![0.0f32; n]);
    let hy = preprocess(&hf, &mut e, &mut r).unwrap();
    for err in [1.0f32, 5.0, 20.0, 50.0] {
        row(
            &format!("Puget Sound 1025^2, E = {err} m"),
            &hy,
            &hf,
            Criterion::MaxError(err),
        );
    }
    // BENCHMARKS.md's view-dependent frame (`relief mesh --eye 20000,20000,3000 --target
    // 80000,80000,0 --size 1280x720 --pixel-error 1`, fov 60).
    let cam = Camera::new(
        Vec3::new(20000.0, 20000.0, 3000.0),
        Vec3::new(80000.0, 80000.0, 0.0),
        60.0,
        1280,
        720,
    )
    .unwrap();
    let view = View::new(&cam, 1.0).unwrap();
    row(
        "Puget Sound 1025^2, view-dependent 1 px",
        &hy,
        &hf,
        Criterion::View(view),
    );
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data");
    for (file, name) in [
        (
            "topotoolbox_srtm_bigtujunga30m_utm11.tif",
            "Big Tujunga 1197 x 643",
        ),
        ("pysheds_dem.tif", "pysheds 367 x 359"),
    ] {
        let p = data.join(file);
        let Ok(dem) = relief_io::read_dem(&p, &Default::default()) else {
            eprintln!("skipped: {} not found", p.display());
            continue;
        };
        let hf: Heightfield<'_, f32> = dem.heightfield().unwrap();
        let (w, h) = (dem.width, dem.height);
        let n = hierarchy_len(w, h);
        let (mut e, mut r) = (vec![0.0f32; n], vec![0.0f32; n]);
        let hy = preprocess(&hf, &mut e, &mut r).unwrap();
        for err in [1.0f32, 5.0, 20.0] {
            row(
                &format!("{name}, E = {err} m"),
                &hy,
                &hf,
                Criterion::MaxError(err),
            );
        }
    }
}
