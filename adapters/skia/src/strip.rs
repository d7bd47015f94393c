//! Top-down view of a generalized triangle strip from SOAR refinement: seed 004's in/out-edge
//! strip (Balogh 2003, chapter 5.1) or SOAR's original strip (Lindstrom & Pascucci 2001). The
//! triangles the strip draws are filled in the order the strip visits them (viridis, dark at
//! its start), a path joins their centroids in that order, and the places where a triangle
//! shares no edge with the one before it (the joins between the pieces of a strip on a grid
//! that is not `(2^k+1)^2`, made of degenerate triangles) are marked.
//!
//! Everything drawn comes from the core's strip ([`Refiner::inout_strip`],
//! [`Refiner::soar_strip`]), decoded by [`relief_core::refine::strip_triangles`]. Nothing of
//! the refinement is recomputed.

use crate::canvas::Canvas;
use crate::refine::RefineInput;
use crate::style::{rgba, viridis, BLACK, VERMILLION};
use crate::{DiagramError, DiagramOptions};
use relief_core::refine::{scratch_len, strip_fewest_indices, strip_triangles, StripCounts};
use relief_core::{Refiner, Scale, Terrain};
use tiny_skia::Pixmap;

/// Which of the core's two strips to draw.
///
/// ```
/// assert_ne!(relief_skia::strip::StripKind::InOut, relief_skia::strip::StripKind::Soar);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StripKind {
    /// Seed 004's in/out-edge strip ([`Refiner::inout_strip`]).
    InOut,
    /// SOAR's original strip ([`Refiner::soar_strip`]).
    Soar,
}

/// A strip as the diagram draws it, all of it from the core.
///
/// ```
/// use relief_core::{refine::{preprocess, Criterion}, Heightfield};
/// use relief_skia::{refine::RefineInput, strip::{strip_state, StripKind}};
/// let hf = Heightfield::new(&[0.0f32; 15], 5, 3).unwrap();
/// let (mut e, mut r) = ([0.0; 15], [0.0; 15]);
/// let h = preprocess(&hf, &mut e, &mut r).unwrap();
/// let st = strip_state(&RefineInput::new(&hf, &h, Criterion::MaxError(1.0)), StripKind::InOut).unwrap();
/// assert_eq!(st.triangles.len(), st.counts.triangles);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct StripState {
    /// World positions of the strip's vertices.
    pub vertices: Vec<[f32; 3]>,
    /// The strip's indices, degenerate triangles included.
    pub strip: Vec<u32>,
    /// The core's counts for the strip.
    pub counts: StripCounts,
    /// The triangles the strip draws (degenerate ones dropped), in its order, counter-clockwise.
    pub triangles: Vec<[u32; 3]>,
    /// The fewest indices any strip of these triangles in this order needs, each
    /// counter-clockwise ([`strip_fewest_indices`]); `None` for a strip without triangles.
    pub fewest: Option<usize>,
    /// Triangles that share no edge with the triangle before them: where the strip jumps, one
    /// per join between two pieces (none on a `(2^k+1)^2` grid, whose strip is one piece).
    pub joins: Vec<usize>,
    /// The terrain's spacing.
    pub scale: Scale,
    /// The terrain's size in samples.
    pub size: [u32; 2],
}

/// Runs the core's strip of `kind` for `input` (its criterion; camera and circles are not
/// used) and decodes it.
///
/// ```
/// use relief_core::{refine::{preprocess, Criterion}, Heightfield};
/// use relief_skia::{refine::RefineInput, strip::{strip_state, StripKind}};
/// let s: Vec<f32> = (0..81).map(|i| ((i * 37) % 11) as f32).collect();
/// let hf = Heightfield::new(&s, 9, 9).unwrap();
/// let (mut e, mut r) = (vec![0.0; 81], vec![0.0; 81]);
/// let h = preprocess(&hf, &mut e, &mut r).unwrap();
/// let st = strip_state(&RefineInput::new(&hf, &h, Criterion::MaxError(0.0)), StripKind::Soar).unwrap();
/// assert_eq!(st.triangles.len(), st.counts.triangles);
/// assert!(st.joins.is_empty()); // a square grid: one piece
/// assert!(st.counts.indices <= st.fewest.unwrap() + 3); // the fewest for its order, up to its start
/// ```
pub fn strip_state<T: Terrain>(
    input: &RefineInput<'_, T>,
    kind: StripKind,
) -> Result<StripState, DiagramError> {
    let t = input.terrain;
    let (w, h) = (t.width(), t.height());
    let r = Refiner::new(input.hierarchy, t, input.criterion)?;
    let mut scratch = vec![0u64; scratch_len(w, h)];
    let need = match kind {
        StripKind::InOut => r.inout_strip_counts(&mut scratch)?,
        StripKind::Soar => r.soar_strip_counts(&mut scratch)?,
    };
    let mut vertices = vec![[0.0f32; 3]; need.vertices];
    let mut strip = vec![0u32; need.indices];
    let counts = match kind {
        StripKind::InOut => r.inout_strip(&mut scratch, &mut vertices, &mut strip)?,
        StripKind::Soar => r.soar_strip(&mut scratch, &mut vertices, &mut strip)?,
    };
    let triangles: Vec<[u32; 3]> = strip_triangles(&strip).collect();
    let joins = triangles
        .windows(2)
        .enumerate()
        .filter(|(_, p)| p[1].iter().filter(|v| p[0].contains(v)).count() < 2)
        .map(|(k, _)| k + 1)
        .collect();
    let fewest = strip_fewest_indices(&strip, true);
    Ok(StripState {
        vertices,
        strip,
        counts,
        triangles,
        fewest,
        joins,
        scale: t.scale(),
        size: [w, h],
    })
}

/// Most triangles whose centroids the path joins (a longer path is a smear).
const MAX_PATH: usize = 60_000;

/// The diagram of [`strip_state`]`(input, kind)`: see the module docs. Sample coordinates, row
/// 0 at the top; an optional background (e.g. [`crate::hillshade`]) shows through the
/// triangles.
///
/// ```
/// use relief_core::{refine::{preprocess, Criterion}, Heightfield};
/// use relief_skia::{refine::RefineInput, strip::{strip, StripKind}, DiagramOptions};
/// let s: Vec<f32> = (0..221).map(|i| ((i * 37) % 11) as f32).collect();
/// let hf = Heightfield::new(&s, 17, 13).unwrap();
/// let (mut e, mut r) = (vec![0.0; 221], vec![0.0; 221]);
/// let h = preprocess(&hf, &mut e, &mut r).unwrap();
/// let o = DiagramOptions::default().with_max_size(200);
/// let a = strip(&RefineInput::new(&hf, &h, Criterion::MaxError(1.0)), StripKind::InOut, &o).unwrap();
/// let b = strip(&RefineInput::new(&hf, &h, Criterion::MaxError(8.0)), StripKind::InOut, &o).unwrap();
/// assert_ne!(a, b); // a different threshold draws a different strip
/// ```
pub fn strip<T: Terrain>(
    input: &RefineInput<'_, T>,
    kind: StripKind,
    opts: &DiagramOptions<'_>,
) -> Result<Pixmap, DiagramError> {
    let st = strip_state(input, kind)?;
    let s = st.scale;
    let (w, h) = (
        st.size[0].saturating_sub(1) as f32,
        st.size[1].saturating_sub(1) as f32,
    );
    let (lo, hi) = ([0.0f32, 0.0], [w.max(1e-3), h.max(1e-3)]);
    let name = match kind {
        StripKind::InOut => "in/out-edge strip",
        StripKind::Soar => "SOAR's strip",
    };
    let alpha = if opts.background.is_some() { 0.6 } else { 0.9 };
    let row = [
        (rgba(viridis(0.0), alpha), "strip start"),
        (rgba(viridis(1.0), alpha), "strip end"),
        (rgba(BLACK, 0.8), "order of the triangles"),
        (rgba(VERMILLION, 1.0), "join between pieces"),
    ];
    let counts = st.counts;
    let mut c = Canvas::new(
        lo,
        hi,
        false,
        &format!(
            "{name}: {} indices (fewest {}), {} triangles ({:.3} per triangle), {} decisions, {} joins",
            counts.indices,
            st.fewest.unwrap_or(0),
            counts.triangles,
            counts.indices_per_triangle(),
            counts.tested,
            st.joins.len()
        ),
        &[&row[..]],
        opts,
    )?;
    if let Some(bg) = opts.background {
        c.background(bg, [-0.5, -0.5], [w + 0.5, h + 0.5]);
    }
    let polys = crate::refine::sample_polygons(&st.vertices, &st.triangles, &s);
    let n = polys.len().max(2) - 1;
    for (k, poly) in polys.iter().enumerate() {
        c.fill_polygon(poly, rgba(viridis(k as f32 / n as f32), alpha));
    }
    let px = c.scale();
    if polys.len() <= 200_000 {
        let edge = if px >= 2.0 { 0.6 } else { 0.3 };
        for poly in &polys {
            c.stroke(poly, true, rgba(BLACK, 0.35), edge, false);
        }
    }
    let centroid = |p: &[[f32; 2]]| {
        let k = p.len().max(1) as f32;
        let (x, y) = p.iter().fold((0.0, 0.0), |a, q| (a.0 + q[0], a.1 + q[1]));
        [x / k, y / k]
    };
    let centres: Vec<[f32; 2]> = polys.iter().map(|p| centroid(p)).collect();
    if centres.len() <= MAX_PATH {
        // The path, cut at the joins (drawn apart below).
        let mut from = 0;
        for &j in st.joins.iter().chain([centres.len()].iter()) {
            if let Some(run) = centres.get(from..j) {
                c.stroke(run, false, rgba(BLACK, 0.8), 1.0, false);
            }
            from = j;
        }
    }
    for &j in &st.joins {
        if let (Some(a), Some(b)) = (centres.get(j - 1), centres.get(j)) {
            c.stroke(&[*a, *b], false, rgba(VERMILLION, 1.0), 1.5, true);
            c.dot(*b, 2.5, rgba(VERMILLION, 1.0));
        }
    }
    c.stroke_rect(lo, hi, rgba(BLACK, 0.8), 1.0, false);
    Ok(c.finish())
}
