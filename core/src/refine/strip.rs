//! Generalized triangle strips built during refinement: seed 004's in/out-edge strip (Balogh
//! 2003, chapter 5.1: enter/leave edges, restricted left-only and right-only refinement that
//! never visits vertices which cannot be active, corner turns by one repeated index).
//!
//! On a square `(2^k+1)^2` grid the strip covers the square; the square's centre and the
//! midpoints of its sides are always refined (the four base triangles of SOAR, chapter 4.5). On
//! a grid of any other size it covers exactly the domain: the triangles across the domain's edge
//! always split, as in [`Refiner::triangles`], and each triangle inside it gets a strip of its
//! own, started as the square's strip starts (its entry vertex twice, at the same parity) and
//! joined to the strip before it by degenerate triangles; a triangle that does not split is
//! joined by the fewest indices that draw it. A culled vertex is treated as inactive: its
//! triangles are drawn coarse (outside the view), as in SOAR.
//!
//! [`strip_fewest_indices`] measures any strip against the fewest indices its triangle order
//! allows, and [`strip_fewest`] rewrites it as that fewest. On a square grid both strips reach
//! it up to their start (three indices over a whole mesh, about 1.6 per triangle on real DEMs);
//! seed 004's 1.32 for its strip is below that fewest, even for strips drawn either way round
//! (about 1.5: BENCHMARKS.md). Off the square they come within about a tenth of it.

use super::grid::Edge;
use super::select::{
    marks, need, rank, BitOrder, Decision, Marks, MeshVertex, MorphVertex, Refiner,
};
use super::StripCounts;
use crate::{Error, Terrain};

type P = (i64, i64);

#[inline(always)]
fn mid(a: P, b: P) -> P {
    ((a.0 + b.0) / 2, (a.1 + b.1) / 2)
}

/// Where strip indices go: marking the bitmap (first pass) or writing ranks (second pass).
trait Out {
    fn put(&mut self, v: P);
}

struct Mark<'a, 's> {
    m: &'a mut Marks<'s>,
    o: BitOrder,
}

impl Out for Mark<'_, '_> {
    #[inline(always)]
    fn put(&mut self, v: P) {
        self.m.mark(self.o.bit(v));
    }
}

struct Write<'a, 'o> {
    bits: &'a [u64],
    prefix: &'a [u64],
    o: BitOrder,
    out: &'o mut [u32],
    n: usize,
}

impl Out for Write<'_, '_> {
    #[inline(always)]
    fn put(&mut self, v: P) {
        if let Some(o) = self.out.get_mut(self.n) {
            *o = rank(self.bits, self.prefix, self.o.bit(v));
        }
        self.n += 1;
    }
}

const SIDE: bool = true;
const BOTTOM: bool = false;

struct Strip<'r, 'h, 't, T: Terrain, O: Out> {
    r: &'r Refiner<'h, 't, T>,
    out: O,
    last: [P; 2],
    len: usize,
    tris: usize,
    first: bool,
    left_only: bool,
    levels: u32,
    parity: bool,
    /// Decisions made ([`StripCounts::tested`]).
    tested: usize,
}

impl<'r, 'h, 't, T: Terrain, O: Out> Strip<'r, 'h, 't, T, O> {
    /// An empty strip of `r`'s mesh into `out`.
    fn new(r: &'r Refiner<'h, 't, T>, out: O) -> Self {
        Strip {
            r,
            out,
            last: [(-1, -1); 2],
            len: 0,
            tris: 0,
            first: true,
            left_only: false,
            levels: r.g.levels(),
            parity: false,
            tested: 0,
        }
    }

    /// The whole strip: a square grid's ([`Self::run`], or SOAR's [`Self::run_soar`]), or one
    /// piece per triangle inside the domain of another ([`Self::run_domain`]).
    fn walk(mut self, soar: bool) -> Self {
        if !self.r.g.is_square() {
            self.run_domain(soar);
        } else if soar {
            self.run_soar();
        } else {
            self.run();
        }
        self
    }

    /// SOAR's `tstrip_append`: skip a vertex already in the last two; insert a degenerate
    /// (repeat the second-to-last index) when the new vertex has the strip's current parity.
    fn append_parity(&mut self, v: P, p: bool) {
        let in_last = (self.len >= 1 && v == self.last[1]) || (self.len >= 2 && v == self.last[0]);
        if in_last {
            return;
        }
        if p != self.parity {
            self.parity = p;
        } else {
            self.turn_corner();
        }
        self.append(v);
    }

    /// SOAR's `submesh_refine` (Lindstrom & Pascucci 2001): triangle with apex `i` and split
    /// vertex `j`, entered at `p`; `i` (at `level`) is tested, and appended between the two
    /// children's strips.
    /// `forced`: `i` is active whatever its decision (the square's centre, or the split vertex
    /// of a triangle across the domain's edge).
    fn soar_submesh(&mut self, i: P, j: P, p: P, level: u32, planes: u8, forced: bool) {
        let mut pl = planes;
        if !(forced || self.active(i, level, &mut pl)) {
            return;
        }
        let parity = (self.levels - level) % 2 == 1;
        if level + 1 < self.levels {
            let q = (2 * j.0 - p.0, 2 * j.1 - p.1);
            self.soar_submesh(j, mid(i, p), p, level + 1, pl, false);
            self.append_parity(i, parity);
            self.soar_submesh(j, mid(i, q), i, level + 1, pl, false);
        } else {
            self.append_parity(i, parity);
        }
    }

    /// SOAR's `mesh_refine`: the four base triangles around the (always refined) centre.
    fn run_soar(&mut self) {
        let n = self.r.g.side() as i64;
        if n < 2 {
            for v in [(1, 0), (1, 1), (0, 0), (0, 1)] {
                self.append(v);
            }
            return;
        }
        let h = n / 2;
        let c = (h, h);
        let mask = self.r.view.map_or(0, |v| v.mask);
        let bases = [
            ((h, 0), (0, 0), (n, 0)),
            ((n, h), (n, 0), (n, n)),
            ((h, n), (n, n), (0, n)),
            ((0, h), (0, n), (0, 0)),
        ];
        self.append((0, 0));
        self.append((0, 0));
        self.parity = true;
        for (m, p, q) in bases {
            self.soar_submesh(c, m, p, 0, mask, true);
            self.append_parity(q, true);
        }
    }
    #[inline(always)]
    fn append(&mut self, v: P) {
        if self.len >= 2 && v != self.last[0] && v != self.last[1] && self.last[0] != self.last[1] {
            self.tris += 1;
        }
        self.out.put(v);
        self.last = [self.last[1], v];
        self.len += 1;
    }

    /// Repeats the second-to-last index: one degenerate triangle that swaps the strip's side.
    #[inline(always)]
    fn turn_corner(&mut self) {
        let v = self.last[0];
        self.append(v);
    }

    /// Whether vertex `v` at `level` is active; updates the plane mask.
    #[inline(always)]
    fn active(&mut self, v: P, level: u32, planes: &mut u8) -> bool {
        if level >= self.levels {
            return false;
        }
        self.tested += 1;
        match self.r.decide(v, *planes, level) {
            Decision::Split(p) => {
                *planes = p;
                true
            }
            _ => false,
        }
    }

    /// Triangle with apex `v1`, active split vertex `v2` at `level`, entered at `p` (left end of
    /// the hypotenuse); `inn`/`out`: whether the strip enters/leaves through a side (leg).
    #[allow(clippy::too_many_arguments)]
    fn refine(&mut self, v1: P, v2: P, p: P, level: u32, inn: bool, out: bool, planes: u8) {
        let q = (2 * v2.0 - p.0, 2 * v2.1 - p.1);
        let left = mid(p, v1);
        let right = mid(v1, q);
        let (mut pl, mut pr) = (planes, planes);
        let is_left = self.active(left, level + 1, &mut pl);
        let is_right = self.active(right, level + 1, &mut pr);
        if is_left {
            if is_right {
                self.refine(v2, left, p, level + 1, !inn, SIDE, pl);
                self.append(v1);
                if self.left_only {
                    self.append(v2);
                    self.right_refine(v2, right, v1, level + 1, !out, pr);
                } else {
                    self.refine(v2, right, v1, level + 1, SIDE, !out, pr);
                }
                self.left_only = false;
            } else {
                self.left_only = true;
                self.left_refine(v2, left, p, level + 1, !inn, pl);
                self.append(v1);
                if out == BOTTOM {
                    self.append(v2);
                }
            }
        } else {
            self.start_or_turn(if inn == SIDE { v1 } else { v2 });
            if is_right {
                if inn == BOTTOM {
                    self.append(v1);
                }
                self.append(v2);
                self.right_refine(v2, right, v1, level + 1, !out, pr);
            } else if inn == SIDE {
                self.append(v2);
                if out == SIDE {
                    self.append(v1);
                }
            } else {
                self.append(v1);
            }
        }
    }

    fn start_or_turn(&mut self, v: P) {
        if self.first {
            self.append(v);
            self.first = false;
        } else {
            self.turn_corner();
        }
    }

    /// Right-only refinement: a loop (tail recursion), at most `levels` iterations.
    fn right_refine(&mut self, v1: P, v2: P, p: P, level: u32, out: bool, planes: u8) {
        let (mut v1, mut v2, mut p, mut level, mut out, mut planes) =
            (v1, v2, p, level, out, planes);
        for _ in 0..=self.levels {
            self.append(v2);
            let q = (2 * v2.0 - p.0, 2 * v2.1 - p.1);
            let right = mid(v1, q);
            let is_right = self.active(right, level + 1, &mut planes);
            p = v1;
            v1 = v2;
            v2 = right;
            level += 1;
            out = !out;
            if !is_right {
                break;
            }
        }
        if out == BOTTOM {
            self.turn_corner();
        }
    }

    /// Left-only refinement: never tests right children.
    fn left_refine(&mut self, v1: P, v2: P, p: P, level: u32, inn: bool, planes: u8) {
        let left = mid(p, v1);
        let mut pl = planes;
        if self.active(left, level + 1, &mut pl) {
            self.left_refine(v2, left, p, level + 1, !inn, pl);
        } else {
            self.start_or_turn(if inn == SIDE { v1 } else { v2 });
            if inn == SIDE {
                self.append(v2);
            }
        }
        self.append(v1);
    }

    /// The whole square: four base triangles around the centre.
    fn run(&mut self) {
        let n = self.r.g.side() as i64;
        if n < 2 {
            // 2 x 2 grid: the two triangles of the single cell.
            for v in [(1, 0), (1, 1), (0, 0), (0, 1)] {
                self.append(v);
            }
            return;
        }
        let h = n / 2;
        let c = (h, h);
        let mask = self.r.view.map_or(0, |v| v.mask);
        let mut pc = mask;
        let _ = self.active(c, 0, &mut pc);
        let bases = [
            ((h, 0), (0, 0), (n, 0)),
            ((n, h), (n, 0), (n, n)),
            ((h, n), (n, n), (0, n)),
            ((0, h), (0, n), (0, 0)),
        ];
        self.append((0, 0));
        self.append((0, 0));
        for (m, p, q) in bases {
            let mut pm = pc;
            let _ = self.active(m, 1, &mut pm);
            self.left_only = false;
            self.refine(c, m, p, 1, SIDE, SIDE, pm);
            self.append(q);
        }
    }

    /// Starts a new piece of the strip at `p` as the whole strip starts: `p` twice, the second
    /// at an odd position (`odd`) or an even one. Before it, the last vertex repeated and `p`
    /// repeated: degenerate triangles only (at most four indices; fewer when the strip so far
    /// ends with `p`: from `(p, y)`, `p` twice leaves `(p, p)`, the window `(p, y, p)` being
    /// degenerate).
    fn restart(&mut self, p: P, odd: bool) {
        if self.len > 0 && self.last[1] != p && (self.len < 2 || self.last[0] != p) {
            let v = self.last[1];
            self.append(v);
        }
        // At most three appends: `p`, `p` and one more to fix the position's parity.
        for _ in 0..3 {
            let at_odd = self.len.is_multiple_of(2); // the last index is at len - 1
            if self.len >= 2 && self.last == [p, p] && at_odd == odd {
                break;
            }
            self.append(p);
        }
        self.first = true;
        self.left_only = false;
    }

    /// Draws the counter-clockwise triangle `t` alone, joined to the strip so far by the
    /// fewest degenerate triangles (at most [`BRIDGE`] indices in all; three on an empty
    /// strip). A piece of one triangle needs no fixed entry, so it can start from whatever
    /// the strip ends with: the shortest run of [`Runs`] into any state of the triangle.
    fn bridge(&mut self, runs: &mut Runs, t: [P; 3]) {
        if self.len < 2 {
            for v in t {
                self.append(v);
            }
            return;
        }
        let [x, y] = self.last;
        let par = self.len % 2;
        let best = runs
            .get(x, y, par, t)
            .iter()
            .copied()
            .min_by_key(|r| r.0)
            .unwrap_or((u8::MAX, [0; BRIDGE]));
        // Never `u8::MAX`: the strip so far ending anywhere, `y`, `l`, `l`, `r`, `a` (and one
        // more `l` for the parity) draw the triangle.
        for &l in best.1.iter().take(usize::from(best.0).min(BRIDGE)) {
            self.append(Runs::vertex(t, x, y, l));
        }
    }

    /// A grid that does not fill its square: the triangles across the domain's edge split,
    /// each triangle `(l, r, a)` inside (counter-clockwise, its split vertex `mid(l, r)` at
    /// `level`) gets its own piece of strip: drawn alone when it does not split
    /// ([`Self::bridge`]), else from one end of its hypotenuse to the other
    /// ([`Self::restart`]), the in/out-edge strip's (`soar == false`) or SOAR's. SOAR's
    /// parity: a vertex at `level` (the square's centre is 0, the corners -1) sits at odd
    /// positions when `levels - level` is odd (the number of levels is even).
    fn run_domain(&mut self, soar: bool) {
        let mask = self.r.view.map_or(0, |v| v.mask);
        let (g, levels) = (self.r.g, self.levels);
        // The shortest joins of pieces of one triangle, found as the pieces need them.
        let mut runs = Runs::new(true);
        // A vertex's side of the strip; the square's corners (no level) are on the odd side.
        let parity = |v: P| {
            g.level(v.0 as u32, v.1 as u32)
                .is_none_or(|lv| levels.saturating_sub(lv) % 2 == 1)
        };
        g.walk_edge(|e| {
            let Edge::Inside(l, r, a, level) = e else {
                return true;
            };
            let m = mid(l, r);
            // Both strips' recursions enter a triangle `(p, q, i)` at `p`, and it turns
            // counter-clockwise when its apex `i` has an even level, as the base triangles do,
            // and clockwise when odd: entered at `l` or at `r`. In the order of the walk, a
            // piece then starts where the one before it ended, when the two touch.
            let apex = level.saturating_sub(1);
            let even = apex % 2 == 0;
            let (p, q) = if even { (l, r) } else { (r, l) };
            // A piece of one triangle (its split vertex inactive) is joined to the strip by
            // the fewest indices ([`Self::bridge`]); a larger one is entered at `p`. (SOAR's
            // recursion then tests `m` again, as it tests every vertex twice.)
            let mut pm = mask;
            if !self.active(m, level, &mut pm) {
                self.bridge(&mut runs, [l, r, a]);
            } else if soar {
                let (pp, pq) = (parity(p), parity(q));
                self.restart(p, pp);
                self.parity = pp;
                // The apex is active: the triangle's parent split.
                self.soar_submesh(a, m, p, apex, mask, true);
                self.append_parity(q, pq);
            } else {
                // As the whole strip starts at an odd position for its counter-clockwise base
                // triangles, a clockwise piece starts at an even one.
                self.restart(p, even);
                self.refine(a, m, p, level, SIDE, SIDE, pm);
                self.append(q);
            }
            true
        });
    }
}

/// Longest run of indices [`strip_fewest_indices`] appends between two consecutive triangles:
/// enough to join any two triangles (the last index repeated, the next triangle's first index
/// twice, its other two, and one more to set the position's parity).
const BRIDGE: usize = 6;

/// The fewest indices of any generalized triangle strip that draws the triangles of `strip`
/// ([`strip_triangles`]) in the same order, each counter-clockwise with `winding` (every window
/// of three indices either degenerate or the next triangle, turned by its position's parity)
/// or either way round without (for drawing with back faces kept), or `None` when `strip`
/// draws no triangle. This measures how far a strip's degenerate triangles are from
/// the least its triangle order allows, by dynamic programming over the strip's possible ends:
/// after each triangle, the ordered pair of its vertices last in the strip and the parity of
/// the next position (12 states), each reached from the ones before by the shortest run of
/// appended indices (at most 6) whose windows are degenerate until the last. Time linear in
/// the strip's length, no allocation.
///
/// ```
/// use relief_core::refine::{strip_fewest_indices, strip_triangles};
/// // A fan of four triangles around vertex 0 drawn as a strip: each pair of consecutive
/// // triangles shares an edge, and one repeated index turns the strip round vertex 0.
/// let strip = [1, 2, 0, 3, 0, 4, 5];
/// assert_eq!(strip_triangles(&strip).count(), 4);
/// assert_eq!(strip_fewest_indices(&strip, true), Some(7));
/// // The same triangles with a wasted join: two more indices than needed.
/// let wasteful = [1, 2, 0, 3, 3, 3, 0, 4, 5];
/// assert!(strip_triangles(&wasteful).eq(strip_triangles(&strip)));
/// assert_eq!(strip_fewest_indices(&wasteful, true), Some(7));
/// ```
pub fn strip_fewest_indices(strip: &[u32], winding: bool) -> Option<usize> {
    fewest_forward(strip, &mut Runs::new(winding), &mut |_, _, _| {}).map(|(n, _, _)| n)
}

/// States of [`fewest_forward`]: the next window's parity (6 apart) and the ordered pair of
/// distinct vertex slots `(i, j)` of the last triangle that end the strip.
const STATES: usize = 12;

/// The state of parity `par` ending with slots `(i, j)`, `i != j`.
#[inline]
fn state(par: usize, i: usize, j: usize) -> usize {
    par * 6 + i * 2 + j - usize::from(j > i)
}

/// The parity and slots of state `s` ([`state`]'s inverse).
#[inline]
fn unstate(s: usize) -> (usize, usize, usize) {
    let (par, q) = (s / 6, s % 6);
    let i = q / 2;
    let j = q % 2 + usize::from(q % 2 >= i);
    (par, i, j)
}

/// The dynamic programme of [`strip_fewest_indices`] (its bridges from `runs`, whose
/// winding it keeps): the fewest indices, the state they end in and the triangles drawn; `record(k, to, from)` is called whenever state `to` of the `k`-th triangle (from 1)
/// gets a new best, reached from state `from` of the triangle before (so the last call for a
/// state names its best predecessor).
fn fewest_forward(
    strip: &[u32],
    runs: &mut Runs,
    record: &mut impl FnMut(usize, usize, usize),
) -> Option<(usize, usize, usize)> {
    let winding = runs.winding;
    let mut tris = strip_triangles(strip);
    let first = tris.next()?;
    let mut cost = [usize::MAX; STATES];
    for r in 0..3 {
        let (a, b, c) = (r, (r + 1) % 3, (r + 2) % 3);
        // The triangle at position 0 as (a, b, c), or at position 1 as (b, a, c) after one
        // repeated index; without winding, either way round.
        for (s, n) in [(state(1, b, c), 3), (state(0, a, c), 4)] {
            if let Some(e) = cost.get_mut(s) {
                *e = n;
            }
        }
        if !winding {
            for (s, n) in [(state(1, a, c), 3), (state(0, b, c), 4)] {
                if let Some(e) = cost.get_mut(s) {
                    *e = n;
                }
            }
        }
    }
    let mut prev = first;
    let mut count = 1;
    for (k, t) in tris.enumerate() {
        count += 1;
        let mut next = [usize::MAX; STATES];
        for (from, &c) in cost.iter().enumerate() {
            if c == usize::MAX {
                continue;
            }
            let (par, i, j) = unstate(from);
            let (Some(&a), Some(&b)) = (prev.get(i), prev.get(j)) else {
                continue;
            };
            for (to, run) in runs.get(a, b, par, t).iter().enumerate() {
                let Some(e) = next.get_mut(to) else {
                    continue;
                };
                let via = c.saturating_add(usize::from(run.0));
                if run.0 != u8::MAX && via < *e {
                    *e = via;
                    record(k + 1, to, from);
                }
            }
        }
        cost = next;
        prev = t;
    }
    let (s, &n) = cost.iter().enumerate().min_by_key(|&(_, &n)| n)?;
    (n != usize::MAX).then_some((n, s, count))
}

/// Bytes of scratch [`strip_fewest`] needs for a strip of `len` indices: 6 per triangle it can
/// draw (`len - 2`).
///
/// ```
/// assert_eq!(relief_core::refine::strip_fewest_scratch_len(10), 48);
/// ```
#[must_use]
pub const fn strip_fewest_scratch_len(len: usize) -> usize {
    len.saturating_sub(2).saturating_mul(6)
}

/// Rewrites `strip` as the fewest indices that draw its triangles in the same order
/// ([`strip_fewest_indices`], which is the length returned): each counter-clockwise with
/// `winding` (the same triangles, each turned as `strip` draws it), or either way round
/// without. `out` of `strip.len()` indices always suffices (the strip itself is one such
/// strip). `scratch` holds the dynamic programme's choices, [`strip_fewest_scratch_len`]
/// bytes. Errors: [`Error::BufferTooSmall`] for `scratch` or `out`. An empty result (0) when
/// `strip` draws no triangle. Time linear in `strip.len()`, no allocation.
///
/// The strips of [`Refiner::inout_strip`] and [`Refiner::soar_strip`] already are the fewest
/// for their order on a square grid, up to their start; off it, where they are made of pieces,
/// this saves up to about a tenth (BENCHMARKS.md).
///
/// ```
/// use relief_core::refine::{strip_fewest, strip_fewest_scratch_len, strip_triangles};
/// // A fan of four triangles with a wasted join (two repeated indices too many).
/// let wasteful = [1, 2, 0, 3, 3, 3, 0, 4, 5];
/// let mut scratch = vec![0u8; strip_fewest_scratch_len(wasteful.len())];
/// let mut out = [0u32; 9];
/// let n = strip_fewest(&wasteful, true, &mut scratch, &mut out).unwrap();
/// assert_eq!(n, 7);
/// assert!(strip_triangles(&out[..n]).eq(strip_triangles(&wasteful)));
/// ```
pub fn strip_fewest(
    strip: &[u32],
    winding: bool,
    scratch: &mut [u8],
    out: &mut [u32],
) -> Result<usize, Error> {
    need(strip_fewest_scratch_len(strip.len()), scratch.len())?;
    // Back-pointers: triangle k (from 1) has 6 bytes at 6 (k - 1), a nibble per state.
    let mut put = |k: usize, to: usize, from: usize| {
        if let Some(b) = scratch.get_mut(6 * (k - 1) + to / 2) {
            let shift = 4 * (to % 2);
            *b = (*b & !(0xf << shift)) | ((from as u8 & 0xf) << shift);
        }
    };
    let mut runs = Runs::new(winding);
    let Some((n, last, tris)) = fewest_forward(strip, &mut runs, &mut put) else {
        return Ok(0);
    };
    need(n, out.len())?;
    // Back from the last triangle: each triangle's chosen state, kept in the first byte of its
    // own back-pointers once they are read.
    let mut s = last;
    for k in (1..tris).rev() {
        let base = 6 * (k - 1);
        let from = scratch
            .get(base + s / 2)
            .map_or(0, |b| usize::from((b >> (4 * (s % 2))) & 0xf));
        if let Some(b) = scratch.get_mut(base) {
            *b = s as u8;
        }
        s = from;
    }
    // Forward: the first triangle in its state, then the shortest bridge into each next state.
    let mut w = 0usize;
    let mut emit = |v: u32, w: &mut usize| {
        if let Some(o) = out.get_mut(*w) {
            *o = v;
        }
        *w += 1;
    };
    let mut it = strip_triangles(strip);
    let Some(first) = it.next() else {
        return Ok(0);
    };
    let (par, i, j) = unstate(s);
    let (u, v) = (first.get(i).copied(), first.get(j).copied());
    let third = first
        .iter()
        .copied()
        .find(|&x| Some(x) != u && Some(x) != v);
    let (Some(u), Some(v), Some(third)) = (u, v, third) else {
        return Err(Error::Internal {
            what: "strip_fewest: a state outside the triangle",
        });
    };
    // Position 0 as (third, u, v), or position 1 after `third` repeated.
    if par == 0 {
        emit(third, &mut w);
    }
    for x in [third, u, v] {
        emit(x, &mut w);
    }
    let (mut a, mut b, mut p) = (u, v, par);
    for (k, t) in it.enumerate() {
        let to = scratch.get(6 * k).map_or(0, |&x| usize::from(x));
        let (np, i, j) = unstate(to);
        let (Some(&x), Some(&y)) = (t.get(i), t.get(j)) else {
            return Err(Error::Internal {
                what: "strip_fewest: a state outside the triangle",
            });
        };
        let (len, labels) = runs
            .get(a, b, p, t)
            .get(to)
            .copied()
            .unwrap_or((u8::MAX, [0; 6]));
        if len == u8::MAX {
            return Err(Error::Internal {
                what: "strip_fewest: no bridge into the chosen state",
            });
        }
        for &l in labels.iter().take(usize::from(len)) {
            emit(Runs::vertex(t, a, b, l), &mut w);
        }
        (a, b, p) = (x, y, np);
    }
    if w != n {
        return Err(Error::Internal {
            what: "strip_fewest: the strip written differs from its count",
        });
    }
    Ok(n)
}

/// Patterns of [`Runs`]: where the strip's last two indices are in the next triangle (the
/// first a vertex or not: 4; the second a vertex, equal to the first, or another: 5), and the
/// parity.
const PATTERNS: usize = 4 * 5 * 2;

/// A shortest run of appended indices in canonical labels (the next triangle's vertices 0, 1
/// and 2, the strip's last two indices 3 and 4 when they are not in it): its length
/// (`u8::MAX`: none) and labels.
type Run = (u8, [u8; BRIDGE]);

/// No run into any state.
const NO_RUNS: [Run; STATES] = [(u8::MAX, [0; BRIDGE]); STATES];

/// The shortest bridges of [`fewest_forward`] and [`strip_fewest`], found once per pattern:
/// for each way the strip's last two indices can relate to the next triangle (each a vertex
/// of it or another index, the second possibly equal to the first) and each parity, the
/// shortest run into each state of the triangle.
struct Runs {
    winding: bool,
    runs: [[Run; STATES]; PATTERNS],
    known: [bool; PATTERNS],
}

impl Runs {
    fn new(winding: bool) -> Runs {
        Runs {
            winding,
            runs: [NO_RUNS; PATTERNS],
            known: [false; PATTERNS],
        }
    }

    /// The canonical label of `v` after `(a, b)` before triangle `t`.
    fn label<V: Copy + PartialEq>(t: [V; 3], a: V, v: V) -> u8 {
        match slot(t, v) {
            Some(k) => k as u8,
            None if v == a => 3,
            None => 4,
        }
    }

    /// The index a label stands for.
    fn vertex<V: Copy>(t: [V; 3], a: V, b: V, label: u8) -> V {
        match label {
            0..=2 => t.get(usize::from(label)).copied().unwrap_or(a),
            3 => a,
            _ => b,
        }
    }

    /// The shortest runs from `(a, b)` (the next window at parity `par`) into each state of
    /// `t` ([`state`]).
    fn get<V: Copy + PartialEq>(&mut self, a: V, b: V, par: usize, t: [V; 3]) -> &[Run; STATES] {
        let (la, lb) = (Self::label(t, a, a), Self::label(t, a, b));
        let key = (usize::from(la.min(3)) * 5 + usize::from(lb)) * 2 + par;
        let key = key.min(PATTERNS - 1);
        if !self.known.get(key).copied().unwrap_or(true) {
            if let Some(row) = self.runs.get_mut(key) {
                *row = shortest_runs(la, lb, par, self.winding);
            }
            if let Some(k) = self.known.get_mut(key) {
                *k = true;
            }
        }
        self.runs.get(key).unwrap_or(&NO_RUNS)
    }
}

/// Where `v` is in `t`.
fn slot<V: Copy + PartialEq>(t: [V; 3], v: V) -> Option<usize> {
    t.iter().position(|&u| u == v)
}

/// Label states of [`shortest_runs`]: the strip's last two labels (0 to 4 each) and the parity.
const LABEL_STATES: usize = 5 * 5 * 2;

/// The shortest runs of appended labels from `(la, lb)` (the next window at parity `par`) into
/// each state of the triangle `(0, 1, 2)` ([`state`]): every window degenerate until the last,
/// which draws the triangle counter-clockwise (either way round unless `winding`), at most
/// [`BRIDGE`] labels. A breadth-first search over the label states the degenerate windows
/// reach (at most 50), each then closed by one drawing append.
fn shortest_runs(la: u8, lb: u8, par: usize, winding: bool) -> [Run; STATES] {
    let idx = |a: u8, b: u8, p: usize| (usize::from(a) * 5 + usize::from(b)) * 2 + p;
    let alphabet = [la, lb, 0, 1, 2];
    let letters = |k: usize| alphabet.get(k).is_some_and(|z| !alphabet[..k].contains(z));
    // Distance, and the state and label each was first reached from.
    let mut dist = [u8::MAX; LABEL_STATES];
    let mut from = [(0usize, 0u8); LABEL_STATES];
    let mut queue = [(0u8, 0u8, 0usize); LABEL_STATES];
    let (mut head, mut tail) = (0usize, 0usize);
    let start = idx(la, lb, par);
    if let (Some(d), Some(q)) = (dist.get_mut(start), queue.get_mut(0)) {
        *d = 0;
        *q = (la, lb, par);
        tail = 1;
    }
    let mut out = NO_RUNS;
    while head < tail {
        let Some(&(a, b, p)) = queue.get(head) else {
            break;
        };
        head += 1;
        let here = idx(a, b, p);
        let d = dist.get(here).copied().unwrap_or(u8::MAX);
        if usize::from(d) >= BRIDGE {
            continue;
        }
        for (k, &z) in alphabet.iter().enumerate() {
            if !letters(k) {
                continue;
            }
            if a == b || b == z || a == z {
                // A degenerate window: a new state, if not reached before.
                let there = idx(b, z, p ^ 1);
                if dist.get(there).is_some_and(|&e| e == u8::MAX) && usize::from(d) + 1 < BRIDGE {
                    if let (Some(e), Some(f), Some(q)) = (
                        dist.get_mut(there),
                        from.get_mut(there),
                        queue.get_mut(tail),
                    ) {
                        *e = d + 1;
                        *f = (here, z);
                        *q = (b, z, p ^ 1);
                        tail += 1;
                    }
                }
                continue;
            }
            // A drawing window: the triangle, the right way round?
            let w = if p == 0 || !winding {
                [a, b, z]
            } else {
                [b, a, z]
            };
            let turns = |u: [u8; 3]| w == u || w == [u[1], u[2], u[0]] || w == [u[2], u[0], u[1]];
            if !(turns([0, 1, 2]) || (!winding && turns([0, 2, 1]))) {
                continue;
            }
            let Some(e) = out.get_mut(state(p ^ 1, usize::from(b), usize::from(z))) else {
                continue;
            };
            if d + 1 >= e.0 {
                continue;
            }
            // The run: back through the states to the start, then `z`.
            e.0 = d + 1;
            let mut at = here;
            let mut run = [0u8; BRIDGE];
            if let Some(r) = run.get_mut(usize::from(d)) {
                *r = z;
            }
            for slot in (0..usize::from(d)).rev() {
                let Some(&(prev, letter)) = from.get(at) else {
                    break;
                };
                if let Some(r) = run.get_mut(slot) {
                    *r = letter;
                }
                at = prev;
            }
            e.1 = run;
        }
    }
    out
}

/// The triangles a generalized strip ([`Refiner::inout_strip`], [`Refiner::soar_strip`])
/// draws, in its order: every three consecutive indices, degenerate triples skipped, those at
/// odd positions turned round so that all are counter-clockwise seen from +z.
///
/// ```
/// use relief_core::refine::strip_triangles;
/// let t: Vec<[u32; 3]> = strip_triangles(&[0, 1, 2, 3, 3, 4]).collect();
/// assert_eq!(t, vec![[0, 1, 2], [2, 1, 3]]);
/// ```
pub fn strip_triangles(strip: &[u32]) -> impl Iterator<Item = [u32; 3]> + '_ {
    strip.windows(3).enumerate().filter_map(|(k, t)| match *t {
        [a, b, c] if a != b && b != c && a != c => {
            Some(if k % 2 == 0 { [a, b, c] } else { [b, a, c] })
        }
        _ => None,
    })
}

impl<T: Terrain> Refiner<'_, '_, T> {
    /// Seed 004's in/out-edge generalized triangle strip (Balogh 2003, chapter 5.1) for a
    /// grid of any size: fills `vertices` (positions or grid coordinates, see
    /// [`MeshVertex`]) and `strip` (indices; every three consecutive
    /// indices form a triangle, counter-clockwise seen from +z on even positions and clockwise on
    /// odd ones, degenerate triangles included) and returns the counts.
    ///
    /// On a square `(2^k+1)^2` grid the square's centre and side midpoints are always refined;
    /// on any other grid the triangles across the domain's edge are (as in
    /// [`Refiner::triangles`]), and the strip is made of one piece per triangle inside, joined
    /// by degenerate triangles ([`strip_bound`](super::strip_bound) counts them). Culled
    /// vertices are treated as inactive (their triangles drawn coarse, as SOAR does), and
    /// culling is tested at every level: lazy culling
    /// ([`View::with_lazy_levels`](super::View::with_lazy_levels)) would leave T-vertices
    /// outside the view, which a strip cannot draw (its triangles are consecutive indices, so
    /// they would come out wrong). Buffers too small:
    /// [`Error::BufferTooSmall`]; coordinates that do not fit the vertex type:
    /// [`Error::SizeOverflow`].
    ///
    /// ```
    /// use relief_core::refine::{preprocess, scratch_len, strip_bound, Criterion, Refiner};
    /// use relief_core::Heightfield;
    /// let hf = Heightfield::new(&[0.0f32; 25], 5, 5).unwrap();
    /// let (mut e, mut r) = ([0.0; 25], [0.0; 25]);
    /// let h = preprocess(&hf, &mut e, &mut r).unwrap();
    /// let rf = Refiner::new(&h, &hf, Criterion::MaxError(1.0)).unwrap();
    /// let mut v = vec![[0.0f32; 3]; 25];
    /// let mut s = vec![0u32; strip_bound(5, 5)];
    /// let c = rf.inout_strip(&mut vec![0; scratch_len(5, 5)], &mut v, &mut s).unwrap();
    /// assert_eq!((c.vertices, c.triangles), (9, 8)); // flat: the four base triangles, halved
    ///
    /// // 5 x 3: the triangles across the domain's edge split, down to the two of the domain.
    /// let hf = Heightfield::new(&[0.0f32; 15], 5, 3).unwrap();
    /// let (mut e, mut r) = ([0.0; 15], [0.0; 15]);
    /// let h = preprocess(&hf, &mut e, &mut r).unwrap();
    /// let rf = Refiner::new(&h, &hf, Criterion::MaxError(1.0)).unwrap();
    /// let mut s = vec![0u32; strip_bound(5, 3)];
    /// let c = rf.inout_strip(&mut vec![0; scratch_len(5, 3)], &mut v, &mut s).unwrap();
    /// assert_eq!(c.triangles, rf.count(&mut vec![0; scratch_len(5, 3)]).unwrap().triangles);
    /// ```
    pub fn inout_strip<P: MeshVertex>(
        &self,
        scratch: &mut [u64],
        vertices: &mut [P],
        strip: &mut [u32],
    ) -> Result<StripCounts, Error> {
        self.strip(scratch, vertices, strip, false)
    }

    /// SOAR's original generalized triangle strip (Lindstrom & Pascucci 2001: `submesh_refine`
    /// appending each triangle's apex between its children, `tstrip_append` inserting a
    /// degenerate triangle when parities match), for a grid of any size; same buffers,
    /// counts, errors, culling and pieces as [`Refiner::inout_strip`]. On a square
    /// `(2^k+1)^2` grid the square's centre is always refined.
    ///
    /// ```
    /// use relief_core::refine::{preprocess, scratch_len, strip_bound, Criterion, Refiner};
    /// use relief_core::Heightfield;
    /// let hf = Heightfield::new(&[0.0f32; 25], 5, 5).unwrap();
    /// let (mut e, mut r) = ([0.0; 25], [0.0; 25]);
    /// let h = preprocess(&hf, &mut e, &mut r).unwrap();
    /// let rf = Refiner::new(&h, &hf, Criterion::MaxError(1.0)).unwrap();
    /// let mut v = vec![[0.0f32; 3]; 25];
    /// let mut s = vec![0u32; strip_bound(5, 5)];
    /// let c = rf.soar_strip(&mut vec![0; scratch_len(5, 5)], &mut v, &mut s).unwrap();
    /// assert_eq!((c.vertices, c.triangles), (5, 4)); // flat: the four base triangles
    /// ```
    pub fn soar_strip<P: MeshVertex>(
        &self,
        scratch: &mut [u64],
        vertices: &mut [P],
        strip: &mut [u32],
    ) -> Result<StripCounts, Error> {
        self.strip(scratch, vertices, strip, true)
    }

    /// The counts that [`Refiner::inout_strip`] returns, without writing anything: the
    /// buffers' sizes for this frame (the strip is walked once, as the first of
    /// `inout_strip`'s two passes). Errors as [`Refiner::count`]'s.
    ///
    /// ```
    /// use relief_core::refine::{preprocess, scratch_len, Criterion, Refiner};
    /// use relief_core::Heightfield;
    /// let hf = Heightfield::new(&[0.0f32; 15], 5, 3).unwrap();
    /// let (mut e, mut r) = ([0.0; 15], [0.0; 15]);
    /// let h = preprocess(&hf, &mut e, &mut r).unwrap();
    /// let rf = Refiner::new(&h, &hf, Criterion::MaxError(1.0)).unwrap();
    /// let mut scratch = vec![0; scratch_len(5, 3)];
    /// let c = rf.inout_strip_counts(&mut scratch).unwrap();
    /// let (mut v, mut s) = (vec![[0u16; 2]; c.vertices], vec![0u32; c.indices]);
    /// assert_eq!(rf.inout_strip(&mut scratch, &mut v, &mut s).unwrap(), c);
    /// ```
    pub fn inout_strip_counts(&self, scratch: &mut [u64]) -> Result<StripCounts, Error> {
        self.strip_counts(scratch, false)
    }

    /// The counts that [`Refiner::soar_strip`] returns, without writing anything (as
    /// [`Refiner::inout_strip_counts`]).
    ///
    /// ```
    /// use relief_core::refine::{preprocess, scratch_len, Criterion, Refiner};
    /// use relief_core::Heightfield;
    /// let hf = Heightfield::new(&[0.0f32; 25], 5, 5).unwrap();
    /// let (mut e, mut r) = ([0.0; 25], [0.0; 25]);
    /// let h = preprocess(&hf, &mut e, &mut r).unwrap();
    /// let rf = Refiner::new(&h, &hf, Criterion::MaxError(1.0)).unwrap();
    /// let mut scratch = vec![0; scratch_len(5, 5)];
    /// let c = rf.soar_strip_counts(&mut scratch).unwrap();
    /// let (mut v, mut s) = (vec![[0.0f32; 3]; c.vertices], vec![0u32; c.indices]);
    /// assert_eq!(rf.soar_strip(&mut scratch, &mut v, &mut s).unwrap(), c);
    /// assert!(rf.soar_strip(&mut scratch, &mut v, &mut s[1..]).is_err());
    /// ```
    pub fn soar_strip_counts(&self, scratch: &mut [u64]) -> Result<StripCounts, Error> {
        self.strip_counts(scratch, true)
    }

    /// Geomorph data for the vertices of [`Refiner::inout_strip`], in the strip's vertex
    /// order (the same data [`Refiner::morph`] gives a vertex of the list: a vertex's morph
    /// depends on the vertex alone, so the strip's shared vertices move alike). `out` at
    /// least the strip's vertex count ([`Error::BufferTooSmall`]); returns that count.
    ///
    /// ```
    /// use relief_core::refine::{preprocess, scratch_len, Criterion, MorphVertex, Refiner, View};
    /// use relief_core::{Camera, Heightfield};
    /// use glam::Vec3;
    /// let s: Vec<f32> = (0..63).map(|i| ((i * 37) % 11) as f32).collect();
    /// let hf = Heightfield::new(&s, 9, 7).unwrap();
    /// let (mut e, mut r) = (vec![0.0; 63], vec![0.0; 63]);
    /// let h = preprocess(&hf, &mut e, &mut r).unwrap();
    /// let cam = Camera::new(Vec3::new(-5.0, -5.0, 20.0), Vec3::new(4.0, 4.0, 0.0), 60.0, 200, 200).unwrap();
    /// let view = View::new(&cam, 4.0).unwrap().with_geomorph(Some(2.0));
    /// let rf = Refiner::new(&h, &hf, Criterion::View(view)).unwrap();
    /// let mut scratch = vec![0; scratch_len(9, 7)];
    /// let c = rf.inout_strip_counts(&mut scratch).unwrap();
    /// let mut out = vec![MorphVertex::default(); c.vertices];
    /// assert_eq!(rf.inout_strip_morph(&mut scratch, &mut out).unwrap(), c.vertices);
    /// assert!(out.iter().all(|v| (0.0..=1.0).contains(&v.morph)));
    /// ```
    pub fn inout_strip_morph(
        &self,
        scratch: &mut [u64],
        out: &mut [MorphVertex],
    ) -> Result<usize, Error> {
        self.strip_morph(scratch, out, false)
    }

    /// Geomorph data for the vertices of [`Refiner::soar_strip`], in its vertex order (as
    /// [`Refiner::inout_strip_morph`]).
    ///
    /// ```
    /// use relief_core::refine::{preprocess, scratch_len, Criterion, MorphVertex, Refiner};
    /// use relief_core::Heightfield;
    /// let hf = Heightfield::new(&[0.0f32; 25], 5, 5).unwrap();
    /// let (mut e, mut r) = ([0.0; 25], [0.0; 25]);
    /// let h = preprocess(&hf, &mut e, &mut r).unwrap();
    /// let rf = Refiner::new(&h, &hf, Criterion::MaxError(1.0)).unwrap();
    /// let mut out = vec![MorphVertex::default(); 25];
    /// let n = rf.soar_strip_morph(&mut vec![0; scratch_len(5, 5)], &mut out).unwrap();
    /// assert!(out[..n].iter().all(|v| v.morph == 1.0)); // view-independent: no morph
    /// assert!(rf.soar_strip_morph(&mut vec![0; scratch_len(5, 5)], &mut out[..n - 1]).is_err());
    /// ```
    pub fn soar_strip_morph(
        &self,
        scratch: &mut [u64],
        out: &mut [MorphVertex],
    ) -> Result<usize, Error> {
        self.strip_morph(scratch, out, true)
    }

    fn strip_morph(
        &self,
        scratch: &mut [u64],
        out: &mut [MorphVertex],
        soar: bool,
    ) -> Result<usize, Error> {
        let strict = self.strict_culling();
        let mut m = marks(scratch, self.g.len())?;
        m.begin_sparse();
        let counts = strict.mark_strip(&mut m, soar);
        if counts.vertices > out.len() {
            m.end_sparse();
        }
        need(counts.vertices, out.len())?;
        let n = self.write_morph(m.bits, m.touched(), out);
        m.end_sparse();
        Ok(n)
    }

    fn strip_counts(&self, scratch: &mut [u64], soar: bool) -> Result<StripCounts, Error> {
        let strict = self.strict_culling();
        let mut m = marks(scratch, self.g.len())?;
        m.begin_sparse();
        let counts = strict.mark_strip(&mut m, soar);
        m.end_sparse();
        Ok(counts)
    }

    /// The first pass of a strip (culling already strict): marks its vertices in `m` (begun
    /// sparse), numbers them and returns the counts.
    fn mark_strip(&self, m: &mut Marks<'_>, soar: bool) -> StripCounts {
        let o = self.order();
        let pass = Strip::new(self, Mark { m, o }).walk(soar);
        let (indices, triangles, tested) = (pass.len, pass.tris, pass.tested);
        StripCounts {
            vertices: m.prefix_sparse(),
            indices,
            triangles,
            tested,
        }
    }

    fn strip<P: MeshVertex>(
        &self,
        scratch: &mut [u64],
        vertices: &mut [P],
        strip: &mut [u32],
        soar: bool,
    ) -> Result<StripCounts, Error> {
        self.fits_vertex::<P>()?;
        let strict = self.strict_culling();
        let mut m = marks(scratch, self.g.len())?;
        m.begin_sparse();
        let counts = strict.mark_strip(&mut m, soar);
        if counts.vertices > vertices.len() || counts.indices > strip.len() {
            m.end_sparse();
        }
        need(counts.vertices, vertices.len())?;
        need(counts.indices, strip.len())?;
        self.write_vertices_in(m.bits, m.touched(), vertices);
        let out = Write {
            bits: m.bits,
            prefix: m.prefix,
            o: self.order(),
            out: strip,
            n: 0,
        };
        Strip::new(&strict, out).walk(soar);
        m.end_sparse();
        Ok(counts)
    }
}
