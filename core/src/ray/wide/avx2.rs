//! The sixteen-wide walk's node test in AVX2 (see `ray/wide.rs`): a child's x slab depends on
//! its column only and its y slab on its row only, so the four columns' slabs take one
//! register of four `f64` lanes, the four rows' another, and each row of the block is then one
//! register (lane `k` is column `k`), the tile's own order; the mask goes into crossing order
//! by the portable node's table. The operations are those of the portable node (and of the
//! neighbour walk's step) in the same order, so the traces are the same.

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

/// Per-ray constants of the walk.
struct Consts {
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

impl<T: Terrain> RayTracer<'_, T> {
    /// [`RayTracer::trace_maxmip_wide`] with its node test in AVX2 registers (x86-64 only):
    /// the same traces. Safe to call only where the CPU has AVX2 (check with
    /// `is_x86_feature_detected!` on the std side).
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
    ///     assert_eq!(wide, t.trace_maxmip_wide(&ray, &mip).unwrap());
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
        let c = Consts::new(&st.0, st.2, mip);
        self.wide_loop(ray, mip, &mut out, st, c, |c, child, ix, iy| {
            node(mip, c, child, ix, iy)
        });
        Ok(out)
    }

    /// [`RayTracer::trace_maxmip_wide_rays`] with its node test in AVX2 registers (x86-64
    /// only): the same traces, two rays' walks interleaved. Safe to call only where the CPU has
    /// AVX2 (check with `is_x86_feature_detected!` on the std side).
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
    ///         assert_eq!(*o, t.trace_maxmip_wide(r, &mip).unwrap());
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
            |lr, oct| Consts::new(lr, oct, mip),
            |c, child, ix, iy| node(mip, c, child, ix, iy),
        );
        Ok(())
    }
}

impl Consts {
    /// The constants of clipped ray `lr` in octant `oct`.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn new(lr: &LocalRay, oct: usize, mip: &MaxMip<'_>) -> Consts {
        Consts {
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

/// The sixteen children (on level `child`) of node `(ix, iy)` two levels up: the mask of those
/// the ray crosses and the neighbour walk would enter (crossing order).
#[target_feature(enable = "avx2")]
#[inline]
fn node(mip: &MaxMip<'_>, c: &Consts, child: u32, ix: u32, iy: u32) -> u32 {
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
    // Live children: a live column in a live row (the columns' bits repeated in every row,
    // the rows' spread to four bits each).
    let live = (lx * 0x1111) & u32::from(ROWS[(ly & 15) as usize]);
    let m = live
        & (row(0, row_lanes::<0x00>(ay, ey))
            | row(1, row_lanes::<0x55>(ay, ey))
            | row(2, row_lanes::<0xaa>(ay, ey))
            | row(3, row_lanes::<0xff>(ay, ey)));
    let cross = c.cross[0][(m & 0xff) as usize] | c.cross[1][(m >> 8 & 0xff) as usize];
    u32::from(cross)
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
