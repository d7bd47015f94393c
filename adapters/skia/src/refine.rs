//! Top-down view of a SOAR refinement (Lindstrom & Pascucci 2001; Balogh 2003, seed 004,
//! figures 5-11 and the plates of chapters 4.5, 5.2 and 6.3): the mesh the core's
//! [`relief_core::Refiner`] emitted, triangles coloured by the level of their split vertex, the
//! active (kept) vertices, the bounding circles of a chosen level, the camera's ground wedge, the
//! culled regions (parts of the domain no emitted triangle covers) and the vertices that lazy
//! culling accepted.
//!
//! "Lazily accepted" vertices are found by asking the core twice: the requested view, and the
//! same view with [`relief_core::refine::View::with_lazy_levels`]`(0)` (every level tested
//! against the frustum). The vertices only the first mesh has are those lazy culling accepted
//! instead of culling. Nothing of the refinement is recomputed here.

use crate::canvas::Canvas;
use crate::style::{rgba, viridis, BLACK, BLUE, REDDISH_PURPLE, SKY_BLUE, VERMILLION};
use crate::{DiagramError, DiagramOptions};
use glam::Vec2;
use relief_core::refine::{scratch_len, triangle_bound, vertex_bound, Criterion, Hierarchy};
use relief_core::{Camera, Refiner, Scale, Terrain};
use std::collections::HashSet;
use tiny_skia::Pixmap;

/// What to refine and what to draw besides the mesh.
///
/// ```
/// use relief_core::{refine::{preprocess, Criterion}, Heightfield};
/// let hf = Heightfield::new(&[0.0f32; 9], 3, 3).unwrap();
/// let (mut e, mut r) = ([0.0; 9], [0.0; 9]);
/// let h = preprocess(&hf, &mut e, &mut r).unwrap();
/// let input = relief_skia::refine::RefineInput::new(&hf, &h, Criterion::MaxError(0.0));
/// assert!(input.camera.is_none() && input.circle_level.is_none());
/// ```
#[derive(Debug, Clone, Copy)]
pub struct RefineInput<'a, T: Terrain> {
    /// The terrain the hierarchy was built from.
    pub terrain: &'a T,
    /// The core's preprocessed errors and bounding volumes.
    pub hierarchy: &'a Hierarchy<'a>,
    /// View-independent or view-dependent refinement.
    pub criterion: Criterion,
    /// The camera of a view-dependent criterion, to draw its ground wedge (default none).
    pub camera: Option<&'a Camera>,
    /// Draw the bounding circles (radius from [`Hierarchy::radius`]) of the active vertices at
    /// this level (default none).
    pub circle_level: Option<u32>,
}

impl<'a, T: Terrain> RefineInput<'a, T> {
    /// Input with no camera wedge and no circles.
    ///
    /// ```
    /// # use relief_core::{refine::{preprocess, Criterion}, Heightfield};
    /// # let hf = Heightfield::new(&[0.0f32; 9], 3, 3).unwrap();
    /// # let (mut e, mut r) = ([0.0; 9], [0.0; 9]);
    /// # let h = preprocess(&hf, &mut e, &mut r).unwrap();
    /// let i = relief_skia::refine::RefineInput::new(&hf, &h, Criterion::MaxError(1.0));
    /// assert_eq!(i.criterion, Criterion::MaxError(1.0));
    /// ```
    #[must_use]
    pub fn new(terrain: &'a T, hierarchy: &'a Hierarchy<'a>, criterion: Criterion) -> Self {
        RefineInput {
            terrain,
            hierarchy,
            criterion,
            camera: None,
            circle_level: None,
        }
    }

    /// Draws the ground wedge of `camera` (default none).
    ///
    /// ```
    /// # use relief_core::{refine::{preprocess, Criterion}, Camera, Heightfield};
    /// # let hf = Heightfield::new(&[0.0f32; 9], 3, 3).unwrap();
    /// # let (mut e, mut r) = ([0.0; 9], [0.0; 9]);
    /// # let h = preprocess(&hf, &mut e, &mut r).unwrap();
    /// let cam = Camera::new(glam::Vec3::new(0.0, 0.0, 5.0), glam::Vec3::new(2.0, 2.0, 0.0), 60.0, 64, 64).unwrap();
    /// let i = relief_skia::refine::RefineInput::new(&hf, &h, Criterion::MaxError(1.0)).with_camera(Some(&cam));
    /// assert!(i.camera.is_some());
    /// ```
    #[must_use]
    pub fn with_camera(mut self, camera: Option<&'a Camera>) -> Self {
        self.camera = camera;
        self
    }

    /// Draws the bounding circles of the active vertices at `level` (default none).
    ///
    /// ```
    /// # use relief_core::{refine::{preprocess, Criterion}, Heightfield};
    /// # let hf = Heightfield::new(&[0.0f32; 9], 3, 3).unwrap();
    /// # let (mut e, mut r) = ([0.0; 9], [0.0; 9]);
    /// # let h = preprocess(&hf, &mut e, &mut r).unwrap();
    /// let i = relief_skia::refine::RefineInput::new(&hf, &h, Criterion::MaxError(1.0)).with_circle_level(Some(2));
    /// assert_eq!(i.circle_level, Some(2));
    /// ```
    #[must_use]
    pub fn with_circle_level(mut self, level: Option<u32>) -> Self {
        self.circle_level = level;
        self
    }
}

/// The refinement's state as the diagram draws it, all of it from the core.
///
/// ```
/// use relief_core::{refine::{preprocess, Criterion}, Heightfield};
/// let s: Vec<f32> = (0..81).map(|i| ((i * 37) % 11) as f32).collect();
/// let hf = Heightfield::new(&s, 9, 9).unwrap();
/// let (mut e, mut r) = (vec![0.0; 81], vec![0.0; 81]);
/// let h = preprocess(&hf, &mut e, &mut r).unwrap();
/// let coarse = relief_skia::refine::refine_state(&relief_skia::refine::RefineInput::new(&hf, &h, Criterion::MaxError(100.0))).unwrap();
/// assert_eq!((coarse.vertices.len(), coarse.triangles.len()), (4, 2));
/// assert_eq!(coarse.triangle_levels, vec![0, 0]); // both split at the centre, level 0
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct RefineState {
    /// World positions of the active vertices ([`Refiner::triangles`]).
    pub vertices: Vec<[f32; 3]>,
    /// The triangles, indices into `vertices`.
    pub triangles: Vec<[u32; 3]>,
    /// Per triangle: the level its split vertex would have (the midpoint of its longest edge;
    /// [`relief_core::RefineGrid::levels`] for full-resolution triangles).
    pub triangle_levels: Vec<u32>,
    /// Number of vertex levels of the grid.
    pub levels: u32,
    /// Grid positions of the vertices kept only because lazy culling accepted them (empty for a
    /// view-independent criterion).
    pub lazy_accepted: Vec<[u32; 2]>,
    /// The terrain's spacing.
    pub scale: Scale,
    /// The terrain's size in samples.
    pub size: [u32; 2],
}

/// Vertices and triangles of one refinement.
type Mesh = (Vec<[f32; 3]>, Vec<[u32; 3]>);

fn mesh<T: Terrain>(h: &Hierarchy<'_>, t: &T, criterion: Criterion) -> Result<Mesh, DiagramError> {
    let (w, hh) = (t.width(), t.height());
    let r = Refiner::new(h, t, criterion)?;
    let mut scratch = vec![0u64; scratch_len(w, hh)];
    let c = r.count(&mut scratch)?;
    let mut verts = vec![[0.0f32; 3]; c.vertices.min(vertex_bound(w, hh))];
    let mut tris = vec![[0u32; 3]; c.triangles.min(triangle_bound(w, hh))];
    let c = r.triangles(&mut scratch, &mut verts, &mut tris)?;
    verts.truncate(c.vertices);
    tris.truncate(c.triangles);
    Ok((verts, tris))
}

/// Each triangle's corners in sample coordinates (world x, y over the spacing).
pub(crate) fn sample_polygons(
    vertices: &[[f32; 3]],
    triangles: &[[u32; 3]],
    s: &Scale,
) -> Vec<Vec<[f32; 2]>> {
    let to_s = |v: &[f32; 3]| [v[0] / s.dx, v[1] / s.dy];
    triangles
        .iter()
        .map(|t| {
            t.iter()
                .map(|&i| vertices.get(i as usize).map_or([0.0, 0.0], to_s))
                .collect()
        })
        .collect()
}

fn grid_pos(p: &[f32; 3], s: &Scale) -> [u32; 2] {
    [
        (p[0] / s.dx).round().max(0.0) as u32,
        (p[1] / s.dy).round().max(0.0) as u32,
    ]
}

/// Runs the core's refiner for `input` (twice for a view-dependent criterion, see the module
/// docs) and collects what the diagram draws.
///
/// ```
/// use relief_core::{refine::{preprocess, Criterion}, Heightfield};
/// let s: Vec<f32> = (0..81).map(|i| ((i * 37) % 11) as f32).collect();
/// let hf = Heightfield::new(&s, 9, 9).unwrap();
/// let (mut e, mut r) = (vec![0.0; 81], vec![0.0; 81]);
/// let h = preprocess(&hf, &mut e, &mut r).unwrap();
/// let fine = relief_skia::refine::refine_state(&relief_skia::refine::RefineInput::new(&hf, &h, Criterion::MaxError(0.0))).unwrap();
/// assert!(fine.triangles.len() > 2 && fine.lazy_accepted.is_empty());
/// ```
pub fn refine_state<T: Terrain>(input: &RefineInput<'_, T>) -> Result<RefineState, DiagramError> {
    let t = input.terrain;
    let s = t.scale();
    let grid = input.hierarchy.grid();
    let (vertices, triangles) = mesh(input.hierarchy, t, input.criterion)?;
    let levels = grid.levels();
    let triangle_levels = triangles
        .iter()
        .map(|tri| {
            let p = tri.map(|i| {
                let v = vertices.get(i as usize).copied().unwrap_or_default();
                [
                    f64::from(v[0] / s.dx).round(),
                    f64::from(v[1] / s.dy).round(),
                ]
            });
            // Longest edge (the hypotenuse) and its midpoint.
            let mut best = (0.0f64, [0.0f64; 2]);
            for k in 0..3 {
                let (a, b) = (p[k], p[(k + 1) % 3]);
                let l = (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2);
                if l > best.0 {
                    best = (l, [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0]);
                }
            }
            let m = best.1;
            if m[0].fract() != 0.0 || m[1].fract() != 0.0 {
                levels
            } else {
                grid.level(m[0] as u32, m[1] as u32).unwrap_or(levels)
            }
        })
        .collect();
    let lazy_accepted = match input.criterion {
        Criterion::View(v) => {
            let (strict, _) = mesh(input.hierarchy, t, Criterion::View(v.with_lazy_levels(0)))?;
            let strict: HashSet<[u32; 2]> = strict.iter().map(|p| grid_pos(p, &s)).collect();
            vertices
                .iter()
                .map(|p| grid_pos(p, &s))
                .filter(|g| !strict.contains(g))
                .collect()
        }
        Criterion::MaxError(_) => Vec::new(),
    };
    Ok(RefineState {
        vertices,
        triangles,
        triangle_levels,
        levels,
        lazy_accepted,
        scale: s,
        size: [t.width(), t.height()],
    })
}

/// Most circles drawn (the first ones in vertex order).
const MAX_CIRCLES: usize = 4000;

/// The diagram of [`refine_state`]`(input)`: see the module docs. Sample coordinates, row 0 at
/// the top; an optional background (e.g. [`crate::hillshade`]) shows through the triangles.
///
/// ```
/// use relief_core::{refine::{preprocess, Criterion}, Heightfield};
/// use relief_skia::{refine::{refine, RefineInput}, DiagramOptions};
/// let s: Vec<f32> = (0..289).map(|i| ((i * 37) % 11) as f32).collect();
/// let hf = Heightfield::new(&s, 17, 17).unwrap();
/// let (mut e, mut r) = (vec![0.0; 289], vec![0.0; 289]);
/// let h = preprocess(&hf, &mut e, &mut r).unwrap();
/// let o = DiagramOptions::default().with_max_size(200);
/// let a = refine(&RefineInput::new(&hf, &h, Criterion::MaxError(1.0)), &o).unwrap();
/// let b = refine(&RefineInput::new(&hf, &h, Criterion::MaxError(8.0)), &o).unwrap();
/// assert_ne!(a, b); // a different threshold draws a different mesh
/// ```
pub fn refine<T: Terrain>(
    input: &RefineInput<'_, T>,
    opts: &DiagramOptions<'_>,
) -> Result<Pixmap, DiagramError> {
    let st = refine_state(input)?;
    let s = st.scale;
    let (w, h) = (
        st.size[0].saturating_sub(1) as f32,
        st.size[1].saturating_sub(1) as f32,
    );
    let (lo, hi) = ([0.0f32, 0.0], [w.max(1e-3), h.max(1e-3)]);
    let crit = match input.criterion {
        Criterion::MaxError(e) => format!("max error {e}"),
        Criterion::View(v) => format!("view, {} px", v.pixel_error()),
    };
    let alpha = if opts.background.is_some() { 0.5 } else { 0.85 };
    let levels = st.levels.max(1) as f32;
    let stops: Vec<u32> = (0..5).map(|k| k * st.levels / 4).collect();
    let names: Vec<String> = stops.iter().map(|l| format!("level {l}")).collect();
    let row: Vec<(tiny_skia::Color, &str)> = stops
        .iter()
        .zip(&names)
        .map(|(&l, n)| (rgba(viridis(l as f32 / levels), alpha), n.as_str()))
        .collect();
    // The full layout stores nested spheres (drawn as their top-view circles), the compact one
    // seed 004's level circles.
    let what = if input.hierarchy.bytes_per_vertex() == 8 {
        "bounding spheres (top view)"
    } else {
        "bounding circles"
    };
    let circles = input.circle_level.map_or_else(
        || format!("{what} (no level chosen)"),
        |l| format!("{what}, level {l}"),
    );
    let row2 = [
        (rgba(BLACK, 0.9), "active vertex"),
        (rgba(REDDISH_PURPLE, 1.0), "lazily accepted"),
        (rgba(VERMILLION, 0.45), "culled"),
        (rgba(SKY_BLUE, 0.9), &circles),
        (rgba(BLUE, 1.0), "frustum wedge"),
    ];
    let mut c = Canvas::new(
        lo,
        hi,
        false,
        &format!(
            "SOAR refinement ({crit}): {} vertices, {} triangles",
            st.vertices.len(),
            st.triangles.len()
        ),
        &[&row[..], &row2[..]],
        opts,
    )?;
    if let Some(bg) = opts.background {
        c.background(bg, [-0.5, -0.5], [w + 0.5, h + 0.5]);
    }
    let to_s = |v: &[f32; 3]| [v[0] / s.dx, v[1] / s.dy];
    let polys = sample_polygons(&st.vertices, &st.triangles, &s);
    c.fill_uncovered(&polys, lo, hi, rgba(VERMILLION, 0.45));
    for (poly, &l) in polys.iter().zip(&st.triangle_levels) {
        c.fill_polygon(poly, rgba(viridis(l as f32 / levels), alpha));
    }
    let px = c.scale();
    // Edges: thin, only where triangles are big enough on screen to show them.
    let edge = if px >= 2.0 { 0.6 } else { 0.3 };
    if st.triangles.len() <= 200_000 {
        for poly in &polys {
            c.stroke(poly, true, rgba(BLACK, 0.45), edge, false);
        }
    }
    if let Some(level) = input.circle_level {
        let grid = input.hierarchy.grid();
        let mut n = 0;
        for v in &st.vertices {
            let g = grid_pos(v, &s);
            if grid.level(g[0], g[1]) != Some(level) {
                continue;
            }
            if let Some(r) = input.hierarchy.radius(g[0], g[1]) {
                c.circle(
                    to_s(v),
                    r / s.dx,
                    None,
                    Some((rgba(SKY_BLUE, 0.9), 1.0, true)),
                );
                n += 1;
            }
            if n >= MAX_CIRCLES {
                break;
            }
        }
    }
    let dot = (px * 0.25).clamp(0.8, 2.5);
    if st.vertices.len() <= 100_000 {
        for v in &st.vertices {
            c.dot(to_s(v), dot, rgba(BLACK, 0.9));
        }
    }
    for g in &st.lazy_accepted {
        c.dot(
            [g[0] as f32, g[1] as f32],
            dot + 1.5,
            rgba(REDDISH_PURPLE, 1.0),
        );
    }
    if let Some(cam) = input.camera {
        let eye = [cam.eye.x / s.dx, cam.eye.y / s.dy];
        let reach = 2.0 * (w * w + h * h).sqrt() + Vec2::new(eye[0], eye[1]).length();
        for i in [0, cam.width.saturating_sub(1)] {
            let (_, d) = cam.ray(i, cam.height / 2);
            let d = Vec2::new(d.x / s.dx, d.y / s.dy).normalize_or_zero();
            c.stroke(
                &[eye, [eye[0] + d.x * reach, eye[1] + d.y * reach]],
                false,
                rgba(BLUE, 1.0),
                2.5,
                false,
            );
        }
        c.dot(eye, 4.0, rgba(BLACK, 1.0));
    }
    c.stroke_rect(lo, hi, rgba(BLACK, 0.8), 1.0, false);
    Ok(c.finish())
}
