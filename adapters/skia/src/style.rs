//! Colours: the Okabe-Ito palette (Okabe & Ito, *Color Universal Design*, 2008), distinguishable
//! with protanopia, deuteranopia and tritanopia, and the viridis colour map (van der Walt & Smith,
//! matplotlib 2015) for scalar fields, perceptually uniform and readable in grey.

use tiny_skia::Color;

/// Okabe-Ito black.
pub const BLACK: [u8; 3] = [0, 0, 0];
/// Okabe-Ito orange.
pub const ORANGE: [u8; 3] = [230, 159, 0];
/// Okabe-Ito sky blue.
pub const SKY_BLUE: [u8; 3] = [86, 180, 233];
/// Okabe-Ito bluish green.
pub const BLUISH_GREEN: [u8; 3] = [0, 158, 115];
/// Okabe-Ito yellow.
pub const YELLOW: [u8; 3] = [240, 228, 66];
/// Okabe-Ito blue.
pub const BLUE: [u8; 3] = [0, 114, 178];
/// Okabe-Ito vermillion.
pub const VERMILLION: [u8; 3] = [213, 94, 0];
/// Okabe-Ito reddish purple.
pub const REDDISH_PURPLE: [u8; 3] = [204, 121, 167];
/// Light grey for grids.
pub const GRID_GREY: [u8; 3] = [200, 200, 200];

/// The eight Okabe-Ito colours in their usual order.
///
/// ```
/// assert_eq!(relief_skia::style::OKABE_ITO.len(), 8);
/// assert_eq!(relief_skia::style::OKABE_ITO[1], relief_skia::style::ORANGE);
/// ```
pub const OKABE_ITO: [[u8; 3]; 8] = [
    BLACK,
    ORANGE,
    SKY_BLUE,
    BLUISH_GREEN,
    YELLOW,
    BLUE,
    VERMILLION,
    REDDISH_PURPLE,
];

/// A `tiny_skia::Color` from an RGB triple and an opacity in `[0, 1]`.
///
/// ```
/// let c = relief_skia::style::rgba(relief_skia::style::BLUE, 0.5);
/// assert!((c.alpha() - 0.5).abs() < 0.01); // stored as 8 bits
/// ```
#[must_use]
pub fn rgba(rgb: [u8; 3], alpha: f32) -> Color {
    let a = (alpha.clamp(0.0, 1.0) * 255.0).round() as u8;
    Color::from_rgba8(rgb[0], rgb[1], rgb[2], a)
}

/// Viridis control points at `t = 0, 1/8, ..., 1` (matplotlib's table, every 32nd entry).
const VIRIDIS: [[f32; 3]; 9] = [
    [0.267004, 0.004874, 0.329415],
    [0.278826, 0.175490, 0.483397],
    [0.229739, 0.322361, 0.545706],
    [0.172719, 0.448791, 0.557885],
    [0.127568, 0.566949, 0.550556],
    [0.157851, 0.683765, 0.501686],
    [0.369214, 0.788888, 0.382914],
    [0.678489, 0.863742, 0.189503],
    [0.993248, 0.906157, 0.143936],
];

/// The viridis colour of `t` in `[0, 1]` (clamped; NaN gives the low end), linearly interpolated
/// between nine control points of matplotlib's table.
///
/// ```
/// use relief_skia::style::viridis;
/// assert_eq!(viridis(0.0), [68, 1, 84]);
/// assert_eq!(viridis(1.0), [253, 231, 37]);
/// assert_eq!(viridis(f32::NAN), viridis(0.0));
/// ```
#[must_use]
pub fn viridis(t: f32) -> [u8; 3] {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let s = t * 8.0;
    let i = (s.floor() as usize).min(7);
    let f = s - i as f32;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    let mut out = [0u8; 3];
    for k in 0..3 {
        out[k] = ((a[k] + (b[k] - a[k]) * f) * 255.0).round() as u8;
    }
    out
}
