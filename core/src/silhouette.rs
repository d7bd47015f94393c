//! The silhouette map of Sakalauskas, *Silhouette Partitioning for Height Field Ray Tracing*
//! (seed 000), sections 4.1.2-4.1.4, on the CPU: for every row `v` of the elevation map and every
//! screen column `x`, the screen height `y` and the map coordinate `u` where the row's projected
//! polyline crosses the column (the bottom level of the silhouette partitioning tree, the paper's
//! `X x V` texture with `y` in R and `u` in G), and the upper envelopes of row ranges that form
//! the tree's higher levels (`S = max(A, B)`, section 4.1.5). A reference and a debugging aid for
//! the GPU passes; the binary-search ray tracing itself is not here.
//!
//! Screen coordinates follow [`Camera::ray`]: `x` in pixels from the left edge (column `i`'s
//! centre at `i + 0.5`), `y` in pixels up from the bottom edge, so a larger `y` is higher on the
//! screen and the silhouette of several rows is their maximum. Each row is the polyline through
//! its samples' world positions; a segment with an end closer than `near` along the view
//! direction is skipped. Along a segment, `u` and `y` are interpolated linearly in screen `x`,
//! as the paper's `InterpolateU` does. Where several segments of a row cover a column (the row
//! folds back on the screen), the highest wins. A column no segment covers holds
//! [`SilhouetteTexel::EMPTY`].

use crate::{Camera, Error, Terrain};
use glam::Vec3;

/// One texel of the silhouette map: screen height `y` (pixels up from the bottom) and map
/// column `u` (grid units) where the row crosses the column.
///
/// ```
/// use relief_core::silhouette::SilhouetteTexel;
/// assert!(SilhouetteTexel::EMPTY.is_empty());
/// assert!(!SilhouetteTexel { y: 3.0, u: 1.5 }.is_empty());
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SilhouetteTexel {
    /// Screen height in pixels, up from the bottom edge; `-inf` where the row does not cover the
    /// column.
    pub y: f32,
    /// Map column in grid units (`0 ..= width - 1`); `-1` where the row does not cover the column.
    pub u: f32,
}

impl SilhouetteTexel {
    /// A column the row does not cover.
    pub const EMPTY: SilhouetteTexel = SilhouetteTexel {
        y: f32::NEG_INFINITY,
        u: -1.0,
    };

    /// Whether no segment of the row covers this column.
    ///
    /// ```
    /// assert!(relief_core::silhouette::SilhouetteTexel::EMPTY.is_empty());
    /// ```
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.y == f32::NEG_INFINITY
    }
}

impl Default for SilhouetteTexel {
    fn default() -> Self {
        SilhouetteTexel::EMPTY
    }
}

/// Texels of a silhouette map: `screen_width * rows` (row-major, one map row per elevation row),
/// `None` on overflow.
///
/// ```
/// assert_eq!(relief_core::silhouette::silhouette_map_len(640, 1025), Some(640 * 1025));
/// ```
#[must_use]
pub const fn silhouette_map_len(screen_width: u32, rows: u32) -> Option<usize> {
    (screen_width as usize).checked_mul(rows as usize)
}

/// Screen position `(x, y)` of world point `p` (pixels; `y` up from the bottom) and its depth
/// along the view direction.
fn project(camera: &Camera, p: Vec3) -> (f32, f32, f32) {
    let (f, r, u) = camera.basis();
    let d = p - camera.eye;
    let depth = d.dot(f);
    let s = camera.tan_half_fov();
    let (w, h) = (camera.width as f32, camera.height as f32);
    let a = w / h;
    let px = d.dot(r) / (depth * a * s);
    let py = d.dot(u) / (depth * s);
    ((px + 1.0) * 0.5 * w, (py + 1.0) * 0.5 * h, depth)
}

/// Fills `out` (at least [`silhouette_map_len`]`(camera.width, terrain.height())` texels) with
/// the silhouette map of `terrain` seen by `camera`: texel `v * camera.width + x` is where row
/// `v` crosses screen column `x` (module docs). Work: at most `(width - 1) * height` segments,
/// each writing at most `camera.width` texels.
///
/// Errors: [`Error::InvalidParameter`] for a `near` that is not finite and positive,
/// [`Error::BufferTooSmall`] for a short `out`, [`Error::SizeOverflow`] if the size overflows.
///
/// ```
/// use relief_core::silhouette::{silhouette_map, silhouette_map_len, SilhouetteTexel};
/// use relief_core::{Camera, Heightfield};
/// use glam::Vec3;
/// let hf = Heightfield::new(&[0.0f32; 16], 4, 4).unwrap();
/// // Looking along +y from above the first row: every row is a horizontal line on screen.
/// let cam = Camera::new(Vec3::new(1.5, -4.0, 3.0), Vec3::new(1.5, 3.0, 0.0), 60.0, 32, 24).unwrap();
/// let mut map = vec![SilhouetteTexel::EMPTY; silhouette_map_len(32, 4).unwrap()];
/// silhouette_map(&hf, &cam, 0.01, &mut map).unwrap();
/// let centre = |v: usize| map[v * 32 + 16];
/// assert!(centre(0).y < centre(3).y); // farther rows of a plane below the eye are higher
/// assert!((centre(2).u - 1.5).abs() < 0.25); // a column next to the centre: the middle
/// ```
pub fn silhouette_map<T: Terrain + ?Sized>(
    terrain: &T,
    camera: &Camera,
    near: f32,
    out: &mut [SilhouetteTexel],
) -> Result<(), Error> {
    if !(near.is_finite() && near > 0.0) {
        return Err(Error::InvalidParameter {
            name: "near",
            value: near,
        });
    }
    let (w, h) = (terrain.width(), terrain.height());
    let sw = camera.width;
    let needed = silhouette_map_len(sw, h).ok_or(Error::SizeOverflow)?;
    let actual = out.len();
    let out = out
        .get_mut(..needed)
        .ok_or(Error::BufferTooSmall { needed, actual })?;
    out.fill(SilhouetteTexel::EMPTY);
    if sw == 0 {
        return Ok(());
    }
    for (v, row) in out.chunks_exact_mut(sw as usize).enumerate() {
        let v = v as u32;
        let Some(mut prev) = terrain.position(0, v).map(|p| project(camera, p)) else {
            continue;
        };
        for u in 1..w {
            let Some(p) = terrain.position(u, v) else {
                break;
            };
            let cur = project(camera, p);
            let (a, b) = (prev, cur);
            prev = cur;
            if !(a.2 >= near && b.2 >= near) {
                continue;
            }
            let (x0, x1) = (a.0.min(b.0), a.0.max(b.0));
            if !(x0.is_finite() && x1.is_finite()) {
                continue;
            }
            // Columns whose centre i + 0.5 lies in [x0, x1].
            let first = libm::ceilf(x0 - 0.5).max(0.0);
            let last = libm::floorf(x1 - 0.5).min(sw as f32 - 1.0);
            if first > last {
                continue;
            }
            let (first, last) = (first as u32, last as u32);
            for i in first..=last {
                let xc = i as f32 + 0.5;
                let dx = b.0 - a.0;
                let t = if dx != 0.0 {
                    ((xc - a.0) / dx).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let y = a.1 + (b.1 - a.1) * t;
                let uu = (u - 1) as f32 + t;
                if let Some(texel) = row.get_mut(i as usize) {
                    if y > texel.y {
                        *texel = SilhouetteTexel { y, u: uu };
                    }
                }
            }
        }
    }
    Ok(())
}

/// Rows `[start, end)` of node `k` at level `level` of the silhouette partitioning tree over
/// `rows` elevation rows: the root (level 0) covers every row, each level halves the span
/// (rounded up). `None` past the last node or for `level >= 32`.
///
/// ```
/// use relief_core::silhouette::tree_node_rows;
/// assert_eq!(tree_node_rows(8, 0, 0), Some((0, 8)));
/// assert_eq!(tree_node_rows(8, 2, 3), Some((6, 8)));
/// assert_eq!(tree_node_rows(5, 1, 1), Some((3, 5)));
/// assert_eq!(tree_node_rows(8, 2, 4), None);
/// ```
#[must_use]
pub fn tree_node_rows(rows: u32, level: u32, k: u32) -> Option<(u32, u32)> {
    if level >= 32 {
        return None;
    }
    let span = (u64::from(rows) + (1u64 << level) - 1) >> level;
    let start = u64::from(k).checked_mul(span)?;
    if start >= u64::from(rows) || span == 0 {
        return None;
    }
    let end = (start + span).min(u64::from(rows));
    Some((start as u32, end as u32))
}

/// The silhouette of rows `[start, end)`: for every screen column the highest `y` of those rows
/// (their upper envelope, the tree's `max` of section 4.1.5), written to `out[..screen_width]`;
/// `-inf` where none of the rows covers the column.
///
/// Errors: [`Error::BufferTooSmall`] when `map` does not hold `end` rows or `out` is shorter than
/// `screen_width`; [`Error::InvalidParameter`] for `start > end`.
///
/// ```
/// use relief_core::silhouette::{silhouette_envelope, SilhouetteTexel};
/// let t = |y| SilhouetteTexel { y, u: 0.0 };
/// let map = [t(1.0), t(5.0), t(3.0), t(2.0)]; // 2 rows of 2 columns
/// let mut out = [0.0f32; 2];
/// silhouette_envelope(&map, 2, 0, 2, &mut out).unwrap();
/// assert_eq!(out, [3.0, 5.0]);
/// ```
pub fn silhouette_envelope(
    map: &[SilhouetteTexel],
    screen_width: u32,
    start: u32,
    end: u32,
    out: &mut [f32],
) -> Result<(), Error> {
    if start > end {
        return Err(Error::InvalidParameter {
            name: "start",
            value: start as f32,
        });
    }
    let sw = screen_width as usize;
    let needed = silhouette_map_len(screen_width, end).ok_or(Error::SizeOverflow)?;
    if map.len() < needed {
        return Err(Error::BufferTooSmall {
            needed,
            actual: map.len(),
        });
    }
    let actual = out.len();
    let out = out
        .get_mut(..sw)
        .ok_or(Error::BufferTooSmall { needed: sw, actual })?;
    out.fill(f32::NEG_INFINITY);
    if sw == 0 {
        return Ok(());
    }
    let rows = map
        .get(start as usize * sw..needed)
        .unwrap_or(&[])
        .chunks_exact(sw);
    for row in rows {
        for (o, t) in out.iter_mut().zip(row) {
            if t.y > *o {
                *o = t.y;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Heightfield;

    fn cam_along_y() -> Camera {
        Camera::new(
            Vec3::new(7.5, -10.0, 6.0),
            Vec3::new(7.5, 8.0, 0.0),
            50.0,
            64,
            48,
        )
        .unwrap()
    }

    #[test]
    fn flat_rows_are_exact_lines() {
        // Rows parallel to the image plane project affinely: u and y are exact.
        let hf = Heightfield::new(&[0.0f32; 16 * 9], 16, 9).unwrap();
        let cam = cam_along_y();
        let mut map = vec![SilhouetteTexel::EMPTY; silhouette_map_len(64, 9).unwrap()];
        silhouette_map(&hf, &cam, 0.01, &mut map).unwrap();
        for v in 0..9u32 {
            let row = &map[v as usize * 64..(v as usize + 1) * 64];
            let covered: Vec<&SilhouetteTexel> = row.iter().filter(|t| !t.is_empty()).collect();
            assert!(!covered.is_empty(), "row {v}");
            for (i, t) in row.iter().enumerate() {
                if t.is_empty() {
                    continue;
                }
                let p = Vec3::new(t.u, v as f32, 0.0);
                let (x, y, _) = project(&cam, p);
                assert!((x - (i as f32 + 0.5)).abs() < 1e-3, "row {v} col {i}: {x}");
                assert!((y - t.y).abs() < 1e-3);
                assert!((0.0..=15.0).contains(&t.u));
            }
        }
        // Farther rows of a plane below the eye lie higher on the screen.
        for v in 1..9usize {
            assert!(map[v * 64 + 32].y > map[(v - 1) * 64 + 32].y);
        }
    }

    #[test]
    fn a_ridge_hides_the_rows_behind_it_in_the_envelope() {
        let (w, h) = (16u32, 12u32);
        let s: Vec<f32> = (0..w * h)
            .map(|i| if i / w == 4 { 8.0 } else { 0.0 })
            .collect();
        let hf = Heightfield::new(&s, w, h).unwrap();
        let cam = cam_along_y();
        let mut map = vec![SilhouetteTexel::EMPTY; silhouette_map_len(64, h).unwrap()];
        silhouette_map(&hf, &cam, 0.01, &mut map).unwrap();
        let mut all = [0.0f32; 64];
        let mut ridge = [0.0f32; 64];
        silhouette_envelope(&map, 64, 0, h, &mut all).unwrap();
        silhouette_envelope(&map, 64, 4, 5, &mut ridge).unwrap();
        // The ridge row is the upper envelope of rows 0..=5 wherever it is visible.
        let mut near = [0.0f32; 64];
        silhouette_envelope(&map, 64, 0, 6, &mut near).unwrap();
        let mut checked = 0;
        for x in 0..64 {
            if ridge[x].is_finite() {
                assert_eq!(near[x], ridge[x]);
                assert!(all[x] >= ridge[x]);
                checked += 1;
            }
        }
        assert!(checked > 10);
    }

    #[test]
    fn envelope_is_monotone_in_the_range() {
        let s: Vec<f32> = (0..100).map(|i| ((i * 37) % 11) as f32 * 0.3).collect();
        let hf = Heightfield::new(&s, 10, 10).unwrap();
        let cam = Camera::new(
            Vec3::new(-3.0, -4.0, 8.0),
            Vec3::new(5.0, 5.0, 0.0),
            60.0,
            40,
            30,
        )
        .unwrap();
        let mut map = vec![SilhouetteTexel::EMPTY; 400];
        silhouette_map(&hf, &cam, 0.01, &mut map).unwrap();
        for level in 0..4 {
            let mut k = 0;
            while let Some((a, b)) = tree_node_rows(10, level, k) {
                let mut node = [0.0f32; 40];
                silhouette_envelope(&map, 40, a, b, &mut node).unwrap();
                // Children of this node: their maximum is the node (section 4.1.5).
                if let (Some((c0, c1)), Some((d0, d1))) = (
                    tree_node_rows(10, level + 1, 2 * k),
                    tree_node_rows(10, level + 1, 2 * k + 1),
                ) {
                    if c0 == a && d1 == b && c1 == d0 {
                        let (mut l, mut r) = ([0.0f32; 40], [0.0f32; 40]);
                        silhouette_envelope(&map, 40, c0, c1, &mut l).unwrap();
                        silhouette_envelope(&map, 40, d0, d1, &mut r).unwrap();
                        for x in 0..40 {
                            assert_eq!(node[x], l[x].max(r[x]));
                        }
                    }
                }
                k += 1;
            }
            assert!(k >= 1);
        }
        assert!(map.iter().all(|t| !t.y.is_nan() && !t.u.is_nan()));
    }

    #[test]
    fn bad_input() {
        let hf = Heightfield::new(&[0.0f32; 4], 2, 2).unwrap();
        let cam = cam_along_y();
        let mut small = vec![SilhouetteTexel::EMPTY; 10];
        assert_eq!(
            silhouette_map(&hf, &cam, 0.01, &mut small),
            Err(Error::BufferTooSmall {
                needed: 128,
                actual: 10
            })
        );
        let mut map = vec![SilhouetteTexel::EMPTY; 128];
        assert!(silhouette_map(&hf, &cam, 0.0, &mut map).is_err());
        assert!(silhouette_map(&hf, &cam, f32::NAN, &mut map).is_err());
        let mut out = [0.0f32; 64];
        assert!(silhouette_envelope(&map, 64, 1, 0, &mut out).is_err());
        assert!(silhouette_envelope(&map, 64, 0, 3, &mut out).is_err());
        assert!(silhouette_envelope(&map, 64, 0, 2, &mut out[..3]).is_err());
        // Everything behind the camera: the map stays empty.
        let away = Camera::new(
            Vec3::new(0.5, 5.0, 1.0),
            Vec3::new(0.5, 10.0, 1.0),
            60.0,
            64,
            48,
        )
        .unwrap();
        silhouette_map(&hf, &away, 0.01, &mut map).unwrap();
        assert!(map.iter().all(SilhouetteTexel::is_empty));
    }
}
