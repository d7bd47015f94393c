//! Triangle rasterisation over the sample grid, the plane through three samples, and the
//! full-grid vertical error scan of a mesh whose vertices are grid samples.
//!
//! The mesh vertical error is the one of CONVENTIONS.md: the maximum over all grid samples of
//! `|h(sample) - mesh(x, y)|` in world z units, where `mesh(x, y)` is the plane of the triangle
//! covering the sample. Heights are compared in *local* units (`h * z_scale`): `z_offset` cancels
//! in the difference, so it costs no precision.

use relief_core::{Error, Terrain};

/// The plane through three grid samples, evaluated by one fixed formula in `f64`.
///
/// The corners are sorted by `(y, x)` before the plane is formed, so the same three samples give
/// bit-identical heights whatever order they are listed in (the greedy builder and the error scan
/// see the same mesh heights). The formula mirrors the one `relief-core`'s refinement uses.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Plane {
    x0: i64,
    y0: i64,
    z0: f64,
    gx: f64,
    gy: f64,
}

impl Plane {
    /// `None` for a degenerate (collinear) triangle.
    pub(crate) fn new(mut p: [(i64, i64, f64); 3]) -> Option<Plane> {
        p.sort_unstable_by_key(|a| (a.1, a.0));
        Plane::sorted(p)
    }

    /// [`Plane::new`] of corners already sorted by `(y, x)`.
    #[inline]
    pub(crate) fn sorted(p: [(i64, i64, f64); 3]) -> Option<Plane> {
        let [(x0, y0, z0), (x1, y1, z1), (x2, y2, z2)] = p;
        let (ax, ay, az) = ((x1 - x0) as f64, (y1 - y0) as f64, z1 - z0);
        let (bx, by, bz) = ((x2 - x0) as f64, (y2 - y0) as f64, z2 - z0);
        let det = ax * by - bx * ay;
        if det == 0.0 {
            return None;
        }
        Some(Plane {
            x0,
            y0,
            z0,
            gx: (az * by - bz * ay) / det,
            gy: (ax * bz - bx * az) / det,
        })
    }

    /// `gy * (y - y0)`: the row term of [`Plane::at`], computed once per row.
    #[inline(always)]
    pub(crate) fn row(&self, y: i64) -> f64 {
        self.gy * (y - self.y0) as f64
    }

    /// The largest `|h - plane|` over one row span, if it exceeds `above`, with the index in
    /// `row` of its first occurrence. `row` holds the heights of samples `lo, lo+1, ...` of the
    /// row whose term is `r` ([`Plane::row`]). Gives bit-identical values to [`Plane::at_row`]:
    /// `start + i` is the exact integer `x - x0`.
    #[inline]
    pub(crate) fn row_max(&self, row: &[f32], lo: i64, r: f64, above: f64) -> Option<(f64, usize)> {
        let start = (lo - self.x0) as f64;
        let err =
            |i: usize, h: f32| (f64::from(h) - (self.z0 + self.gx * (start + i as f64) + r)).abs();
        // Pass 1: the maximum, four independent lanes so the loop vectorises.
        let mut lanes = [0.0f64; 4];
        let chunks = row.chunks_exact(4);
        let tail = chunks.remainder();
        for (k, ch) in chunks.enumerate() {
            for (j, (&h, m)) in ch.iter().zip(lanes.iter_mut()).enumerate() {
                let d = err(4 * k + j, h);
                *m = if d > *m { d } else { *m };
            }
        }
        let mut max = lanes[0].max(lanes[1]).max(lanes[2].max(lanes[3]));
        let t0 = row.len() - tail.len();
        for (j, &h) in tail.iter().enumerate() {
            let d = err(t0 + j, h);
            max = if d > max { d } else { max };
        }
        if max <= above {
            return None;
        }
        // Pass 2 (rare): where it is first reached.
        row.iter()
            .enumerate()
            .position(|(i, &h)| err(i, h) == max)
            .map(|i| (max, i))
    }

    /// Height over the first sorted corner plus `(dx, dy)`: bit-identical to [`Plane::at_row`]
    /// and [`Plane::row_max`] there (the same operations in the same order).
    #[inline(always)]
    pub(crate) fn at_offset(&self, dx: i64, dy: i64) -> f64 {
        self.z0 + self.gx * dx as f64 + self.gy * dy as f64
    }

    /// Height over `(x, y)` given the row term of `y`: `z0 + gx (x - x0) + gy (y - y0)`.
    #[inline(always)]
    pub(crate) fn at_row(&self, x: i64, row: f64) -> f64 {
        self.z0 + self.gx * (x - self.x0) as f64 + row
    }
}

/// Twice the signed area of `(a, b, c)`: positive when counter-clockwise (x right, y up).
#[inline(always)]
pub(crate) fn orient(a: (i64, i64), b: (i64, i64), c: (i64, i64)) -> i64 {
    (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0)
}

/// Calls `f(y, x_lo, x_hi)` for every row of the closed triangle `(a, b, c)` holding grid
/// points, with the inclusive column span of that row; exact integer arithmetic. Degenerate
/// triangles visit nothing.
#[inline]
pub(crate) fn for_each_span(
    a: (i64, i64),
    b: (i64, i64),
    c: (i64, i64),
    mut f: impl FnMut(i64, i64, i64),
) {
    let o = orient(a, b, c);
    if o == 0 {
        return;
    }
    let p = if o > 0 { [a, b, c] } else { [a, c, b] };
    let y_lo = a.1.min(b.1).min(c.1);
    let y_hi = a.1.max(b.1).max(c.1);
    let x_lo = a.0.min(b.0).min(c.0);
    let x_hi = a.0.max(b.0).max(c.0);
    // Edge k (from p[k] to p[k+1]): a sample s is inside (left of or on the edge) when
    // ex (sy - py) - ey (sx - px) >= 0, i.e. ey * sx <= ex (sy - py) + ey px.
    let edges = [(p[0], p[1]), (p[1], p[2]), (p[2], p[0])];
    for y in y_lo..=y_hi {
        let (mut lo, mut hi) = (x_lo, x_hi);
        let mut empty = false;
        for &((px, py), (qx, qy)) in &edges {
            let (ex, ey) = (qx - px, qy - py);
            let rhs = ex * (y - py) + ey * px;
            if ey > 0 {
                hi = hi.min(rhs.div_euclid(ey));
            } else if ey < 0 {
                // sx >= rhs / ey: the ceiling of (-rhs) / (-ey).
                let (n, d) = (-rhs, -ey);
                lo = lo.max(-(-n).div_euclid(d));
            } else if ex * (y - py) < 0 {
                empty = true;
            }
        }
        if !empty && lo <= hi {
            f(y, lo, hi);
        }
    }
}

/// Local heights (`h * z_scale`) of every sample, row-major, read once through the trait.
pub(crate) fn local_heights<T: Terrain + ?Sized>(terrain: &T) -> Result<Vec<f32>, Error> {
    let (w, h) = (terrain.width(), terrain.height());
    let n = (w as usize)
        .checked_mul(h as usize)
        .ok_or(Error::SizeOverflow)?;
    let mut out = Vec::with_capacity(n);
    for y in 0..h {
        for x in 0..w {
            out.push(terrain.local_z(x, y));
        }
    }
    Ok(out)
}

/// Vertical error of a mesh against its terrain, in world z units.
///
/// ```
/// use relief_core::Heightfield;
/// use relief_tin::mesh_error;
/// // A 3 x 2 ramp is reproduced exactly by two triangles over the whole domain.
/// let hf = Heightfield::new(&[0.0f32, 1.0, 2.0, 0.0, 1.0, 2.0], 3, 2).unwrap();
/// let e = mesh_error(&hf, &[[0, 0], [2, 0], [2, 1], [0, 1]], &[[0, 1, 2], [0, 2, 3]]).unwrap();
/// assert_eq!((e.max, e.rms, e.samples), (0.0, 0.0, 6));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshError {
    /// Maximum over all grid samples of `|h(sample) - mesh(x, y)|`.
    pub max: f64,
    /// Root mean square of `h(sample) - mesh(x, y)` over all grid samples.
    pub rms: f64,
    /// Number of grid samples measured (`width * height`).
    pub samples: usize,
    /// Column and row of a sample where the maximum is reached.
    pub worst: [u32; 2],
}

/// Measures a mesh whose vertices are grid samples against `terrain` by scanning every grid
/// sample: the maximum and RMS vertical error of CONVENTIONS.md.
///
/// Each triangle is rasterised over the grid (exact integer point-in-triangle) and every sample
/// it covers is compared with the triangle's plane; a sample on a shared edge is measured by each
/// triangle holding it and keeps the larger difference. The scan also checks coverage: every
/// grid sample must lie in some triangle.
///
/// Errors: [`Error::OutOfBounds`] for a vertex outside the grid, [`Error::BufferTooSmall`] when a
/// triangle names a vertex index beyond `vertices` (`needed` is that index + 1),
/// [`Error::InvalidParameter`] (`name: "triangle"`, value the triangle's index) for a degenerate
/// triangle or one that is not counter-clockwise seen from +z, [`Error::OutOfBounds`] naming the first sample no triangle covers.
///
/// ```
/// use relief_core::{Error, Heightfield};
/// use relief_tin::mesh_error;
/// let hf = Heightfield::new(&[0.0f32, 0.0, 0.0, 4.0], 2, 2).unwrap();
/// let v = [[0, 0], [1, 0], [1, 1], [0, 1]];
/// // Diagonal (0,0)-(1,1): every sample is a vertex, the mesh is exact.
/// assert_eq!(mesh_error(&hf, &v, &[[0, 1, 2], [0, 2, 3]]).unwrap().max, 0.0);
/// // One triangle alone leaves sample (0, 1) uncovered.
/// assert_eq!(mesh_error(&hf, &v, &[[0, 1, 2]]), Err(Error::OutOfBounds { x: 0, y: 1 }));
/// ```
pub fn mesh_error<T: Terrain + ?Sized>(
    terrain: &T,
    vertices: &[[u32; 2]],
    triangles: &[[u32; 3]],
) -> Result<MeshError, Error> {
    let heights = local_heights(terrain)?;
    mesh_error_heights(
        &heights,
        terrain.width(),
        terrain.height(),
        vertices,
        triangles,
    )
}

/// [`mesh_error`] over precomputed local heights.
pub(crate) fn mesh_error_heights(
    heights: &[f32],
    width: u32,
    height: u32,
    vertices: &[[u32; 2]],
    triangles: &[[u32; 3]],
) -> Result<MeshError, Error> {
    if let Some(v) = vertices.iter().find(|v| v[0] >= width || v[1] >= height) {
        return Err(Error::OutOfBounds { x: v[0], y: v[1] });
    }
    let w = width as usize;
    // Per-sample error, NaN until a triangle covers the sample.
    let mut err = vec![f64::NAN; heights.len()];
    let z =
        |x: i64, y: i64| f64::from(heights.get(y as usize * w + x as usize).map_or(0.0, |&h| h));
    for (ti, t) in triangles.iter().enumerate() {
        let mut c = [(0i64, 0i64); 3];
        for (k, &i) in t.iter().enumerate() {
            let v = vertices.get(i as usize).ok_or(Error::BufferTooSmall {
                needed: i as usize + 1,
                actual: vertices.len(),
            })?;
            c[k] = (i64::from(v[0]), i64::from(v[1]));
        }
        if orient(c[0], c[1], c[2]) <= 0 {
            return Err(Error::InvalidParameter {
                name: "triangle",
                value: ti as f32,
            });
        }
        let plane = Plane::new([
            (c[0].0, c[0].1, z(c[0].0, c[0].1)),
            (c[1].0, c[1].1, z(c[1].0, c[1].1)),
            (c[2].0, c[2].1, z(c[2].0, c[2].1)),
        ])
        .ok_or(Error::InvalidParameter {
            name: "triangle",
            value: ti as f32,
        })?;
        for_each_span(c[0], c[1], c[2], |y, lo, hi| {
            let row = plane.row(y);
            let base = y as usize * w;
            for x in lo..=hi {
                let i = base + x as usize;
                // A vertex lies on the mesh by definition.
                let d = if c.contains(&(x, y)) {
                    0.0
                } else {
                    (z(x, y) - plane.at_row(x, row)).abs()
                };
                if let Some(e) = err.get_mut(i) {
                    if e.is_nan() || *e < d {
                        *e = d;
                    }
                }
            }
        });
    }
    let mut max = 0.0f64;
    let mut worst = [0u32; 2];
    let mut sum = 0.0f64;
    for (i, &e) in err.iter().enumerate() {
        let (x, y) = ((i % w) as u32, (i / w) as u32);
        if e.is_nan() {
            return Err(Error::OutOfBounds { x, y });
        }
        if e > max {
            max = e;
            worst = [x, y];
        }
        sum += e * e;
    }
    let samples = err.len();
    Ok(MeshError {
        max,
        rms: (sum / samples.max(1) as f64).sqrt(),
        samples,
        worst,
    })
}
