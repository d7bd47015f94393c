//! Diagrams of Cornel, Horváth, Waser, *Adaptive Heightfield Rendering with Complex Interpolants
//! Using Ray Casting* (2022, seed 002):
//! - [`rbf()`]: the adaptive grid's cells, the dashed truncation circles (`3.5 sigma c_i`) of
//!   chosen cells, and the cells that influence the first chosen cell's centre filled light —
//!   seed 002's figure 2;
//! - [`cascades`]: the exact ground footprint of the camera frustum over the heightfield's
//!   height range ([`frustum_footprint`], from [`relief_core::Camera::frustum_planes`]), the
//!   potentially visible hull split into three cascade polygons at the logarithmic splits, and
//!   each cascade's snapped texture square — seed 002's figure 1a.
//!
//! Everything drawn is the core's state: [`relief_core::rbf::AdaptiveGrid::cells`], the radius
//! of [`relief_core::rbf::RbfOptions::radius`], [`relief_core::rbf::Rbf::influencing`] and
//! [`relief_core::rbf::Rbf::weight`], and the [`relief_core::rbf::Cascades`] of
//! [`relief_core::rbf::fit_cascades`].

use crate::canvas::{Canvas, LABEL};
use crate::style::{
    rgba, viridis, BLACK, BLUE, BLUISH_GREEN, GRID_GREY, ORANGE, REDDISH_PURPLE, SKY_BLUE,
    VERMILLION,
};
use crate::{DiagramError, DiagramOptions};
use glam::{DMat3, DVec2, DVec3};
use relief_core::rbf::{Cascades, Rbf, RbfOptions};
use relief_core::{Camera, Scale};
use tiny_skia::Pixmap;

/// Colours of the chosen cells, in order (then repeating).
const CHOSEN: [[u8; 3]; 4] = [BLUISH_GREEN, VERMILLION, BLUE, REDDISH_PURPLE];

/// The adaptive grid of `rbf` with the influence circles of the `chosen` cells (indices into
/// [`relief_core::rbf::AdaptiveGrid::cells`]; unknown indices are an error). Cells are filled by
/// value (viridis) unless a background is given; the cells with a non-zero weight at the first
/// chosen cell's centre are filled light green, as in seed 002's figure 2.
///
/// ```
/// use relief_core::rbf::*;
/// let cells = [Cell::new(0, 0, 4, 0.0), Cell::new(4, 0, 2, 1.0), Cell::new(6, 0, 2, 1.0),
///              Cell::new(4, 2, 2, 2.0), Cell::new(6, 2, 2, 2.0), Cell::new(0, 4, 4, 0.0),
///              Cell::new(4, 4, 4, 3.0)];
/// let mut index = vec![0; 64];
/// let grid = AdaptiveGrid::new(8, 8, &cells, &mut index).unwrap();
/// let opts = RbfOptions::default();
/// let mut offsets = vec![0; InfluenceSets::offsets_len(&grid)];
/// let mut entries = vec![0; InfluenceSets::entries_len(&grid, &opts).unwrap()];
/// let sets = InfluenceSets::build(&grid, &opts, &mut offsets, &mut entries).unwrap();
/// let rbf = Rbf::new(grid, sets, &opts).unwrap();
/// let a = relief_skia::rbf::rbf(&rbf, &[1], &relief_skia::DiagramOptions::default()).unwrap();
/// let b = relief_skia::rbf::rbf(&rbf, &[6], &relief_skia::DiagramOptions::default()).unwrap();
/// assert_ne!(a, b);
/// assert!(relief_skia::rbf::rbf(&rbf, &[99], &relief_skia::DiagramOptions::default()).is_err());
/// ```
pub fn rbf(
    rbf: &Rbf<'_>,
    chosen: &[usize],
    opts: &DiagramOptions<'_>,
) -> Result<Pixmap, DiagramError> {
    let grid = rbf.grid();
    let cells = grid.cells();
    if chosen.iter().any(|&i| i >= cells.len()) {
        return Err(DiagramError::InvalidParameter {
            name: "cell",
            reason: "index past the adaptive grid's cells",
        });
    }
    let (w, h) = (grid.width() as f32, grid.height() as f32);
    let (lo, hi) = ([-0.5, -0.5], [w - 0.5, h - 0.5]);
    let (smin, smax) = grid.size_range();
    let names: Vec<String> = chosen
        .iter()
        .map(|&i| {
            let k = cells.get(i).copied().unwrap_or_default();
            format!("cell {i} ({}, {}) size {}", k.x, k.y, k.size)
        })
        .collect();
    let row: Vec<(tiny_skia::Color, &str)> = chosen
        .iter()
        .enumerate()
        .map(|(n, _)| (rgba(CHOSEN[n % CHOSEN.len()], 0.85), names[n].as_str()))
        .collect();
    let row2 = [
        (
            rgba(BLUISH_GREEN, 0.3),
            "influences the first cell's centre",
        ),
        (
            rgba(GRID_GREY, 1.0),
            "cell; dashed circle: truncation radius 3.5 sigma c",
        ),
    ];
    let mut c = Canvas::new(
        lo,
        hi,
        false,
        &format!(
            "adaptive grid: {} cells, sizes {}..{}, sigma {}",
            cells.len(),
            smin,
            smax,
            rbf.sigma()
        ),
        &[&row[..], &row2[..]],
        opts,
    )?;
    let ropts = RbfOptions::default().with_sigma(rbf.sigma());
    let (vmin, vmax) = cells
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), k| {
            (a.min(k.value), b.max(k.value))
        });
    if let Some(bg) = opts.background {
        c.background(bg, lo, hi);
    } else {
        for k in cells {
            let t = if vmax > vmin {
                (k.value - vmin) / (vmax - vmin)
            } else {
                0.5
            };
            let (a, b) = area(k);
            c.fill_rect(a, b, rgba(viridis(t), 0.45));
        }
    }
    // Cells influencing the first chosen cell's centre.
    if let Some(&first) = chosen.first() {
        if let Some(k) = cells.get(first) {
            let p = k.center();
            for &i in rbf.influencing(p) {
                if rbf.weight(i as usize, p) > 0.0 {
                    if let Some(ci) = cells.get(i as usize) {
                        let (a, b) = area(ci);
                        c.fill_rect(a, b, rgba(BLUISH_GREEN, 0.3));
                    }
                }
            }
        }
    }
    let line = if c.scale() >= 4.0 { 1.0 } else { 0.5 };
    for k in cells {
        let (a, b) = area(k);
        c.stroke_rect(a, b, rgba(GRID_GREY, 1.0), line, false);
    }
    for (n, &i) in chosen.iter().enumerate() {
        let Some(k) = cells.get(i) else { continue };
        let col = CHOSEN[n % CHOSEN.len()];
        let (a, b) = area(k);
        c.fill_rect(a, b, rgba(col, 0.85));
        c.stroke_rect(a, b, rgba(col, 1.0), 2.5, false);
        let ctr = k.center();
        c.circle(
            [ctr.x, ctr.y],
            ropts.radius(k.size),
            None,
            Some((rgba(col, 1.0), 2.0, true)),
        );
        c.dot([ctr.x, ctr.y], 2.5, rgba(BLACK, 1.0));
    }
    c.stroke_rect(lo, hi, rgba(BLACK, 0.8), 1.0, false);
    Ok(c.finish())
}

/// The closed area a cell covers in sample coordinates.
fn area(k: &relief_core::rbf::Cell) -> ([f32; 2], [f32; 2]) {
    let a = [k.x as f32 - 0.5, k.y as f32 - 0.5];
    (a, [a[0] + k.size as f32, a[1] + k.size as f32])
}

/// What [`cascades`] needs besides the fitted cascades.
///
/// ```
/// use relief_core::{Camera, Scale};
/// let cam = Camera::new(glam::Vec3::new(-10.0, 30.0, 20.0), glam::Vec3::new(30.0, 30.0, 0.0), 60.0, 64, 64).unwrap();
/// let v = relief_skia::rbf::CascadeView { camera: &cam, scale: Scale::default(), size: [64, 64] };
/// assert_eq!(v.size, [64, 64]);
/// ```
#[derive(Debug, Clone, Copy)]
pub struct CascadeView<'a> {
    /// The camera the cascades were fitted for.
    pub camera: &'a Camera,
    /// The heightfield's spacing (world to sample coordinates).
    pub scale: Scale,
    /// The heightfield's size in samples.
    pub size: [u32; 2],
}

const CASCADE_COLOURS: [[u8; 3]; 3] = [VERMILLION, ORANGE, YELLOWISH];
const YELLOWISH: [u8; 3] = crate::style::YELLOW;

/// The ground footprint of the camera's view frustum between the planes at distances
/// `frustum[0]` (near) and `frustum[1]` (far) along the view, cut by the height slab
/// `z_range[0] <= z <= z_range[1]`: the convex hull, counter-clockwise, of the ground projection
/// of that solid (seed 002's figure 1a draws it in orange). The frustum's corners are the
/// intersections of the core's [`Camera::frustum_planes`]; empty when the slab misses the
/// frustum.
///
/// For a fit of [`relief_core::rbf::fit_cascades`], `(fit.frustum, fit.z_range)` gives the
/// footprint the cascades' visible hull was cut from (the hull is this footprint clipped to the
/// heightfield's domain).
///
/// ```
/// use relief_core::Camera;
/// use glam::Vec3;
/// let cam = Camera::new(Vec3::new(0.0, 0.0, 10.0), Vec3::new(10.0, 0.0, 0.0), 60.0, 4, 4).unwrap();
/// let f = relief_skia::rbf::frustum_footprint(&cam, [1.0, 100.0], [0.0, 0.0]).unwrap();
/// assert!(f.len() >= 3 && f.iter().all(|p| p.x > 0.0)); // ground ahead of the eye only
/// assert!(relief_skia::rbf::frustum_footprint(&cam, [1.0, 100.0], [50.0, 60.0]).unwrap().is_empty());
/// ```
pub fn frustum_footprint(
    camera: &Camera,
    frustum: [f32; 2],
    z_range: [f32; 2],
) -> Result<Vec<DVec2>, DiagramError> {
    let [z0, z1] = z_range.map(f64::from);
    if !(z0.is_finite() && z1.is_finite() && z0 <= z1) {
        return Err(DiagramError::InvalidParameter {
            name: "z_range",
            reason: "must be finite, lowest first",
        });
    }
    let planes = camera
        .frustum_planes(frustum[0], frustum[1])?
        .map(|p| p.as_dvec4());
    // Corner k: bit 0 right (else left), bit 1 top (else bottom), bit 2 far (else near).
    let mut corners = [DVec3::ZERO; 8];
    for (k, c) in corners.iter_mut().enumerate() {
        let pick = |bit: usize, a: usize| planes[a + usize::from(k & bit != 0)];
        let (a, b, e) = (pick(1, 0), pick(2, 2), pick(4, 4));
        let m = DMat3::from_cols(a.truncate(), b.truncate(), e.truncate()).transpose();
        if m.determinant().abs() < 1e-300 {
            return Err(DiagramError::InvalidParameter {
                name: "camera",
                reason: "degenerate frustum",
            });
        }
        *c = m.inverse() * -DVec3::new(a.w, b.w, e.w);
    }
    let mut pts: Vec<DVec2> = corners
        .iter()
        .filter(|c| (z0..=z1).contains(&c.z))
        .map(|c| c.truncate())
        .collect();
    for k in 0..8usize {
        for bit in [1usize, 2, 4] {
            if k & bit != 0 {
                continue;
            }
            let (p, q) = (corners[k], corners[k | bit]);
            for z in [z0, z1] {
                let (dp, dq) = (p.z - z, q.z - z);
                if (dp < 0.0) != (dq < 0.0) && dp != dq {
                    pts.push((p + (q - p) * (dp / (dp - dq))).truncate());
                }
            }
        }
    }
    Ok(convex_hull(pts))
}

/// Andrew's monotone chain, counter-clockwise, collinear points dropped.
fn convex_hull(mut pts: Vec<DVec2>) -> Vec<DVec2> {
    pts.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    pts.dedup();
    if pts.len() < 3 {
        return Vec::new();
    }
    let cross = |o: DVec2, a: DVec2, b: DVec2| (a - o).perp_dot(b - o);
    let turns_left = |hull: &[DVec2], p: DVec2| match hull {
        [.., o, a] => cross(*o, *a, p) > 0.0,
        _ => true,
    };
    let mut hull: Vec<DVec2> = Vec::with_capacity(2 * pts.len());
    for &p in &pts {
        while hull.len() >= 2 && !turns_left(&hull, p) {
            hull.pop();
        }
        hull.push(p);
    }
    let lower = hull.len() + 1;
    for &p in pts.iter().rev().skip(1) {
        while hull.len() >= lower && !turns_left(&hull, p) {
            hull.pop();
        }
        hull.push(p);
    }
    hull.pop();
    if hull.len() < 3 {
        Vec::new()
    } else {
        hull
    }
}

/// The chord of the convex polygon `poly` on the line `(q - eye) . v = offset`, if it crosses.
fn chord(poly: &[DVec2], eye: DVec2, v: DVec2, offset: f64) -> Option<(DVec2, DVec2)> {
    let g = |q: DVec2| (q - eye).dot(v) - offset;
    let mut hits = Vec::new();
    let mut prev = *poly.last()?;
    for &q in poly {
        let (gp, gq) = (g(prev), g(q));
        if (gp < 0.0) != (gq < 0.0) && gp != gq {
            hits.push(prev + (q - prev) * (gp / (gp - gq)));
        }
        prev = q;
    }
    match hits.as_slice() {
        [a, b, ..] => Some((*a, *b)),
        _ => None,
    }
}

/// Seed 002's figure 1a from the core's fit: the heightfield's outline, the exact ground
/// footprint of the camera frustum over the fit's height range, near to far
/// ([`frustum_footprint`] of `fit.frustum` and `fit.z_range`, dashed sky blue), the three
/// cascade polygons (filled, overlaps darker) whose union is the visible hull (the footprint
/// clipped to the domain), the split lines at `splits[0]` and `splits[1]` (solid) and the
/// hull's near and far offsets (dashed) across the footprint, and each cascade's snapped
/// texture square (blue, numbered 1-3).
///
/// ```
/// use relief_core::{rbf::*, Camera, Scale};
/// let cells = [Cell::new(0, 0, 64, 0.0)];
/// let mut index = vec![0; 64 * 64];
/// let grid = AdaptiveGrid::new(64, 64, &cells, &mut index).unwrap();
/// let cam = Camera::new(glam::Vec3::new(-10.0, 30.0, 20.0), glam::Vec3::new(30.0, 30.0, 0.0), 60.0, 64, 64).unwrap();
/// let fit = fit_cascades(&cam, &grid, &Scale::default(), (0.0, 1.0), &CascadeOptions::default().with_resolution(64), None).unwrap();
/// let view = relief_skia::rbf::CascadeView { camera: &cam, scale: Scale::default(), size: [64, 64] };
/// let p = relief_skia::rbf::cascades(&fit, &view, &relief_skia::DiagramOptions::default()).unwrap();
/// assert!(p.width() > 100);
/// ```
pub fn cascades(
    fit: &Cascades,
    view: &CascadeView<'_>,
    opts: &DiagramOptions<'_>,
) -> Result<Pixmap, DiagramError> {
    let s = view.scale;
    if !(s.dx.is_finite() && s.dy.is_finite() && s.dx > 0.0 && s.dy > 0.0) {
        return Err(DiagramError::InvalidParameter {
            name: "scale",
            reason: "dx and dy must be finite and positive",
        });
    }
    let to_s = |p: DVec2| {
        [
            (p.x / f64::from(s.dx)) as f32,
            (p.y / f64::from(s.dy)) as f32,
        ]
    };
    let cam = view.camera;
    let eye = DVec2::new(f64::from(cam.eye.x), f64::from(cam.eye.y));
    let (f3, _, _) = cam.basis();
    // The core's projected view vector (its offsets are measured along it from the eye).
    let v = DVec2::new(f64::from(f3.x), f64::from(f3.y)).normalize_or(DVec2::X);
    let footprint = if fit.frustum[0] > 0.0 && fit.frustum[1] > fit.frustum[0] {
        frustum_footprint(cam, fit.frustum, fit.z_range)?
    } else {
        Vec::new()
    };
    // Texture squares in sample coordinates.
    let squares: Vec<([f32; 2], [f32; 2])> = fit
        .cascades
        .iter()
        .map(|k| {
            let h = k.spacing * 0.5;
            let a = k.texel_center(0, 0);
            let b = k.texel_center(
                k.resolution.saturating_sub(1),
                k.resolution.saturating_sub(1),
            );
            ([a.x - h, a.y - h], [b.x + h, b.y + h])
        })
        .collect();
    let (w, h) = (
        view.size[0].saturating_sub(1) as f32,
        view.size[1].saturating_sub(1) as f32,
    );
    let mut lo = [0.0f32, 0.0];
    let mut hi = [w.max(1.0), h.max(1.0)];
    let mut grow = |p: [f32; 2]| {
        if p[0].is_finite() && p[1].is_finite() {
            lo = [lo[0].min(p[0]), lo[1].min(p[1])];
            hi = [hi[0].max(p[0]), hi[1].max(p[1])];
        }
    };
    grow(to_s(eye));
    for p in &footprint {
        grow(to_s(*p));
    }
    if fit.visible {
        for (a, b) in &squares {
            grow(*a);
            grow(*b);
        }
    }
    let pad = 0.03 * (hi[0] - lo[0]).max(hi[1] - lo[1]);
    let (lo, hi) = ([lo[0] - pad, lo[1] - pad], [hi[0] + pad, hi[1] + pad]);
    let row1 = [
        (rgba(VERMILLION, 0.5), "cascade 1"),
        (rgba(ORANGE, 0.5), "cascade 2"),
        (rgba(YELLOWISH, 0.5), "cascade 3 (union: visible hull)"),
        (rgba(BLUE, 1.0), "snapped texture"),
    ];
    let frustum_label = format!(
        "frustum footprint, z {:.0}..{:.0} (dashed)",
        fit.z_range[0], fit.z_range[1]
    );
    let row2 = [
        (rgba(SKY_BLUE, 1.0), frustum_label.as_str()),
        (
            rgba(BLACK, 0.8),
            "splits (solid), near/far of hull (dashed)",
        ),
    ];
    let mut c = Canvas::new(
        lo,
        hi,
        false,
        &format!(
            "cascades: near {:.1}, splits {:.1} / {:.1}, far {:.1} (world units along the view)",
            fit.near, fit.splits[0], fit.splits[1], fit.far
        ),
        &[&row1[..], &row2[..]],
        opts,
    )?;
    let domain = ([0.0, 0.0], [w, h]);
    if let Some(bg) = opts.background {
        c.background(bg, [-0.5, -0.5], [w + 0.5, h + 0.5]);
    }
    let foot: Vec<[f32; 2]> = footprint.iter().map(|p| to_s(*p)).collect();
    if foot.len() >= 3 {
        c.fill_polygon(&foot, rgba(SKY_BLUE, 0.12));
    }
    c.stroke_rect(domain.0, domain.1, rgba(BLACK, 0.9), 1.5, false);
    if fit.visible {
        for (k, casc) in fit.cascades.iter().enumerate() {
            let poly: Vec<[f32; 2]> = casc.polygon().iter().map(|p| to_s(p.as_dvec2())).collect();
            c.fill_polygon(&poly, rgba(CASCADE_COLOURS[k], 0.3));
            c.stroke(&poly, true, rgba(CASCADE_COLOURS[k], 1.0), 1.5, false);
        }
        for (k, (a, b)) in squares.iter().enumerate() {
            c.stroke_rect(*a, *b, rgba(BLUE, 1.0), 2.0, false);
            let lab = [a[0], a[1]];
            c.label(lab, &format!(" {}", k + 1), LABEL + 2.0, BLUE);
        }
    }
    if foot.len() >= 3 {
        c.stroke(&foot, true, rgba(SKY_BLUE, 1.0), 2.0, true);
    }
    // The hull's near and far offsets (dashed) and the splits (solid), across the footprint.
    for (off, dashed) in [
        (fit.near, true),
        (fit.splits[0], false),
        (fit.splits[1], false),
        (fit.far, true),
    ] {
        if let Some((a, b)) = chord(&footprint, eye, v, f64::from(off)) {
            c.stroke(&[to_s(a), to_s(b)], false, rgba(BLACK, 0.8), 1.5, dashed);
        }
    }
    c.dot(to_s(eye), 4.0, rgba(BLACK, 1.0));
    Ok(c.finish())
}
