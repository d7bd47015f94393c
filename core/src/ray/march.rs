//! Linear + binary search ray marching: Kentie, *On-GPU ray traced terrain* (2009),
//! sections 3.3 (fixed sample count along the clipped ray, first sample at or below the surface)
//! and 3.4 (view-dependent sample count, `lerp(min, max, 1 - |dir.z|)`, and binary refinement
//! between the last sample above and the first below).
//!
//! It is approximate and says how wrong it can be: [`MarchTrace`] reports the sample spacing
//! (a feature narrower than it, horizontally, can be stepped over entirely) and the width of the
//! final bracket (the error of `t` when the bracket holds the first crossing).

use super::{cell, Hit, Ray, RayTracer, Trace};
use crate::{Error, Terrain};
use glam::DVec3;

/// Options of [`RayTracer::trace_march`].
///
/// Defaults: 256 samples, fixed (not view-dependent), minimum 32 for view-dependent counts,
/// 8 binary refinement steps.
///
/// ```
/// use relief_core::ray::MarchOptions;
/// let o = MarchOptions::default().with_samples(512).with_view_dependent(64).with_refine(10);
/// assert_eq!((o.samples, o.min_samples, o.view_dependent, o.refine), (512, 64, true, 10));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MarchOptions {
    /// Samples along the clipped ray (the maximum when view-dependent); at least 1.
    pub samples: u32,
    /// Fewest samples for view-dependent counts (steep rays).
    pub min_samples: u32,
    /// Choose the count per ray as `lerp(min_samples, samples, 1 - |dir.z|)`.
    pub view_dependent: bool,
    /// Binary search steps after the linear search (at most 64).
    pub refine: u32,
}

impl Default for MarchOptions {
    fn default() -> Self {
        MarchOptions {
            samples: 256,
            min_samples: 32,
            view_dependent: false,
            refine: 8,
        }
    }
}

impl MarchOptions {
    /// Sets the (maximum) sample count (default 256).
    ///
    /// ```
    /// assert_eq!(relief_core::ray::MarchOptions::default().with_samples(9).samples, 9);
    /// ```
    #[must_use]
    pub fn with_samples(mut self, samples: u32) -> Self {
        self.samples = samples;
        self
    }

    /// Makes the count view-dependent with at least `min_samples` (default: fixed, 32).
    ///
    /// ```
    /// assert!(relief_core::ray::MarchOptions::default().with_view_dependent(8).view_dependent);
    /// ```
    #[must_use]
    pub fn with_view_dependent(mut self, min_samples: u32) -> Self {
        self.view_dependent = true;
        self.min_samples = min_samples;
        self
    }

    /// Sets the binary refinement steps (default 8).
    ///
    /// ```
    /// assert_eq!(relief_core::ray::MarchOptions::default().with_refine(0).refine, 0);
    /// ```
    #[must_use]
    pub fn with_refine(mut self, refine: u32) -> Self {
        self.refine = refine;
        self
    }
}

/// A marched ray: the hit and counters, plus how wrong it can be.
///
/// ```
/// use relief_core::ray::{MarchOptions, Ray, RayTracer};
/// use relief_core::{Heightfield, Surface};
/// use glam::Vec3;
/// let hf = Heightfield::new(&[0.0f32; 16], 4, 4).unwrap();
/// let t = RayTracer::new(&hf, Surface::Triangles);
/// let ray = Ray::new(Vec3::new(0.0, 0.5, 1.0), Vec3::new(1.0, 0.0, -0.5)).unwrap();
/// let m = t.trace_march(&ray, &MarchOptions::default()).unwrap();
/// assert!((m.trace.hit.unwrap().t - 2.0).abs() <= m.bracket);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MarchTrace {
    /// Hit and counters (`steps` = samples taken including refinement).
    pub trace: Trace,
    /// Samples used for this ray.
    pub samples: u32,
    /// Ray parameter between samples.
    pub step: f64,
    /// Horizontal sample spacing in cells: features narrower than this may be missed.
    pub step_cells: f64,
    /// Width in `t` of the final bracket around the reported hit (0 for a hit at the start):
    /// the reported `t` is at most this much after the crossing the march found.
    pub bracket: f64,
}

impl<T: Terrain> RayTracer<'_, T> {
    fn below(&self, lr: &cell::LocalRay, t: f64) -> bool {
        let ext = self.cells.as_dvec2();
        let gx = (lr.o.x + t * lr.d.x).max(0.0).min(ext.x);
        let gy = (lr.o.y + t * lr.d.y).max(0.0).min(ext.y);
        let cx = (libm::floor(gx) as u32).min(self.cells.x - 1);
        let cy = (libm::floor(gy) as u32).min(self.cells.y - 1);
        let h = self.corners(cx, cy);
        let s = cell::surface_at(self.surface, &h, gx - cx as f64, gy - cy as f64);
        lr.z(t) <= s
    }

    /// Marches `ray` with a linear search over the clipped ray and a binary refinement
    /// (approximate). [`Error::InvalidParameter`] for zero samples or more than 64 refinement
    /// steps.
    ///
    /// ```
    /// use relief_core::ray::{MarchOptions, Ray, RayTracer};
    /// use relief_core::{Heightfield, Surface};
    /// use glam::Vec3;
    /// let hf = Heightfield::new(&[0.0f32; 4], 2, 2).unwrap();
    /// let t = RayTracer::new(&hf, Surface::Bilinear);
    /// assert!(t.trace_march(&Ray::new(Vec3::ONE, -Vec3::Z).unwrap(), &MarchOptions::default().with_samples(0)).is_err());
    /// ```
    pub fn trace_march(&self, ray: &Ray, opts: &MarchOptions) -> Result<MarchTrace, Error> {
        if opts.samples == 0 {
            return Err(Error::InvalidParameter {
                name: "samples",
                value: 0.0,
            });
        }
        if opts.refine > 64 {
            return Err(Error::InvalidParameter {
                name: "refine",
                value: opts.refine as f32,
            });
        }
        let mut out = MarchTrace::default();
        let Some(lr) = self.local(ray) else {
            return Ok(out);
        };
        let n = if opts.view_dependent {
            let dz = ray.dir.normalize_or_zero().z.abs();
            let lo = opts.min_samples.min(opts.samples) as f64;
            let hi = opts.samples as f64;
            libm::round(lo + (hi - lo) * (1.0 - dz)).max(1.0).min(hi) as u32
        } else {
            opts.samples
        };
        let step = (lr.t1 - lr.t0) / n as f64;
        out.samples = n;
        out.step = step;
        out.step_cells = step * libm::sqrt(lr.d.x * lr.d.x + lr.d.y * lr.d.y);
        let mut prev = lr.t0;
        let mut found = None;
        for i in 0..=n {
            let t = if i == n {
                lr.t1
            } else {
                lr.t0 + step * i as f64
            };
            out.trace.steps += 1;
            if self.below(&lr, t) {
                found = Some((prev, t));
                break;
            }
            prev = t;
        }
        let Some((mut lo, mut hi)) = found else {
            return Ok(out);
        };
        if hi > lo {
            for _ in 0..opts.refine {
                out.trace.steps += 1;
                let mid = 0.5 * (lo + hi);
                if self.below(&lr, mid) {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
        }
        out.bracket = hi - lo;
        let ext = self.cells.as_dvec2();
        let gx = (lr.o.x + hi * lr.d.x).max(0.0).min(ext.x);
        let gy = (lr.o.y + hi * lr.d.y).max(0.0).min(ext.y);
        let cx = (libm::floor(gx) as u32).min(self.cells.x - 1);
        let cy = (libm::floor(gy) as u32).min(self.cells.y - 1);
        let [h00, h10, h01, h11] = self.corners(cx, cy);
        let (fx, fy) = (gx - cx as f64, gy - cy as f64);
        let n = DVec3::new(
            -(h10 - h00 + (h00 - h10 - h01 + h11) * fy),
            -(h01 - h00 + (h00 - h10 - h01 + h11) * fx),
            1.0,
        );
        out.trace.cells = out.trace.steps;
        let hit: Hit = self.make_hit(ray, cx, cy, cell::CellHit { t: hi, n });
        out.trace.hit = Some(hit);
        Ok(out)
    }
}
