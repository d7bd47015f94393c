//! Ray traversal and intersection of heightfields.
//!
//! Implements, over any [`Terrain`]:
//! - the cell DDA (Amanatides & Woo 1987) and the run-length DDA of Henning & Stephenson,
//!   *Accelerating the Ray Tracing of Height Fields* (2004), section 2, as `Copy` iterators
//!   ([`GridLine`], [`CellDda`], [`RunDda`]);
//! - exact per-cell intersection for every [`Surface`] (section 3 of the same paper for
//!   [`Surface::Plane`]) and whole-run rejection with an O(1) range maximum per row and column
//!   ([`RunAccel`]);
//! - maximum-mipmap traversal (Tevs, Ihrke, Seidel, *Maximum Mipmaps for Fast, Accurate, and
//!   Scalable Dynamic Height Field Rendering*, 2008) with a pyramid in caller storage
//!   ([`MaxMip`]);
//! - linear + binary search marching (Kentie, *On-GPU ray traced terrain*, section 3.3-3.4) with
//!   an error report ([`MarchOptions`], [`MarchTrace`]).
//!
//! ## Rules every method follows
//! - **Precision.** A [`Ray`] keeps its origin and direction in `f64`. Tracing converts it once
//!   to *heightfield-local* coordinates: `x / dx`, `y / dy` (divisions, not multiplications by a
//!   rounded reciprocal) and `z - z_offset`, all in `f64`; every intersection is computed there,
//!   relative to the cell's corner. The hit position is converted back at the end. So a
//!   `z_offset` of `1e6` or an eye `1e6` units away costs no precision beyond `f64` rounding.
//! - **Hits.** The hit is the first point of the ray inside the domain's vertical prism that is
//!   at or below the surface. A ray starting below the surface hits at its start (`t = 0`); one
//!   entering the prism through a side below the surface hits at the side. `t` is the ray
//!   parameter: `origin + t * dir` (a distance when `dir` is a unit vector, as for camera rays).
//! - **Clipping.** The ray is clipped to the domain and to the height range of the terrain
//!   widened by a margin (`1e-6` of the largest magnitude, plus `1e-9`), so flat ground at the
//!   minimum height is still hit.
//! - **Bounds.** Every loop is bounded: a DDA visits at most `width + height` cells (see
//!   [`GridLine::step_bound`]), the max-mip traversal at most [`MaxMip::step_bound`] nodes, the
//!   march its sample count.
//!
//! ```
//! use relief_core::ray::{Ray, RayTracer};
//! use relief_core::{Heightfield, Surface};
//! use glam::Vec3;
//! let samples = [0.0f32; 16];
//! let hf = Heightfield::new(&samples, 4, 4).unwrap();
//! let tracer = RayTracer::new(&hf, Surface::Triangles);
//! let ray = Ray::new(Vec3::new(1.5, 1.5, 10.0), Vec3::new(0.0, 0.0, -1.0)).unwrap();
//! let hit = tracer.trace_cell_dda(&ray).hit.unwrap();
//! assert_eq!(hit.t, 10.0);
//! assert_eq!(hit.cell, [1, 1]);
//! ```

mod cell;
mod dda;
mod march;
mod maxmip;
mod run;
#[cfg(target_arch = "x86_64")]
mod simd;
#[cfg(test)]
mod tests;
mod wide;

pub use dda::{CellDda, CellRun, GridLine, RunDda, RunIntercept, RunIntercepts};
pub use march::{MarchOptions, MarchTrace};
pub use maxmip::{MaxMip, PACKET_LANES};
pub use run::RunAccel;

use crate::{Error, Surface, Terrain};
use cell::{CellHit, LocalRay};
use glam::{DVec2, DVec3, Vec3};
use maxmip::{max_f, min_f};

/// Cells per axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Cells {
    pub x: u32,
    pub y: u32,
}

impl Cells {
    #[inline]
    pub fn as_dvec2(self) -> DVec2 {
        DVec2::new(self.x as f64, self.y as f64)
    }
}

/// Largest magnitude of a ray origin component, in world units (1e12: a billion kilometres).
/// Beyond it `f64` resolves positions only to `1e-4` of a unit or worse, not enough to know
/// which cell a ray enters.
///
/// ```
/// assert_eq!(relief_core::ray::MAX_RAY_ORIGIN, 1e12);
/// ```
pub const MAX_RAY_ORIGIN: f64 = 1e12;

/// A ray `origin + t * dir`, `t >= 0`, in world coordinates, kept in `f64`.
///
/// ```
/// use relief_core::{ray::Ray, Error};
/// use glam::Vec3;
/// assert!(Ray::new(Vec3::ZERO, Vec3::X).is_ok());
/// assert_eq!(Ray::new(Vec3::ZERO, Vec3::ZERO).unwrap_err(), Error::NonFiniteInput { name: "ray direction" });
/// assert!(Ray::new(Vec3::new(f32::NAN, 0.0, 0.0), Vec3::X).is_err());
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    origin: DVec3,
    dir: DVec3,
}

impl Ray {
    /// A checked ray from `f32` vectors: [`Error::NonFiniteInput`] for a NaN or infinite origin
    /// or direction, or a zero direction. The direction need not be normalised.
    ///
    /// ```
    /// use relief_core::ray::Ray;
    /// use glam::Vec3;
    /// let r = Ray::new(Vec3::ONE, Vec3::Z).unwrap();
    /// assert_eq!(r.origin(), glam::DVec3::ONE);
    /// ```
    pub fn new(origin: Vec3, dir: Vec3) -> Result<Ray, Error> {
        Ray::new_f64(origin.as_dvec3(), dir.as_dvec3())
    }

    /// A checked ray from `f64` vectors (for origins far from the grid, e.g. `1e6` away).
    /// Origin components beyond `±MAX_RAY_ORIGIN` (1e12 world units) are rejected as
    /// [`Error::NonFiniteInput`]: that far out, `f64` cannot tell which cell the ray enters
    /// (found by fuzzing: an origin `1.7e38` away made the exact methods disagree).
    ///
    /// ```
    /// use relief_core::ray::{Ray, MAX_RAY_ORIGIN};
    /// use glam::DVec3;
    /// assert!(Ray::new_f64(DVec3::new(1e6 + 0.125, 0.0, 1.0), DVec3::X).is_ok());
    /// assert!(Ray::new_f64(DVec3::ZERO, DVec3::new(0.0, f64::INFINITY, 0.0)).is_err());
    /// assert!(Ray::new_f64(DVec3::new(0.0, -2.0 * MAX_RAY_ORIGIN, 0.0), DVec3::Y).is_err());
    /// ```
    pub fn new_f64(origin: DVec3, dir: DVec3) -> Result<Ray, Error> {
        if !origin.is_finite() || origin.abs().max_element() > MAX_RAY_ORIGIN {
            return Err(Error::NonFiniteInput { name: "ray origin" });
        }
        if !dir.is_finite() || dir == DVec3::ZERO || !dir.length_squared().is_finite() {
            return Err(Error::NonFiniteInput {
                name: "ray direction",
            });
        }
        Ok(Ray { origin, dir })
    }

    /// The origin.
    ///
    /// ```
    /// # use relief_core::ray::Ray; use glam::{DVec3, Vec3};
    /// assert_eq!(Ray::new(Vec3::X, Vec3::Z).unwrap().origin(), DVec3::X);
    /// ```
    #[must_use]
    pub fn origin(&self) -> DVec3 {
        self.origin
    }

    /// The direction (as given).
    ///
    /// ```
    /// # use relief_core::ray::Ray; use glam::{DVec3, Vec3};
    /// assert_eq!(Ray::new(Vec3::X, Vec3::Z).unwrap().dir(), DVec3::Z);
    /// ```
    #[must_use]
    pub fn dir(&self) -> DVec3 {
        self.dir
    }

    /// The point at parameter `t`.
    ///
    /// ```
    /// # use relief_core::ray::Ray; use glam::{DVec3, Vec3};
    /// assert_eq!(Ray::new(Vec3::X, Vec3::Z).unwrap().at(2.0), DVec3::new(1.0, 0.0, 2.0));
    /// ```
    #[must_use]
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + t * self.dir
    }
}

/// Where a ray hits the surface.
///
/// ```
/// use relief_core::ray::{Ray, RayTracer};
/// use relief_core::{Heightfield, Surface};
/// use glam::Vec3;
/// let hf = Heightfield::new(&[1.0f32; 4], 2, 2).unwrap();
/// let t = RayTracer::new(&hf, Surface::Bilinear);
/// let hit = t.trace_cell_dda(&Ray::new(Vec3::new(0.5, 0.5, 3.0), -Vec3::Z).unwrap()).hit.unwrap();
/// assert_eq!((hit.t, hit.cell, hit.normal), (2.0, [0, 0], Vec3::Z));
/// assert_eq!(hit.position, glam::DVec3::new(0.5, 0.5, 1.0));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit (distance for a unit direction).
    pub t: f64,
    /// The cell `[x, y]` hit.
    pub cell: [u32; 2],
    /// World position of the hit.
    pub position: DVec3,
    /// Unit surface normal in world coordinates (`z >= 0` on the surface; horizontal on the
    /// walls of the `nearest` sample boxes).
    pub normal: Vec3,
}

/// The result of tracing one ray: the hit, if any, and work counters.
///
/// ```
/// use relief_core::ray::{Ray, RayTracer};
/// use relief_core::{Heightfield, Surface};
/// use glam::Vec3;
/// let hf = Heightfield::new(&[0.0f32; 4], 2, 2).unwrap();
/// let tr = RayTracer::new(&hf, Surface::Triangles).trace_cell_dda(&Ray::new(Vec3::splat(5.0), Vec3::Z).unwrap());
/// assert!(tr.hit.is_none()); // looking up, away from the terrain
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Trace {
    /// The first hit, `None` for a miss.
    pub hit: Option<Hit>,
    /// Cells whose heights were read and tested.
    pub cells: u32,
    /// Traversal steps: cells (cell DDA), runs (run DDA), pyramid nodes (max-mip), samples
    /// (march).
    pub steps: u32,
}

/// Traces rays against one terrain and surface. Holds the terrain's height range (for clipping);
/// acceleration data ([`RunAccel`], [`MaxMip`]) is passed per call. Single-threaded and `Sync`:
/// share one tracer between threads for parallel rendering.
///
/// ```
/// use relief_core::ray::{Ray, RayTracer};
/// use relief_core::{Heightfield, Surface};
/// use glam::Vec3;
/// let samples = [0.0f32, 0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 0.0, 0.0];
/// let hf = Heightfield::new(&samples, 3, 3).unwrap();
/// let tracer = RayTracer::new(&hf, Surface::Triangles);
/// assert_eq!(tracer.height_range(), (0.0, 4.0));
/// let ray = Ray::new(Vec3::new(-1.0, 1.0, 2.0), Vec3::X).unwrap();
/// let hit = tracer.trace_cell_dda(&ray).hit.unwrap();
/// assert!((hit.t - 1.5).abs() < 1e-12); // half way up the slope towards the peak
/// ```
#[derive(Debug, Clone, Copy)]
pub struct RayTracer<'t, T: Terrain> {
    terrain: &'t T,
    surface: Surface,
    zmin: f64,
    zmax: f64,
    cells: Cells,
    spacing: DVec2,
    z_offset: f64,
    /// Descent per cell (local height units) up to which a max-mip walk climbs after a skip:
    /// `maxmip::CLIMB_RELIEF` times the height range over the longer side's cells.
    climb_slope: f64,
}

impl<'t, T: Terrain> RayTracer<'t, T> {
    /// A tracer for `terrain` and `surface`; scans every sample once for the height range.
    ///
    /// ```
    /// use relief_core::{ray::RayTracer, Heightfield, Surface};
    /// let hf = Heightfield::new(&[3u16, 1, 4, 1], 2, 2).unwrap();
    /// assert_eq!(RayTracer::new(&hf, Surface::Nearest).height_range(), (1.0, 4.0));
    /// ```
    pub fn new(terrain: &'t T, surface: Surface) -> Self {
        let (w, h) = (terrain.width(), terrain.height());
        let mut lo = f32::INFINITY;
        let mut hi = f32::NEG_INFINITY;
        for y in 0..h {
            for x in 0..w {
                let z = terrain.local_z(x, y);
                lo = lo.min(z);
                hi = hi.max(z);
            }
        }
        Self::build(terrain, surface, lo as f64, hi as f64)
    }

    /// A tracer with a known local height range `[lo, hi]` (e.g. from a [`MaxMip`]), skipping the
    /// scan. The range must contain every local height (`h * z_scale`); an error
    /// ([`Error::InvalidParameter`]) for NaN or `lo > hi`.
    ///
    /// ```
    /// use relief_core::{ray::RayTracer, Heightfield, Surface};
    /// let hf = Heightfield::new(&[0u16; 4], 2, 2).unwrap();
    /// assert!(RayTracer::with_height_range(&hf, Surface::Triangles, 0.0, 1.0).is_ok());
    /// assert!(RayTracer::with_height_range(&hf, Surface::Triangles, 1.0, 0.0).is_err());
    /// ```
    pub fn with_height_range(
        terrain: &'t T,
        surface: Surface,
        lo: f32,
        hi: f32,
    ) -> Result<Self, Error> {
        if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
            return Err(Error::InvalidParameter {
                name: "height range",
                value: if lo.is_finite() { hi } else { lo },
            });
        }
        Ok(Self::build(terrain, surface, lo as f64, hi as f64))
    }

    fn build(terrain: &'t T, surface: Surface, lo: f64, hi: f64) -> Self {
        let s = terrain.scale();
        let cells = Cells {
            x: terrain.width().saturating_sub(1).max(1),
            y: terrain.height().saturating_sub(1).max(1),
        };
        RayTracer {
            terrain,
            surface,
            zmin: lo,
            zmax: hi,
            cells,
            spacing: DVec2::new(s.dx as f64, s.dy as f64),
            z_offset: s.z_offset as f64,
            climb_slope: maxmip::CLIMB_RELIEF * (hi - lo) / f64::from(cells.x.max(cells.y)),
        }
    }

    /// Local height range `(min, max)` used for clipping.
    ///
    /// ```
    /// use relief_core::{ray::RayTracer, Heightfield, Scale, Surface};
    /// let hf = Heightfield::with_scale(&[0u16, 10, 0, 0], 2, 2, Scale::default().with_z_scale(0.5)).unwrap();
    /// assert_eq!(RayTracer::new(&hf, Surface::Triangles).height_range(), (0.0, 5.0));
    /// ```
    #[must_use]
    pub fn height_range(&self) -> (f32, f32) {
        (self.zmin as f32, self.zmax as f32)
    }

    /// The surface traced.
    ///
    /// ```
    /// use relief_core::{ray::RayTracer, Heightfield, Surface};
    /// let hf = Heightfield::new(&[0u16; 4], 2, 2).unwrap();
    /// assert_eq!(RayTracer::new(&hf, Surface::Plane).surface(), Surface::Plane);
    /// ```
    #[must_use]
    pub fn surface(&self) -> Surface {
        self.surface
    }

    /// Upper bound on the cells a DDA visits for any ray: `(width - 1) + (height - 1) + 2`.
    ///
    /// ```
    /// use relief_core::{ray::RayTracer, Heightfield, Surface};
    /// let hf = Heightfield::new(&[0u16; 12], 4, 3).unwrap();
    /// assert_eq!(RayTracer::new(&hf, Surface::Triangles).step_bound(), 7);
    /// ```
    #[must_use]
    pub fn step_bound(&self) -> u64 {
        self.cells.x as u64 + self.cells.y as u64 + 2
    }

    /// The heights `(lo, hi)` a ray is clipped to: the height range widened by a margin (a flat
    /// sea at the lowest height must not clip to a point and be lost).
    #[inline]
    pub(crate) fn clip_heights(&self) -> (f64, f64) {
        let margin = 1e-6 * self.zmin.abs().max(self.zmax.abs()) + 1e-9;
        (self.zmin - margin, self.zmax + margin)
    }

    /// The ray in local coordinates, clipped to the domain prism and the height range; `None`
    /// when it cannot hit. `ray/simd.rs` (`starts8`) clips eight rays at once with the same
    /// operations in the same order (`max_f` / `min_f` are the `maxpd` / `minpd` rules): keep
    /// the two in step.
    pub(crate) fn local(&self, ray: &Ray) -> Option<LocalRay> {
        let o = DVec3::new(
            ray.origin.x / self.spacing.x,
            ray.origin.y / self.spacing.y,
            ray.origin.z - self.z_offset,
        );
        let mut d = DVec3::new(
            ray.dir.x / self.spacing.x,
            ray.dir.y / self.spacing.y,
            ray.dir.z,
        );
        // The side clips multiply by the reciprocals that the walks' slabs use (two divisions
        // fewer a ray than dividing, the same depth images on the views of
        // bench-peers/maxmip_ab.py); the conversion to grid units above divides (a rounded
        // reciprocal of the spacing moves exact grid coordinates).
        let inv = [1.0 / d.x, 1.0 / d.y];
        // A horizontal component whose reciprocal overflows (subnormal in grid units) moves
        // the ray by less than the smallest normal number over any length a finite `t` can
        // reach in the domain: it folds to an exact zero, as a minor component that vanishes
        // in the DDAs' fixed point does. Kept, it made `0 * inf = NaN` slab parameters for a
        // ray starting on a grid line, and the exact methods disagreed (`HARD_CASES.md`).
        if !inv[0].is_finite() {
            d.x = 0.0;
        }
        if !inv[1].is_finite() {
            d.y = 0.0;
        }
        let mut t0 = 0.0f64;
        let mut t1 = f64::INFINITY;
        let ext = self.cells.as_dvec2();
        for (oc, dc, hi, ic) in [(o.x, d.x, ext.x, inv[0]), (o.y, d.y, ext.y, inv[1])] {
            if dc == 0.0 {
                if !(oc >= 0.0 && oc <= hi) {
                    return None;
                }
            } else {
                let a = (0.0 - oc) * ic;
                let b = (hi - oc) * ic;
                t0 = max_f(t0, min_f(a, b));
                t1 = min_f(t1, max_f(a, b));
            }
        }
        if t0.is_nan() || t1.is_nan() || t0 > t1 {
            return None;
        }
        let (zlo, zhi) = self.clip_heights();
        if d.z == 0.0 {
            if o.z > zhi {
                return None;
            }
        } else if d.z < 0.0 {
            t0 = max_f(t0, (zhi - o.z) / d.z);
            if t0 > t1 {
                return None;
            }
            // Below every height from here on: the hit is at or before this point.
            t1 = min_f(t1, max_f(t0, (zlo - o.z) / d.z));
        } else {
            t1 = min_f(t1, (zhi - o.z) / d.z);
            if t0 > t1 {
                return None;
            }
        }
        if !(t0.is_finite() && t1.is_finite() && t0 <= t1) {
            return None;
        }
        Some(LocalRay { o, d, inv, t0, t1 })
    }

    /// The hit at the clipped start `t0` when the ray is already at or below the surface there:
    /// it starts below the terrain, or enters the domain's prism through a side below it. Tested
    /// on its own so that a degenerate interval (a ray that enters below the lowest height, where
    /// the clipped interval shrinks to the point `t0`) is not lost to rounding of the per-cell
    /// intervals. Rays starting above the highest sample skip the test, and so do starts above
    /// their cell's highest corner (no surface of the cell reaches them).
    #[inline]
    pub(crate) fn start_hit(&self, ray: &Ray, lr: &LocalRay) -> Option<Hit> {
        let z0 = lr.z(lr.t0);
        if z0 > self.zmax {
            return None;
        }
        let fx = lr.o.x + lr.t0 * lr.d.x;
        let fy = lr.o.y + lr.t0 * lr.d.y;
        let cx = (libm::floor(fx).max(0.0) as u32).min(self.cells.x - 1);
        let cy = (libm::floor(fy).max(0.0) as u32).min(self.cells.y - 1);
        // The one-point interval through the cell test every walk's cells take: its
        // bounding-box reject skips the exact test for a start above the cell's highest
        // corner, where no surface of the cell reaches.
        let h = self.test_cell(lr, cx, cy, lr.t0, lr.t0)?;
        Some(self.make_hit(ray, cx, cy, h))
    }

    /// The fixed-point digital line of a clipped local ray.
    pub(crate) fn line(&self, lr: &LocalRay) -> Option<GridLine> {
        let dxy = DVec2::new(lr.d.x, lr.d.y);
        let o = DVec2::new(lr.o.x, lr.o.y);
        // One cell of slack past the end: the end point comes from the real ray, which may pass
        // a corner on the other side of the digital line. Cells past the end have an empty
        // parameter interval and are skipped.
        let major = dxy.x.abs().max(dxy.y.abs());
        let slack = if major > 0.0 {
            dxy / major
        } else {
            DVec2::ZERO
        };
        GridLine::new(
            o + lr.t0 * dxy,
            dxy,
            o + lr.t1 * dxy + slack,
            [self.cells.x, self.cells.y],
        )
        .ok()
    }

    #[inline]
    pub(crate) fn corners(&self, cx: u32, cy: u32) -> [f64; 4] {
        let c = self.terrain.cell_corners(cx, cy);
        [c[0] as f64, c[1] as f64, c[2] as f64, c[3] as f64]
    }

    /// Clipped parameter interval of cell `(cx, cy)`, `None` if empty.
    #[inline]
    pub(crate) fn cell_interval(&self, lr: &LocalRay, cx: u32, cy: u32) -> Option<(f64, f64)> {
        let (a, b) = lr.cell_span(cx, cy);
        let (a, b) = (a.max(lr.t0), b.min(lr.t1));
        (a <= b).then_some((a, b))
    }

    /// Tests one cell over `[ta, tb]`: bounding-box reject, then the exact surface.
    #[inline]
    pub(crate) fn test_cell(
        &self,
        lr: &LocalRay,
        cx: u32,
        cy: u32,
        ta: f64,
        tb: f64,
    ) -> Option<CellHit> {
        let h = self.corners(cx, cy);
        let hmax = h[0].max(h[1]).max(h[2]).max(h[3]);
        if lr.z(ta).min(lr.z(tb)) > hmax {
            return None;
        }
        cell::intersect(self.surface, lr, cx, cy, &h, ta, tb)
    }

    /// The hit of `ray` in cell `(cx, cy)`: world position, and the unit world normal of the
    /// cell hit's grid-unit normal (`ray/simd.rs` computes the same normal in lanes).
    pub(crate) fn make_hit(&self, ray: &Ray, cx: u32, cy: u32, h: CellHit) -> Hit {
        let n = DVec3::new(h.n.x / self.spacing.x, h.n.y / self.spacing.y, h.n.z);
        let n = n.try_normalize().unwrap_or(DVec3::Z).as_vec3();
        Hit {
            t: h.t,
            cell: [cx, cy],
            position: ray.at(h.t),
            normal: n,
        }
    }

    /// Traces `ray` with the cell DDA, testing every cell's bounding box (the four corner
    /// heights) and then the exact surface. The baseline every other method must equal.
    ///
    /// ```
    /// use relief_core::ray::{Ray, RayTracer};
    /// use relief_core::{Heightfield, Surface};
    /// use glam::Vec3;
    /// let hf = Heightfield::new(&[0.0f32; 9], 3, 3).unwrap();
    /// let t = RayTracer::new(&hf, Surface::Triangles);
    /// let r = t.trace_cell_dda(&Ray::new(Vec3::new(0.0, 0.5, 1.0), Vec3::new(1.0, 0.0, -0.5)).unwrap());
    /// assert_eq!(r.hit.unwrap().t, 2.0);
    /// assert_eq!(r.hit.unwrap().cell, [1, 0]);
    /// ```
    #[must_use]
    pub fn trace_cell_dda(&self, ray: &Ray) -> Trace {
        let mut out = Trace::default();
        let Some(lr) = self.local(ray) else {
            return out;
        };
        if let Some(hit) = self.start_hit(ray, &lr) {
            out.cells = 1;
            out.hit = Some(hit);
            return out;
        }
        let Some(line) = self.line(&lr) else {
            return out;
        };
        for [cx, cy] in line.cells() {
            out.steps += 1;
            let Some((ta, tb)) = self.cell_interval(&lr, cx, cy) else {
                continue;
            };
            out.cells += 1;
            if let Some(h) = self.test_cell(&lr, cx, cy, ta, tb) {
                out.hit = Some(self.make_hit(ray, cx, cy, h));
                return out;
            }
        }
        out
    }
}
