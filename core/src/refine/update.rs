//! Live edits of preprocessed refinement data (issue 6, part 3; the data are those of seed 004,
//! chapter 4.5 and Lindstrom & Pascucci 2002's nested L-infinity errors and bounding spheres).
//!
//! After the caller changes the samples in a rectangle ([`Region`]), [`update`] (full layout) or
//! [`update_compact`] recomputes exactly the vertices whose stored values can change, bottom-up:
//! at half-size `h`, the edge vertices within `2h - 1` samples and the centres within `3h - 1`
//! samples of the region (a vertex depends on the samples of its diamond, at most `h` away, and
//! on its children, whose own distances give that recursion). Every recomputed vertex runs the
//! very code of the full preprocessing on identical inputs, so the result is **bit-identical** to
//! [`preprocess_pyramid`] (and [`super::preprocess`]) of the edited map.
//!
//! **Cost.** Per level, `(w_r / 2h + 4) (h_r / 2h + 4)` vertices for a `w_r x h_r` region, so
//! `O(region + levels)` vertices in all. Each vertex's error is the maximum of `|h - plane|` over
//! its diamond, found by branch and bound on the caller's min/max block pyramid of the heights
//! (module `pyramid`): blocks whose bound cannot beat the children's nested error (the running
//! maximum) are skipped. The ancestors' diamonds are huge (the root's covers the map); when their
//! planes fit the terrain so well that few blocks can be pruned, the **worst case is a visit of
//! every sample of every affected ancestor's diamond**, i.e. `O(levels x map)` like the full
//! preprocessing. On the bundled DEM the measured update of a 1-sample crater takes well under a
//! millisecond (see BENCHMARKS.md, "Terrain at scale: edits and tiles").
//!
//! The same pruning speeds up the full preprocessing ([`preprocess_pyramid`]).

use super::preprocess::{self, pass_range, passes, Pruning};
use super::pyramid::{fill, Layout};
use super::{ErrorStore, Hierarchy, PreprocessOptions};
use crate::{Error, Terrain};

pub use super::pyramid::pyramid_len;

/// An inclusive rectangle of changed samples `[x0, x1] x [y0, y1]`.
///
/// ```
/// use relief_core::refine::Region;
/// let r = Region::new(3, 4, 10, 4).unwrap();
/// assert_eq!((r.x0, r.y0, r.x1, r.y1), (3, 4, 10, 4));
/// assert!(Region::new(5, 0, 4, 0).is_err());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Region {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// Last column (inclusive).
    pub x1: u32,
    /// Last row (inclusive).
    pub y1: u32,
}

impl Region {
    /// The rectangle `[x0, x1] x [y0, y1]`; [`Error::InvalidParameter`] when `x0 > x1` or
    /// `y0 > y1`.
    ///
    /// ```
    /// assert!(relief_core::refine::Region::new(0, 0, 0, 0).is_ok());
    /// ```
    pub fn new(x0: u32, y0: u32, x1: u32, y1: u32) -> Result<Region, Error> {
        if x0 > x1 {
            return Err(Error::InvalidParameter {
                name: "x1",
                value: x1 as f32,
            });
        }
        if y0 > y1 {
            return Err(Error::InvalidParameter {
                name: "y1",
                value: y1 as f32,
            });
        }
        Ok(Region { x0, y0, x1, y1 })
    }

    /// The smallest region holding both.
    ///
    /// ```
    /// use relief_core::refine::Region;
    /// let u = Region::new(0, 0, 1, 1).unwrap().union(Region::new(5, 2, 6, 3).unwrap());
    /// assert_eq!(u, Region::new(0, 0, 6, 3).unwrap());
    /// ```
    #[must_use]
    pub fn union(self, o: Region) -> Region {
        Region {
            x0: self.x0.min(o.x0),
            y0: self.y0.min(o.y0),
            x1: self.x1.max(o.x1),
            y1: self.y1.max(o.y1),
        }
    }
}

/// Lowers every sample of `samples` (`width x height`, row-major) at distance `r < radius` from
/// `(x, y)` by `depth * (1 - (r / radius)^2)` (the crater of issue 6; coordinates and radius in
/// samples, depth in sample units) and returns the region of samples it visited, `None` when no
/// sample is within the radius. Errors: [`Error::LengthMismatch`], [`Error::InvalidParameter`]
/// for a non-finite `x`, `y`, `depth` or a radius that is not positive and finite.
///
/// ```
/// use relief_core::refine::{crater, Region};
/// let mut s = vec![10.0f32; 25];
/// let r = crater(&mut s, 5, 5, 2.0, 2.0, 1.5, 4.0).unwrap().unwrap();
/// assert_eq!(s[12], 6.0); // the centre: lowered by the full depth
/// assert_eq!(s[7], 10.0 - 4.0 * (1.0 - 1.0 / 2.25)); // r = 1
/// assert_eq!(r, Region::new(1, 1, 3, 3).unwrap());
/// ```
pub fn crater(
    samples: &mut [f32],
    width: u32,
    height: u32,
    x: f32,
    y: f32,
    radius: f32,
    depth: f32,
) -> Result<Option<Region>, Error> {
    let n = (width as usize).saturating_mul(height as usize);
    if samples.len() != n {
        return Err(Error::LengthMismatch {
            expected: n,
            actual: samples.len(),
        });
    }
    for (name, v) in [("x", x), ("y", y), ("depth", depth)] {
        if !v.is_finite() {
            return Err(Error::InvalidParameter { name, value: v });
        }
    }
    if !(radius.is_finite() && radius > 0.0) {
        return Err(Error::InvalidParameter {
            name: "radius",
            value: radius,
        });
    }
    if width == 0 || height == 0 {
        return Ok(None);
    }
    let clamp = |v: f32, hi: u32| -> u32 { (v.max(0.0) as u32).min(hi) };
    let (xa, xb) = (
        clamp(libm::floorf(x - radius), width - 1),
        clamp(libm::ceilf(x + radius), width - 1),
    );
    let (ya, yb) = (
        clamp(libm::floorf(y - radius), height - 1),
        clamp(libm::ceilf(y + radius), height - 1),
    );
    let mut region: Option<Region> = None;
    for sy in ya..=yb {
        for sx in xa..=xb {
            let (dx, dy) = (sx as f32 - x, sy as f32 - y);
            let r = libm::sqrtf(dx * dx + dy * dy);
            if r < radius {
                let q = r / radius;
                if let Some(s) = samples.get_mut(sy as usize * width as usize + sx as usize) {
                    *s -= depth * (1.0 - q * q);
                }
                let here = Region {
                    x0: sx,
                    y0: sy,
                    x1: sx,
                    y1: sy,
                };
                region = Some(region.map_or(here, |g| g.union(here)));
            }
        }
    }
    Ok(region)
}

fn check_pyramid<T: Terrain>(t: &T, pyramid: &[f32]) -> Result<Layout, Error> {
    let need = pyramid_len(t.width(), t.height());
    if pyramid.len() < need {
        return Err(Error::BufferTooSmall {
            needed: need,
            actual: pyramid.len(),
        });
    }
    Ok(Layout::new(t.width(), t.height()))
}

/// [`super::preprocess_with`] with a min/max block `pyramid` (at least [`pyramid_len`] floats,
/// filled here) that prunes the error search of large triangles. Same errors and radii, bit for
/// bit. The pyramid is what [`update`] needs; for a one-off preprocessing the plain
/// functions need no pyramid and take about as long (BENCHMARKS.md, Refinement: the pyramid
/// 1.1-1.2x faster on a 1025^2 grid, 1.05-1.1x slower on 513^2 ones).
///
/// ```
/// use relief_core::refine::{hierarchy_len, preprocess, preprocess_pyramid, pyramid_len};
/// use relief_core::refine::PreprocessOptions;
/// use relief_core::Heightfield;
/// let s: Vec<f32> = (0..17 * 17).map(|i| ((i * 7919) % 31) as f32).collect();
/// let hf = Heightfield::new(&s, 17, 17).unwrap();
/// let n = hierarchy_len(17, 17);
/// let (mut e1, mut r1, mut e2, mut r2) = (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
/// let mut pyr = vec![0.0; pyramid_len(17, 17)];
/// preprocess(&hf, &mut e1, &mut r1).unwrap();
/// preprocess_pyramid(&hf, &mut e2, &mut r2, &mut pyr, PreprocessOptions::default()).unwrap();
/// assert_eq!(e1, e2);
/// assert_eq!(r1, r2);
/// ```
pub fn preprocess_pyramid<'a, T: Terrain>(
    terrain: &T,
    errors: &'a mut [f32],
    radii: &'a mut [f32],
    pyramid: &mut [f32],
    options: PreprocessOptions,
) -> Result<Hierarchy<'a>, Error> {
    let g = preprocess::check(terrain, errors.len())?;
    preprocess::check(terrain, radii.len())?;
    let l = check_pyramid(terrain, pyramid)?;
    fill(terrain, &l, pyramid, 0, 0, u32::MAX, u32::MAX);
    let pr = Pruning {
        layout: &l,
        buf: pyramid,
    };
    preprocess::build(
        terrain,
        &g,
        &mut *errors,
        Some(&mut *radii),
        options.contain_diamond,
        Some(pr),
    );
    let (lo, hi) = l.range(pyramid);
    Ok(Hierarchy::assemble(
        g,
        terrain.scale(),
        ErrorStore::F32(errors),
        Some(radii),
        lo,
        hi,
    ))
}

/// [`super::preprocess_compact`] with a min/max block `pyramid` (see [`preprocess_pyramid`]).
///
/// ```
/// use relief_core::refine::{preprocess_compact, preprocess_compact_pyramid, pyramid_len};
/// use relief_core::Heightfield;
/// let s: Vec<f32> = (0..9 * 6).map(|i| ((i * 31) % 17) as f32).collect();
/// let hf = Heightfield::new(&s, 9, 6).unwrap();
/// let (mut a, mut b) = (vec![0u16; 54], vec![0u16; 54]);
/// let mut pyr = vec![0.0; pyramid_len(9, 6)];
/// preprocess_compact(&hf, &mut a).unwrap();
/// preprocess_compact_pyramid(&hf, &mut b, &mut pyr).unwrap();
/// assert_eq!(a, b);
/// ```
pub fn preprocess_compact_pyramid<'a, T: Terrain>(
    terrain: &T,
    errors: &'a mut [u16],
    pyramid: &mut [f32],
) -> Result<Hierarchy<'a>, Error> {
    let g = preprocess::check(terrain, errors.len())?;
    let l = check_pyramid(terrain, pyramid)?;
    fill(terrain, &l, pyramid, 0, 0, u32::MAX, u32::MAX);
    let pr = Pruning {
        layout: &l,
        buf: pyramid,
    };
    preprocess::build(terrain, &g, &mut *errors, None, true, Some(pr));
    let (lo, hi) = l.range(pyramid);
    Ok(Hierarchy::assemble(
        g,
        terrain.scale(),
        ErrorStore::Bf16(errors),
        None,
        lo,
        hi,
    ))
}

fn update_impl<T: Terrain, E: preprocess::ErrorSink + ?Sized>(
    terrain: &T,
    errors: &mut E,
    mut radii: Option<&mut [f32]>,
    pyramid: &mut [f32],
    region: Region,
    contain_corners: bool,
) -> Result<(super::RefineGrid, (f32, f32)), Error> {
    let g = super::RefineGrid::new(terrain.width(), terrain.height())?;
    let l = check_pyramid(terrain, pyramid)?;
    if region.x0 >= g.width() || region.y0 >= g.height() || region.x0 > region.x1 {
        return Err(Error::OutOfBounds {
            x: region.x0,
            y: region.y0,
        });
    }
    let (x1, y1) = (region.x1.min(g.width() - 1), region.y1.min(g.height() - 1));
    fill(terrain, &l, pyramid, region.x0, region.y0, x1, y1);
    let pr = Pruning {
        layout: &l,
        buf: pyramid,
    };
    let (rx0, ry0, rx1, ry1) = (region.x0 as i64, region.y0 as i64, x1 as i64, y1 as i64);
    let n = g.side() as i64;
    let mut h = 1i64;
    while h < n {
        for (x0, y0, d) in passes(h) {
            pass_range(
                terrain,
                &g,
                h,
                (x0, y0),
                (rx0 - d, rx1 + d, ry0 - d, ry1 + d),
                errors,
                radii.as_deref_mut(),
                contain_corners,
                Some(pr),
            );
        }
        h *= 2;
    }
    preprocess::corners(&g, errors, radii);
    Ok((g, l.range(pyramid)))
}

/// Updates full-layout data after the samples in `region` changed: `errors`, `radii` and
/// `pyramid` must hold [`preprocess_pyramid`]'s output for the map as it was (same size, same
/// `options`); `terrain` is the edited map. Afterwards they are bit-identical to
/// [`preprocess_pyramid`] of the edited map. Several edits may be applied one after the other,
/// or at once with the union of their regions. Cost: see the module documentation.
///
/// Errors: size mismatches as [`preprocess_pyramid`]; [`Error::OutOfBounds`] when the region
/// starts outside the grid (its end is clipped to the grid).
///
/// ```
/// use relief_core::refine::{crater, hierarchy_len, preprocess_pyramid, pyramid_len, update};
/// use relief_core::refine::PreprocessOptions;
/// use relief_core::Heightfield;
/// let (w, h) = (33u32, 20u32);
/// let mut s: Vec<f32> = (0..w * h).map(|i| ((i * 7919) % 97) as f32 * 0.1).collect();
/// let n = hierarchy_len(w, h);
/// let (mut e, mut r) = (vec![0.0; n], vec![0.0; n]);
/// let mut pyr = vec![0.0; pyramid_len(w, h)];
/// let o = PreprocessOptions::default();
/// preprocess_pyramid(&Heightfield::new(&s, w, h).unwrap(), &mut e, &mut r, &mut pyr, o).unwrap();
/// let region = crater(&mut s, w, h, 10.0, 7.0, 3.0, 5.0).unwrap().unwrap();
/// let edited = Heightfield::new(&s, w, h).unwrap();
/// update(&edited, &mut e, &mut r, &mut pyr, region, o).unwrap();
/// // The same as preprocessing the edited map from scratch:
/// let (mut e2, mut r2, mut p2) = (vec![0.0; n], vec![0.0; n], vec![0.0; pyramid_len(w, h)]);
/// preprocess_pyramid(&edited, &mut e2, &mut r2, &mut p2, o).unwrap();
/// assert_eq!((e, r, pyr), (e2, r2, p2));
/// ```
pub fn update<'a, T: Terrain>(
    terrain: &T,
    errors: &'a mut [f32],
    radii: &'a mut [f32],
    pyramid: &mut [f32],
    region: Region,
    options: PreprocessOptions,
) -> Result<Hierarchy<'a>, Error> {
    preprocess::check(terrain, errors.len())?;
    preprocess::check(terrain, radii.len())?;
    let (g, (lo, hi)) = update_impl(
        terrain,
        &mut *errors,
        Some(&mut *radii),
        pyramid,
        region,
        options.contain_diamond,
    )?;
    Ok(Hierarchy::assemble(
        g,
        terrain.scale(),
        ErrorStore::F32(errors),
        Some(radii),
        lo,
        hi,
    ))
}

/// [`update`] for the compact layout ([`preprocess_compact_pyramid`]'s `errors`).
///
/// ```
/// use relief_core::refine::{crater, preprocess_compact_pyramid, pyramid_len, update_compact};
/// use relief_core::Heightfield;
/// let mut s: Vec<f32> = (0..17 * 17).map(|i| ((i * 37) % 23) as f32).collect();
/// let (mut e, mut p) = (vec![0u16; 289], vec![0.0; pyramid_len(17, 17)]);
/// preprocess_compact_pyramid(&Heightfield::new(&s, 17, 17).unwrap(), &mut e, &mut p).unwrap();
/// let region = crater(&mut s, 17, 17, 3.0, 12.0, 2.0, 9.0).unwrap().unwrap();
/// let edited = Heightfield::new(&s, 17, 17).unwrap();
/// update_compact(&edited, &mut e, &mut p, region).unwrap();
/// let (mut e2, mut p2) = (vec![0u16; 289], vec![0.0; pyramid_len(17, 17)]);
/// preprocess_compact_pyramid(&edited, &mut e2, &mut p2).unwrap();
/// assert_eq!(e, e2);
/// ```
pub fn update_compact<'a, T: Terrain>(
    terrain: &T,
    errors: &'a mut [u16],
    pyramid: &mut [f32],
    region: Region,
) -> Result<Hierarchy<'a>, Error> {
    preprocess::check(terrain, errors.len())?;
    let (g, (lo, hi)) = update_impl(terrain, &mut *errors, None, pyramid, region, true)?;
    Ok(Hierarchy::assemble(
        g,
        terrain.scale(),
        ErrorStore::Bf16(errors),
        None,
        lo,
        hi,
    ))
}
