//! Labels: glyphs of the bundled DejaVu Sans (Bitstream Vera licence, `assets/fonts/`)
//! rasterised by `ab_glyph` and blended source-over into the pixmap.

use ab_glyph::{point, Font, FontRef, PxScale, ScaleFont};
use tiny_skia::{Pixmap, PremultipliedColorU8};

static FONT_BYTES: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");

fn font() -> Option<FontRef<'static>> {
    FontRef::try_from_slice(FONT_BYTES).ok()
}

/// Width in pixels of `text` set at `size` pixels (0 if the font cannot be read).
///
/// ```
/// let w = relief_skia::text_width("run 3/41", 12.0);
/// assert!(w > 30.0 && w < 80.0);
/// assert_eq!(relief_skia::text_width("", 12.0), 0.0);
/// ```
#[must_use]
pub fn text_width(text: &str, size: f32) -> f32 {
    let Some(f) = font() else { return 0.0 };
    let s = f.as_scaled(PxScale::from(size));
    let mut w = 0.0;
    let mut prev = None;
    for c in text.chars() {
        let g = s.glyph_id(c);
        if let Some(p) = prev {
            w += s.kern(p, g);
        }
        w += s.h_advance(g);
        prev = Some(g);
    }
    w
}

/// Draws `text` with its top-left corner at pixel `(x, y)`, `size` pixels high, in colour `rgb`
/// (opaque). Pixels outside the pixmap are skipped.
///
/// ```
/// let mut p = relief_skia::Pixmap::new(80, 20).unwrap();
/// relief_skia::draw_text(&mut p, "Hello", 2.0, 2.0, 14.0, [0, 0, 0]);
/// assert!(p.pixels().iter().any(|c| c.alpha() > 0));
/// ```
pub fn draw_text(pixmap: &mut Pixmap, text: &str, x: f32, y: f32, size: f32, rgb: [u8; 3]) {
    let Some(f) = font() else { return };
    let s = f.as_scaled(PxScale::from(size));
    let baseline = y + s.ascent();
    let (w, h) = (pixmap.width() as i64, pixmap.height() as i64);
    let pixels = pixmap.pixels_mut();
    let mut pen = x;
    let mut prev = None;
    for c in text.chars() {
        let id = s.glyph_id(c);
        if let Some(p) = prev {
            pen += s.kern(p, id);
        }
        let glyph = id.with_scale_and_position(PxScale::from(size), point(pen, baseline));
        pen += s.h_advance(id);
        prev = Some(id);
        let Some(outline) = f.outline_glyph(glyph) else {
            continue;
        };
        let b = outline.px_bounds();
        outline.draw(|gx, gy, cov| {
            let px = b.min.x as i64 + gx as i64;
            let py = b.min.y as i64 + gy as i64;
            if px < 0 || py < 0 || px >= w || py >= h {
                return;
            }
            let Some(dst) = pixels.get_mut((py * w + px) as usize) else {
                return;
            };
            *dst = blend(*dst, rgb, cov.clamp(0.0, 1.0));
        });
    }
}

/// Source-over of an opaque colour at coverage `a` onto a premultiplied pixel.
fn blend(dst: PremultipliedColorU8, rgb: [u8; 3], a: f32) -> PremultipliedColorU8 {
    let mix = |s: u8, d: u8| (f32::from(s) * a + f32::from(d) * (1.0 - a)).round() as u8;
    let out_a = (255.0 * a + f32::from(dst.alpha()) * (1.0 - a)).round() as u8;
    let r = mix(rgb[0], dst.red()).min(out_a);
    let g = mix(rgb[1], dst.green()).min(out_a);
    let b = mix(rgb[2], dst.blue()).min(out_a);
    PremultipliedColorU8::from_rgba(r, g, b, out_a).unwrap_or(dst)
}
