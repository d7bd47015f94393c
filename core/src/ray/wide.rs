//! Maximum-mipmap traversal (Tevs, Ihrke, Seidel, *Maximum Mipmaps for Fast, Accurate, and
//! Scalable Dynamic Height Field Rendering*, I3D 2008) one ray at a time through sixteen-wide
//! nodes, the single-ray form of wide hierarchies (Wald, Benthin, Boulos, *Getting Rid of
//! Packets: Efficient SIMD Single-Ray Traversal using Multi-branching BVHs*, IEEE RT 2008; the
//! form Embree's single-ray kernels take).
//!
//! The pyramid ([`MaxMip`]) stores each level in 4 x 4 tiles, so the sixteen nodes two levels
//! below node `(x, y)` of level `k` are tile `(x, y)` of level `k - 2`: one 64-byte line. Taken
//! two levels at a time the pyramid is a 16-ary tree whose leaves are the cells. A node tests its
//! sixteen children at once in two AVX-512 registers of `f64` lanes, with the operations of the
//! neighbour walk's step (`mip_step` in `maxmip.rs`) in the same order: each child's slab
//! parameters, its interval `[ta, tb]` clipped to the ray's, and its maximum against the ray's
//! lowest point over that interval. So a child is entered when the neighbour walk would descend
//! into it, and a cell is tested over the same interval, except for children the ray only
//! touches at one point (`ta == tb`), which are not entered. The neighbour walk tests two kinds
//! of those: the cell under a start that lies on a cell boundary (whose one-point test
//! `start_hit` has already made before either walk begins) and a cell entered exactly at the
//! ray's clipped end. So the cells tested are the same or fewer, and the hits are those of
//! [`RayTracer::trace_maxmip`] (bit for bit on every ray of the tests and the `rays` fuzz
//! target). The lanes hold the children in the order the ray crosses them
//! (a ray's path through a 4 x 4 block is a monotone staircase, one child per anti-diagonal
//! counted from the corner it enters by), so the next child is the lowest set bit of the
//! node's mask; a node with children left waits on a stack of at most one node per level pair,
//! and the first cell hit ends the ray.

use super::cell::{CellHit, LocalRay};
use super::maxmip::MaxMip;
use super::{Hit, Ray, RayTracer, Trace};
use crate::{Error, Terrain};
use bytemuck::cast;
use core::arch::x86_64::*;

/// The children's `(column, row)` in a 4 x 4 block, in lane order, for a ray whose x and y
/// directions are negative (`fx`, `fy`) or not: by anti-diagonal from the corner the ray
/// enters by, rows in order within one.
const fn order(fx: bool, fy: bool) -> [[u32; 2]; 16] {
    let mut out = [[0u32; 2]; 16];
    let mut n = 0;
    let mut k = 0;
    while k < 7 {
        let mut r = 0;
        while r < 4 {
            if k >= r && k - r < 4 {
                let (c, rr) = ((k - r) as u32, r as u32);
                out[n] = [if fx { 3 - c } else { c }, if fy { 3 - rr } else { rr }];
                n += 1;
            }
            r += 1;
        }
        k += 1;
    }
    out
}

/// The lanes of one direction octant: [`order`], and the same as `f64` lane values (two
/// halves) and as tile elements (`row * 4 + column`, for the permute of the maxima).
struct Lanes {
    xy: [[u32; 2]; 16],
    cx: [[f64; 8]; 2],
    cy: [[f64; 8]; 2],
    perm: [i32; 16],
}

const fn lanes(fx: bool, fy: bool) -> Lanes {
    let xy = order(fx, fy);
    let mut l = Lanes {
        xy,
        cx: [[0.0; 8]; 2],
        cy: [[0.0; 8]; 2],
        perm: [0; 16],
    };
    let mut j = 0;
    while j < 16 {
        l.cx[j / 8][j % 8] = xy[j][0] as f64;
        l.cy[j / 8][j % 8] = xy[j][1] as f64;
        l.perm[j] = (xy[j][1] * 4 + xy[j][0]) as i32;
        j += 1;
    }
    l
}

/// [`lanes`] for the four direction octants, indexed `fx | fy << 1`.
static LANES: [Lanes; 4] = [
    lanes(false, false),
    lanes(true, false),
    lanes(false, true),
    lanes(true, true),
];

/// Per-ray constants of one horizontal axis.
struct Axis {
    /// The children's positions along the axis (in nodes of their level) in lane order, two
    /// halves.
    c: [__m512d; 2],
    /// Origin and inverse direction component.
    o: __m512d,
    inv: __m512d,
    /// Cells along the axis.
    n: __m512d,
    /// Direction component positive (all lanes alike), or zero.
    pos: __mmask8,
    zero: bool,
}

impl Axis {
    /// For the children in half `h` of a block starting at `base` with nodes of size `s`:
    /// the lanes whose node lies inside the grid and, when the ray does not move along this
    /// axis, holds it (the node the neighbour walk's `floor` picks, the last one for `o == n`),
    /// and the slab parameters (`slab_signed` of `maxmip.rs`; `-inf, inf` for a zero
    /// component).
    #[target_feature(enable = "avx512f")]
    #[inline]
    fn span(&self, h: usize, base: __m512d, s: __m512d) -> (__mmask8, __m512d, __m512d) {
        let lo = _mm512_add_pd(base, _mm512_mul_pd(self.c[h & 1], s));
        let hi = _mm512_min_pd(_mm512_add_pd(lo, s), self.n);
        // The tile's padding past the grid is never read as a node.
        let live = _mm512_cmp_pd_mask::<_CMP_LT_OQ>(lo, self.n);
        if self.zero {
            let o = self.o;
            let inside = _mm512_cmp_pd_mask::<_CMP_LT_OQ>(o, _mm512_add_pd(lo, s))
                | (_mm512_cmp_pd_mask::<_CMP_GE_OQ>(o, self.n)
                    & _mm512_cmp_pd_mask::<_CMP_GE_OQ>(hi, self.n));
            let on = _mm512_cmp_pd_mask::<_CMP_LE_OQ>(lo, o) & inside;
            return (
                live & on,
                _mm512_set1_pd(f64::NEG_INFINITY),
                _mm512_set1_pd(f64::INFINITY),
            );
        }
        let a = _mm512_mul_pd(_mm512_sub_pd(lo, self.o), self.inv);
        let b = _mm512_mul_pd(_mm512_sub_pd(hi, self.o), self.inv);
        (
            live,
            _mm512_mask_blend_pd(self.pos, b, a),
            _mm512_mask_blend_pd(self.pos, a, b),
        )
    }
}

/// Per-ray constants of the walk.
struct Consts {
    x: Axis,
    y: Axis,
    /// Lane `j` reads element `row * 4 + column` of the tile.
    perm: __m512i,
    oz: __m512d,
    dz: __m512d,
    /// The ray descends (`dz < 0`).
    down: bool,
    t0: __m512d,
    t1: __m512d,
}

/// A node: the level of its children, its index on its own level, and the children left.
#[derive(Clone, Copy)]
struct Node {
    child: u32,
    ix: u32,
    iy: u32,
    mask: u32,
}

impl<T: Terrain> RayTracer<'_, T> {
    /// [`RayTracer::trace_maxmip`] through sixteen-wide nodes, the sixteen children of a node
    /// tested in AVX-512 lanes (x86-64 only; see `ray/wide.rs`): the same hits, the same cells
    /// tested or fewer (cells the ray only touches at a point are skipped), in fewer and wider
    /// steps. [`Trace::steps`] counts the nodes whose children
    /// were tested. Safe to call only where the CPU has AVX-512F (check with
    /// `is_x86_feature_detected!` on the std side). [`Error::LengthMismatch`] if `mip` belongs
    /// to another grid size.
    ///
    /// # Safety
    ///
    /// The CPU must support AVX-512F (a `#[target_feature]` function: calling it elsewhere is
    /// undefined behaviour). The function itself uses no `unsafe`.
    ///
    /// ```
    /// # #[cfg(target_arch = "x86_64")] {
    /// use relief_core::ray::{MaxMip, Ray, RayTracer};
    /// use relief_core::{Heightfield, Surface};
    /// use glam::Vec3;
    /// let s: Vec<f32> = (0..81 * 81).map(|i| ((i * 37) % 11) as f32).collect();
    /// let hf = Heightfield::new(&s, 81, 81).unwrap();
    /// let mut buf = vec![0.0; MaxMip::len(81, 81).unwrap()];
    /// let mip = MaxMip::build(&hf, &mut buf).unwrap();
    /// let t = RayTracer::new(&hf, Surface::Triangles);
    /// let ray = Ray::new(Vec3::new(-3.0, 2.5, 14.0), Vec3::new(1.0, 0.7, -0.2)).unwrap();
    /// if std::is_x86_feature_detected!("avx512f") {
    ///     // SAFETY: the CPU has AVX-512F.
    ///     let wide = unsafe { t.trace_maxmip_wide_avx512(&ray, &mip) }.unwrap();
    ///     let neighbour = t.trace_maxmip(&ray, &mip).unwrap();
    ///     assert_eq!(wide.hit, neighbour.hit);
    ///     assert!(wide.cells <= neighbour.cells && wide.steps < neighbour.steps);
    /// }
    /// # }
    /// ```
    // Not under `cfg(doctest)`, as `trace_maxmip_packet_avx512` (rust-lang/rust#49864).
    #[cfg_attr(not(doctest), target_feature(enable = "avx512f"))]
    pub fn trace_maxmip_wide_avx512(&self, ray: &Ray, mip: &MaxMip<'_>) -> Result<Trace, Error> {
        self.check_mip(mip)?;
        let mut out = Trace::default();
        self.wide_walk(ray, mip, &mut out);
        Ok(out)
    }

    #[target_feature(enable = "avx512f")]
    fn wide_walk(&self, ray: &Ray, mip: &MaxMip<'_>, out: &mut Trace) {
        let top = mip.levels - 1;
        // The root: the top node, or one past it when the top level is odd (its children,
        // the tile of the level below the top, hold at most 2 x 2 nodes).
        let root = top + (top & 1);
        if root < 2 {
            // A single cell: no node to take.
            self.mip_walk(ray, mip, out);
            return;
        }
        let Some(lr) = self.mip_clip(ray, out) else {
            return;
        };
        let oct = usize::from(lr.d.x < 0.0) | usize::from(lr.d.y < 0.0) << 1;
        let ln = &LANES[oct & 3];
        let ord = &ln.xy;
        let axis = |c: &[[f64; 8]; 2], o: f64, d: f64, inv: f64, n: u32| Axis {
            c: [cast(c[0]), cast(c[1])],
            o: _mm512_set1_pd(o),
            inv: _mm512_set1_pd(inv),
            n: _mm512_set1_pd(n as f64),
            pos: if d > 0.0 { 0xff } else { 0 },
            zero: d == 0.0,
        };
        let c = Consts {
            x: axis(&ln.cx, lr.o.x, lr.d.x, lr.inv[0], mip.nx),
            y: axis(&ln.cy, lr.o.y, lr.d.y, lr.inv[1], mip.ny),
            perm: cast(ln.perm),
            oz: _mm512_set1_pd(lr.o.z),
            dz: _mm512_set1_pd(lr.d.z),
            down: lr.d.z < 0.0,
            t0: _mm512_set1_pd(lr.t0),
            t1: _mm512_set1_pd(lr.t1),
        };
        let (mask, mut ta, mut tb) = self.wide_node(mip, &c, root - 2, 0, 0);
        let mut cur = Node {
            child: root - 2,
            ix: 0,
            iy: 0,
            mask,
        };
        let mut nodes = 1u64;
        // Nodes with children left below `cur`: at most one per level pair.
        let mut stack = [cur; 17];
        let mut sp = 0usize;
        // Bounded: each pass takes one child the ray's segment crosses, at most
        // `mip.step_bound()` over all levels (a line crosses at most `w + h + 1` nodes of a
        // `w x h` level), and a node is only pushed with a child left.
        let mut passes = 0u64;
        while passes < mip.bound {
            passes += 1;
            if cur.mask == 0 {
                if sp == 0 {
                    break;
                }
                sp -= 1;
                let Some(&n) = stack.get(sp) else {
                    break;
                };
                cur = n;
            }
            let j = (cur.mask.trailing_zeros() & 15) as usize;
            cur.mask &= cur.mask - 1;
            let [kx, ky] = ord[j];
            let (gx, gy) = (4 * cur.ix + kx, 4 * cur.iy + ky);
            if cur.child == 0 {
                out.cells += 1;
                let (tas, tbs): ([f64; 8], [f64; 8]) = (cast(ta[j >> 3]), cast(tb[j >> 3]));
                if let Some(h) = self.wide_cell(&lr, gx, gy, tas[j & 7], tbs[j & 7]) {
                    out.hit = Some(self.wide_hit(ray, gx, gy, h));
                    break;
                }
                continue;
            }
            let (mask, nta, ntb) = self.wide_node(mip, &c, cur.child - 2, gx, gy);
            nodes += 1;
            if mask != 0 {
                if cur.mask != 0 {
                    if let Some(e) = stack.get_mut(sp) {
                        *e = cur;
                        sp += 1;
                    }
                }
                cur = Node {
                    child: cur.child - 2,
                    ix: gx,
                    iy: gy,
                    mask,
                };
                (ta, tb) = (nta, ntb);
            }
        }
        out.steps = u32::try_from(nodes).unwrap_or(u32::MAX);
    }

    /// The sixteen children (on level `child`) of node `(ix, iy)` two levels up: the mask of
    /// those the ray crosses and the neighbour walk would enter (lane order), and their
    /// intervals.
    #[target_feature(enable = "avx512f")]
    #[inline]
    fn wide_node(
        &self,
        mip: &MaxMip<'_>,
        c: &Consts,
        child: u32,
        ix: u32,
        iy: u32,
    ) -> (u32, [__m512d; 2], [__m512d; 2]) {
        let l = mip.level(child);
        // Node sizes and block corners are integers below 2^53: exact in `f64`, as the
        // neighbour walk's `ix * s` converted.
        let s = (1u64 << (child & 63)) as f64;
        let sv = _mm512_set1_pd(s);
        let (bx, by) = (
            _mm512_set1_pd(((4 * ix as u64) << (child & 63)) as f64),
            _mm512_set1_pd(((4 * iy as u64) << (child & 63)) as f64),
        );
        let idx = l.off + (((iy as usize) * l.tx as usize + ix as usize) << 4);
        let mut tile = [f32::NEG_INFINITY; 16];
        if let Some(src) = mip.data.get(idx..idx + 16) {
            tile.copy_from_slice(src);
        }
        let m = _mm512_permutexvar_ps(c.perm, cast(tile));
        let mx: [__m512d; 2] = [
            _mm512_cvtps_pd(_mm512_castps512_ps256(m)),
            _mm512_cvtps_pd(_mm256_castpd_ps(_mm512_extractf64x4_pd::<1>(
                _mm512_castps_pd(m),
            ))),
        ];
        let mut mask = 0u32;
        let mut ta = [_mm512_setzero_pd(); 2];
        let mut tb = [_mm512_setzero_pd(); 2];
        for h in 0..2 {
            let (live_x, ax, ex) = c.x.span(h, bx, sv);
            let (live_y, ay, ey) = c.y.span(h, by, sv);
            let live = live_x & live_y;
            let a = _mm512_max_pd(_mm512_max_pd(c.t0, ax), ay);
            let b = _mm512_min_pd(_mm512_min_pd(c.t1, ex), ey);
            // The ray's lowest point over the interval: `min(z(a), z(b))` of the neighbour
            // walk, which is `z(b)` for a descending ray and `z(a)` otherwise (rounding is
            // monotone, so the same value).
            let zmin = _mm512_add_pd(c.oz, _mm512_mul_pd(if c.down { b } else { a }, c.dz));
            let enter = live
                // `<`: a child the ray only touches (an exact corner crossing, a start or
                // end on its boundary) is not entered; see the function's documentation.
                & _mm512_cmp_pd_mask::<_CMP_LT_OQ>(a, b)
                & _mm512_cmp_pd_mask::<_CMP_LE_OQ>(zmin, mx[h]);
            mask |= u32::from(enter) << (8 * h);
            ta[h] = a;
            tb[h] = b;
        }
        (mask, ta, tb)
    }

    /// The exact test of cell `(cx, cy)` over `[ta, tb]`, out of line: the surfaces' tests may
    /// call `libm`'s square root (legacy SSE), which must not run inside the AVX-512 function
    /// with its upper register state dirty (`ray/simd.rs` met that cost; a call is preceded by
    /// `vzeroupper`).
    #[inline(never)]
    fn wide_cell(&self, lr: &LocalRay, cx: u32, cy: u32, ta: f64, tb: f64) -> Option<CellHit> {
        super::cell::intersect(self.surface, lr, cx, cy, &self.corners(cx, cy), ta, tb)
    }

    /// [`RayTracer::make_hit`] out of line, for the reason of [`RayTracer::wide_cell`].
    #[inline(never)]
    fn wide_hit(&self, ray: &Ray, cx: u32, cy: u32, h: CellHit) -> Hit {
        self.make_hit(ray, cx, cy, h)
    }
}
