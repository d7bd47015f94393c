//! Figures: line charts with plotters and false-colour images, written as PNG through the
//! atomic writer. Colours are the Okabe-Ito palette (readable with colour-blindness); images use
//! viridis.

use crate::{CliError, CliResult};
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

/// The bundled open font (DejaVu Sans, licence beside it in assets/fonts).
static FONT: &[u8] = include_bytes!("../../../../assets/fonts/DejaVuSans.ttf");

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The only failure is a malformed font, which the bundled one is not; charts then fail
        // with plotters' own error.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// Okabe-Ito colours.
pub const PALETTE: [RGBColor; 7] = [
    RGBColor(0, 114, 178),
    RGBColor(230, 159, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(86, 180, 233),
    RGBColor(213, 94, 0),
    RGBColor(0, 0, 0),
];

/// One named series of points.
pub struct Series {
    /// Legend label.
    pub label: String,
    /// Points `(x, y)`; non-finite points are skipped.
    pub points: Vec<(f64, f64)>,
}

/// A line chart.
pub struct Chart<'a> {
    /// Title above the chart.
    pub title: &'a str,
    /// X axis label.
    pub x_label: &'a str,
    /// Y axis label.
    pub y_label: &'a str,
    /// Logarithmic x axis.
    pub log_x: bool,
    /// Logarithmic y axis.
    pub log_y: bool,
    /// The data.
    pub series: &'a [Series],
}

fn range(values: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite() && (!log || *v > 0.0)) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (1.0, 10.0);
    }
    if log {
        (lo / 1.5, hi * 1.5)
    } else {
        let pad = ((hi - lo) * 0.05).max(1e-9);
        (lo - pad, hi + pad)
    }
}

/// Draws `chart` into a `w x h` PNG at `path`.
pub fn line_chart(path: &Path, w: u32, h: u32, chart: &Chart<'_>) -> CliResult {
    register_font();
    let mut buf = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        let err = |e: &dyn std::fmt::Display| CliError(format!("plot {}: {e}", path.display()));
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let pts = || chart.series.iter().flat_map(|s| s.points.iter().copied());
        let (x0, x1) = range(pts().map(|p| p.0), chart.log_x);
        let (y0, y1) = range(pts().map(|p| p.1), chart.log_y);
        let mut builder = ChartBuilder::on(&root);
        builder
            .caption(chart.title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70);
        macro_rules! draw {
            ($ctx:expr) => {{
                let mut ctx = $ctx;
                ctx.configure_mesh()
                    .x_desc(chart.x_label)
                    .y_desc(chart.y_label)
                    .label_style(("sans-serif", 12))
                    .draw()
                    .map_err(|e| err(&e))?;
                for (k, s) in chart.series.iter().enumerate() {
                    let c = PALETTE[k % PALETTE.len()];
                    let p: Vec<(f64, f64)> = s
                        .points
                        .iter()
                        .copied()
                        .filter(|(x, y)| {
                            x.is_finite()
                                && y.is_finite()
                                && (!chart.log_x || *x > 0.0)
                                && (!chart.log_y || *y > 0.0)
                        })
                        .collect();
                    ctx.draw_series(LineSeries::new(p.clone(), c.stroke_width(2)))
                        .map_err(|e| err(&e))?
                        .label(s.label.clone())
                        .legend(move |(x, y)| {
                            PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2))
                        });
                    ctx.draw_series(p.into_iter().map(|q| Circle::new(q, 3, c.filled())))
                        .map_err(|e| err(&e))?;
                }
                ctx.configure_series_labels()
                    .background_style(WHITE.mix(0.85))
                    .border_style(BLACK)
                    .label_font(("sans-serif", 12))
                    .draw()
                    .map_err(|e| err(&e))?;
            }};
        }
        match (chart.log_x, chart.log_y) {
            (false, false) => draw!(builder
                .build_cartesian_2d(x0..x1, y0..y1)
                .map_err(|e| err(&e))?),
            (true, false) => draw!(builder
                .build_cartesian_2d((x0..x1).log_scale(), y0..y1)
                .map_err(|e| err(&e))?),
            (false, true) => draw!(builder
                .build_cartesian_2d(x0..x1, (y0..y1).log_scale())
                .map_err(|e| err(&e))?),
            (true, true) => draw!(builder
                .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
                .map_err(|e| err(&e))?),
        }
        root.present().map_err(|e| err(&e))?;
    }
    relief_io::write_png_rgb8(path, w, h, &buf)?;
    Ok(())
}

/// Viridis colour of `t` in `[0, 1]` (clamped; NaN is drawn magenta).
pub fn viridis(t: f64) -> [u8; 3] {
    if t.is_nan() {
        return [255, 0, 255];
    }
    let c = ViridisRGB::get_color(t.clamp(0.0, 1.0));
    [c.0, c.1, c.2]
}

/// Writes `values` (row-major `w x h`) as a false-colour PNG, mapping `[lo, hi]` through
/// `colour`.
pub fn image(
    path: &Path,
    w: u32,
    h: u32,
    values: &[f32],
    lo: f64,
    hi: f64,
    colour: impl Fn(f64) -> [u8; 3],
) -> CliResult {
    let span = if hi > lo { hi - lo } else { 1.0 };
    let rgb: Vec<u8> = values
        .iter()
        .flat_map(|v| colour((f64::from(*v) - lo) / span))
        .collect();
    relief_io::write_png_rgb8(path, w, h, &rgb)?;
    Ok(())
}
