//! Maximum-mipmap traversal (Tevs, Ihrke, Seidel, *Maximum Mipmaps for Fast, Accurate, and
//! Scalable Dynamic Height Field Rendering*, I3D 2008) one ray at a time through sixteen-wide
//! nodes, the single-ray form of wide hierarchies (Wald, Benthin, Boulos, *Getting Rid of
//! Packets: Efficient SIMD Single-Ray Traversal using Multi-branching BVHs*, IEEE RT 2008; the
//! form Embree's single-ray kernels take).
//!
//! The pyramid ([`MaxMip`]) stores each level in 4 x 4 tiles, so the sixteen nodes two levels
//! below node `(x, y)` of level `k` are tile `(x, y)` of level `k - 2`: one 64-byte line. Taken
//! two levels at a time the pyramid is a 16-ary tree whose leaves are the cells. A node tests its
//! sixteen children at once, with the operations of the neighbour walk's step (`mip_step` in
//! `maxmip.rs`) in the same order: each child's slab parameters, its interval `[ta, tb]` clipped
//! to the ray's, and its maximum against the ray's lowest point over that interval. So a child
//! is entered when the neighbour walk would descend into it, and a cell is tested over the same
//! interval, except for children the ray only touches at one point (`ta == tb`), which are not
//! entered. The neighbour walk tests two kinds of those: the cell under a start that lies on a
//! cell boundary (whose one-point test `start_hit` has already made before either walk begins)
//! and a cell entered exactly at the ray's clipped end. So the cells tested are the same or
//! fewer, but for one kind of ray: one that passes within a rounding unit of a grid vertex may
//! cross a cell there for a rounding unit of `t`, which the wide walk tests (its interval is
//! not empty) and the neighbour walk's descent, flooring its entry position past the corner,
//! skips; one cell more for each such vertex, the same hit (found by the `rays` fuzz target:
//! `tests/tests/rays_packet.rs::wide_walk_may_test_a_cell_crossed_for_a_rounding_unit_at_a_vertex`).
//! The hits are those of [`RayTracer::trace_maxmip`] (bit for bit on the rays of
//! the packet tests and the `rays` fuzz target; rays aimed exactly at a sample's top on the
//! domain's edge may touch it by a rounding unit in one walk and not the other, or hit the
//! other cell at that corner: `HARD_CASES.md`). The walk takes a node's children in the order
//! the ray crosses them (a ray's path through a 4 x 4 block is a monotone staircase, one child
//! per anti-diagonal counted from the corner it enters by), so the next child is the lowest set
//! bit of the node's mask in that order; a node with children left waits on a stack of at most
//! one node per level pair, and the first cell hit ends the ray.
//!
//! Three forms of the node test share the walk ([`RayTracer::wide_loop`]), each giving the
//! same hits and testing the same cells:
//! - the portable one here ([`RayTracer::trace_maxmip_wide`]), plain `f64` arithmetic in the
//!   tile's own order (lane `row * 4 + column`): a child's x slab depends on its column only and
//!   its y slab on its row only, so four of each are computed and combined sixteen times; the
//!   mask goes into crossing order by a table;
//! - AVX2 (`wide/avx2.rs`), in `f32` with margins, eight lanes a register: a conservative test
//!   that enters every child the exact one enters and possibly a few more (so its
//!   [`Trace::steps`] may be larger); rays outside its range take the same operations as the
//!   portable node in registers of four `f64` lanes;
//! - AVX-512 (`wide/avx512.rs`), the portable node's operations in two registers of eight
//!   lanes in crossing order (the portable form's traces, steps included).
//!
//! A cell's interval is computed again, in scalar, when it is tested, and so is its lane's
//! test: a cell that a conservative node test entered and the exact test would not is
//! skipped, not tested. The slice forms
//! ([`RayTracer::trace_maxmip_wide_rays`], `trace_maxmip_wide_rays_avx2`) keep two rays' walks
//! in flight and make a pass of each in turn: a pass is one long dependent chain (the tile's
//! load, the slabs, the compares, the mask, the next child), and two independent chains
//! overlap. Measured on the bundled DEM (BENCHMARKS.md, "The sixteen-wide walk in AVX2" and
//! "The sixteen-wide walk with fewer instructions"): AVX2 1.15-1.4x the neighbour walk ray by
//! ray, two interleaved 1.4-1.7x, the portable form 0.8-0.9x the neighbour walk (the compiler
//! does not vectorise it well).

use super::cell::{CellHit, LocalRay};
use super::maxmip::{max_f, min_f, MaxMip};
use super::{Hit, Ray, RayTracer, Trace};
use crate::{Error, Terrain};
use glam::DVec3;

#[cfg(target_arch = "x86_64")]
mod avx2;
#[cfg(target_arch = "x86_64")]
mod avx512;

/// The children's `(column, row)` in a 4 x 4 block, in crossing order, for a ray whose x and y
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

/// [`order`] for the four direction octants, indexed `fx | fy << 1`.
const ORDER: [[[u32; 2]; 16]; 4] = [
    order(false, false),
    order(true, false),
    order(false, true),
    order(true, true),
];

/// The portable node's mask (bit `row * 4 + column`) put into crossing order (bit `n` for
/// the `n`-th child of [`order`]), a byte of the tile mask at a time: `[half][byte]`.
const fn crossing(fx: bool, fy: bool) -> [[u16; 256]; 2] {
    let ord = order(fx, fy);
    let mut lane = [0u32; 16];
    let mut n = 0;
    while n < 16 {
        lane[(ord[n][1] * 4 + ord[n][0]) as usize] = n as u32;
        n += 1;
    }
    let mut out = [[0u16; 256]; 2];
    let mut h = 0;
    while h < 2 {
        let mut v = 0;
        while v < 256 {
            let mut b = 0;
            while b < 8 {
                if v >> b & 1 != 0 {
                    out[h][v] |= 1 << lane[h * 8 + b];
                }
                b += 1;
            }
            v += 1;
        }
        h += 1;
    }
    out
}

/// [`crossing`] for the four direction octants, indexed as [`ORDER`] (4 KiB).
static CROSSING: [[[u16; 256]; 2]; 4] = [
    crossing(false, false),
    crossing(true, false),
    crossing(false, true),
    crossing(true, true),
];

/// The node size and the block corner of the sixteen children (on level `child`) of node
/// `(ix, iy)` two levels up, in cells: `(s, bx, by)`. Integers below 2^53, exact in `f64`, as
/// the neighbour walk's `ix * s` converted (`2^child` from its exponent, then products with a
/// power of two, which are exact; an unsigned 64-bit conversion took a dozen instructions).
#[inline(always)]
fn block(child: u32, ix: u32, iy: u32) -> (f64, f64, f64) {
    let s = f64::from_bits((1023 + u64::from(child & 63)) << 52);
    (s, f64::from(ix) * 4.0 * s, f64::from(iy) * 4.0 * s)
}

/// The sixteen maxima of node `(ix, iy)`'s tile on level `child` (tile order), `-inf` past the
/// storage (never, for a node of the grid).
#[inline(always)]
fn tile(mip: &MaxMip<'_>, child: u32, ix: u32, iy: u32) -> [f32; 16] {
    let l = mip.level(child);
    // Level offsets are whole tiles.
    let t = (l.off >> 4) + (iy as usize) * l.tx as usize + ix as usize;
    mip.data
        .as_chunks::<16>()
        .0
        .get(t)
        .copied()
        .unwrap_or([f32::NEG_INFINITY; 16])
}

/// The most passes a walk takes. Each pass takes one child the ray's segment crosses, and a
/// node is only pushed with a child left: with the exact test at most `w + h + 1` nodes of each
/// `w x h` level the walk tests (every other level), within `mip.step_bound()`, which counts
/// `2 (w + h) + 2` for every level. The AVX2 form's `f32` test also takes children the segment
/// passes within a quarter of a node, at most as many again; twice the step bound covers both
/// with room to spare, so that no walk is cut short.
#[inline(always)]
fn wide_bound(mip: &MaxMip<'_>) -> u64 {
    mip.bound.saturating_mul(2)
}

/// Per-ray constants of one horizontal axis (portable node).
struct Axis {
    /// Origin, inverse direction component, cells along the axis.
    o: f64,
    inv: f64,
    n: f64,
    /// Direction component positive, or zero.
    pos: bool,
    zero: bool,
}

impl Axis {
    fn new(o: f64, d: f64, inv: f64, n: u32) -> Axis {
        Axis {
            o,
            inv,
            n: f64::from(n),
            pos: d > 0.0,
            zero: d == 0.0,
        }
    }

    /// For the child at position `c` (in nodes of its level) of a block starting at `base`
    /// with nodes of size `s`: whether its node lies inside the grid and, when the ray does not
    /// move along this axis, holds it (the node the neighbour walk's `floor` picks, the last
    /// one for `o == n`), and its slab parameters (`slab_signed` of `maxmip.rs`; `-inf, inf`
    /// for a zero component). The same operations as the AVX2 and AVX-512 nodes' `Axis::span`;
    /// the walk also calls it for a cell's interval (`c = 0`, `s = 1`).
    #[inline(always)]
    fn span(&self, c: f64, base: f64, s: f64) -> (bool, f64, f64) {
        let lo = base + c * s;
        let hi = min_f(lo + s, self.n);
        // The tile's padding past the grid is never read as a node.
        let live = lo < self.n;
        let o = self.o;
        let inside = (o < lo + s) | ((o >= self.n) & (hi >= self.n));
        let on = (lo <= o) & inside;
        let a = (lo - o) * self.inv;
        let b = (hi - o) * self.inv;
        let (en, ex) = if self.pos { (a, b) } else { (b, a) };
        if self.zero {
            (live & on, f64::NEG_INFINITY, f64::INFINITY)
        } else {
            (live, en, ex)
        }
    }
}

/// Per-ray constants of the portable node.
struct Consts {
    x: Axis,
    y: Axis,
    oz: f64,
    dz: f64,
    /// The ray descends (`dz < 0`).
    down: bool,
    t0: f64,
    t1: f64,
    /// [`CROSSING`] of the ray's octant.
    cross: &'static [[u16; 256]; 2],
}

impl Consts {
    /// The constants of clipped ray `lr` in octant `oct`.
    fn new(lr: &LocalRay, oct: usize, mip: &MaxMip<'_>) -> Consts {
        Consts {
            x: Axis::new(lr.o.x, lr.d.x, lr.inv[0], mip.nx),
            y: Axis::new(lr.o.y, lr.d.y, lr.inv[1], mip.ny),
            oz: lr.o.z,
            dz: lr.d.z,
            down: lr.d.z < 0.0,
            t0: lr.t0,
            t1: lr.t1,
            cross: &CROSSING[oct & 3],
        }
    }
}

/// A node: the level of its children, its index on its own level, and the children left.
#[derive(Clone, Copy)]
struct Node {
    child: u32,
    ix: u32,
    iy: u32,
    mask: u32,
}

/// Walks [`RayTracer::wide_rays`] interleaves. Two overlapped the chains of a walk's passes
/// (1.17x one at a time on the Puget camera view with the AVX2 node); three read the same as
/// two (BENCHMARKS.md, "The sixteen-wide walk in AVX2").
const WIDE_INTERLEAVED: usize = 2;

/// The ray of an idle walk: still, at the origin, with an empty interval.
const IDLE: LocalRay = LocalRay {
    o: DVec3::ZERO,
    d: DVec3::ZERO,
    inv: [0.0; 2],
    t0: 0.0,
    t1: 0.0,
};

/// One ray's sixteen-wide walk in progress.
struct WideWalk<C> {
    /// The ray's index in its slice ([`RayTracer::wide_rays`]).
    i: usize,
    lr: LocalRay,
    /// The ray's constants for the node test of its form.
    c: C,
    /// The ray's axes, for the cells' intervals.
    x: Axis,
    y: Axis,
    /// The children's positions in crossing order: [`ORDER`] of the ray's octant.
    order: &'static [[u32; 2]; 16],
    /// The walk has a ray in progress (a finished walk's slot is restarted in place by
    /// [`RayTracer::wide_rays`]).
    live: bool,
    cur: Node,
    /// Nodes with children left below `cur`: at most one per level pair.
    stack: [Node; 17],
    sp: usize,
    /// Children taken (cells and nodes).
    passes: u64,
    /// Cells taken but skipped by the exact test (after a conservative node test).
    skipped: u64,
    /// The trace so far; its `steps` are set when the walk ends ([`Self::trace`]).
    tr: Trace,
}

impl<C> WideWalk<C> {
    /// A walk from the root node on level `root` (children on `root - 2`), whose children to
    /// enter are `mask`.
    fn new(
        i: usize,
        lr: LocalRay,
        c: C,
        mip: &MaxMip<'_>,
        (root, oct, mask): (u32, usize, u32),
    ) -> WideWalk<C> {
        let cur = Node {
            child: root - 2,
            ix: 0,
            iy: 0,
            mask,
        };
        WideWalk {
            i,
            x: Axis::new(lr.o.x, lr.d.x, lr.inv[0], mip.nx),
            y: Axis::new(lr.o.y, lr.d.y, lr.inv[1], mip.ny),
            lr,
            c,
            order: &ORDER[oct & 3],
            live: true,
            cur,
            stack: [cur; 17],
            sp: 0,
            passes: 0,
            skipped: 0,
            tr: Trace::default(),
        }
    }

    /// [`Self::new`] in place, for the next ray of a slot: the stack's old entries are left,
    /// since only entries below `sp` are read (the struct is about a kilobyte, and writing a
    /// new one per ray cost about a twentieth of the slice walk's instructions).
    fn restart(
        &mut self,
        i: usize,
        lr: LocalRay,
        c: C,
        mip: &MaxMip<'_>,
        (root, oct, mask): (u32, usize, u32),
    ) {
        self.i = i;
        self.x = Axis::new(lr.o.x, lr.d.x, lr.inv[0], mip.nx);
        self.y = Axis::new(lr.o.y, lr.d.y, lr.inv[1], mip.ny);
        self.lr = lr;
        self.c = c;
        self.order = &ORDER[oct & 3];
        self.live = true;
        self.cur = Node {
            child: root - 2,
            ix: 0,
            iy: 0,
            mask,
        };
        self.sp = 0;
        self.passes = 0;
        self.skipped = 0;
        self.tr = Trace::default();
    }

    /// The trace of a walk that has ended: [`Trace::steps`] counts the nodes tested, the root
    /// and every child taken that is not a cell.
    fn trace(&self) -> Trace {
        let nodes = self
            .passes
            .saturating_add(1)
            .saturating_sub(u64::from(self.tr.cells))
            .saturating_sub(self.skipped);
        Trace {
            steps: u32::try_from(nodes).unwrap_or(u32::MAX),
            ..self.tr
        }
    }
}

impl<T: Terrain> RayTracer<'_, T> {
    /// [`RayTracer::trace_maxmip`] through sixteen-wide nodes, the sixteen children of a node
    /// tested at once (see `ray/wide.rs`): the same hits, the same cells tested or fewer (cells
    /// the ray only touches at a point are skipped; a ray passing within a rounding unit of a
    /// grid vertex may take one cell more there), in fewer and wider steps.
    /// [`Trace::steps`] counts the nodes whose children were tested. This is the portable
    /// form, built for the target's baseline vector unit; on x86-64, `trace_maxmip_wide_avx512`
    /// gives the same traces where the CPU has AVX-512F, and `trace_maxmip_wide_avx2` the same
    /// hits and cells where it has AVX2 (its steps may be more: see `ray/wide.rs`).
    /// [`Error::LengthMismatch`] if `mip` belongs to another grid size.
    ///
    /// ```
    /// use relief_core::ray::{MaxMip, Ray, RayTracer};
    /// use relief_core::{Heightfield, Surface};
    /// use glam::Vec3;
    /// let s: Vec<f32> = (0..81 * 81).map(|i| ((i * 37) % 11) as f32).collect();
    /// let hf = Heightfield::new(&s, 81, 81).unwrap();
    /// let mut buf = vec![0.0; MaxMip::len(81, 81).unwrap()];
    /// let mip = MaxMip::build(&hf, &mut buf).unwrap();
    /// let t = RayTracer::new(&hf, Surface::Triangles);
    /// let ray = Ray::new(Vec3::new(-3.0, 2.5, 14.0), Vec3::new(1.0, 0.7, -0.2)).unwrap();
    /// let wide = t.trace_maxmip_wide(&ray, &mip).unwrap();
    /// let neighbour = t.trace_maxmip(&ray, &mip).unwrap();
    /// assert_eq!(wide.hit, neighbour.hit);
    /// assert!(wide.cells <= neighbour.cells && wide.steps < neighbour.steps);
    /// ```
    pub fn trace_maxmip_wide(&self, ray: &Ray, mip: &MaxMip<'_>) -> Result<Trace, Error> {
        self.check_mip(mip)?;
        let mut out = Trace::default();
        self.wide_portable(ray, mip, &mut out);
        Ok(out)
    }

    /// [`RayTracer::trace_maxmip_wide`] for every ray of `rays` into `out`, two walks
    /// interleaved (a pass of each in turn, so that the dependent chains of the two rays'
    /// passes overlap): the same traces, ray for ray. [`Error::BufferTooSmall`] if `out` is
    /// shorter than `rays`, [`Error::LengthMismatch`] if `mip` belongs to another grid size.
    ///
    /// ```
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
    /// t.trace_maxmip_wide_rays(&rays, &mip, &mut out).unwrap();
    /// for (r, o) in rays.iter().zip(&out) {
    ///     assert_eq!(*o, t.trace_maxmip_wide(r, &mip).unwrap());
    /// }
    /// assert!(t.trace_maxmip_wide_rays(&rays, &mip, &mut out[..19]).is_err());
    /// ```
    pub fn trace_maxmip_wide_rays(
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
                || Consts::new(&IDLE, 0, mip),
                |lr, oct| Some(Consts::new(lr, oct, mip)),
                // Never called: the portable form walks every ray interleaved.
                |ray, _, o| self.wide_portable(ray, mip, o),
            ),
            |c, child, ix, iy| wide_node(mip, c, child, ix, iy),
        );
        Ok(())
    }

    /// The walk with the portable node.
    fn wide_portable(&self, ray: &Ray, mip: &MaxMip<'_>, out: &mut Trace) {
        let Some(st) = self.wide_start(ray, mip, out) else {
            return;
        };
        let c = Consts::new(&st.0, st.2, mip);
        self.wide_loop(ray, mip, out, st, c, |c, child, ix, iy| {
            wide_node(mip, c, child, ix, iy)
        });
    }

    /// The start of every form of the walk: the clipped ray, the root level (the top node,
    /// or one past it when the top level is odd: its children, the tile of the level below
    /// the top, hold at most 2 x 2 nodes) and the ray's octant (`fx | fy << 1`); `None` when
    /// the ray is done (a miss, a hit at its start, or a single-cell grid, walked by the
    /// neighbour walk).
    #[inline(always)]
    fn wide_start(
        &self,
        ray: &Ray,
        mip: &MaxMip<'_>,
        out: &mut Trace,
    ) -> Option<(LocalRay, u32, usize)> {
        let top = mip.levels - 1;
        let root = top + (top & 1);
        if root < 2 {
            // A single cell: no node to take.
            self.mip_walk(ray, mip, out);
            return None;
        }
        let lr = self.mip_clip(ray, out)?;
        let oct = usize::from(lr.d.x < 0.0) | usize::from(lr.d.y < 0.0) << 1;
        Some((lr, root, oct))
    }

    /// The walk of one ray from the root: `node(c, child, ix, iy)` tests the sixteen children
    /// (on level `child`) of node `(ix, iy)` two levels up with the ray's node constants `c`
    /// and gives the mask of those to enter, in crossing order.
    #[inline(always)]
    fn wide_loop<C>(
        &self,
        ray: &Ray,
        mip: &MaxMip<'_>,
        out: &mut Trace,
        (lr, root, oct): (LocalRay, u32, usize),
        c: C,
        node: impl Fn(&C, u32, u32, u32) -> u32,
    ) {
        let mask = node(&c, root - 2, 0, 0);
        let mut w = WideWalk::new(0, lr, c, mip, (root, oct, mask));
        // Bounded: `wide_step` ends the walk after `wide_bound(mip)` passes.
        let bound = wide_bound(mip);
        for _ in 0..=bound {
            if self.wide_step(core::slice::from_ref(ray), mip, &mut w, &node, bound) {
                break;
            }
        }
        *out = w.trace();
    }

    /// [`Self::wide_loop`] for each ray of `rays` into `out` (at least as long; the caller
    /// checks), [`WIDE_INTERLEAVED`] walks at a time, a pass of each in turn, so that their
    /// dependent chains of loads and compares overlap; a walk that ends takes the next ray.
    /// `start` makes a ray's node constants from its clipped ray and octant, or gives `None`
    /// for a ray that `alone` walks by itself into its trace (the AVX2 form's rays outside
    /// its `f32` test's range); `idle` makes the constants of a walk without a ray, which no
    /// pass reads.
    #[inline(always)]
    fn wide_rays<C>(
        &self,
        rays: &[Ray],
        mip: &MaxMip<'_>,
        out: &mut [Trace],
        form: (
            impl Fn() -> C,
            impl Fn(&LocalRay, usize) -> Option<C>,
            impl Fn(&Ray, (LocalRay, u32, usize), &mut Trace),
        ),
        node: impl Fn(&C, u32, u32, u32) -> u32,
    ) {
        let (idle, start, alone) = form;
        // Idle walks (`live` false) until the first rays arrive: a ray that stays still at the
        // origin.
        let mut walks: [WideWalk<C>; WIDE_INTERLEAVED] = core::array::from_fn(|_| {
            let mut w = WideWalk::new(0, IDLE, idle(), mip, (2, 0, 0));
            w.live = false;
            w
        });
        let mut next = 0usize;
        for w in walks.iter_mut() {
            self.wide_refill(w, &mut next, rays, mip, out, (&start, &alone, &node));
        }
        // Bounded: each round makes a pass of every live walk; a ray takes at most
        // `bound + 1` passes, so `rays * (bound + 1) + 1` rounds cover every ray.
        let bound = wide_bound(mip);
        let rounds = (rays.len() as u64)
            .saturating_mul(bound.saturating_add(1))
            .saturating_add(1);
        for _ in 0..rounds {
            let mut busy = false;
            for w in walks.iter_mut() {
                if !w.live {
                    continue;
                }
                busy = true;
                if self.wide_step(rays, mip, w, &node, bound) {
                    if let Some(o) = out.get_mut(w.i) {
                        *o = w.trace();
                    }
                    w.live = false;
                    self.wide_refill(w, &mut next, rays, mip, out, (&start, &alone, &node));
                }
            }
            if !busy {
                break;
            }
        }
    }

    /// A walk of [`Self::wide_rays`] that has ended takes the next ray from `next` on that does
    /// not end at its start (a miss, or a hit at the start, written at once) and that `start`
    /// gives constants for (`alone` traces the others at once); it stays idle when none is
    /// left. At most `rays.len()` starts over a slice. A method rather than a closure, so that
    /// it is inlined with the caller's target features (a closure is compiled with those of
    /// the function that defines it).
    #[inline(always)]
    fn wide_refill<C>(
        &self,
        w: &mut WideWalk<C>,
        next: &mut usize,
        rays: &[Ray],
        mip: &MaxMip<'_>,
        out: &mut [Trace],
        (start, alone, node): (
            &impl Fn(&LocalRay, usize) -> Option<C>,
            &impl Fn(&Ray, (LocalRay, u32, usize), &mut Trace),
            &impl Fn(&C, u32, u32, u32) -> u32,
        ),
    ) {
        while !w.live && *next < rays.len() {
            let i = *next;
            *next += 1;
            let (Some(ray), Some(o)) = (rays.get(i), out.get_mut(i)) else {
                break;
            };
            *o = Trace::default();
            if let Some((lr, root, oct)) = self.wide_start(ray, mip, o) {
                match start(&lr, oct) {
                    Some(c) => {
                        let mask = node(&c, root - 2, 0, 0);
                        w.restart(i, lr, c, mip, (root, oct, mask));
                    }
                    None => alone(ray, (lr, root, oct), o),
                }
            }
        }
    }

    /// One pass of a walk: takes the current node's next child (the lowest bit of its mask, or
    /// pops a node when it has none left) and tests it, a cell exactly, a node by `node`.
    /// `true` when the walk is done: a hit, no node left, or `bound` ([`wide_bound`]) passes.
    /// A cell's interval is computed again when it is tested, with the scalar form of the
    /// node's operations ([`Axis::span`]), rather than kept from its node's test for every lane
    /// (the same values).
    #[inline(always)]
    fn wide_step<C>(
        &self,
        rays: &[Ray],
        mip: &MaxMip<'_>,
        w: &mut WideWalk<C>,
        node: &impl Fn(&C, u32, u32, u32) -> u32,
        bound: u64,
    ) -> bool {
        if w.passes >= bound {
            return true;
        }
        if w.cur.mask == 0 {
            if w.sp == 0 {
                return true;
            }
            w.sp -= 1;
            let Some(&n) = w.stack.get(w.sp) else {
                return true;
            };
            w.cur = n;
        }
        // Every pass past this point tests one child: a cell or a node.
        w.passes += 1;
        let j = (w.cur.mask.trailing_zeros() & 15) as usize;
        w.cur.mask &= w.cur.mask - 1;
        let [kx, ky] = w.order[j];
        let (gx, gy) = (4 * w.cur.ix + kx, 4 * w.cur.iy + ky);
        if w.cur.child == 0 {
            // Cell `(gx, gy)`: child 0 of a block at `(gx, gy)` with nodes of size 1, the
            // operations and values of its lane in the exact node test, made again here: a
            // node test that is only conservative (the AVX2 form's `f32` test) enters cells
            // the exact one would not, and those are skipped (for the exact forms this never
            // happens).
            let (_, ax, ex) = w.x.span(0.0, f64::from(gx), 1.0);
            let (_, ay, ey) = w.y.span(0.0, f64::from(gy), 1.0);
            let ta = max_f(max_f(w.lr.t0, ax), ay);
            let tb = min_f(min_f(w.lr.t1, ex), ey);
            // The lane's interval and height test (a cell of the grid is live, and the `f32`
            // test takes only rays moving along both axes, whose `on` test is always true).
            let m = tile(mip, 0, w.cur.ix, w.cur.iy)[(ky * 4 + kx) as usize & 15];
            let zmin = w.lr.o.z + (if w.lr.d.z < 0.0 { tb } else { ta }) * w.lr.d.z;
            if !(ta < tb && zmin <= f64::from(m)) {
                w.skipped += 1;
                return false;
            }
            w.tr.cells += 1;
            if let Some(h) = self.wide_cell(&w.lr, gx, gy, ta, tb) {
                w.tr.hit = rays.get(w.i).map(|ray| self.wide_hit(ray, gx, gy, h));
                return true;
            }
            return false;
        }
        let mask = node(&w.c, w.cur.child - 2, gx, gy);
        if mask != 0 {
            if w.cur.mask != 0 {
                if let Some(e) = w.stack.get_mut(w.sp) {
                    *e = w.cur;
                    w.sp += 1;
                }
            }
            w.cur = Node {
                child: w.cur.child - 2,
                ix: gx,
                iy: gy,
                mask,
            };
        }
        false
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

/// The portable node test: the sixteen children (on level `child`) of node `(ix, iy)` two
/// levels up, in tile order; the mask of those the ray crosses and the neighbour walk would
/// enter, in crossing order.
#[inline(always)]
fn wide_node(mip: &MaxMip<'_>, c: &Consts, child: u32, ix: u32, iy: u32) -> u32 {
    let (s, bx, by) = block(child, ix, iy);
    let tile = tile(mip, child, ix, iy);
    // A child's x slab depends on its column only and its y slab on its row only: four of
    // each, the same values the sixteen lanes would compute one by one.
    let (mut lx, mut ax, mut ex) = ([false; 4], [0.0; 4], [0.0; 4]);
    let (mut ly, mut ay, mut ey) = ([false; 4], [0.0; 4], [0.0; 4]);
    for (k, d) in [0.0, 1.0, 2.0, 3.0].into_iter().enumerate() {
        let (l, a, e) = c.x.span(d, bx, s);
        // The ray's own interval first, as `max_f(max_f(t0, ax), ay)` in the neighbour walk.
        (lx[k], ax[k], ex[k]) = (l, max_f(c.t0, a), min_f(c.t1, e));
        (ly[k], ay[k], ey[k]) = c.y.span(d, by, s);
    }
    let mut m = 0u32;
    for (r, mr) in tile.chunks_exact(4).enumerate() {
        let (lyr, ayr, eyr) = (ly[r & 3], ay[r & 3], ey[r & 3]);
        for (k, (&mk, ((&lxk, &axk), &exk))) in
            mr.iter().zip(lx.iter().zip(&ax).zip(&ex)).enumerate()
        {
            let a = max_f(axk, ayr);
            let b = min_f(exk, eyr);
            // The ray's lowest point over the interval: `min(z(a), z(b))` of the neighbour
            // walk, which is `z(b)` for a descending ray and `z(a)` otherwise (rounding is
            // monotone, so the same value).
            let zmin = c.oz + (if c.down { b } else { a }) * c.dz;
            // `<`: a child the ray only touches (an exact corner crossing, a start or end on
            // its boundary) is not entered; see the module's documentation.
            let e = lxk & lyr & (a < b) & (zmin <= f64::from(mk));
            m |= u32::from(e) << (4 * r + k);
        }
    }
    let cross = c.cross[0][(m & 0xff) as usize] | c.cross[1][(m >> 8 & 0xff) as usize];
    u32::from(cross)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Heightfield, Surface};
    use core::cell::Cell;
    use glam::Vec3;
    use std::vec;

    /// A trace's `steps` are the node tests the walk made, the root's included: counted here by
    /// wrapping the node test, against the count the walk derives from its passes and cells
    /// (`WideWalk::trace`). The slice forms' traces equal these (`tests/tests/rays_packet.rs`).
    #[test]
    fn steps_count_the_node_tests() {
        let (w, h) = (83u32, 61u32);
        let s: std::vec::Vec<f32> = (0..w * h)
            .map(|i| ((i * 37) % 29) as f32 * 0.4 + ((i / w) as f32 * 0.2).sin() * 5.0)
            .collect();
        let hf = Heightfield::new(&s, w, h).unwrap();
        let mut buf = vec![0.0; MaxMip::len(w, h).unwrap()];
        let mip = MaxMip::build(&hf, &mut buf).unwrap();
        let t = RayTracer::new(&hf, Surface::Triangles);
        let (mut rays, mut hits, mut misses) = (0, 0, 0);
        for k in 0..400u32 {
            let a = k as f32 * 0.37;
            let origin = Vec3::new(
                -5.0 + (k % 7) as f32 * 13.0,
                -3.0 + (k % 5) as f32 * 11.0,
                12.0,
            );
            let dir = Vec3::new(a.cos(), a.sin(), -0.05 - (k % 9) as f32 * 0.04);
            let ray = Ray::new(origin, dir).unwrap();
            let mut out = Trace::default();
            let Some(st) = t.wide_start(&ray, &mip, &mut out) else {
                continue;
            };
            let c = Consts::new(&st.0, st.2, &mip);
            let calls = Cell::new(0u32);
            t.wide_loop(&ray, &mip, &mut out, st, c, |c, child, ix, iy| {
                calls.set(calls.get() + 1);
                wide_node(&mip, c, child, ix, iy)
            });
            assert_eq!(out.steps, calls.get(), "{ray:?}");
            rays += 1;
            if out.hit.is_some() {
                hits += 1;
            } else {
                misses += 1;
            }
        }
        assert!(
            rays > 200 && hits > 50 && misses > 20,
            "{rays} {hits} {misses}"
        );
    }
}
