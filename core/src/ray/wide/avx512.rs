//! The sixteen-wide walk's node test in AVX-512 (see `ray/wide.rs`): the sixteen children in
//! two registers of eight `f64` lanes, in crossing order, with the operations of the portable
//! node (and of the neighbour walk's step) in the same order.

use super::{block, tile, ORDER};
use crate::ray::maxmip::MaxMip;
use crate::ray::{Ray, RayTracer, Trace};
use crate::{Error, Terrain};
use bytemuck::cast;
use core::arch::x86_64::*;

/// The lanes of one direction octant: [`ORDER`] as `f64` lane values (two halves) and as tile
/// elements (`row * 4 + column`, for the permute of the maxima).
struct Lanes {
    cx: [[f64; 8]; 2],
    cy: [[f64; 8]; 2],
    perm: [i32; 16],
}

const fn lanes(oct: usize) -> Lanes {
    let xy = ORDER[oct];
    let mut l = Lanes {
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

/// [`lanes`] for the four direction octants, indexed as [`ORDER`].
static LANES: [Lanes; 4] = [lanes(0), lanes(1), lanes(2), lanes(3)];

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

impl<T: Terrain> RayTracer<'_, T> {
    /// [`RayTracer::trace_maxmip`] through sixteen-wide nodes, the sixteen children of a node
    /// tested in AVX-512 lanes (x86-64 only; see `ray/wide.rs`): the same hits, the same cells
    /// tested or fewer (cells the ray only touches at a point are skipped; a ray passing within
    /// a rounding unit of a grid vertex may take one cell more there), in fewer and wider
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
        let Some(st) = self.wide_start(ray, mip, out) else {
            return;
        };
        let (lr, oct) = (&st.0, st.2);
        let ln = &LANES[oct & 3];
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
        self.wide_loop(ray, mip, out, st, c, |c, child, ix, iy| {
            self.wide_node(mip, c, child, ix, iy)
        });
    }

    /// The sixteen children (on level `child`) of node `(ix, iy)` two levels up: the mask of
    /// those the ray crosses and the neighbour walk would enter (lane order: crossing order).
    #[target_feature(enable = "avx512f")]
    #[inline]
    fn wide_node(&self, mip: &MaxMip<'_>, c: &Consts, child: u32, ix: u32, iy: u32) -> u32 {
        let (s, bx, by) = block(child, ix, iy);
        let (sv, bx, by) = (_mm512_set1_pd(s), _mm512_set1_pd(bx), _mm512_set1_pd(by));
        let m = _mm512_permutexvar_ps(c.perm, cast(tile(mip, child, ix, iy)));
        let mx: [__m512d; 2] = [
            _mm512_cvtps_pd(_mm512_castps512_ps256(m)),
            _mm512_cvtps_pd(_mm256_castpd_ps(_mm512_extractf64x4_pd::<1>(
                _mm512_castps_pd(m),
            ))),
        ];
        let mut mask = 0u32;
        for (h, &mx) in mx.iter().enumerate() {
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
                & _mm512_cmp_pd_mask::<_CMP_LE_OQ>(zmin, mx);
            mask |= u32::from(enter) << (8 * h);
        }
        mask
    }
}
