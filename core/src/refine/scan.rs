//! Full-grid vertical error scan of a mesh whose vertices are grid samples (CONVENTIONS.md,
//! "Mesh vertical error"): every triangle's samples are rasterised exactly and compared with the
//! triangle's plane, `max |h(sample) - mesh(x, y)|`, and every sample must be covered.

use super::raster::{for_each_span, Plane};
use crate::{Error, Terrain};

/// Length of the `u64` coverage bitmap [`vertical_error`] needs: `ceil(width * height / 64)`.
///
/// ```
/// assert_eq!(relief_core::refine::coverage_len(10, 10), 2);
/// ```
#[must_use]
pub const fn coverage_len(width: u32, height: u32) -> usize {
    super::hierarchy_len(width, height).div_ceil(64)
}

/// The mesh's vertical error: the maximum over all grid samples of `|h(sample) - mesh(x, y)|`
/// in world z units, where `mesh(x, y)` is the plane of the triangle covering the sample
/// (the largest when a sample lies on several). Loops over every triangle's bounding rows.
///
/// Vertices are world positions and must sit on grid samples (`x / dx` and `y / dy` within
/// `1e-3` of an integer in the grid: [`Error::InvalidParameter`] otherwise); their `z` is used
/// as given (minus `z_offset`, in `f64`), so the scan measures the mesh actually output. A
/// sample that no triangle covers is [`Error::OutOfBounds`] (the mesh has a gap); a triangle
/// index beyond `vertices` is [`Error::BufferTooSmall`]. `coverage` needs [`coverage_len`]
/// words.
///
/// ```
/// use relief_core::refine::{coverage_len, vertical_error};
/// use relief_core::{Error, Heightfield};
/// let hf = Heightfield::new(&[0.0f32, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0], 3, 3).unwrap();
/// let v = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 2.0, 0.0], [0.0, 2.0, 0.0]];
/// let t = [[0, 1, 2], [0, 2, 3]];
/// let mut cov = vec![0u64; coverage_len(3, 3)];
/// assert_eq!(vertical_error(&hf, &v, &t, &mut cov), Ok(2.0));
/// // One triangle only: half the grid is not covered.
/// assert!(matches!(vertical_error(&hf, &v, &t[..1], &mut cov), Err(Error::OutOfBounds { .. })));
/// ```
pub fn vertical_error<T: Terrain>(
    terrain: &T,
    vertices: &[[f32; 3]],
    triangles: &[[u32; 3]],
    coverage: &mut [u64],
) -> Result<f64, Error> {
    let (max, uncovered) = vertical_error_partial(terrain, vertices, triangles, coverage)?;
    match uncovered {
        None => Ok(max),
        Some((x, y, _)) => Err(Error::OutOfBounds { x, y }),
    }
}

/// The first sample no triangle covers, `(x, y)`, and how many are uncovered; `None` when the
/// mesh covers the whole grid.
///
/// ```
/// let u: relief_core::refine::Uncovered = Some((0, 1, 1));
/// assert_eq!(u.map(|(_, _, n)| n), Some(1));
/// ```
pub type Uncovered = Option<(u32, u32, usize)>;

/// [`vertical_error`] for meshes with holes (view-dependent meshes with culling): the maximum
/// over the samples the mesh covers, and the first uncovered sample `(x, y)` with the number of
/// uncovered samples (`None` when the mesh covers the whole grid).
///
/// ```
/// use relief_core::refine::{coverage_len, vertical_error_partial};
/// use relief_core::Heightfield;
/// let hf = Heightfield::new(&[0.0f32, 0.0, 0.0, 3.0], 2, 2).unwrap();
/// let v = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 3.0], [0.0, 1.0, 0.0]];
/// let mut cov = vec![0u64; coverage_len(2, 2)];
/// let r = vertical_error_partial(&hf, &v, &[[0, 1, 2]], &mut cov).unwrap();
/// assert_eq!(r, (0.0, Some((0, 1, 1))));
/// ```
pub fn vertical_error_partial<T: Terrain>(
    terrain: &T,
    vertices: &[[f32; 3]],
    triangles: &[[u32; 3]],
    coverage: &mut [u64],
) -> Result<(f64, Uncovered), Error> {
    // Grids have at least 2 x 2 samples; the max keeps a division-by-zero panic path out.
    let (w, h) = (terrain.width().max(1) as usize, terrain.height() as usize);
    let n = w * h;
    let words = n.div_ceil(64);
    if coverage.len() < words {
        return Err(Error::BufferTooSmall {
            needed: words,
            actual: coverage.len(),
        });
    }
    let cov = coverage.get_mut(..words).unwrap_or(&mut []);
    cov.fill(0);
    let s = terrain.scale();
    let off = s.z_offset as f64;
    let grid_point = |v: &[f32; 3]| -> Result<(i64, i64, f64), Error> {
        let gx = v[0] as f64 / s.dx as f64;
        let gy = v[1] as f64 / s.dy as f64;
        let (rx, ry) = (libm::round(gx), libm::round(gy));
        let on_grid = (gx - rx).abs() <= 1e-3 && (gy - ry).abs() <= 1e-3;
        let inside = rx >= 0.0 && ry >= 0.0 && rx < w as f64 && ry < h as f64;
        if !(on_grid && inside && v[2].is_finite()) {
            return Err(Error::InvalidParameter {
                name: "mesh vertex (not on a grid sample)",
                value: v[0],
            });
        }
        Ok((rx as i64, ry as i64, v[2] as f64 - off))
    };
    let mut max = 0.0f64;
    for t in triangles {
        let mut p = [(0i64, 0i64, 0.0f64); 3];
        for (o, &i) in p.iter_mut().zip(t.iter()) {
            let v = vertices.get(i as usize).ok_or(Error::BufferTooSmall {
                needed: i as usize + 1,
                actual: vertices.len(),
            })?;
            *o = grid_point(v)?;
        }
        let Some(plane) = Plane::new(p) else {
            continue; // degenerate: covers no area
        };
        for_each_span(
            (p[0].0, p[0].1),
            (p[1].0, p[1].1),
            (p[2].0, p[2].1),
            |y, lo, hi| {
                for x in lo..=hi {
                    let i = y as usize * w + x as usize;
                    if let Some(word) = cov.get_mut(i >> 6) {
                        *word |= 1u64 << (i & 63);
                    }
                    let hz = terrain.local_z(x as u32, y as u32) as f64;
                    let d = (hz - plane.at(x, y)).abs();
                    if d > max {
                        max = d;
                    }
                }
            },
        );
    }
    let mut first = None;
    let mut missing = 0usize;
    for (wi, &word) in cov.iter().enumerate() {
        let top = (n - wi * 64).min(64);
        let full = if top == 64 {
            u64::MAX
        } else {
            (1u64 << top) - 1
        };
        if word != full {
            let gap = !word & full;
            missing += gap.count_ones() as usize;
            if first.is_none() {
                let k = wi * 64 + gap.trailing_zeros() as usize;
                first = Some(((k % w) as u32, (k / w) as u32));
            }
        }
    }
    Ok((max, first.map(|(x, y)| (x, y, missing))))
}
