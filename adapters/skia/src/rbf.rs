//! Diagrams of Cornel, Horváth, Waser, *Adaptive Heightfield Rendering with Complex Interpolants
//! Using Ray Casting* (2022, seed 002):
//! - [`rbf()`]: the adaptive grid's cells, the dashed truncation circles (`3.5 sigma c_i`) of
//!   chosen cells, and the cells that influence the first chosen cell's centre filled light —
//!   seed 002's figure 2;
//! - [`cascades`]: the camera's ground wedge, the potentially visible hull split into three
//!   cascade polygons at the logarithmic splits, and each cascade's snapped texture square —
//!   seed 002's figure 1a.
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
use glam::Vec2;
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

/// Seed 002's figure 1a from the core's fit: the heightfield's outline, the camera's ground
/// wedge (horizontal field of view), the three cascade polygons (filled, overlaps darker) whose
/// union is the visible hull, the split lines at `splits[0]` and `splits[1]` and the hull's near
/// and far offsets, and each cascade's snapped texture square (blue, numbered 1-3).
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
    let to_s = |p: Vec2| [p.x / s.dx, p.y / s.dy];
    let cam = view.camera;
    let eye = Vec2::new(cam.eye.x, cam.eye.y);
    let (f3, _, _) = cam.basis();
    let v = Vec2::new(f3.x, f3.y).normalize_or_zero();
    let (_, left) = cam.ray(0, cam.height / 2);
    let (_, right) = cam.ray(cam.width.saturating_sub(1), cam.height / 2);
    let dirs = [left, right].map(|d| Vec2::new(d.x, d.y).normalize_or_zero());
    let reach = fit.far.max(1.0) * 1.1;
    // Wedge points in world units.
    let wedge: Vec<Vec2> = dirs
        .iter()
        .map(|d| {
            let cosang = d.dot(v).max(0.05);
            eye + *d * (reach / cosang)
        })
        .collect();
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
    let row2 = [
        (rgba(SKY_BLUE, 1.0), "frustum wedge (dashed)"),
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
    c.stroke_rect(domain.0, domain.1, rgba(BLACK, 0.9), 1.5, false);
    if fit.visible {
        for (k, casc) in fit.cascades.iter().enumerate() {
            let poly: Vec<[f32; 2]> = casc.polygon().iter().map(|p| to_s(*p)).collect();
            c.fill_polygon(&poly, rgba(CASCADE_COLOURS[k], 0.3));
            c.stroke(&poly, true, rgba(CASCADE_COLOURS[k], 1.0), 1.5, false);
        }
        for (k, (a, b)) in squares.iter().enumerate() {
            c.stroke_rect(*a, *b, rgba(BLUE, 1.0), 2.0, false);
            let lab = [a[0], a[1]];
            c.label(lab, &format!(" {}", k + 1), LABEL + 2.0, BLUE);
        }
    }
    // The wedge and the split lines across it.
    let e = to_s(eye);
    for p in &wedge {
        c.stroke(&[e, to_s(*p)], false, rgba(SKY_BLUE, 1.0), 1.5, true);
    }
    let n = Vec2::new(-v.y, v.x);
    for (off, dashed) in [
        (fit.near, true),
        (fit.splits[0], false),
        (fit.splits[1], false),
        (fit.far, true),
    ] {
        let centre = eye + v * off;
        let half: f32 = dirs
            .iter()
            .map(|d| {
                let c = d.dot(v).max(0.05);
                (*d * (off / c) - v * off).length()
            })
            .fold(0.0, f32::max)
            * 1.05;
        c.stroke(
            &[to_s(centre - n * half), to_s(centre + n * half)],
            false,
            rgba(BLACK, 0.8),
            1.5,
            dashed,
        );
    }
    c.dot(e, 4.0, rgba(BLACK, 1.0));
    Ok(c.finish())
}
