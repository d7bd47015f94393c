//! Comparison data: for one terrain and a list of error targets, the triangles, measured maximum
//! and RMS vertical error and build time of each meshing method, as plain rows for reports.
//!
//! [`compare_tin`] measures the greedy TIN. Any other method whose vertices are grid samples (the
//! core's view-independent refinement, a peer's mesh read back) plugs in through
//! [`compare_method`] with a closure that builds its mesh for a given error target; every method
//! is then measured by the same full-grid scan ([`mesh_error`](crate::mesh_error)).

use crate::scan::{local_heights, mesh_error_heights};
use crate::{Tin, TinOptions};
use relief_core::{Error, Terrain};
use std::time::Instant;

/// A mesh whose vertices are grid samples `[x, y]` and whose triangles are counter-clockwise
/// vertex indices: what [`compare_method`] measures.
///
/// ```
/// let m = relief_tin::GridMesh { vertices: vec![[0, 0], [1, 0], [1, 1]], triangles: vec![[0, 1, 2]] };
/// assert_eq!(m.triangles.len(), 1);
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct GridMesh {
    /// Vertices as grid samples (column, row).
    pub vertices: Vec<[u32; 2]>,
    /// Triangles, counter-clockwise seen from +z.
    pub triangles: Vec<[u32; 3]>,
}

impl From<Tin> for GridMesh {
    fn from(t: Tin) -> GridMesh {
        GridMesh {
            vertices: t.vertices().to_vec(),
            triangles: t.triangles().to_vec(),
        }
    }
}

/// One measured mesh: a method at one error target.
///
/// ```
/// use relief_core::Heightfield;
/// let hf = Heightfield::new(&[0.0f32, 1.0, 0.0, 1.0, 9.0, 1.0, 0.0, 1.0, 0.0], 3, 3).unwrap();
/// let rows = relief_tin::compare_tin(&hf, &[0.0]).unwrap();
/// let r = &rows[0];
/// assert_eq!((r.method.as_str(), r.target_error, r.max_error), ("tin", 0.0, 0.0));
/// assert!(r.triangles >= 4 && r.build_ms >= 0.0);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct ComparisonRow {
    /// Method name (`"tin"`, `"rqt"`, a peer's name).
    pub method: String,
    /// The error target the mesh was built for (world z units).
    pub target_error: f32,
    /// Vertices of the mesh.
    pub vertices: usize,
    /// Triangles of the mesh.
    pub triangles: usize,
    /// Measured maximum vertical error over all grid samples (world z units).
    pub max_error: f64,
    /// Measured RMS vertical error over all grid samples (world z units).
    pub rms_error: f64,
    /// Wall-clock time of the build alone, in milliseconds (not the measurement).
    pub build_ms: f64,
}

/// Builds one mesh per error target with `build` and measures each: triangles, maximum and RMS
/// error by the full-grid scan, and the time `build` took.
///
/// This is the hook for methods other than the TIN. Errors: whatever `build` returns, and the
/// scan's errors ([`mesh_error`](crate::mesh_error)) for a mesh that does not cover the grid.
///
/// ```
/// use relief_core::Heightfield;
/// use relief_tin::{compare_method, GridMesh};
/// // The full-resolution grid as a mesh: exact, 2 triangles per cell.
/// let hf = Heightfield::new(&[0.0f32, 2.0, 4.0, 1.0], 2, 2).unwrap();
/// let rows = compare_method(&hf, "grid", &[0.0, 1.0], |_e| {
///     Ok(GridMesh {
///         vertices: vec![[0, 0], [1, 0], [0, 1], [1, 1]],
///         triangles: vec![[0, 1, 3], [0, 3, 2]],
///     })
/// })
/// .unwrap();
/// assert_eq!(rows.len(), 2);
/// assert_eq!((rows[1].triangles, rows[1].max_error), (2, 0.0));
/// ```
pub fn compare_method<T, F>(
    terrain: &T,
    method: &str,
    errors: &[f32],
    mut build: F,
) -> Result<Vec<ComparisonRow>, Error>
where
    T: Terrain + ?Sized,
    F: FnMut(f32) -> Result<GridMesh, Error>,
{
    let heights = local_heights(terrain)?;
    let mut rows = Vec::with_capacity(errors.len());
    for &e in errors {
        let t0 = Instant::now();
        let mesh = build(e)?;
        let build_ms = t0.elapsed().as_secs_f64() * 1e3;
        let m = mesh_error_heights(
            &heights,
            terrain.width(),
            terrain.height(),
            &mesh.vertices,
            &mesh.triangles,
        )?;
        rows.push(ComparisonRow {
            method: method.to_string(),
            target_error: e,
            vertices: mesh.vertices.len(),
            triangles: mesh.triangles.len(),
            max_error: m.max,
            rms_error: m.rms,
            build_ms,
        });
    }
    Ok(rows)
}

/// [`compare_method`] for the greedy TIN ([`Tin::build`] with `max_error = E` for each `E`).
///
/// ```
/// use relief_core::Heightfield;
/// let s: Vec<f32> = (0..400).map(|i| ((i * 7919) % 97) as f32).collect();
/// let hf = Heightfield::new(&s, 20, 20).unwrap();
/// let rows = relief_tin::compare_tin(&hf, &[40.0, 10.0, 0.0]).unwrap();
/// assert!(rows.iter().all(|r| r.max_error <= f64::from(r.target_error)));
/// assert!(rows[0].triangles <= rows[1].triangles && rows[1].triangles <= rows[2].triangles);
/// ```
pub fn compare_tin<T: Terrain + ?Sized>(
    terrain: &T,
    errors: &[f32],
) -> Result<Vec<ComparisonRow>, Error> {
    compare_method(terrain, "tin", errors, |e| {
        Tin::build(terrain, &TinOptions::default().with_max_error(e)).map(GridMesh::from)
    })
}

/// Formats rows as a Markdown table (method, target E, vertices, triangles, measured max and
/// RMS error, build ms), one row per line, for reports and `BENCHMARKS.md`.
///
/// ```
/// use relief_core::Heightfield;
/// let hf = Heightfield::new(&[0.0f32; 4], 2, 2).unwrap();
/// let t = relief_tin::markdown_table(&relief_tin::compare_tin(&hf, &[1.0]).unwrap());
/// assert!(t.lines().nth(2).unwrap().starts_with("| tin | 1 | 4 | 2 | 0 |"));
/// ```
#[must_use]
pub fn markdown_table(rows: &[ComparisonRow]) -> String {
    let mut s = String::from(
        "| method | E | vertices | triangles | max error | RMS error | build ms |\n|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        s.push_str(&format!(
            "| {} | {} | {} | {} | {} | {:.4} | {:.1} |\n",
            r.method, r.target_error, r.vertices, r.triangles, r.max_error, r.rms_error, r.build_ms
        ));
    }
    s
}
