//! AVX-512 packet traversal of the maximum mipmap (Tevs, Ihrke, Seidel 2008, section 4): eight
//! rays walk the pyramid at once, one ray per 64-bit lane, each in its own node. Every lane
//! takes the step of [`RayTracer::trace_maxmip`] (`mip_step` in `maxmip.rs`) with the same
//! `f64` operations in the same order — `maxpd`/`minpd` are the `max_f`/`min_f` rules there,
//! conversions between integers and floats are exact — so every lane computes bit for bit the
//! values of the scalar step, and the hits are the same. The exact cell test of the `triangles`
//! surface runs in lanes too, with the operations of `cell::triangles_hit` and of the hit's
//! normal in `make_hit`, and so does the clip and start of the rays, eight at a time
//! (`RayTracer::local` and `mip_start`). Only the pyramid and corner loads (scalar loads, since
//! the core has no `unsafe` for gathers), the cell tests of the other surfaces and the start
//! test of rays that begin below the highest sample run lane by lane; a lane whose ray ends
//! takes the next clipped ray.
//!
//! The state lives in registers; lanes are read and written through `bytemuck` casts, so the
//! module needs no `unsafe` either. Callers select it at run time (see
//! [`RayTracer::trace_maxmip_packet_avx512`]).

use super::cell::LocalRay;
use super::maxmip::start_level;
use super::{Hit, MaxMip, Ray, RayTracer, Trace, PACKET_LANES};
use crate::{Error, Surface, Terrain};
use bytemuck::cast;
use core::arch::x86_64::*;
use glam::{DVec3, Vec3};

/// Levels the lane tables hold (two 8-lane registers): grids up to `2^15` cells a side.
const TABLE_LEVELS: u32 = 16;

/// Per-lane values of one ray, written into its lane on refill.
struct Lanes {
    ox: __m512d,
    oy: __m512d,
    oz: __m512d,
    dx: __m512d,
    dy: __m512d,
    dz: __m512d,
    invx: __m512d,
    invy: __m512d,
    t1: __m512d,
    t: __m512d,
    ix: __m512i,
    iy: __m512i,
    lvl: __m512i,
    steps: __m512i,
    stepx: __m512i,
    stepy: __m512i,
    /// Direction component positive / zero, per axis.
    posx: __mmask8,
    posy: __mmask8,
    zerox: __mmask8,
    zeroy: __mmask8,
    /// The walk climbs after a skip into another parent (`RayTracer::climbs`).
    climb: __mmask8,
}

impl Lanes {
    #[target_feature(enable = "avx512f,avx512dq")]
    #[inline]
    fn new() -> Lanes {
        let z = _mm512_setzero_pd();
        let zi = _mm512_setzero_si512();
        Lanes {
            ox: z,
            oy: z,
            oz: z,
            dx: z,
            dy: z,
            dz: z,
            invx: z,
            invy: z,
            t1: z,
            t: z,
            ix: zi,
            iy: zi,
            lvl: zi,
            steps: zi,
            stepx: zi,
            stepy: zi,
            posx: 0,
            posy: 0,
            zerox: 0,
            zeroy: 0,
            climb: 0,
        }
    }

    /// Moves lane `j` of `from` into lane `k` (`bit = 1 << k`): a permute per vector, no
    /// round trip through scalars.
    #[target_feature(enable = "avx512f,avx512dq")]
    #[inline]
    fn take(&mut self, bit: __mmask8, from: &Lanes, j: usize) {
        let idx = _mm512_set1_epi64(j as i64);
        let f = |v: __m512d, src: __m512d| _mm512_mask_permutexvar_pd(v, bit, idx, src);
        let i = |v: __m512i, src: __m512i| _mm512_mask_permutexvar_epi64(v, bit, idx, src);
        self.ox = f(self.ox, from.ox);
        self.oy = f(self.oy, from.oy);
        self.oz = f(self.oz, from.oz);
        self.dx = f(self.dx, from.dx);
        self.dy = f(self.dy, from.dy);
        self.dz = f(self.dz, from.dz);
        self.invx = f(self.invx, from.invx);
        self.invy = f(self.invy, from.invy);
        self.t1 = f(self.t1, from.t1);
        self.t = f(self.t, from.t);
        self.ix = i(self.ix, from.ix);
        self.iy = i(self.iy, from.iy);
        self.lvl = i(self.lvl, from.lvl);
        self.steps = i(self.steps, from.steps);
        self.stepx = i(self.stepx, from.stepx);
        self.stepy = i(self.stepy, from.stepy);
        let m = |mask: __mmask8, src: __mmask8| {
            if src & (1 << (j & 7)) != 0 {
                mask | bit
            } else {
                mask & !bit
            }
        };
        self.posx = m(self.posx, from.posx);
        self.posy = m(self.posy, from.posy);
        self.zerox = m(self.zerox, from.zerox);
        self.zeroy = m(self.zeroy, from.zeroy);
        self.climb = m(self.climb, from.climb);
    }
}

/// Lanes of one pack: the vector state, each lane's clipped ray (for the cell tests of the surfaces
/// other than `triangles`) and its index.
struct Pack {
    ln: Lanes,
    locals: [Option<LocalRay>; PACKET_LANES],
    ray_of: [usize; PACKET_LANES],
    active: __mmask8,
}

impl Pack {
    #[target_feature(enable = "avx512f,avx512dq")]
    #[inline]
    fn new() -> Pack {
        Pack {
            ln: Lanes::new(),
            locals: [None; PACKET_LANES],
            ray_of: [usize::MAX; PACKET_LANES],
            active: 0,
        }
    }
}

/// Up to [`PACKET_LANES`] consecutive rays clipped and started in lanes (`starts8`), handed
/// to the lanes' refills one by one (`Lanes::take`).
struct Starts {
    /// Index of lane 0's ray; rays in the batch; the next lane to hand out.
    first: usize,
    len: usize,
    cur: usize,
    /// Lanes whose ray reaches the clipped prism (`RayTracer::local` is `Some`).
    ok: __mmask8,
    /// Lanes whose clipped start is not above the highest sample (`start_hit` must test it).
    test: __mmask8,
    /// The clipped rays, their start nodes and their direction masks, as in [`Lanes`].
    ln: Lanes,
}

impl Starts {
    #[target_feature(enable = "avx512f,avx512dq")]
    #[inline]
    fn new() -> Starts {
        Starts {
            first: 0,
            len: 0,
            cur: 0,
            ok: 0,
            test: 0,
            ln: Lanes::new(),
        }
    }

    /// The clipped ray of lane `k`.
    #[target_feature(enable = "avx512f,avx512dq")]
    #[inline]
    fn local(&self, k: usize) -> Option<LocalRay> {
        let at = |v: __m512d| cast::<__m512d, [f64; 8]>(v).get(k).copied();
        let l = &self.ln;
        Some(LocalRay {
            o: DVec3::new(at(l.ox)?, at(l.oy)?, at(l.oz)?),
            d: DVec3::new(at(l.dx)?, at(l.dy)?, at(l.dz)?),
            inv: [at(l.invx)?, at(l.invy)?],
            t0: at(l.t)?,
            t1: at(l.t1)?,
        })
    }
}

/// Hits of the `triangles` leaf test waiting for their unit normal: the ray and its triangle's
/// grid-unit normal `(nx, ny, 1)`. Normalised [`PACKET_LANES`] at a time
/// (`RayTracer::flush_normals`) rather than in the step, where one or two lanes hit at a time.
struct Normals {
    len: usize,
    ray: [usize; PENDING],
    nx: [f64; PENDING],
    ny: [f64; PENDING],
}

/// Hits a [`Normals`] holds before it is flushed (a multiple of [`PACKET_LANES`]).
const PENDING: usize = 64;

/// The per-call state both packs share: the clipped rays to hand out, the hits waiting for
/// their normals.
struct Feed<'a> {
    starts: &'a mut Starts,
    normals: &'a mut Normals,
}

/// Per-call constants: level tables and splats.
struct Consts {
    off_t: (__m512i, __m512i),
    tx_t: (__m512i, __m512i),
    w_t: (__m512i, __m512i),
    h_t: (__m512i, __m512i),
    one: __m512i,
    zero_i: __m512i,
    nx: __m512i,
    ny: __m512i,
    levels: __m512i,
    bound: __m512i,
    c1023: __m512i,
    three: __m512i,
}

/// `(entry, exit)` of the slabs `[lo, hi]` per lane: `slab_signed` of `maxmip.rs`.
#[target_feature(enable = "avx512f,avx512dq")]
#[inline]
fn slab8(
    o: __m512d,
    inv: __m512d,
    pos: __mmask8,
    zero: __mmask8,
    lo: __m512d,
    hi: __m512d,
) -> (__m512d, __m512d) {
    let a = _mm512_mul_pd(_mm512_sub_pd(lo, o), inv);
    let b = _mm512_mul_pd(_mm512_sub_pd(hi, o), inv);
    let entry = _mm512_mask_blend_pd(pos, b, a);
    let exit = _mm512_mask_blend_pd(pos, a, b);
    (
        _mm512_mask_blend_pd(zero, entry, _mm512_set1_pd(f64::NEG_INFINITY)),
        _mm512_mask_blend_pd(zero, exit, _mm512_set1_pd(f64::INFINITY)),
    )
}

/// One lane-wise table lookup: `tab[idx]` for `idx` in `0..16`.
#[target_feature(enable = "avx512f,avx512dq")]
#[inline]
fn lookup(tab: &(__m512i, __m512i), idx: __m512i) -> __m512i {
    _mm512_permutex2var_epi64(tab.0, idx, tab.1)
}

impl<T: Terrain> RayTracer<'_, T> {
    /// [`RayTracer::trace_maxmip_packet`] with [`PACKET_LANES`] (eight) rays in the eight `f64` lanes of AVX-512
    /// registers (x86-64 only): the same results, ray for ray. Safe to call only where the CPU
    /// has AVX-512F and AVX-512DQ (check with `is_x86_feature_detected!` on the std side).
    /// Pyramids of more than 16 levels (grids over `2^15` cells a side) are traced ray by ray.
    ///
    /// # Safety
    ///
    /// The CPU must support AVX-512F and AVX-512DQ (a `#[target_feature]` function: calling it
    /// elsewhere is undefined behaviour). The function itself uses no `unsafe`.
    ///
    /// ```
    /// # #[cfg(target_arch = "x86_64")] {
    /// use relief_core::ray::{MaxMip, Ray, RayTracer, Trace};
    /// use relief_core::{Heightfield, Surface};
    /// use glam::Vec3;
    /// let s: Vec<f32> = (0..64).map(|i| ((i * 5) % 7) as f32).collect();
    /// let hf = Heightfield::new(&s, 8, 8).unwrap();
    /// let mut buf = vec![0.0; MaxMip::len(8, 8).unwrap()];
    /// let mip = MaxMip::build(&hf, &mut buf).unwrap();
    /// let t = RayTracer::new(&hf, Surface::Triangles);
    /// let rays: Vec<Ray> = (0..20)
    ///     .map(|i| Ray::new(Vec3::new(-1.0, 0.3 * i as f32, 9.0), Vec3::new(1.0, 0.1, -0.8)).unwrap())
    ///     .collect();
    /// let mut out = vec![Trace::default(); rays.len()];
    /// if std::is_x86_feature_detected!("avx512f") && std::is_x86_feature_detected!("avx512dq") {
    ///     // SAFETY: the CPU has both features.
    ///     unsafe { t.trace_maxmip_packet_avx512(&rays, &mip, &mut out) }.unwrap();
    ///     for (r, o) in rays.iter().zip(&out) {
    ///         assert_eq!(*o, t.trace_maxmip(r, &mip).unwrap());
    ///     }
    /// }
    /// # }
    /// ```
    // Not under `cfg(doctest)`: rustdoc extracts the doctests of a `#[target_feature]` function
    // only where the feature is enabled at compile time (rust-lang/rust#49864), so this example
    // would never run. The crate the doctests link against is built with the attribute.
    #[cfg_attr(not(doctest), target_feature(enable = "avx512f,avx512dq"))]
    pub fn trace_maxmip_packet_avx512(
        &self,
        rays: &[Ray],
        mip: &MaxMip<'_>,
        out: &mut [Trace],
    ) -> Result<(), Error> {
        self.check_rays(rays, mip, out)?;
        if mip.levels > TABLE_LEVELS {
            self.each_ray(rays, mip, out);
            return Ok(());
        }
        self.walk8(rays, mip, out);
        Ok(())
    }

    #[target_feature(enable = "avx512f,avx512dq")]
    fn walk8(&self, rays: &[Ray], mip: &MaxMip<'_>, out: &mut [Trace]) {
        // Level tables (levels past the top read as one node; never selected).
        let (mut off, mut tx, mut lw, mut lh) = ([0i64; 16], [0i64; 16], [1i64; 16], [1i64; 16]);
        for (k, (((o, t), w), h)) in off
            .iter_mut()
            .zip(tx.iter_mut())
            .zip(lw.iter_mut())
            .zip(lh.iter_mut())
            .enumerate()
        {
            let l = mip.level(k as u32);
            (*o, *t, *w, *h) = (l.off as i64, l.tx as i64, l.w, l.h);
        }
        let split = |a: [i64; 16]| -> (__m512i, __m512i) {
            let lo: [i64; 8] = [a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7]];
            let hi: [i64; 8] = [a[8], a[9], a[10], a[11], a[12], a[13], a[14], a[15]];
            (cast(lo), cast(hi))
        };
        let c = Consts {
            off_t: split(off),
            tx_t: split(tx),
            w_t: split(lw),
            h_t: split(lh),
            one: _mm512_set1_epi64(1),
            zero_i: _mm512_setzero_si512(),
            nx: _mm512_set1_epi64(mip.nx as i64),
            ny: _mm512_set1_epi64(mip.ny as i64),
            levels: _mm512_set1_epi64(mip.levels as i64),
            bound: _mm512_set1_epi64(mip.bound.min(i64::MAX as u64) as i64),
            c1023: _mm512_set1_epi64(1023),
            three: _mm512_set1_epi64(3),
        };
        // Two packs of eight lanes, stepped in turn: their pyramid loads overlap.
        let mut packs = [Pack::new(), Pack::new()];
        let mut st = Starts::new();
        let mut normals = Normals {
            len: 0,
            ray: [0; PENDING],
            nx: [0.0; PENDING],
            ny: [0.0; PENDING],
        };
        for pk in packs.iter_mut() {
            for k in 0..PACKET_LANES {
                self.refill(
                    rays,
                    mip,
                    out,
                    &mut st,
                    k,
                    &mut pk.locals,
                    &mut pk.ray_of,
                    &mut pk.ln,
                    &mut pk.active,
                );
            }
        }
        // Bounded: each round steps every busy lane once (or ends its ray), and a ray is walked
        // for at most `bound + 1` rounds, so `rays * (bound + 1) + 1` rounds cover every ray.
        let rounds = (rays.len() as u64)
            .saturating_mul(mip.bound.saturating_add(1))
            .saturating_add(1);
        let mut round = 0u64;
        while packs.iter().any(|p| p.active != 0) && round < rounds {
            round += 1;
            for pk in packs.iter_mut() {
                let feed = Feed {
                    starts: &mut st,
                    normals: &mut normals,
                };
                self.step8(rays, mip, out, feed, &c, pk);
            }
        }
        self.flush_normals(&mut normals, out);
    }

    /// One step of every busy lane of `pk`; ended lanes take the next ray.
    #[target_feature(enable = "avx512f,avx512dq")]
    #[inline]
    fn step8(
        &self,
        rays: &[Ray],
        mip: &MaxMip<'_>,
        out: &mut [Trace],
        feed: Feed<'_>,
        c: &Consts,
        pk: &mut Pack,
    ) {
        if pk.active == 0 {
            return;
        }
        let live = pk.active & _mm512_cmplt_epi64_mask(pk.ln.steps, c.bound);
        pk.ln.steps = _mm512_mask_add_epi64(pk.ln.steps, live, pk.ln.steps, c.one);
        let (ix, iy, lvl) = (pk.ln.ix, pk.ln.iy, pk.ln.lvl);
        let off = lookup(&c.off_t, lvl);
        let txs = lookup(&c.tx_t, lvl);
        let w = lookup(&c.w_t, lvl);
        let h = lookup(&c.h_t, lvl);
        let s = _mm512_sllv_epi64(c.one, lvl);
        // ix * 2^lvl as a shift (the indices of a walking lane are never negative; idle lanes
        // compute values that are never used); a 64-bit multiply has a long latency.
        let x0i = _mm512_sllv_epi64(ix, lvl);
        let y0i = _mm512_sllv_epi64(iy, lvl);
        let x1i = _mm512_min_epi64(_mm512_add_epi64(x0i, s), c.nx);
        let y1i = _mm512_min_epi64(_mm512_add_epi64(y0i, s), c.ny);
        let (ax, bx) = slab8(
            pk.ln.ox,
            pk.ln.invx,
            pk.ln.posx,
            pk.ln.zerox,
            _mm512_cvtepi64_pd(x0i),
            _mm512_cvtepi64_pd(x1i),
        );
        let (ay, by) = slab8(
            pk.ln.oy,
            pk.ln.invy,
            pk.ln.posy,
            pk.ln.zeroy,
            _mm512_cvtepi64_pd(y0i),
            _mm512_cvtepi64_pd(y1i),
        );
        let ta = _mm512_max_pd(_mm512_max_pd(pk.ln.t, ax), ay);
        let tb = _mm512_min_pd(_mm512_min_pd(pk.ln.t1, bx), by);
        // Node index in the tiled level (tiled_t of maxmip.rs).
        let tile = _mm512_add_epi64(
            // Both factors are below 2^31: the 32 x 32 -> 64-bit multiply is exact.
            _mm512_mul_epu32(_mm512_srai_epi64::<2>(iy), txs),
            _mm512_srai_epi64::<2>(ix),
        );
        let inner = _mm512_or_si512(
            _mm512_slli_epi64::<2>(_mm512_and_si512(iy, c.three)),
            _mm512_and_si512(ix, c.three),
        );
        let idx = _mm512_add_epi64(off, _mm512_add_epi64(_mm512_slli_epi64::<4>(tile), inner));
        let ia: [i64; 8] = cast(idx);
        let mut mv = [f32::NEG_INFINITY; 8];
        for (m, &i) in mv.iter_mut().zip(&ia) {
            // A negative index (idle lanes only) wraps past every buffer length: `None`.
            *m = mip
                .data
                .get(i as u64 as usize)
                .copied()
                .unwrap_or(f32::NEG_INFINITY);
        }
        let m = _mm512_cvtps_pd(cast::<[f32; 8], __m256>(mv));
        let za = _mm512_add_pd(pk.ln.oz, _mm512_mul_pd(ta, pk.ln.dz));
        let zb = _mm512_add_pd(pk.ln.oz, _mm512_mul_pd(tb, pk.ln.dz));
        let zmin = _mm512_min_pd(za, zb);
        let inside = live
            & _mm512_cmp_pd_mask::<_CMP_LE_OQ>(ta, tb)
            & _mm512_cmp_pd_mask::<_CMP_LE_OQ>(zmin, m);
        let lvl0 = _mm512_cmpeq_epi64_mask(lvl, c.zero_i);
        let leaf = inside & lvl0;
        let mut hit_mask: __mmask8 = 0;
        if leaf != 0 {
            let (xs, ys): ([i64; 8], [i64; 8]) = (cast(ix), cast(iy));
            // Corner heights of every leaf lane first, then the exact tests: the sample loads
            // (usually cache misses) of different lanes overlap.
            let mut hs = [[0.0f64; 4]; PACKET_LANES];
            for (k, (h, (&cx, &cy))) in hs.iter_mut().zip(xs.iter().zip(&ys)).enumerate() {
                if leaf & (1 << k) != 0 {
                    *h = self.corners(cx as u32, cy as u32);
                }
            }
            if self.surface == Surface::Triangles {
                hit_mask = self.leaves_triangles8(rays, out, pk, (leaf, ta, tb), &hs, feed.normals);
            } else {
                let (tas, tbs): ([f64; 8], [f64; 8]) = (cast(ta), cast(tb));
                for k in 0..PACKET_LANES {
                    if leaf & (1 << k) == 0 {
                        continue;
                    }
                    let (Some(Some(lr)), Some(&r)) = (pk.locals.get(k), pk.ray_of.get(k)) else {
                        continue;
                    };
                    let (Some(ray), Some(o)) = (rays.get(r), out.get_mut(r)) else {
                        continue;
                    };
                    let (Some(&a), Some(&b), Some(&cx), Some(&cy), Some(h)) =
                        (tas.get(k), tbs.get(k), xs.get(k), ys.get(k), hs.get(k))
                    else {
                        continue;
                    };
                    o.cells += 1;
                    let (cx, cy) = (cx as u32, cy as u32);
                    if let Some(hit) = super::cell::intersect(self.surface, lr, cx, cy, h, a, b) {
                        o.hit = Some(self.make_hit(ray, cx, cy, hit));
                        hit_mask |= 1 << k;
                    }
                }
            }
        }
        let descend = inside & !lvl0;
        // Descend into the child holding the point at `ta`.
        let l = _mm512_sub_epi64(lvl, c.one);
        let cw = lookup(&c.w_t, l);
        let ch = lookup(&c.h_t, l);
        let inv = _mm512_castsi512_pd(_mm512_slli_epi64::<52>(_mm512_sub_epi64(c.c1023, l)));
        let px = _mm512_add_pd(pk.ln.ox, _mm512_mul_pd(ta, pk.ln.dx));
        let py = _mm512_add_pd(pk.ln.oy, _mm512_mul_pd(ta, pk.ln.dy));
        let one = c.one;
        let clamp = |v: __m512i, i: __m512i, n: __m512i| {
            let lo = _mm512_add_epi64(i, i);
            let v = _mm512_min_epi64(_mm512_max_epi64(v, lo), _mm512_add_epi64(lo, one));
            _mm512_min_epi64(v, _mm512_sub_epi64(n, one))
        };
        let dxi = clamp(_mm512_cvttpd_epi64(_mm512_mul_pd(px, inv)), ix, cw);
        let dyi = clamp(_mm512_cvttpd_epi64(_mm512_mul_pd(py, inv)), iy, ch);
        // Skip to the neighbour through the face crossed first.
        let exit = _mm512_min_pd(bx, by);
        let st = _mm512_max_pd(exit, pk.ln.t);
        let sx = _mm512_mask_add_epi64(
            ix,
            _mm512_cmp_pd_mask::<_CMP_LE_OQ>(bx, by),
            ix,
            pk.ln.stepx,
        );
        let sy = _mm512_mask_add_epi64(
            iy,
            _mm512_cmp_pd_mask::<_CMP_LE_OQ>(by, bx),
            iy,
            pk.ln.stepy,
        );
        let gone = _mm512_cmp_pd_mask::<_CMP_GT_OQ>(st, pk.ln.t1)
            | _mm512_cmpge_epi64_mask(_mm512_add_epi64(lvl, c.one), c.levels)
            | _mm512_cmplt_epi64_mask(sx, c.zero_i)
            | _mm512_cmplt_epi64_mask(sy, c.zero_i)
            | _mm512_cmpge_epi64_mask(sx, w)
            | _mm512_cmpge_epi64_mask(sy, h);
        let up = pk.ln.climb
            & (_mm512_cmpneq_epi64_mask(_mm512_srai_epi64::<1>(sx), _mm512_srai_epi64::<1>(ix))
                | _mm512_cmpneq_epi64_mask(_mm512_srai_epi64::<1>(sy), _mm512_srai_epi64::<1>(iy)));
        let sx = _mm512_mask_srai_epi64::<1>(sx, up, sx);
        let sy = _mm512_mask_srai_epi64::<1>(sy, up, sy);
        let sl = _mm512_mask_add_epi64(lvl, up, lvl, c.one);
        pk.ln.ix = _mm512_mask_blend_epi64(descend, sx, dxi);
        pk.ln.iy = _mm512_mask_blend_epi64(descend, sy, dyi);
        pk.ln.lvl = _mm512_mask_blend_epi64(descend, sl, l);
        pk.ln.t = _mm512_mask_blend_pd(descend, st, ta);
        let cont = live & !hit_mask & (descend | !gone);
        let ended = pk.active & !cont;
        pk.active = cont;
        if ended != 0 {
            let steps: [i64; 8] = cast(pk.ln.steps);
            for k in 0..PACKET_LANES {
                if ended & (1 << k) == 0 {
                    continue;
                }
                if let (Some(&r), Some(&n)) = (pk.ray_of.get(k), steps.get(k)) {
                    if let Some(o) = out.get_mut(r) {
                        o.steps = u32::try_from(n).unwrap_or(u32::MAX);
                    }
                }
                self.refill(
                    rays,
                    mip,
                    out,
                    feed.starts,
                    k,
                    &mut pk.locals,
                    &mut pk.ray_of,
                    &mut pk.ln,
                    &mut pk.active,
                );
            }
        }
    }

    /// The exact `triangles` test of the leaf lanes `leaf` (cells `(ix, iy)` of their lanes,
    /// parameter intervals `ta..tb`, corner heights `hs`) in the eight lanes at once:
    /// `cell::triangles_hit` with the same `f64` operations in the same order, each of its
    /// branches a lane mask, so every lane gets the scalar test's result bit for bit. Records
    /// the leaf lanes' cells and hits in `out`; returns the lanes that hit.
    #[target_feature(enable = "avx512f,avx512dq")]
    #[inline]
    fn leaves_triangles8(
        &self,
        rays: &[Ray],
        out: &mut [Trace],
        pk: &Pack,
        (leaf, ta, tb): (__mmask8, __m512d, __m512d),
        hs: &[[f64; 4]; PACKET_LANES],
        normals: &mut Normals,
    ) -> __mmask8 {
        let ln = &pk.ln;
        let corner = |c: usize| -> __m512d {
            let mut v = [0.0f64; PACKET_LANES];
            for (x, h) in v.iter_mut().zip(hs) {
                *x = h.get(c).copied().unwrap_or(0.0);
            }
            cast(v)
        };
        let (h00, h10, h01, h11) = (corner(0), corner(1), corner(2), corner(3));
        let zero = _mm512_setzero_pd();
        let one = _mm512_set1_pd(1.0);
        let half = _mm512_set1_pd(0.5);
        // Cell-local origin (`cell::intersect`).
        let px = _mm512_sub_pd(ln.ox, _mm512_cvtepi64_pd(ln.ix));
        let py = _mm512_sub_pd(ln.oy, _mm512_cvtepi64_pd(ln.iy));
        let (dx, dy) = (ln.dx, ln.dy);
        // The diagonal crossing `td = -g0 / gd` splits `[ta, tb]` where it lies inside.
        let g0 = _mm512_sub_pd(px, py);
        let gd = _mm512_sub_pd(dx, dy);
        let td = _mm512_div_pd(_mm512_xor_pd(g0, _mm512_set1_pd(-0.0)), gd);
        let cross = _mm512_cmp_pd_mask::<_CMP_NEQ_UQ>(gd, zero)
            & _mm512_cmp_pd_mask::<_CMP_GT_OQ>(td, ta)
            & _mm512_cmp_pd_mask::<_CMP_LT_OQ>(td, tb);
        // `clamp(0, 1)`: `max(0, x)` keeps `x` on ties and NaN, as `f64::clamp` does.
        let clamp01 = |x: __m512d| _mm512_min_pd(one, _mm512_max_pd(zero, x));
        // The slopes along x and y of the upper or lower triangle, chosen per lane by `upper`
        // (`tri_height`, `unit_normal_tri`).
        let (lx, ly) = (_mm512_sub_pd(h10, h00), _mm512_sub_pd(h11, h10));
        let (ux, uy) = (_mm512_sub_pd(h11, h01), _mm512_sub_pd(h01, h00));
        let slopes = |upper: __mmask8| {
            (
                _mm512_mask_blend_pd(upper, lx, ux),
                _mm512_mask_blend_pd(upper, ly, uy),
            )
        };
        // Ray height minus the piece's triangle at `t`.
        let f = |t: __m512d, upper: __mmask8| {
            let x = clamp01(_mm512_add_pd(px, _mm512_mul_pd(t, dx)));
            let y = clamp01(_mm512_add_pd(py, _mm512_mul_pd(t, dy)));
            let (a, b) = slopes(upper);
            let s = _mm512_add_pd(_mm512_add_pd(h00, _mm512_mul_pd(x, a)), _mm512_mul_pd(y, b));
            _mm512_sub_pd(_mm512_add_pd(ln.oz, _mm512_mul_pd(t, ln.dz)), s)
        };
        let upper_at = |a: __m512d, b: __m512d| {
            let mid = _mm512_mul_pd(half, _mm512_add_pd(a, b));
            _mm512_cmp_pd_mask::<_CMP_GT_OQ>(
                _mm512_add_pd(py, _mm512_mul_pd(mid, dy)),
                _mm512_add_pd(px, _mm512_mul_pd(mid, dx)),
            )
        };
        let le0 = |v: __m512d| _mm512_cmp_pd_mask::<_CMP_LE_OQ>(v, zero);
        // First piece `[ta, td or tb]`, then (where the diagonal cuts) `[td, tb]`.
        let b1 = _mm512_mask_blend_pd(cross, tb, td);
        let up1 = upper_at(ta, b1);
        let (fa1, fb1) = (f(ta, up1), f(b1, up1));
        let up2 = upper_at(td, tb);
        let (fa2, fb2) = (f(td, up2), f(tb, up2));
        let second = cross & !le0(fa1) & !le0(fb1);
        let a = _mm512_mask_blend_pd(second, ta, td);
        let b = _mm512_mask_blend_pd(second, b1, tb);
        let fa = _mm512_mask_blend_pd(second, fa1, fa2);
        let fb = _mm512_mask_blend_pd(second, fb1, fb2);
        let upper = (up1 & !second) | (up2 & second);
        let at_a = le0(fa);
        let hits = leaf & (at_a | le0(fb));
        // `t = a + (b - a) * (fa / (fa - fb))`, then `t.max(a).min(b)`.
        let t = _mm512_add_pd(
            a,
            _mm512_mul_pd(
                _mm512_sub_pd(b, a),
                _mm512_div_pd(fa, _mm512_sub_pd(fa, fb)),
            ),
        );
        let t = _mm512_min_pd(_mm512_max_pd(t, a), b);
        let t: [f64; 8] = cast(_mm512_mask_blend_pd(at_a, t, a));
        // The triangle's grid-unit normal (`unit_normal_tri`), normalised later in lanes.
        let neg = _mm512_set1_pd(-0.0);
        let (na, nb) = slopes(upper);
        let nx: [f64; 8] = cast(_mm512_xor_pd(na, neg));
        let ny: [f64; 8] = cast(_mm512_xor_pd(nb, neg));
        let (xs, ys): ([i64; 8], [i64; 8]) = (cast(ln.ix), cast(ln.iy));
        for k in 0..PACKET_LANES {
            let bit = 1u8 << k;
            if leaf & bit == 0 {
                continue;
            }
            let (Some(&r), Some(&cx), Some(&cy), Some(&tk)) =
                (pk.ray_of.get(k), xs.get(k), ys.get(k), t.get(k))
            else {
                continue;
            };
            let (Some(ray), Some(o)) = (rays.get(r), out.get_mut(r)) else {
                continue;
            };
            o.cells += 1;
            if let (true, Some(&x), Some(&y)) = (hits & bit != 0, nx.get(k), ny.get(k)) {
                // The normal is written when `normals` is flushed.
                o.hit = Some(Hit {
                    t: tk,
                    cell: [cx as u32, cy as u32],
                    position: ray.at(tk),
                    normal: Vec3::Z,
                });
                if normals.len >= PENDING {
                    self.flush_normals(normals, out);
                }
                if let (Some(pr), Some(px), Some(py)) = (
                    normals.ray.get_mut(normals.len),
                    normals.nx.get_mut(normals.len),
                    normals.ny.get_mut(normals.len),
                ) {
                    (*pr, *px, *py) = (r, x, y);
                    normals.len += 1;
                }
            }
        }
        hits
    }

    /// Writes the unit world normal of every hit in `normals` ([`PACKET_LANES`] at a time)
    /// and empties it: `make_hit`'s operations (divided by the spacing,
    /// `DVec3::try_normalize`, then `f32`) in lanes. A scalar square root here would also be
    /// libm's legacy-SSE `sqrtsd`, slow after AVX-512 code.
    #[target_feature(enable = "avx512f,avx512dq")]
    #[inline(never)]
    fn flush_normals(&self, normals: &mut Normals, out: &mut [Trace]) {
        let zero = _mm512_setzero_pd();
        let one = _mm512_set1_pd(1.0);
        let (sx, sy) = (
            _mm512_set1_pd(self.spacing.x),
            _mm512_set1_pd(self.spacing.y),
        );
        let n = normals.len.min(PENDING);
        for ((rs, ax), ay) in normals.ray[..n]
            .chunks(PACKET_LANES)
            .zip(normals.nx.chunks_exact(PACKET_LANES))
            .zip(normals.ny.chunks_exact(PACKET_LANES))
        {
            let lane = |c: &[f64]| -> __m512d {
                let mut v = [0.0f64; PACKET_LANES];
                v.copy_from_slice(c.get(..PACKET_LANES).unwrap_or(&[0.0; PACKET_LANES]));
                cast(v)
            };
            let nx = _mm512_div_pd(lane(ax), sx);
            let ny = _mm512_div_pd(lane(ay), sy);
            let len2 = _mm512_add_pd(
                _mm512_add_pd(_mm512_mul_pd(nx, nx), _mm512_mul_pd(ny, ny)),
                _mm512_mul_pd(one, one),
            );
            let rcp = _mm512_div_pd(one, _mm512_sqrt_pd(len2));
            let ok = _mm512_cmp_pd_mask::<_CMP_LT_OQ>(rcp, _mm512_set1_pd(f64::INFINITY))
                & _mm512_cmp_pd_mask::<_CMP_GT_OQ>(rcp, zero);
            let unit = |v: __m512d, fallback: __m512d| -> [f32; 8] {
                cast(_mm512_cvtpd_ps(_mm512_mask_blend_pd(
                    ok,
                    fallback,
                    _mm512_mul_pd(v, rcp),
                )))
            };
            let (ux, uy, uz) = (unit(nx, zero), unit(ny, zero), unit(one, one));
            for (k, &r) in rs.iter().enumerate() {
                if let (Some(Some(h)), Some(&x), Some(&y), Some(&z)) = (
                    out.get_mut(r).map(|o| o.hit.as_mut()),
                    ux.get(k),
                    uy.get(k),
                    uz.get(k),
                ) {
                    h.normal = Vec3::new(x, y, z);
                }
            }
        }
        normals.len = 0;
    }

    /// Clips the rays from `first` (up to eight) in lanes and finds the node of level `lvl`
    /// holding each clipped start: `RayTracer::local` and the start of `mip_start` with the
    /// same `f64` operations in the same order, so every lane gets the scalar values bit for
    /// bit (`max_f` / `min_f` there are the `maxpd` / `minpd` rules here).
    #[target_feature(enable = "avx512f,avx512dq")]
    #[inline]
    fn starts8(&self, rays: &[Ray], first: usize, mip: &MaxMip<'_>, st: &mut Starts) {
        let batch = rays.get(first..).unwrap_or(&[]);
        let len = batch.len().min(PACKET_LANES);
        // Lanes past the last ray repeat it (`refill` never hands them out). Built by inserts,
        // not through an array: eight scalar stores read back as one vector stall the load.
        let ray = |k: usize| batch.get(k.min(len.saturating_sub(1))).copied();
        let Some(r0) = ray(0) else {
            return;
        };
        let rs = [
            r0,
            ray(1).unwrap_or(r0),
            ray(2).unwrap_or(r0),
            ray(3).unwrap_or(r0),
            ray(4).unwrap_or(r0),
            ray(5).unwrap_or(r0),
            ray(6).unwrap_or(r0),
            ray(7).unwrap_or(r0),
        ];
        let lanes = |f: fn(&Ray) -> f64| {
            let [a, b, c, d, e, g, h, i] = rs.each_ref().map(f);
            _mm512_setr_pd(a, b, c, d, e, g, h, i)
        };
        let rox = lanes(|r| r.origin.x);
        let roy = lanes(|r| r.origin.y);
        let roz = lanes(|r| r.origin.z);
        let rdx = lanes(|r| r.dir.x);
        let rdy = lanes(|r| r.dir.y);
        let rdz = lanes(|r| r.dir.z);
        let zero = _mm512_setzero_pd();
        let one = _mm512_set1_pd(1.0);
        let inf = _mm512_set1_pd(f64::INFINITY);
        let (sx, sy) = (
            _mm512_set1_pd(self.spacing.x),
            _mm512_set1_pd(self.spacing.y),
        );
        let ox = _mm512_div_pd(rox, sx);
        let oy = _mm512_div_pd(roy, sy);
        let oz = _mm512_sub_pd(roz, _mm512_set1_pd(self.z_offset));
        let dx = _mm512_div_pd(rdx, sx);
        let dy = _mm512_div_pd(rdy, sy);
        let dz = rdz;
        let invx = _mm512_div_pd(one, dx);
        let invy = _mm512_div_pd(one, dy);
        // A component whose reciprocal is not finite folds to an exact zero.
        let finite = |x: __m512d| _mm512_cmp_pd_mask::<_CMP_LT_OQ>(_mm512_abs_pd(x), inf);
        let dx = _mm512_mask_blend_pd(finite(invx), zero, dx);
        let dy = _mm512_mask_blend_pd(finite(invy), zero, dy);
        let mut fail: __mmask8 = 0;
        let mut t0 = zero;
        let mut t1 = inf;
        let ext = self.cells.as_dvec2();
        for (oc, dc, hi, ic) in [(ox, dx, ext.x, invx), (oy, dy, ext.y, invy)] {
            let hi = _mm512_set1_pd(hi);
            let flat = _mm512_cmp_pd_mask::<_CMP_EQ_OQ>(dc, zero);
            let inside = _mm512_cmp_pd_mask::<_CMP_GE_OQ>(oc, zero)
                & _mm512_cmp_pd_mask::<_CMP_LE_OQ>(oc, hi);
            fail |= flat & !inside;
            let a = _mm512_mul_pd(_mm512_sub_pd(zero, oc), ic);
            let b = _mm512_mul_pd(_mm512_sub_pd(hi, oc), ic);
            let n0 = _mm512_max_pd(t0, _mm512_min_pd(a, b));
            let n1 = _mm512_min_pd(t1, _mm512_max_pd(a, b));
            t0 = _mm512_mask_blend_pd(flat, n0, t0);
            t1 = _mm512_mask_blend_pd(flat, n1, t1);
        }
        fail |= _mm512_cmp_pd_mask::<_CMP_UNORD_Q>(t0, t0)
            | _mm512_cmp_pd_mask::<_CMP_UNORD_Q>(t1, t1)
            | _mm512_cmp_pd_mask::<_CMP_GT_OQ>(t0, t1);
        let (zlo, zhi) = self.clip_heights();
        let (zlo, zhi) = (_mm512_set1_pd(zlo), _mm512_set1_pd(zhi));
        let flat = _mm512_cmp_pd_mask::<_CMP_EQ_OQ>(dz, zero);
        let down = _mm512_cmp_pd_mask::<_CMP_LT_OQ>(dz, zero);
        let up = !flat & !down;
        fail |= flat & _mm512_cmp_pd_mask::<_CMP_GT_OQ>(oz, zhi);
        // Descending: enter at the top of the range, end below its bottom.
        let d0 = _mm512_max_pd(t0, _mm512_div_pd(_mm512_sub_pd(zhi, oz), dz));
        fail |= down & _mm512_cmp_pd_mask::<_CMP_GT_OQ>(d0, t1);
        let d1 = _mm512_min_pd(
            t1,
            _mm512_max_pd(d0, _mm512_div_pd(_mm512_sub_pd(zlo, oz), dz)),
        );
        // Ascending: leave at the top of the range.
        let u1 = _mm512_min_pd(t1, _mm512_div_pd(_mm512_sub_pd(zhi, oz), dz));
        fail |= up & _mm512_cmp_pd_mask::<_CMP_GT_OQ>(t0, u1);
        let t0 = _mm512_mask_blend_pd(down, t0, d0);
        let t1 = _mm512_mask_blend_pd(down, _mm512_mask_blend_pd(up, t1, u1), d1);
        let ok = finite(t0) & finite(t1) & _mm512_cmp_pd_mask::<_CMP_LE_OQ>(t0, t1) & !fail;
        // The start node (`mip_start`).
        let lvl = start_level(mip);
        let l = mip.level(lvl);
        let inv = _mm512_set1_pd(f64::from_bits((1023 - lvl as u64) << 52));
        let node = |o: __m512d, d: __m512d, n: i64| {
            let q = _mm512_mul_pd(_mm512_add_pd(o, _mm512_mul_pd(t0, d)), inv);
            // `as i64` saturates: NaN and large negatives clamp to 0 below, large positives
            // (which `cvttpd` turns negative) to the last node.
            let big = _mm512_cmp_pd_mask::<_CMP_GE_OQ>(q, _mm512_set1_pd(i64::MAX as f64));
            let i = _mm512_max_epi64(_mm512_cvttpd_epi64(q), _mm512_setzero_si512());
            let last = _mm512_set1_epi64(n - 1);
            _mm512_mask_blend_epi64(big, _mm512_min_epi64(i, last), last)
        };
        let (ix, iy) = (node(ox, dx, l.w), node(oy, dy, l.h));
        let z0 = _mm512_add_pd(oz, _mm512_mul_pd(t0, dz));
        let top = _mm512_set1_pd(self.zmax);
        // `Walk::start` and `RayTracer::climbs`, in lanes.
        let step = |d: __m512d| {
            let pos = _mm512_cmp_pd_mask::<_CMP_GE_OQ>(d, zero);
            _mm512_mask_blend_epi64(pos, _mm512_set1_epi64(-1), _mm512_set1_epi64(1))
        };
        let steep = _mm512_mul_pd(
            _mm512_set1_pd(self.climb_slope),
            _mm512_max_pd(_mm512_abs_pd(dx), _mm512_abs_pd(dy)),
        );
        *st = Starts {
            first,
            len,
            cur: 0,
            ok,
            test: ok & !_mm512_cmp_pd_mask::<_CMP_GT_OQ>(z0, top),
            ln: Lanes {
                ox,
                oy,
                oz,
                dx,
                dy,
                dz,
                invx,
                invy,
                t1,
                t: t0,
                ix,
                iy,
                lvl: _mm512_set1_epi64(lvl as i64),
                steps: _mm512_setzero_si512(),
                stepx: step(dx),
                stepy: step(dy),
                posx: _mm512_cmp_pd_mask::<_CMP_GT_OQ>(dx, zero),
                posy: _mm512_cmp_pd_mask::<_CMP_GT_OQ>(dy, zero),
                zerox: _mm512_cmp_pd_mask::<_CMP_EQ_OQ>(dx, zero),
                zeroy: _mm512_cmp_pd_mask::<_CMP_EQ_OQ>(dy, zero),
                climb: _mm512_cmp_pd_mask::<_CMP_LE_OQ>(
                    _mm512_xor_pd(dz, _mm512_set1_pd(-0.0)),
                    steep,
                ),
            },
        };
    }

    /// Puts the next ray that needs a walk into lane `k` (its `Trace` reset, start tested);
    /// leaves the lane idle when the rays are used up. Rays are clipped eight at a time
    /// (`starts8`) into `st`.
    #[allow(clippy::too_many_arguments)]
    #[target_feature(enable = "avx512f,avx512dq")]
    #[inline]
    fn refill(
        &self,
        rays: &[Ray],
        mip: &MaxMip<'_>,
        out: &mut [Trace],
        st: &mut Starts,
        k: usize,
        locals: &mut [Option<LocalRay>; PACKET_LANES],
        ray_of: &mut [usize; PACKET_LANES],
        ln: &mut Lanes,
        active: &mut __mmask8,
    ) {
        let bit: __mmask8 = 1 << (k & 7);
        let (Some(lk), Some(rk)) = (locals.get_mut(k), ray_of.get_mut(k)) else {
            return;
        };
        *lk = None;
        // Bounded: each pass hands out one ray (clipping the next batch first where the last is
        // used up), so `rays.len() + 1` passes cover them all.
        for _ in 0..=rays.len() {
            if st.cur >= st.len {
                let first = st.first + st.len;
                if first >= rays.len() {
                    return;
                }
                self.starts8(rays, first, mip, st);
            }
            let j = st.cur;
            st.cur += 1;
            let r = st.first + j;
            let (Some(ray), Some(o)) = (rays.get(r), out.get_mut(r)) else {
                return;
            };
            *o = Trace::default();
            let jb = 1u8 << (j & 7);
            if st.ok & jb == 0 {
                continue;
            }
            if st.test & jb != 0 {
                let Some(lr) = st.local(j) else {
                    continue;
                };
                if let Some(hit) = self.start_hit(ray, &lr) {
                    o.cells = 1;
                    o.hit = Some(hit);
                    continue;
                }
            }
            ln.take(bit, &st.ln, j);
            // The scalar cell tests of the other surfaces take the lane's clipped ray.
            if self.surface != Surface::Triangles {
                *lk = st.local(j);
            }
            *rk = r;
            *active |= bit;
            return;
        }
    }
}
