//! A pixmap with a plot area mapped to diagram units, a title line on top and legend rows below.

use crate::style::{rgba, BLACK};
use crate::text::{draw_text, text_width};
use crate::DiagramError;
use tiny_skia::{
    Color, FillRule, FilterQuality, Paint, PathBuilder, Pixmap, PixmapPaint, Rect, Stroke,
    StrokeDash, Transform,
};

/// Layout options shared by every diagram.
///
/// Defaults: plot area at most 640 pixels on its longest side, title and legend drawn, no
/// background picture.
///
/// ```
/// use relief_skia::DiagramOptions;
/// let o = DiagramOptions::default().with_max_size(300).with_legend(false);
/// assert_eq!((o.max_size, o.legend, o.title), (300, false, true));
/// ```
#[derive(Debug, Clone, Copy)]
pub struct DiagramOptions<'a> {
    /// Longest side of the plot area in pixels (16 ..= 8192).
    pub max_size: u32,
    /// Draw the title line.
    pub title: bool,
    /// Draw the legend rows.
    pub legend: bool,
    /// A picture stretched under the plot area of map diagrams (usually [`crate::hillshade`]
    /// of the same DEM, one pixel per sample).
    pub background: Option<&'a Pixmap>,
}

impl Default for DiagramOptions<'_> {
    fn default() -> Self {
        DiagramOptions {
            max_size: 640,
            title: true,
            legend: true,
            background: None,
        }
    }
}

impl<'a> DiagramOptions<'a> {
    /// Sets the longest side of the plot area (default 640).
    ///
    /// ```
    /// assert_eq!(relief_skia::DiagramOptions::default().with_max_size(128).max_size, 128);
    /// ```
    #[must_use]
    pub fn with_max_size(mut self, max_size: u32) -> Self {
        self.max_size = max_size;
        self
    }

    /// Turns the title line on or off (default on).
    ///
    /// ```
    /// assert!(!relief_skia::DiagramOptions::default().with_title(false).title);
    /// ```
    #[must_use]
    pub fn with_title(mut self, on: bool) -> Self {
        self.title = on;
        self
    }

    /// Turns the legend on or off (default on).
    ///
    /// ```
    /// assert!(!relief_skia::DiagramOptions::default().with_legend(false).legend);
    /// ```
    #[must_use]
    pub fn with_legend(mut self, on: bool) -> Self {
        self.legend = on;
        self
    }

    /// Draws `base` under the plot area of map diagrams (default none).
    ///
    /// ```
    /// let p = relief_skia::Pixmap::new(2, 2).unwrap();
    /// assert!(relief_skia::DiagramOptions::default().with_background(Some(&p)).background.is_some());
    /// ```
    #[must_use]
    pub fn with_background(mut self, base: Option<&'a Pixmap>) -> Self {
        self.background = base;
        self
    }
}

const MARGIN: f32 = 14.0;
const TITLE_H: f32 = 24.0;
const LEGEND_ROW: f32 = 20.0;
pub(crate) const LABEL: f32 = 12.0;

/// A diagram under construction: plot area `[min, max]` in diagram units.
pub(crate) struct Canvas {
    pixmap: Pixmap,
    min: [f32; 2],
    scale: f32,
    ox: f32,
    oy: f32,
    plot_h: f32,
    y_up: bool,
    legend_top: f32,
    legend: bool,
    clip: Option<tiny_skia::Mask>,
}

const TITLE_SIZE: f32 = 15.0;

/// Width of a legend row in pixels.
fn legend_width(entries: &[(Color, &str)]) -> f32 {
    entries
        .iter()
        .map(|(_, t)| 16.0 + text_width(t, LABEL) + 14.0)
        .sum()
}

fn paint(color: Color) -> Paint<'static> {
    let mut p = Paint::default();
    p.set_color(color);
    p.anti_alias = true;
    p
}

impl Canvas {
    /// A canvas showing units `[min, max]`, `y_up` for the mathematical orientation (row 0 at the
    /// top otherwise), with `legend_rows` rows of legend below. The plot area's longest side is
    /// `opts.max_size` pixels.
    pub(crate) fn new(
        min: [f32; 2],
        max: [f32; 2],
        y_up: bool,
        title: &str,
        legend: &[&[(Color, &str)]],
        opts: &DiagramOptions<'_>,
    ) -> Result<Canvas, DiagramError> {
        let (w, h) = (max[0] - min[0], max[1] - min[1]);
        if !(w.is_finite() && h.is_finite() && w > 0.0 && h > 0.0) {
            return Err(DiagramError::InvalidParameter {
                name: "extent",
                reason: "the diagram's extent must be finite and non-empty",
            });
        }
        if !(16..=8192).contains(&opts.max_size) {
            return Err(DiagramError::Size {
                width: opts.max_size,
                height: opts.max_size,
            });
        }
        let scale = opts.max_size as f32 / w.max(h);
        let (pw, ph) = ((w * scale).ceil().max(1.0), (h * scale).ceil().max(1.0));
        let top = if opts.title { TITLE_H } else { 0.0 } + MARGIN;
        let rows = if opts.legend { legend.len() } else { 0 };
        let legend_h = rows as f32 * LEGEND_ROW;
        let mut width = pw + 2.0 * MARGIN;
        if opts.title {
            width = width.max(text_width(title, TITLE_SIZE) + 2.0 * MARGIN);
        }
        if opts.legend {
            for row in legend {
                width = width.max(legend_width(row) + 2.0 * MARGIN);
            }
        }
        let height = top + ph + MARGIN + legend_h;
        let (wi, hi) = (width.ceil() as u32, height.ceil() as u32);
        let mut pixmap = Pixmap::new(wi, hi).ok_or(DiagramError::Size {
            width: wi,
            height: hi,
        })?;
        pixmap.fill(Color::WHITE);
        if opts.title {
            draw_text(&mut pixmap, title, MARGIN, 5.0, TITLE_SIZE, BLACK);
        }
        let ox = MARGIN + (width - 2.0 * MARGIN - pw).max(0.0) / 2.0;
        let clip = tiny_skia::Mask::new(wi, hi).map(|mut m| {
            if let Some(r) = Rect::from_xywh(ox - 1.0, top - 1.0, pw + 2.0, ph + 2.0) {
                m.fill_path(
                    &PathBuilder::from_rect(r),
                    FillRule::Winding,
                    false,
                    Transform::identity(),
                );
            }
            m
        });
        let mut c = Canvas {
            pixmap,
            min,
            scale,
            ox,
            oy: top,
            plot_h: ph,
            y_up,
            legend_top: top + ph + MARGIN * 0.5,
            legend: opts.legend,
            clip,
        };
        for row in legend {
            c.legend_row(row);
        }
        Ok(c)
    }

    /// Pixels per diagram unit.
    pub(crate) fn scale(&self) -> f32 {
        self.scale
    }

    /// The transform from diagram units to pixels.
    fn transform(&self) -> Transform {
        if self.y_up {
            Transform::from_row(
                self.scale,
                0.0,
                0.0,
                -self.scale,
                self.ox - self.min[0] * self.scale,
                self.oy + self.plot_h + self.min[1] * self.scale,
            )
        } else {
            Transform::from_row(
                self.scale,
                0.0,
                0.0,
                self.scale,
                self.ox - self.min[0] * self.scale,
                self.oy - self.min[1] * self.scale,
            )
        }
    }

    /// Pixel position of a point in diagram units.
    pub(crate) fn to_px(&self, p: [f32; 2]) -> [f32; 2] {
        let x = self.ox + (p[0] - self.min[0]) * self.scale;
        let y = if self.y_up {
            self.oy + self.plot_h - (p[1] - self.min[1]) * self.scale
        } else {
            self.oy + (p[1] - self.min[1]) * self.scale
        };
        [x, y]
    }

    /// Draws `base` stretched over the units rectangle `[min, max]` (bilinear filtering).
    pub(crate) fn background(&mut self, base: &Pixmap, min: [f32; 2], max: [f32; 2]) {
        let (bw, bh) = (base.width() as f32, base.height() as f32);
        let sx = (max[0] - min[0]) / bw;
        let sy = (max[1] - min[1]) / bh;
        let (y0, sy) = if self.y_up {
            (max[1], -sy)
        } else {
            (min[1], sy)
        };
        let t = self
            .transform()
            .pre_concat(Transform::from_row(sx, 0.0, 0.0, sy, min[0], y0));
        let p = PixmapPaint {
            quality: FilterQuality::Bilinear,
            ..PixmapPaint::default()
        };
        self.pixmap
            .draw_pixmap(0, 0, base.as_ref(), &p, t, self.clip.as_ref());
    }

    /// Fills a polygon given in diagram units.
    pub(crate) fn fill_polygon(&mut self, pts: &[[f32; 2]], color: Color) {
        let Some(path) = self.path(pts, true) else {
            return;
        };
        self.pixmap.fill_path(
            &path,
            &paint(color),
            FillRule::Winding,
            Transform::identity(),
            self.clip.as_ref(),
        );
    }

    /// Strokes a polyline given in diagram units, `width` pixels wide, dashed if `dash`.
    pub(crate) fn stroke(
        &mut self,
        pts: &[[f32; 2]],
        closed: bool,
        color: Color,
        width: f32,
        dash: bool,
    ) {
        let Some(path) = self.path(pts, closed) else {
            return;
        };
        let stroke = Stroke {
            width,
            dash: if dash {
                StrokeDash::new(vec![5.0, 4.0], 0.0)
            } else {
                None
            },
            ..Stroke::default()
        };
        self.pixmap.stroke_path(
            &path,
            &paint(color),
            &stroke,
            Transform::identity(),
            self.clip.as_ref(),
        );
    }

    fn path(&self, pts: &[[f32; 2]], closed: bool) -> Option<tiny_skia::Path> {
        let mut pb = PathBuilder::new();
        let mut it = pts.iter();
        let first = self.to_px(*it.next()?);
        pb.move_to(first[0], first[1]);
        for p in it {
            let q = self.to_px(*p);
            pb.line_to(q[0], q[1]);
        }
        if closed {
            pb.close();
        }
        pb.finish()
    }

    /// Fills the axis-aligned rectangle `[a, b]` in diagram units.
    pub(crate) fn fill_rect(&mut self, a: [f32; 2], b: [f32; 2], color: Color) {
        self.fill_polygon(&[a, [b[0], a[1]], b, [a[0], b[1]]], color);
    }

    /// Strokes the axis-aligned rectangle `[a, b]`.
    pub(crate) fn stroke_rect(
        &mut self,
        a: [f32; 2],
        b: [f32; 2],
        color: Color,
        width: f32,
        dash: bool,
    ) {
        self.stroke(
            &[a, [b[0], a[1]], b, [a[0], b[1]]],
            true,
            color,
            width,
            dash,
        );
    }

    /// A circle of `radius` diagram units: filled and/or stroked (`width` pixels, dashed).
    pub(crate) fn circle(
        &mut self,
        c: [f32; 2],
        radius: f32,
        fill: Option<Color>,
        stroke: Option<(Color, f32, bool)>,
    ) {
        let p = self.to_px(c);
        let Some(path) = PathBuilder::from_circle(p[0], p[1], (radius * self.scale).max(0.5))
        else {
            return;
        };
        if let Some(f) = fill {
            self.pixmap.fill_path(
                &path,
                &paint(f),
                FillRule::Winding,
                Transform::identity(),
                self.clip.as_ref(),
            );
        }
        if let Some((color, width, dash)) = stroke {
            let s = Stroke {
                width,
                dash: if dash {
                    StrokeDash::new(vec![6.0, 4.0], 0.0)
                } else {
                    None
                },
                ..Stroke::default()
            };
            self.pixmap.stroke_path(
                &path,
                &paint(color),
                &s,
                Transform::identity(),
                self.clip.as_ref(),
            );
        }
    }

    /// A dot of `radius_px` pixels.
    pub(crate) fn dot(&mut self, c: [f32; 2], radius_px: f32, color: Color) {
        let p = self.to_px(c);
        if let Some(path) = PathBuilder::from_circle(p[0], p[1], radius_px) {
            self.pixmap.fill_path(
                &path,
                &paint(color),
                FillRule::Winding,
                Transform::identity(),
                self.clip.as_ref(),
            );
        }
    }

    /// Text centred on a point in diagram units.
    pub(crate) fn label_centered(&mut self, c: [f32; 2], text: &str, size: f32, rgb: [u8; 3]) {
        let p = self.to_px(c);
        let w = text_width(text, size);
        draw_text(
            &mut self.pixmap,
            text,
            p[0] - w / 2.0,
            p[1] - size * 0.6,
            size,
            rgb,
        );
    }

    /// Text with its top-left corner at a point in diagram units.
    pub(crate) fn label(&mut self, c: [f32; 2], text: &str, size: f32, rgb: [u8; 3]) {
        let p = self.to_px(c);
        draw_text(&mut self.pixmap, text, p[0], p[1], size, rgb);
    }

    /// One legend row of swatches and their descriptions (ignored when the legend is off).
    fn legend_row(&mut self, entries: &[(Color, &str)]) {
        if !self.legend {
            return;
        }
        let mut x = MARGIN;
        let y = self.legend_top;
        for (color, text) in entries {
            if let Some(r) = Rect::from_xywh(x, y + 3.0, 12.0, 12.0) {
                self.pixmap
                    .fill_rect(r, &paint(*color), Transform::identity(), None);
                let path = PathBuilder::from_rect(r);
                let s = Stroke {
                    width: 1.0,
                    ..Stroke::default()
                };
                self.pixmap.stroke_path(
                    &path,
                    &paint(rgba(BLACK, 0.6)),
                    &s,
                    Transform::identity(),
                    None,
                );
            }
            draw_text(&mut self.pixmap, text, x + 16.0, y + 2.0, LABEL, BLACK);
            x += 16.0 + text_width(text, LABEL) + 14.0;
        }
        self.legend_top += LEGEND_ROW;
    }

    /// Fills the parts of the rectangle `[a, b]` that none of `polys` covers (rasterised
    /// without anti-aliasing, so shared edges leave no seams).
    pub(crate) fn fill_uncovered(
        &mut self,
        polys: &[Vec<[f32; 2]>],
        a: [f32; 2],
        b: [f32; 2],
        color: Color,
    ) {
        let Some(mut mask) = tiny_skia::Mask::new(self.pixmap.width(), self.pixmap.height()) else {
            return;
        };
        for poly in polys {
            if let Some(path) = self.path(poly, true) {
                mask.fill_path(&path, FillRule::Winding, false, Transform::identity());
            }
        }
        mask.invert();
        let Some(path) = self.path(&[a, [b[0], a[1]], b, [a[0], b[1]]], true) else {
            return;
        };
        self.pixmap.fill_path(
            &path,
            &paint(color),
            FillRule::Winding,
            Transform::identity(),
            Some(&mask),
        );
    }

    /// The finished picture.
    pub(crate) fn finish(self) -> Pixmap {
        self.pixmap
    }
}
