//! Yardstick, not library code: how fast a view-dependent refinement written for one case only
//! runs on this machine. The case is a square `2^k + 1` grid, `f32` arithmetic, the full
//! layout's per-vertex error and radius arrays and recursion on grid coordinates. It keeps
//! SOAR's projected-error test from the sphere, frustum culling with an active-plane mask (lazy
//! below the last 4 levels) and an indexed output: each vertex numbered at its first use through
//! a per-frame stamp array. The same camera and thresholds as `refine_probe`'s `vd` rows; it
//! prints its triangle count beside `Refiner::triangles`'s, for the same work. Two more timings:
//! the same walk counting triangles only (no output), and that count with an explicit stack
//! instead of recursion.
//!
//! `cargo run --release -p relief-benches --example vd_lean` (`RUNS=n`; `COUNT=0` leaves out the
//! count-only frames)

use relief_core::refine::{hierarchy_len, preprocess, triangle_bound, Criterion, Refiner, View};
use relief_core::Heightfield;
use std::hint::black_box;
use std::time::Instant;

mod common;
use common::{camera, BENCH_EYE_X};

struct Lean<'a> {
    err: &'a [f32],
    rad: &'a [f32],
    z: &'a [f32],
    v: common::LeanView,
}

struct Out<'o> {
    /// Count the triangles only (no vertex numbering, no output): the decisions' own cost.
    count_only: bool,
    stamp: &'o mut [u32],
    index: &'o mut [u32],
    frame: u32,
    verts: &'o mut [[f32; 3]],
    nv: usize,
    tris: &'o mut [[u32; 3]],
    nt: usize,
}

type P = (u32, u32);

impl Lean<'_> {
    #[inline(always)]
    fn vertex(&self, o: &mut Out<'_>, p: P) -> u32 {
        let i = (p.1 * self.v.w + p.0) as usize;
        if o.stamp[i] != o.frame {
            o.stamp[i] = o.frame;
            o.index[i] = o.nv as u32;
            o.verts[o.nv] = [
                p.0 as f32 * self.v.f32s.sx,
                p.1 as f32 * self.v.f32s.sy,
                self.z[i],
            ];
            o.nv += 1;
        }
        o.index[i]
    }

    #[inline(always)]
    fn emit(&self, o: &mut Out<'_>, l: P, r: P, a: P) {
        if o.count_only {
            o.nt += 1;
            return;
        }
        let t = [self.vertex(o, l), self.vertex(o, r), self.vertex(o, a)];
        o.tris[o.nt] = t;
        o.nt += 1;
    }

    /// The decision for split vertex `m` at `level`: `None` if its sphere is outside an active
    /// plane (culled), else whether it splits and the planes still active.
    #[inline(always)]
    fn decide(&self, m: P, planes: u8, level: u32) -> Option<(bool, u8)> {
        let i = (m.1 * self.v.w + m.0) as usize;
        let (e, rr) = (self.err[i], self.rad[i]);
        self.v
            .decide(
                &self.v.f32s,
                (m.0, m.1, level),
                (e, rr, self.z[i]),
                u32::from(planes),
            )
            .map(|(s, p)| (s, p as u8))
    }

    /// The count-only walk with an explicit stack instead of recursion.
    fn count_iter(&self, roots: [(P, P, P); 2]) -> usize {
        let mut stack = [((0u32, 0u32), (0u32, 0u32), (0u32, 0u32), 0u8, 0u32); 64];
        let mut sp = 0;
        for (l, r, a) in roots {
            stack[sp] = (l, r, a, 0b01_1111, 0);
            sp += 1;
        }
        let mut n = 0;
        while sp > 0 {
            sp -= 1;
            let (l, r, a, planes, level) = stack[sp];
            if level >= self.v.levels {
                n += 1;
                continue;
            }
            let m = ((l.0 + r.0) >> 1, (l.1 + r.1) >> 1);
            match self.decide(m, planes, level) {
                None => {}
                Some((true, p)) => {
                    // The second child below the first, so the first is taken next.
                    stack[sp] = (r, a, m, p, level + 1);
                    stack[sp + 1] = (a, l, m, p, level + 1);
                    sp += 2;
                }
                Some((false, _)) => n += 1,
            }
        }
        n
    }

    fn walk(&self, o: &mut Out<'_>, l: P, r: P, a: P, planes: u8, level: u32) {
        if level >= self.v.levels {
            self.emit(o, l, r, a);
            return;
        }
        let m = ((l.0 + r.0) >> 1, (l.1 + r.1) >> 1);
        match self.decide(m, planes, level) {
            None => {}
            Some((true, p)) => {
                self.walk(o, a, l, m, p, level + 1);
                self.walk(o, r, a, m, p, level + 1);
            }
            Some((false, _)) => self.emit(o, l, r, a),
        }
    }
}

fn main() {
    let runs = common::runs(30);
    let dem = common::puget();
    let (w, h) = (dem.width, dem.height);
    assert!(w == h && (w - 1).is_power_of_two(), "a square 2^k + 1 grid");
    let hf = Heightfield::with_scale(&dem.samples, w, h, dem.scale).unwrap();
    let n = hierarchy_len(w, h);
    let (mut ef, mut rf) = (vec![0.0f32; n], vec![0.0f32; n]);
    let full = preprocess(&hf, &mut ef, &mut rf).unwrap();
    let side = w - 1;
    let cam = camera(BENCH_EYE_X);
    // The lean walk reads plain row-major arrays: the hierarchy's own values, copied out.
    let li = common::lean_inputs(&hf, &full, &cam);
    let (e2, r2, z, planes) = (&li.err, &li.rad, &li.z, li.planes);
    let mut stamp = vec![0u32; (w * h) as usize];
    let mut index = vec![0u32; (w * h) as usize];
    let mut verts = vec![[0.0f32; 3]; n];
    let mut tris = vec![[0u32; 3]; triangle_bound(w, h)];
    let mut scratch = vec![0u64; relief_core::refine::scratch_len(w, h)];
    let mut frame = 0u32;
    // COUNT=0 leaves out the count-only frames (for instruction counts under callgrind).
    let with_count = std::env::var("COUNT").map_or(true, |v| v != "0");
    for tau in [0.5f32, 1.0, 4.0] {
        let lean = Lean {
            err: e2,
            rad: r2,
            z,
            v: common::LeanView::new(&dem, &cam, tau, planes),
        };
        let r = Refiner::new(&full, &hf, Criterion::View(View::new(&cam, tau).unwrap())).unwrap();
        // The three are interleaved frame by frame, so that a change of the machine's speed
        // hits them alike; each keeps its fastest frame.
        let (mut best, mut best_c, mut best_r) = (f64::INFINITY, f64::INFINITY, f64::INFINITY);
        let mut best_i = f64::INFINITY;
        let (mut nv, mut nt, mut nt_c) = (0, 0, 0);
        let mut c = Default::default();
        for _ in 0..runs {
            for count_only in [false, true] {
                if count_only && !with_count {
                    nt_c = nt;
                    best_c = f64::NAN;
                    continue;
                }
                frame += 1;
                let s = Instant::now();
                let mut o = Out {
                    count_only,
                    stamp: &mut stamp,
                    index: &mut index,
                    frame,
                    verts: &mut verts,
                    nv: 0,
                    tris: &mut tris,
                    nt: 0,
                };
                lean.walk(&mut o, (side, side), (0, 0), (side, 0), 0b01_1111, 0);
                lean.walk(&mut o, (0, 0), (side, side), (0, side), 0b01_1111, 0);
                black_box(&o.tris[..o.nt.min(o.tris.len())]);
                let ms = s.elapsed().as_secs_f64() * 1e3;
                if count_only {
                    nt_c = o.nt;
                    best_c = best_c.min(ms);
                } else {
                    (nv, nt) = (o.nv, o.nt);
                    best = best.min(ms);
                }
            }
            let s = Instant::now();
            let ni = black_box(lean.count_iter([
                ((side, side), (0, 0), (side, 0)),
                ((0, 0), (side, side), (0, side)),
            ]));
            assert_eq!(ni, nt);
            best_i = best_i.min(s.elapsed().as_secs_f64() * 1e3);
            let s = Instant::now();
            c = black_box(r.triangles(&mut scratch, &mut verts, &mut tris).unwrap());
            best_r = best_r.min(s.elapsed().as_secs_f64() * 1e3);
        }
        assert_eq!(nt, nt_c);
        let c: relief_core::refine::FrameCounts = c;
        println!(
            "tau={tau:<4} lean {nt:>7} tris {nv:>7} verts {best:8.3} ms {:6.1} M tris/s (count only {best_c:7.3} ms, iterative {best_i:7.3} ms) | Refiner::triangles {:>7} tris {:>7} verts {best_r:8.3} ms {:6.1} M tris/s",
            nt as f64 / best / 1e3,
            c.triangles,
            c.vertices,
            c.triangles as f64 / best_r / 1e3
        );
    }
}
