//! Helpers shared by the `rays` fuzz target (`fuzz/fuzz_targets/rays.rs`) and the ray tests
//! that replay its inputs (`tests/tests/rays_packet.rs`): the input's decoding, and the grid
//! vertices a ray passes within a rounding unit of.

use relief_core::glam::{DVec3, Vec3};
use relief_core::Surface;

/// A `rays` fuzz input, decoded.
#[derive(Debug, Clone, PartialEq)]
pub struct RaysInput {
    /// Grid width in samples (2 to 13).
    pub w: u32,
    /// Grid height in samples (2 to 13).
    pub h: u32,
    /// The surface traced.
    pub surface: Surface,
    /// The ray's origin (any `f32` values, non-finite ones included).
    pub origin: Vec3,
    /// The ray's direction (any `f32` values, zero and non-finite ones included).
    pub dir: Vec3,
    /// The samples, row-major, `w * h` of them (bytes from offset 28, less 100; 0 past the end).
    pub samples: Vec<f32>,
}

impl RaysInput {
    /// Decodes `data` as the `rays` target does, or `None` for fewer than 40 bytes.
    ///
    /// ```
    /// use relief_tests::ray_check::RaysInput;
    /// let mut data = vec![0u8; 40];
    /// data[0] = 4;
    /// let input = RaysInput::decode(&data).unwrap();
    /// assert_eq!((input.w, input.h, input.samples.len()), (6, 2, 12));
    /// assert!(RaysInput::decode(&data[..39]).is_none());
    /// ```
    pub fn decode(data: &[u8]) -> Option<RaysInput> {
        if data.len() < 40 {
            return None;
        }
        let f = |i: usize| {
            f32::from_le_bytes([0, 1, 2, 3].map(|k| data.get(i + k).copied().unwrap_or(0)))
        };
        let (w, h) = (u32::from(data[0] % 12) + 2, u32::from(data[1] % 12) + 2);
        let surface = [
            Surface::Triangles,
            Surface::Bilinear,
            Surface::Plane,
            Surface::Nearest,
        ][usize::from(data[2] % 4)];
        let samples = (0..w * h)
            .map(|i| f32::from(data.get(28 + i as usize).copied().unwrap_or(0)) - 100.0)
            .collect();
        Some(RaysInput {
            w,
            h,
            surface,
            origin: Vec3::new(f(4), f(8), f(12)),
            dir: Vec3::new(f(16), f(20), f(24)),
            samples,
        })
    }
}

/// The grid vertices (of a `w x h` grid with unit spacing at the origin) that the horizontal
/// line of the ray from `o` along `d` passes ahead of `o` within a rounding unit of: a distance
/// below 1e-12 of the vertex's and the origin's magnitude (plus one), far below any ray not
/// aimed at the vertex. The sixteen-wide walk may test one cell more than the neighbour walk
/// for each (`core/src/ray/wide.rs`).
///
/// ```
/// use relief_core::glam::DVec3;
/// use relief_tests::ray_check::corner_passes;
/// let o = DVec3::new(-0.5, -0.5, 3.0);
/// // Along the diagonal through (0, 0), (1, 1), (2, 2) of a 3 x 3 grid.
/// assert_eq!(corner_passes(o, DVec3::new(1.0, 1.0, -1.0), 3, 3), 3);
/// assert_eq!(corner_passes(o, DVec3::new(1.0, 0.9, -1.0), 3, 3), 0);
/// ```
pub fn corner_passes(o: DVec3, d: DVec3, w: u32, h: u32) -> usize {
    let len = d.x.hypot(d.y);
    if len == 0.0 {
        return 0;
    }
    let (ux, uy) = (d.x / len, d.y / len);
    let mut n = 0;
    for j in 0..h {
        for i in 0..w {
            let (vx, vy) = (f64::from(i) - o.x, f64::from(j) - o.y);
            let dist = (vx * uy - vy * ux).abs();
            let ahead = vx * ux + vy * uy >= 0.0;
            if ahead && dist <= 1e-12 * (1.0 + f64::from(i.max(j)) + o.x.abs().max(o.y.abs())) {
                n += 1;
            }
        }
    }
    n
}
