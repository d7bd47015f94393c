//! The cell DDA (Amanatides & Woo 1987) and the run-length DDA of Henning & Stephenson,
//! *Accelerating the Ray Tracing of Height Fields* (2004, seed 001), side by side: the grid, the
//! ray, the cells [`relief_core::ray::CellDda`] visits in order, and the runs
//! [`relief_core::ray::RunDda`] yields, coloured short vs long with the intercept sequence
//! `beta_j` above them — seed 001's figure 6 for the line `y = 17/41 x`.
//!
//! The cells, runs and intercepts are the core's ([`relief_core::ray::RunDda::with_intercepts`]);
//! this module only classifies what it draws. A run of the core's 4-connected line is the
//! paper's 8-connected run extended at its beginning by one cell, except where the line passes
//! exactly through a corner ([`relief_core::ray::RunIntercept::extended`] says which). The
//! paper's run length is the 4-connected length less the extension; with
//! `r = floor(|major| / |minor|)` it is short (`r`) or long (`r + 1`); first and last runs
//! shorter than `r` are cut by the segment's ends. The intercept `beta_j` (paper eq. 2) is the
//! core's exact fixed-point value, printed as a fraction in lowest terms when its denominator is
//! small (rays with integer start and direction: `10/41`, ...), with two decimals otherwise.

use crate::canvas::{Canvas, LABEL};
use crate::style::{rgba, BLACK, BLUE, GRID_GREY, ORANGE, REDDISH_PURPLE, SKY_BLUE};
use crate::{DiagramError, DiagramOptions};
use glam::DVec2;
use relief_core::ray::{CellRun, GridLine, RunIntercept};
use tiny_skia::Pixmap;

/// A projected ray over a grid of cells, in grid units (cell `(cx, cy)` is the square
/// `[cx, cx+1] x [cy, cy+1]`), as [`GridLine::new`] takes it.
///
/// ```
/// use relief_skia::dda::DdaSpec;
/// let s = DdaSpec::seed001_figure6();
/// assert_eq!((s.dir.x, s.dir.y, s.cells), (41.0, 17.0, [41, 17]));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DdaSpec {
    /// Start point.
    pub start: DVec2,
    /// Direction (need not be normalised).
    pub dir: DVec2,
    /// End point of the segment (the last cell is the one containing it).
    pub stop: DVec2,
    /// Number of cells along x and y.
    pub cells: [u32; 2],
}

impl DdaSpec {
    /// Seed 001's example line `y = 17/41 x` from the origin over 41 x 17 cells (figure 6).
    ///
    /// ```
    /// let s = relief_skia::dda::DdaSpec::seed001_figure6();
    /// assert_eq!(s.start, glam::DVec2::ZERO);
    /// ```
    #[must_use]
    pub fn seed001_figure6() -> DdaSpec {
        DdaSpec {
            start: DVec2::ZERO,
            dir: DVec2::new(41.0, 17.0),
            stop: DVec2::new(41.0, 17.0),
            cells: [41, 17],
        }
    }

    /// The core's digital line for this ray.
    ///
    /// ```
    /// let line = relief_skia::dda::DdaSpec::seed001_figure6().line().unwrap();
    /// assert_eq!(line.cells().count(), 41 + 16); // 41 columns, 16 row changes
    /// ```
    pub fn line(&self) -> Result<GridLine, DiagramError> {
        Ok(GridLine::new(self.start, self.dir, self.stop, self.cells)?)
    }
}

/// How a run is classified in the diagram.
///
/// ```
/// use relief_skia::dda::RunKind;
/// assert_eq!(RunKind::Long.symbol(), 'l');
/// assert_eq!(RunKind::Short.symbol(), 's');
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RunKind {
    /// Length `r` (the paper's short run, dark).
    Short,
    /// Length `r + 1` (the paper's long run, light).
    Long,
    /// The first or last run, shorter than `r`: cut by the segment's ends.
    Truncated,
    /// The ray runs along the major axis (zero minor component): a single run.
    Axis,
}

impl RunKind {
    /// The paper's symbol: `s`, `l`, `t` (truncated) or `a` (axis).
    ///
    /// ```
    /// assert_eq!(relief_skia::dda::RunKind::Truncated.symbol(), 't');
    /// ```
    #[must_use]
    pub fn symbol(self) -> char {
        match self {
            RunKind::Short => 's',
            RunKind::Long => 'l',
            RunKind::Truncated => 't',
            RunKind::Axis => 'a',
        }
    }
}

/// One run of the core's run-length DDA, as the diagram reads it.
///
/// ```
/// let runs = relief_skia::dda::runs(&relief_skia::dda::DdaSpec::seed001_figure6()).unwrap();
/// assert_eq!(runs[1].run.len, 3); // 4-connected: the 8-connected short run plus its extension
/// assert!(runs[1].extended);
/// assert_eq!(runs[1].length8, 2);
/// assert_eq!(runs[1].intercept_label, "10/41");
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct RunInfo {
    /// The run exactly as [`relief_core::ray::RunDda`] yielded it (4-connected).
    pub run: CellRun,
    /// The run begins with the 4-connected extension cell.
    pub extended: bool,
    /// The paper's (8-connected) run length: `run.len` less the extension.
    pub length8: u32,
    /// Short, long or truncated.
    pub kind: RunKind,
    /// The core's intercept `beta_j` ([`relief_core::ray::RunIntercept::to_f64`]): in
    /// `[0, alpha)` after the first run; for the first run the line at the left face of the
    /// start column, in `(-alpha, 1)` (negative when the line enters the start row between that
    /// face and the start point).
    pub intercept: f64,
    /// `beta_j` as printed: `n/d` over the major component for integer rays (`10/41`), in lowest
    /// terms for other small denominators, two decimals otherwise.
    pub intercept_label: String,
}

/// The runs of the core's run-length DDA for `spec`, classified (module docs).
///
/// ```
/// use relief_skia::dda::{runs, DdaSpec};
/// let r = runs(&DdaSpec::seed001_figure6()).unwrap();
/// let seq: String = r.iter().map(|x| x.kind.symbol()).collect();
/// assert_eq!(seq, "lslslsslslsslslss"); // seed 001, figure 6
/// ```
pub fn runs(spec: &DdaSpec) -> Result<Vec<RunInfo>, DiagramError> {
    let line = spec.line()?;
    let (du, dv) = if spec.dir.y.abs() > spec.dir.x.abs() {
        (spec.dir.y, spec.dir.x)
    } else {
        (spec.dir.x, spec.dir.y)
    };
    let r = if dv != 0.0 {
        (du.abs() / dv.abs()).floor() as u32
    } else {
        0
    };
    let mut out = Vec::new();
    for (run, beta) in line.runs().with_intercepts() {
        let extended = beta.extended();
        // A last run cut right after its extension cell has no 8-connected cell: length 0.
        let length8 = run.len - u32::from(extended);
        let kind = if dv == 0.0 {
            RunKind::Axis
        } else if length8 == r + 1 {
            RunKind::Long
        } else if length8 == r {
            RunKind::Short
        } else {
            // Only the first and last runs can be shorter: cut by the segment's ends.
            RunKind::Truncated
        };
        out.push(RunInfo {
            run,
            extended,
            length8,
            kind,
            intercept: beta.to_f64(),
            intercept_label: intercept_label(beta, du),
        });
    }
    Ok(out)
}

/// `n/d` over the ray's major component when that is a whole number that the reduced
/// denominator divides (seed 001 writes figure 6's intercepts over 41), else `n/d` in lowest
/// terms when `d` is small, else two decimals.
fn intercept_label(beta: RunIntercept, major: f64) -> String {
    let (n, d) = beta.reduced();
    let m = major.abs();
    if m.fract() == 0.0 && (1.0..=9999.0).contains(&m) {
        let m = m as i64;
        if m % d == 0 {
            return format!("{}/{m}", n * (m / d));
        }
    }
    if d <= 9999 {
        format!("{n}/{d}")
    } else {
        format!("{:.2}", beta.to_f64())
    }
}

fn kind_colour(k: RunKind) -> [u8; 3] {
    match k {
        RunKind::Short => BLUE,
        RunKind::Long => ORANGE,
        RunKind::Truncated => REDDISH_PURPLE,
        RunKind::Axis => SKY_BLUE,
    }
}

/// Cell DDA (left) and run-length DDA (right) of `spec`, drawn over the cells the ray spans:
/// the grid, the ray, visited cells numbered in order, runs coloured long (orange) / short
/// (blue) / truncated (purple) with the 4-connected extension cell paler, the paper's run length
/// inside each run and `beta_j` above its first 8-connected cell.
///
/// With a background (one pixel per sample, as [`crate::hillshade`] makes it for a DEM of
/// `cells + 1` samples), the part under the window is drawn beneath both panels, cells
/// translucent over it.
///
/// ```
/// use relief_skia::dda::{dda, DdaSpec};
/// let p = dda(&DdaSpec::seed001_figure6(), &relief_skia::DiagramOptions::default().with_max_size(400)).unwrap();
/// assert!(p.width() > 800);
/// let other = DdaSpec { dir: glam::DVec2::new(41.0, 12.0), ..DdaSpec::seed001_figure6() };
/// let q = dda(&other, &relief_skia::DiagramOptions::default().with_max_size(400)).unwrap();
/// assert_ne!(p, q); // a different ray visits different cells
/// ```
pub fn dda(spec: &DdaSpec, opts: &DiagramOptions<'_>) -> Result<Pixmap, DiagramError> {
    let line = spec.line()?;
    let cells: Vec<[u32; 2]> = line.cells().collect();
    let info = runs(spec)?;
    // Window: the cells visited, plus one cell around, inside the grid.
    let (mut lo, mut hi) = ([u32::MAX; 2], [0u32; 2]);
    for c in &cells {
        for k in 0..2 {
            lo[k] = lo[k].min(c[k]);
            hi[k] = hi[k].max(c[k] + 1);
        }
    }
    if cells.is_empty() {
        return Err(DiagramError::InvalidParameter {
            name: "ray",
            reason: "the ray visits no cell",
        });
    }
    let pad = |a: u32, b: u32, n: u32| (a.saturating_sub(1), (b + 1).min(n));
    let (x0, x1) = pad(lo[0], hi[0], spec.cells[0]);
    let (y0, y1) = pad(lo[1], hi[1], spec.cells[1]);
    let (ww, wh) = ((x1 - x0) as f32, (y1 - y0) as f32);
    let gap = (ww * 0.08).max(1.0);
    // Room for the panel titles: about 26 pixels.
    let scale0 = 2.0 * opts.max_size as f32 / (2.0 * ww + gap).max(wh);
    let head = 26.0 / scale0.max(1e-3);
    let r = if spec.dir.x.abs() >= spec.dir.y.abs() {
        spec.dir.x.abs() / spec.dir.y.abs()
    } else {
        spec.dir.y.abs() / spec.dir.x.abs()
    };
    let short = format!(
        "short run (r = {})",
        if r.is_finite() { r.floor() } else { 0.0 }
    );
    let long = format!(
        "long run (r + 1 = {})",
        if r.is_finite() { r.floor() + 1.0 } else { 0.0 }
    );
    let row1 = [
        (rgba(SKY_BLUE, 0.75), "cell visited (number = order)"),
        (rgba(BLACK, 1.0), "ray"),
        (rgba(BLUE, 0.85), &short),
        (rgba(ORANGE, 0.85), &long),
    ];
    let row2 = [
        (rgba(REDDISH_PURPLE, 0.85), "truncated run"),
        (rgba(BLUE, 0.3), "4-connected extension"),
        (
            rgba(BLACK, 0.0),
            "number in run: paper's length; above: intercept beta_j",
        ),
    ];
    let mut c = Canvas::new(
        [0.0, 0.0],
        [2.0 * ww + gap, wh + head],
        true,
        &format!(
            "DDA of ({}, {}) + t ({}, {}): {} cells, {} runs",
            spec.start.x,
            spec.start.y,
            spec.dir.x,
            spec.dir.y,
            cells.len(),
            info.len()
        ),
        &[&row1[..], &row2[..]],
        &DiagramOptions {
            max_size: opts.max_size.saturating_mul(2).min(8192),
            ..*opts
        },
    )?;
    let px = c.scale();
    let font = (px * 0.55).clamp(7.0, 14.0);
    let panels = [0.0f32, ww + gap];
    if let Some(bg) = opts.background {
        // Samples x0..=x1, y0..=y1 of the background, row 0 at the bottom (y up).
        if let Some(crop) = sample_window(bg, [x0, y0], [x1, y1]) {
            for &ox in &panels {
                c.background(&crop, [ox - 0.5, -0.5], [ox + ww + 0.5, wh + 0.5]);
            }
        }
    }
    // Local units of a grid cell in panel `p`.
    let at = |p: usize, x: f32, y: f32| [panels[p] + x - x0 as f32, y - y0 as f32];
    for (p, &ox) in panels.iter().enumerate() {
        let title = if p == 0 {
            "cell DDA (Amanatides & Woo)"
        } else {
            "run-length DDA (Henning & Stephenson)"
        };
        c.label([ox, wh + head * 0.8], title, LABEL + 1.0, BLACK);
    }
    // Labels are drawn last, over the grid and the ray.
    let mut labels: Vec<([f32; 2], String, f32)> = Vec::new();
    // Left: visited cells in order.
    for (k, cell) in cells.iter().enumerate() {
        let (x, y) = (cell[0] as f32, cell[1] as f32);
        c.fill_rect(at(0, x, y), at(0, x + 1.0, y + 1.0), rgba(SKY_BLUE, 0.75));
        if px >= 14.0 && cells.len() <= 999 {
            labels.push((at(0, x + 0.5, y + 0.5), k.to_string(), font * 0.9));
        }
    }
    // Right: runs.
    for r in &info {
        let col = kind_colour(r.kind);
        for (k, cell) in r.run.cells().enumerate() {
            let (x, y) = (cell[0] as f32, cell[1] as f32);
            let alpha = if k == 0 && r.extended { 0.3 } else { 0.85 };
            c.fill_rect(at(1, x, y), at(1, x + 1.0, y + 1.0), rgba(col, alpha));
        }
        let (a, b) = (
            r.run.start,
            r.run.cell(r.run.len - 1).unwrap_or(r.run.start),
        );
        let mid = [
            (a[0] + b[0]) as f32 / 2.0 + 0.5,
            (a[1] + b[1]) as f32 / 2.0 + 0.5,
        ];
        if px >= 10.0 {
            labels.push((at(1, mid[0], mid[1]), r.length8.to_string(), font));
            let c8 = r.run.cell(u32::from(r.extended)).unwrap_or(a);
            let (lx, ly) = if r.run.along_y {
                (c8[0] as f32 - 0.9, c8[1] as f32 + 0.5)
            } else {
                (c8[0] as f32 + 0.5, c8[1] as f32 + 1.45)
            };
            labels.push((at(1, lx, ly), r.intercept_label.clone(), font * 0.85));
        }
    }
    // Grids, outlines and the ray on both panels.
    for p in 0..2 {
        if px >= 3.0 {
            for x in x0..=x1 {
                let xf = x as f32;
                c.stroke(
                    &[at(p, xf, y0 as f32), at(p, xf, y1 as f32)],
                    false,
                    rgba(GRID_GREY, 1.0),
                    1.0,
                    false,
                );
            }
            for y in y0..=y1 {
                let yf = y as f32;
                c.stroke(
                    &[at(p, x0 as f32, yf), at(p, x1 as f32, yf)],
                    false,
                    rgba(GRID_GREY, 1.0),
                    1.0,
                    false,
                );
            }
        }
        c.stroke_rect(
            at(p, x0 as f32, y0 as f32),
            at(p, x1 as f32, y1 as f32),
            rgba(BLACK, 0.8),
            1.0,
            false,
        );
        // The ray from start to stop, clipped to the window.
        let (s, e) = ray_segment(spec, [x0 as f64, y0 as f64], [x1 as f64, y1 as f64]);
        c.stroke(
            &[at(p, s[0], s[1]), at(p, e[0], e[1])],
            false,
            rgba(BLACK, 1.0),
            2.0,
            false,
        );
        c.dot(at(p, s[0], s[1]), 3.5, rgba(BLACK, 1.0));
    }
    for (p, t, size) in &labels {
        c.label_centered(*p, t, *size, BLACK);
    }
    Ok(c.finish())
}

/// Samples `lo..=hi` of a one-pixel-per-sample picture, flipped so that sample row `lo[1]` is
/// the picture's last row (the DDA panels draw y up); `None` if the window misses the picture.
fn sample_window(bg: &Pixmap, lo: [u32; 2], hi: [u32; 2]) -> Option<Pixmap> {
    let (w, h) = (hi[0].checked_sub(lo[0])? + 1, hi[1].checked_sub(lo[1])? + 1);
    if hi[0] >= bg.width() || hi[1] >= bg.height() {
        return None;
    }
    let mut out = Pixmap::new(w, h)?;
    let src = bg.pixels();
    let dst = out.pixels_mut();
    for r in 0..h {
        for x in 0..w {
            let s = (lo[1] + r) as usize * bg.width() as usize + (lo[0] + x) as usize;
            let d = (h - 1 - r) as usize * w as usize + x as usize;
            if let (Some(sp), Some(dp)) = (src.get(s), dst.get_mut(d)) {
                *dp = *sp;
            }
        }
    }
    Some(out)
}

/// The ray from its start to the stop's major coordinate, clipped to the window `[lo, hi]`.
fn ray_segment(spec: &DdaSpec, lo: [f64; 2], hi: [f64; 2]) -> ([f32; 2], [f32; 2]) {
    let (p, d) = (spec.start, spec.dir);
    let k = if d.x.abs() >= d.y.abs() { 0 } else { 1 };
    let mut t1 = if d[k] != 0.0 {
        ((spec.stop[k] - p[k]) / d[k]).max(0.0)
    } else {
        0.0
    };
    let mut t0 = 0.0f64;
    for a in 0..2 {
        if d[a] != 0.0 {
            let (ta, tb) = ((lo[a] - p[a]) / d[a], (hi[a] - p[a]) / d[a]);
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
    }
    let t1 = t1.max(t0);
    let at = |t: f64| {
        let q = p + d * t;
        [q.x as f32, q.y as f32]
    };
    (at(t0), at(t1))
}
