//! Yardstick, not library code: the maximum mipmap traversed as a 4-ary bounding volume
//! hierarchy (the way Embree traverses its BVH), against `RayTracer::trace_maxmip` (Tevs et
//! al.'s neighbour walk, exact `f64` decisions) on the same rays. The case is the `triangles`
//! surface on the bundled Puget grid (1024 x 1024 cells, a power of two).
//!
//! The question it answers (issue 4): the neighbour walk's step is a chain (slabs, then the
//! entry parameter, then the child's index, then the next slabs), and `mip_lean` showed that a
//! lean `f32` version of it gains only 1.1-1.3x. A hierarchy traversal instead tests a node's
//! four children at once (the compiler makes it four-lane SSE): their slabs share three planes
//! per axis (six products a node), entry and exit planes are picked by the ray's signs, the
//! four maxima are one 16-byte load in Morton order (the node carries its Morton index), and
//! the hit children go on a small stack nearest first; children that are cells are tested in
//! place, nearest first. The first cell hit ends the ray (the children do not overlap in x and
//! y, so every node left on the stack lies further along the ray). Decisions are `f32` with a
//! margin (a child is entered when the ray's lowest point over it is within `1e-3` of its
//! maximum and its slab interval, widened by `1e-5` relative, is not empty); cells are tested
//! as in `mip_lean`: `f64` Moller-Trumbore on the two triangles. Hits are compared with the
//! library's to `1e-4` relative distance, the tolerance of the Embree comparison. Views: the
//! camera and grazing views of `bench-peers/embree_rays.sh` on Puget, 384 x 256 rays, the two
//! tracers interleaved pass by pass (fastest of `RUNS`, default 9), then in the Embree
//! script's chunks (4096 rays, fastest of 9 each, summed). Then packets: sixteen rays of a
//! 4 x 4 pixel tile walk the hierarchy together (`Tracer::trace_packet`, built for AVX-512
//! where the CPU has it) against the library's AVX-512 packets and its single-ray walk, the
//! rays in tile order on every side.
//!
//! `cargo run --release -p relief-benches --example mip_quad`

mod common;

/// A complete quadtree of cell maxima over a `2^n x 2^n` domain, each level in Morton order
/// (the four children of node `m` are `4m .. 4m + 4`); cells outside the grid are `-inf`.
struct Quad {
    /// `levels[l]`: `4^(n - l)` maxima; level 0 holds the cells.
    levels: Vec<Vec<f32>>,
    n: u32,
}

impl Quad {
    fn new(g: &common::LocalGrid) -> Quad {
        let (cw, ch) = (g.w - 1, g.h - 1);
        let n = cw.max(ch).next_power_of_two().trailing_zeros();
        let levels = common::morton_levels(g, n, 4);
        Quad { levels, n }
    }
}

struct Tracer {
    g: common::LocalGrid,
    quad: Quad,
}

/// A node on the stack: level, cell-space index, Morton index and its parameter interval.
#[derive(Clone, Copy, Default)]
struct Entry {
    level: u32,
    ix: u32,
    iy: u32,
    m: u32,
    ta: f32,
    tb: f32,
}

impl common::LocalTracer for Tracer {
    /// The hit parameter of local ray `o + t d` (`t` as for the world ray), or `None`.
    fn trace(&self, o: [f32; 3], d: [f32; 3]) -> Option<f64> {
        let inv = [common::finite_inverse(d[0]), common::finite_inverse(d[1])];
        let (t0, t1) = self.g.clip(o, d, inv)?;
        let down = d[2] < 0.0;
        let (fx, fy) = (usize::from(d[0] < 0.0), usize::from(d[1] < 0.0));
        let near = fx | fy << 1;
        let eps = 1e-5 * t1.abs().max(1.0);
        let mut stack = [Entry::default(); 64];
        stack[0] = Entry {
            level: self.quad.n,
            ix: 0,
            iy: 0,
            m: 0,
            ta: t0,
            tb: t1,
        };
        let mut sp = 1usize;
        // Bounded: every node is pushed at most once (a tree has fewer than 2 (4^n) nodes).
        while sp > 0 {
            sp -= 1;
            let e = stack[sp];
            if e.level == 0 {
                let (x, y) = (e.ix as usize, e.iy as usize);
                if let Some(t) = self.g.cell(o, d, x, y, e.ta - eps, e.tb + eps) {
                    return Some(t);
                }
                continue;
            }
            // The children's entry and exit parameters per axis, by the ray's signs (no
            // min/max): column cx enters at plane cx + fx and leaves at plane cx + 1 - fx.
            let l = e.level - 1;
            let s = (1u32 << l) as f32;
            let (x0, y0) = ((2 * e.ix) as f32 * s, (2 * e.iy) as f32 * s);
            let px = [x0 - o[0], x0 + s - o[0], x0 + 2.0 * s - o[0]];
            let py = [y0 - o[1], y0 + s - o[1], y0 + 2.0 * s - o[1]];
            let tx = [px[0] * inv[0], px[1] * inv[0], px[2] * inv[0]];
            let ty = [py[0] * inv[1], py[1] * inv[1], py[2] * inv[1]];
            let (ex, xx) = if fx == 0 {
                ([tx[0], tx[1]], [tx[1], tx[2]])
            } else {
                ([tx[1], tx[2]], [tx[0], tx[1]])
            };
            let (ey, xy) = if fy == 0 {
                ([ty[0], ty[1]], [ty[1], ty[2]])
            } else {
                ([ty[1], ty[2]], [ty[0], ty[1]])
            };
            let base = 4 * e.m as usize;
            let Some(maxima) = self.quad.levels[l as usize].get(base..base + 4) else {
                continue;
            };
            let mut ta = [0.0f32; 4];
            let mut tb = [0.0f32; 4];
            let mut hit = [false; 4];
            for c in 0..4 {
                let (cx, cy) = (c & 1, c >> 1);
                ta[c] = ex[cx].max(ey[cy]).max(e.ta);
                tb[c] = xx[cx].min(xy[cy]).min(e.tb);
                let low = o[2] + d[2] * if down { tb[c] } else { ta[c] };
                hit[c] = (ta[c] <= tb[c] + eps) & (low <= maxima[c] + 1e-3);
            }
            // The children in ray order: the one at the entry corner, then the two sides
            // (the one across the first mid-line crossed first), then the far one. Pushed in
            // reverse, so the nearest is on top.
            let (sa, sb) = if tx[1] <= ty[1] {
                (near ^ 1, near ^ 2)
            } else {
                (near ^ 2, near ^ 1)
            };
            if l == 0 {
                // The children are cells: test them here, nearest first.
                for c in [near, sa, sb, near ^ 3] {
                    if hit[c] {
                        let (x, y) = (
                            (2 * e.ix) as usize + (c & 1),
                            (2 * e.iy) as usize + (c >> 1),
                        );
                        if let Some(t) = self.g.cell(o, d, x, y, ta[c] - eps, tb[c] + eps) {
                            return Some(t);
                        }
                    }
                }
                continue;
            }
            for c in [near ^ 3, sb, sa, near] {
                if hit[c] && sp < stack.len() {
                    stack[sp] = Entry {
                        level: l,
                        ix: 2 * e.ix + (c & 1) as u32,
                        iy: 2 * e.iy + (c >> 1) as u32,
                        m: (base + c) as u32,
                        ta: ta[c],
                        tb: tb[c],
                    };
                    sp += 1;
                }
            }
        }
        None
    }
}

/// Lanes of a packet: 16 rays of a 4 x 4 pixel tile.
const L: usize = 16;

impl Tracer {
    /// Traces `rays` (a tile of [`L`]) together: every node's four children are tested
    /// against all the packet's rays at once (`L` lanes of each operation), a child is entered
    /// when any ray enters it, and each ray keeps the nearest hit found so far, which clips its
    /// later tests; the packet ends when the stack is empty. Packets whose rays do not share
    /// the signs of their x and y directions take the single-ray walk.
    #[inline(always)]
    fn trace_packet(&self, rays: &[&common::MipRay; L], out: &mut [Option<f64>; L]) {
        use common::LocalTracer;
        let mut o = [[0.0f32; L]; 3];
        let mut d = [[0.0f32; L]; 3];
        let mut inv = [[0.0f32; L]; 2];
        let (mut t0, mut cap, mut eps) = ([f32::INFINITY; L], [f32::NEG_INFINITY; L], [0.0f32; L]);
        let (mut neg_x, mut neg_y) = (0u32, 0u32);
        for (k, r) in rays.iter().enumerate() {
            out[k] = None;
            let iv = [
                common::finite_inverse(r.d[0]),
                common::finite_inverse(r.d[1]),
            ];
            for a in 0..3 {
                o[a][k] = r.o[a];
                d[a][k] = r.d[a];
            }
            inv[0][k] = iv[0];
            inv[1][k] = iv[1];
            if let Some((a, b)) = self.g.clip(r.o, r.d, iv) {
                (t0[k], cap[k]) = (a, b);
                eps[k] = 1e-5 * b.abs().max(1.0);
            }
            neg_x += u32::from(r.d[0] < 0.0);
            neg_y += u32::from(r.d[1] < 0.0);
        }
        if !(neg_x == 0 || neg_x == L as u32) || !(neg_y == 0 || neg_y == L as u32) {
            for (k, r) in rays.iter().enumerate() {
                out[k] = self.trace(r.o, r.d);
            }
            return;
        }
        let (fx, fy) = (usize::from(neg_x > 0), usize::from(neg_y > 0));
        let near = fx | fy << 1;
        let max_ = |a: f32, b: f32| if a > b { a } else { b };
        let min_ = |a: f32, b: f32| if a < b { a } else { b };
        // (level, ix, iy, Morton index)
        let mut stack = [(0u32, 0u32, 0u32, 0u32); 64];
        stack[0] = (self.quad.n, 0, 0, 0);
        let mut sp = 1usize;
        // Bounded: every node is pushed at most once.
        while sp > 0 {
            sp -= 1;
            let (level, ix, iy, m) = stack[sp];
            let l = level - 1;
            let s = (1u32 << l) as f32;
            let (x0, y0) = ((2 * ix) as f32 * s, (2 * iy) as f32 * s);
            // Plane parameters: tx[p][k] for the planes x0 + p s.
            let mut tx = [[0.0f32; L]; 3];
            let mut ty = [[0.0f32; L]; 3];
            for p in 0..3 {
                for k in 0..L {
                    tx[p][k] = (x0 + p as f32 * s - o[0][k]) * inv[0][k];
                    ty[p][k] = (y0 + p as f32 * s - o[1][k]) * inv[1][k];
                }
            }
            let base = 4 * m as usize;
            let Some(maxima) = self.quad.levels[l as usize].get(base..base + 4) else {
                continue;
            };
            let mut ta = [[0.0f32; L]; 4];
            let mut tb = [[0.0f32; L]; 4];
            let mut mask = [0u32; 4];
            for c in 0..4 {
                let (cx, cy) = (c & 1, c >> 1);
                let (ex, xx) = (&tx[cx + fx], &tx[cx + 1 - fx]);
                let (ey, xy) = (&ty[cy + fy], &ty[cy + 1 - fy]);
                let max = maxima[c] + 1e-3;
                let mut bits = 0u32;
                for k in 0..L {
                    let a = max_(max_(ex[k], ey[k]), t0[k]);
                    let b = min_(min_(xx[k], xy[k]), cap[k]);
                    let tz = if d[2][k] < 0.0 { b } else { a };
                    let low = o[2][k] + d[2][k] * tz;
                    bits |= u32::from((a <= b + eps[k]) & (low <= max)) << k;
                    ta[c][k] = a;
                    tb[c][k] = b;
                }
                mask[c] = bits;
            }
            let (sa, sb) = if tx[1][0] <= ty[1][0] {
                (near ^ 1, near ^ 2)
            } else {
                (near ^ 2, near ^ 1)
            };
            if l == 0 {
                // Cells: each lane's own test; a hit clips that lane's later tests.
                for c in [near, sa, sb, near ^ 3] {
                    let mut bits = mask[c];
                    while bits != 0 {
                        let k = bits.trailing_zeros() as usize;
                        bits &= bits - 1;
                        let (x, y) = ((2 * ix) as usize + (c & 1), (2 * iy) as usize + (c >> 1));
                        let (a, b) = (ta[c][k] - eps[k], tb[c][k] + eps[k]);
                        if let Some(t) = self.g.cell(rays[k].o, rays[k].d, x, y, a, b) {
                            if out[k].is_none_or(|u| t < u) {
                                out[k] = Some(t);
                                cap[k] = min_(cap[k], t as f32);
                            }
                        }
                    }
                }
                continue;
            }
            for c in [near ^ 3, sb, sa, near] {
                if mask[c] != 0 && sp < stack.len() {
                    let (cx, cy) = ((c & 1) as u32, (c >> 1) as u32);
                    stack[sp] = (l, 2 * ix + cx, 2 * iy + cy, (base + c) as u32);
                    sp += 1;
                }
            }
        }
    }

    /// [`Tracer::trace_packet`] compiled for AVX-512 (sixteen `f32` lanes a register).
    ///
    /// # Safety
    /// The CPU must have AVX-512 F.
    #[target_feature(enable = "avx512f")]
    unsafe fn trace_packet_avx512(&self, rays: &[&common::MipRay; L], out: &mut [Option<f64>; L]) {
        self.trace_packet(rays, out)
    }
}

/// The views' rays in 4 x 4 pixel tiles (the image is 384 x 256).
fn tiles(rays: &[common::MipRay]) -> Vec<[&common::MipRay; L]> {
    let mut v = Vec::new();
    for ty in 0..256 / 4 {
        for tx in 0..384 / 4 {
            v.push(std::array::from_fn(|k| {
                &rays[(ty * 4 + k / 4) * 384 + tx * 4 + k % 4]
            }));
        }
    }
    v
}

/// Packets of the hierarchy walk against the library's AVX-512 packets and ray by ray, the
/// rays in tile order on every side, fastest of 9 passes each, interleaved.
fn packets(qt: &Tracer) {
    use relief_core::ray::{MaxMip, RayTracer, Trace};
    use std::hint::black_box;
    use std::time::Instant;
    let avx512 = std::arch::is_x86_feature_detected!("avx512f")
        && std::arch::is_x86_feature_detected!("avx512dq");
    let dem = common::puget();
    let (w, h) = (dem.width, dem.height);
    let hf = relief_core::Heightfield::with_scale(&dem.samples, w, h, dem.scale).unwrap();
    let mut buf = vec![0.0f32; MaxMip::len(w, h).unwrap()];
    let mip = MaxMip::build(&hf, &mut buf).unwrap();
    let tracer = RayTracer::new(&hf, relief_core::Surface::Triangles);
    let run = |p: &[&common::MipRay; L], out: &mut [Option<f64>; L]| {
        if avx512 {
            // SAFETY: AVX-512 F was detected above.
            unsafe { qt.trace_packet_avx512(p, out) }
        } else {
            qt.trace_packet(p, out)
        }
    };
    for (name, rays) in common::embree_views(&dem) {
        let tiles = tiles(&rays);
        let lib_rays: Vec<relief_core::ray::Ray> =
            tiles.iter().flat_map(|t| t.iter().map(|r| r.ray)).collect();
        let mut out = [None; L];
        let (agree, both_miss, differ) = common::agreement(tiles.iter().flat_map(|t| {
            run(t, &mut out);
            let lib: Vec<Option<f64>> = t
                .iter()
                .map(|r| tracer.trace_maxmip(&r.ray, &mip).unwrap().hit.map(|h| h.t))
                .collect();
            lib.into_iter().zip(out).collect::<Vec<_>>()
        }));
        let mut traces = vec![Trace::default(); lib_rays.len()];
        let (mut best_q, mut best_p, mut best_s) = (f64::INFINITY, f64::INFINITY, f64::INFINITY);
        for _ in 0..9 {
            let s = Instant::now();
            for t in &tiles {
                run(t, &mut out);
                black_box(&out);
            }
            best_q = best_q.min(s.elapsed().as_secs_f64());
            if avx512 {
                let s = Instant::now();
                // SAFETY: AVX-512 F and DQ were detected above.
                unsafe { tracer.trace_maxmip_packet_avx512(&lib_rays, &mip, &mut traces) }.unwrap();
                black_box(&traces);
                best_p = best_p.min(s.elapsed().as_secs_f64());
            }
            let s = Instant::now();
            for r in &lib_rays {
                black_box(tracer.trace_maxmip(r, &mip).ok());
            }
            best_s = best_s.min(s.elapsed().as_secs_f64());
        }
        // The chunked protocol: 256 tiles (4096 rays) at a time, each 9 times, fastest summed.
        let (mut chunk_q, mut chunk_p) = (0.0, 0.0);
        for (tc, rc) in tiles.chunks(256).zip(lib_rays.chunks(256 * L)) {
            let (mut bq, mut bp) = (f64::INFINITY, f64::INFINITY);
            for _ in 0..9 {
                let s = Instant::now();
                for t in tc {
                    run(t, &mut out);
                    black_box(&out);
                }
                bq = bq.min(s.elapsed().as_secs_f64());
                if avx512 {
                    let s = Instant::now();
                    // SAFETY: AVX-512 F and DQ were detected above.
                    unsafe { tracer.trace_maxmip_packet_avx512(rc, &mip, &mut traces[..rc.len()]) }
                        .unwrap();
                    black_box(&traces);
                    bp = bp.min(s.elapsed().as_secs_f64());
                }
            }
            chunk_q += bq;
            chunk_p += bp;
        }
        let m = rays.len() as f64 / 1e6;
        println!(
            "{name:8} packets of {L} ({}): hits agree {agree} (both miss {both_miss}), differ {differ} | M rays/s in tile order, whole passes: quadtree packets {:.2}, library AVX-512 packets {:.2}, trace_maxmip {:.2} | chunked: quadtree packets {:.2}, library AVX-512 packets {:.2} ({:.2}x)",
            if avx512 { "AVX-512" } else { "portable" },
            m / best_q,
            m / best_p,
            m / best_s,
            m / chunk_q,
            m / chunk_p,
            chunk_p / chunk_q
        );
    }
}

fn main() {
    let qt = common::mip_yardstick("quadtree", |g| {
        let quad = Quad::new(&g);
        Tracer { g, quad }
    });
    packets(&qt);
}
