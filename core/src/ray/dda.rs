//! Grid traversal of a projected ray: the cell DDA (Amanatides & Woo, *A Fast Voxel Traversal
//! Algorithm for Ray Tracing*, 1987) and the run-length DDA of Henning & Stephenson,
//! *Accelerating the Ray Tracing of Height Fields* (2004), section 2.
//!
//! Both walk the same *digital line*: the projected ray in fixed point. The direction is scaled
//! to integers `(DX, DY)` with `max(|DX|, |DY|)` in `[2^39, 2^40]` and the start point is rounded
//! to `2^-21` cells, so every decision is an integer add and a sign test:
//!
//! - the 8-way symmetry folds the slope into `0 <= alpha <= 1` (major axis `u`, minor axis `v`,
//!   both increasing in the folded frame);
//! - the *intercept* `B` is the minor coordinate of the line at the left face of the current
//!   column, relative to the bottom of the current row, in units of `1 / (DX 2^21)` of a cell:
//!   one row is `Q = DX 2^21`, one column step adds `A = DY 2^21` (so `alpha = A / Q`);
//! - the cell DDA compares `B + A` with `Q` (the exit crosses the right face, the top face, or
//!   exactly the corner), which is Amanatides & Woo's `tMaxX < tMaxY` test made exact;
//! - the run DDA uses the short run `r = floor(Q / A)` and the remainder `rho = Q - r A`
//!   (the paper's `nu = A - rho` and `mu = rho`): with the shifted intercept `C = B - rho`, the
//!   row holds `r + 1` cells (4-connected) when `C + A > 0`, `r + 2` when `C + A < 0`, and a
//!   corner intersection (no 4-connected extension) happens when `C + A == 0` (or `C == 0` for
//!   slopes exactly `1/k`). The truncated first run needs one division per ray.
//!
//! At an exact corner both DDAs step diagonally: the ray touches the two side cells only in one
//! point, where the surface is the shared corner height. A line lying exactly on a grid line is
//! assigned to the cell on the side the folding picks (the cell above/right, except on the upper
//! domain border, where the cell inside the domain is picked). Because both DDAs use the same
//! integers, the cells a [`RunDda`] implies equal the cells of the [`CellDda`] exactly; for
//! directions that are small integers and start points with at most 21 fractional bits the
//! digital line *is* the real line, which the tests check against an exact rational reference.
//! For other rays the digital line is within about `2^-21 + n 2^-39` cells of the real one after
//! `n` cells.

use crate::Error;
use glam::DVec2;

const FRAC_BITS: u32 = 21;
const DIR_BITS: i32 = 40;

/// A projected ray in fixed point, folded into the first octant, clipped to a grid of cells:
/// the shared set-up of [`CellDda`] and [`RunDda`].
///
/// ```
/// use relief_core::ray::GridLine;
/// use glam::DVec2;
/// let line = GridLine::new(DVec2::new(0.5, 0.5), DVec2::new(3.0, 1.0), DVec2::new(8.0, 8.0), [8, 8]).unwrap();
/// assert_eq!(line.cells().count(), line.runs().map(|r| r.len as usize).sum::<usize>());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GridLine {
    /// The major axis is y.
    pub(crate) swap: bool,
    /// The major direction is positive.
    pub(crate) pos_u: bool,
    /// The minor direction is positive.
    pub(crate) pos_v: bool,
    /// One row in intercept units (`DX << 21`).
    pub(crate) q: i64,
    /// Intercept increment per column (`DY << 21`).
    pub(crate) a: i64,
    /// Short run `floor(q / a)` (0 when `a == 0`).
    pub(crate) r: i64,
    /// `q - r a`.
    pub(crate) rho: i64,
    /// Start cell, folded.
    pub(crate) u0: i64,
    pub(crate) v0: i64,
    /// Intercept at the left face of the start column, relative to the start row.
    pub(crate) b0: i64,
    /// Last folded column and row that may be visited.
    pub(crate) u_last: i64,
    pub(crate) v_last: i64,
    /// Last row visited: `v_last`, or the top row of column `u_last` when that comes first. Every
    /// cell of the rows before it lies at or before column `u_last`, so walks there need no
    /// column test and runs no clamp.
    pub(crate) v_end: i64,
}

/// Folded cell range `[min, max]` of an axis with `n` cells.
#[inline]
fn folded_range(n: u32, pos: bool) -> (i64, i64) {
    if pos {
        (0, n as i64 - 1)
    } else {
        (-(n as i64), -1)
    }
}

/// Unfolds a folded cell index.
#[inline]
fn unfold(c: i64, pos: bool) -> u32 {
    (if pos { c } else { -c - 1 }) as u32
}

impl GridLine {
    /// Sets up the digital line from `start` along `dir` (both in grid units, where cell
    /// `(cx, cy)` is the square `[cx, cx+1] x [cy, cy+1]`) over a grid of `cells.x x cells.y`
    /// cells, stopping after the cell that contains `stop` (the end of the segment). `start` and
    /// `stop` are clamped into the grid. A zero direction visits the start cell only.
    ///
    /// Errors: [`Error::NonFiniteInput`] for NaN or infinite input, [`Error::TooSmall`] for a
    /// grid without cells, [`Error::SizeOverflow`] for more than `2^30` cells along an axis.
    ///
    /// ```
    /// use relief_core::ray::GridLine;
    /// use glam::DVec2;
    /// let line = GridLine::new(DVec2::ZERO, DVec2::X, DVec2::new(2.5, 0.0), [4, 4]).unwrap();
    /// let cells: Vec<[u32; 2]> = line.cells().collect();
    /// assert_eq!(cells, vec![[0, 0], [1, 0], [2, 0]]);
    /// assert!(GridLine::new(DVec2::NAN, DVec2::X, DVec2::ZERO, [4, 4]).is_err());
    /// ```
    pub fn new(start: DVec2, dir: DVec2, stop: DVec2, cells: [u32; 2]) -> Result<GridLine, Error> {
        let cells = super::Cells {
            x: cells[0],
            y: cells[1],
        };
        if !start.is_finite() {
            return Err(Error::NonFiniteInput { name: "start" });
        }
        if !dir.is_finite() {
            return Err(Error::NonFiniteInput { name: "direction" });
        }
        if !stop.is_finite() {
            return Err(Error::NonFiniteInput { name: "stop" });
        }
        if cells.x == 0 || cells.y == 0 {
            return Err(Error::TooSmall {
                width: cells.x.saturating_add(1),
                height: cells.y.saturating_add(1),
            });
        }
        // Keeps every fixed-point product below 2^63.
        if cells.x > (1 << 30) || cells.y > (1 << 30) {
            return Err(Error::SizeOverflow);
        }
        let ext = cells.as_dvec2();
        let start = start.max(DVec2::ZERO).min(ext);
        let degenerate = dir.x == 0.0 && dir.y == 0.0;
        let stop = if degenerate {
            start
        } else {
            stop.max(DVec2::ZERO).min(ext)
        };
        let swap = dir.y.abs() > dir.x.abs();
        let (mu, mv, su, sv, eu, ev, nu, nv) = if swap {
            (
                dir.y, dir.x, start.y, start.x, stop.y, stop.x, cells.y, cells.x,
            )
        } else {
            (
                dir.x, dir.y, start.x, start.y, stop.x, stop.y, cells.x, cells.y,
            )
        };
        let pos_u = mu >= 0.0;
        // Fixed-point direction: max(|DX|, |DY|) in [2^39, 2^40].
        let (dxi, dyi) = if degenerate {
            (1i64 << (DIR_BITS - 1), 0i64)
        } else {
            let (m, e) = libm::frexp(mu.abs());
            let dx = libm::round(libm::ldexp(m, DIR_BITS)) as i64;
            let dy = libm::round(libm::ldexp(mv.abs(), DIR_BITS - e)) as i64;
            (dx, dy.min(dx))
        };
        // A minor component that is zero *in fixed point* (exactly zero, or too small to register
        // against the major one) makes the line parallel to the major axis. If it starts on a grid
        // line, pick the side inside the domain (the upper one except on the upper border), for
        // both DDAs alike: folding by the sign of a component that rounded to zero would put the
        // start on the far side of its row boundary, where the cell DDA takes a corner step out of
        // the grid and the run DDA does not (found by fuzzing: start (0.5, 0), direction
        // (1, -1e-30)).
        let pos_v = if dyi == 0 { sv < nv as f64 } else { mv > 0.0 };
        let q = dxi << FRAC_BITS;
        let a = dyi << FRAC_BITS;
        let (r, rho) = if a > 0 {
            let r = q.checked_div(a).unwrap_or(0);
            (r, q - r * a)
        } else {
            (0, 0)
        };
        let one = (1i64 << FRAC_BITS) as f64;
        let fold = |g: f64, pos: bool| if pos { g } else { -g };
        // Floor, not round: the start cell must be the cell the float start point lies in
        // (rounding to the nearest 2^-21 moved points within 2^-22 below a row boundary into the
        // next row, so the DDA skipped the cell the ray starts in; found by fuzzing).
        let uf = libm::floor(fold(su, pos_u) * one) as i64;
        let vf = libm::floor(fold(sv, pos_v) * one) as i64;
        let (umin, umax) = folded_range(nu, pos_u);
        let (vmin, vmax) = folded_range(nv, pos_v);
        let u0 = (uf >> FRAC_BITS).max(umin).min(umax);
        let v0 = (vf >> FRAC_BITS).max(vmin).min(vmax);
        // In [-A, Q]: both factors are below 2^21 + 1 and 2^40 + 1, so no overflow.
        let b0 = dxi * (vf - (v0 << FRAC_BITS)) + ((u0 << FRAC_BITS) - uf) * dyi;
        // A line parallel to the major axis stays in its row: a start rounded onto the row's
        // upper boundary (or clamped into the last row) must not read as a corner crossing.
        let b0 = if dyi == 0 { b0.min(q - 1) } else { b0 };
        let (u_last, v_last) = if degenerate {
            (u0, v0)
        } else {
            let ue = libm::floor(fold(eu, pos_u)) as i64;
            let ve = libm::floor(fold(ev, pos_v)) as i64;
            // Parallel in fixed point: the line never leaves its row, even when the float end
            // point has drifted (by less than 2^-11 of a cell) across the row's boundary.
            let ve = if dyi == 0 { v0 } else { ve };
            (ue.max(umin).min(umax), ve.max(vmin).min(vmax))
        };
        // The line's height at the right face of column `u_last`, `h`, in units of `1 / q` of a
        // row above the start row (at least 0 because `b0 >= -a`); the top row of that column is
        // `ceil(h / q) - 1 = floor((h - 1) / q)` (an exact corner steps diagonally out of the
        // column). `h` reaches 2^92: the quotient is estimated in `f64` and corrected exactly
        // with `i128` products (an `i128` division would link compiler-builtins' routine).
        let v_end = if u_last < u0 || v_last < v0 {
            v0 - 1
        } else {
            let k = u_last - u0 + 1;
            let hm = b0 as i128 + k as i128 * a as i128 - 1;
            let (q128, qf) = (q as i128, q as f64);
            let mut top = libm::floor(((b0 - 1) as f64 + k as f64 * a as f64) / qf) as i64;
            // `q >= 2^60` and `hm < 2^93`: the estimate is within one of the quotient.
            for _ in 0..4 {
                let tq = top as i128 * q128;
                if tq > hm {
                    top -= 1;
                } else if tq + q128 <= hm {
                    top += 1;
                }
            }
            v_last.min(v0.saturating_add(top.max(0)))
        };
        Ok(GridLine {
            swap,
            pos_u,
            pos_v,
            q,
            a,
            r,
            rho,
            u0,
            v0,
            b0,
            u_last,
            v_last,
            v_end,
        })
    }

    /// Unfolds a folded run.
    #[inline]
    pub(crate) fn unfold_run(&self, f: FoldedRun) -> CellRun {
        CellRun {
            start: self.cell(f.u_a, f.v),
            len: (f.u_b - f.u_a + 1) as u32,
            along_y: self.swap,
            step: if self.pos_u { 1 } else { -1 },
        }
    }

    /// Unfolds a folded `(u, v)` cell into grid coordinates `[x, y]`.
    #[inline]
    pub(crate) fn cell(&self, u: i64, v: i64) -> [u32; 2] {
        let (a, b) = (unfold(u, self.pos_u), unfold(v, self.pos_v));
        if self.swap {
            [b, a]
        } else {
            [a, b]
        }
    }

    /// The cell DDA over this line.
    ///
    /// ```
    /// use relief_core::ray::GridLine;
    /// use glam::DVec2;
    /// let line = GridLine::new(DVec2::new(0.5, 0.5), DVec2::ONE, DVec2::new(3.5, 3.5), [4, 4]).unwrap();
    /// // Exactly diagonal: it passes through the corners and steps diagonally there.
    /// assert_eq!(line.cells().collect::<Vec<_>>(), vec![[0, 0], [1, 1], [2, 2], [3, 3]]);
    /// ```
    #[must_use]
    pub fn cells(&self) -> CellDda {
        CellDda {
            line: *self,
            u: self.u0,
            v: self.v0,
            b: self.b0,
        }
    }

    /// The run-length DDA over this line.
    ///
    /// ```
    /// use relief_core::ray::GridLine;
    /// use glam::DVec2;
    /// let line = GridLine::new(DVec2::new(0.5, 0.5), DVec2::new(4.0, 1.0), DVec2::new(16.0, 16.0), [16, 16]).unwrap();
    /// let lens: Vec<u32> = line.runs().map(|r| r.len).take(3).collect();
    /// assert_eq!(lens, vec![3, 5, 5]); // truncated first run, then r + 1 = 5 (4-connected)
    /// ```
    #[must_use]
    pub fn runs(&self) -> RunDda {
        RunDda {
            line: *self,
            u: self.u0,
            v: self.v0,
            b: self.b0,
            first: true,
        }
    }

    /// An upper bound on the number of cells either DDA visits: columns plus rows spanned.
    ///
    /// ```
    /// use relief_core::ray::GridLine;
    /// use glam::DVec2;
    /// let line = GridLine::new(DVec2::ZERO, DVec2::ONE, DVec2::splat(9.0), [10, 10]).unwrap();
    /// assert!(line.cells().count() as u64 <= line.step_bound());
    /// ```
    #[must_use]
    pub fn step_bound(&self) -> u64 {
        ((self.u_last - self.u0 + 1).max(0) + (self.v_last - self.v0 + 1).max(0)) as u64
    }
}

/// Amanatides & Woo cell DDA: yields the cells `[x, y]` of the 4-connected digital line in
/// order (diagonal steps only at exact corners). `Copy`; at most
/// [`GridLine::step_bound`] items.
///
/// Internal iteration (`for_each`, `fold`, `count`, ...) runs the DDA's own loop, which tests
/// only the row below the last one instead of both coordinates: about a fifth faster per cell
/// than a `for` loop calling `next` (BENCHMARKS.md, Rays).
///
/// ```
/// use relief_core::ray::GridLine;
/// use glam::DVec2;
/// let line = GridLine::new(DVec2::new(0.5, 0.5), DVec2::new(2.0, 1.0), DVec2::new(4.0, 4.0), [4, 4]).unwrap();
/// let cells: Vec<_> = line.cells().take(4).collect();
/// assert_eq!(cells, vec![[0, 0], [1, 0], [1, 1], [2, 1]]);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CellDda {
    line: GridLine,
    u: i64,
    v: i64,
    b: i64,
}

impl CellDda {
    /// The next cell in the folded frame `(u, v)`, for callers that work there.
    #[inline]
    pub(crate) fn next_folded(&mut self) -> Option<(i64, i64)> {
        let l = &self.line;
        if self.u > l.u_last || self.v > l.v_last {
            return None;
        }
        let out = (self.u, self.v);
        Self::step(l, &mut self.u, &mut self.v, &mut self.b);
        Some(out)
    }

    /// One cell step of `(u, v)` with intercept `b`. One branch per cell, on the exit face (the
    /// right face `e < q` steps u); the top face steps v, and the exact corner both, selected
    /// without a second branch.
    #[inline(always)]
    fn step(l: &GridLine, u: &mut i64, v: &mut i64, b: &mut i64) {
        let e = *b + l.a;
        if e < l.q {
            *u += 1;
            *b = e;
        } else {
            let corner = e == l.q;
            *v += 1;
            *u += i64::from(corner);
            *b = if corner { 0 } else { *b - l.q };
        }
    }

    /// Folds `f` over the remaining cells in the folded frame, in order: the cells of
    /// [`CellDda::next_folded`], in a loop that tests only the row before the last one
    /// (`GridLine::v_end`).
    #[inline]
    fn fold_folded<A>(self, init: A, mut f: impl FnMut(A, (i64, i64)) -> A) -> A {
        let l = self.line;
        let (mut u, mut v, mut b) = (self.u, self.v, self.b);
        let mut acc = init;
        if u > l.u_last || v > l.v_last {
            return acc;
        }
        while v < l.v_end {
            acc = f(acc, (u, v));
            Self::step(&l, &mut u, &mut v, &mut b);
        }
        while v == l.v_end && u <= l.u_last {
            acc = f(acc, (u, v));
            Self::step(&l, &mut u, &mut v, &mut b);
        }
        acc
    }
}

impl Iterator for CellDda {
    type Item = [u32; 2];
    #[inline]
    fn next(&mut self) -> Option<[u32; 2]> {
        let (u, v) = self.next_folded()?;
        Some(self.line.cell(u, v))
    }

    #[inline]
    fn fold<A, F: FnMut(A, [u32; 2]) -> A>(self, init: A, mut f: F) -> A {
        let line = self.line;
        self.fold_folded(init, |acc, (u, v)| f(acc, line.cell(u, v)))
    }
}

/// A run of cells: `len` contiguous cells of one row (`along_y == false`) or one column, starting
/// at `start` and stepping by `step` (`+1` or `-1`) along that axis.
///
/// ```
/// use relief_core::ray::CellRun;
/// let run = CellRun { start: [5, 2], len: 3, along_y: false, step: -1 };
/// assert_eq!(run.cell(2), Some([3, 2]));
/// assert_eq!(run.span(), (3, 5));
/// assert_eq!(run.cell(3), None);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CellRun {
    /// First cell `[x, y]` in traversal order.
    pub start: [u32; 2],
    /// Number of cells, at least 1.
    pub len: u32,
    /// The run lies in one column (cells vary in y) rather than one row.
    pub along_y: bool,
    /// Direction of traversal along the run: `1` or `-1`.
    pub step: i32,
}

impl CellRun {
    /// The `k`-th cell of the run, `None` past its end.
    ///
    /// ```
    /// use relief_core::ray::CellRun;
    /// let run = CellRun { start: [1, 4], len: 2, along_y: true, step: 1 };
    /// assert_eq!(run.cell(1), Some([1, 5]));
    /// ```
    #[must_use]
    pub fn cell(&self, k: u32) -> Option<[u32; 2]> {
        if k >= self.len {
            return None;
        }
        let i = usize::from(self.along_y);
        let mut c = self.start;
        let base = *c.get(i)? as i64 + self.step as i64 * k as i64;
        *c.get_mut(i)? = u32::try_from(base).ok()?;
        Some(c)
    }

    /// Lowest and highest coordinate along the run's axis.
    ///
    /// ```
    /// use relief_core::ray::CellRun;
    /// let run = CellRun { start: [1, 4], len: 2, along_y: true, step: 1 };
    /// assert_eq!(run.span(), (4, 5));
    /// ```
    #[must_use]
    pub fn span(&self) -> (u32, u32) {
        let s = if self.along_y {
            self.start[1]
        } else {
            self.start[0]
        };
        let n = self.len.saturating_sub(1);
        if self.step < 0 {
            (s.saturating_sub(n), s)
        } else {
            (s, s.saturating_add(n))
        }
    }

    /// The cells of the run in traversal order.
    ///
    /// ```
    /// use relief_core::ray::CellRun;
    /// let run = CellRun { start: [1, 4], len: 2, along_y: false, step: -1 };
    /// assert_eq!(run.cells().collect::<Vec<_>>(), vec![[1, 4], [0, 4]]);
    /// ```
    pub fn cells(self) -> impl Iterator<Item = [u32; 2]> {
        (0..self.len).filter_map(move |k| self.cell(k))
    }
}

/// A run in the folded frame: row `v`, columns `u_a..=u_b`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct FoldedRun {
    pub v: i64,
    pub u_a: i64,
    pub u_b: i64,
}

/// Run-length DDA (Henning & Stephenson 2004): yields whole [`CellRun`]s of the 4-connected
/// digital line, at constant cost per run. The cells they imply, in order, are exactly those of
/// [`GridLine::cells`]. `Copy`; at most one run per row crossed.
///
/// Internal iteration (`for_each`, `fold`, `count`, `sum`, ...) runs the DDA's own loop, which
/// tests only the row and clamps only the last run: about a third faster per cell than a `for`
/// loop calling `next` (BENCHMARKS.md, Rays). Prefer it wherever no early exit is needed.
///
/// ```
/// use relief_core::ray::GridLine;
/// use glam::DVec2;
/// let line = GridLine::new(DVec2::new(0.25, 0.5), DVec2::new(7.0, 2.0), DVec2::splat(32.0), [32, 32]).unwrap();
/// let from_runs: Vec<[u32; 2]> = line.runs().flat_map(|r| r.cells()).collect();
/// assert_eq!(from_runs, line.cells().collect::<Vec<_>>());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RunDda {
    line: GridLine,
    /// First column of the current row (4-connected).
    u: i64,
    v: i64,
    /// Intercept at the left face of column `u`, relative to row `v`.
    b: i64,
    first: bool,
}

impl RunDda {
    /// The run of row `v` from column `u` with intercept `b`, for rows after the first (`a > 0`):
    /// `(cells in the row, next row's first column, next intercept)`.
    #[inline(always)]
    fn step(l: &GridLine, u: i64, b: i64) -> (i64, i64, i64) {
        let c = b - l.rho;
        if c == 0 {
            (l.r, u + l.r, 0)
        } else {
            let d = c + l.a;
            if d > 0 {
                (l.r + 1, u + l.r, c)
            } else if d == 0 {
                (l.r + 1, u + l.r + 1, 0)
            } else {
                (l.r + 2, u + l.r + 1, d)
            }
        }
    }

    /// The truncated first run (one division per ray), or the whole line when it is parallel
    /// to the major axis: the same triple as [`RunDda::step`].
    #[inline]
    fn first_run(l: &GridLine, u: i64, b: i64) -> (i64, i64, i64) {
        if l.a == 0 {
            return (l.u_last - u + 1, l.u_last + 1, b);
        }
        let n = (l.q - b + l.a - 1).checked_div(l.a).unwrap_or(1).max(1);
        let e = b + n * l.a;
        if e == l.q {
            (n, u + n, 0)
        } else {
            (n, u + n - 1, e - l.a - l.q)
        }
    }

    /// The next run in the folded frame.
    #[inline]
    pub(crate) fn next_folded(&mut self) -> Option<FoldedRun> {
        let l = self.line;
        // Rows after `v_end` are never visited, and the rows up to it start at or before
        // `u_last` (`GridLine::v_end`).
        if self.v > l.v_end {
            return None;
        }
        let u = self.u;
        let (n, nu, nb) = if self.first {
            self.first = false;
            Self::first_run(&l, u, self.b)
        } else {
            Self::step(&l, u, self.b)
        };
        let run = FoldedRun {
            v: self.v,
            u_a: u,
            u_b: (u + n - 1).min(l.u_last),
        };
        self.v += 1;
        self.u = nu;
        self.b = nb;
        Some(run)
    }

    /// Folds `f` over the remaining runs in the folded frame, in order: the runs of
    /// [`RunDda::next_folded`], in a loop that tests only the row and clamps only the last run
    /// (`GridLine::v_end`).
    #[inline]
    fn fold_folded<A>(mut self, init: A, mut f: impl FnMut(A, FoldedRun) -> A) -> A {
        let mut acc = init;
        if self.first {
            match self.next_folded() {
                Some(run) => acc = f(acc, run),
                None => return acc,
            }
        }
        let l = self.line;
        let (mut u, mut v, mut b) = (self.u, self.v, self.b);
        // A line parallel to the major axis has one run, and `v_end` is its row.
        while v < l.v_end {
            let (n, nu, nb) = Self::step(&l, u, b);
            acc = f(
                acc,
                FoldedRun {
                    v,
                    u_a: u,
                    u_b: u + n - 1,
                },
            );
            v += 1;
            u = nu;
            b = nb;
        }
        if v == l.v_end {
            let (n, _, _) = Self::step(&l, u, b);
            acc = f(
                acc,
                FoldedRun {
                    v,
                    u_a: u,
                    u_b: (u + n - 1).min(l.u_last),
                },
            );
        }
        acc
    }
}

impl Iterator for RunDda {
    type Item = CellRun;
    #[inline]
    fn next(&mut self) -> Option<CellRun> {
        let f = self.next_folded()?;
        Some(self.line.unfold_run(f))
    }

    #[inline]
    fn fold<A, F: FnMut(A, CellRun) -> A>(self, init: A, mut f: F) -> A {
        let line = self.line;
        self.fold_folded(init, |acc, run| f(acc, line.unfold_run(run)))
    }
}

/// The intercept `beta_j` of a run (seed 001, section 2, eq. 2: `beta_j = alpha x_j - y_j`, the
/// fractional minor coordinate of the line where it meets the left face of the run's first
/// 8-connected cell), kept exactly as the run DDA holds it: a numerator over one row
/// `Q = DX 2^21` (module docs), in the folded frame where the slope is `0 <= alpha <= 1`.
///
/// - Runs after the first: `beta_j` is in `[0, alpha)`. When it is `0` the line passes exactly
///   through the corner below the run's first cell and the run has no 4-connected extension;
///   otherwise the run's first cell (as [`RunDda`] yields it) is the extension and its first
///   8-connected cell is the next one.
/// - The first run: the intercept at the left face of the start column, relative to the start
///   row (the paper's `beta` of a start point `(x_0, y_0 + beta)` on a left face). For a start
///   inside a column it lies in `(-alpha, 1)`: negative when the line enters the start row
///   between the column's left face and the start point.
///
/// ```
/// use relief_core::ray::GridLine;
/// use glam::DVec2;
/// // Seed 001, figure 6: y = 17/41 x from the origin.
/// let line = GridLine::new(DVec2::ZERO, DVec2::new(41.0, 17.0), DVec2::new(41.0, 17.0), [41, 17]).unwrap();
/// let betas: Vec<(i64, i64)> = line.runs().with_intercepts().map(|(_, b)| b.reduced()).take(4).collect();
/// assert_eq!(betas, vec![(0, 1), (10, 41), (3, 41), (13, 41)]);
/// let (run, beta) = line.runs().with_intercepts().nth(1).unwrap();
/// assert!(beta.extended() && run.len == 3); // 8-connected short run of 2 plus its extension
/// assert!((beta.to_f64() - 10.0 / 41.0).abs() < 1e-15);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RunIntercept {
    numerator: i64,
    denominator: i64,
    extended: bool,
}

impl RunIntercept {
    /// The exact numerator, in units of `1 / denominator()` of a cell.
    ///
    /// ```
    /// use relief_core::ray::GridLine;
    /// use glam::DVec2;
    /// let line = GridLine::new(DVec2::ZERO, DVec2::new(4.0, 1.0), DVec2::splat(8.0), [8, 8]).unwrap();
    /// let (_, b) = line.runs().with_intercepts().next().unwrap();
    /// assert_eq!(b.numerator(), 0); // the start point lies on a corner
    /// ```
    #[must_use]
    pub fn numerator(self) -> i64 {
        self.numerator
    }

    /// One row of the fixed-point line, `Q = DX 2^21` with `DX` the major direction component
    /// scaled into `[2^39, 2^40]`; always positive.
    ///
    /// ```
    /// use relief_core::ray::GridLine;
    /// use glam::DVec2;
    /// let line = GridLine::new(DVec2::ZERO, DVec2::new(4.0, 1.0), DVec2::splat(8.0), [8, 8]).unwrap();
    /// let (_, b) = line.runs().with_intercepts().next().unwrap();
    /// assert_eq!(b.denominator(), 1 << 60); // DX = 2^39 for a major component 4
    /// ```
    #[must_use]
    pub fn denominator(self) -> i64 {
        self.denominator
    }

    /// Whether the run begins with its 4-connected extension cell (never for the first run).
    ///
    /// ```
    /// use relief_core::ray::GridLine;
    /// use glam::DVec2;
    /// // Slope 1/4 from a corner: every later run starts exactly at a corner, no extension.
    /// let line = GridLine::new(DVec2::ZERO, DVec2::new(4.0, 1.0), DVec2::splat(8.0), [8, 8]).unwrap();
    /// assert!(line.runs().with_intercepts().all(|(_, b)| !b.extended()));
    /// ```
    #[must_use]
    pub fn extended(self) -> bool {
        self.extended
    }

    /// The intercept as `f64` (numerator and denominator each rounded to `f64`, then divided).
    ///
    /// ```
    /// use relief_core::ray::GridLine;
    /// use glam::DVec2;
    /// let line = GridLine::new(DVec2::new(0.0, 0.25), DVec2::new(8.0, 1.0), DVec2::splat(8.0), [8, 8]).unwrap();
    /// let (_, b) = line.runs().with_intercepts().next().unwrap();
    /// assert_eq!(b.to_f64(), 0.25);
    /// ```
    #[must_use]
    pub fn to_f64(self) -> f64 {
        self.numerator as f64 / self.denominator as f64
    }

    /// The intercept as a fraction in lowest terms `(numerator, denominator)`, denominator
    /// positive; `(0, 1)` for zero. For rays whose start and direction are small integers this
    /// is the paper's fraction (`10/41` for figure 6's second run).
    ///
    /// ```
    /// use relief_core::ray::GridLine;
    /// use glam::DVec2;
    /// let line = GridLine::new(DVec2::new(0.0, 0.5), DVec2::new(3.0, 1.0), DVec2::splat(8.0), [8, 8]).unwrap();
    /// let (_, b) = line.runs().with_intercepts().next().unwrap();
    /// assert_eq!(b.reduced(), (1, 2));
    /// ```
    #[must_use]
    pub fn reduced(self) -> (i64, i64) {
        let (mut x, mut y) = (
            self.numerator.unsigned_abs(),
            self.denominator.unsigned_abs(),
        );
        // Euclid on u64 takes at most 93 steps (Fibonacci worst case).
        for _ in 0..100 {
            match x.checked_rem(y) {
                Some(r) => {
                    x = y;
                    y = r;
                }
                None => break,
            }
        }
        // x is now the gcd (or 0 when both are 0).
        let g = x.max(1);
        let n = (self.numerator.unsigned_abs() / g) as i64;
        let d = (self.denominator.unsigned_abs() / g).max(1) as i64;
        (if self.numerator < 0 { -n } else { n }, d)
    }
}

impl RunDda {
    /// The runs together with their intercepts `beta_j` ([`RunIntercept`]): the same runs as
    /// iterating `self`, read from the DDA's own state before each step (the plain iterator is
    /// untouched, so traversal pays nothing for this).
    ///
    /// ```
    /// use relief_core::ray::GridLine;
    /// use glam::DVec2;
    /// let line = GridLine::new(DVec2::new(0.3, 0.7), DVec2::new(5.0, 2.0), DVec2::splat(16.0), [16, 16]).unwrap();
    /// let plain: Vec<_> = line.runs().collect();
    /// let with: Vec<_> = line.runs().with_intercepts().map(|(r, _)| r).collect();
    /// assert_eq!(plain, with);
    /// ```
    #[must_use]
    pub fn with_intercepts(self) -> RunIntercepts {
        RunIntercepts { dda: self }
    }
}

/// Iterator of [`RunDda::with_intercepts`]: each [`CellRun`] with its [`RunIntercept`].
///
/// ```
/// use relief_core::ray::GridLine;
/// use glam::DVec2;
/// let line = GridLine::new(DVec2::ZERO, DVec2::new(41.0, 17.0), DVec2::new(41.0, 17.0), [41, 17]).unwrap();
/// // Every later intercept is below the slope alpha = 17/41 (seed 001).
/// assert!(line.runs().with_intercepts().skip(1).all(|(_, b)| b.to_f64() < 17.0 / 41.0));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RunIntercepts {
    dda: RunDda,
}

impl Iterator for RunIntercepts {
    type Item = (CellRun, RunIntercept);
    fn next(&mut self) -> Option<(CellRun, RunIntercept)> {
        let d = &self.dda;
        let q = d.line.q;
        // After the first run the state intercept `b` is at the left face of the run's first
        // (4-connected) column, in (-A, 0]: 0 is a corner crossing, otherwise the line meets
        // the next column's left face at b + A, inside the row.
        let (numerator, extended) = if d.first || d.b == 0 || d.line.a == 0 {
            (d.b, false)
        } else {
            (d.b.saturating_add(d.line.a), true)
        };
        let beta = RunIntercept {
            numerator,
            denominator: q.max(1),
            extended,
        };
        let f = self.dda.next_folded()?;
        Some((self.dda.line.unfold_run(f), beta))
    }
}

#[cfg(test)]
mod intercept_tests {
    use super::GridLine;
    use glam::DVec2;

    fn reduce(n: i128, d: i128) -> (i64, i64) {
        let (mut a, mut b) = (n.abs(), d.abs());
        while b != 0 {
            (a, b) = (b, a % b);
        }
        let g = a.max(1);
        ((n / g) as i64, (d / g) as i64)
    }

    /// Every run's intercept equals the exact rational one (seed 001, eq. 2) in every octant,
    /// for starts on eighths of a cell and small integer directions; later runs lie in
    /// `[0, alpha)`, and `extended` matches the cells (first cell 4-adjacent to the last one).
    #[test]
    fn intercepts_match_rational_reference() {
        let mut checked = 0usize;
        for (du, dv) in (1i64..=9).flat_map(|a| (1..=a).map(move |b| (a, b))) {
            for signs in 0..8u32 {
                let (sx, sy, swap) = (signs & 1 == 0, signs & 2 == 0, signs & 4 != 0);
                if swap && du == dv {
                    continue; // the core folds |x| == |y| with x major
                }
                let (mx, my) = (if sx { du } else { -du }, if sy { dv } else { -dv });
                let dir = if swap {
                    DVec2::new(my as f64, mx as f64)
                } else {
                    DVec2::new(mx as f64, my as f64)
                };
                for (ex, ey) in [(0i64, 0i64), (3, 5), (4, 0), (7, 1)] {
                    let start8 = [8 * 20 + ex, 8 * 19 + ey];
                    let start = DVec2::new(start8[0] as f64 / 8.0, start8[1] as f64 / 8.0);
                    let line = GridLine::new(start, dir, start + dir * 100.0, [40, 40]).unwrap();
                    let (ku, kv) = if swap { (1, 0) } else { (0, 1) };
                    let (pu, pv) = (dir[ku] > 0.0, dir[kv] > 0.0);
                    let fold = |c: i64, pos: bool| if pos { c } else { -c - 1 };
                    let fp = |p: i64, pos: bool| if pos { p } else { -p };
                    let (su, sv) = (fp(start8[ku], pu), fp(start8[kv], pv));
                    let mut prev_last: Option<[u32; 2]> = None;
                    for (j, (run, beta)) in line.runs().with_intercepts().enumerate() {
                        let first = run.start;
                        let adjacent = prev_last.is_some_and(|p| p[ku] == first[ku]);
                        assert_eq!(beta.extended(), adjacent, "run {j} of {dir} from {start}");
                        let face = fold(i64::from(first[ku]), pu) + i64::from(beta.extended());
                        let row = fold(i64::from(first[kv]), pv);
                        // 8 du beta = 8 du v(face) - 8 du row, v(u) = sv/8 + dv/du (u - su/8).
                        let num = i128::from(sv * du + dv * (8 * face - su) - 8 * du * row);
                        let want = reduce(num, i128::from(8 * du));
                        assert_eq!(beta.reduced(), want, "run {j} of {dir} from {start}");
                        let f = beta.to_f64();
                        assert!((f - want.0 as f64 / want.1 as f64).abs() < 1e-12);
                        if j > 0 {
                            assert!(f >= 0.0 && f < dv as f64 / du as f64, "run {j}: {f}");
                        } else {
                            assert!(f > -(dv as f64 / du as f64) && f < 1.0);
                        }
                        prev_last = run.cell(run.len - 1);
                        checked += 1;
                    }
                }
            }
        }
        assert!(checked > 10_000, "{checked}");
    }
}
