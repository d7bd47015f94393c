//! Yardstick, not library code: how fast a scalar maximum-mipmap walk written for one case runs
//! on this machine, against `RayTracer::trace_maxmip` on the same rays. The case is the
//! `triangles` surface on the bundled Puget grid.
//!
//! The walk decides in `f32` with a margin (it descends when the ray's lowest point over a node
//! is within `1e-3` of the node's maximum) instead of `trace_maxmip`'s exact `f64` decisions.
//! It keeps a row-major pyramid of its own, climbs at most one level per step and tests leaves
//! in `f64` (the cell's two triangles, Moller-Trumbore). Its hits are compared with the
//! library's to `1e-4` relative distance, the tolerance of the Embree comparison. Views: the
//! camera and grazing views of `bench-peers/embree_rays.sh` on Puget, 384 x 256 rays,
//! interleaved with the library ray by ray, fastest of `RUNS` (default 9) passes each.
//!
//! `cargo run --release -p relief-benches --example mip_lean`

mod common;

struct Pyramid {
    /// Level `k`: `w_k x h_k` maxima, row-major.
    levels: Vec<(Vec<f32>, usize, usize)>,
}

impl Pyramid {
    fn new(g: &common::LocalGrid) -> Pyramid {
        let (cw, ch) = (g.w - 1, g.h - 1);
        let mut l0 = vec![0.0f32; cw * ch];
        for y in 0..ch {
            for x in 0..cw {
                l0[y * cw + x] = g.cell_max(x, y);
            }
        }
        let mut levels = vec![(l0, cw, ch)];
        while levels.last().is_some_and(|l| l.1 > 1 || l.2 > 1) {
            let (p, pw, ph) = levels.last().unwrap();
            let (nw, nh) = (pw.div_ceil(2), ph.div_ceil(2));
            let mut n = vec![f32::NEG_INFINITY; nw * nh];
            for y in 0..*ph {
                for x in 0..*pw {
                    let v = &mut n[(y / 2) * nw + x / 2];
                    *v = v.max(p[y * pw + x]);
                }
            }
            levels.push((n, nw, nh));
        }
        Pyramid { levels }
    }
}

struct Lean {
    g: common::LocalGrid,
    mip: Pyramid,
}

impl common::LocalTracer for Lean {
    /// The hit parameter of local ray `o + t d` (`t` as for the world ray), or `None`.
    fn trace(&self, o: [f32; 3], d: [f32; 3]) -> Option<f64> {
        let inv = [1.0 / d[0], 1.0 / d[1]];
        let (t0, t1) = self.g.clip(o, d, inv)?;
        let top = self.mip.levels.len() - 1;
        let mut lvl = top.saturating_sub(4);
        let (px, py) = (o[0] + t0 * d[0], o[1] + t0 * d[1]);
        let (lw, lh) = (self.mip.levels[lvl].1, self.mip.levels[lvl].2);
        let mut ix = ((px as usize) >> lvl).min(lw - 1);
        let mut iy = ((py as usize) >> lvl).min(lh - 1);
        let (sx, sy) = (d[0] >= 0.0, d[1] >= 0.0);
        let mut t = t0;
        // Bounded: every step moves on or down; 8 (w + h) is far above what a line needs.
        for _ in 0..8 * (self.g.w * 2) {
            let (m, lw, lh) = &self.mip.levels[lvl];
            let s = (1usize << lvl) as f32;
            let x0 = ix as f32 * s;
            let y0 = iy as f32 * s;
            let fx = if sx { (x0 + s).min(self.g.cw) } else { x0 };
            let fy = if sy { (y0 + s).min(self.g.ch) } else { y0 };
            let tx = if d[0] == 0.0 {
                f32::INFINITY
            } else {
                (fx - o[0]) * inv[0]
            };
            let ty = if d[1] == 0.0 {
                f32::INFINITY
            } else {
                (fy - o[1]) * inv[1]
            };
            let tb = tx.min(ty).min(t1);
            let zmin = o[2] + if d[2] < 0.0 { tb } else { t } * d[2];
            if zmin <= m[iy * lw + ix] + 1e-3 {
                if lvl == 0 {
                    if let Some(h) = self.g.cell(o, d, ix, iy, t, tb) {
                        return Some(h);
                    }
                } else {
                    lvl -= 1;
                    let half = s * 0.5;
                    let hx = (o[0] + t * d[0]) >= x0 + half;
                    let hy = (o[1] + t * d[1]) >= y0 + half;
                    let (cw, ch) = (self.mip.levels[lvl].1, self.mip.levels[lvl].2);
                    ix = (2 * ix + usize::from(hx)).min(cw - 1);
                    iy = (2 * iy + usize::from(hy)).min(ch - 1);
                    continue;
                }
            }
            if tb >= t1 {
                return None;
            }
            t = tb;
            let (nx, ny) = if tx <= ty {
                (if sx { ix + 1 } else { ix.wrapping_sub(1) }, iy)
            } else {
                (ix, if sy { iy + 1 } else { iy.wrapping_sub(1) })
            };
            if nx >= *lw || ny >= *lh {
                return None;
            }
            if (nx >> 1 != ix >> 1 || ny >> 1 != iy >> 1) && lvl < top {
                lvl += 1;
                (ix, iy) = (nx >> 1, ny >> 1);
            } else {
                (ix, iy) = (nx, ny);
            }
        }
        None
    }
}

fn main() {
    let _ = common::mip_yardstick("lean", |g| {
        let mip = Pyramid::new(&g);
        Lean { g, mip }
    });
}
