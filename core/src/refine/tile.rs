//! Tiles without skirts (issue 6, part 2): a terrain cut into tiles that share their border rows
//! and columns, each preprocessed (seed 004, chapter 4.5; Lindstrom & Pascucci 2002) and meshed
//! on its own, possibly on other machines, whose meshes meet with identical border vertices.
//!
//! A tile's border vertex sees only its own side of the border: its error and radius lack the
//! neighbour's triangle and the neighbour's descendants. Two tiles decide a shared border vertex
//! alike when they store the same error (and, for view-dependent refinement, the same radius) for
//! it. The **protocol** makes them equal with `O(border)` data per round:
//!
//! 1. each tile runs [`super::preprocess`] (or [`super::preprocess_pyramid`]) on its own samples;
//! 2. each tile [`export_border`]s every side that has a neighbour (errors and radii of the
//!    samples along that side, in increasing order of the other coordinate);
//! 3. each tile [`merge_border`]s what its neighbours exported for the opposite sides
//!    (element-wise maximum; the count of raised values is returned);
//! 4. each tile [`renest`]s: bottom-up over the vertices whose descendants reach a merged side
//!    (at half-size `h`, those within `3h` samples of it), every vertex's error becomes the
//!    maximum of its own and its children's, and its radius again contains its children's spheres.
//!
//! Repeat 2-4 until no tile's merge raises a value (values only grow and are bounded, so this
//! ends; a border vertex near a tile corner also depends on the diagonal neighbour, through the
//! two other tiles, which is why one round is not always enough: on the bundled DEM in 257 x 257
//! tiles, three rounds raise values and a fourth confirms). At that point every shared border vertex has the same error and radius in
//! both tiles, errors and radii are nested within every tile, and every stored error still bounds
//! the tile's own samples, so the union of the tile meshes is crack-free and within `E`.
//!
//! View-dependent refinement of the tiles: give every tile the same camera, in the map's world
//! coordinates, and its grid origin ([`super::View::with_grid_origin`]). Each view-dependent test
//! then evaluates a vertex at its map grid index in `f64` (projected error and frustum planes),
//! so two tiles decide a shared border vertex bit for bit alike, even exactly at the pixel
//! threshold (moving the camera by the tile's origin in `f32` instead does crack there: see
//! `tests/tests/refine_tiles.rs`). Frustum culling uses the same planes in every tile, so a
//! border vertex is culled in both tiles or in neither.
//!
//! The compact layout ([`super::preprocess_compact`]: bfloat16 errors, level-only bounding
//! circles) runs the same protocol on the error codes alone ([`export_border_compact`],
//! [`merge_border_compact`], [`renest_compact`]): the circles depend only on the level and the
//! spacing, so they already agree. Its view-dependent test also bounds each vertex by the
//! terrain's height range, so tiles must share the map's range
//! ([`super::View::with_z_range`]).
//!
//! Optional skirts ([`skirt`]) hang below a tile's border edges for users who want them.
//!
//! Tiles of `2^k + 1` samples per side keep the hierarchy of each tile aligned with its
//! neighbours'; the last tiles of a map whose size is not a multiple may be smaller (they embed in
//! a smaller square, and their square corners are forced into both tiles' meshes by the merge).

use super::grid::RefineGrid;
use super::preprocess::{self, passes, round_up_inexact};
use super::{ErrorStore, Hierarchy, PreprocessOptions};
use crate::{Error, Terrain};

/// A side of a tile: the column `x = 0` (`XMin`), `x = width - 1` (`XMax`), the row `y = 0`
/// (`YMin`) or `y = height - 1` (`YMax`).
///
/// ```
/// use relief_core::refine::Side;
/// assert_eq!(Side::XMax.opposite(), Side::XMin);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Side {
    /// The column `x = 0`.
    XMin,
    /// The column `x = width - 1`.
    XMax,
    /// The row `y = 0`.
    YMin,
    /// The row `y = height - 1`.
    YMax,
}

impl Side {
    /// All four sides.
    ///
    /// ```
    /// assert_eq!(relief_core::refine::Side::ALL.len(), 4);
    /// ```
    pub const ALL: [Side; 4] = [Side::XMin, Side::XMax, Side::YMin, Side::YMax];

    /// The neighbour's side that coincides with this one.
    ///
    /// ```
    /// use relief_core::refine::Side;
    /// assert_eq!(Side::YMin.opposite(), Side::YMax);
    /// ```
    #[must_use]
    pub fn opposite(self) -> Side {
        match self {
            Side::XMin => Side::XMax,
            Side::XMax => Side::XMin,
            Side::YMin => Side::YMax,
            Side::YMax => Side::YMin,
        }
    }

    /// Grid point `i` along the side of a `width x height` tile.
    fn point(self, width: u32, height: u32, i: u32) -> (u32, u32) {
        match self {
            Side::XMin => (0, i),
            Side::XMax => (width.saturating_sub(1), i),
            Side::YMin => (i, 0),
            Side::YMax => (i, height.saturating_sub(1)),
        }
    }
}

/// Number of samples along `side` of a `width x height` tile: `height` for `XMin`/`XMax`,
/// `width` for `YMin`/`YMax`.
///
/// ```
/// use relief_core::refine::{border_len, Side};
/// assert_eq!(border_len(257, 100, Side::XMax), 100);
/// assert_eq!(border_len(257, 100, Side::YMin), 257);
/// ```
#[must_use]
pub fn border_len(width: u32, height: u32, side: Side) -> usize {
    match side {
        Side::XMin | Side::XMax => height as usize,
        Side::YMin | Side::YMax => width as usize,
    }
}

/// Storage index (`y * width + x`) of each of the first `n` samples along `side`, in order.
fn border_indices(width: u32, height: u32, side: Side, n: usize) -> impl Iterator<Item = usize> {
    (0..n).map(move |i| {
        let (x, y) = side.point(width, height, i as u32);
        y as usize * width as usize + x as usize
    })
}

fn check_arrays(
    width: u32,
    height: u32,
    errors: usize,
    radii: usize,
    side: Side,
    a: usize,
    b: usize,
) -> Result<(RefineGrid, usize), Error> {
    let g = RefineGrid::new(width, height)?;
    for len in [errors, radii] {
        if len < g.len() {
            return Err(Error::BufferTooSmall {
                needed: g.len(),
                actual: len,
            });
        }
    }
    let n = border_len(width, height, side);
    for len in [a, b] {
        if len < n {
            return Err(Error::BufferTooSmall {
                needed: n,
                actual: len,
            });
        }
    }
    Ok((g, n))
}

/// Step 2 of the protocol: copies the errors and radii of the [`border_len`] samples along
/// `side` of a `width x height` tile (full layout arrays of [`super::preprocess`]) into
/// `out_errors` and `out_radii`, in increasing order of the other coordinate. Returns the count.
///
/// ```
/// use relief_core::refine::{export_border, preprocess, Side};
/// use relief_core::Heightfield;
/// let hf = Heightfield::new(&[0.0f32, 0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 0.0, 0.0], 3, 3).unwrap();
/// let (mut e, mut r) = ([0.0; 9], [0.0; 9]);
/// preprocess(&hf, &mut e, &mut r).unwrap();
/// let (mut be, mut br) = ([0.0; 3], [0.0; 3]);
/// assert_eq!(export_border(3, 3, &e, &r, Side::YMin, &mut be, &mut br).unwrap(), 3);
/// assert_eq!(be[0], f32::INFINITY); // a corner of the square: always in the mesh
/// assert_eq!(be[1], e[1]);
/// ```
pub fn export_border(
    width: u32,
    height: u32,
    errors: &[f32],
    radii: &[f32],
    side: Side,
    out_errors: &mut [f32],
    out_radii: &mut [f32],
) -> Result<usize, Error> {
    let (_, n) = check_arrays(
        width,
        height,
        errors.len(),
        radii.len(),
        side,
        out_errors.len(),
        out_radii.len(),
    )?;
    for ((oe, or), k) in out_errors
        .iter_mut()
        .zip(out_radii.iter_mut())
        .zip(border_indices(width, height, side, n))
    {
        *oe = errors.get(k).copied().unwrap_or(f32::INFINITY);
        *or = radii.get(k).copied().unwrap_or(f32::INFINITY);
    }
    Ok(n)
}

/// Step 3 of the protocol: raises the errors and radii along `side` of this tile to the
/// neighbour's values (`neighbour_errors`, `neighbour_radii`: what the neighbour exported for
/// `side.opposite()`), element-wise maximum. Returns how many values were raised (0 for every
/// side of every tile ends the protocol). Call [`renest`] afterwards.
///
/// ```
/// use relief_core::refine::{merge_border, Side};
/// let (mut e, mut r) = ([0.0f32; 4], [0.0f32; 4]);
/// let raised = merge_border(2, 2, &mut e, &mut r, Side::XMax, &[5.0, 0.0], &[1.0, 0.0]);
/// assert_eq!(raised.unwrap(), 2); // e[1] and r[1]
/// assert_eq!((e[1], r[1]), (5.0, 1.0));
/// ```
pub fn merge_border(
    width: u32,
    height: u32,
    errors: &mut [f32],
    radii: &mut [f32],
    side: Side,
    neighbour_errors: &[f32],
    neighbour_radii: &[f32],
) -> Result<usize, Error> {
    let (_, n) = check_arrays(
        width,
        height,
        errors.len(),
        radii.len(),
        side,
        neighbour_errors.len(),
        neighbour_radii.len(),
    )?;
    let mut raised = 0usize;
    for ((&ne, &nr), k) in neighbour_errors
        .iter()
        .zip(neighbour_radii)
        .zip(border_indices(width, height, side, n))
    {
        if let Some(e) = errors.get_mut(k) {
            if ne > *e {
                *e = ne;
                raised += 1;
            }
        }
        if let Some(r) = radii.get_mut(k) {
            if nr > *r {
                *r = nr;
                raised += 1;
            }
        }
    }
    Ok(raised)
}

/// Step 4 of the protocol: restores nesting after [`merge_border`] on the given `sides` of the
/// tile `terrain` (whose `errors` and `radii` hold its preprocessing plus the merged values):
/// bottom-up over the vertices within `3h` samples of those sides at each half-size `h`, each
/// vertex's error becomes at least its children's and its radius contains its children's
/// spheres (with the margin of [`super::preprocess`]). Values only grow, so every stored error
/// still bounds the tile's samples. Cost: about `2.5` vertices per border sample, each O(1).
///
/// `options` must be the ones of the tile's preprocessing. With no side it changes nothing and
/// only wraps the arrays as a [`Hierarchy`] (e.g. for data received after the protocol).
///
/// ```
/// use relief_core::refine::{merge_border, preprocess, renest, PreprocessOptions, Side};
/// use relief_core::Heightfield;
/// let hf = Heightfield::new(&[0.0f32; 25], 5, 5).unwrap();
/// let (mut e, mut r) = ([0.0; 25], [0.0; 25]);
/// preprocess(&hf, &mut e, &mut r).unwrap();
/// // The neighbour saw a 3-unit error at (4, 1) (a finest-level vertex on this tile's XMax).
/// merge_border(5, 5, &mut e, &mut r, Side::XMax, &[0.0, 3.0, 0.0, 0.0, 0.0], &[0.0; 5]).unwrap();
/// let h = renest(&hf, &mut e, &mut r, &[Side::XMax], PreprocessOptions::default()).unwrap();
/// assert_eq!(h.error(3, 1), Some(3.0)); // its parent
/// assert_eq!(h.error(2, 2), Some(3.0)); // and the root
/// ```
pub fn renest<'a, T: Terrain>(
    terrain: &T,
    errors: &'a mut [f32],
    radii: &'a mut [f32],
    sides: &[Side],
    options: PreprocessOptions,
) -> Result<Hierarchy<'a>, Error> {
    let _ = options; // the children's spheres are contained whatever the corner option
    let g = preprocess::check(terrain, errors.len())?;
    preprocess::check(terrain, radii.len())?;
    for_each_border_pass(&g, sides, |h, origin, rect| {
        nest_range(terrain, &g, h, origin, rect, errors, radii);
    });
    Ok(preprocess::finish(
        terrain,
        g,
        ErrorStore::F32(errors),
        Some(radii),
    ))
}

/// An inclusive rectangle of grid indices `(x_lo, x_hi, y_lo, y_hi)`.
type Rect = (i64, i64, i64, i64);

/// Calls `f(h, pass_origin, rect)` bottom-up for every half-size `h` of `g`, every pass of that
/// half-size and every one of `sides` (at most four), with `rect` the band of the vertices within
/// `3h` samples of the side, whose descendants can reach it.
fn for_each_border_pass(g: &RefineGrid, sides: &[Side], mut f: impl FnMut(i64, (i64, i64), Rect)) {
    let (w, hgt) = (g.width() as i64, g.height() as i64);
    let n = g.side() as i64;
    let mut h = 1i64;
    while h < n {
        for (x0, y0, d) in passes(h) {
            for &side in sides.iter().take(4) {
                let rect = match side {
                    Side::XMin => (0, d, 0, hgt - 1),
                    Side::XMax => (w - 1 - d, w - 1, 0, hgt - 1),
                    Side::YMin => (0, w - 1, 0, d),
                    Side::YMax => (0, w - 1, hgt - 1 - d, hgt - 1),
                };
                f(h, (x0, y0), rect);
            }
        }
        h *= 2;
    }
}

/// Calls `f(x, y)` for every vertex of the pass with half-size `h` and origin `(x0, y0)` (the
/// lattice `(x0 + 2h i, y0 + 2h j)`) inside `rect` and the grid, row by row.
fn for_each_pass_vertex(
    g: &RefineGrid,
    h: i64,
    (x0, y0): (i64, i64),
    (xl, xh, yl, yh): Rect,
    mut f: impl FnMut(i64, i64),
) {
    let (wi, hi) = (g.width() as i64, g.height() as i64);
    let step = 2 * h;
    let first = |o: i64, lo: i64| {
        let lo = lo.max(0);
        if lo <= o {
            o
        } else {
            o + step * ((lo - o + step - 1) / step.max(1))
        }
    };
    let mut y = first(y0, yl);
    while y <= yh.min(hi - 1) {
        let mut x = first(x0, xl);
        while x <= xh.min(wi - 1) {
            f(x, y);
            x += step;
        }
        y += step;
    }
}

/// Re-nests the vertices of one pass in a rectangle: error at least the children's, radius
/// containing the children's spheres.
fn nest_range<T: Terrain>(
    t: &T,
    g: &RefineGrid,
    h: i64,
    origin: (i64, i64),
    rect: Rect,
    errors: &mut [f32],
    radii: &mut [f32],
) {
    let w = g.width() as usize;
    let idx = |x: i64, y: i64| y as usize * w + x as usize;
    let pos = |x: i64, y: i64| {
        let s = t.scale();
        [
            x as f64 * s.dx as f64,
            y as f64 * s.dy as f64,
            t.local_z(x as u32, y as u32) as f64,
        ]
    };
    for_each_pass_vertex(g, h, origin, rect, |x, y| {
        let kids = g.children(x as u32, y as u32);
        let mut e = errors.get(idx(x, y)).copied().unwrap_or(0.0);
        let p = pos(x, y);
        let mut rad = 0.0f64;
        for &(cx, cy) in kids.iter().flatten() {
            if g.in_domain(cx, cy) {
                e = e.max(errors.get(idx(cx, cy)).copied().unwrap_or(0.0));
                let rc = radii.get(idx(cx, cy)).copied().unwrap_or(0.0) as f64;
                let q = pos(cx, cy);
                let (dx, dy, dz) = (p[0] - q[0], p[1] - q[1], p[2] - q[2]);
                rad = rad.max(libm::sqrt(dx * dx + dy * dy + dz * dz) + rc);
            }
        }
        if let Some(s) = errors.get_mut(idx(x, y)) {
            *s = e;
        }
        if rad > 0.0 {
            let need =
                round_up_inexact(rad * (1.0 + preprocess::SPHERE_MARGIN) + f64::MIN_POSITIVE);
            if let Some(s) = radii.get_mut(idx(x, y)) {
                *s = s.max(need);
            }
        }
    });
}

/// Most skirt vertices, and most skirt triangles, [`skirt`] emits for a `width x height` tile:
/// two per border edge, `4 ((width - 1) + (height - 1))` (saturating).
///
/// ```
/// assert_eq!(relief_core::refine::skirt_bound(257, 129), 4 * (256 + 128));
/// ```
#[must_use]
pub const fn skirt_bound(width: u32, height: u32) -> usize {
    let w = width.saturating_sub(1) as usize;
    let h = height.saturating_sub(1) as usize;
    w.saturating_add(h).saturating_mul(4)
}

/// Optional skirts for a tile's mesh (issue 6: tiles weld without them, but some users want
/// them, e.g. to hide gaps to tiles meshed by other software): for every mesh edge lying on one
/// of `sides` of the `width x height` tile (both ends on that side's grid line), two triangles
/// hanging `depth` world units straight below the edge, facing outwards.
///
/// `vertices` and `triangles` are the tile's mesh as [`super::Refiner::triangles`] writes it
/// (world units, the tile's sample `(i, j)` at `(i dx, j dy)` with `scale`'s spacing;
/// counter-clockwise seen from +z). The skirt's vertices go to `out_vertices` and are numbered
/// after the mesh's (`vertices.len()`, `vertices.len() + 1`, ...) so the caller appends them;
/// each border edge gets its own two (positions, not indices, are shared with the neighbouring
/// edges' skirts). Buffers of [`skirt_bound`] always suffice. Returns the counts
/// `(vertices, triangles)` (equal: two each per border edge).
///
/// Errors: `depth` not finite and `> 0`; a triangle index outside `vertices`
/// ([`Error::BufferTooSmall`] naming the index needed); an output buffer too small.
///
/// ```
/// use relief_core::refine::{skirt, skirt_bound, Side};
/// use relief_core::Scale;
/// // A 2 x 2 tile as two triangles (spacing 1).
/// let v = [[0.0f32, 0.0, 5.0], [1.0, 0.0, 5.0], [0.0, 1.0, 5.0], [1.0, 1.0, 5.0]];
/// let t = [[0u32, 1, 3], [0, 3, 2]];
/// let mut sv = vec![[0.0f32; 3]; skirt_bound(2, 2)];
/// let mut st = vec![[0u32; 3]; skirt_bound(2, 2)];
/// let (nv, nt) = skirt(2, 2, Scale::default(), &v, &t, &Side::ALL, 2.0, &mut sv, &mut st).unwrap();
/// assert_eq!((nv, nt), (8, 8)); // four border edges
/// assert_eq!(sv[0][2], 3.0); // 2 below the edge
/// assert!(st[..nt].iter().flatten().all(|&i| i < 4 + nv as u32));
/// // Only the side y = 0: the edge 0 -> 1.
/// let (nv, _) = skirt(2, 2, Scale::default(), &v, &t, &[Side::YMin], 2.0, &mut sv, &mut st).unwrap();
/// assert_eq!(nv, 2);
/// assert_eq!(st[0], [1, 0, 4]);
/// ```
#[allow(clippy::too_many_arguments)]
pub fn skirt(
    width: u32,
    height: u32,
    scale: crate::Scale,
    vertices: &[[f32; 3]],
    triangles: &[[u32; 3]],
    sides: &[Side],
    depth: f32,
    out_vertices: &mut [[f32; 3]],
    out_triangles: &mut [[u32; 3]],
) -> Result<(usize, usize), Error> {
    RefineGrid::new(width, height)?;
    if !(depth.is_finite() && depth > 0.0) {
        return Err(Error::InvalidParameter {
            name: "skirt depth",
            value: depth,
        });
    }
    let (dx, dy) = (scale.dx as f64, scale.dy as f64);
    if !(dx.is_finite() && dx > 0.0 && dy.is_finite() && dy > 0.0) {
        return Err(Error::InvalidParameter {
            name: "spacing",
            value: if dx > 0.0 { scale.dy } else { scale.dx },
        });
    }
    let base = vertices.len();
    let (xmax, ymax) = (i64::from(width) - 1, i64::from(height) - 1);
    // The grid line a position is on, per axis (None: not on a grid line).
    let line = |p: f32, d: f64| {
        let g = p as f64 / d;
        let r = libm::round(g);
        ((g - r).abs() <= 1e-3).then_some(r as i64)
    };
    let on_side = |p: &[f32; 3], side: Side| match side {
        Side::XMin => line(p[0], dx) == Some(0),
        Side::XMax => line(p[0], dx) == Some(xmax),
        Side::YMin => line(p[1], dy) == Some(0),
        Side::YMax => line(p[1], dy) == Some(ymax),
    };
    let mut nv = 0usize;
    for tri in triangles {
        for (a, b) in [(tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])] {
            let get = |i: u32| {
                vertices.get(i as usize).ok_or(Error::BufferTooSmall {
                    needed: (i as usize).saturating_add(1),
                    actual: base,
                })
            };
            let (pa, pb) = (get(a)?, get(b)?);
            if !sides
                .iter()
                .take(4)
                .any(|&s| on_side(pa, s) && on_side(pb, s))
            {
                continue;
            }
            let need = nv.saturating_add(2);
            let (Some(ov), Some(ot)) = (
                out_vertices.get_mut(nv..need),
                out_triangles.get_mut(nv..need),
            ) else {
                let (v, t) = (out_vertices.len(), out_triangles.len());
                return Err(Error::BufferTooSmall {
                    needed: need,
                    actual: v.min(t),
                });
            };
            let (Ok(la), Ok(lb)) = (
                u32::try_from(base.saturating_add(nv)),
                u32::try_from(base.saturating_add(nv).saturating_add(1)),
            ) else {
                return Err(Error::SizeOverflow);
            };
            if let [va, vb] = ov {
                *va = [pa[0], pa[1], pa[2] - depth];
                *vb = [pb[0], pb[1], pb[2] - depth];
            }
            // The mesh triangle runs a -> b counter-clockwise seen from above, so the outside is
            // to the right of a -> b: (b, a, la) and (b, la, lb) face outwards.
            if let [ta, tb] = ot {
                *ta = [b, a, la];
                *tb = [b, la, lb];
            }
            nv = need;
        }
    }
    Ok((nv, nv))
}

/// [`export_border`] for the compact layout ([`super::preprocess_compact`]: bfloat16 errors,
/// level-only radii, so only errors travel): copies the error codes of the [`border_len`]
/// samples along `side` into `out_errors`, in increasing order of the other coordinate.
///
/// ```
/// use relief_core::refine::{export_border_compact, preprocess_compact, Side};
/// use relief_core::Heightfield;
/// let hf = Heightfield::new(&[0.0f32, 0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 0.0, 0.0], 3, 3).unwrap();
/// let mut e = [0u16; 9];
/// preprocess_compact(&hf, &mut e).unwrap();
/// let mut be = [0u16; 3];
/// assert_eq!(export_border_compact(3, 3, &e, Side::YMin, &mut be).unwrap(), 3);
/// assert_eq!(be[1], e[1]);
/// ```
pub fn export_border_compact(
    width: u32,
    height: u32,
    errors: &[u16],
    side: Side,
    out_errors: &mut [u16],
) -> Result<usize, Error> {
    let (_, n) = check_arrays(
        width,
        height,
        errors.len(),
        errors.len(),
        side,
        out_errors.len(),
        out_errors.len(),
    )?;
    for (oe, k) in out_errors
        .iter_mut()
        .zip(border_indices(width, height, side, n))
    {
        *oe = errors.get(k).copied().unwrap_or(BF16_INFINITY);
    }
    Ok(n)
}

/// bfloat16 `+inf` (errors are never negative or NaN, so codes order like their values).
const BF16_INFINITY: u16 = 0x7F80;

/// [`merge_border`] for the compact layout: raises the error codes along `side` to the
/// neighbour's (what it exported for `side.opposite()`), element-wise maximum (non-negative
/// bfloat16 codes order like their values). Returns how many were raised; call
/// [`renest_compact`] afterwards.
///
/// ```
/// use relief_core::refine::{merge_border_compact, Side};
/// let mut e = [0u16; 4];
/// assert_eq!(merge_border_compact(2, 2, &mut e, Side::XMax, &[0x4000, 0]).unwrap(), 1);
/// assert_eq!(e[1], 0x4000); // 2.0
/// ```
pub fn merge_border_compact(
    width: u32,
    height: u32,
    errors: &mut [u16],
    side: Side,
    neighbour_errors: &[u16],
) -> Result<usize, Error> {
    let (_, n) = check_arrays(
        width,
        height,
        errors.len(),
        errors.len(),
        side,
        neighbour_errors.len(),
        neighbour_errors.len(),
    )?;
    let mut raised = 0usize;
    for (&ne, k) in neighbour_errors
        .iter()
        .zip(border_indices(width, height, side, n))
    {
        if let Some(e) = errors.get_mut(k) {
            // A NaN code (never written by preprocessing) counts as infinite: always refined.
            let ne = if ne & 0x7FFF > BF16_INFINITY {
                BF16_INFINITY
            } else {
                ne & 0x7FFF
            };
            if ne > *e {
                *e = ne;
                raised += 1;
            }
        }
    }
    Ok(raised)
}

/// [`renest`] for the compact layout: bottom-up over the vertices within `3h` samples of the
/// merged `sides` at each half-size `h`, each vertex's error code becomes at least its
/// children's (the level-only radii nest by construction). Returns the hierarchy.
///
/// ```
/// use relief_core::refine::{merge_border_compact, preprocess_compact, renest_compact, Side};
/// use relief_core::Heightfield;
/// let hf = Heightfield::new(&[0.0f32; 25], 5, 5).unwrap();
/// let mut e = [0u16; 25];
/// preprocess_compact(&hf, &mut e).unwrap();
/// merge_border_compact(5, 5, &mut e, Side::XMax, &[0, 0x4040, 0, 0, 0]).unwrap(); // 3.0
/// let h = renest_compact(&hf, &mut e, &[Side::XMax]).unwrap();
/// assert_eq!(h.error(3, 1), Some(3.0)); // its parent
/// assert_eq!(h.error(2, 2), Some(3.0)); // and the root
/// ```
pub fn renest_compact<'a, T: Terrain>(
    terrain: &T,
    errors: &'a mut [u16],
    sides: &[Side],
) -> Result<Hierarchy<'a>, Error> {
    let g = preprocess::check(terrain, errors.len())?;
    for_each_border_pass(&g, sides, |h, origin, rect| {
        nest_codes(&g, h, origin, rect, errors);
    });
    Ok(preprocess::finish(
        terrain,
        g,
        ErrorStore::Bf16(errors),
        None,
    ))
}

/// Re-nests the error codes of one pass in a rectangle.
fn nest_codes(g: &RefineGrid, h: i64, origin: (i64, i64), rect: Rect, errors: &mut [u16]) {
    let w = g.width() as usize;
    let idx = |x: i64, y: i64| y as usize * w + x as usize;
    for_each_pass_vertex(g, h, origin, rect, |x, y| {
        let mut e = errors.get(idx(x, y)).copied().unwrap_or(0);
        for &(cx, cy) in g.children(x as u32, y as u32).iter().flatten() {
            if g.in_domain(cx, cy) {
                e = e.max(errors.get(idx(cx, cy)).copied().unwrap_or(0));
            }
        }
        if let Some(s) = errors.get_mut(idx(x, y)) {
            *s = e;
        }
    });
}
