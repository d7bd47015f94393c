//! Yardstick, not library code: view-dependent refinement of the `vd_lean` frames (Puget
//! 1025^2, 0.5 / 1 / 4 px) with the triangles written as grid indices `y * width + x` (the
//! whole grid as the vertex buffer, nothing renumbered), four ways, interleaved run by run:
//! - *level by level*: each level's triangles are a flat list decided in one loop with no
//!   data-dependent branch (children and output written unconditionally, the write positions
//!   advanced by the decision);
//! - *depth first*: `vd_lean`'s recursion (same decisions: SOAR's sphere test, frustum culling
//!   with the active-plane mask, lazy below the last 4 levels, `f32`, a square `2^k + 1` grid,
//!   each vertex's error, radius and height in one 16-byte row-major record);
//! - *stack*: the same with an explicit stack, again with the decision in `f64` as the
//!   library makes it (positions from the grid index, planes, eye and `kappa / tau` in `f64`),
//!   and again reading the library's own linear 8-byte records (`pack_records`; their
//!   bfloat16 errors and radii are rounded up, so the triangles are those of the records
//!   layout);
//! - *stack, lookahead*: the stack walk on its own records, which also hold two per-triangle
//!   bounds of the children's errors (`vd_lookahead`), writing a split's children as leaves
//!   without deciding them when the bound settles them (same triangles, same order);
//! - *pair*: the stack walk deciding both children of a split before pushing them, so that a
//!   popped entry's kind was decided long before (on its own records in `f32` and in `f64`,
//!   and on the library's records in `f32` and in `f64`; the same triangles in the same order
//!   as the stack walk on the same data, and in `f64` on the library's records exactly
//!   `grid_triangles`' list);
//! - *pair x2*: the pair walk in `f64` on the library's records with both children's sphere
//!   tests (below the culled levels) in the two lanes of SSE2 registers (`sse2`, intrinsics) or
//!   as straight-line pairs of scalar operations left to the compiler (`straight`, the form a
//!   core without `unsafe` can write); both exactly `grid_triangles`' list (asserted);
//! - *current*: the pair walk with the visited triangle held apart (only the second child is
//!   pushed: the library's walk since 2026-12-06), in `f64` on the library's records, alone and
//!   with the *x2* sphere tests (`straight`, `sse2`);
//! - *current leaves*: the library's walk form exactly (a split whose first child does not split
//!   writes its leaf children at once), and *straight*, that case as straight-line code;
//! - *pair prefetch*: the pair walk in `f64` on the library's records, prefetching the records
//!   of each pushed child's two children (the same triangles);
//! - *current, level records*: *current* on the library's records regrouped by level of the
//!   bisection ([`by_level`]: each level's split vertices in a compact grid of their own, so a
//!   cache line holds eight neighbours of one level instead of a row's eight samples);
//! - *current packed*: *current* with each corner packed as row-major index, `x` and `y` in one
//!   `u64`, so a triangle's output and a record's index are masks (*tables*: also the squared
//!   x and y distances to the eye from per-frame tables);
//! - *branch-free*: a stack walk that decides the children of every entry it visits, whatever
//!   its kind, and selects the next entry, the stack size and the output position without a
//!   data-dependent branch below the culled levels (*two-ended*: two such walks in one loop,
//!   from the front and the back of the depth-first order, meeting in the middle; *pairs*: the
//!   same visiting splits only, a leaf that must wait for its first sibling's subtree pushed
//!   as an entry of its own);
//! - the library's `Refiner::grid_triangles` on the full layout, linear and interleaved
//!   records, and `Refiner::triangles` (compact vertices, renumbered) for reference.
//!
//! The first three give the same triangles (asserted as multisets), `grid_triangles` on the
//! full layout gives the depth-first walk's triangles in its order (asserted).
//!
//! `cargo run --release -p relief-benches --example vd_bfs` (`RUNS=n`; `ONLY=text` runs only
//! the variants whose name contains `text`; `MOVE=m` instead times two walks on one frame
//! repeated against two frames in turn, the second with the eye moved `m` metres)

use relief_core::refine::{
    hierarchy_len, pack_records, preprocess, records_len, triangle_bound, Criterion, RecordLayout,
    Refiner, VertexRecord, View,
};
use relief_core::Heightfield;
use std::hint::black_box;
use std::time::Instant;

mod common;
use common::{camera, BENCH_EYE_X};

/// A triangle of the bisection hierarchy: hypotenuse `l`-`r`, apex `a`, points packed as
/// `x | y << 16`, and the planes still active for it.
#[derive(Clone, Copy, Default, Debug)]
struct Tri {
    l: u32,
    r: u32,
    a: u32,
    planes: u32,
}

impl Tri {
    /// The two children of the split at the hypotenuse's midpoint (first, second), each with
    /// `planes`.
    #[inline(always)]
    fn children(&self, planes: u32) -> (Tri, Tri) {
        let m = (self.l + self.r) >> 1;
        (
            Tri {
                l: self.a,
                r: self.l,
                a: m,
                planes,
            },
            Tri {
                l: self.r,
                r: self.a,
                a: m,
                planes,
            },
        )
    }
}

struct Frame<'a> {
    /// Per vertex, row-major: error, radius, local height (one cache line per decision), and
    /// in the fourth slot the lookahead's two per-triangle bounds ([`look_bounds`]).
    rec: &'a [[f32; 4]],
    /// The library's own linear 8-byte records (`pack_records`), for the `LIB` variant.
    lib: &'a [VertexRecord],
    /// The same records by level ([`by_level`]): each level's split vertices in a compact
    /// row-major grid of their own, and per level `(base, row stride, row shift, column shift)`.
    lvl: &'a [VertexRecord],
    lvl_tab: &'a [[u32; 4]],
    v: common::LeanView,
}

/// Where a stack walk reads and decides: the 16-byte records in `f32`, the same in `f64`, or
/// the library's 8-byte linear records in `f32`.
const OWN_F32: u8 = 0;
const OWN_F64: u8 = 1;
const LIB: u8 = 2;
/// [`OWN_F32`] with the lookahead of `vd_lookahead`: a split whose children the per-triangle
/// bound in the record's fourth slot settles writes them as leaves without deciding them.
const OWN_LOOK: u8 = 3;
/// [`LIB`] with the decision in `f64`, as the library makes it.
const LIB_F64: u8 = 4;
/// [`LIB_F64`] with the pair walk's two sphere tests in the two lanes of SSE2 registers
/// (below the culled levels; the same `f64` operations, so the same decisions).
const LIB_F64_X2: u8 = 5;
/// [`LIB_F64_X2`] written as straight-line pairs of scalar operations, left to the compiler's
/// vectorizer (the form the core, which has no `unsafe`, could use).
const LIB_F64_X2S: u8 = 6;

/// [`LIB_F64`] with the records of each child's two children's split vertices prefetched when
/// the child is pushed (their addresses need only the corners, not the decisions).
const LIB_F64_PF: u8 = 7;

/// [`LIB_F64`] on the records by level ([`by_level`]).
const LVL_F64: u8 = 8;

/// Stack entry kinds of [`Frame::dfs_pair`].
const CULLED: u32 = 0;
const LEAF: u32 = 1;
const SPLIT: u32 = 2;
thread_local! {
    /// [`Frame::dfs_p`]'s decisions without and with planes to test, when it counts them.
    static PATHS: [std::cell::Cell<u64>; 2] = const { [std::cell::Cell::new(0), std::cell::Cell::new(0)] };
}

/// The bottom entry of a branch-free walk's stack ([`Frame::dfs_bl`]).
const STOP: u32 = 3;

/// An entry of [`Frame::dfs_bl`]: a triangle, its level and kind, and the range of finest
/// triangles it covers in depth-first order.
#[derive(Clone, Copy, Default)]
struct BlEntry {
    t: Tri,
    level: u32,
    kind: u32,
    lo: u32,
    hi: u32,
}

/// One walk of [`Frame::dfs_bl`]: its stack, stack size, output position and the entry it visits
/// next (without `PAIRS`; with it, the stack top is).
struct BlWalk {
    stack: [BlEntry; 64],
    sp: usize,
    n: usize,
    cur: BlEntry,
}

#[inline(always)]
fn xy(p: u32) -> (u32, u32) {
    (p & 0xffff, p >> 16)
}

impl Frame<'_> {
    #[inline(always)]
    fn index(&self, p: u32) -> u32 {
        let (x, y) = xy(p);
        y * self.v.w + x
    }

    /// `vd_lean`'s decision for split vertex `m` (packed) at `level`: `None` if its sphere is
    /// outside an active plane (culled), else whether it splits and the planes still active.
    #[inline(always)]
    fn decide(&self, m: u32, planes: u32, level: u32) -> Option<(bool, u32)> {
        self.decide_in::<OWN_F32>(m, planes, level)
    }

    /// [`Frame::decide`] with the data and precision of `SRC` ([`OWN_F32`], [`OWN_F64`]:
    /// `f64` constants, [`LIB`]).
    #[inline(always)]
    fn decide_in<const SRC: u8>(&self, m: u32, planes: u32, level: u32) -> Option<(bool, u32)> {
        let (x, y) = xy(m);
        let i = self.index(m) as usize;
        if SRC == LIB || SRC == LIB_F64 || SRC == LVL_F64 {
            let r = if SRC == LVL_F64 {
                let [base, stride, sy, sx] = self.lvl_tab[level as usize];
                self.lvl[(base + (y >> sy) * stride + (x >> sx)) as usize]
            } else {
                self.lib[i]
            };
            let erz = (r.error_value(), r.radius_value(), r.z);
            if SRC == LIB_F64 || SRC == LVL_F64 {
                return self.v.decide(&self.v.f64s, (x, y, level), erz, planes);
            }
            return self.v.decide(&self.v.f32s, (x, y, level), erz, planes);
        }
        let [e, rr, pz, _] = self.rec[i];
        if SRC == OWN_F64 {
            self.v
                .decide(&self.v.f64s, (x, y, level), (e, rr, pz), planes)
        } else {
            self.v
                .decide(&self.v.f32s, (x, y, level), (e, rr, pz), planes)
        }
    }

    /// The depth-first walk of `vd_lean` (same decisions), into grid-index triangles: the
    /// reference.
    fn dfs(&self, out: &mut Vec<[u32; 3]>, t: Tri, level: u32) {
        let tri = [self.index(t.l), self.index(t.r), self.index(t.a)];
        if level >= self.v.levels {
            out.push(tri);
            return;
        }
        let m = (t.l + t.r) >> 1;
        let Some((split, planes)) = self.decide(m, t.planes, level) else {
            return;
        };
        if split {
            let (a, b) = t.children(planes);
            self.dfs(out, a, level + 1);
            self.dfs(out, b, level + 1);
        } else {
            out.push(tri);
        }
    }

    /// The depth-first walk with an explicit stack (the second child below the first, so the
    /// output order is the recursion's), into `out`; returns the triangle count.
    fn dfs_stack<const SRC: u8>(&self, roots: [Tri; 2], out: &mut [[u32; 3]]) -> usize {
        let mut stack = [(Tri::default(), 0u32); 64];
        stack[0] = (roots[1], 0);
        stack[1] = (roots[0], 0);
        let mut sp = 2usize;
        let mut no = 0usize;
        while sp > 0 {
            sp -= 1;
            let (t, level) = stack[sp];
            let tri = [self.index(t.l), self.index(t.r), self.index(t.a)];
            if level >= self.v.levels {
                out[no] = tri;
                no += 1;
                continue;
            }
            let m = (t.l + t.r) >> 1;
            let Some((split, planes)) = self.decide_in::<SRC>(m, t.planes, level) else {
                continue;
            };
            if split {
                if SRC == OWN_LOOK
                    && level + 1 < self.v.levels
                    && (planes == 0 || level + 1 >= self.v.lazy_from)
                    && self.settled(m, t.a)
                {
                    // Both children are leaves: written as the walk would pop them.
                    out[no] = [self.index(t.a), self.index(t.l), self.index(m)];
                    out[no + 1] = [self.index(t.r), self.index(t.a), self.index(m)];
                    no += 2;
                    continue;
                }
                let (a, b) = t.children(planes);
                stack[sp] = (b, level + 1);
                stack[sp + 1] = (a, level + 1);
                sp += 2;
            } else {
                out[no] = tri;
                no += 1;
            }
        }
        no
    }

    /// The decision of `t` at `level` as a stack entry's kind: [`CULLED`], [`LEAF`] or
    /// [`SPLIT`] (with the planes still active written into `t`).
    #[inline(always)]
    fn kind<const SRC: u8>(&self, t: &mut Tri, level: u32) -> u32 {
        if level >= self.v.levels {
            return LEAF;
        }
        match self.decide_in::<SRC>((t.l + t.r) >> 1, t.planes, level) {
            None => CULLED,
            Some((split, planes)) => {
                t.planes = planes;
                if split {
                    SPLIT
                } else {
                    LEAF
                }
            }
        }
    }

    /// [`Frame::kind`] of two siblings on `level` for [`LIB_F64_X2`]: where no plane is left to
    /// test, both sphere tests in one pair of `f64` lanes.
    #[inline(always)]
    fn kinds_x2<const SSE2: bool>(&self, a: &mut Tri, b: &mut Tri, level: u32) -> (u32, u32) {
        use std::arch::x86_64::*;
        if level >= self.v.levels {
            return (LEAF, LEAF);
        }
        if a.planes != 0 && level < self.v.lazy_from {
            return (
                self.kind::<LIB_F64>(a, level),
                self.kind::<LIB_F64>(b, level),
            );
        }
        let (ma, mb) = ((a.l + a.r) >> 1, (b.l + b.r) >> 1);
        let (ra, rb) = (
            self.lib[self.index(ma) as usize],
            self.lib[self.index(mb) as usize],
        );
        let ((xa, ya), (xb, yb)) = (xy(ma), xy(mb));
        let c = &self.v.f64s;
        let m = if SSE2 {
            // SAFETY: SSE2 is part of x86-64.
            unsafe {
                let pair = |p: f64, q: f64| _mm_set_pd(q, p);
                let px = _mm_mul_pd(pair(f64::from(xa), f64::from(xb)), _mm_set1_pd(c.sx));
                let py = _mm_mul_pd(pair(f64::from(ya), f64::from(yb)), _mm_set1_pd(c.sy));
                let pz = pair(f64::from(ra.z), f64::from(rb.z));
                let e = pair(f64::from(ra.error_value()), f64::from(rb.error_value()));
                let r = pair(f64::from(ra.radius_value()), f64::from(rb.radius_value()));
                let dx = _mm_sub_pd(_mm_set1_pd(c.eye[0]), px);
                let dy = _mm_sub_pd(_mm_set1_pd(c.eye[1]), py);
                let dz = _mm_sub_pd(_mm_set1_pd(c.eye[2]), pz);
                let reach = _mm_add_pd(_mm_mul_pd(e, _mm_set1_pd(c.k)), r);
                let d2 = _mm_add_pd(
                    _mm_add_pd(_mm_mul_pd(dx, dx), _mm_mul_pd(dy, dy)),
                    _mm_mul_pd(dz, dz),
                );
                let split = _mm_and_pd(
                    _mm_cmpgt_pd(e, _mm_setzero_pd()),
                    _mm_cmpgt_pd(_mm_mul_pd(reach, reach), d2),
                );
                _mm_movemask_pd(split)
            }
        } else {
            // Straight-line pairs of the same operations, for the compiler's SLP vectorizer.
            let (px0, px1) = (f64::from(xa) * c.sx, f64::from(xb) * c.sx);
            let (py0, py1) = (f64::from(ya) * c.sy, f64::from(yb) * c.sy);
            let (pz0, pz1) = (f64::from(ra.z), f64::from(rb.z));
            let (e0, e1) = (f64::from(ra.error_value()), f64::from(rb.error_value()));
            let (r0, r1) = (f64::from(ra.radius_value()), f64::from(rb.radius_value()));
            let (dx0, dx1) = (c.eye[0] - px0, c.eye[0] - px1);
            let (dy0, dy1) = (c.eye[1] - py0, c.eye[1] - py1);
            let (dz0, dz1) = (c.eye[2] - pz0, c.eye[2] - pz1);
            let (q0, q1) = (e0 * c.k + r0, e1 * c.k + r1);
            let (d0, d1) = (
                dx0 * dx0 + dy0 * dy0 + dz0 * dz0,
                dx1 * dx1 + dy1 * dy1 + dz1 * dz1,
            );
            let s0 = (e0 > 0.0) & (q0 * q0 > d0);
            let s1 = (e1 > 0.0) & (q1 * q1 > d1);
            i32::from(s0) | i32::from(s1) << 1
        };
        let k = |bit: i32| if m & bit != 0 { SPLIT } else { LEAF };
        (k(1), k(2))
    }

    /// [`Frame::dfs_stack`] with both children decided when their parent splits, before either
    /// is pushed: the two record loads and decisions are independent, and the branch on a
    /// popped entry's kind reads a value decided long before (same triangles, same order).
    fn dfs_pair<const SRC: u8>(&self, roots: [Tri; 2], out: &mut [[u32; 3]]) -> usize {
        let mut stack = [(Tri::default(), 0u32, 0u32); 64];
        let (mut r0, mut r1) = (roots[0], roots[1]);
        let k0 = self.kind::<SRC>(&mut r0, 0);
        let k1 = self.kind::<SRC>(&mut r1, 0);
        stack[0] = (r1, 0, k1);
        stack[1] = (r0, 0, k0);
        let mut sp = 2usize;
        let mut no = 0usize;
        while sp > 0 {
            sp -= 1;
            let (t, level, kind) = stack[sp];
            if kind == LEAF {
                out[no] = [self.index(t.l), self.index(t.r), self.index(t.a)];
                no += 1;
                continue;
            }
            if kind == CULLED {
                continue;
            }
            let (mut a, mut b) = t.children(t.planes);
            if SRC == LIB_F64_PF && level + 2 < self.v.levels {
                for c in [&a, &b] {
                    for q in [(c.a + c.l) >> 1, (c.r + c.a) >> 1] {
                        let p = self.lib.as_ptr().wrapping_add(self.index(q) as usize);
                        // SAFETY: a prefetch does not access memory.
                        unsafe {
                            std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
                                p as *const i8,
                            )
                        };
                    }
                }
            }
            let (ka, kb) = if SRC == LIB_F64_X2 {
                self.kinds_x2::<true>(&mut a, &mut b, level + 1)
            } else if SRC == LIB_F64_X2S {
                self.kinds_x2::<false>(&mut a, &mut b, level + 1)
            } else if SRC == LIB_F64_PF {
                (
                    self.kind::<LIB_F64>(&mut a, level + 1),
                    self.kind::<LIB_F64>(&mut b, level + 1),
                )
            } else {
                (
                    self.kind::<SRC>(&mut a, level + 1),
                    self.kind::<SRC>(&mut b, level + 1),
                )
            };
            stack[sp] = (b, level + 1, kb);
            stack[sp + 1] = (a, level + 1, ka);
            sp += 2;
        }
        no
    }

    /// [`Frame::dfs_pair`] with the first child kept in registers as the current entry instead
    /// of pushed and popped at once (only the second child is pushed; same triangles, same
    /// order).
    fn dfs_cur<const SRC: u8>(&self, roots: [Tri; 2], out: &mut [[u32; 3]]) -> usize {
        let mut stack = [(Tri::default(), 0u32, 0u32); 64];
        let (mut r0, mut r1) = (roots[0], roots[1]);
        let k0 = self.kind::<SRC>(&mut r0, 0);
        let k1 = self.kind::<SRC>(&mut r1, 0);
        stack[0] = (r1, 0, k1);
        let mut sp = 1usize;
        let mut no = 0usize;
        let mut cur = (r0, 0u32, k0);
        loop {
            let (t, level, kind) = cur;
            if kind == SPLIT {
                let (mut a, mut b) = t.children(t.planes);
                let (ka, kb) = match SRC {
                    LIB_F64_X2 => self.kinds_x2::<true>(&mut a, &mut b, level + 1),
                    LIB_F64_X2S => self.kinds_x2::<false>(&mut a, &mut b, level + 1),
                    _ => (
                        self.kind::<SRC>(&mut a, level + 1),
                        self.kind::<SRC>(&mut b, level + 1),
                    ),
                };
                stack[sp] = (b, level + 1, kb);
                sp += 1;
                cur = (a, level + 1, ka);
                continue;
            }
            if kind == LEAF {
                out[no] = [self.index(t.l), self.index(t.r), self.index(t.a)];
                no += 1;
            }
            if sp == 0 {
                break;
            }
            sp -= 1;
            cur = stack[sp];
        }
        no
    }

    /// A corner packed for [`Frame::dfs_p`]: row-major index in the low 32 bits, `x` in bits
    /// 32-47, `y` in bits 48-63 (the midpoint of a hypotenuse is the packed mean: every field's
    /// sum is even, and none carries into the next).
    #[inline(always)]
    fn packed(&self, p: u32) -> u64 {
        let (x, y) = xy(p);
        u64::from(y * self.v.w + x) | u64::from(x) << 32 | u64::from(y) << 48
    }

    /// [`Frame::kind`] in `f64` on the library's records for a packed hypotenuse `l`-`r`
    /// ([`Frame::packed`]); with `TAB`, the squared x and y distances to the eye from the
    /// per-frame tables `tx`, `ty` (the same `f64` values the decision computes).
    #[inline(always)]
    fn kind_p<const TAB: bool, const COUNT: bool>(
        &self,
        l: u64,
        r: u64,
        planes: &mut u32,
        level: u32,
        tx: &[f64],
        ty: &[f64],
    ) -> u32 {
        if level >= self.v.levels {
            return LEAF;
        }
        let m = (l + r) >> 1;
        let (x, y) = (((m >> 32) & 0xffff) as u32, (m >> 48) as u32);
        let rec = self.lib[m as u32 as usize];
        let erz = (rec.error_value(), rec.radius_value(), rec.z);
        if COUNT {
            // Decisions below the culled levels (or with no plane left) / with planes to test.
            let k = usize::from(*planes != 0 && level < self.v.lazy_from);
            PATHS.with(|p| p[k].set(p[k].get() + 1));
        }
        if *planes != 0 && level < self.v.lazy_from {
            return match self.v.decide(&self.v.f64s, (x, y, level), erz, *planes) {
                None => CULLED,
                Some((split, p)) => {
                    *planes = p;
                    if split {
                        SPLIT
                    } else {
                        LEAF
                    }
                }
            };
        }
        let dxy = TAB.then(|| tx[x as usize] + ty[y as usize]);
        if self.sphere_f64((x, y), erz, dxy) {
            SPLIT
        } else {
            LEAF
        }
    }

    /// SOAR's sphere test in `f64` as the library makes it, without a branch, for the split
    /// vertex at `(x, y)` with error, radius and local height `erz`; `dxy`, if given, is its
    /// squared horizontal distance to the eye (the same value, from a table).
    #[inline(always)]
    fn sphere_f64(&self, (x, y): (u32, u32), erz: (f32, f32, f32), dxy: Option<f64>) -> bool {
        let c = &self.v.f64s;
        let (e, r) = (f64::from(erz.0), f64::from(erz.1));
        let dz = c.eye[2] - f64::from(erz.2);
        let dxy = dxy.unwrap_or_else(|| {
            let (dx, dy) = (
                c.eye[0] - f64::from(x) * c.sx,
                c.eye[1] - f64::from(y) * c.sy,
            );
            dx * dx + dy * dy
        });
        let reach = e * c.k + r;
        (e > 0.0) & (reach * reach > dxy + dz * dz)
    }

    /// [`Frame::dfs_cur`] (as `LIB_F64`) with corners packed by [`Frame::packed`], so a
    /// triangle's output and a record's index are masks, not index computations; with `TAB`,
    /// [`Frame::kind_p`]'s distance tables, filled per frame here. `COUNT`: count the
    /// decisions by path in `PATHS` (not timed).
    fn dfs_p<const TAB: bool, const COUNT: bool>(
        &self,
        roots: [Tri; 2],
        out: &mut [[u32; 3]],
    ) -> usize {
        let c = &self.v.f64s;
        let mut tx = [0.0f64; 1025];
        let mut ty = [0.0f64; 1025];
        if TAB {
            for (i, (a, b)) in tx.iter_mut().zip(ty.iter_mut()).enumerate() {
                let (dx, dy) = (c.eye[0] - i as f64 * c.sx, c.eye[1] - i as f64 * c.sy);
                *a = dx * dx;
                *b = dy * dy;
            }
        }
        type E = (u64, u64, u64, u32, u32, u32);
        let mut stack = [(0u64, 0u64, 0u64, 0u32, 0u32, 0u32); 64];
        let root = |t: Tri| {
            let (l, r, a) = (self.packed(t.l), self.packed(t.r), self.packed(t.a));
            let mut pl = t.planes;
            let k = self.kind_p::<TAB, COUNT>(l, r, &mut pl, 0, &tx, &ty);
            (l, r, a, pl, 0u32, k)
        };
        stack[0] = root(roots[1]);
        let mut sp = 1usize;
        let mut no = 0usize;
        let mut cur: E = root(roots[0]);
        loop {
            let (l, r, a, planes, level, kind) = cur;
            if kind == SPLIT {
                let m = (l + r) >> 1;
                let (mut pa, mut pb) = (planes, planes);
                let ka = self.kind_p::<TAB, COUNT>(a, l, &mut pa, level + 1, &tx, &ty);
                let kb = self.kind_p::<TAB, COUNT>(r, a, &mut pb, level + 1, &tx, &ty);
                stack[sp] = (r, a, m, pb, level + 1, kb);
                sp += 1;
                cur = (a, l, m, pa, level + 1, ka);
                continue;
            }
            if kind == LEAF {
                out[no] = [l as u32, r as u32, a as u32];
                no += 1;
            }
            if sp == 0 {
                break;
            }
            sp -= 1;
            cur = stack[sp];
        }
        no
    }

    /// The library's walk form exactly (`Refiner::lean_walk`): [`Frame::dfs_cur`] where a
    /// split whose first child does not split writes its leaf children at once and visits the
    /// second child without a push (or writes it too). With `BF`, that case is straight-line
    /// code: both children written to the output slots unconditionally and the position
    /// advanced by their kinds, the next entry selected between the second child and the
    /// stack top by masks (a stop entry at the stack bottom ends the walk). Same triangles,
    /// same order.
    fn dfs_leaves<const BF: bool>(&self, roots: [Tri; 2], out: &mut [[u32; 3]]) -> usize {
        let mut stack = [(Tri::default(), 0u32, 0u32); 64];
        let (mut r0, mut r1) = (roots[0], roots[1]);
        let k0 = self.kind::<LIB_F64>(&mut r0, 0);
        let k1 = self.kind::<LIB_F64>(&mut r1, 0);
        stack[0] = (Tri::default(), 0, STOP);
        stack[1] = (r1, 0, k1);
        let mut sp = 2usize;
        let mut no = 0usize;
        let mut cur = (r0, 0u32, k0);
        let idx = |t: &Tri| [self.index(t.l), self.index(t.r), self.index(t.a)];
        loop {
            let (t, level, kind) = cur;
            if kind == SPLIT {
                let (mut a, mut b) = t.children(t.planes);
                let ka = self.kind::<LIB_F64>(&mut a, level + 1);
                let kb = self.kind::<LIB_F64>(&mut b, level + 1);
                let second = (b, level + 1, kb);
                if ka == SPLIT {
                    stack[sp] = second;
                    sp += 1;
                    cur = (a, level + 1, ka);
                    continue;
                }
                if BF {
                    out[no] = idx(&a);
                    no += usize::from(ka == LEAF);
                    out[no] = idx(&b);
                    no += usize::from(kb == LEAF);
                    let split = kb == SPLIT;
                    let top = stack[sp - 1];
                    let mk = 0u32.wrapping_sub(u32::from(split));
                    let sel = |p: u32, q: u32| (p & mk) | (q & !mk);
                    cur = (
                        Tri {
                            l: sel(b.l, top.0.l),
                            r: sel(b.r, top.0.r),
                            a: sel(b.a, top.0.a),
                            planes: sel(b.planes, top.0.planes),
                        },
                        sel(level + 1, top.1),
                        sel(kb, top.2),
                    );
                    sp -= usize::from(!split);
                    continue;
                }
                if ka == LEAF {
                    out[no] = idx(&a);
                    no += 1;
                }
                if kb == SPLIT {
                    cur = second;
                    continue;
                }
                if kb == LEAF {
                    out[no] = idx(&b);
                    no += 1;
                }
            } else if kind == LEAF {
                out[no] = idx(&t);
                no += 1;
            } else if kind == STOP {
                break;
            }
            sp -= 1;
            cur = stack[sp];
        }
        no
    }

    /// Whether the lookahead settles both children of the split of the triangle with split
    /// vertex `m` and apex `a`: the largest error among the children's split vertices (the
    /// record's bound for `a`'s side) fails SOAR's test against `m`'s own sphere, so by nesting
    /// every child's does too.
    #[inline(always)]
    fn settled(&self, m: u32, a: u32) -> bool {
        let (x, y) = xy(m);
        let [_, rr, pz, look] = self.rec[(y * self.v.w + x) as usize];
        let ec = f32::from_bits((look.to_bits() >> (16 * side(m, a))) << 16);
        let c = &self.v.f32s;
        let (dx, dy, dz) = (
            c.eye[0] - x as f32 * c.sx,
            c.eye[1] - y as f32 * c.sy,
            c.eye[2] - pz,
        );
        let reach = ec * c.k + rr;
        reach * reach <= dx * dx + dy * dy + dz * dz
    }

    /// One level, level by level: decides every triangle of `cur`, writes the split ones'
    /// children to `next` and the others (unless culled) to `out` from `no`. Returns the
    /// children written and the new output length. `CULL`: the level is above the lazy levels.
    #[inline(always)]
    fn level<const CULL: bool>(
        &self,
        cur: &[Tri],
        next: &mut [Tri],
        out: &mut [[u32; 3]],
        mut no: usize,
    ) -> (usize, usize) {
        let mut nn = 0usize;
        for t in cur {
            let m = (t.l + t.r) >> 1;
            let (x, y) = xy(m);
            let i = (y * self.v.w + x) as usize;
            let [e, rr, pz, _] = self.rec[i];
            let (px, py) = (x as f32 * self.v.f32s.sx, y as f32 * self.v.f32s.sy);
            let mut planes = t.planes;
            let mut culled = false;
            if CULL {
                for (k, p) in self.v.f32s.planes.iter().enumerate() {
                    let on = (t.planes >> k) & 1 != 0;
                    let c = p[0] * px + p[1] * py + p[2] * pz + p[3];
                    culled |= on & (c + rr < 0.0);
                    planes &= !((u32::from(on & (c - rr > 0.0))) << k);
                }
            }
            let (dx, dy, dz) = (
                self.v.f32s.eye[0] - px,
                self.v.f32s.eye[1] - py,
                self.v.f32s.eye[2] - pz,
            );
            let reach = e * self.v.f32s.k + rr;
            let split = !culled & (e > 0.0) & (reach * reach > dx * dx + dy * dy + dz * dz);
            let emit = !culled & !split;
            (next[nn], next[nn + 1]) = t.children(planes);
            nn += 2 * usize::from(split);
            out[no] = [self.index(t.l), self.index(t.r), self.index(t.a)];
            no += usize::from(emit);
        }
        (nn, no)
    }

    /// [`Frame::kind`] in `f64` on the library's records without a data-dependent branch
    /// where no plane is left to test (below the culled levels): the record is loaded even
    /// for a triangle on the finest level (at index 0), and the kind is arithmetic.
    #[inline(always)]
    fn kind_bl(&self, t: &mut Tri, level: u32) -> u32 {
        if t.planes != 0 && level < self.v.lazy_from {
            return self.kind::<LIB_F64>(t, level);
        }
        let deep = level < self.v.levels;
        let m = ((t.l + t.r) >> 1) & 0u32.wrapping_sub(u32::from(deep));
        let (x, y) = xy(m);
        let rec = self.lib[(y * self.v.w + x) as usize];
        let erz = (rec.error_value(), rec.radius_value(), rec.z);
        LEAF + u32::from(deep & self.sphere_f64((x, y), erz, None))
    }

    /// The two children of entry `e` of a branch-free walk, each decided ([`Frame::kind_bl`])
    /// and with its half of `e`'s range, in the walk's order: first child first when `FWD`,
    /// second child first otherwise.
    #[inline(always)]
    fn bl_children<const FWD: bool>(&self, e: &BlEntry) -> (BlEntry, BlEntry) {
        let (mut a, mut b) = e.t.children(e.t.planes);
        let level = e.level + 1;
        let (ka, kb) = (self.kind_bl(&mut a, level), self.kind_bl(&mut b, level));
        let mid = e.lo + ((e.hi - e.lo) >> 1);
        let first = BlEntry {
            t: a,
            level,
            kind: ka,
            lo: e.lo,
            hi: mid,
        };
        let second = BlEntry {
            t: b,
            level,
            kind: kb,
            lo: mid,
            hi: e.hi,
        };
        if FWD {
            (first, second)
        } else {
            (second, first)
        }
    }

    /// One step of a branch-free walk ([`Frame::dfs_bl`]): the current entry's children are
    /// decided whatever its kind, the second (first when `!FWD`) is written to the stack top,
    /// the triangle to the output slot, and the counters and the next entry are selected.
    #[inline(always)]
    fn step_bl<const FWD: bool>(&self, w: &mut BlWalk, out: &mut [[u32; 3]]) {
        let e = w.cur;
        let (visit, push) = self.bl_children::<FWD>(&e);
        let leaf = usize::from(e.kind == LEAF);
        let tri = [self.index(e.t.l), self.index(e.t.r), self.index(e.t.a)];
        if FWD {
            out[w.n] = tri;
            w.n += leaf;
        } else {
            out[w.n - 1] = tri;
            w.n -= leaf;
        }
        w.stack[w.sp] = push;
        let popped = w.stack[w.sp - 1];
        let split = e.kind == SPLIT;
        let mk = 0u32.wrapping_sub(u32::from(split));
        let sel = |p: u32, q: u32| (p & mk) | (q & !mk);
        w.sp = (w.sp + 1 - 2 * usize::from(!split)).min(63);
        w.cur = BlEntry {
            t: Tri {
                l: sel(visit.t.l, popped.t.l),
                r: sel(visit.t.r, popped.t.r),
                a: sel(visit.t.a, popped.t.a),
                planes: sel(visit.t.planes, popped.t.planes),
            },
            level: sel(visit.level, popped.level),
            kind: sel(visit.kind, popped.kind),
            lo: sel(visit.lo, popped.lo),
            hi: sel(visit.hi, popped.hi),
        };
    }

    /// One step of [`Frame::dfs_bl`] with `PAIRS`: pops an entry (a split, or a leaf whose writing waits on
    /// its first sibling's subtree), decides its children whatever it is, and without a
    /// data-dependent branch (below the culled levels) writes what comes next in the order (the
    /// entry if a leaf; else its first child if a leaf, and its second too if the first does
    /// not split and the second is a leaf), then pushes the second child (a split, or a leaf
    /// behind a splitting first) and the first (a split). `FWD`: depth-first order, writing
    /// forwards; else the reverse, writing backwards.
    #[inline(always)]
    fn step_bp<const FWD: bool>(&self, w: &mut BlWalk, out: &mut [[u32; 3]]) {
        w.sp -= 1;
        let e = w.stack[w.sp];
        let (f, s) = self.bl_children::<FWD>(&e);
        let split = e.kind == SPLIT;
        let f_split = f.kind == SPLIT;
        let w0 = (!split & (e.kind == LEAF)) | (split & (f.kind == LEAF));
        let w1 = split & !f_split & (s.kind == LEAF);
        let mk = 0u32.wrapping_sub(u32::from(split));
        let sel = |p: u32, q: u32| (p & mk) | (q & !mk);
        let t0 = [
            self.index(sel(f.t.l, e.t.l)),
            self.index(sel(f.t.r, e.t.r)),
            self.index(sel(f.t.a, e.t.a)),
        ];
        let t1 = [self.index(s.t.l), self.index(s.t.r), self.index(s.t.a)];
        if FWD {
            out[w.n] = t0;
            w.n += usize::from(w0);
            out[w.n] = t1;
            w.n += usize::from(w1);
        } else {
            out[w.n - 1] = t0;
            w.n -= usize::from(w0);
            out[w.n - 1] = t1;
            w.n -= usize::from(w1);
        }
        let p1 = split & ((f_split & (s.kind != CULLED)) | (!f_split & (s.kind == SPLIT)));
        w.stack[w.sp] = s;
        w.sp += usize::from(p1);
        w.stack[w.sp] = f;
        w.sp += usize::from(split & f_split);
    }

    /// The roots' entries and ranges (in finest triangles, depth-first order) for
    /// [`Frame::dfs_bl`].
    fn bl_roots(&self, roots: [Tri; 2]) -> [BlEntry; 2] {
        let span = 1u32 << self.v.levels;
        let mut out = [BlEntry::default(); 2];
        for (i, mut t) in roots.into_iter().enumerate() {
            let kind = self.kind::<LIB_F64>(&mut t, 0);
            out[i] = BlEntry {
                t,
                level: 0,
                kind,
                lo: span * i as u32,
                hi: span * (i as u32 + 1),
            };
        }
        out
    }

    /// A depth-first walk without a data-dependent branch below the culled levels, deciding
    /// in `f64` on the library's records as `grid_triangles` does (the same triangles in the
    /// same order), by [`Frame::step_bl`] (the current entry held apart) or, with `PAIRS`, by
    /// [`Frame::step_bp`] (every entry on the stack: a split or a waiting leaf, so the children
    /// decided for nothing are only those of waiting leaves). `TWO`: two walks in one loop, one
    /// from the front of the depth-first order writing forwards from the start of `out`, one
    /// from its back writing backwards from the end, meeting where the first's next triangle
    /// starts at or after the second's (the decisions are the walk's, so both see the same
    /// partition of the domain); the second's triangles are then moved behind the first's.
    /// `out` needs two slots more than the count.
    fn dfs_bl<const PAIRS: bool, const TWO: bool>(
        &self,
        roots: [Tri; 2],
        out: &mut [[u32; 3]],
    ) -> usize {
        let [r0, r1] = self.bl_roots(roots);
        // A walk from the front (`fwd`) or the back: its stack bottom, its roots, its output
        // position.
        let walk = |fwd: bool, n: usize| {
            let (first, then) = if fwd { (r0, r1) } else { (r1, r0) };
            let end = if fwd { u32::MAX } else { 0 };
            let mut w = BlWalk {
                stack: [BlEntry::default(); 64],
                sp: 2,
                n,
                cur: first,
            };
            w.stack[0] = BlEntry {
                kind: STOP,
                lo: end,
                hi: end,
                ..BlEntry::default()
            };
            w.stack[1] = then;
            if PAIRS {
                w.stack[2] = first;
                w.sp = 3;
            }
            w
        };
        // The entry a walk takes next.
        let next = |w: &BlWalk| if PAIRS { w.stack[w.sp - 1] } else { w.cur };
        let step = |w: &mut BlWalk, out: &mut [[u32; 3]], fwd: bool| match (PAIRS, fwd) {
            (true, true) => self.step_bp::<true>(w, out),
            (true, false) => self.step_bp::<false>(w, out),
            (false, true) => self.step_bl::<true>(w, out),
            (false, false) => self.step_bl::<false>(w, out),
        };
        let mut fa = walk(true, 0);
        if !TWO {
            while next(&fa).kind != STOP {
                step(&mut fa, out, true);
            }
            return fa.n;
        }
        let cap = out.len();
        let mut fb = walk(false, cap);
        loop {
            if next(&fa).lo >= next(&fb).hi {
                break;
            }
            step(&mut fa, out, true);
            if next(&fa).lo >= next(&fb).hi {
                break;
            }
            step(&mut fb, out, false);
        }
        out.copy_within(fb.n..cap, fa.n);
        fa.n + cap - fb.n
    }

    /// The whole frame level by level; returns the triangle count.
    fn bfs(&self, roots: [Tri; 2], a: &mut [Tri], b: &mut [Tri], out: &mut [[u32; 3]]) -> usize {
        a[..2].copy_from_slice(&roots);
        let mut n = 2usize;
        let mut no = 0usize;
        let (mut cur, mut next) = (a, b);
        for level in 0..self.v.levels {
            let (nn, o) = if level < self.v.lazy_from {
                self.level::<true>(&cur[..n], next, out, no)
            } else {
                self.level::<false>(&cur[..n], next, out, no)
            };
            no = o;
            n = nn;
            std::mem::swap(&mut cur, &mut next);
        }
        // The finest level: every remaining triangle is a leaf.
        for t in &cur[..n] {
            out[no] = [self.index(t.l), self.index(t.r), self.index(t.a)];
            no += 1;
        }
        no
    }
}

/// Which triangle of `m`'s diamond has apex `a`: 0 or 1.
fn side(m: u32, a: u32) -> u32 {
    let ((mx, my), (ax, ay)) = (xy(m), xy(a));
    u32::from(ax > mx || (ax == mx && ay > my))
}

/// bfloat16 bits of `e >= 0`, rounded up.
/// The linear records `lib` of a `side + 1` square grid (`side = 2^k`) regrouped by level of
/// the bisection: level `2d` holds the centres of the `2^d x 2^d` squares of side `side / 2^d`
/// (a `2^d`-wide grid), level `2d + 1` the midpoints of their edges (rows of `2^d + 1`, one
/// row per multiple of half the side). Returns the records and per level `(base, stride, row
/// shift, column shift)`: vertex `(x, y)` of level `l` is at `base + (y >> rs) * stride + (x
/// >> cs)`.
fn by_level(lib: &[VertexRecord], side: u32) -> (Vec<VertexRecord>, Vec<[u32; 4]>) {
    let k = side.trailing_zeros();
    let mut tab = Vec::new();
    let mut base = 0u32;
    for l in 0..2 * k {
        let (d, t) = (l / 2, k - 1 - l / 2);
        let (stride, rows, rs) = if l % 2 == 0 {
            (1 << d, 1 << d, t + 1)
        } else {
            ((1 << d) + 1, (2 << d) + 1, t)
        };
        tab.push([base, stride, rs, t + 1]);
        base += stride * rows;
    }
    let mut out = vec![VertexRecord::default(); base as usize];
    let w = side + 1;
    for y in 0..w {
        for x in 0..w {
            let t = (x | y).trailing_zeros();
            if t >= k {
                continue; // a corner: never split
            }
            let centre = (x >> t) & 1 == 1 && (y >> t) & 1 == 1;
            let l = 2 * (k - 1 - t) + u32::from(!centre);
            let [b, st, rs, cs] = tab[l as usize];
            out[(b + (y >> rs) * st + (x >> cs)) as usize] = lib[(y * w + x) as usize];
        }
    }
    (out, tab)
}

fn bf16_up(e: f32) -> u32 {
    let b = e.to_bits();
    (b >> 16) + u32::from(b & 0xffff != 0)
}

/// Writes the lookahead's bounds into the fourth slot of `rec` (`side` 0 in the low 16 bits):
/// for each triangle `(l, r, a)` of the hierarchy above the finest level, the largest error of
/// its children's split vertices, bfloat16 rounded up, at its split vertex.
fn look_bounds(rec: &mut [[f32; 4]], w: u32, levels: u32, roots: [Tri; 2]) {
    let mut stack: Vec<(Tri, u32)> = roots.iter().map(|&t| (t, 0)).collect();
    let e = |rec: &[[f32; 4]], p: u32| {
        let (x, y) = xy(p);
        rec[(y * w + x) as usize][0]
    };
    while let Some((t, level)) = stack.pop() {
        if level + 1 >= levels {
            continue;
        }
        let m = (t.l + t.r) >> 1;
        let ec = e(rec, (t.a + t.l) >> 1).max(e(rec, (t.r + t.a) >> 1));
        let (x, y) = xy(m);
        let slot = &mut rec[(y * w + x) as usize][3];
        let bits = slot.to_bits() | (bf16_up(ec) << (16 * side(m, t.a)));
        *slot = f32::from_bits(bits);
        let (a, b) = t.children(0);
        stack.push((a, level + 1));
        stack.push((b, level + 1));
    }
}

fn main() {
    let runs = common::runs(30);
    let dem = common::puget();
    let (w, h) = (dem.width, dem.height);
    assert!(w == h && (w - 1).is_power_of_two() && w < 1 << 15);
    let hf = Heightfield::with_scale(&dem.samples, w, h, dem.scale).unwrap();
    let n = hierarchy_len(w, h);
    let (mut ef, mut rf) = (vec![0.0f32; n], vec![0.0f32; n]);
    let full = preprocess(&hf, &mut ef, &mut rf).unwrap();
    let side = w - 1;
    let cam = camera(BENCH_EYE_X);
    let li = common::lean_inputs(&hf, &full, &cam);
    let mut rec: Vec<[f32; 4]> = (0..li.z.len())
        .map(|i| [li.err[i], li.rad[i], li.z[i], 0.0])
        .collect();
    let planes = li.planes;
    let bound = triangle_bound(w, h);
    let mut la = vec![Tri::default(); bound + 2];
    let mut lb = vec![Tri::default(); bound + 2];
    let mut out = vec![[0u32; 3]; bound + 1];
    let mut verts = vec![[0.0f32; 3]; n];
    let mut tris = vec![[0u32; 3]; bound];
    let mut scratch = vec![0u64; relief_core::refine::scratch_len(w, h)];
    let mut out2 = vec![[0u32; 3]; bound];
    let mut out64 = vec![[0u32; 3]; bound + 1];
    let mut out_lib = vec![[0u32; 3]; bound + 1];
    let mut out_look = vec![[0u32; 3]; bound + 1];
    let mut out_pair = vec![[0u32; 3]; bound + 1];
    let mut out_pair_lib = vec![[0u32; 3]; bound + 1];
    let mut out_pair64 = vec![[0u32; 3]; bound + 1];
    let mut out_pair_lib64 = vec![[0u32; 3]; bound + 1];
    let mut out_pair_x2 = vec![[0u32; 3]; bound + 1];
    let mut out_pair_pf = vec![[0u32; 3]; bound + 1];
    let mut out_cur = vec![[0u32; 3]; bound + 1];
    let mut out_cur_lvl = vec![[0u32; 3]; bound + 1];
    let mut out_bl = vec![[0u32; 3]; bound + 2];
    let mut out_lv = vec![[0u32; 3]; bound + 2];
    let mut out_lv2 = vec![[0u32; 3]; bound + 2];
    let mut out_bp = vec![[0u32; 3]; bound + 2];
    let mut out_bp2 = vec![[0u32; 3]; bound + 2];
    let mut out_p = vec![[0u32; 3]; bound + 2];
    let mut out_pt = vec![[0u32; 3]; bound + 2];
    let mut out_bl2 = vec![[0u32; 3]; bound + 2];
    let mut out_cur_x2s = vec![[0u32; 3]; bound + 1];
    let mut out_cur_x2 = vec![[0u32; 3]; bound + 1];
    let mut out_pair_x2s = vec![[0u32; 3]; bound + 1];

    let mut tris_g = [
        vec![[0u32; 3]; bound],
        vec![[0u32; 3]; bound],
        vec![[0u32; 3]; bound],
    ];
    let mut lin = vec![VertexRecord::default(); records_len(w, h, RecordLayout::Linear)];
    let mut itl = vec![VertexRecord::default(); records_len(w, h, RecordLayout::Interleaved)];
    let lin_h = pack_records(&full, &hf, RecordLayout::Linear, &mut lin).unwrap();
    let itl_h = pack_records(&full, &hf, RecordLayout::Interleaved, &mut itl).unwrap();
    let pack = |x: u32, y: u32| x | (y << 16);
    let roots = [
        Tri {
            l: pack(side, side),
            r: pack(0, 0),
            a: pack(side, 0),
            planes: 0b01_1111,
        },
        Tri {
            l: pack(0, 0),
            r: pack(side, side),
            a: pack(0, side),
            planes: 0b01_1111,
        },
    ];
    look_bounds(&mut rec, w, 2 * side.trailing_zeros(), roots);
    if let Some(step) = std::env::var("MOVE")
        .ok()
        .and_then(|s| s.parse::<f32>().ok())
    {
        let lib = lin_h.records().unwrap().0;
        moving(&dem, &hf, &full, &lin_h, lib, &rec, roots, step, runs);
        return;
    }
    let (lvl, lvl_tab) = by_level(lin_h.records().unwrap().0, side);
    for tau in [0.5f32, 1.0, 4.0] {
        let f = Frame {
            rec: &rec,
            lib: lin_h.records().unwrap().0,
            lvl: &lvl,
            lvl_tab: &lvl_tab,
            v: common::LeanView::new(&dem, &cam, tau, planes),
        };
        // Same triangles as the depth-first walk (as a multiset).
        let mut reference = Vec::new();
        for t in roots {
            f.dfs(&mut reference, t, 0);
        }
        let reference_in_order = reference.clone();
        let nt = f.bfs(roots, &mut la, &mut lb, &mut out);
        let mut got = out[..nt].to_vec();
        reference.sort_unstable();
        got.sort_unstable();
        assert_eq!(
            got, reference,
            "level-by-level and depth-first triangles differ"
        );
        let crit = Criterion::View(View::new(&cam, tau).unwrap());
        let r = Refiner::new(&full, &hf, crit).unwrap();
        let rl = Refiner::new(&lin_h, &hf, crit).unwrap();
        let ri = Refiner::new(&itl_h, &hf, crit).unwrap();
        // The library's grid-index list: the depth-first walk's triangles, in its order.
        let ng = r.grid_triangles(&mut out2).unwrap();
        assert_eq!(
            &out2[..ng],
            &reference_in_order[..],
            "grid_triangles differs"
        );
        let ns = f.dfs_stack::<OWN_F32>(roots, &mut out);
        let mut got = out[..ns].to_vec();
        // The lookahead writes the same triangles in the same order.
        let nl = f.dfs_stack::<OWN_LOOK>(roots, &mut out2);
        assert_eq!(&out2[..nl], &got[..], "the lookahead changed the triangles");
        let np = f.dfs_pair::<OWN_F32>(roots, &mut out2);
        assert_eq!(&out2[..np], &got[..], "the pair walk changed the triangles");
        let n64 = f.dfs_stack::<OWN_F64>(roots, &mut out2);
        let f64_ref = out2[..n64].to_vec();
        let np64 = f.dfs_pair::<OWN_F64>(roots, &mut out2);
        assert_eq!(
            &out2[..np64],
            &f64_ref[..],
            "the pair walk changed the triangles"
        );
        let nl1 = f.dfs_stack::<LIB>(roots, &mut out2);
        let lib_ref = out2[..nl1].to_vec();
        // In `f64` on the library's records the yardstick decides as the library does.
        let nl64 = f.dfs_pair::<LIB_F64>(roots, &mut out2);
        let nlg = rl.grid_triangles(&mut out_lib).unwrap();

        assert_eq!(
            &out2[..nl64],
            &out_lib[..nlg],
            "pair f64 differs from grid_triangles"
        );
        for n in [
            f.dfs_cur::<LIB_F64>(roots, &mut out2),
            f.dfs_cur::<LVL_F64>(roots, &mut out2),
            f.dfs_leaves::<false>(roots, &mut out2),
            f.dfs_leaves::<true>(roots, &mut out2),
            f.dfs_p::<false, false>(roots, &mut out2),
            f.dfs_p::<true, false>(roots, &mut out2),
            f.dfs_bl::<true, false>(roots, &mut out2),
            f.dfs_bl::<true, true>(roots, &mut out2),
            f.dfs_bl::<false, false>(roots, &mut out2),
            f.dfs_bl::<false, true>(roots, &mut out2),
            f.dfs_cur::<LIB_F64_X2S>(roots, &mut out2),
            f.dfs_cur::<LIB_F64_X2>(roots, &mut out2),
            f.dfs_pair::<LIB_F64_PF>(roots, &mut out2),
            f.dfs_pair::<LIB_F64_X2>(roots, &mut out2),
            f.dfs_pair::<LIB_F64_X2S>(roots, &mut out2),
        ] {
            assert_eq!(
                &out2[..n],
                &out_lib[..nlg],
                "pair x2 f64 differs from grid_triangles"
            );
        }
        PATHS.with(|p| p.iter().for_each(|c| c.set(0)));
        f.dfs_p::<false, true>(roots, &mut out2);
        let paths = PATHS.with(|p| [p[0].get(), p[1].get()]);
        let nl2 = f.dfs_pair::<LIB>(roots, &mut out2);
        assert_eq!(
            &out2[..nl2],
            &lib_ref[..],
            "the pair walk changed the triangles"
        );
        got.sort_unstable();
        assert_eq!(got, reference, "stack and recursive triangles differ");
        let (r, rl, ri) = (&r, &rl, &ri);
        let (f, sc, vs, ts) = (&f, &mut scratch, &mut verts, &mut tris);
        let (la, lb, out, out2) = (&mut la, &mut lb, &mut out, &mut out2);
        let mut dfs_out = Vec::with_capacity(bound);
        let [g0, g1, g2] = &mut tris_g;
        type Run<'a> = Box<dyn FnMut() -> usize + 'a>;
        let mut variants: Vec<(&str, Run<'_>)> = vec![
            ("level by level", Box::new(|| f.bfs(roots, la, lb, out))),
            (
                "depth first",
                Box::new(|| {
                    dfs_out.clear();
                    for t in roots {
                        f.dfs(&mut dfs_out, t, 0);
                    }
                    black_box(&dfs_out).len()
                }),
            ),
            ("stack", Box::new(|| f.dfs_stack::<OWN_F32>(roots, out2))),
            (
                "stack, lookahead",
                Box::new(|| f.dfs_stack::<OWN_LOOK>(roots, &mut out_look)),
            ),
            (
                "pair, own records",
                Box::new(|| f.dfs_pair::<OWN_F32>(roots, &mut out_pair)),
            ),
            (
                "pair, f64 decisions",
                Box::new(|| f.dfs_pair::<OWN_F64>(roots, &mut out_pair64)),
            ),
            (
                "pair, library records, f64",
                Box::new(|| f.dfs_pair::<LIB_F64>(roots, &mut out_pair_lib64)),
            ),
            (
                "pair, library records",
                Box::new(|| f.dfs_pair::<LIB>(roots, &mut out_pair_lib)),
            ),
            (
                "current, library records, f64",
                Box::new(|| f.dfs_cur::<LIB_F64>(roots, &mut out_cur)),
            ),
            (
                "current, level records, f64",
                Box::new(|| f.dfs_cur::<LVL_F64>(roots, &mut out_cur_lvl)),
            ),
            (
                "current leaves, library records, f64",
                Box::new(|| f.dfs_leaves::<false>(roots, &mut out_lv)),
            ),
            (
                "current leaves straight, library records, f64",
                Box::new(|| f.dfs_leaves::<true>(roots, &mut out_lv2)),
            ),
            (
                "current packed, library records, f64",
                Box::new(|| f.dfs_p::<false, false>(roots, &mut out_p)),
            ),
            (
                "current packed tables, library records, f64",
                Box::new(|| f.dfs_p::<true, false>(roots, &mut out_pt)),
            ),
            (
                "branch-free pairs, library records, f64",
                Box::new(|| f.dfs_bl::<true, false>(roots, &mut out_bp)),
            ),
            (
                "branch-free pairs two-ended, library records, f64",
                Box::new(|| f.dfs_bl::<true, true>(roots, &mut out_bp2)),
            ),
            (
                "branch-free, library records, f64",
                Box::new(|| f.dfs_bl::<false, false>(roots, &mut out_bl)),
            ),
            (
                "branch-free two-ended, library records, f64",
                Box::new(|| f.dfs_bl::<false, true>(roots, &mut out_bl2)),
            ),
            (
                "current x2 straight, library records, f64",
                Box::new(|| f.dfs_cur::<LIB_F64_X2S>(roots, &mut out_cur_x2s)),
            ),
            (
                "current x2 sse2, library records, f64",
                Box::new(|| f.dfs_cur::<LIB_F64_X2>(roots, &mut out_cur_x2)),
            ),
            (
                "pair prefetch, library records, f64",
                Box::new(|| f.dfs_pair::<LIB_F64_PF>(roots, &mut out_pair_pf)),
            ),
            (
                "pair x2 sse2, library records, f64",
                Box::new(|| f.dfs_pair::<LIB_F64_X2>(roots, &mut out_pair_x2)),
            ),
            (
                "pair x2 straight, library records, f64",
                Box::new(|| f.dfs_pair::<LIB_F64_X2S>(roots, &mut out_pair_x2s)),
            ),
            (
                "stack, f64 decisions",
                Box::new(|| f.dfs_stack::<OWN_F64>(roots, &mut out64)),
            ),
            (
                "stack, library records",
                Box::new(|| f.dfs_stack::<LIB>(roots, &mut out_lib)),
            ),
            (
                "grid_triangles, full",
                Box::new(|| r.grid_triangles(g0).unwrap()),
            ),
            (
                "grid_triangles, linear records",
                Box::new(|| rl.grid_triangles(g1).unwrap()),
            ),
            (
                "grid_triangles, interleaved records",
                Box::new(|| ri.grid_triangles(g2).unwrap()),
            ),
            (
                "triangles, full",
                Box::new(|| r.triangles(sc, vs, ts).unwrap().triangles),
            ),
        ];
        // `ONLY=text`: just the variants whose name contains it (for instruction counts).
        if let Ok(only) = std::env::var("ONLY") {
            variants.retain(|(name, _)| name.contains(only.as_str()));
        }
        // Cold: the variants take turns, so each run starts after the others have filled the
        // caches with their own data (as one refinement per frame between other work would).
        // Warm: `runs` runs of one variant in a row.
        let k = variants.len();
        let (mut cold, mut warm, mut count) =
            (vec![f64::INFINITY; k], vec![f64::INFINITY; k], vec![0; k]);
        for _ in 0..runs {
            for (i, (_, run)) in variants.iter_mut().enumerate() {
                let s = Instant::now();
                count[i] = black_box(run());
                cold[i] = cold[i].min(s.elapsed().as_secs_f64() * 1e3);
            }
        }
        for (i, (_, run)) in variants.iter_mut().enumerate() {
            for _ in 0..runs {
                let s = Instant::now();
                black_box(run());
                warm[i] = warm[i].min(s.elapsed().as_secs_f64() * 1e3);
            }
        }
        println!(
            "tau={tau} px ({nt} triangles; decisions without / with planes to test: {} / {})",
            paths[0], paths[1]
        );
        for (i, (name, _)) in variants.iter().enumerate() {
            println!(
                "  {name:<36} {:>7} tris  cold {:7.3} ms {:6.1} M/s  warm {:7.3} ms {:6.1} M/s",
                count[i],
                cold[i],
                count[i] as f64 / cold[i] / 1e3,
                warm[i],
                count[i] as f64 / warm[i] / 1e3
            );
        }
    }
}

/// `MOVE=step`: the pair x2 sse2 yardstick and `grid_triangles` (linear records), each timed
/// warm on one frame (`runs` runs in a row, as above) and on two frames taken in turn, the
/// second with the eye moved `step` metres along the view (a camera in flight). A walk whose
/// branches the predictor has learnt for one frame runs faster on that frame repeated than on
/// frames that differ; the gap between the two readings is that learning.
#[allow(clippy::too_many_arguments)]
fn moving(
    dem: &relief_io::Dem,
    hf: &Heightfield<'_, f32>,
    full: &relief_core::refine::Hierarchy<'_>,
    lin_h: &relief_core::refine::Hierarchy<'_>,
    lib: &[VertexRecord],
    rec: &[[f32; 4]],
    roots: [Tri; 2],
    step: f32,
    runs: usize,
) {
    let bound = triangle_bound(dem.width, dem.height);
    let mut out = vec![[0u32; 3]; bound + 1];
    let cams = [camera(BENCH_EYE_X), camera(BENCH_EYE_X - step)];
    for tau in [0.5f32, 1.0, 4.0] {
        let frames: Vec<Frame<'_>> = cams
            .iter()
            .map(|c| Frame {
                rec,
                lib,
                lvl: &[],
                lvl_tab: &[],
                v: common::LeanView::new(dem, c, tau, common::lean_inputs(hf, full, c).planes),
            })
            .collect();
        let refiners: Vec<Refiner<'_, '_, _>> = cams
            .iter()
            .map(|c| Refiner::new(lin_h, hf, Criterion::View(View::new(c, tau).unwrap())).unwrap())
            .collect();
        for (f, r) in frames.iter().zip(&refiners) {
            let n = f.dfs_pair::<LIB_F64_X2>(roots, &mut out);
            let want = out[..n].to_vec();
            let m = r.grid_triangles(&mut out).unwrap();
            assert_eq!(
                &out[..m],
                &want[..],
                "pair x2 sse2 differs from grid_triangles"
            );
        }
        let mut line = format!("tau={tau} px, eye moved {step} m:");
        for (name, lib_walk) in [("pair x2 sse2", false), ("grid_triangles, linear", true)] {
            let run = |k: usize, out: &mut [[u32; 3]]| {
                if lib_walk {
                    refiners[k].grid_triangles(out).unwrap()
                } else {
                    frames[k].dfs_pair::<LIB_F64_X2>(roots, out)
                }
            };
            // M triangles/s, fastest run: frame 0 alone, then frames 0 and 1 in turn.
            let mut one = 0.0f64;
            for _ in 0..runs {
                let s = Instant::now();
                let n = black_box(run(0, &mut out));
                one = one.max(n as f64 / s.elapsed().as_secs_f64() / 1e6);
            }
            let mut turns = 0.0f64;
            for i in 0..2 * runs {
                let s = Instant::now();
                let n = black_box(run(i & 1, &mut out));
                turns = turns.max(n as f64 / s.elapsed().as_secs_f64() / 1e6);
            }
            line += &format!("  {name}: one frame {one:.1}, two in turn {turns:.1} M/s");
        }
        println!("{line}");
    }
}
