//! Yardstick, not library code: the maximum mipmap traversed one ray at a time as a 16-ary
//! hierarchy, two pyramid levels a node, the sixteen children of a node tested in one AVX-512
//! register (the way Embree's single-ray kernels test several boxes an instruction), against
//! `RayTracer::trace_maxmip` on the same rays. The case is the `triangles` surface on the
//! bundled Puget grid (1024 x 1024 cells, `4^5`). The library's form of this walk, with exact
//! `f64` decisions, is `RayTracer::trace_maxmip_wide_avx512`.
//!
//! Per node, in `f32` with `mip_quad`'s margins (`1e-3` on heights, `1e-5` relative on the
//! parameter): the children's entry and exit parameters from the 4 x 4 block's planes (picked
//! by the ray's signs), the sixteen maxima in one load (each level in Morton order, so a node's
//! sixteen grandchildren in the pyramid are consecutive), and the ray's lowest point over each
//! child against its maximum. The lanes hold the children in the order the ray crosses them
//! (by anti-diagonal from the corner the ray enters by: a path through a 4 x 4 block is a
//! monotone staircase), so the next child is the lowest set bit of the mask; the current node
//! stays in registers and only nodes with children left go on the stack. The first cell hit
//! ends the ray. Switches (each on unless set to `0`): `CHEAP_CELL`, cells tested (`LocalGrid::cell_pieces`) by cutting
//! the ray's part inside the cell at the diagonal and intersecting each piece with its
//! triangle's plane in `f64`, instead of the yardsticks' shared Moller-Trumbore test;
//! `ONE_FMA`, one multiply-add per slab parameter; `U16_CELLS`, the cells' maxima as `u16`
//! quantised upwards. Hits are compared with the library's to `1e-4` relative distance; the
//! last line gives nodes and cells per ray over both views.
//!
//! `cargo run --release -p relief-benches --example mip_sixteen` (needs AVX-512 F)

mod common;

use std::arch::x86_64::*;

/// Maxima over a `4^k x 4^k` domain, each level in Morton order (the sixteen cells two levels
/// below node `m` are `16m .. 16m + 16`); cells outside the grid are `-inf`. Only even levels
/// are kept: `levels[j]` is pyramid level `2j`.
struct Pyramid {
    levels: Vec<Vec<f32>>,
    /// The cells' maxima quantised upwards: `zlo + q step >= max`.
    cells16: Vec<u16>,
    zlo: f32,
    step: f32,
    /// Pyramid levels (even).
    n: u32,
}

impl Pyramid {
    fn new(g: &common::LocalGrid) -> Pyramid {
        let (cw, ch) = (g.w - 1, g.h - 1);
        let mut n = cw.max(ch).next_power_of_two().trailing_zeros();
        n += n & 1;
        let levels = common::morton_levels(g, n, 16);
        let step = (g.zhi - g.zlo).max(1e-3) / 65000.0;
        let cells16 = levels[0]
            .iter()
            .map(|&m| {
                if m == f32::NEG_INFINITY {
                    return 0;
                }
                let mut q = ((m - g.zlo) / step).ceil().max(0.0) as u32;
                while g.zlo + q as f32 * step < m {
                    q += 1;
                }
                q.min(65535) as u16
            })
            .collect();
        Pyramid {
            levels,
            n,
            cells16,
            zlo: g.zlo,
            step,
        }
    }
}

struct Tracer {
    g: common::LocalGrid,
    p: Pyramid,
    orders: [(common::Order, __m512i); 4],
    v: Variant,
    nodes: std::cell::Cell<u64>,
    cells: std::cell::Cell<u64>,
    rays: std::cell::Cell<u64>,
}

/// A node with children left to visit: pyramid level, cell-space index of its block, Morton
/// index, the children left (bits in Morton order) and their parameter intervals.
#[derive(Clone, Copy)]
struct Entry {
    level: u32,
    ix: u32,
    iy: u32,
    m: u32,
    mask: u32,
    ta: __m512,
    tb: __m512,
}

fn vec16(a: [f32; 16]) -> __m512 {
    // SAFETY: `__m512` and `[f32; 16]` have the same size, and every bit pattern is valid.
    unsafe { std::mem::transmute(a) }
}

fn arr16(v: __m512) -> [f32; 16] {
    // SAFETY: as in `vec16`.
    unsafe { std::mem::transmute(v) }
}

impl Tracer {
    /// The ray's walk; see the module documentation.
    #[target_feature(enable = "avx512f")]
    fn trace16<const CHEAP: bool, const FMA: bool, const U16: bool>(
        &self,
        o: [f32; 3],
        d: [f32; 3],
    ) -> Option<f64> {
        let inv = [common::finite_inverse(d[0]), common::finite_inverse(d[1])];
        let r64 = common::Ray64::new(o, d);
        self.rays.set(self.rays.get() + 1);
        let (t0, t1) = self.g.clip(o, d, inv)?;
        let eps = 1e-5 * t1.abs().max(1.0);
        let (fx, fy) = (f32::from(d[0] < 0.0), f32::from(d[1] < 0.0));
        let (ord, ord_idx) = &self.orders[usize::from(d[0] < 0.0) | usize::from(d[1] < 0.0) << 1];
        let (cx, cy) = (vec16(ord.cx), vec16(ord.cy));
        // Entry and exit plane offsets of each child, in child sizes from the block's corner.
        let ex_off = _mm512_add_ps(cx, _mm512_set1_ps(fx));
        let xx_off = _mm512_add_ps(cx, _mm512_set1_ps(1.0 - fx));
        let ey_off = _mm512_add_ps(cy, _mm512_set1_ps(fy));
        let xy_off = _mm512_add_ps(cy, _mm512_set1_ps(1.0 - fy));
        let (invx, invy) = (_mm512_set1_ps(inv[0]), _mm512_set1_ps(inv[1]));
        let (t0v, t1v) = (_mm512_set1_ps(t0), _mm512_set1_ps(t1));
        let epsv = _mm512_set1_ps(eps);
        let (oz, dz) = (_mm512_set1_ps(o[2]), _mm512_set1_ps(d[2]));
        let margin = _mm512_set1_ps(1e-3);
        let (stepv, zlov) = (_mm512_set1_ps(self.p.step), _mm512_set1_ps(self.p.zlo));
        let down = d[2] < 0.0;
        // The children of node (level, ix, iy, m) that the ray may hit, and their intervals.
        let node = |level: u32, ix: u32, iy: u32, m: u32| -> (u16, __m512, __m512) {
            self.nodes.set(self.nodes.get() + 1);
            let s = (1u32 << (level - 2)) as f32;
            let (bx, by) = (
                _mm512_set1_ps((4 * ix) as f32 * s - o[0]),
                _mm512_set1_ps((4 * iy) as f32 * s - o[1]),
            );
            let (ex, xx, ey, xy) = if FMA {
                // Plane `X0 + k s` at `k (s inv) + (X0 - o) inv`.
                let (sx, sy) = (_mm512_set1_ps(s * inv[0]), _mm512_set1_ps(s * inv[1]));
                let (ax, ay) = (
                    _mm512_set1_ps(((4 * ix) as f32 * s - o[0]) * inv[0]),
                    _mm512_set1_ps(((4 * iy) as f32 * s - o[1]) * inv[1]),
                );
                (
                    _mm512_fmadd_ps(ex_off, sx, ax),
                    _mm512_fmadd_ps(xx_off, sx, ax),
                    _mm512_fmadd_ps(ey_off, sy, ay),
                    _mm512_fmadd_ps(xy_off, sy, ay),
                )
            } else {
                let sv = _mm512_set1_ps(s);
                (
                    _mm512_mul_ps(_mm512_fmadd_ps(ex_off, sv, bx), invx),
                    _mm512_mul_ps(_mm512_fmadd_ps(xx_off, sv, bx), invx),
                    _mm512_mul_ps(_mm512_fmadd_ps(ey_off, sv, by), invy),
                    _mm512_mul_ps(_mm512_fmadd_ps(xy_off, sv, by), invy),
                )
            };
            let ta = _mm512_max_ps(_mm512_max_ps(ex, ey), t0v);
            let tb = _mm512_min_ps(_mm512_min_ps(xx, xy), t1v);
            let tz = if down { tb } else { ta };
            let low = _mm512_fmadd_ps(dz, tz, oz);
            let base = 16 * m as usize;
            let raw = if U16 && level == 2 {
                let Some(mx) = self.p.cells16.get(base..base + 16) else {
                    return (0, ta, tb);
                };
                let mut a = [0u16; 16];
                a.copy_from_slice(mx);
                // SAFETY: same size, every bit pattern valid.
                let q = unsafe { std::mem::transmute::<[u16; 16], __m256i>(a) };
                _mm512_fmadd_ps(_mm512_cvtepi32_ps(_mm512_cvtepu16_epi32(q)), stepv, zlov)
            } else {
                let lvl = &self.p.levels[(level / 2 - 1) as usize];
                let Some(mx) = lvl.get(base..base + 16) else {
                    return (0, ta, tb);
                };
                let mut a = [0.0f32; 16];
                a.copy_from_slice(mx);
                vec16(a)
            };
            let max = _mm512_add_ps(_mm512_permutexvar_ps(*ord_idx, raw), margin);
            let open = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(ta, _mm512_add_ps(tb, epsv));
            let under = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(low, max);
            (open & under, ta, tb)
        };
        let (mask, ta, tb) = node(self.p.n, 0, 0, 0);
        if mask == 0 {
            return None;
        }
        let mut cur = Entry {
            level: self.p.n,
            ix: 0,
            iy: 0,
            m: 0,
            mask: u32::from(mask),
            ta,
            tb,
        };
        // Nodes with children left, below `cur` (at most one a level).
        let mut stack = [cur; 16];
        let mut sp = 0usize;
        // Bounded: every node is entered at most once, and each pass takes one of its children.
        loop {
            if cur.mask == 0 {
                if sp == 0 {
                    break;
                }
                sp -= 1;
                cur = stack[sp];
            }
            // The nearest child left: the lanes are in the ray's order.
            let j = cur.mask.trailing_zeros() as usize & 15;
            cur.mask &= cur.mask - 1;
            let k = ord.morton[j];
            let (kx, ky) = (ord.ix[j], ord.iy[j]);
            let (ix, iy, m) = (4 * cur.ix + kx, 4 * cur.iy + ky, 16 * cur.m + k as u32);
            let level = cur.level - 2;
            if level == 0 {
                let (a, b) = (arr16(cur.ta)[j], arr16(cur.tb)[j]);
                self.cells.set(self.cells.get() + 1);
                let hit = if CHEAP {
                    self.g
                        .cell_pieces(&r64, ix as usize, iy as usize, a - eps, b + eps)
                } else {
                    self.g
                        .cell(o, d, ix as usize, iy as usize, a - eps, b + eps)
                };
                if let Some(t) = hit {
                    return Some(t);
                }
                continue;
            }
            let (mask, ta, tb) = node(level, ix, iy, m);
            if mask != 0 {
                if cur.mask != 0 && sp < stack.len() {
                    stack[sp] = cur;
                    sp += 1;
                }
                cur = Entry {
                    level,
                    ix,
                    iy,
                    m,
                    mask: u32::from(mask),
                    ta,
                    tb,
                };
            }
        }
        None
    }
}

/// The variant's switches, each on unless its environment variable is `0`.
#[derive(Clone, Copy)]
struct Variant {
    /// `CHEAP_CELL`: cells take `LocalGrid::cell_pieces` instead of the yardsticks' shared
    /// Moller-Trumbore test.
    cheap_cell: bool,
    /// `ONE_FMA`: a node's slab parameters take one multiply-add each (per-node scalars
    /// folded).
    one_fma: bool,
    /// `U16_CELLS`: the cells' maxima are read as `u16` quantised upwards (half the bytes).
    u16_cells: bool,
}

impl Variant {
    fn from_env() -> Variant {
        let on = |k: &str| std::env::var(k).map_or(true, |v| v != "0");
        Variant {
            cheap_cell: on("CHEAP_CELL"),
            one_fma: on("ONE_FMA"),
            u16_cells: on("U16_CELLS"),
        }
    }
}

impl common::LocalTracer for Tracer {
    fn trace(&self, o: [f32; 3], d: [f32; 3]) -> Option<f64> {
        let v = self.v;
        // SAFETY: `main` checked that the CPU has AVX-512 F. Each combination of switches is
        // its own instance (switches tested at run time inside the walk cost about a fifth).
        unsafe {
            match (v.cheap_cell, v.one_fma, v.u16_cells) {
                (true, true, true) => self.trace16::<true, true, true>(o, d),
                (true, true, false) => self.trace16::<true, true, false>(o, d),
                (true, false, true) => self.trace16::<true, false, true>(o, d),
                (true, false, false) => self.trace16::<true, false, false>(o, d),
                (false, true, true) => self.trace16::<false, true, true>(o, d),
                (false, true, false) => self.trace16::<false, true, false>(o, d),
                (false, false, true) => self.trace16::<false, false, true>(o, d),
                (false, false, false) => self.trace16::<false, false, false>(o, d),
            }
        }
    }
}

fn main() {
    assert!(
        std::arch::is_x86_feature_detected!("avx512f"),
        "mip_sixteen needs AVX-512 F"
    );
    let t = common::mip_yardstick("sixteen", |g| {
        let p = Pyramid::new(&g);
        let orders =
            [(false, false), (true, false), (false, true), (true, true)].map(|(fx, fy)| {
                let o = common::Order::new(fx, fy);
                let idx: [i32; 16] = std::array::from_fn(|j| o.morton[j] as i32);
                // SAFETY: same size, every bit pattern valid.
                (o, unsafe { std::mem::transmute::<[i32; 16], __m512i>(idx) })
            });
        Tracer {
            g,
            p,
            orders,
            v: Variant::from_env(),
            nodes: Default::default(),
            cells: Default::default(),
            rays: Default::default(),
        }
    });
    println!(
        "nodes/ray {:.2} cells/ray {:.2}",
        t.nodes.get() as f64 / t.rays.get() as f64,
        t.cells.get() as f64 / t.rays.get() as f64
    );
}
