//! The sixteen-wide walk's node test in AVX2 (see `ray/wide.rs`). A child's x slab depends on
//! its column only and its y slab on its row only, so the four columns' slabs take one register
//! of four lanes, the four rows' another, and the block is then tested a row or two at a time
//! (lane `k` is column `k`, the tile's own order); the mask goes into crossing order by the
//! portable node's table.
//!
//! Two tests, chosen per ray:
//! - **`f32`, conservative** (`Fast`), where the ray's values allow it (grids up to 2^16 cells a
//!   side, both horizontal direction components non-zero, magnitudes in range: `Fast::new`):
//!   eight children a register, the tile's maxima compared as they are stored. The ray is
//!   re-based at its clipped start (`t' = t - t0`, start `o + t0 d`), and every slab parameter
//!   is widened by a margin `2^-19 ((n + |o'|) |1/d| + |t0| 2^-28)`, the segment's end by a
//!   factor `1 + 2^-19` and the start's height lowered by `2^-19 (|z'| + |dz| t1' + 2 |t0 dz|)`:
//!   at least 32 times the rounding error of the `f32` operations (four roundings of
//!   `2^-24` relative each, on values bounded by those terms) plus the `f64` test's own, so the
//!   widened interval holds the exact test's interval and its lowest point lies at or below
//!   the exact one. Each margin and the segment's end get an absolute floor of `2^-119`, above
//!   what an `f32` underflow loses (a segment of 1e-49 at the grid's edge, found by the `rays`
//!   fuzz target, rounded to an empty one). Every child the exact (`f64`) test enters is
//!   entered; a few more may be (a ray passing within a quarter of a cell of a node: 0.01-0.04%
//!   more steps on the views of `bench-peers/maxmip_ab.py`). A cell is tested only after its
//!   lane's exact test (`RayTracer::wide_step`), and a node the exact test rejects holds no
//!   cell the exact test accepts (the intervals and heights are monotone), so the cells tested
//!   and the hits are those of the exact forms; `Trace::steps` may be larger. Embree's robust
//!   traversal widens its `f32` boxes in the same spirit.
//! - **`f64`, exact** (`Exact`) otherwise: the operations of the portable node (and of the
//!   neighbour walk's step) in the same order, so the traces are the portable form's.
//!
//! The margins are checked against the exact forms on adversarial rays by
//! `tests/tests/rays_packet.rs::wide_avx2_f32_node_test_misses_no_cell` (which fails with the
//! margins at 0) and by the `rays` fuzz target.

use super::{block, tile, CROSSING};
use crate::ray::cell::LocalRay;
use crate::ray::maxmip::MaxMip;
use crate::ray::{Ray, RayTracer, Trace};
use crate::{Error, Terrain};
use bytemuck::cast;
use core::arch::x86_64::*;

/// Per-ray constants of one horizontal axis.
struct Axis {
    /// Origin, inverse direction component, cells along the axis.
    o: __m256d,
    inv: __m256d,
    n: __m256d,
    /// All lanes set when the direction component is positive: the slab's entry is then its
    /// low side.
    pos: __m256d,
    /// The direction component is zero.
    zero: bool,
}

impl Axis {
    #[target_feature(enable = "avx2")]
    #[inline]
    fn new(o: f64, d: f64, inv: f64, n: u32) -> Axis {
        Axis {
            o: _mm256_set1_pd(o),
            inv: _mm256_set1_pd(inv),
            n: _mm256_set1_pd(f64::from(n)),
            pos: _mm256_castsi256_pd(_mm256_set1_epi64x(-i64::from(d > 0.0))),
            zero: d == 0.0,
        }
    }

    /// The portable `Axis::span` for the four children at positions `0, 1, 2, 3` (lanes) of a
    /// block starting at `base` with nodes of size `s`: the bits of the positions whose node
    /// lies inside the grid (and holds the ray, for a zero component), and the slab parameters.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn span(&self, base: __m256d, s: __m256d) -> (u32, __m256d, __m256d) {
        let lo = _mm256_add_pd(base, _mm256_mul_pd(_mm256_set_pd(3.0, 2.0, 1.0, 0.0), s));
        let hi = _mm256_min_pd(_mm256_add_pd(lo, s), self.n);
        // The tile's padding past the grid is never read as a node.
        let live = _mm256_cmp_pd::<_CMP_LT_OQ>(lo, self.n);
        if self.zero {
            let o = self.o;
            let inside = _mm256_or_pd(
                _mm256_cmp_pd::<_CMP_LT_OQ>(o, _mm256_add_pd(lo, s)),
                _mm256_and_pd(
                    _mm256_cmp_pd::<_CMP_GE_OQ>(o, self.n),
                    _mm256_cmp_pd::<_CMP_GE_OQ>(hi, self.n),
                ),
            );
            let on = _mm256_and_pd(_mm256_cmp_pd::<_CMP_LE_OQ>(lo, o), inside);
            return (
                _mm256_movemask_pd(_mm256_and_pd(live, on)) as u32,
                _mm256_set1_pd(f64::NEG_INFINITY),
                _mm256_set1_pd(f64::INFINITY),
            );
        }
        let a = _mm256_mul_pd(_mm256_sub_pd(lo, self.o), self.inv);
        let b = _mm256_mul_pd(_mm256_sub_pd(hi, self.o), self.inv);
        (
            _mm256_movemask_pd(live) as u32,
            _mm256_blendv_pd(b, a, self.pos),
            _mm256_blendv_pd(a, b, self.pos),
        )
    }
}

/// Per-ray constants of the exact (`f64`) node test.
struct Exact {
    x: Axis,
    y: Axis,
    oz: __m256d,
    dz: __m256d,
    /// All lanes set when the ray descends (`dz < 0`), so that `zmin` takes `b`.
    down: __m256d,
    t0: __m256d,
    t1: __m256d,
    /// [`CROSSING`] of the ray's octant.
    cross: &'static [[u16; 256]; 2],
}

/// The relative margin of the `f32` test: `2^-19`, 32 times the `f32` rounding unit.
const MARGIN: f64 = 1.0 / (1u32 << 19) as f64;
/// The `f32` test's range: a ray whose values (or products of them) leave
/// `[2^-100, 2^100]` takes the exact test, so no `f32` operation overflows or loses relative
/// precision to an underflow beyond the margins' absolute floor [`FLOOR`].
const RANGE: f64 = 1.2676506002282294e30; // 2^100
/// The margins' absolute floor, `2^-119`: above `f32` underflows (at most `2^-149`), and
/// normal in `f32`.
const FLOOR: f64 = 1.0 / (RANGE * 524288.0);

/// Per-ray constants of one horizontal axis for the `f32` test, the ray re-based at its start.
struct FastAxis {
    /// The start's coordinate, the inverse direction component, cells along the axis, all
    /// lanes set when the component is positive, and the slab parameters' margin.
    o: __m128,
    inv: __m128,
    n: __m128,
    pos: __m128,
    eps: __m128,
}

impl FastAxis {
    /// The axis of a ray starting at `o` (re-based) with direction component `d`, inverse
    /// `inv`, on a grid of `n` cells, with slab margin `eps` (checked by [`Fast::new`]).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn new(o: f64, d: f64, inv: f64, n: u32, eps: f64) -> FastAxis {
        FastAxis {
            o: _mm_set1_ps(o as f32),
            inv: _mm_set1_ps(inv as f32),
            n: _mm_set1_ps(n as f32),
            pos: _mm_castsi128_ps(_mm_set1_epi32(-i32::from(d > 0.0))),
            eps: _mm_set1_ps(eps as f32),
        }
    }

    /// For the four children at positions `0, 1, 2, 3` (lanes) of a block starting at `base`
    /// with nodes of size `s`: the bits of the positions whose node lies inside the grid, and
    /// the slab parameters, widened by the margin.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn span(&self, base: __m128, s: __m128) -> (u32, __m128, __m128) {
        let lo = _mm_add_ps(base, _mm_mul_ps(_mm_set_ps(3.0, 2.0, 1.0, 0.0), s));
        let hi = _mm_min_ps(_mm_add_ps(lo, s), self.n);
        // The tile's padding past the grid is never read as a node.
        let live = _mm_cmplt_ps(lo, self.n);
        let a = _mm_mul_ps(_mm_sub_ps(lo, self.o), self.inv);
        let b = _mm_mul_ps(_mm_sub_ps(hi, self.o), self.inv);
        (
            _mm_movemask_ps(live) as u32,
            _mm_sub_ps(_mm_blendv_ps(b, a, self.pos), self.eps),
            _mm_add_ps(_mm_blendv_ps(a, b, self.pos), self.eps),
        )
    }
}

/// Per-ray constants of the conservative `f32` node test.
struct Fast {
    x: FastAxis,
    y: FastAxis,
    /// The start's height less the height margin, and the vertical direction component.
    oz: __m256,
    dz: __m256,
    /// All lanes set when the ray descends.
    down: __m256,
    /// The segment's end `t1 - t0`, rounded up, at least [`FLOOR`].
    t1: __m128,
    /// [`CROSSING`] of the ray's octant.
    cross: &'static [[u16; 256]; 2],
}

impl Fast {
    /// The constants of an idle walk, which no pass reads.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn idle() -> Fast {
        Fast {
            x: FastAxis::new(0.0, 0.0, 0.0, 0, 0.0),
            y: FastAxis::new(0.0, 0.0, 0.0, 0, 0.0),
            oz: _mm256_setzero_ps(),
            dz: _mm256_setzero_ps(),
            down: _mm256_setzero_ps(),
            t1: _mm_setzero_ps(),
            cross: &CROSSING[0],
        }
    }

    /// The `f32` constants of clipped ray `lr` in octant `oct`, or `None` where the ray takes
    /// the exact test (see the module doc).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn new(lr: &LocalRay, oct: usize, mip: &MaxMip<'_>) -> Option<Fast> {
        let t0 = lr.t0;
        let o = lr.o + t0 * lr.d;
        let span = (lr.t1 - t0) * (1.0 + MARGIN);
        let (dz, (nx, ny)) = (lr.d.z, (f64::from(mip.nx), f64::from(mip.ny)));
        let drop = (dz * span).abs();
        let (ix, iy) = (lr.inv[0].abs(), lr.inv[1].abs());
        // The slab parameters' magnitudes, `|lo - o| |inv|` for every boundary `lo` in
        // `[0, n]` (infinite for a zero component, whose inverse is infinite: `n >= 1`).
        let (rx, ry) = ((nx + o.x.abs()) * ix, (ny + o.y.abs()) * iy);
        // The clipped ray's values are finite (`RayTracer::local`), so no term is NaN.
        let big = rx
            .max(ry)
            .max(span)
            .max(drop)
            .max(o.z.abs())
            .max(t0)
            .max(dz.abs());
        let small = ix.min(iy).min(if dz == 0.0 { 1.0 } else { dz.abs() });
        // The start lies in the grid's box (up to rounding): the margins stay below a quarter
        // of a cell on grids up to 2^16 cells a side.
        let far = (o.x.abs() - 2.0 * nx).max(o.y.abs() - 2.0 * ny);
        let ok = big <= RANGE && small >= 1.0 / RANGE && far <= 2.0 && nx.max(ny) <= 65536.0;
        if !ok {
            return None;
        }
        // Slabs: four `f32` roundings of at most 2^-24 relative on terms below `r`, and the
        // exact test's few roundings of 2^-53 on terms below `r + t0`.
        let eps = |r: f64| (r + t0 * (1.0 / 268435456.0)) * MARGIN + FLOOR;
        let ez = (o.z.abs() + drop + 2.0 * (t0 * dz).abs()) * MARGIN + FLOOR;
        Some(Fast {
            x: FastAxis::new(o.x, lr.d.x, lr.inv[0], mip.nx, eps(rx)),
            y: FastAxis::new(o.y, lr.d.y, lr.inv[1], mip.ny, eps(ry)),
            oz: _mm256_set1_ps((o.z - ez) as f32),
            dz: _mm256_set1_ps(dz as f32),
            down: _mm256_castsi256_ps(_mm256_set1_epi32(-i32::from(dz < 0.0))),
            // With the floor: a segment shorter than `f32`'s smallest number (a ray clipped to
            // a point at the grid's edge) must not round to an empty one.
            t1: _mm_set1_ps((span + FLOOR) as f32),
            cross: &CROSSING[oct & 3],
        })
    }
}

impl<T: Terrain> RayTracer<'_, T> {
    /// [`RayTracer::trace_maxmip_wide`] with its node test in AVX2 registers (x86-64 only), in
    /// `f32` with margins where the ray allows it (see `ray/wide/avx2.rs`): the same hits and
    /// the same cells tested, in as many steps or a few more. Safe to call only where the CPU
    /// has AVX2 (check with `is_x86_feature_detected!` on the std side).
    ///
    /// # Safety
    ///
    /// The CPU must support AVX2 (a `#[target_feature]` function: calling it elsewhere is
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
    /// if std::is_x86_feature_detected!("avx2") {
    ///     // SAFETY: the CPU has AVX2.
    ///     let wide = unsafe { t.trace_maxmip_wide_avx2(&ray, &mip) }.unwrap();
    ///     let exact = t.trace_maxmip_wide(&ray, &mip).unwrap();
    ///     assert_eq!((wide.hit, wide.cells), (exact.hit, exact.cells));
    ///     assert!(wide.steps >= exact.steps);
    /// }
    /// # }
    /// ```
    // Not under `cfg(doctest)`, as `trace_maxmip_packet_avx512` (rust-lang/rust#49864).
    #[cfg_attr(not(doctest), target_feature(enable = "avx2"))]
    pub fn trace_maxmip_wide_avx2(&self, ray: &Ray, mip: &MaxMip<'_>) -> Result<Trace, Error> {
        self.check_mip(mip)?;
        let mut out = Trace::default();
        let Some(st) = self.wide_start(ray, mip, &mut out) else {
            return Ok(out);
        };
        match Fast::new(&st.0, st.2, mip) {
            Some(c) => self.wide_loop(ray, mip, &mut out, st, c, |c, child, ix, iy| {
                node_fast(mip, c, child, ix, iy)
            }),
            None => self.wide_alone(ray, mip, &mut out, st),
        }
        Ok(out)
    }

    /// [`RayTracer::trace_maxmip_wide_rays`] with its node test in AVX2 registers (x86-64
    /// only): the traces of [`RayTracer::trace_maxmip_wide_avx2`] ray for ray, two rays' walks
    /// interleaved. Safe to call only where the CPU has AVX2 (check with
    /// `is_x86_feature_detected!` on the std side).
    ///
    /// # Safety
    ///
    /// The CPU must support AVX2 (a `#[target_feature]` function: calling it elsewhere is
    /// undefined behaviour). The function itself uses no `unsafe`.
    ///
    /// ```
    /// # #[cfg(target_arch = "x86_64")] {
    /// use relief_core::ray::{MaxMip, Ray, RayTracer, Trace};
    /// use relief_core::{Heightfield, Surface};
    /// use glam::Vec3;
    /// let s: Vec<f32> = (0..81 * 81).map(|i| ((i * 37) % 11) as f32).collect();
    /// let hf = Heightfield::new(&s, 81, 81).unwrap();
    /// let mut buf = vec![0.0; MaxMip::len(81, 81).unwrap()];
    /// let mip = MaxMip::build(&hf, &mut buf).unwrap();
    /// let t = RayTracer::new(&hf, Surface::Triangles);
    /// let rays: Vec<Ray> = (0..20)
    ///     .map(|i| Ray::new(Vec3::new(-3.0, 0.5 + 3.0 * i as f32, 14.0), Vec3::new(1.0, 0.7, -0.2)).unwrap())
    ///     .collect();
    /// let mut out = vec![Trace::default(); rays.len()];
    /// if std::is_x86_feature_detected!("avx2") {
    ///     // SAFETY: the CPU has AVX2.
    ///     unsafe { t.trace_maxmip_wide_rays_avx2(&rays, &mip, &mut out) }.unwrap();
    ///     for (r, o) in rays.iter().zip(&out) {
    ///         // SAFETY: the CPU has AVX2.
    ///         assert_eq!(*o, unsafe { t.trace_maxmip_wide_avx2(r, &mip) }.unwrap());
    ///     }
    /// }
    /// # }
    /// ```
    // Not under `cfg(doctest)`, as `trace_maxmip_packet_avx512` (rust-lang/rust#49864).
    #[cfg_attr(not(doctest), target_feature(enable = "avx2"))]
    pub fn trace_maxmip_wide_rays_avx2(
        &self,
        rays: &[Ray],
        mip: &MaxMip<'_>,
        out: &mut [Trace],
    ) -> Result<(), Error> {
        self.check_rays(rays, mip, out)?;
        self.wide_rays(
            rays,
            mip,
            out,
            (
                || Fast::idle(),
                |lr, oct| Fast::new(lr, oct, mip),
                |ray, st, o| self.wide_alone(ray, mip, o, st),
            ),
            |c, child, ix, iy| node_fast(mip, c, child, ix, iy),
        );
        Ok(())
    }

    /// The walk of a ray outside the `f32` test's range, with the exact test.
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    fn wide_alone(&self, ray: &Ray, mip: &MaxMip<'_>, out: &mut Trace, st: (LocalRay, u32, usize)) {
        let c = Exact::new(&st.0, st.2, mip);
        self.wide_loop(ray, mip, out, st, c, |c, child, ix, iy| {
            node_exact(mip, c, child, ix, iy)
        });
    }
}

impl Exact {
    /// The constants of clipped ray `lr` in octant `oct`.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn new(lr: &LocalRay, oct: usize, mip: &MaxMip<'_>) -> Exact {
        Exact {
            x: Axis::new(lr.o.x, lr.d.x, lr.inv[0], mip.nx),
            y: Axis::new(lr.o.y, lr.d.y, lr.inv[1], mip.ny),
            oz: _mm256_set1_pd(lr.o.z),
            dz: _mm256_set1_pd(lr.d.z),
            down: _mm256_castsi256_pd(_mm256_set1_epi64x(-i64::from(lr.d.z < 0.0))),
            t0: _mm256_set1_pd(lr.t0),
            t1: _mm256_set1_pd(lr.t1),
            cross: &CROSSING[oct & 3],
        }
    }
}

/// The sixteen children (on level `child`) of node `(ix, iy)` two levels up, by the exact test:
/// the mask of those the ray crosses and the neighbour walk would enter (crossing order).
#[target_feature(enable = "avx2")]
#[inline]
fn node_exact(mip: &MaxMip<'_>, c: &Exact, child: u32, ix: u32, iy: u32) -> u32 {
    let (s, bx, by) = block(child, ix, iy);
    let (s, bx, by) = (_mm256_set1_pd(s), _mm256_set1_pd(bx), _mm256_set1_pd(by));
    let rows: [__m128; 4] = cast(tile(mip, child, ix, iy));
    let (lx, ax, ex) = c.x.span(bx, s);
    // The ray's own interval first, as `max_f(max_f(t0, ax), ay)` in the neighbour walk.
    let (ax, ex) = (_mm256_max_pd(c.t0, ax), _mm256_min_pd(c.t1, ex));
    let (ly, ay, ey) = c.y.span(by, s);
    let row = |r: usize, (ay_r, ey_r): (__m256d, __m256d)| {
        let a = _mm256_max_pd(ax, ay_r);
        let b = _mm256_min_pd(ex, ey_r);
        // The ray's lowest point over the interval: `min(z(a), z(b))` of the neighbour walk,
        // `z(b)` for a descending ray and `z(a)` otherwise.
        let zmin = _mm256_add_pd(c.oz, _mm256_mul_pd(_mm256_blendv_pd(a, b, c.down), c.dz));
        let m = _mm256_cvtps_pd(rows[r & 3]);
        // `<`: a child the ray only touches is not entered (see `ray/wide.rs`).
        let e = _mm256_and_pd(
            _mm256_cmp_pd::<_CMP_LT_OQ>(a, b),
            _mm256_cmp_pd::<_CMP_LE_OQ>(zmin, m),
        );
        (_mm256_movemask_pd(e) as u32) << (4 * r)
    };
    let m = row(0, row_lanes::<0x00>(ay, ey))
        | row(1, row_lanes::<0x55>(ay, ey))
        | row(2, row_lanes::<0xaa>(ay, ey))
        | row(3, row_lanes::<0xff>(ay, ey));
    crossing_mask(c.cross, lx, ly, m)
}

/// The children to enter, in crossing order (`cross`, [`CROSSING`] of the ray's octant), from
/// the tile-order mask `m` of those passing the test and the live columns `lx` and rows `ly`: a
/// live column in a live row (the columns' bits repeated in every row, the rows' spread to
/// four bits each).
#[inline(always)]
fn crossing_mask(cross: &[[u16; 256]; 2], lx: u32, ly: u32, m: u32) -> u32 {
    let m = m & (lx * 0x1111) & u32::from(ROWS[(ly & 15) as usize]);
    u32::from(cross[0][(m & 0xff) as usize] | cross[1][(m >> 8 & 0xff) as usize])
}

/// The sixteen children (on level `child`) of node `(ix, iy)` two levels up, by the
/// conservative `f32` test: the mask (crossing order) of every child the exact test enters, and
/// possibly a few more (see the module doc). Two rows of the block a register.
#[target_feature(enable = "avx2")]
#[inline]
fn node_fast(mip: &MaxMip<'_>, c: &Fast, child: u32, ix: u32, iy: u32) -> u32 {
    // [`block`]'s values in `f32` directly (integers below 2^17 on grids of at most 2^16 cells
    // a side, exact in `f32`; `2^child` from its exponent, and products with a power of two,
    // are exact), without the round trip through `f64` on the pass's dependent chain.
    let s = f32::from_bits((127 + (child & 63)) << 23);
    let (s, bx, by) = (
        _mm_set1_ps(s),
        _mm_set1_ps(ix as f32 * 4.0 * s),
        _mm_set1_ps(iy as f32 * 4.0 * s),
    );
    let halves: [__m256; 2] = cast(tile(mip, child, ix, iy));
    let (lx, ax, ex) = c.x.span(bx, s);
    // The ray's own interval first: `[0, t1']` after the re-basing.
    let (ax, ex) = (_mm_max_ps(_mm_setzero_ps(), ax), _mm_min_ps(c.t1, ex));
    // The columns' values in both rows of a register.
    let (ax, ex) = (_mm256_set_m128(ax, ax), _mm256_set_m128(ex, ex));
    let (ly, ay, ey) = c.y.span(by, s);
    let (ay, ey) = (_mm256_castps128_ps256(ay), _mm256_castps128_ps256(ey));
    // Rows `2h` and `2h + 1`: their y values spread over four lanes each by `idx`.
    let half = |h: usize, idx: __m256i| {
        let a = _mm256_max_ps(ax, _mm256_permutevar8x32_ps(ay, idx));
        let b = _mm256_min_ps(ex, _mm256_permutevar8x32_ps(ey, idx));
        let zmin = _mm256_add_ps(c.oz, _mm256_mul_ps(_mm256_blendv_ps(a, b, c.down), c.dz));
        let e = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_LT_OQ>(a, b),
            _mm256_cmp_ps::<_CMP_LE_OQ>(zmin, halves[h & 1]),
        );
        (_mm256_movemask_ps(e) as u32) << (8 * h)
    };
    let m = half(0, _mm256_set_epi32(1, 1, 1, 1, 0, 0, 0, 0))
        | half(1, _mm256_set_epi32(3, 3, 3, 3, 2, 2, 2, 2));
    crossing_mask(c.cross, lx, ly, m)
}

/// Row `r`'s y values (`IMM` is `r` in each of the four two-bit fields: `0x00`, `0x55`, `0xaa`,
/// `0xff`) in every lane: its entry and exit.
#[target_feature(enable = "avx2")]
#[inline]
fn row_lanes<const IMM: i32>(ay: __m256d, ey: __m256d) -> (__m256d, __m256d) {
    (
        _mm256_permute4x64_pd::<IMM>(ay),
        _mm256_permute4x64_pd::<IMM>(ey),
    )
}

/// A four-bit row mask spread to the tile's bit order: bit `r` to bits `4r .. 4r + 4`.
const ROWS: [u16; 16] = {
    let mut t = [0u16; 16];
    let mut v = 0;
    while v < 16 {
        let mut r = 0;
        while r < 4 {
            if v >> r & 1 != 0 {
                t[v] |= 0xf << (4 * r);
            }
            r += 1;
        }
        v += 1;
    }
    t
};
