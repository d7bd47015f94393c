//! Maximum-mipmap traversal: Tevs, Ihrke, Seidel, *Maximum Mipmaps for Fast, Accurate, and
//! Scalable Dynamic Height Field Rendering* (I3D 2008), section 4 (also used by Cornel et al.
//! 2022, seed 002, for their cascades).
//!
//! Level 0 holds the maximum of each cell's four corners; level `k` the maximum of 2 x 2 nodes of
//! level `k - 1` (odd sizes round up), up to one node. The ray descends into a node only if its
//! lowest point over the node is at or below the node's maximum; otherwise it skips the node and
//! climbs one level when it crosses into another parent. Leaves are tested exactly (the same
//! cell test as the DDAs), so the hit equals the cell DDA's.

use super::{Ray, RayTracer, Trace};
use crate::{Error, Terrain};

const MAX_LEVELS: usize = 33;

/// A maximum pyramid over caller storage (`f32` local heights), see [`MaxMip::len`].
///
/// ```
/// use relief_core::ray::{MaxMip, Ray, RayTracer};
/// use relief_core::{Heightfield, Surface};
/// use glam::Vec3;
/// let samples: Vec<f32> = (0..25).map(|i| ((i * 7) % 5) as f32).collect();
/// let hf = Heightfield::new(&samples, 5, 5).unwrap();
/// let mut buf = vec![0.0f32; MaxMip::len(5, 5).unwrap()];
/// let mip = MaxMip::build(&hf, &mut buf).unwrap();
/// assert_eq!(mip.max(), 4.0);
/// let tracer = RayTracer::new(&hf, Surface::Bilinear);
/// let ray = Ray::new(Vec3::new(-1.0, 0.7, 6.0), Vec3::new(1.0, 0.4, -1.0)).unwrap();
/// assert_eq!(tracer.trace_maxmip(&ray, &mip).unwrap().hit, tracer.trace_cell_dda(&ray).hit);
/// ```
#[derive(Debug, Clone, Copy)]
pub struct MaxMip<'a> {
    data: &'a [f32],
    nx: u32,
    ny: u32,
    levels: u32,
    offsets: [usize; MAX_LEVELS],
    /// Per level: nodes across, nodes down, tiles across.
    dims: [(u32, u32, u32); MAX_LEVELS],
    bound: u64,
}

#[inline]
fn dim(n: u32, k: u32) -> u32 {
    ((n - 1) >> k) + 1
}

/// Index of node `(x, y)` in a level `w` nodes wide, stored in 4 x 4 tiles (64 bytes, one cache
/// line): a node's children and its neighbours usually share a line with it.
#[inline]
fn tiled(w: u32, x: u32, y: u32) -> usize {
    tiled_t(w.div_ceil(4), x, y)
}

/// [`tiled`] with the tiles across already known.
#[inline]
fn tiled_t(tiles_x: u32, x: u32, y: u32) -> usize {
    (((y >> 2) as usize * tiles_x as usize + (x >> 2) as usize) << 4)
        + (((y & 3) << 2) | (x & 3)) as usize
}

/// Elements of a level of `w x h` nodes (padded to whole tiles).
#[inline]
fn level_len(w: u32, h: u32) -> Option<usize> {
    (w as usize)
        .div_ceil(4)
        .checked_mul((h as usize).div_ceil(4))?
        .checked_mul(16)
}

/// Number of levels and their offsets for `nx x ny` cells; `None` on overflow.
fn layout(nx: u32, ny: u32) -> Option<(u32, [usize; MAX_LEVELS], usize)> {
    let mut offsets = [0usize; MAX_LEVELS];
    let mut total = 0usize;
    let mut k = 0u32;
    loop {
        *offsets.get_mut(k as usize)? = total;
        let (w, h) = (dim(nx, k), dim(ny, k));
        total = total.checked_add(level_len(w, h)?)?;
        k += 1;
        if (w == 1 && h == 1) || k as usize >= MAX_LEVELS {
            break;
        }
    }
    Some((k, offsets, total))
}

fn cells_of(width: u32, height: u32) -> Result<(u32, u32), Error> {
    if width < 2 || height < 2 {
        return Err(Error::TooSmall { width, height });
    }
    Ok((width - 1, height - 1))
}

impl<'a> MaxMip<'a> {
    /// Elements of storage for a `width x height` sample grid: about `4/3` of the cell count,
    /// each level padded to whole 4 x 4 tiles (levels are stored tile by tile, one 64-byte cache
    /// line per tile); `None` for a grid smaller than 2 x 2 or on overflow.
    ///
    /// ```
    /// // 4 x 4 cells: one tile per level, three levels (4 x 4, 2 x 2, 1 x 1).
    /// assert_eq!(relief_core::ray::MaxMip::len(5, 5), Some(48));
    /// // 1024 x 1024 cells: 1024^2 + 512^2 + ... + 4^2 + 3 padded tiles.
    /// assert_eq!(relief_core::ray::MaxMip::len(1025, 1025), Some(1398128));
    /// ```
    #[must_use]
    pub fn len(width: u32, height: u32) -> Option<usize> {
        let (nx, ny) = cells_of(width, height).ok()?;
        layout(nx, ny).map(|l| l.2)
    }

    /// Builds the pyramid of `terrain` into `buf` ([`Error::BufferTooSmall`] if shorter than
    /// [`MaxMip::len`]). `O(cells)`.
    ///
    /// ```
    /// use relief_core::{ray::MaxMip, Heightfield};
    /// let hf = Heightfield::new(&[1u16, 2, 3, 9], 2, 2).unwrap();
    /// let mut buf = [0.0f32; 16];
    /// assert_eq!(MaxMip::build(&hf, &mut buf).unwrap().max(), 9.0);
    /// ```
    pub fn build<T: Terrain>(terrain: &T, buf: &'a mut [f32]) -> Result<MaxMip<'a>, Error> {
        let (w, h) = (terrain.width(), terrain.height());
        Self::update(terrain, buf, 0, 0, w - 1, h - 1)?;
        Self::view(buf, w, h)
    }

    /// A view of a pyramid already built in `buf` for a `width x height` grid.
    ///
    /// ```
    /// use relief_core::{ray::MaxMip, Heightfield};
    /// let hf = Heightfield::new(&[1u16, 2, 3, 9], 2, 2).unwrap();
    /// let mut buf = [0.0f32; 16];
    /// MaxMip::build(&hf, &mut buf).unwrap();
    /// assert_eq!(MaxMip::view(&buf, 2, 2).unwrap().max(), 9.0);
    /// assert!(MaxMip::view(&buf, 3, 3).is_err());
    /// ```
    pub fn view(buf: &'a [f32], width: u32, height: u32) -> Result<MaxMip<'a>, Error> {
        let (nx, ny) = cells_of(width, height)?;
        let (levels, offsets, total) = layout(nx, ny).ok_or(Error::SizeOverflow)?;
        if buf.len() < total {
            return Err(Error::BufferTooSmall {
                needed: total,
                actual: buf.len(),
            });
        }
        let mut dims = [(1u32, 1u32, 1u32); MAX_LEVELS];
        let mut bound = 2u64;
        for (k, d) in dims.iter_mut().enumerate().take(levels as usize) {
            let (w, h) = (dim(nx, k as u32), dim(ny, k as u32));
            *d = (w, h, w.div_ceil(4));
            bound += 2 * (w as u64 + h as u64) + 2;
        }
        Ok(MaxMip {
            data: buf,
            nx,
            ny,
            levels,
            offsets,
            dims,
            bound,
        })
    }

    /// Updates the pyramid in `buf` after the samples in the rectangle `x0..=x1, y0..=y1` (sample
    /// coordinates) changed: recomputes the cells touching it and their ancestors only.
    /// [`Error::OutOfBounds`] if the rectangle is empty or outside the grid.
    ///
    /// ```
    /// use relief_core::{ray::MaxMip, Heightfield};
    /// let mut s = [0u16; 16];
    /// let mut buf = vec![0.0f32; MaxMip::len(4, 4).unwrap()];
    /// MaxMip::build(&Heightfield::new(&s, 4, 4).unwrap(), &mut buf).unwrap();
    /// s[5] = 7; // sample (1, 1)
    /// let hf = Heightfield::new(&s, 4, 4).unwrap();
    /// MaxMip::update(&hf, &mut buf, 1, 1, 1, 1).unwrap();
    /// assert_eq!(MaxMip::view(&buf, 4, 4).unwrap().max(), 7.0);
    /// ```
    pub fn update<T: Terrain>(
        terrain: &T,
        buf: &mut [f32],
        x0: u32,
        y0: u32,
        x1: u32,
        y1: u32,
    ) -> Result<(), Error> {
        let (w, h) = (terrain.width(), terrain.height());
        let (nx, ny) = cells_of(w, h)?;
        let (levels, offsets, total) = layout(nx, ny).ok_or(Error::SizeOverflow)?;
        if buf.len() < total {
            return Err(Error::BufferTooSmall {
                needed: total,
                actual: buf.len(),
            });
        }
        if x0 > x1 || y0 > y1 || x1 >= w || y1 >= h {
            return Err(Error::OutOfBounds { x: x1, y: y1 });
        }
        // Cells touching the changed samples.
        let (mut cx0, mut cy0) = (x0.saturating_sub(1), y0.saturating_sub(1));
        let (mut cx1, mut cy1) = (x1.min(nx - 1), y1.min(ny - 1));
        for y in cy0..=cy1 {
            for x in cx0..=cx1 {
                let c = terrain.cell_corners(x, y);
                if let Some(v) = buf.get_mut(tiled(nx, x, y)) {
                    *v = c[0].max(c[1]).max(c[2]).max(c[3]);
                }
            }
        }
        for k in 1..levels {
            let (pw, ph) = (dim(nx, k - 1), dim(ny, k - 1));
            let lw = dim(nx, k);
            let prev = offsets.get(k as usize - 1).copied().unwrap_or(0);
            let cur = offsets.get(k as usize).copied().unwrap_or(0);
            (cx0, cy0, cx1, cy1) = (cx0 >> 1, cy0 >> 1, cx1 >> 1, cy1 >> 1);
            for y in cy0..=cy1 {
                for x in cx0..=cx1 {
                    let mut m = f32::NEG_INFINITY;
                    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let (px, py) = (2 * x + dx, 2 * y + dy);
                        if px < pw && py < ph {
                            let i = prev + tiled(pw, px, py);
                            m = m.max(buf.get(i).copied().unwrap_or(f32::NEG_INFINITY));
                        }
                    }
                    if let Some(v) = buf.get_mut(cur + tiled(lw, x, y)) {
                        *v = m;
                    }
                }
            }
        }
        Ok(())
    }

    /// Number of levels (level 0 = cells).
    ///
    /// ```
    /// assert_eq!(relief_core::ray::MaxMip::view(&[0.0; 48], 5, 5).unwrap().levels(), 3);
    /// ```
    #[must_use]
    pub fn levels(&self) -> u32 {
        self.levels
    }

    /// The maximum local height over the whole grid (the top node).
    ///
    /// ```
    /// use relief_core::{ray::MaxMip, Heightfield};
    /// let hf = Heightfield::new(&[0u16, 1, 2, 3, 4, 5, 6, 7, 8], 3, 3).unwrap();
    /// let mut buf = vec![0.0; MaxMip::len(3, 3).unwrap()];
    /// assert_eq!(MaxMip::build(&hf, &mut buf).unwrap().max(), 8.0);
    /// ```
    #[must_use]
    pub fn max(&self) -> f32 {
        self.node(self.levels - 1, 0, 0)
    }

    /// Maximum of node `(x, y)` of `level` (`-inf` outside).
    ///
    /// ```
    /// use relief_core::{ray::MaxMip, Heightfield};
    /// let hf = Heightfield::new(&[0u16, 1, 2, 3, 4, 5, 6, 7, 8], 3, 3).unwrap();
    /// let mut buf = vec![0.0; MaxMip::len(3, 3).unwrap()];
    /// let m = MaxMip::build(&hf, &mut buf).unwrap();
    /// // Cell (1, 0) has corners 1, 2, 4, 5.
    /// assert_eq!((m.node(0, 1, 0), m.node(1, 0, 0), m.node(0, 5, 5)), (5.0, 8.0, f32::NEG_INFINITY));
    /// ```
    #[must_use]
    pub fn node(&self, level: u32, x: u32, y: u32) -> f32 {
        let Some(&(w, h, tx)) = self.dims.get(level as usize) else {
            return f32::NEG_INFINITY;
        };
        if level >= self.levels || x >= w || y >= h {
            return f32::NEG_INFINITY;
        }
        let off = self.offsets.get(level as usize).copied().unwrap_or(0);
        self.data
            .get(off + tiled_t(tx, x, y))
            .copied()
            .unwrap_or(f32::NEG_INFINITY)
    }

    /// Nodes across and down on `level` (`(1, 1)` past the top).
    #[inline]
    fn dims_of(&self, level: u32) -> (i64, i64) {
        self.dims
            .get(level as usize)
            .map_or((1, 1), |d| (d.0 as i64, d.1 as i64))
    }

    /// Upper bound on the traversal steps of one ray: twice the nodes a line can cross on every
    /// level, plus two per level (about `4 (width + height)`).
    ///
    /// ```
    /// let m = relief_core::ray::MaxMip::view(&[0.0; 48], 5, 5).unwrap();
    /// assert_eq!(m.step_bound(), 2 * ((4 + 4) + (2 + 2) + (1 + 1)) + 2 * 3 + 2);
    /// ```
    #[must_use]
    pub fn step_bound(&self) -> u64 {
        self.bound
    }
}

impl<T: Terrain> RayTracer<'_, T> {
    /// Traces `ray` through the maximum mipmap `mip` (built for this terrain): hierarchical
    /// skipping, exact cell tests at level 0, so the hit equals [`RayTracer::trace_cell_dda`]'s.
    /// [`Error::LengthMismatch`] if `mip` belongs to another grid size.
    ///
    /// ```
    /// use relief_core::ray::{MaxMip, Ray, RayTracer};
    /// use relief_core::{Heightfield, Surface};
    /// use glam::Vec3;
    /// let hf = Heightfield::new(&[0.0f32; 16], 4, 4).unwrap();
    /// let mut buf = vec![0.0; MaxMip::len(4, 4).unwrap()];
    /// let mip = MaxMip::build(&hf, &mut buf).unwrap();
    /// let t = RayTracer::new(&hf, Surface::Triangles);
    /// let r = t.trace_maxmip(&Ray::new(Vec3::new(0.0, 0.5, 1.0), Vec3::new(1.0, 0.0, -0.5)).unwrap(), &mip).unwrap();
    /// assert_eq!(r.hit.unwrap().t, 2.0);
    /// ```
    pub fn trace_maxmip(&self, ray: &Ray, mip: &MaxMip<'_>) -> Result<Trace, Error> {
        if mip.nx != self.cells.x || mip.ny != self.cells.y {
            return Err(Error::LengthMismatch {
                expected: self.cells.x as usize * self.cells.y as usize,
                actual: mip.nx as usize * mip.ny as usize,
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
        let (sx, sy) = (lr.d.x >= 0.0, lr.d.y >= 0.0);
        let top = mip.levels - 1;
        let mut lvl = top;
        let (mut ix, mut iy) = (0i64, 0i64);
        let mut t = lr.t0;
        let (nx, ny) = (mip.nx as i64, mip.ny as i64);
        let bound = mip.step_bound();
        let mut steps = 0u64;
        while steps < bound {
            steps += 1;
            out.steps = out.steps.saturating_add(1);
            let s = 1i64 << lvl;
            let (x0, x1) = ((ix * s) as f64, ((ix + 1) * s).min(nx) as f64);
            let (y0, y1) = ((iy * s) as f64, ((iy + 1) * s).min(ny) as f64);
            let (ax, bx) = slab(lr.o.x, lr.d.x, lr.inv[0], x0, x1);
            let (ay, by) = slab(lr.o.y, lr.d.y, lr.inv[1], y0, y1);
            let ta = t.max(ax).max(ay);
            let tb = lr.t1.min(bx).min(by);
            let mut descend = false;
            if ta <= tb {
                let m = mip.node(lvl, ix as u32, iy as u32) as f64;
                if lr.z(ta).min(lr.z(tb)) <= m {
                    if lvl == 0 {
                        out.cells += 1;
                        let (cx, cy) = (ix as u32, iy as u32);
                        if let Some(h) = super::cell::intersect(
                            self.surface,
                            &lr,
                            cx,
                            cy,
                            &self.corners(cx, cy),
                            ta,
                            tb,
                        ) {
                            out.hit = Some(self.make_hit(ray, cx, cy, h));
                            return Ok(out);
                        }
                    } else {
                        descend = true;
                    }
                }
            }
            if descend {
                lvl -= 1;
                t = ta;
                // 1 / 2^lvl is exact; truncation equals floor after the clamp into the children
                // (the point lies in the node up to rounding).
                let inv = 1.0 / (1i64 << lvl) as f64;
                let px = lr.o.x + ta * lr.d.x;
                let py = lr.o.y + ta * lr.d.y;
                let (w, h) = mip.dims_of(lvl);
                ix = ((px * inv) as i64).max(2 * ix).min(2 * ix + 1).min(w - 1);
                iy = ((py * inv) as i64).max(2 * iy).min(2 * iy + 1).min(h - 1);
                continue;
            }
            // Skip the node: leave through the face crossed first (both at a corner).
            let exit = bx.min(by);
            if exit > t {
                t = exit;
            }
            if t > lr.t1 || lvl == top {
                return Ok(out);
            }
            let (ox, oy) = (ix, iy);
            if bx <= by {
                ix += if sx { 1 } else { -1 };
            }
            if by <= bx {
                iy += if sy { 1 } else { -1 };
            }
            let (w, h) = mip.dims_of(lvl);
            if ix < 0 || iy < 0 || ix >= w || iy >= h {
                return Ok(out);
            }
            if (ix >> 1) != (ox >> 1) || (iy >> 1) != (oy >> 1) {
                lvl += 1;
                ix >>= 1;
                iy >>= 1;
            }
        }
        Ok(out)
    }
}

#[inline]
fn slab(o: f64, d: f64, inv: f64, lo: f64, hi: f64) -> (f64, f64) {
    if d == 0.0 {
        return (f64::NEG_INFINITY, f64::INFINITY);
    }
    let a = (lo - o) * inv;
    let b = (hi - o) * inv;
    if a <= b {
        (a, b)
    } else {
        (b, a)
    }
}
