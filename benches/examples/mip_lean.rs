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

use relief_core::glam::{DVec3, Vec3};
use relief_core::ray::{MaxMip, Ray, RayTracer};
use relief_core::{Camera, Heightfield, Surface};
use std::hint::black_box;
use std::time::Instant;

mod common;

struct Pyramid {
    /// Level `k`: `w_k x h_k` maxima, row-major.
    levels: Vec<(Vec<f32>, usize, usize)>,
}

impl Pyramid {
    fn new(z: &[f32], w: usize, h: usize) -> Pyramid {
        let (cw, ch) = (w - 1, h - 1);
        let mut l0 = vec![0.0f32; cw * ch];
        for y in 0..ch {
            for x in 0..cw {
                let c = [
                    z[y * w + x],
                    z[y * w + x + 1],
                    z[(y + 1) * w + x],
                    z[(y + 1) * w + x + 1],
                ];
                l0[y * cw + x] = c[0].max(c[1]).max(c[2]).max(c[3]);
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

struct Lean<'a> {
    z: &'a [f32],
    w: usize,
    cw: f32,
    ch: f32,
    zlo: f32,
    zhi: f32,
    mip: &'a Pyramid,
}

impl Lean<'_> {
    /// The hit parameter of local ray `o + t d` (`t` as for the world ray), or `None`.
    fn trace(&self, o: [f32; 3], d: [f32; 3]) -> Option<f64> {
        let inv = [1.0 / d[0], 1.0 / d[1]];
        let (mut t0, mut t1) = (0.0f32, f32::INFINITY);
        for (k, hi) in [(0, self.cw), (1, self.ch)] {
            if d[k] == 0.0 {
                if !(o[k] >= 0.0 && o[k] <= hi) {
                    return None;
                }
            } else {
                let (a, b) = ((0.0 - o[k]) * inv[k], (hi - o[k]) * inv[k]);
                t0 = t0.max(a.min(b));
                t1 = t1.min(a.max(b));
            }
        }
        if d[2] < 0.0 {
            t0 = t0.max((self.zhi - o[2]) / d[2]);
            t1 = t1.min((self.zlo - 1.0 - o[2]) / d[2]);
        } else if d[2] > 0.0 {
            t1 = t1.min((self.zhi - o[2]) / d[2]);
        } else if o[2] > self.zhi {
            return None;
        }
        if t0.is_nan() || t1.is_nan() || t0 > t1 {
            return None;
        }
        let top = self.mip.levels.len() - 1;
        let mut lvl = top.saturating_sub(4);
        let (px, py) = (o[0] + t0 * d[0], o[1] + t0 * d[1]);
        let (lw, lh) = (self.mip.levels[lvl].1, self.mip.levels[lvl].2);
        let mut ix = ((px as usize) >> lvl).min(lw - 1);
        let mut iy = ((py as usize) >> lvl).min(lh - 1);
        let (sx, sy) = (d[0] >= 0.0, d[1] >= 0.0);
        let mut t = t0;
        // Bounded: every step moves on or down; 8 (w + h) is far above what a line needs.
        for _ in 0..8 * (self.w * 2) {
            let (m, lw, lh) = &self.mip.levels[lvl];
            let s = (1usize << lvl) as f32;
            let x0 = ix as f32 * s;
            let y0 = iy as f32 * s;
            let fx = if sx { (x0 + s).min(self.cw) } else { x0 };
            let fy = if sy { (y0 + s).min(self.ch) } else { y0 };
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
                    if let Some(h) = self.cell(o, d, ix, iy, t, tb) {
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

    /// The cell's two triangles against the ray, nearest hit with `t` in `[ta, tb]` (widened).
    fn cell(&self, o: [f32; 3], d: [f32; 3], x: usize, y: usize, ta: f32, tb: f32) -> Option<f64> {
        let z = |x: usize, y: usize| self.z[y * self.w + x] as f64;
        let p = |x: usize, y: usize| DVec3::new(x as f64, y as f64, z(x, y));
        let (a, b, c, e) = (p(x, y), p(x + 1, y), p(x + 1, y + 1), p(x, y + 1));
        let (o, d) = (
            DVec3::new(o[0] as f64, o[1] as f64, o[2] as f64),
            DVec3::new(d[0] as f64, d[1] as f64, d[2] as f64),
        );
        let mut best: Option<f64> = None;
        for (v0, v1, v2) in [(a, b, c), (a, c, e)] {
            let (e1, e2) = (v1 - v0, v2 - v0);
            let pv = d.cross(e2);
            let det = e1.dot(pv);
            if det.abs() < 1e-30 {
                continue;
            }
            let tv = o - v0;
            let u = tv.dot(pv) / det;
            let q = tv.cross(e1);
            let v = d.dot(q) / det;
            let t = e2.dot(q) / det;
            let eps = 1e-9;
            if u >= -eps && v >= -eps && u + v <= 1.0 + eps {
                let slack = 1e-4 * (tb as f64).abs().max(1.0);
                if t >= ta as f64 - slack && t <= tb as f64 + slack && best.is_none_or(|b| t < b) {
                    best = Some(t);
                }
            }
        }
        best
    }
}

fn main() {
    let runs = common::runs(9);
    let dem = common::puget();
    let (w, h) = (dem.width, dem.height);
    let hf = Heightfield::with_scale(&dem.samples, w, h, dem.scale).unwrap();
    let z = common::local_heights(&hf);
    let (zlo, zhi) = z
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let pyr = Pyramid::new(&z, w as usize, h as usize);
    let lean = Lean {
        z: &z,
        w: w as usize,
        cw: (w - 1) as f32,
        ch: (h - 1) as f32,
        zlo,
        zhi,
        mip: &pyr,
    };
    let mut buf = vec![0.0f32; MaxMip::len(w, h).unwrap()];
    let mip = MaxMip::build(&hf, &mut buf).unwrap();
    let tracer = RayTracer::new(&hf, Surface::Triangles);
    let views = [
        (
            "camera",
            Vec3::new(19660.8, 14745.6, 12571.8),
            Vec3::new(90112.0, 98304.0, 0.0),
            60.0,
        ),
        (
            "grazing",
            Vec3::new(1638.4, 3276.8, 4412.568),
            Vec3::new(163840.0, 152371.2, 4363.4165),
            30.0,
        ),
    ];
    let off = dem.scale.z_offset;
    for (name, eye, target, fov) in views {
        let cam = Camera::new(eye, target, fov, 384, 256).unwrap();
        let rays: Vec<(Ray, [f32; 3], [f32; 3])> = (0..256)
            .flat_map(|j| (0..384).map(move |i| (i, j)))
            .map(|(i, j)| {
                let (o, d) = cam.ray(i, j);
                let r = Ray::new(o, d).unwrap();
                let lo = [o.x / dem.scale.dx, o.y / dem.scale.dy, o.z - off];
                let ld = [d.x / dem.scale.dx, d.y / dem.scale.dy, d.z];
                (r, lo, ld)
            })
            .collect();
        let (mut agree, mut both_miss, mut differ) = (0, 0, 0);
        for (r, lo, ld) in &rays {
            let a = tracer.trace_maxmip(r, &mip).unwrap().hit.map(|h| h.t);
            let b = lean.trace(*lo, *ld);
            match (a, b) {
                (None, None) => both_miss += 1,
                (Some(x), Some(y)) if (x - y).abs() <= 1e-4 * x.abs().max(1.0) => agree += 1,
                _ => differ += 1,
            }
        }
        let (mut best_l, mut best_r) = (f64::INFINITY, f64::INFINITY);
        for _ in 0..runs {
            let s = Instant::now();
            for (_, lo, ld) in &rays {
                black_box(lean.trace(*lo, *ld));
            }
            best_l = best_l.min(s.elapsed().as_secs_f64());
            let s = Instant::now();
            for (r, _, _) in &rays {
                black_box(tracer.trace_maxmip(r, &mip).ok());
            }
            best_r = best_r.min(s.elapsed().as_secs_f64());
        }
        let n = rays.len() as f64;
        println!(
            "{name:8} hits agree {agree} (both miss {both_miss}), differ {differ} | lean {:.2} M rays/s | trace_maxmip {:.2} M rays/s | lean / library {:.2}",
            n / best_l / 1e6,
            n / best_r / 1e6,
            best_r / best_l
        );
    }
}
