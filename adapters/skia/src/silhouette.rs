//! The silhouette map and chosen levels of the silhouette partitioning tree of Sakalauskas,
//! *Silhouette Partitioning for Height Field Ray Tracing* (seed 000), figure 9 (c)-(e): on the
//! left the map itself (`X x V`, one row per elevation row, nearest row at the bottom, coloured by
//! the screen height `y` of the row at each column, white where the row is not on screen), on the
//! right the silhouettes (upper envelopes) of every node of the chosen tree levels, drawn in
//! screen space. Both come from [`relief_core::silhouette`].

use crate::canvas::{Canvas, LABEL};
use crate::style::{rgba, viridis, BLACK, OKABE_ITO};
use crate::{DiagramError, DiagramOptions};
use relief_core::silhouette::{
    silhouette_envelope, silhouette_map, silhouette_map_len, tree_node_rows, SilhouetteTexel,
};
use relief_core::{Camera, Terrain};
use tiny_skia::{Pixmap, PremultipliedColorU8};

/// Most nodes drawn per level (the first ones).
const MAX_NODES: u32 = 256;

/// The silhouette map of `terrain` seen by `camera` (segments closer than `near` skipped) and the
/// silhouettes of all nodes of the tree `levels` (0 is the root, covering every row).
///
/// Errors: the core's (bad `near`, sizes), [`DiagramError::InvalidParameter`] for a level of 32
/// or more.
///
/// ```
/// use relief_core::{Camera, Heightfield};
/// use glam::Vec3;
/// let s: Vec<f32> = (0..256).map(|i| ((i % 16) as f32 * 0.7).sin() * 2.0 + (i / 16) as f32 * 0.1).collect();
/// let hf = Heightfield::new(&s, 16, 16).unwrap();
/// let cam = Camera::new(Vec3::new(7.5, -8.0, 6.0), Vec3::new(7.5, 10.0, 0.0), 60.0, 96, 64).unwrap();
/// let o = relief_skia::DiagramOptions::default().with_max_size(200);
/// let a = relief_skia::silhouette::silhouette(&hf, &cam, 0.01, &[1], &o).unwrap();
/// let b = relief_skia::silhouette::silhouette(&hf, &cam, 0.01, &[3], &o).unwrap();
/// assert_ne!(a, b); // another tree level, other silhouettes
/// ```
pub fn silhouette<T: Terrain + ?Sized>(
    terrain: &T,
    camera: &Camera,
    near: f32,
    levels: &[u32],
    opts: &DiagramOptions<'_>,
) -> Result<Pixmap, DiagramError> {
    if levels.iter().any(|&l| l >= 32) {
        return Err(DiagramError::InvalidParameter {
            name: "level",
            reason: "tree levels are 0..=31",
        });
    }
    let (sw, sh) = (camera.width, camera.height);
    let rows = terrain.height();
    let len = silhouette_map_len(sw, rows).ok_or(DiagramError::Size {
        width: sw,
        height: rows,
    })?;
    let mut map = vec![SilhouetteTexel::EMPTY; len];
    silhouette_map(terrain, camera, near, &mut map)?;
    // The map as a picture: one pixel per texel, nearest row at the bottom.
    let mut img = Pixmap::new(sw, rows).ok_or(DiagramError::Size {
        width: sw,
        height: rows,
    })?;
    let white = PremultipliedColorU8::from_rgba(255, 255, 255, 255);
    for (k, px) in img.pixels_mut().iter_mut().enumerate() {
        let (x, r) = (k % sw as usize, k / sw as usize);
        let v = rows as usize - 1 - r;
        let t = map
            .get(v * sw as usize + x)
            .copied()
            .unwrap_or(SilhouetteTexel::EMPTY);
        let c = if t.is_empty() {
            white
        } else {
            let [r8, g8, b8] = viridis(t.y / sh as f32);
            PremultipliedColorU8::from_rgba(r8, g8, b8, 255)
        };
        if let Some(c) = c {
            *px = c;
        }
    }
    let (w, h) = (sw as f32, sh as f32);
    let gap = 0.06 * w;
    let head = 0.08 * h;
    let level_names: Vec<String> = levels.iter().map(|l| l.to_string()).collect();
    let legend1 = [
        (rgba(viridis(0.0), 1.0), "map: y = 0 (bottom of screen)"),
        (rgba(viridis(1.0), 1.0), "y = screen top"),
        (rgba([255, 255, 255], 1.0), "row not on screen"),
    ];
    let lv = format!(
        "right: silhouettes of every node of level(s) {} (colour = node)",
        level_names.join(", ")
    );
    let legend2 = [(rgba(OKABE_ITO[5], 1.0), lv.as_str())];
    let mut c = Canvas::new(
        [0.0, 0.0],
        [2.0 * w + gap, h + head],
        true,
        &format!("silhouette map: {rows} rows x {sw} columns (seed 000, figure 9)"),
        &[&legend1[..], &legend2[..]],
        &DiagramOptions {
            max_size: opts.max_size.saturating_mul(2).min(8192),
            ..*opts
        },
    )?;
    c.background(&img, [0.0, 0.0], [w, h]);
    c.stroke_rect([0.0, 0.0], [w, h], rgba(BLACK, 0.8), 1.0, false);
    c.label(
        [0.0, h + head * 0.9],
        "silhouette map (row v up, screen column x across)",
        LABEL + 1.0,
        BLACK,
    );
    let ox = w + gap;
    c.fill_rect([ox, 0.0], [ox + w, h], rgba([245, 245, 245], 1.0));
    c.stroke_rect([ox, 0.0], [ox + w, h], rgba(BLACK, 0.8), 1.0, false);
    c.label(
        [ox, h + head * 0.9],
        "tree levels in screen space (x, y)",
        LABEL + 1.0,
        BLACK,
    );
    let row_h = h / rows.max(1) as f32;
    let mut env = vec![f32::NEG_INFINITY; sw as usize];
    for &level in levels {
        let mut k = 0u32;
        while let Some((a, b)) = tree_node_rows(rows, level, k) {
            if k >= MAX_NODES {
                break;
            }
            silhouette_envelope(&map, sw, a, b, &mut env)?;
            let col = OKABE_ITO[1 + (k as usize % (OKABE_ITO.len() - 1))];
            // Node boundary on the map.
            c.stroke(
                &[[0.0, a as f32 * row_h], [w, a as f32 * row_h]],
                false,
                rgba(BLACK, 0.35),
                0.8,
                true,
            );
            // The node's silhouette: a polyline, broken where no row covers the column.
            let mut run: Vec<[f32; 2]> = Vec::new();
            for (x, &y) in env.iter().enumerate() {
                if y.is_finite() {
                    run.push([ox + x as f32 + 0.5, y.clamp(0.0, h)]);
                } else if !run.is_empty() {
                    c.stroke(&run, false, rgba(col, 1.0), 1.8, false);
                    run.clear();
                }
            }
            if !run.is_empty() {
                c.stroke(&run, false, rgba(col, 1.0), 1.8, false);
            }
            k += 1;
        }
    }
    Ok(c.finish())
}
