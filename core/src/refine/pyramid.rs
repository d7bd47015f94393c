//! A min/max block pyramid of the heights and the exact branch-and-bound maximum of
//! `|h - plane|` over a hierarchy triangle, used by [`super::preprocess_pyramid`] and
//! [`super::update`] to compute the L-infinity errors of Lindstrom & Pascucci 2002 (and seed 004,
//! chapter 4.5) without visiting every sample of large triangles.
//!
//! Level `j` (`j >= 2`) holds, for every aligned `2^j x 2^j` block of samples (clipped to the
//! grid), the minimum and maximum local height; the top level is a single block. A block whose
//! bound `max(z_max - plane_min, plane_max - z_min)` cannot beat the best deviation found so far is
//! skipped; otherwise its four sub-blocks are searched, and `4 x 4` blocks are evaluated sample by
//! sample with the very formula of the rasterising path, so the maximum is bit-identical.
//!
//! Worst case: a triangle whose every block's bound exceeds the running maximum visits all its
//! samples plus the blocks above them (4/3 of the rasterising cost plus the bounds); a plane that
//! fits the terrain to within the local relief of each block is such a case.

use super::raster::{orient, span_deviation, Plane, RowSpans};
use crate::Terrain;

/// `log2` of the finest block side (4 x 4 samples).
const LEAF_LOG: u32 = 2;
/// At most this many levels (block sides up to `2^33`).
const MAX_LEVELS: usize = 32;
/// Depth-first stack entries: each pop pushes at most 4, depth is at most `MAX_LEVELS`.
const STACK: usize = 4 * MAX_LEVELS + 16;

/// Number of blocks of level `j` along a side of `n` samples.
#[inline(always)]
const fn blocks(n: u32, j: u32) -> usize {
    let s = 1u64 << j;
    (n as u64).div_ceil(s) as usize
}

/// `log2` of the top level's block side: the smallest `J >= 2` with `2^J >= max(width, height)`.
const fn top_level(width: u32, height: u32) -> u32 {
    let m = if width > height { width } else { height };
    let mut j = LEAF_LOG;
    while j < 40 && (1u64 << j) < m as u64 {
        j += 1;
    }
    j
}

/// Length of the pyramid buffer ([`super::preprocess_pyramid`], [`super::update`]): two `f32`
/// (min, max) per block over all levels, about `width * height / 6` (`0.67` bytes per sample).
///
/// ```
/// // 5 x 5 samples: 2 x 2 blocks of 4 x 4, then one 8 x 8 block: 5 blocks, 10 floats.
/// assert_eq!(relief_core::refine::pyramid_len(5, 5), 10);
/// ```
#[must_use]
pub const fn pyramid_len(width: u32, height: u32) -> usize {
    let top = top_level(width, height);
    let mut j = LEAF_LOG;
    let mut n = 0usize;
    while j <= top {
        n = n.saturating_add(blocks(width, j).saturating_mul(blocks(height, j)));
        j += 1;
    }
    n.saturating_mul(2)
}

/// Offsets (in blocks) of each level and the level count.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Layout {
    width: u32,
    height: u32,
    top: u32,
    offset: [usize; MAX_LEVELS],
}

impl Layout {
    pub(crate) fn new(width: u32, height: u32) -> Layout {
        let top = top_level(width, height).min(MAX_LEVELS as u32 - 1);
        let mut offset = [0usize; MAX_LEVELS];
        let mut acc = 0usize;
        let mut j = LEAF_LOG;
        while j <= top {
            if let Some(o) = offset.get_mut(j as usize) {
                *o = acc;
            }
            acc = acc.saturating_add(blocks(width, j).saturating_mul(blocks(height, j)));
            j += 1;
        }
        Layout {
            width,
            height,
            top,
            offset,
        }
    }

    #[inline(always)]
    fn index(&self, j: u32, bx: i64, by: i64) -> usize {
        let bw = blocks(self.width, j);
        let o = self.offset.get(j as usize).copied().unwrap_or(0);
        o.saturating_add((by as usize).saturating_mul(bw))
            .saturating_add(bx as usize)
            .saturating_mul(2)
    }

    /// The top level's (min, max) of `buf`: the range of every height.
    pub(crate) fn range(&self, buf: &[f32]) -> (f32, f32) {
        get(buf, self.index(self.top, 0, 0))
    }
}

#[inline(always)]
fn get(buf: &[f32], i: usize) -> (f32, f32) {
    match buf.get(i..i.saturating_add(2)) {
        Some(&[a, b]) => (a, b),
        _ => (f32::NEG_INFINITY, f32::INFINITY), // never: a bound that prunes nothing
    }
}

#[inline(always)]
fn put(buf: &mut [f32], i: usize, v: (f32, f32)) {
    if let Some([a, b]) = buf.get_mut(i..i.saturating_add(2)) {
        *a = v.0;
        *b = v.1;
    }
}

/// Recomputes the blocks of every level that cover samples `[x0, x1] x [y0, y1]` (clipped to
/// the grid): the finest from the terrain, the others from their sub-blocks.
pub(crate) fn fill<T: Terrain>(
    t: &T,
    l: &Layout,
    buf: &mut [f32],
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
) {
    let (w, h) = (l.width, l.height);
    if w == 0 || h == 0 {
        return;
    }
    let (x1, y1) = (x1.min(w - 1), y1.min(h - 1));
    if x0 > x1 || y0 > y1 {
        return;
    }
    let mut j = LEAF_LOG;
    while j <= l.top {
        let (bx0, bx1) = ((x0 >> j) as i64, (x1 >> j) as i64);
        let (by0, by1) = ((y0 >> j) as i64, (y1 >> j) as i64);
        let (cw, ch) = (blocks(w, j - 1) as i64, blocks(h, j - 1) as i64);
        for by in by0..=by1 {
            for bx in bx0..=bx1 {
                let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
                if j == LEAF_LOG {
                    let s = 1u32 << j;
                    let (sx0, sy0) = (bx as u32 * s, by as u32 * s);
                    let (sx1, sy1) = ((sx0 + s - 1).min(w - 1), (sy0 + s - 1).min(h - 1));
                    for y in sy0..=sy1 {
                        for x in sx0..=sx1 {
                            let z = t.local_z(x, y);
                            lo = lo.min(z);
                            hi = hi.max(z);
                        }
                    }
                } else {
                    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let (cx, cy) = (2 * bx + dx, 2 * by + dy);
                        if cx < cw && cy < ch {
                            let (a, b) = get(buf, l.index(j - 1, cx, cy));
                            lo = lo.min(a);
                            hi = hi.max(b);
                        }
                    }
                }
                put(buf, l.index(j, bx, by), (lo, hi));
            }
        }
        j += 1;
    }
}

/// Whether the closed rectangle `[x0, x1] x [y0, y1]` may meet the closed counter-clockwise
/// triangle `p` (exact integer test per edge; may say yes for a rectangle that misses it).
#[inline(always)]
fn may_meet(p: &[(i64, i64); 3], x0: i64, x1: i64, y0: i64, y1: i64) -> bool {
    for k in 0..3 {
        let (a, b) = (p[k], p[(k + 1) % 3]);
        let m = orient(a, b, (x0, y0))
            .max(orient(a, b, (x1, y0)))
            .max(orient(a, b, (x0, y1)))
            .max(orient(a, b, (x1, y1)));
        if m < 0 {
            return false;
        }
    }
    true
}

/// `max(floor, max over the samples of the closed triangle of |h - plane|)`, where every sample
/// term is computed exactly as the rasterising path computes it. Blocks whose bound is `<=` the
/// running maximum (which starts at `floor`) are skipped, so the result equals the rasterised
/// maximum whenever that exceeds `floor`, and is `floor` otherwise.
pub(crate) fn max_deviation<T: Terrain>(
    t: &T,
    l: &Layout,
    buf: &[f32],
    spans: &RowSpans,
    plane: &Plane,
    floor: f64,
) -> f64 {
    let p = spans.ccw();
    let (xl, xh, yl, yh) = spans.bbox();
    let ext = (xh - xl).max(yh - yl).max(1) as u64;
    // The coarsest level whose blocks are no larger than the triangle's extent.
    let mut j0 = LEAF_LOG;
    while j0 < l.top && (1u64 << (j0 + 1)) <= ext {
        j0 += 1;
    }
    let mut best = floor;
    let mut stack = [(0i64, 0i64, 0u32); STACK];
    for by in (yl >> j0)..=(yh >> j0) {
        for bx in (xl >> j0)..=(xh >> j0) {
            let mut n = 1usize;
            if let Some(s) = stack.get_mut(0) {
                *s = (bx, by, j0);
            }
            // Each pop removes one entry and pushes at most four sub-blocks of a finer level,
            // so the loop runs at most (blocks of the pyramid under this one) times.
            while n > 0 {
                n -= 1;
                let Some(&(cx, cy, j)) = stack.get(n) else {
                    break;
                };
                let s = 1i64 << j;
                let (rx0, ry0) = ((cx * s).max(xl), (cy * s).max(yl));
                let (rx1, ry1) = ((cx * s + s - 1).min(xh), (cy * s + s - 1).min(yh));
                if rx0 > rx1 || ry0 > ry1 || !may_meet(&p, rx0, rx1, ry0, ry1) {
                    continue;
                }
                let (zlo, zhi) = get(buf, l.index(j, cx, cy));
                let (plo, phi) = plane.range_over(rx0, rx1, ry0, ry1);
                let bound = (zhi as f64 - plo).max(phi - zlo as f64);
                if bound.is_nan() || bound <= best {
                    continue;
                }
                if j <= LEAF_LOG || n + 4 > STACK {
                    for y in ry0..=ry1 {
                        if let Some((lo, hi)) = spans.at(y) {
                            let row = span_deviation(t, plane, y, lo.max(rx0), hi.min(rx1));
                            if row > best {
                                best = row;
                            }
                        }
                    }
                    continue;
                }
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    if let Some(e) = stack.get_mut(n) {
                        *e = (2 * cx + dx, 2 * cy + dy, j - 1);
                        n += 1;
                    }
                }
            }
        }
    }
    best
}
