//! The base layer of every map diagram: a hillshade lit by Lambert's law, from the normals the
//! core computes ([`relief_core::normal_map`]), one pixel per sample.

use crate::DiagramError;
use relief_core::{normal_map, NormalMethod, Terrain};
use tiny_skia::{Pixmap, PremultipliedColorU8};

/// Hillshade parameters.
///
/// Defaults: light from azimuth 315 degrees (north-west, where north is row 0, the top of the
/// picture) at 45 degrees above the horizon, central-difference normals, ambient level 0.35.
///
/// ```
/// let o = relief_skia::HillshadeOptions::default().with_light(270.0, 30.0).with_ambient(0.2);
/// assert_eq!((o.azimuth_deg, o.altitude_deg, o.ambient), (270.0, 30.0, 0.2));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HillshadeOptions {
    /// Direction the light comes from, degrees clockwise from north (row 0, up in the picture).
    pub azimuth_deg: f32,
    /// Light elevation above the horizon in degrees.
    pub altitude_deg: f32,
    /// Brightness of a face turned away from the light, in `[0, 1]`.
    pub ambient: f32,
    /// How the core computes the normals.
    pub method: NormalMethod,
}

impl Default for HillshadeOptions {
    fn default() -> Self {
        HillshadeOptions {
            azimuth_deg: 315.0,
            altitude_deg: 45.0,
            ambient: 0.35,
            method: NormalMethod::Central,
        }
    }
}

impl HillshadeOptions {
    /// Sets the light direction (default azimuth 315, altitude 45 degrees).
    ///
    /// ```
    /// assert_eq!(relief_skia::HillshadeOptions::default().with_light(0.0, 60.0).altitude_deg, 60.0);
    /// ```
    #[must_use]
    pub fn with_light(mut self, azimuth_deg: f32, altitude_deg: f32) -> Self {
        self.azimuth_deg = azimuth_deg;
        self.altitude_deg = altitude_deg;
        self
    }

    /// Sets the ambient level (default 0.35).
    ///
    /// ```
    /// assert_eq!(relief_skia::HillshadeOptions::default().with_ambient(0.5).ambient, 0.5);
    /// ```
    #[must_use]
    pub fn with_ambient(mut self, ambient: f32) -> Self {
        self.ambient = ambient;
        self
    }
}

/// A grey hillshade of `terrain`, one opaque pixel per sample (pixel `(x, y)` is sample
/// `(x, y)`): brightness `ambient + (1 - ambient) max(0, n . l)` with the core's normal `n`.
/// Pass it as [`crate::DiagramOptions::background`] to draw a diagram over the terrain.
///
/// Errors: [`DiagramError::InvalidParameter`] for non-finite light angles or an ambient level
/// outside `[0, 1]`; [`DiagramError::Size`] for a terrain too large for a pixmap.
///
/// ```
/// use relief_core::Heightfield;
/// use relief_skia::{hillshade, HillshadeOptions};
/// // A ramp rising to the east (+x) faces west, away from a light in the east.
/// let s: Vec<f32> = (0..16).map(|i| (i % 4) as f32).collect();
/// let hf = Heightfield::new(&s, 4, 4).unwrap();
/// let east = hillshade(&hf, &HillshadeOptions::default().with_light(90.0, 45.0)).unwrap();
/// let west = hillshade(&hf, &HillshadeOptions::default().with_light(270.0, 45.0)).unwrap();
/// assert!(east.pixel(1, 1).unwrap().red() < west.pixel(1, 1).unwrap().red());
/// ```
pub fn hillshade<T: Terrain + ?Sized>(
    terrain: &T,
    options: &HillshadeOptions,
) -> Result<Pixmap, DiagramError> {
    let o = options;
    if !(o.azimuth_deg.is_finite() && o.altitude_deg.is_finite()) {
        return Err(DiagramError::InvalidParameter {
            name: "light",
            reason: "azimuth and altitude must be finite",
        });
    }
    if !(0.0..=1.0).contains(&o.ambient) {
        return Err(DiagramError::InvalidParameter {
            name: "ambient",
            reason: "must lie in [0, 1]",
        });
    }
    let (w, h) = (terrain.width(), terrain.height());
    let mut pixmap = Pixmap::new(w, h).ok_or(DiagramError::Size {
        width: w,
        height: h,
    })?;
    let mut normals = vec![glam::Vec3::Z; w as usize * h as usize];
    normal_map(terrain, o.method, &mut normals)?;
    // North is -y (row 0 at the top); azimuth clockwise from north, so east is +x.
    let (az, alt) = (o.azimuth_deg.to_radians(), o.altitude_deg.to_radians());
    let light = glam::Vec3::new(az.sin() * alt.cos(), -az.cos() * alt.cos(), alt.sin());
    for (px, n) in pixmap.pixels_mut().iter_mut().zip(&normals) {
        let lum = o.ambient + (1.0 - o.ambient) * n.dot(light).max(0.0);
        let g = (lum.clamp(0.0, 1.0) * 255.0).round() as u8;
        if let Some(c) = PremultipliedColorU8::from_rgba(g, g, g, 255) {
            *px = c;
        }
    }
    Ok(pixmap)
}
