//! Exact integer rasterisation of triangles with grid-point corners, and the one plane formula
//! shared by preprocessing and the error scan (so that both see bit-identical mesh heights).

use crate::Terrain;

/// A plane through three grid points, evaluated by one fixed formula in `f64`.
///
/// The corners are sorted by `(y, x)` first, so the same three points give the same plane (and
/// the same rounding) whatever order a caller lists them in.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Plane {
    x0: i64,
    y0: i64,
    z0: f64,
    gx: f64,
    gy: f64,
}

impl Plane {
    /// `None` for a degenerate (collinear) triangle. Always inlined: preprocessing's finest
    /// level calls it with constant relative coordinates, which then fold.
    #[inline(always)]
    pub(crate) fn new(mut p: [(i64, i64, f64); 3]) -> Option<Plane> {
        // A three-element sorting network by (y, x) (the generic sort is slow for three).
        let key = |q: &(i64, i64, f64)| (q.1, q.0);
        if key(&p[1]) < key(&p[0]) {
            p.swap(0, 1);
        }
        if key(&p[2]) < key(&p[1]) {
            p.swap(1, 2);
        }
        if key(&p[1]) < key(&p[0]) {
            p.swap(0, 1);
        }
        let [(x0, y0, z0), (x1, y1, z1), (x2, y2, z2)] = p;
        let (ax, ay, az) = ((x1 - x0) as f64, (y1 - y0) as f64, z1 - z0);
        let (bx, by, bz) = ((x2 - x0) as f64, (y2 - y0) as f64, z2 - z0);
        let det = ax * by - bx * ay;
        if det == 0.0 {
            return None;
        }
        let gx = (az * by - bz * ay) / det;
        let gy = (ax * bz - bx * az) / det;
        Some(Plane { x0, y0, z0, gx, gy })
    }

    /// Height of the plane over grid point `(x, y)`.
    #[inline(always)]
    pub(crate) fn at(&self, x: i64, y: i64) -> f64 {
        self.z0 + self.gx * (x - self.x0) as f64 + self.gy * (y - self.y0) as f64
    }

    /// Bounds `(lo, hi)` on the values [`Plane::at`] computes over the rectangle
    /// `[x0, x1] x [y0, y1]` (`x0 <= x1`, `y0 <= y1`): the corner values widened by a margin
    /// (`2^-40` of the largest term) far above the few ulps of rounding `at` can add, so that
    /// every computed value inside lies in `[lo, hi]`.
    #[inline]
    pub(crate) fn range_over(&self, x0: i64, x1: i64, y0: i64, y1: i64) -> (f64, f64) {
        let (ax, bx) = (
            self.gx * (x0 - self.x0) as f64,
            self.gx * (x1 - self.x0) as f64,
        );
        let (ay, by) = (
            self.gy * (y0 - self.y0) as f64,
            self.gy * (y1 - self.y0) as f64,
        );
        let lo = self.z0 + ax.min(bx) + ay.min(by);
        let hi = self.z0 + ax.max(bx) + ay.max(by);
        let m = self.z0.abs() + ax.abs().max(bx.abs()) + ay.abs().max(by.abs());
        let tol = m * (1.0 / (1u64 << 40) as f64) + f64::MIN_POSITIVE;
        (lo - tol, hi + tol)
    }
}

/// `max |h - plane|` over the samples `lo..=hi` of row `y` (in the grid), read with
/// [`Terrain::fold_local_z_row`] (bit for bit `local_z`), with [`Plane::at`]'s very terms: the
/// row's part `gy (y - y0)` is computed once and `(x + k - x0)` is carried as an exact `f64`
/// counter; four independent maxima over the quads (a maximum does not depend on the order) let
/// the loop vectorise, and the heights stay in registers. Loops `(hi - lo + 1) / 4 + 3` times.
#[inline]
pub(crate) fn span_deviation<T: Terrain>(t: &T, plane: &Plane, y: i64, lo: i64, hi: i64) -> f64 {
    if hi < lo {
        return 0.0;
    }
    let n = (hi - lo + 1) as usize;
    let cy = plane.gy * (y - plane.y0) as f64;
    let x0 = (lo - plane.x0) as f64;
    let (z0, gx) = (plane.z0, plane.gx);
    // (per-lane maxima, per-lane columns relative to the plane's corner, the single samples'
    // maximum, the next single sample's offset from lane 0's column)
    let start = (
        [0.0f64; 4],
        [x0, x0 + 1.0, x0 + 2.0, x0 + 3.0],
        0.0f64,
        0.0f64,
    );
    let (acc, _, rest, _) = t.fold_local_z_row(
        lo as u32,
        y as u32,
        n,
        start,
        |(mut acc, mut xs, rest, k), q| {
            for ((a, xk), h) in acc.iter_mut().zip(xs.iter_mut()).zip(q) {
                let d = (h as f64 - ((z0 + gx * *xk) + cy)).abs();
                *a = if d > *a { d } else { *a };
                *xk += 4.0;
            }
            (acc, xs, rest, k)
        },
        |(acc, xs, rest, k), h| {
            let d = (h as f64 - ((z0 + gx * (xs[0] + k)) + cy)).abs();
            (acc, xs, if d > rest { d } else { rest }, k + 1.0)
        },
    );
    let mut m = rest;
    for a in acc {
        m = if a > m { a } else { m };
    }
    m
}

/// Twice the signed area of `(a, b, c)`: positive when counter-clockwise (y up).
#[inline(always)]
pub(crate) const fn orient(a: (i64, i64), b: (i64, i64), c: (i64, i64)) -> i64 {
    (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0)
}

/// A closed triangle prepared for row queries: [`RowSpans::at`] gives the same spans as
/// [`for_each_span`] (one formula for both).
#[derive(Clone, Copy, Debug)]
pub(crate) struct RowSpans {
    p: [(i64, i64); 3],
    x_lo: i64,
    x_hi: i64,
    y_lo: i64,
    y_hi: i64,
}

impl RowSpans {
    /// `None` for a degenerate triangle.
    pub(crate) fn new(a: (i64, i64), b: (i64, i64), c: (i64, i64)) -> Option<RowSpans> {
        let o = orient(a, b, c);
        if o == 0 {
            return None;
        }
        Some(RowSpans {
            p: if o > 0 { [a, b, c] } else { [a, c, b] },
            x_lo: a.0.min(b.0).min(c.0),
            x_hi: a.0.max(b.0).max(c.0),
            y_lo: a.1.min(b.1).min(c.1),
            y_hi: a.1.max(b.1).max(c.1),
        })
    }

    /// The corners, counter-clockwise.
    pub(crate) fn ccw(&self) -> [(i64, i64); 3] {
        self.p
    }

    /// Bounding box `(x_lo, x_hi, y_lo, y_hi)`.
    pub(crate) fn bbox(&self) -> (i64, i64, i64, i64) {
        (self.x_lo, self.x_hi, self.y_lo, self.y_hi)
    }

    /// Inclusive column span of row `y`, `None` when the row holds no grid point.
    #[inline]
    pub(crate) fn at(&self, y: i64) -> Option<(i64, i64)> {
        if y < self.y_lo || y > self.y_hi {
            return None;
        }
        let (mut lo, mut hi) = (self.x_lo, self.x_hi);
        for k in 0..3 {
            let (px, py) = self.p[k];
            let (qx, qy) = self.p[(k + 1) % 3];
            let (ex, ey) = (qx - px, qy - py);
            if ey == 0 {
                if ex * (y - py) < 0 {
                    return None;
                }
                continue;
            }
            let bound_floor_ceil = if ex == 0 {
                (px, px)
            } else if ex == ey {
                (px + (y - py), px + (y - py))
            } else if ex == -ey {
                (px - (y - py), px - (y - py))
            } else {
                let rhs = ex * (y - py) + ey * px;
                let (n, d) = if ey > 0 { (rhs, ey) } else { (-rhs, -ey) };
                (n.div_euclid(d), -((-n).div_euclid(d)))
            };
            if ey > 0 {
                hi = hi.min(bound_floor_ceil.0);
            } else {
                lo = lo.max(bound_floor_ceil.1);
            }
        }
        (lo <= hi).then_some((lo, hi))
    }
}

/// Calls `f(y, x_lo, x_hi)` for every row of the closed triangle `(a, b, c)` that holds grid
/// points, with the inclusive column span of that row. Loops over `max y - min y + 1` rows.
pub(crate) fn for_each_span(
    a: (i64, i64),
    b: (i64, i64),
    c: (i64, i64),
    mut f: impl FnMut(i64, i64, i64),
) {
    let o = orient(a, b, c);
    if o == 0 {
        return;
    }
    let p = if o > 0 { [a, b, c] } else { [a, c, b] };
    let y_lo = a.1.min(b.1).min(c.1);
    let y_hi = a.1.max(b.1).max(c.1);
    let x_lo0 = a.0.min(b.0).min(c.0);
    let x_hi0 = a.0.max(b.0).max(c.0);
    for y in y_lo..=y_hi {
        let (mut lo, mut hi) = (x_lo0, x_hi0);
        let mut empty = false;
        for k in 0..3 {
            let (px, py) = p[k];
            let (qx, qy) = p[(k + 1) % 3];
            let (ex, ey) = (qx - px, qy - py);
            // Inside (left of or on the edge): ex (y - py) - ey (x - px) >= 0.
            if ey == 0 {
                if ex * (y - py) < 0 {
                    empty = true;
                }
                continue;
            }
            // ey * x <= ex (y - py) + ey px. Axis-parallel and 45-degree edges (every hierarchy
            // triangle) divide exactly: no integer division.
            let bound_floor_ceil = if ex == 0 {
                (px, px)
            } else if ex == ey {
                (px + (y - py), px + (y - py))
            } else if ex == -ey {
                (px - (y - py), px - (y - py))
            } else {
                let rhs = ex * (y - py) + ey * px;
                let (n, d) = if ey > 0 { (rhs, ey) } else { (-rhs, -ey) };
                (n.div_euclid(d), -((-n).div_euclid(d)))
            };
            if ey > 0 {
                hi = hi.min(bound_floor_ceil.0);
            } else {
                // Dividing by a negative flips the inequality: x >= ceil(rhs / ey).
                lo = lo.max(bound_floor_ceil.1);
            }
        }
        if !empty && lo <= hi {
            f(y, lo, hi);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn brute(a: (i64, i64), b: (i64, i64), c: (i64, i64)) -> std::vec::Vec<(i64, i64)> {
        let mut v = std::vec::Vec::new();
        let s = orient(a, b, c).signum();
        for y in -2..12 {
            for x in -2..12 {
                let q = (x, y);
                if orient(a, b, q) * s >= 0 && orient(b, c, q) * s >= 0 && orient(c, a, q) * s >= 0
                {
                    v.push(q);
                }
            }
        }
        v
    }

    #[test]
    fn spans_match_brute_force() {
        let tris = [
            ((0, 0), (4, 0), (4, 4)),
            ((0, 0), (4, 4), (0, 4)),
            ((0, 0), (8, 0), (4, 4)),
            ((4, 4), (2, 2), (2, 6)),
            ((1, 0), (9, 3), (3, 7)),
            ((3, 7), (9, 3), (1, 0)),
            ((0, 0), (1, 1), (0, 1)),
        ];
        for (a, b, c) in tris {
            let mut got = std::vec::Vec::new();
            for_each_span(a, b, c, |y, lo, hi| {
                for x in lo..=hi {
                    got.push((x, y));
                }
            });
            got.sort_by_key(|p| (p.1, p.0));
            let mut want = brute(a, b, c);
            want.sort_by_key(|p| (p.1, p.0));
            assert_eq!(got, want, "{a:?} {b:?} {c:?}");
        }
    }

    #[test]
    fn row_spans_match_for_each_span() {
        let tris = [
            ((0, 0), (4, 0), (4, 4)),
            ((0, 0), (8, 0), (4, 4)),
            ((4, 4), (2, 2), (2, 6)),
            ((1, 0), (9, 3), (3, 7)),
            ((3, 7), (9, 3), (1, 0)),
        ];
        for (a, b, c) in tris {
            let mut want = std::vec::Vec::new();
            for_each_span(a, b, c, |y, lo, hi| want.push((y, lo, hi)));
            let r = RowSpans::new(a, b, c).unwrap();
            let got: std::vec::Vec<_> = (-3..12)
                .filter_map(|y| r.at(y).map(|(lo, hi)| (y, lo, hi)))
                .collect();
            assert_eq!(got, want);
        }
    }

    #[test]
    fn plane_range_contains_every_value() {
        let p = Plane::new([(0, 0, 1234.5), (64, 0, -17.25), (64, 64, 3.0e4)]).unwrap();
        let (lo, hi) = p.range_over(8, 40, 3, 60);
        for y in 3..=60 {
            for x in 8..=40 {
                let v = p.at(x, y);
                assert!(v >= lo && v <= hi);
            }
        }
        assert!(hi - lo < 4.0e4);
    }

    #[test]
    fn span_deviation_is_the_per_sample_maximum_bit_for_bit() {
        use crate::{Heightfield, Scale, Terrain};
        let p = Plane::new([(3, -2, 1234.5), (70, 1, -17.25), (9, 64, 3.0e4)]).unwrap();
        let (w, h) = (48u32, 45u32);
        let s: std::vec::Vec<f32> = (0..w * h)
            .map(|k| ((k * 7919) % 113) as f32 * 37.5)
            .collect();
        let hf = Heightfield::with_scale(&s, w, h, Scale::default().with_z_scale(0.7)).unwrap();
        // Empty, shorter than a quad, whole quads, quads and a rest, and spans past the last
        // column (clamped like local_z).
        for (y, lo, hi) in [
            (0i64, 5i64, 4i64),
            (7, 5, 5),
            (9, 0, 2),
            (2, 11, 14),
            (40, 2, 38),
            (3, 40, 50),
        ] {
            let mut want = 0.0f64;
            for x in lo..=hi {
                let d = (f64::from(hf.local_z(x as u32, y as u32)) - p.at(x, y)).abs();
                want = if d > want { d } else { want };
            }
            assert_eq!(
                span_deviation(&hf, &p, y, lo, hi).to_bits(),
                want.to_bits(),
                "{y} {lo}..={hi}"
            );
        }
    }

    #[test]
    fn plane_is_order_independent() {
        let p = [(0, 0, 1.1), (4, 0, 2.7), (4, 4, -3.3)];
        let q = [p[2], p[0], p[1]];
        let (a, b) = (Plane::new(p).unwrap(), Plane::new(q).unwrap());
        for (x, y) in [(1, 0), (3, 2), (4, 3)] {
            assert_eq!(a.at(x, y).to_bits(), b.at(x, y).to_bits());
        }
        assert!(Plane::new([(0, 0, 0.0), (1, 1, 0.0), (2, 2, 0.0)]).is_none());
    }
}
