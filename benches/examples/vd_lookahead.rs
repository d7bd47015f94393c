//! Probe, not library code: how many SOAR decisions a *lookahead* would skip in the
//! view-dependent frames of `vd_lean` / `vd_bfs` (Puget 1025^2, 0.5 / 1 / 4 px).
//!
//! The idea: when a triangle splits at vertex `m`, its children's split vertices are decided
//! next. If the largest nested error `e_c` among the split vertices of the children of both
//! triangles of `m`'s diamond passes SOAR's test against `m`'s own sphere,
//! `e_c kappa / tau + r(m) <= |eye - m|`, nesting makes every child inactive (a child's sphere
//! lies in `m`'s, so `reach(child) <= reach(m) - |child - m| <= |eye - child|`), and the two
//! children could be written as leaves without loading their records. That needs `e_c` stored
//! per vertex (or one per triangle of the diamond for the tighter per-triangle bound), and
//! only applies where culling is finished (no active planes, or below the lazy levels).
//!
//! The probe walks the same frames recursively with `vd_lean`'s `f32` decision and counts the
//! decisions, the splits, and the splits whose two children the lookahead would settle, with
//! the per-vertex bound (four children) and the per-triangle bound (two).
//!
//! `cargo run --release -p relief-benches --example vd_lookahead`

use relief_core::refine::{hierarchy_len, preprocess};
use relief_core::Heightfield;

mod common;
use common::{camera, BENCH_EYE_X};

type P = (i64, i64);

fn mid(a: P, b: P) -> P {
    ((a.0 + b.0) / 2, (a.1 + b.1) / 2)
}

struct Probe<'a> {
    li: &'a common::LeanInputs,
    w: i64,
    v: common::LeanView,
    decisions: u64,
    splits: u64,
    per_triangle: u64,
    per_vertex: u64,
    leaves: u64,
}

impl Probe<'_> {
    /// Nested error at `p`, 0 outside the grid (a diamond cut by the border).
    fn e(&self, p: P) -> f32 {
        if p.0 < 0 || p.1 < 0 || p.0 >= self.w || p.1 >= self.w {
            return 0.0;
        }
        self.li.err[(p.1 * self.w + p.0) as usize]
    }

    fn walk(&mut self, l: P, r: P, a: P, planes: u32, level: u32) {
        if level >= self.v.levels {
            self.leaves += 1;
            return;
        }
        let m = mid(l, r);
        let i = (m.1 * self.w + m.0) as usize;
        self.decisions += 1;
        let erz = (self.li.err[i], self.li.rad[i], self.li.z[i]);
        let at = (m.0 as u32, m.1 as u32, level);
        let Some((split, pl)) = self.v.decide(&self.v.f32s, at, erz, planes) else {
            return;
        };
        if !split {
            self.leaves += 1;
            return;
        }
        self.splits += 1;
        if level + 1 < self.v.levels && (pl == 0 || level + 1 >= self.v.lazy_from) {
            // The other triangle of the diamond has its apex mirrored through `m`.
            let a2 = (2 * m.0 - a.0, 2 * m.1 - a.1);
            let tri = self.e(mid(r, a)).max(self.e(mid(a, l)));
            let vert = tri.max(self.e(mid(r, a2))).max(self.e(mid(a2, l)));
            let c = &self.v.f32s;
            let (dx, dy, dz) = (
                c.eye[0] - m.0 as f32 * c.sx,
                c.eye[1] - m.1 as f32 * c.sy,
                c.eye[2] - self.li.z[i],
            );
            let d2 = dx * dx + dy * dy + dz * dz;
            let settled = |e: f32| {
                let reach = e * c.k + self.li.rad[i];
                reach * reach <= d2
            };
            self.per_triangle += u64::from(settled(tri));
            self.per_vertex += u64::from(settled(vert));
        }
        self.walk(a, l, m, pl, level + 1);
        self.walk(r, a, m, pl, level + 1);
    }
}

fn main() {
    let dem = common::puget();
    let (w, h) = (dem.width, dem.height);
    let hf = Heightfield::with_scale(&dem.samples, w, h, dem.scale).unwrap();
    let n = hierarchy_len(w, h);
    let (mut ef, mut rf) = (vec![0.0f32; n], vec![0.0f32; n]);
    let full = preprocess(&hf, &mut ef, &mut rf).unwrap();
    let cam = camera(BENCH_EYE_X);
    let li = common::lean_inputs(&hf, &full, &cam);
    let s = i64::from(w - 1);
    println!("| px | triangles | decisions | splits | children settled, per-vertex bound | per-triangle bound | decisions skipped, per vertex / per triangle |");
    println!("|---|---|---|---|---|---|---|");
    for tau in [0.5f32, 1.0, 4.0] {
        let mut p = Probe {
            li: &li,
            w: i64::from(w),
            v: common::LeanView::new(&dem, &cam, tau, li.planes),
            decisions: 0,
            splits: 0,
            per_triangle: 0,
            per_vertex: 0,
            leaves: 0,
        };
        p.walk((s, s), (0, 0), (s, 0), 0b01_1111, 0);
        p.walk((0, 0), (s, s), (0, s), 0b01_1111, 0);
        let pct = |k: u64| 100.0 * (2 * k) as f64 / p.decisions as f64;
        println!(
            "| {tau} | {} | {} | {} | {} | {} | {:.1} % / {:.1} % |",
            p.leaves,
            p.decisions,
            p.splits,
            p.per_vertex,
            p.per_triangle,
            pct(p.per_vertex),
            pct(p.per_triangle)
        );
    }
}
