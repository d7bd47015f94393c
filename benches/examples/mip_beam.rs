//! Yardstick, not library code: camera rays traced a tile of pixels at a time, the tile's
//! common start found once by walking the maximum mipmap with the whole tile's *beam*, then
//! each ray walked by the library's `RayTracer::trace_maxmip` from that start (its origin moved
//! there), against `trace_maxmip` from the eye, on the bundled Puget grid's Embree views.
//!
//! The beam: rays `o_i + t d_i` (grid-local units) with every `o_i` and `d_i` inside the boxes
//! `[o_lo, o_hi]`, `[d_lo, d_hi]`. For `t >= 0` every ray's point lies in
//! `[o_lo + t d_lo, o_hi + t d_hi]`: a box whose faces move linearly in `t`. A pyramid node
//! (cells `[x0, x1] x [y0, y1]`, maximum `m`) may hold a hit of some ray of the tile only for
//! `t` in the interval where that box overlaps the node's columns and its lowest height
//! `o_lo.z + t d_lo.z` is at most `m`. The walk (depth first, children nearest first, pruned
//! by the best start so far) finds the smallest such `t` over the nodes of level `STOP`: no
//! ray of the tile can reach the surface before it, so each ray may start there (less a
//! margin). A tile whose beam passes over or beside every node misses entirely.
//!
//! Here the rays start at the beam's start by a moved origin (`o + t d`), so their hits are
//! compared to `1e-4` relative distance, not bit for bit; this measures what the start is
//! worth, not the library's contract. It printed that the start is not worth its beam (the
//! walk from the eye takes only 7.6 steps a camera ray): BENCHMARKS.md, "A common start for a
//! tile of camera rays from its beam".
//!
//! `cargo run --release -p relief-benches --example mip_beam` (`TILE=n`, default 8; `STOP=k`,
//! default 0; `RUNS=n`)

mod common;

use relief_core::glam::DVec3;
use relief_core::ray::{MaxMip, Ray, RayTracer};
use relief_core::Heightfield;
use std::hint::black_box;
use std::time::Instant;

/// The beam of a tile of rays in grid-local units.
struct Beam {
    o_lo: DVec3,
    o_hi: DVec3,
    d_lo: DVec3,
    d_hi: DVec3,
}

/// `{t >= 0 : a + t b <= c}` intersected into `[lo, hi]`.
#[inline(always)]
fn below(a: f64, b: f64, c: f64, lo: &mut f64, hi: &mut f64) {
    if b > 0.0 {
        *hi = hi.min((c - a) / b);
    } else if b < 0.0 {
        *lo = lo.max((c - a) / b);
    } else if a > c {
        *hi = f64::NEG_INFINITY;
    }
}

impl Beam {
    fn new(o: &[DVec3], d: &[DVec3]) -> Beam {
        let fold = |v: &[DVec3]| {
            v.iter().fold(
                (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                |(a, b), &p| (a.min(p), b.max(p)),
            )
        };
        let (o_lo, o_hi) = fold(o);
        let (d_lo, d_hi) = fold(d);
        Beam {
            o_lo,
            o_hi,
            d_lo,
            d_hi,
        }
    }

    /// The interval of `t >= 0` over which the beam may reach below `m` inside the columns
    /// `[x0, x1] x [y0, y1]` (empty when `lo > hi`).
    #[inline(always)]
    fn interval(&self, x0: f64, x1: f64, y0: f64, y1: f64, m: f64) -> (f64, f64) {
        let (mut lo, mut hi) = (0.0f64, f64::INFINITY);
        // The box's low face must be at most the node's high side, its high face at least the
        // node's low side.
        below(self.o_lo.x, self.d_lo.x, x1, &mut lo, &mut hi);
        below(-self.o_hi.x, -self.d_hi.x, -x0, &mut lo, &mut hi);
        below(self.o_lo.y, self.d_lo.y, y1, &mut lo, &mut hi);
        below(-self.o_hi.y, -self.d_hi.y, -y0, &mut lo, &mut hi);
        below(self.o_lo.z, self.d_lo.z, m, &mut lo, &mut hi);
        (lo, hi)
    }

    /// The smallest `t` at which some ray may reach a node of level `stop` at or below its
    /// maximum (`inf`: none does), and the nodes tested.
    fn start(&self, mip: &MaxMip<'_>, stop: u32) -> (f64, u32) {
        let top = mip.levels() - 1;
        let mut best = f64::INFINITY;
        let mut tested = 0u32;
        // (level, x, y, t_in)
        let mut stack = [(0u32, 0u32, 0u32, 0.0f64); 256];
        stack[0] = (top, 0, 0, 0.0);
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            let (lvl, x, y, tin) = stack[sp];
            if tin >= best {
                continue;
            }
            // The four children (or, at `stop`, this node itself was already accepted).
            if lvl == stop {
                best = tin;
                continue;
            }
            let c = lvl - 1;
            let s = f64::from(1u32 << c);
            let mut kids = [(f64::INFINITY, 0u32, 0u32); 4];
            let mut n = 0;
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let (cx, cy) = (2 * x + dx, 2 * y + dy);
                let m = mip.node(c, cx, cy);
                tested += 1;
                if m == f32::NEG_INFINITY {
                    continue;
                }
                let (x0, y0) = (f64::from(cx) * s, f64::from(cy) * s);
                let (lo, hi) = self.interval(x0, x0 + s, y0, y0 + s, f64::from(m));
                if lo <= hi && lo < best {
                    kids[n] = (lo, cx, cy);
                    n += 1;
                }
            }
            // Nearest first on top of the stack.
            kids[..n].sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
            for &(lo, cx, cy) in &kids[..n] {
                stack[sp] = (c, cx, cy, lo);
                sp += 1;
            }
        }
        (best, tested)
    }
}

fn main() {
    let runs = common::runs(9);
    let tile: usize = std::env::var("TILE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(8);
    let stop: u32 = std::env::var("STOP")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    let dem = common::puget();
    let (w, h) = (dem.width, dem.height);
    let hf = Heightfield::with_scale(&dem.samples, w, h, dem.scale).unwrap();
    let mut buf = vec![0.0f32; MaxMip::len(w, h).unwrap()];
    let mip = MaxMip::build(&hf, &mut buf).unwrap();
    let tracer = RayTracer::new(&hf, relief_core::Surface::Triangles);
    let s = dem.scale;
    let local = |v: DVec3| DVec3::new(v.x / f64::from(s.dx), v.y / f64::from(s.dy), v.z);
    for (name, rays) in common::embree_views(&dem) {
        let (iw, ih) = (384usize, 256usize);
        assert_eq!(rays.len(), iw * ih);
        // Rays regrouped by tiles.
        let mut tiles: Vec<Vec<Ray>> = Vec::new();
        for ty in (0..ih).step_by(tile) {
            for tx in (0..iw).step_by(tile) {
                let mut v = Vec::new();
                for j in ty..(ty + tile).min(ih) {
                    for i in tx..(tx + tile).min(iw) {
                        v.push(rays[j * iw + i].ray);
                    }
                }
                tiles.push(v);
            }
        }
        let z_off = f64::from(s.z_offset);
        let beam_of = |t: &[Ray]| {
            let o: Vec<DVec3> = t
                .iter()
                .map(|r| local(r.origin()) - DVec3::new(0.0, 0.0, z_off))
                .collect();
            let d: Vec<DVec3> = t.iter().map(|r| local(r.dir())).collect();
            Beam::new(&o, &d)
        };
        let beams: Vec<Beam> = tiles.iter().map(|t| beam_of(t)).collect();
        // A tile's start less a margin (`None`: every ray misses), and the nodes tested.
        let start = |b: &Beam| {
            let (t0, n) = b.start(&mip, stop);
            let t0 = (t0 < f64::INFINITY).then(|| (t0 - 1e-9 * t0.abs() - 1e-9).max(0.0));
            (t0, n)
        };
        // One tile: its start, then each ray from there.
        let trace_tile = |t: &[Ray], b: &Beam, out: &mut Vec<Option<f64>>, tested: &mut u64| {
            let (t0, n) = start(b);
            *tested += u64::from(n);
            let Some(t0) = t0 else {
                out.extend(t.iter().map(|_| None));
                return;
            };
            for r in t {
                let moved = Ray::new_f64(r.at(t0), r.dir()).unwrap();
                let hit = tracer.trace_maxmip(&moved, &mip).unwrap().hit;
                out.push(hit.map(|h| h.t + t0));
            }
        };
        let mut got = Vec::with_capacity(rays.len());
        let mut tested = 0u64;
        for (t, b) in tiles.iter().zip(&beams) {
            trace_tile(t, b, &mut got, &mut tested);
        }
        let want: Vec<Option<f64>> = tiles
            .iter()
            .flatten()
            .map(|r| tracer.trace_maxmip(r, &mip).unwrap().hit.map(|h| h.t))
            .collect();
        let (agree, both_miss, differ) =
            common::agreement(got.iter().copied().zip(want.iter().copied()));
        // Steps: ray by ray from the eye, and from the beam's start.
        let steps_eye: u64 = tiles
            .iter()
            .flatten()
            .map(|r| u64::from(tracer.trace_maxmip(r, &mip).unwrap().steps))
            .sum();
        let mut steps_beam = 0u64;
        let mut dda_beam = 0u64;
        for (t, b) in tiles.iter().zip(&beams) {
            let Some(t0) = start(b).0 else {
                continue;
            };
            for r in t {
                let moved = Ray::new_f64(r.at(t0), r.dir()).unwrap();
                steps_beam += u64::from(tracer.trace_maxmip(&moved, &mip).unwrap().steps);
                dda_beam += u64::from(tracer.trace_cell_dda(&moved).steps);
            }
        }
        let (mut best_b, mut best_e) = (f64::INFINITY, f64::INFINITY);
        let mut out = Vec::with_capacity(rays.len());
        for _ in 0..runs {
            let st = Instant::now();
            out.clear();
            let mut n = 0;
            for t in &tiles {
                // The beam is part of the timed work.
                let b = beam_of(t);
                trace_tile(t, &b, &mut out, &mut n);
            }
            black_box(&out);
            best_b = best_b.min(st.elapsed().as_secs_f64());
            let st = Instant::now();
            for r in tiles.iter().flatten() {
                black_box(tracer.trace_maxmip(r, &mip).unwrap());
            }
            best_e = best_e.min(st.elapsed().as_secs_f64());
        }
        let m = rays.len() as f64 / 1e6;
        println!(
            "{name:8} tile {tile} stop {stop} | agree {agree} (both miss {both_miss}) differ {differ} | steps/ray eye {:.2} beam {:.2}, cell DDA steps/ray from the beam {:.2}, beam nodes/tile {:.1} | M rays/s beam {:.2}, eye {:.2} ({:.2}x)",
            steps_eye as f64 / rays.len() as f64,
            steps_beam as f64 / rays.len() as f64,
            dda_beam as f64 / rays.len() as f64,
            tested as f64 / tiles.len() as f64,
            m / best_b,
            m / best_e,
            best_e / best_b
        );
    }
}
