//! Full tracing with the run-length DDA (Henning & Stephenson 2004, sections 2-3) and whole-run
//! rejection.
//!
//! A run is a contiguous segment of one row (or column) of cells, so its maximum height is a
//! range maximum over that row. [`RunAccel`] keeps, per row and per column, a sparse table of
//! cell maxima (levels `2^0 .. 2^5` cells) in caller storage: a run of up to 64 cells is rejected
//! with two table reads, longer runs with one read per 32 cells. Only runs whose lowest ray point
//! is at or below that maximum are tested cell by cell.

use super::{Ray, RayTracer, Trace};
use crate::{Error, Terrain};

/// Sparse-table levels kept per row and column.
const LEVELS: u32 = 6;

/// Row and column range-maximum tables of cell maxima, over caller storage, for rejecting whole
/// runs of the run-length DDA.
///
/// ```
/// use relief_core::ray::{Ray, RayTracer, RunAccel};
/// use relief_core::{Heightfield, Surface};
/// use glam::Vec3;
/// let samples: Vec<f32> = (0..64).map(|i| (i % 7) as f32).collect();
/// let hf = Heightfield::new(&samples, 8, 8).unwrap();
/// let mut buf = vec![0.0f32; RunAccel::len(8, 8).unwrap()];
/// let accel = RunAccel::build(&hf, &mut buf).unwrap();
/// assert_eq!(accel.row_max(0, 0, 6), Some(6.0));
/// let tracer = RayTracer::new(&hf, Surface::Triangles);
/// let ray = Ray::new(Vec3::new(-2.0, 3.3, 9.0), Vec3::new(1.0, 0.2, -0.9)).unwrap();
/// let a = tracer.trace_run_dda(&ray, &accel).unwrap();
/// assert_eq!(a.hit, tracer.trace_cell_dda(&ray).hit);
/// ```
#[derive(Debug, Clone, Copy)]
pub struct RunAccel<'a> {
    data: &'a [f32],
    nx: u32,
    ny: u32,
    levels: u32,
}

fn levels_for(nx: u32, ny: u32) -> u32 {
    let n = nx.max(ny).max(1);
    (32 - n.leading_zeros()).min(LEVELS)
}

impl<'a> RunAccel<'a> {
    /// Elements of storage for a `width x height` sample grid: `2 * levels * cells`, where
    /// `levels = min(floor(log2(max(cells_x, cells_y))) + 1, 6)`; `None` for a grid smaller than
    /// 2 x 2 or on overflow.
    ///
    /// ```
    /// assert_eq!(relief_core::ray::RunAccel::len(3, 3), Some(2 * 2 * 4));
    /// assert_eq!(relief_core::ray::RunAccel::len(1, 3), None);
    /// ```
    #[must_use]
    pub fn len(width: u32, height: u32) -> Option<usize> {
        if width < 2 || height < 2 {
            return None;
        }
        let (nx, ny) = (width - 1, height - 1);
        (nx as usize)
            .checked_mul(ny as usize)?
            .checked_mul(2 * levels_for(nx, ny) as usize)
    }

    /// Builds the tables into `buf` (at least [`RunAccel::len`] elements, else
    /// [`Error::BufferTooSmall`]) and returns the view. `O(cells * levels)`.
    ///
    /// ```
    /// use relief_core::{ray::RunAccel, Error, Heightfield};
    /// let hf = Heightfield::new(&[0u16; 9], 3, 3).unwrap();
    /// let mut small = [0.0f32; 3];
    /// assert_eq!(RunAccel::build(&hf, &mut small).unwrap_err(), Error::BufferTooSmall { needed: 16, actual: 3 });
    /// ```
    pub fn build<T: Terrain>(terrain: &T, buf: &'a mut [f32]) -> Result<RunAccel<'a>, Error> {
        let needed = Self::len(terrain.width(), terrain.height()).ok_or(Error::SizeOverflow)?;
        if buf.len() < needed {
            return Err(Error::BufferTooSmall {
                needed,
                actual: buf.len(),
            });
        }
        let (nx, ny) = (terrain.width() - 1, terrain.height() - 1);
        let levels = levels_for(nx, ny);
        let (nxs, nys) = (nx as usize, ny as usize);
        let plane = nxs * nys;
        let (rows, cols) = buf
            .split_at_mut_checked(levels as usize * plane)
            .ok_or(Error::SizeOverflow)?;
        // Level 0: cell maxima, row-major in `rows`, column-major in `cols`.
        for y in 0..ny {
            for x in 0..nx {
                let c = terrain.cell_corners(x, y);
                let m = c[0].max(c[1]).max(c[2]).max(c[3]);
                if let Some(v) = rows.get_mut(y as usize * nxs + x as usize) {
                    *v = m;
                }
                if let Some(v) = cols.get_mut(x as usize * nys + y as usize) {
                    *v = m;
                }
            }
        }
        for (table, lines, n) in [(rows, nys, nxs), (cols, nxs, nys)] {
            for j in 1..levels as usize {
                let half = 1usize << (j - 1);
                for line in 0..lines {
                    for i in 0..n {
                        let prev = (j - 1) * plane + line * n;
                        let a = table.get(prev + i).copied().unwrap_or(f32::NEG_INFINITY);
                        let b = if i + half < n {
                            table
                                .get(prev + i + half)
                                .copied()
                                .unwrap_or(f32::NEG_INFINITY)
                        } else {
                            f32::NEG_INFINITY
                        };
                        if let Some(v) = table.get_mut(j * plane + line * n + i) {
                            *v = a.max(b);
                        }
                    }
                }
            }
        }
        Ok(RunAccel {
            data: buf,
            nx,
            ny,
            levels,
        })
    }

    #[inline]
    fn query(&self, base: usize, n: usize, lo: u32, hi: u32) -> Option<f32> {
        if lo > hi || hi as usize >= n {
            return None;
        }
        let plane = self.nx as usize * self.ny as usize;
        let len = (hi - lo + 1) as usize;
        let k = (usize::BITS - 1 - len.leading_zeros()).min(self.levels - 1) as usize;
        let block = 1usize << k;
        let at = |i: usize| self.data.get(base + k * plane + i).copied();
        let (lo, hi) = (lo as usize, hi as usize);
        if len <= 2 * block {
            return Some(at(lo)?.max(at(hi + 1 - block)?));
        }
        // Long runs: one read per block (bounded by len / 32 + 1).
        let mut m = at(hi + 1 - block)?;
        let mut i = lo;
        while i + block <= hi {
            m = m.max(at(i)?);
            i += block;
        }
        Some(m)
    }

    /// Maximum local height of cells `x_lo..=x_hi` of cell row `y`; `None` outside the grid.
    ///
    /// ```
    /// use relief_core::{ray::RunAccel, Heightfield};
    /// let hf = Heightfield::new(&[0u16, 5, 0, 0, 0, 0], 3, 2).unwrap();
    /// let mut buf = vec![0.0; RunAccel::len(3, 2).unwrap()];
    /// let acc = RunAccel::build(&hf, &mut buf).unwrap();
    /// assert_eq!(acc.row_max(0, 0, 1), Some(5.0));
    /// assert_eq!(acc.row_max(0, 0, 2), None);
    /// ```
    #[must_use]
    pub fn row_max(&self, y: u32, x_lo: u32, x_hi: u32) -> Option<f32> {
        if y >= self.ny {
            return None;
        }
        let n = self.nx as usize;
        self.query(y as usize * n, n, x_lo, x_hi)
    }

    /// Maximum local height of cells `y_lo..=y_hi` of cell column `x`; `None` outside the grid.
    ///
    /// ```
    /// use relief_core::{ray::RunAccel, Heightfield};
    /// let hf = Heightfield::new(&[0u16, 0, 0, 0, 0, 7], 2, 3).unwrap();
    /// let mut buf = vec![0.0; RunAccel::len(2, 3).unwrap()];
    /// let acc = RunAccel::build(&hf, &mut buf).unwrap();
    /// assert_eq!((acc.col_max(0, 0, 0), acc.col_max(0, 0, 1)), (Some(0.0), Some(7.0)));
    /// ```
    #[must_use]
    pub fn col_max(&self, x: u32, y_lo: u32, y_hi: u32) -> Option<f32> {
        if x >= self.nx {
            return None;
        }
        let n = self.ny as usize;
        let base = self.levels as usize * self.nx as usize * n + x as usize * n;
        self.query(base, n, y_lo, y_hi)
    }
}

impl<T: Terrain> RayTracer<'_, T> {
    /// Traces `ray` with the run-length DDA: each run is rejected as a whole when the ray's
    /// lowest point over it is above the run's maximum ([`RunAccel`]); otherwise its cells are
    /// tested as in [`RayTracer::trace_cell_dda`], so the hit is the same.
    /// [`Error::LengthMismatch`] if `accel` was built for another grid size.
    ///
    /// ```
    /// use relief_core::ray::{Ray, RayTracer, RunAccel};
    /// use relief_core::{Heightfield, Surface};
    /// use glam::Vec3;
    /// let hf = Heightfield::new(&[0.0f32; 16], 4, 4).unwrap();
    /// let mut buf = vec![0.0; RunAccel::len(4, 4).unwrap()];
    /// let acc = RunAccel::build(&hf, &mut buf).unwrap();
    /// let t = RayTracer::new(&hf, Surface::Bilinear);
    /// let r = t.trace_run_dda(&Ray::new(Vec3::new(0.0, 0.5, 1.0), Vec3::new(1.0, 0.0, -0.5)).unwrap(), &acc).unwrap();
    /// assert_eq!(r.hit.unwrap().t, 2.0);
    /// ```
    pub fn trace_run_dda(&self, ray: &Ray, accel: &RunAccel<'_>) -> Result<Trace, Error> {
        if accel.nx != self.cells.x || accel.ny != self.cells.y {
            return Err(Error::LengthMismatch {
                expected: self.cells.x as usize * self.cells.y as usize,
                actual: accel.nx as usize * accel.ny as usize,
            });
        }
        let mut out = Trace::default();
        let Some(lr) = self.local(ray) else {
            return Ok(out);
        };
        if let Some(hit) = self.start_hit(ray, &lr) {
            out.cells = 1;
            out.hit = Some(hit);
            return Ok(out);
        }
        let Some(line) = self.line(&lr) else {
            return Ok(out);
        };
        let (swap, pos_u, pos_v) = (line.swap, line.pos_u, line.pos_v);
        // Major axis index into LocalRay::slab: 0 = x.
        let (ma, mi) = if swap { (1, 0) } else { (0, 1) };
        let mut runs = line.runs();
        while let Some(f) = runs.next_folded() {
            out.steps += 1;
            // Unfolded cell span along the major axis and the row/column index.
            let (lo, hi) = if pos_u {
                (f.u_a, f.u_b)
            } else {
                (-f.u_b - 1, -f.u_a - 1)
            };
            let row = if pos_v { f.v } else { -f.v - 1 };
            let (lo, hi, row) = (lo as u32, hi as u32, row as u32);
            // Parameter range of the ray over the run: major slab of the whole run, minor slab of
            // the row.
            let (a_lo, b_lo) = lr.slab(ma, lo as f64);
            let (a_hi, b_hi) = lr.slab(ma, hi as f64);
            let (ra, rb) = (a_lo.min(a_hi), b_lo.max(b_hi));
            let (va, vb) = lr.slab(mi, row as f64);
            let ta = ra.max(va).max(lr.t0);
            let tb = rb.min(vb).min(lr.t1);
            if ta > tb {
                continue;
            }
            let m = if swap {
                accel.col_max(row, lo, hi)
            } else {
                accel.row_max(row, lo, hi)
            };
            let Some(m) = m else { continue };
            if lr.z(ta).min(lr.z(tb)) > m as f64 {
                continue;
            }
            let run = line.unfold_run(f);
            for [cx, cy] in run.cells() {
                let Some((ca, cb)) = self.cell_interval(&lr, cx, cy) else {
                    continue;
                };
                out.cells += 1;
                if let Some(h) = self.test_cell(&lr, cx, cy, ca, cb) {
                    out.hit = Some(self.make_hit(ray, cx, cy, h));
                    return Ok(out);
                }
            }
        }
        Ok(out)
    }
}
