//! Yardstick, not library code: camera rays traced sixteen at a time as one *coherent packet*
//! (a 4 x 4 tile of pixels, one ray per `f32` lane of an AVX-512 register) through the maximum
//! mipmap taken as a 16-ary hierarchy (two pyramid levels a node, as `mip_sixteen`), against
//! the library's AVX-512 packets (`RayTracer::trace_maxmip_packet_avx512`: eight independent
//! rays in lanes, each in its own node) on the same rays, on the bundled Puget grid's Embree
//! views (`common::embree_views`, and `common::low_view`: `embree_trace.py`'s low flight).
//!
//! The packet walks the hierarchy once for all its rays (Wald, Slusallek, Benthin, Wagner,
//! *Interactive Rendering with Coherent Ray Tracing*, 2001, there for BVHs): a node tests each
//! of its sixteen children against all sixteen rays at once, in `f32` with `mip_sixteen`'s
//! margins (`1e-3` on heights, `1e-5` relative on the parameter), giving each child the mask of
//! the rays that may reach its maximum inside it; the walk goes depth first into the children
//! that any ray may reach, with only those rays. The children are taken in the order of
//! `common::Order` for the packet's direction quadrant: by anti-diagonal from the corner the
//! rays enter by. For rays that share the signs of their x and y directions, that order is
//! front to back for every one of them (a ray's path visits cells, and nodes of every level,
//! that form a chain in the componentwise order of the flipped coordinates, and a depth-first
//! walk by anti-diagonals visits any such chain in order), so a ray's first cell hit is its
//! nearest and the ray leaves the packet there. A tile whose rays differ in those signs is
//! walked once per quadrant, each time with the rays of that quadrant. Cells are tested one ray
//! at a time by `LocalGrid::cell_pieces` (exact in `f64`). Hits are compared with the library's
//! `trace_maxmip` to `1e-4` relative distance.
//!
//! Timing: chunks of 4096 rays (256 tiles), each traced 9 times, the fastest summed (the CLI's
//! `--chunk-rays 4096 --chunk-reps 9` protocol), the three sides alternated chunk by chunk: the
//! yardstick on tile-ordered rays, the library's AVX-512 packets on the same tile-ordered rays,
//! and the library's packets on the image's row order (what `relief trace` gives them); the
//! fastest of `RUNS` (default 3) such passes. The last line gives nodes, cells and passes
//! (children taken) per ray. `TILE=16x1` (or `8x2`, `2x8`; default `4x4`) sets the tile's
//! shape; `NO_CELL_TESTS=1` times the walk without its cell tests (see [`Tracer::no_cells`]).
//! Results: BENCHMARKS.md, "Coherent packets of sixteen rays through the 16-ary pyramid".
//!
//! `cargo run --release -p relief-benches --example mip_packet` (needs AVX-512 F, BW, VL)

mod common;

use relief_core::ray::{MaxMip, Ray, RayTracer, Trace};
use relief_core::{Heightfield, Surface};
use std::arch::x86_64::*;
use std::cell::Cell;
use std::hint::black_box;
use std::time::Instant;

/// Image size of `common::embree_views`.
const W: usize = 384;
const H: usize = 256;

fn arr16(v: __m512) -> [f32; 16] {
    // SAFETY: as in `vec16`.
    unsafe { std::mem::transmute(v) }
}

fn arr8(v: __m512d) -> [f64; 8] {
    // SAFETY: as in `vec16`.
    unsafe { std::mem::transmute(v) }
}

fn vec16(a: [f32; 16]) -> __m512 {
    // SAFETY: `__m512` and `[f32; 16]` have the same size, and every bit pattern is valid.
    unsafe { std::mem::transmute(a) }
}

/// Sixteen rays in lanes (grid-local units).
struct Packet {
    oz: __m512,
    dz: __m512,
    invx: __m512,
    invy: __m512,
    /// `-o inv` per axis: a plane `X` is crossed at `X inv - o inv`.
    nox: __m512,
    noy: __m512,
    t0: __m512,
    t1: __m512,
    eps: __m512,
    /// The descending rays.
    down: u16,
    /// The rays, the `f64` inverses of their x and y components, and their clipped intervals,
    /// for the cell tests.
    o: [[f32; 3]; 16],
    d: [[f32; 3]; 16],
    inv64: [[f64; 16]; 2],
    span: [(f32, f32); 16],
}

impl Packet {
    /// Lane `k`'s ray in `f64` (`common::Ray64::new`'s values, the inverses computed once).
    fn ray64(&self, k: usize) -> common::Ray64 {
        common::Ray64 {
            o: self.o[k].map(f64::from),
            d: self.d[k].map(f64::from),
            inv: [self.inv64[0][k], self.inv64[1][k]],
        }
    }
}

struct Tracer {
    g: common::LocalGrid,
    /// `levels[j]` holds the maxima of pyramid level `2j` in Morton order.
    levels: Vec<Vec<f32>>,
    /// Pyramid levels of the root (even).
    n: u32,
    orders: [common::Order; 4],
    /// `NO_CELL_TESTS=1`: the first cell a ray may reach counts as its hit, without a test,
    /// to time the walk alone (the hits then differ).
    no_cells: bool,
    nodes: Cell<u64>,
    cells: Cell<u64>,
    pops: Cell<u64>,
}

/// A node on the walk's stack: its level, block position, Morton index, the children left to
/// visit (bits in crossing order) and each child's ray mask.
#[derive(Clone, Copy)]
struct Entry {
    level: u32,
    ix: u32,
    iy: u32,
    m: u32,
    pending: u32,
    masks: [u16; 16],
}

impl Tracer {
    fn new(g: common::LocalGrid) -> Tracer {
        let (cw, ch) = (g.w - 1, g.h - 1);
        let mut n = cw.max(ch).next_power_of_two().trailing_zeros();
        n += n & 1;
        // Groups of 16: the even levels, the 16-ary hierarchy's.
        let levels = common::morton_levels(&g, n, 16);
        let orders = [(false, false), (true, false), (false, true), (true, true)]
            .map(|(fx, fy)| common::Order::new(fx, fy));
        Tracer {
            g,
            levels,
            n,
            orders,
            no_cells: std::env::var("NO_CELL_TESTS").is_ok_and(|v| v == "1"),
            nodes: Cell::new(0),
            cells: Cell::new(0),
            pops: Cell::new(0),
        }
    }

    /// Traces the rays `rays` (up to sixteen) into `out` (hit parameters).
    #[target_feature(enable = "avx512f,avx512bw,avx512vl")]
    fn trace_tile(&self, rays: &[&common::MipRay], out: &mut [Option<f64>]) {
        let (p, quad) = self.setup_lanes(rays);
        out.iter_mut().take(16).for_each(|o| *o = None);
        for (q, &lanes) in quad.iter().enumerate() {
            if lanes != 0 {
                self.walk(&p, &self.orders[q], lanes, out);
            }
        }
    }

    /// The packet of `rays` (up to sixteen) and its rays by direction quadrant:
    /// `common::finite_inverse` and `LocalGrid::clip` with the same operations, sixteen rays at
    /// once (about 5% faster in all than ray by ray).
    #[target_feature(enable = "avx512f,avx512bw,avx512vl")]
    fn setup_lanes(&self, rays: &[&common::MipRay]) -> (Packet, [u16; 4]) {
        let (mut o16, mut d16) = ([[0.0f32; 3]; 16], [[0.0f32; 3]; 16]);
        let mut c = [[0.0f32; 16]; 6];
        for (k, r) in rays.iter().enumerate().take(16) {
            (o16[k], d16[k]) = (r.o, r.d);
            (c[0][k], c[1][k], c[2][k]) = (r.o[0], r.o[1], r.o[2]);
            (c[3][k], c[4][k], c[5][k]) = (r.d[0], r.d[1], r.d[2]);
        }
        let used = (1u32 << rays.len().min(16)).wrapping_sub(1) as u16;
        let [ox, oy, oz, dx, dy, dz] = c.map(vec16);
        let zero = _mm512_setzero_ps();
        let inv = |d: __m512| {
            let big = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(_mm512_abs_ps(d), _mm512_set1_ps(1e-20));
            // `copysign(1e20, d)`: the sign bit of `d` on `1e20`.
            let sign = _mm512_and_si512(_mm512_castps_si512(d), _mm512_set1_epi32(i32::MIN));
            let far = _mm512_castsi512_ps(_mm512_or_si512(
                sign,
                _mm512_castps_si512(_mm512_set1_ps(1e20)),
            ));
            _mm512_mask_div_ps(far, big, _mm512_set1_ps(1.0), d)
        };
        let (invx, invy) = (inv(dx), inv(dy));
        let mut t0 = zero;
        let mut t1 = _mm512_set1_ps(f32::INFINITY);
        let mut ok = used;
        for (o, d, iv, hi) in [(ox, dx, invx, self.g.cw), (oy, dy, invy, self.g.ch)] {
            let flat = _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(d, zero);
            let inside = _mm512_cmp_ps_mask::<_CMP_GE_OQ>(o, zero)
                & _mm512_cmp_ps_mask::<_CMP_LE_OQ>(o, _mm512_set1_ps(hi));
            ok &= !flat | inside;
            let a = _mm512_mul_ps(_mm512_sub_ps(zero, o), iv);
            let b = _mm512_mul_ps(_mm512_sub_ps(_mm512_set1_ps(hi), o), iv);
            t0 = _mm512_mask_max_ps(t0, !flat, t0, _mm512_min_ps(a, b));
            t1 = _mm512_mask_min_ps(t1, !flat, t1, _mm512_max_ps(a, b));
        }
        let down = _mm512_cmp_ps_mask::<_CMP_LT_OQ>(dz, zero);
        let up = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(dz, zero);
        let top = _mm512_div_ps(_mm512_sub_ps(_mm512_set1_ps(self.g.zhi), oz), dz);
        let bottom = _mm512_div_ps(_mm512_sub_ps(_mm512_set1_ps(self.g.zlo - 1.0), oz), dz);
        t0 = _mm512_mask_max_ps(t0, down, t0, top);
        t1 = _mm512_mask_min_ps(t1, down, t1, bottom);
        t1 = _mm512_mask_min_ps(t1, up, t1, top);
        ok &= !(!down & !up & _mm512_cmp_ps_mask::<_CMP_GT_OQ>(oz, _mm512_set1_ps(self.g.zhi)));
        // Not NaN, not empty.
        ok &= _mm512_cmp_ps_mask::<_CMP_LE_OQ>(t0, t1);
        let keep = |v: __m512| _mm512_maskz_mov_ps(ok, v);
        let negx = _mm512_cmp_ps_mask::<_CMP_LT_OQ>(dx, zero);
        let negy = _mm512_cmp_ps_mask::<_CMP_LT_OQ>(dy, zero);
        let quad = [
            ok & !negx & !negy,
            ok & negx & !negy,
            ok & !negx & negy,
            ok & negx & negy,
        ];
        let (t0a, t1a): ([f32; 16], [f32; 16]) = (arr16(t0), arr16(t1));
        let p = Packet {
            oz: keep(oz),
            dz: keep(dz),
            invx: keep(invx),
            invy: keep(invy),
            nox: keep(_mm512_mul_ps(_mm512_sub_ps(zero, ox), invx)),
            noy: keep(_mm512_mul_ps(_mm512_sub_ps(zero, oy), invy)),
            t0,
            t1,
            eps: _mm512_mul_ps(
                _mm512_set1_ps(1e-5),
                _mm512_max_ps(_mm512_abs_ps(t1), _mm512_set1_ps(1.0)),
            ),
            down: down & ok,
            o: o16,
            d: d16,
            inv64: [dx, dy].map(|d| {
                let one = _mm512_set1_pd(1.0);
                let lo = _mm512_div_pd(one, _mm512_cvtps_pd(_mm512_castps512_ps256(d)));
                let hi = _mm512_div_pd(
                    one,
                    _mm512_cvtps_pd(_mm256_castpd_ps(_mm512_extractf64x4_pd::<1>(
                        _mm512_castps_pd(d),
                    ))),
                );
                let (lo, hi): ([f64; 8], [f64; 8]) = (arr8(lo), arr8(hi));
                std::array::from_fn(|k| if k < 8 { lo[k] } else { hi[k - 8] })
            }),
            span: std::array::from_fn(|k| (t0a[k], t1a[k])),
        };
        (p, quad)
    }

    /// The children of node `(level, ix, iy)` (Morton index `m`) that each ray of `lanes` may
    /// reach below their maxima: masks in crossing order, and the children with any ray.
    #[target_feature(enable = "avx512f,avx512bw,avx512vl")]
    #[inline]
    fn node(
        &self,
        p: &Packet,
        ord: &common::Order,
        (level, ix, iy, m): (u32, u32, u32, u32),
        lanes: u16,
    ) -> ([u16; 16], u32) {
        self.nodes.set(self.nodes.get() + 1);
        let mut masks = [0u16; 16];
        let base = 16 * m as usize;
        let Some(mx) = self.levels[(level / 2 - 1) as usize].get(base..base + 16) else {
            return (masks, 0);
        };
        let s = (1u32 << (level - 2)) as f32;
        let (x0, y0) = ((4 * ix) as f32 * s, (4 * iy) as f32 * s);
        // Each ray's interval inside column `c` (row `r`), clipped to its segment.
        let mut ax = [_mm512_setzero_ps(); 4];
        let mut bx = [_mm512_setzero_ps(); 4];
        let mut ay = [_mm512_setzero_ps(); 4];
        let mut by = [_mm512_setzero_ps(); 4];
        let mut px = _mm512_fmadd_ps(_mm512_set1_ps(x0), p.invx, p.nox);
        let mut py = _mm512_fmadd_ps(_mm512_set1_ps(y0), p.invy, p.noy);
        for c in 0..4 {
            let qx = _mm512_fmadd_ps(_mm512_set1_ps(x0 + (c + 1) as f32 * s), p.invx, p.nox);
            let qy = _mm512_fmadd_ps(_mm512_set1_ps(y0 + (c + 1) as f32 * s), p.invy, p.noy);
            ax[c] = _mm512_max_ps(_mm512_min_ps(px, qx), p.t0);
            bx[c] = _mm512_min_ps(_mm512_max_ps(px, qx), p.t1);
            ay[c] = _mm512_max_ps(_mm512_min_ps(py, qy), p.t0);
            by[c] = _mm512_min_ps(_mm512_max_ps(py, qy), p.t1);
            (px, py) = (qx, qy);
        }
        // The maxima in crossing order, with the margin.
        let mut mxo = [0.0f32; 16];
        for (v, &k) in mxo.iter_mut().zip(&ord.morton) {
            *v = mx[k] + 1e-3;
        }
        for (j, mask) in masks.iter_mut().enumerate() {
            let (c, r) = (ord.ix[j] as usize, ord.iy[j] as usize);
            let ta = _mm512_max_ps(ax[c], ay[r]);
            let tb = _mm512_min_ps(bx[c], by[r]);
            // The lowest point: at the exit for a descending ray, else at the entry.
            let low = _mm512_fmadd_ps(p.dz, _mm512_mask_blend_ps(p.down, ta, tb), p.oz);
            let open = _mm512_mask_cmp_ps_mask::<_CMP_LE_OQ>(lanes, ta, _mm512_add_ps(tb, p.eps));
            *mask = _mm512_mask_cmp_ps_mask::<_CMP_LE_OQ>(open, low, _mm512_set1_ps(mxo[j]));
        }
        // The children with any ray: one compare of the sixteen masks.
        // SAFETY: `[u16; 16]` and `__m256i` have the same size, every bit pattern valid.
        let mv = unsafe { std::mem::transmute::<[u16; 16], __m256i>(masks) };
        let pending = u32::from(_mm256_cmpneq_epi16_mask(mv, _mm256_setzero_si256()));
        (masks, pending)
    }

    /// The depth-first walk of the rays `lanes`, all in the quadrant of `ord`.
    #[target_feature(enable = "avx512f,avx512bw,avx512vl")]
    fn walk(&self, p: &Packet, ord: &common::Order, lanes: u16, out: &mut [Option<f64>]) {
        let mut active = lanes;
        let (masks, pending) = self.node(p, ord, (self.n, 0, 0, 0), active);
        let root = Entry {
            level: self.n,
            ix: 0,
            iy: 0,
            m: 0,
            pending,
            masks,
        };
        // One entry a node level: a child is entered only after its parent's entry.
        let mut stack = [root; 16];
        let mut sp = 0usize;
        // Bounded: each node is entered at most once a quadrant.
        loop {
            let e = &mut stack[sp];
            if e.pending == 0 {
                if sp == 0 {
                    break;
                }
                sp -= 1;
                continue;
            }
            let j = e.pending.trailing_zeros() as usize;
            e.pending &= e.pending - 1;
            self.pops.set(self.pops.get() + 1);
            let rays = e.masks[j] & active;
            if rays == 0 {
                continue;
            }
            let (ix, iy) = (4 * e.ix + ord.ix[j], 4 * e.iy + ord.iy[j]);
            let (m, level) = (16 * e.m + ord.morton[j] as u32, e.level - 2);
            if level == 0 {
                let mut left = rays;
                while left != 0 {
                    let k = left.trailing_zeros() as usize;
                    left &= left - 1;
                    self.cells.set(self.cells.get() + 1);
                    let (a, b) = p.span[k];
                    let hit = if self.no_cells {
                        Some(f64::from(a))
                    } else {
                        self.g
                            .cell_pieces(&p.ray64(k), ix as usize, iy as usize, a, b)
                    };
                    if let Some(t) = hit {
                        out[k] = Some(t);
                        active &= !(1 << k);
                    }
                }
                if active == 0 {
                    return;
                }
                continue;
            }
            let (masks, pending) = self.node(p, ord, (level, ix, iy, m), rays);
            if pending != 0 && sp + 1 < stack.len() {
                sp += 1;
                stack[sp] = Entry {
                    level,
                    ix,
                    iy,
                    m,
                    pending,
                    masks,
                };
            }
        }
    }
}

/// The pixels of the image in tiles of `tw x th` pixels (`tw th = 16`), tile by tile in row
/// order.
fn tile_order(tw: usize, th: usize) -> Vec<usize> {
    let mut v = Vec::with_capacity(W * H);
    for ty in (0..H).step_by(th) {
        for tx in (0..W).step_by(tw) {
            for y in ty..ty + th {
                for x in tx..tx + tw {
                    v.push(y * W + x);
                }
            }
        }
    }
    v
}

fn main() {
    assert!(
        std::arch::is_x86_feature_detected!("avx512f"),
        "mip_packet needs AVX-512 F"
    );
    let runs = common::runs(3);
    let dem = common::puget();
    let (w, h) = (dem.width, dem.height);
    let hf = Heightfield::with_scale(&dem.samples, w, h, dem.scale).unwrap();
    let y = Tracer::new(common::LocalGrid::of(&hf));
    let mut buf = vec![0.0f32; MaxMip::len(w, h).unwrap()];
    let mip = MaxMip::build(&hf, &mut buf).unwrap();
    let tracer = RayTracer::new(&hf, Surface::Triangles);
    // `TILE=WxH` (default 4x4): the tile's shape, 16 pixels.
    let tile = std::env::var("TILE").unwrap_or_else(|_| "4x4".into());
    let (tw, th) = match tile.as_str() {
        "16x1" => (16, 1),
        "8x2" => (8, 2),
        "2x8" => (2, 8),
        _ => (4, 4),
    };
    println!("tiles of {tw} x {th} pixels");
    let order = tile_order(tw, th);
    let (mut nrays, mut ncells, mut nnodes, mut npops) = (0u64, 0u64, 0u64, 0u64);
    let mut views = common::embree_views(&dem);
    views.push(common::low_view(&dem));
    for (name, rays) in views {
        let tiled: Vec<&common::MipRay> = order.iter().map(|&i| &rays[i]).collect();
        let lib_tiled: Vec<Ray> = tiled.iter().map(|r| r.ray).collect();
        let lib_rows: Vec<Ray> = rays.iter().map(|r| r.ray).collect();
        // Hits against the library's ray-by-ray walk.
        let mut mine = vec![None; tiled.len()];
        let (n0, c0, p0) = (y.nodes.get(), y.cells.get(), y.pops.get());
        for (c, o) in tiled.chunks(16).zip(mine.chunks_mut(16)) {
            // SAFETY: `main` checked that the CPU has AVX-512 F.
            unsafe { y.trace_tile(c, o) };
        }
        let (agree, both_miss, differ) =
            common::agreement(tiled.iter().zip(&mine).map(|(r, &t)| {
                (
                    tracer.trace_maxmip(&r.ray, &mip).unwrap().hit.map(|h| h.t),
                    t,
                )
            }));
        nrays += tiled.len() as u64;
        nnodes += y.nodes.get() - n0;
        ncells += y.cells.get() - c0;
        npops += y.pops.get() - p0;
        let mut out = vec![Trace::default(); 4096];
        let mut tout = vec![None; 16 * 256];
        let (mut best_y, mut best_t, mut best_r) = (f64::INFINITY, f64::INFINITY, f64::INFINITY);
        for _ in 0..runs {
            let (mut sy, mut st, mut sr) = (0.0, 0.0, 0.0);
            for (k, c) in tiled.chunks(4096).enumerate() {
                let (mut fy, mut ft, mut fr) = (f64::INFINITY, f64::INFINITY, f64::INFINITY);
                let lt = &lib_tiled[k * 4096..(k * 4096 + c.len())];
                let lr = &lib_rows[k * 4096..(k * 4096 + c.len())];
                for _ in 0..9 {
                    let s = Instant::now();
                    for (cc, o) in c.chunks(16).zip(tout.chunks_mut(16)) {
                        // SAFETY: as above.
                        unsafe { y.trace_tile(cc, o) };
                    }
                    black_box(&tout);
                    fy = fy.min(s.elapsed().as_secs_f64());
                    let s = Instant::now();
                    // SAFETY: as above.
                    unsafe { tracer.trace_maxmip_packet_avx512(lt, &mip, &mut out[..c.len()]) }
                        .unwrap();
                    black_box(&out);
                    ft = ft.min(s.elapsed().as_secs_f64());
                    let s = Instant::now();
                    // SAFETY: as above.
                    unsafe { tracer.trace_maxmip_packet_avx512(lr, &mip, &mut out[..c.len()]) }
                        .unwrap();
                    black_box(&out);
                    fr = fr.min(s.elapsed().as_secs_f64());
                }
                (sy, st, sr) = (sy + fy, st + ft, sr + fr);
            }
            (best_y, best_t, best_r) = (best_y.min(sy), best_t.min(st), best_r.min(sr));
        }
        let m = tiled.len() as f64 / 1e6;
        println!(
            "{name:8} hits agree {agree} (both miss {both_miss}), differ {differ} | chunked M rays/s: coherent packets {:.2}, library packets tiled {:.2} ({:.2}x), rows {:.2} ({:.2}x)",
            m / best_y,
            m / best_t,
            best_t / best_y,
            m / best_r,
            best_r / best_y
        );
    }
    // Counts of the first (untimed) pass of each view.
    println!(
        "nodes/ray, cells/ray and pops/ray over the untimed passes: {:.2} {:.2} {:.2}",
        nnodes as f64 / nrays as f64,
        ncells as f64 / nrays as f64,
        npops as f64 / nrays as f64
    );
}
