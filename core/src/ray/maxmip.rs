//! Maximum-mipmap traversal: Tevs, Ihrke, Seidel, *Maximum Mipmaps for Fast, Accurate, and
//! Scalable Dynamic Height Field Rendering* (I3D 2008), section 4 (also used by Cornel et al.
//! 2022, seed 002, for their cascades).
//!
//! Level 0 holds the maximum of each cell's four corners; level `k` the maximum of 2 x 2 nodes of
//! level `k - 1` (odd sizes round up), up to one node. The ray descends into a node only if its
//! lowest point over the node is at or below the node's maximum; otherwise it skips the node and
//! climbs one level when it crosses into another parent, except for steeply descending rays
//! (`CLIMB_RELIEF`, a departure from the paper that saves steps and changes no hit). Leaves are
//! tested exactly (the same cell test as the DDAs), so the hit equals the cell DDA's. A walk
//! starts a few levels below the top (`START_DEPTH`), in the node holding the ray's clipped
//! start, which saves the descent through the top levels that nearly every ray makes;
//! `ray/simd.rs` walks eight rays at once with the same steps.

use super::cell::LocalRay;
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
    pub(super) data: &'a [f32],
    pub(super) nx: u32,
    pub(super) ny: u32,
    pub(super) levels: u32,
    lv: [Level; MAX_LEVELS],
    pub(super) bound: u64,
}

/// Where a level lies in the storage and its size.
#[derive(Debug, Clone, Copy)]
pub(super) struct Level {
    /// First element.
    pub(super) off: usize,
    /// Tiles across.
    pub(super) tx: u32,
    /// Nodes across and down.
    pub(super) w: i64,
    pub(super) h: i64,
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
        let mut lv = [Level {
            off: 0,
            tx: 1,
            w: 1,
            h: 1,
        }; MAX_LEVELS];
        let mut bound = 2u64;
        for (k, (l, &off)) in lv
            .iter_mut()
            .zip(&offsets)
            .enumerate()
            .take(levels as usize)
        {
            let (w, h) = (dim(nx, k as u32), dim(ny, k as u32));
            *l = Level {
                off,
                tx: w.div_ceil(4),
                w: w as i64,
                h: h as i64,
            };
            bound += 2 * (w as u64 + h as u64) + 2;
        }
        Ok(MaxMip {
            data: buf,
            nx,
            ny,
            levels,
            lv,
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
        let Some(l) = self.lv.get(level as usize) else {
            return f32::NEG_INFINITY;
        };
        if level >= self.levels || x as i64 >= l.w || y as i64 >= l.h {
            return f32::NEG_INFINITY;
        }
        self.data
            .get(l.off + tiled_t(l.tx, x, y))
            .copied()
            .unwrap_or(f32::NEG_INFINITY)
    }

    /// The layout of `level` (a one-node level past the top).
    #[inline(always)]
    pub(super) fn level(&self, level: u32) -> Level {
        self.lv.get(level as usize).copied().unwrap_or(Level {
            off: 0,
            tx: 1,
            w: 1,
            h: 1,
        })
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

/// Rays traced together by the AVX-512 packet path (`trace_maxmip_packet_avx512`, x86-64): one
/// ray per `f64` lane; each lane walks its own ray through the pyramid and takes the next ray
/// when its own ends.
///
/// ```
/// assert_eq!(relief_core::ray::PACKET_LANES, 8);
/// ```
pub const PACKET_LANES: usize = 8;

/// Levels below the top where a walk starts (in the node holding the ray's clipped start):
/// the top levels hold the highest samples and nearly every ray descends through them, so
/// starting lower saves those steps (the walk still climbs to the top as it moves). The hits
/// are the same from any start level; on the Puget Sound camera and grazing views of
/// `bench-peers/embree_rays.sh` (384 x 256 rays, `relief trace --json`, `steps`) 2, 3, 4, 5
/// and 6 took 824k / 1150k, 774k / 1128k, 743k / 1143k, 760k / 1270k and 885k / 1540k steps.
const START_DEPTH: u32 = 4;

/// A ray that descends by more than `CLIMB_RELIEF` times the terrain's mean relief per cell
/// (height range over the longer side's cells) for each cell it crosses does not climb after a
/// skip (Tevs et al. climb whenever a skip leaves the parent). Such a ray nears the surface
/// soon, and a climb then more often costs a descent back than it saves skips. The hits are
/// the same either way, and so are the cells tested (a cell is tested exactly when the ray
/// passes at or below its maximum). On the fourteen views of `bench-peers/embree_rays.sh` the
/// rule takes 2-10% fewer steps than climbing always; 1 and 4 took more steps than 2 on the
/// Puget views, and so did climbing several levels at once.
pub(super) const CLIMB_RELIEF: f64 = 2.0;

/// The traversal state of one ray in the pyramid.
#[derive(Debug, Clone, Copy)]
pub(super) struct Walk {
    pub(super) lr: LocalRay,
    pub(super) t: f64,
    pub(super) ix: i64,
    pub(super) iy: i64,
    pub(super) lvl: u32,
    pub(super) steps: u64,
    /// Per axis: whether the direction component is zero (`0`), positive (`1`) or negative
    /// (`-1`); the neighbour step along the axis (`1` or `-1`).
    pub(super) dir_x: i8,
    pub(super) dir_y: i8,
    pub(super) step_x: i64,
    pub(super) step_y: i64,
}

impl Walk {
    /// The walk of `lr` from node `(ix, iy)` of level `lvl`, at the clipped start.
    #[inline(always)]
    pub(super) fn start(lr: LocalRay, lvl: u32, ix: i64, iy: i64) -> Walk {
        Walk {
            lr,
            t: lr.t0,
            ix,
            iy,
            lvl,
            steps: 0,
            dir_x: sign(lr.d.x),
            dir_y: sign(lr.d.y),
            step_x: if lr.d.x >= 0.0 { 1 } else { -1 },
            step_y: if lr.d.y >= 0.0 { 1 } else { -1 },
        }
    }
}

/// The level where every walk of `mip` starts (`START_DEPTH` below the top).
#[inline(always)]
pub(super) fn start_level(mip: &MaxMip<'_>) -> u32 {
    (mip.levels - 1).saturating_sub(START_DEPTH)
}

impl<T: Terrain> RayTracer<'_, T> {
    /// The checks of the entry points that trace a slice of rays into `out`: `mip` belongs to
    /// this grid ([`Self::check_mip`]) and `out` holds a trace per ray.
    pub(super) fn check_rays(
        &self,
        rays: &[Ray],
        mip: &MaxMip<'_>,
        out: &[Trace],
    ) -> Result<(), Error> {
        self.check_mip(mip)?;
        if out.len() < rays.len() {
            return Err(Error::BufferTooSmall {
                needed: rays.len(),
                actual: out.len(),
            });
        }
        Ok(())
    }

    pub(super) fn check_mip(&self, mip: &MaxMip<'_>) -> Result<(), Error> {
        if mip.nx != self.cells.x || mip.ny != self.cells.y {
            return Err(Error::LengthMismatch {
                expected: self.cells.x as usize * self.cells.y as usize,
                actual: mip.nx as usize * mip.ny as usize,
            });
        }
        Ok(())
    }

    /// Clips `ray` and tests its start: the clipped local ray when a walk goes on, `None`
    /// when the ray misses the domain or hits at its start (recorded in `out`).
    #[inline(always)]
    pub(super) fn mip_clip(&self, ray: &Ray, out: &mut Trace) -> Option<LocalRay> {
        let lr = self.local(ray)?;
        if let Some(hit) = self.start_hit(ray, &lr) {
            out.cells = 1;
            out.hit = Some(hit);
            return None;
        }
        Some(lr)
    }

    /// Clips `ray` and tests its start ([`Self::mip_clip`]); the walk from the start node
    /// when it goes on.
    #[inline(always)]
    pub(super) fn mip_start(&self, ray: &Ray, mip: &MaxMip<'_>, out: &mut Trace) -> Option<Walk> {
        let lr = self.mip_clip(ray, out)?;
        let lvl = start_level(mip);
        let l = mip.level(lvl);
        let inv = f64::from_bits((1023 - lvl as u64) << 52);
        let px = lr.o.x + lr.t0 * lr.d.x;
        let py = lr.o.y + lr.t0 * lr.d.y;
        Some(Walk::start(
            lr,
            lvl,
            min_i(max_i((px * inv) as i64, 0), l.w - 1),
            min_i(max_i((py * inv) as i64, 0), l.h - 1),
        ))
    }

    /// Whether a walk of `lr` climbs after a skip into another parent (see `CLIMB_RELIEF`).
    /// Computed by the scalar walk before its loop, not in `mip_start` (the packet path, which
    /// once inlined `mip_start` and ran 5-8% slower with it there, now computes the rule in
    /// lanes in `ray/simd.rs`).
    #[inline(always)]
    pub(super) fn climbs(&self, lr: &LocalRay) -> bool {
        -lr.d.z <= self.climb_slope * max_f(lr.d.x.abs(), lr.d.y.abs())
    }

    /// One traversal step of `w`: descend into the current node, test it exactly (a cell), or
    /// skip it to its neighbour (and climb when the neighbour has another parent). `false` when
    /// the walk has ended (hit recorded in `out`, or left the grid, or past the clipped end).
    /// `ray/simd.rs` takes the same step in eight lanes with the same operations: keep the two
    /// in step.
    #[inline(always)]
    fn mip_step(
        &self,
        ray: &Ray,
        mip: &MaxMip<'_>,
        w: &mut Walk,
        climb: bool,
        out: &mut Trace,
    ) -> bool {
        if w.steps >= mip.bound {
            return false;
        }
        w.steps += 1;
        out.steps = out.steps.saturating_add(1);
        let lr = &w.lr;
        let (ix, iy, lvl) = (w.ix, w.iy, w.lvl);
        let lv = mip.level(lvl);
        let s = 1i64 << (lvl & 63);
        let x0 = (ix * s) as f64;
        let x1 = min_i(ix * s + s, mip.nx as i64) as f64;
        let y0 = (iy * s) as f64;
        let y1 = min_i(iy * s + s, mip.ny as i64) as f64;
        let (ax, bx) = slab_signed(lr.o.x, lr.inv[0], w.dir_x, x0, x1);
        let (ay, by) = slab_signed(lr.o.y, lr.inv[1], w.dir_y, y0, y1);
        let ta = max_f(max_f(w.t, ax), ay);
        let tb = min_f(min_f(lr.t1, bx), by);
        if ta <= tb {
            let idx = lv.off + tiled_t(lv.tx, ix as u32, iy as u32);
            let m = mip.data.get(idx).copied().unwrap_or(f32::NEG_INFINITY) as f64;
            if min_f(lr.z(ta), lr.z(tb)) <= m {
                if lvl == 0 {
                    out.cells += 1;
                    let (cx, cy) = (ix as u32, iy as u32);
                    if let Some(h) = super::cell::intersect(
                        self.surface,
                        lr,
                        cx,
                        cy,
                        &self.corners(cx, cy),
                        ta,
                        tb,
                    ) {
                        out.hit = Some(self.make_hit(ray, cx, cy, h));
                        return false;
                    }
                } else {
                    // Descend into the child holding the point at `ta`. 2^-l is exact;
                    // truncation equals floor after the clamp into the children (the point
                    // lies in the node up to rounding).
                    let l = lvl - 1;
                    let cl = mip.level(l);
                    let inv = f64::from_bits((1023 - l as u64) << 52);
                    let px = lr.o.x + ta * lr.d.x;
                    let py = lr.o.y + ta * lr.d.y;
                    w.ix = min_i(
                        min_i(max_i((px * inv) as i64, 2 * ix), 2 * ix + 1),
                        cl.w - 1,
                    );
                    w.iy = min_i(
                        min_i(max_i((py * inv) as i64, 2 * iy), 2 * iy + 1),
                        cl.h - 1,
                    );
                    w.lvl = l;
                    w.t = ta;
                    return true;
                }
            }
        }
        // Skip the node: leave through the face crossed first (both at a corner).
        let exit = min_f(bx, by);
        w.t = max_f(exit, w.t);
        if w.t > lr.t1 || lvl + 1 >= mip.levels {
            return false;
        }
        let (mut sx, mut sy) = (ix, iy);
        if bx <= by {
            sx += w.step_x;
        }
        if by <= bx {
            sy += w.step_y;
        }
        if sx < 0 || sy < 0 || sx >= lv.w || sy >= lv.h {
            return false;
        }
        if climb && ((sx >> 1) != (ix >> 1) || (sy >> 1) != (iy >> 1)) {
            w.lvl += 1;
            sx >>= 1;
            sy >>= 1;
        }
        w.ix = sx;
        w.iy = sy;
        true
    }

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
        self.check_mip(mip)?;
        let mut out = Trace::default();
        self.mip_walk(ray, mip, &mut out);
        Ok(out)
    }

    /// Traces every ray of `rays` through `mip` into `out` (one [`Trace`] per ray, in order),
    /// the same as [`RayTracer::trace_maxmip`] ray by ray. This portable version does exactly
    /// that (interleaving the rays of a packet in scalar code was tried and was slower); on
    /// x86-64 the std side can select `trace_maxmip_packet_avx512` at run time, which walks
    /// [`PACKET_LANES`] rays at once in SIMD lanes with the same results. Errors:
    /// [`Error::LengthMismatch`] for a pyramid of another grid, [`Error::BufferTooSmall`] if
    /// `out` is shorter than `rays`.
    ///
    /// ```
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
    /// t.trace_maxmip_packet(&rays, &mip, &mut out).unwrap();
    /// for (r, o) in rays.iter().zip(&out) {
    ///     assert_eq!(*o, t.trace_maxmip(r, &mip).unwrap());
    /// }
    /// assert!(t.trace_maxmip_packet(&rays, &mip, &mut out[..3]).is_err());
    /// ```
    pub fn trace_maxmip_packet(
        &self,
        rays: &[Ray],
        mip: &MaxMip<'_>,
        out: &mut [Trace],
    ) -> Result<(), Error> {
        self.check_rays(rays, mip, out)?;
        self.each_ray(rays, mip, out);
        Ok(())
    }

    /// [`RayTracer::trace_maxmip`] for each ray (lengths already checked).
    pub(super) fn each_ray(&self, rays: &[Ray], mip: &MaxMip<'_>, out: &mut [Trace]) {
        for (ray, o) in rays.iter().zip(out.iter_mut()) {
            *o = Trace::default();
            self.mip_walk(ray, mip, o);
        }
    }

    /// The whole walk of one ray, into `out` (reset by the caller).
    #[inline(always)]
    pub(super) fn mip_walk(&self, ray: &Ray, mip: &MaxMip<'_>, out: &mut Trace) {
        if let Some(mut w) = self.mip_start(ray, mip, out) {
            let climb = self.climbs(&w.lr);
            // Bounded: every step counts towards `mip.bound`, after which `mip_step` stops.
            while self.mip_step(ray, mip, &mut w, climb, out) {}
        }
    }
}

#[inline(always)]
pub(super) fn sign(d: f64) -> i8 {
    if d > 0.0 {
        1
    } else if d < 0.0 {
        -1
    } else {
        0
    }
}

/// The parameter interval `(entry, exit)` of the line `o + t d` in the slab `[lo, hi]`, given
/// `inv = 1 / d` and the sign of `d`; `(-inf, inf)` for `d == 0`. The same values as sorting
/// `(lo - o) inv` and `(hi - o) inv`, without a branch.
#[inline(always)]
fn slab_signed(o: f64, inv: f64, sign: i8, lo: f64, hi: f64) -> (f64, f64) {
    let a = (lo - o) * inv;
    let b = (hi - o) * inv;
    let (a, b) = if sign > 0 { (a, b) } else { (b, a) };
    let a = if sign == 0 { f64::NEG_INFINITY } else { a };
    let b = if sign == 0 { f64::INFINITY } else { b };
    (a, b)
}

/// `max` without the NaN handling of `f64::max` (operands are never NaN here); exactly the
/// x86 `maxpd` rule (`b` unless `a > b`), so the SIMD path computes the same values.
#[inline(always)]
pub(super) fn max_f(a: f64, b: f64) -> f64 {
    if a > b {
        a
    } else {
        b
    }
}

/// `min` without the NaN handling of `f64::min`; exactly the x86 `minpd` rule.
#[inline(always)]
pub(super) fn min_f(a: f64, b: f64) -> f64 {
    if a < b {
        a
    } else {
        b
    }
}

#[inline(always)]
fn max_i(a: i64, b: i64) -> i64 {
    if b > a {
        b
    } else {
        a
    }
}

#[inline(always)]
fn min_i(a: i64, b: i64) -> i64 {
    if b < a {
        b
    } else {
        a
    }
}
