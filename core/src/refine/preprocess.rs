//! Preprocessing for SOAR refinement (Lindstrom & Pascucci 2001/2002; Balogh 2003, seed 004,
//! chapters 4.5 and 6): a true L-infinity object-space error per vertex, nested, and nested
//! bounding spheres (or seed 004's level-only bounding circles).
//!
//! The error stored at a vertex is the maximum, over both closed triangles of its diamond, of
//! `|h(sample) - plane(sample)|` for every grid sample in the triangle, each triangle measured
//! against its own plane; then the maximum with every child's stored error (a child's error can
//! exceed its parent's). It is rounded up when stored. A triangle is only ever emitted when its
//! split vertex has stored error `<= E`, so every sample it covers is within `E` of it.

use super::grid::{Class, RefineGrid};
use super::pyramid::{max_deviation, Layout};
use super::raster::{for_each_span, span_deviation, Plane, RowSpans};
use super::{ErrorStore, Hierarchy};
use crate::{Error, Terrain};

/// Relative inflation of bounding-sphere radii so that nesting survives floating point.
pub(crate) const SPHERE_MARGIN: f64 = 1.0 / (1u64 << 20) as f64;
/// Relative inflation of level-only circle radii (their exact nesting is an equality).
pub(crate) const CIRCLE_MARGIN: f64 = 1.0 / (1u64 << 16) as f64;

/// The smallest `f32` at least `e` (`e >= 0`). The branch is taken rarely for errors: on
/// quantised heights they are mostly exact in `f32`.
#[inline]
pub(crate) fn round_up(e: f64) -> f32 {
    let f = e as f32;
    if (f as f64) < e {
        f.next_up()
    } else {
        f
    }
}

/// [`round_up`] without a branch, for values that are seldom exact in `f32` (radii, from square
/// roots), where a branch on the rounding would mispredict about half the time. For a
/// non-negative `f32` below `+inf` the next one up is the next bit pattern (the largest finite
/// one's is `+inf`); a negative one (never passed) steps the other way.
#[inline]
pub(crate) fn round_up_inexact(e: f64) -> f32 {
    let f = e as f32;
    let step = u32::from((f as f64) < e);
    let b = f.to_bits();
    let b = if b >> 31 == 0 {
        b.wrapping_add(step)
    } else {
        b.wrapping_sub(step)
    };
    f32::from_bits(b)
}

/// Encodes a non-negative error as the upper 16 bits of its `f32` pattern, rounded up
/// (bfloat16, relative step `2^-7`); monotone, so nesting survives.
#[inline]
pub(crate) fn encode_bf16_up(e: f32) -> u16 {
    let b = e.max(0.0).to_bits() as u64;
    ((b + 0xFFFF) >> 16).min(0x7F80) as u16
}

/// Decodes [`encode_bf16_up`].
#[inline(always)]
pub(crate) fn decode_bf16(c: u16) -> f32 {
    f32::from_bits((c as u32) << 16)
}

/// Where preprocessing writes errors.
pub(crate) trait ErrorSink {
    fn get(&self, i: usize) -> f32;
    fn put(&mut self, i: usize, e: f32);
}

impl ErrorSink for [f32] {
    #[inline]
    fn get(&self, i: usize) -> f32 {
        self.get(i).copied().unwrap_or(0.0)
    }
    #[inline]
    fn put(&mut self, i: usize, e: f32) {
        if let Some(s) = self.get_mut(i) {
            *s = e;
        }
    }
}

impl ErrorSink for [u16] {
    #[inline]
    fn get(&self, i: usize) -> f32 {
        self.get(i).map_or(0.0, |&c| decode_bf16(c))
    }
    #[inline]
    fn put(&mut self, i: usize, e: f32) {
        if let Some(s) = self.get_mut(i) {
            *s = encode_bf16_up(e);
        }
    }
}

#[inline(always)]
fn local(t: &impl Terrain, x: i64, y: i64) -> f64 {
    t.local_z(x as u32, y as u32) as f64
}

/// L-infinity error of one hierarchy triangle against its own plane: 0 outside the domain,
/// infinite when it crosses the domain's border (it must always be split).
pub(crate) fn triangle_error(t: &impl Terrain, g: &RefineGrid, p: [(i64, i64); 3]) -> f64 {
    match g.classify(p) {
        Class::Outside => 0.0,
        Class::Straddle => f64::INFINITY,
        Class::Inside => {
            let z = [
                local(t, p[0].0, p[0].1),
                local(t, p[1].0, p[1].1),
                local(t, p[2].0, p[2].1),
            ];
            let Some(plane) = Plane::new([
                (p[0].0, p[0].1, z[0]),
                (p[1].0, p[1].1, z[1]),
                (p[2].0, p[2].1, z[2]),
            ]) else {
                return 0.0;
            };
            if super::raster::orient(p[0], p[1], p[2]).abs() <= 4 {
                // Area 1 (the finest vertex level): the samples are the three corners and the
                // midpoint of the one edge of even length. Area 2 (centres of 2 x 2 squares):
                // the corners and the midpoints of all three edges (no interior point, by
                // Pick's theorem). Same values as rasterising.
                let mut e = 0.0f64;
                for k in 0..3 {
                    let (a, b) = (p[k], p[(k + 1) % 3]);
                    e = e.max((z[k] - plane.at(a.0, a.1)).abs());
                    if (a.0 - b.0) % 2 == 0 && (a.1 - b.1) % 2 == 0 {
                        let (mx, my) = ((a.0 + b.0) / 2, (a.1 + b.1) / 2);
                        e = e.max((local(t, mx, my) - plane.at(mx, my)).abs());
                    }
                }
                return e;
            }
            let mut e = 0.0f64;
            for_each_span(p[0], p[1], p[2], |y, lo, hi| {
                let row = span_deviation(t, &plane, y, lo, hi);
                if row > e {
                    e = row;
                }
            });
            e
        }
    }
}

fn position(t: &impl Terrain, x: i64, y: i64) -> [f64; 3] {
    let s = t.scale();
    [
        x as f64 * s.dx as f64,
        y as f64 * s.dy as f64,
        local(t, x, y),
    ]
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    let (dx, dy, dz) = (a[0] - b[0], a[1] - b[1], a[2] - b[2]);
    libm::sqrt(dx * dx + dy * dy + dz * dz)
}

/// The min/max pyramid that lets [`vertex`] skip blocks of large triangles.
#[derive(Clone, Copy)]
pub(crate) struct Pruning<'p> {
    pub(crate) layout: &'p Layout,
    pub(crate) buf: &'p [f32],
}

/// Triangles whose bounding box is at least this many samples wide use the pyramid.
const PRUNE_EXTENT: i64 = 8;

/// [`triangle_error`], or something `<= floor` when that is `<= floor` (blocks of the pyramid
/// that cannot beat the running maximum are skipped; every sample term is the same formula).
fn triangle_error_pruned(
    t: &impl Terrain,
    g: &RefineGrid,
    p: [(i64, i64); 3],
    pruning: Option<Pruning<'_>>,
    floor: f64,
) -> f64 {
    let Some(pr) = pruning else {
        return triangle_error(t, g, p);
    };
    let ext = (p[0].0.max(p[1].0).max(p[2].0) - p[0].0.min(p[1].0).min(p[2].0))
        .max(p[0].1.max(p[1].1).max(p[2].1) - p[0].1.min(p[1].1).min(p[2].1));
    if ext < PRUNE_EXTENT || g.classify(p) != Class::Inside {
        return triangle_error(t, g, p);
    }
    let z = [
        local(t, p[0].0, p[0].1),
        local(t, p[1].0, p[1].1),
        local(t, p[2].0, p[2].1),
    ];
    let (Some(plane), Some(spans)) = (
        Plane::new([
            (p[0].0, p[0].1, z[0]),
            (p[1].0, p[1].1, z[1]),
            (p[2].0, p[2].1, z[2]),
        ]),
        RowSpans::new(p[0], p[1], p[2]),
    ) else {
        return 0.0;
    };
    max_deviation(t, pr.layout, pr.buf, &spans, &plane, floor)
}

/// Whether the square of the centre vertex `(x, y)` of half-size `h` is cut along its main
/// diagonal: `main_diagonal(x - h, y - h, 2h)` with shifts (`x - h` and `y - h` are multiples
/// of `2h`).
#[inline(always)]
fn on_main_diagonal(x: i64, y: i64, h: i64) -> bool {
    let k = (2 * h).trailing_zeros();
    (((x - h) >> k) + ((y - h) >> k)) & 1 == 0
}

/// The diamond triangles and children of the vertex `(x, y)` of half-size `h` in pass `pass`
/// (0: horizontal edges, 1: vertical edges, 2: centres), the same sets as
/// [`RefineGrid::diamond`] and [`RefineGrid::children`] (tested), by shifts instead of the
/// integer divisions those need for an arbitrary point.
#[inline(always)]
#[allow(clippy::type_complexity)]
pub(crate) fn shape(
    g: &RefineGrid,
    x: i64,
    y: i64,
    h: i64,
    pass: usize,
) -> ([Option<[(i64, i64); 3]>; 2], [Option<(i64, i64)>; 4]) {
    let n = g.side() as i64;
    let inside = |t: [(i64, i64); 3]| {
        t.iter()
            .all(|&(a, b)| a >= 0 && b >= 0 && a <= n && b <= n)
            .then_some(t)
    };
    let ok = |p: (i64, i64)| (p.0 >= 0 && p.1 >= 0 && p.0 <= n && p.1 <= n).then_some(p);
    let edge_kids = |x: i64, y: i64| {
        if h >= 2 {
            let q = h / 2;
            [
                ok((x - q, y - q)),
                ok((x + q, y - q)),
                ok((x - q, y + q)),
                ok((x + q, y + q)),
            ]
        } else {
            [None; 4]
        }
    };
    match pass {
        0 => {
            let (e0, e1) = ((x - h, y), (x + h, y));
            (
                [inside([e0, e1, (x, y + h)]), inside([e1, e0, (x, y - h)])],
                edge_kids(x, y),
            )
        }
        1 => {
            let (e0, e1) = ((x, y - h), (x, y + h));
            (
                [inside([e0, e1, (x - h, y)]), inside([e1, e0, (x + h, y)])],
                edge_kids(x, y),
            )
        }
        _ => {
            let (c00, c10, c01, c11) = (
                (x - h, y - h),
                (x + h, y - h),
                (x - h, y + h),
                (x + h, y + h),
            );
            let d = if on_main_diagonal(x, y, h) {
                [Some([c00, c10, c11]), Some([c00, c11, c01])]
            } else {
                [Some([c00, c10, c01]), Some([c10, c11, c01])]
            };
            (
                d,
                [
                    ok((x - h, y)),
                    ok((x + h, y)),
                    ok((x, y - h)),
                    ok((x, y + h)),
                ],
            )
        }
    }
}

/// Whether [`near_row`] may take [`vertex_near`] (always outside tests; tests switch it off to
/// compare against [`vertex_general`], the reference).
#[cfg(not(test))]
struct FastFinest;
#[cfg(not(test))]
impl FastFinest {
    #[inline(always)]
    fn get(&self) -> bool {
        true
    }
}
#[cfg(not(test))]
const FAST_FINEST: FastFinest = FastFinest;
#[cfg(test)]
std::thread_local! {
    /// Test switch: `false` forces the reference path.
    pub(crate) static FAST_FINEST: core::cell::Cell<bool> = const { core::cell::Cell::new(true) };
}

/// Height at `q` (relative to the vertex, each coordinate in `-H..=H`) from the row-major
/// `(2H + 1)^2` neighbourhood `nb`.
#[inline(always)]
fn nb_at<const H: i64, const S: usize>(nb: &[f64; S], q: (i64, i64)) -> f64 {
    nb.get(((q.1 + H) * (2 * H + 1) + q.0 + H) as usize)
        .copied()
        .unwrap_or(0.0)
}

/// L-infinity error of a triangle of area 1 or 2 given in coordinates relative to its vertex
/// (each in `-1..=1`), heights from the 3 x 3 neighbourhood `nb`: [`triangle_error`]'s closed
/// form with the same plane formula (a plane depends only on coordinate differences, so relative
/// coordinates give the same values), which constant coordinates let the compiler fold.
#[inline(always)]
#[cfg(test)]
fn small_error<const S: usize>(nb: &[f64; S], p: [(i64, i64); 3]) -> f64 {
    let at = |q: (i64, i64)| nb_at::<1, S>(nb, q);
    let z = [at(p[0]), at(p[1]), at(p[2])];
    let Some(plane) = Plane::new([
        (p[0].0, p[0].1, z[0]),
        (p[1].0, p[1].1, z[1]),
        (p[2].0, p[2].1, z[2]),
    ]) else {
        return 0.0;
    };
    let mut e = 0.0f64;
    for k in 0..3 {
        let (a, b) = (p[k], p[(k + 1) % 3]);
        e = e.max((z[k] - plane.at(a.0, a.1)).abs());
        if (a.0 - b.0) % 2 == 0 && (a.1 - b.1) % 2 == 0 {
            let (mx, my) = ((a.0 + b.0) / 2, (a.1 + b.1) / 2);
            e = e.max((at((mx, my)) - plane.at(mx, my)).abs());
        }
    }
    e
}

/// The plane of triangle `p` (coordinates relative to a vertex, each in `-H..=H`) through its
/// corners' heights in the `(2H + 1)^2` neighbourhood `nb`; `None` if degenerate.
#[inline(always)]
fn near_plane<const H: i64, const S: usize>(nb: &[f64; S], p: [(i64, i64); 3]) -> Option<Plane> {
    let z = |k: usize| nb_at::<H, S>(nb, p[k]);
    Plane::new([
        (p[0].0, p[0].1, z(0)),
        (p[1].0, p[1].1, z(1)),
        (p[2].0, p[2].1, z(2)),
    ])
}

/// L-infinity error of a triangle given in coordinates relative to its vertex (each in
/// `-H..=H`), heights from the `(2H + 1)^2` neighbourhood `nb`: the maximum of the rasterising
/// path's very terms `|h - plane|` over the same samples (those of the closed triangle, tested
/// against the rasteriser by `raster`'s tests), in another order (a maximum does not depend on
/// it). Lists the samples at run time (the tests' reference for [`near_triangle_error`]).
#[cfg(test)]
fn box_error<const H: i64, const S: usize>(nb: &[f64; S], p: [(i64, i64); 3]) -> f64 {
    let Some(plane) = near_plane::<H, S>(nb, p) else {
        return 0.0;
    };
    let (list, n) = inside_offsets(H, p);
    let mut e = 0.0f64;
    for &(dx, dy) in list.get(..n).unwrap_or(&[]) {
        let (dx, dy) = (i64::from(dx), i64::from(dy));
        let d = (nb_at::<H, S>(nb, (dx, dy)) - plane.at(dx, dy)).abs();
        e = if d > e { d } else { e };
    }
    e
}

/// [`box_error`] of triangle `K` (0 or 1) of the diamond of shape `P` ([`NearShape`]) of a vertex
/// of half-size `H`: the same terms over the same samples, each sample a constant of its own
/// (written out, not looped over, so that its coordinates fold into the plane formula whatever
/// the unroller decides; samples past the triangle's count are compile-time no-ops). Serves
/// `H = 1` as well, where the samples are the corners and the midpoints of the even edges.
#[inline(always)]
fn near_triangle_error<const H: i64, const S: usize, const P: u8, const K: usize>(
    nb: &[f64; S],
) -> f64 {
    let p = NearShape::<H, P>::DIAMOND[K];
    let Some(plane) = near_plane::<H, S>(nb, p) else {
        return 0.0;
    };
    let (list, n) = NearShape::<H, P>::INSIDE[K];
    let mut e = 0.0f64;
    macro_rules! samples {
        ($($k:literal)*) => {$(
            if $k < n {
                let (dx, dy) = (i64::from(list[$k].0), i64::from(list[$k].1));
                let d = (nb_at::<H, S>(nb, (dx, dy)) - plane.at(dx, dy)).abs();
                e = if d > e { d } else { e };
            }
        )*};
    }
    samples!(0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 28 29 30 31
        32 33 34 35 36 37 38 39 40 41 42 43 44 45 46 47 48 49 50 51 52 53 54 55 56 57 58 59 60 61
        62 63 64 65 66 67 68 69 70 71 72 73 74 75 76 77 78 79 80 81 82 83 84 85 86 87 88 89 90 91
        92 93 94 95 96 97 98 99 100 101 102 103 104 105 106 107 108 109 110 111 112 113 114 115 116
        117 118 119 120 121 122 123 124 125 126 127 128 129 130 131 132 133 134 135 136 137 138 139
        140 141 142 143 144 145 146 147 148 149 150 151 152);
    e
}

/// The largest half-size the neighbourhood path ([`vertex_near`]) serves.
const NEAR_MAX_H: i64 = 8;

/// Capacity of a triangle's sample list in the neighbourhood path: the samples of a closed right
/// triangle with legs `2 NEAR_MAX_H`, `(2H + 1)(2H + 2) / 2`.
const NEAR_SAMPLES: usize = 153;

/// The samples `(dx, dy)` of the closed lattice triangle `p` (coordinates relative to a vertex,
/// each in `-h..=h`, `h <= 8`) in row order (`dy`, then `dx`), and how many (at most
/// [`NEAR_SAMPLES`]: a right triangle with legs 16 holds 153).
const fn inside_offsets(h: i64, p: [(i64, i64); 3]) -> ([(i8, i8); NEAR_SAMPLES], usize) {
    use super::raster::orient;
    let mut out = [(0i8, 0i8); NEAR_SAMPLES];
    let mut n = 0usize;
    let sg = orient(p[0], p[1], p[2]).signum();
    let mut dy = -h;
    while dy <= h {
        let mut dx = -h;
        while dx <= h {
            let q = (dx, dy);
            if orient(p[0], p[1], q) * sg >= 0
                && orient(p[1], p[2], q) * sg >= 0
                && orient(p[2], p[0], q) * sg >= 0
                && n < out.len()
            {
                out[n] = (dx as i8, dy as i8);
                n += 1;
            }
            dx += 1;
        }
        dy += 1;
    }
    (out, n)
}

/// The diamond (two triangles) of a vertex of half-size `h` (at most 8) and shape `p` (as in
/// [`vertex_near`]), relative to the vertex: the sets of [`shape`] (tested), corners listed as
/// there.
const fn near_diamond(h: i64, p: u8) -> [[(i64, i64); 3]; 2] {
    match p {
        0 => [[(-h, 0), (h, 0), (0, h)], [(h, 0), (-h, 0), (0, -h)]],
        1 => [[(0, -h), (0, h), (-h, 0)], [(0, h), (0, -h), (h, 0)]],
        2 => [[(-h, -h), (h, -h), (h, h)], [(-h, -h), (h, h), (-h, h)]],
        _ => [[(-h, -h), (h, -h), (-h, h)], [(h, -h), (h, h), (-h, h)]],
    }
}

/// Compile-time data of a vertex shape of the neighbourhood path: half-size `H` (at most 8),
/// shape `P` (as in [`vertex_near`]).
struct NearShape<const H: i64, const P: u8>;

impl<const H: i64, const P: u8> NearShape<H, P> {
    /// The diamond, [`near_diamond`].
    const DIAMOND: [[(i64, i64); 3]; 2] = near_diamond(H, P);
    /// The samples of each of its triangles, [`inside_offsets`].
    const INSIDE: [([(i8, i8); NEAR_SAMPLES], usize); 2] = [
        inside_offsets(H, Self::DIAMOND[0]),
        inside_offsets(H, Self::DIAMOND[1]),
    ];
    /// The diamond's four distinct corners.
    const CORNERS: [(i64, i64); 4] = match P {
        0 => [(-H, 0), (H, 0), (0, H), (0, -H)],
        1 => [(0, -H), (0, H), (-H, 0), (H, 0)],
        _ => [(-H, -H), (H, -H), (-H, H), (H, H)],
    };
    /// The children (the diagonal ones of an edge vertex, none for `H = 1`; the edge midpoints
    /// of a centre's square) and how many.
    const KIDS: ([(i64, i64); 4], usize) = match P {
        0 | 1 => (
            [
                (-H / 2, -H / 2),
                (H / 2, -H / 2),
                (-H / 2, H / 2),
                (H / 2, H / 2),
            ],
            if H >= 2 { 4 } else { 0 },
        ),
        _ => ([(-H, 0), (H, 0), (0, -H), (0, H)], 4),
    };

    /// [`NearShape::KIDS`] as a slice.
    #[inline(always)]
    fn kids() -> &'static [(i64, i64)] {
        Self::KIDS.0.get(..Self::KIDS.1).unwrap_or(&[])
    }
}

/// [`vertex_general`] for a vertex of half-size `H` (1, 2, 4 or 8; `S = (2H + 1)^2`) at
/// `(x, y)` whose `(2H + 1)^2` neighbourhood lies in the domain (so every triangle is inside and
/// every corner and child in the domain): the heights are read once, the diamond's two planes
/// are built in relative coordinates, and the arithmetic is otherwise the same, in the same
/// order.
///
/// `P` is the vertex's shape: 0 an edge vertex of pass 0, 1 of pass 1, 2 a centre whose square is
/// cut along its main diagonal, 3 along the other one. As a constant it makes every relative
/// coordinate below a constant, so the plane formulas and the inside tests fold (each shape is
/// its own copy: one copy for all four, choosing the coordinates at run time, took about three
/// times the instructions).
#[inline(always)]
fn vertex_near<const H: i64, const S: usize, const P: u8, T: Terrain, E: ErrorSink + ?Sized>(
    t: &T,
    g: &RefineGrid,
    (x, y): (i64, i64),
    errors: &mut E,
    radii: Option<&mut [f32]>,
    contain_corners: bool,
) {
    let mut nb = [0.0f64; S];
    let side = (2 * H + 1) as usize;
    // Row by row (constant trip counts unroll; no division per entry).
    for (row, dy) in nb.chunks_exact_mut(side).zip(-H..=H) {
        let mut hs = [0.0f32; 2 * NEAR_MAX_H as usize + 1];
        let hs = hs.get_mut(..side).unwrap_or(&mut []);
        t.local_z_row((x - H) as u32, (y + dy) as u32, hs);
        for (v, &z) in row.iter_mut().zip(hs.iter()) {
            *v = z as f64;
        }
    }
    near_store::<H, S, P, T, E>(t, g, (x, y), &nb, errors, radii, contain_corners);
}

/// One vertex of a neighbourhood-path row (see [`near_row`]): [`vertex_near`] with shape `P` when its
/// `(2H + 1)^2` neighbourhood lies in the domain, else [`vertex_general`].
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn near_one<const H: i64, const S: usize, const P: u8, T: Terrain, E: ErrorSink + ?Sized>(
    t: &T,
    g: &RefineGrid,
    (x, y, pass): (i64, i64, usize),
    fast_row: bool,
    errors: &mut E,
    radii: Option<&mut [f32]>,
    contain_corners: bool,
    pruning: Option<Pruning<'_>>,
) {
    if fast_row && x >= H && g.in_domain(x + H, y) {
        vertex_near::<H, S, P, T, E>(t, g, (x, y), errors, radii, contain_corners);
    } else {
        vertex_general(
            t,
            g,
            (x, y, H, pass),
            errors,
            radii,
            contain_corners,
            pruning,
        );
    }
}

/// The vertices `x_first, x_first + 2H, ..., <= x_end` of row `y` of a pass with half-size `H`
/// (1, 2, 4 or 8; `S = (2H + 1)^2`), alternately of shape `PA` and `PB` (as in [`vertex_near`];
/// the same for edge vertices, the two diagonals for centres, starting with `x_first`'s). Vertices
/// whose `(2H + 1)^2` neighbourhood lies in the domain take [`vertex_near`], the others
/// [`vertex_general`]; both store bit-identical values (tested). Never inlined: each
/// instantiation keeps its shapes' constants (merged copies chose them at run time).
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn near_row<const H: i64, const S: usize, const PA: u8, const PB: u8, T, E>(
    t: &T,
    g: &RefineGrid,
    (y, pass): (i64, usize),
    (x_first, x_end): (i64, i64),
    errors: &mut E,
    mut radii: Option<&mut [f32]>,
    contain_corners: bool,
    pruning: Option<Pruning<'_>>,
) where
    T: Terrain,
    E: ErrorSink + ?Sized,
{
    let fast_row = FAST_FINEST.get() && y >= H && g.in_domain(0, y + H);
    let mut x = x_first;
    // Two vertices per turn, one of each shape, one after the other (not one body choosing its
    // shape). At most `(x_end - x_first) / 2H + 1` vertices.
    while x <= x_end {
        let (r, e) = (radii.as_deref_mut(), &mut *errors);
        near_one::<H, S, PA, T, E>(t, g, (x, y, pass), fast_row, e, r, contain_corners, pruning);
        x += 2 * H;
        if x > x_end {
            break;
        }
        let (r, e) = (radii.as_deref_mut(), &mut *errors);
        near_one::<H, S, PB, T, E>(t, g, (x, y, pass), fast_row, e, r, contain_corners, pruning);
        x += 2 * H;
    }
}

/// The rest of [`vertex_near`] for one diamond shape `P` ([`NearShape`]: its triangles, four
/// distinct corners and children, relative to `(x, y)`). The radius takes one square root for all
/// corners (`sqrt` is correctly rounded, hence monotone: the square root of the largest squared
/// distance is the largest distance, bit for bit).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn near_store<const H: i64, const S: usize, const P: u8, T: Terrain, E: ErrorSink + ?Sized>(
    t: &T,
    g: &RefineGrid,
    (x, y): (i64, i64),
    nb: &[f64; S],
    errors: &mut E,
    radii: Option<&mut [f32]>,
    contain_corners: bool,
) {
    let (corners, kids) = (NearShape::<H, P>::CORNERS, NearShape::<H, P>::kids());
    let w = g.width() as usize;
    let idx = |q: (i64, i64)| (y + q.1) as usize * w + (x + q.0) as usize;
    let mut c = 0.0f32;
    for &kq in kids {
        c = c.max(errors.get(idx(kq)));
    }
    let e = 0.0f64
        .max(near_triangle_error::<H, S, P, 0>(nb))
        .max(near_triangle_error::<H, S, P, 1>(nb));
    errors.put(idx((0, 0)), round_up(e).max(c));
    if let Some(r) = radii {
        let s = t.scale();
        let pos = |q: (i64, i64)| {
            [
                (x + q.0) as f64 * s.dx as f64,
                (y + q.1) as f64 * s.dy as f64,
                nb_at::<H, S>(nb, q),
            ]
        };
        let p = pos((0, 0));
        let d2 = |a: [f64; 3], b: [f64; 3]| {
            let (dx, dy, dz) = (a[0] - b[0], a[1] - b[1], a[2] - b[2]);
            dx * dx + dy * dy + dz * dz
        };
        let mut rad = 0.0f64;
        if contain_corners {
            let mut m = 0.0f64;
            for cq in corners {
                m = m.max(d2(p, pos(cq)));
            }
            rad = rad.max(libm::sqrt(m));
        }
        for &kq in kids {
            let rc = r.get(idx(kq)).copied().unwrap_or(0.0) as f64;
            rad = rad.max(dist(p, pos(kq)) + rc);
        }
        if let Some(slot) = r.get_mut(idx((0, 0))) {
            *slot = round_up_inexact(rad * (1.0 + SPHERE_MARGIN) + f64::MIN_POSITIVE);
        }
    }
}

/// The reference computation of [`vertex`] for any vertex.
#[inline]
#[allow(clippy::too_many_arguments)]
pub(crate) fn vertex_general<T: Terrain, E: ErrorSink + ?Sized>(
    t: &T,
    g: &RefineGrid,
    (x, y, h, pass): (i64, i64, i64, usize),
    errors: &mut E,
    radii: Option<&mut [f32]>,
    contain_corners: bool,
    pruning: Option<Pruning<'_>>,
) {
    let w = g.width() as usize;
    let idx = |x: i64, y: i64| y as usize * w + x as usize;
    let (diamond, kids) = shape(g, x, y, h, pass);
    let mut c = 0.0f32;
    for &(cx, cy) in kids.iter().flatten() {
        if g.in_domain(cx, cy) {
            c = c.max(errors.get(idx(cx, cy)));
        }
    }
    let mut e = 0.0f64;
    for tri in diamond.iter().flatten() {
        e = e.max(triangle_error_pruned(t, g, *tri, pruning, e.max(c as f64)));
    }
    errors.put(idx(x, y), round_up(e).max(c));
    if let Some(r) = radii {
        let p = position(t, x, y);
        let mut rad = 0.0f64;
        if contain_corners {
            // Each distinct corner once (the two triangles share their hypotenuse; a repeated
            // corner would give the same distance).
            let [a, b] = diamond;
            let seen = |q: (i64, i64)| a.is_some_and(|ta| ta.contains(&q));
            let firsts = a.into_iter().flatten();
            let seconds = b.into_iter().flatten().filter(|&q| !seen(q));
            for (cx, cy) in firsts.chain(seconds) {
                if g.in_domain(cx, cy) {
                    rad = rad.max(dist(p, position(t, cx, cy)));
                }
            }
        }
        for &(cx, cy) in kids.iter().flatten() {
            if g.in_domain(cx, cy) {
                let rc = r.get(idx(cx, cy)).copied().unwrap_or(0.0) as f64;
                rad = rad.max(dist(p, position(t, cx, cy)) + rc);
            }
        }
        if let Some(slot) = r.get_mut(idx(x, y)) {
            *slot = round_up_inexact(rad * (1.0 + SPHERE_MARGIN) + f64::MIN_POSITIVE);
        }
    }
}

/// The half-sizes of the hierarchy's vertices, finest first, and for each the three passes in
/// dependency order: `(x0, y0)` of the pass's lattice (step `2h` in both directions) and the
/// distance from a changed region within which the pass's vertices may change
/// (`2h - 1` for edge vertices, `3h - 1` for centres; see [`super::update`]).
pub(crate) fn passes(h: i64) -> [(i64, i64, i64); 3] {
    [(h, 0, 2 * h - 1), (0, h, 2 * h - 1), (h, h, 3 * h - 1)]
}

/// Computes every vertex with half-size `h` of the given pass whose coordinates lie in
/// `[x_lo, x_hi] x [y_lo, y_hi]` (clipped to the grid), in the order [`build`] uses.
#[allow(clippy::too_many_arguments)]
pub(crate) fn pass_range<T: Terrain, E: ErrorSink + ?Sized>(
    t: &T,
    g: &RefineGrid,
    h: i64,
    (x0, y0): (i64, i64),
    (x_lo, x_hi, y_lo, y_hi): (i64, i64, i64, i64),
    errors: &mut E,
    mut radii: Option<&mut [f32]>,
    contain_corners: bool,
    pruning: Option<Pruning<'_>>,
) {
    let (wi, hi) = (g.width() as i64, g.height() as i64);
    let step = 2 * h;
    // First lattice coordinate >= lo: x0 + step * ceil((lo - x0) / step).
    let first = |o: i64, lo: i64| {
        let lo = lo.max(0);
        if lo <= o {
            o
        } else {
            o + step * ((lo - o + step - 1) / step.max(1))
        }
    };
    let (xe, ye) = (x_hi.min(wi - 1), y_hi.min(hi - 1));
    let pass = if y0 == 0 {
        0
    } else if x0 == 0 {
        1
    } else {
        2
    };
    let mut y = first(y0, y_lo);
    while y <= ye {
        let xs = (first(x0, x_lo), xe);
        let (r, e, cc, pr) = (radii.as_deref_mut(), &mut *errors, contain_corners, pruning);
        // Centres: whether the square of the row's first vertex is cut along its main diagonal;
        // the next one's is not.
        let main = || on_main_diagonal(xs.0, y, h);
        // The row's shapes as constants: edge vertices of pass 0 or 1, or centres alternating
        // between the two diagonals, starting with the first vertex's.
        macro_rules! near {
            ($h:literal, $s:literal) => {
                match pass {
                    0 => near_row::<$h, $s, 0, 0, T, E>(t, g, (y, pass), xs, e, r, cc, pr),
                    1 => near_row::<$h, $s, 1, 1, T, E>(t, g, (y, pass), xs, e, r, cc, pr),
                    _ if main() => {
                        near_row::<$h, $s, 2, 3, T, E>(t, g, (y, pass), xs, e, r, cc, pr)
                    }
                    _ => near_row::<$h, $s, 3, 2, T, E>(t, g, (y, pass), xs, e, r, cc, pr),
                }
            };
        }
        match h {
            1 => near!(1, 9),
            2 => near!(2, 25),
            4 => near!(4, 81),
            8 => near!(8, 289),
            _ => {
                let mut x = xs.0;
                while x <= xe {
                    let (r, e) = (radii.as_deref_mut(), &mut *errors);
                    vertex_general(t, g, (x, y, h, pass), e, r, contain_corners, pruning);
                    x += step;
                }
            }
        }
        y += step;
    }
}

/// Sets the square's corners (always in the mesh): infinite error, zero radius.
pub(crate) fn corners<E: ErrorSink + ?Sized>(
    g: &RefineGrid,
    errors: &mut E,
    mut radii: Option<&mut [f32]>,
) {
    let w = g.width() as usize;
    let n = g.side() as i64;
    for (cx, cy) in [(0, 0), (n, 0), (0, n), (n, n)] {
        if g.in_domain(cx, cy) {
            let i = cy as usize * w + cx as usize;
            errors.put(i, f32::INFINITY);
            if let Some(r) = radii.as_deref_mut() {
                if let Some(slot) = r.get_mut(i) {
                    *slot = 0.0;
                }
            }
        }
    }
}

/// Fills `errors` (and `radii` when given) bottom-up. Loops: `levels x width x height`
/// vertices, each over the samples of its diamond (about `2 width height` per level), fewer with
/// `pruning`.
pub(crate) fn build<T: Terrain, E: ErrorSink + ?Sized>(
    t: &T,
    g: &RefineGrid,
    errors: &mut E,
    mut radii: Option<&mut [f32]>,
    contain_corners: bool,
    pruning: Option<Pruning<'_>>,
) {
    let n = g.side() as i64;
    let all = (0, i64::MAX, 0, i64::MAX);
    let mut h = 1i64;
    while h < n {
        // Edge vertices of half-size h (children: centres of half-size h/2, done), then centres
        // of half-size h (children: these edge vertices).
        for (x0, y0, _) in passes(h) {
            pass_range(
                t,
                g,
                h,
                (x0, y0),
                all,
                errors,
                radii.as_deref_mut(),
                contain_corners,
                pruning,
            );
        }
        h *= 2;
    }
    corners(g, errors, radii);
}

/// Checks that `terrain` fits `len` per-vertex entries and returns its grid.
pub(crate) fn check<T: Terrain>(t: &T, len: usize) -> Result<RefineGrid, Error> {
    let g = RefineGrid::new(t.width(), t.height())?;
    if len < g.len() {
        return Err(Error::BufferTooSmall {
            needed: g.len(),
            actual: len,
        });
    }
    Ok(g)
}

/// Minimum and maximum local height over the grid.
pub(crate) fn z_range<T: Terrain>(t: &T) -> (f32, f32) {
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    for y in 0..t.height() {
        for x in 0..t.width() {
            let z = t.local_z(x, y);
            lo = lo.min(z);
            hi = hi.max(z);
        }
    }
    (lo, hi)
}

/// Builds the [`Hierarchy`] value once the arrays are filled.
pub(crate) fn finish<'a, T: Terrain>(
    t: &T,
    grid: RefineGrid,
    errors: ErrorStore<'a>,
    radii: Option<&'a [f32]>,
) -> Hierarchy<'a> {
    let (z_min, z_max) = z_range(t);
    Hierarchy::assemble(grid, t.scale(), errors, radii, z_min, z_max)
}

#[cfg(test)]
mod fast_tests {
    use super::super::{
        hierarchy_len, preprocess_compact, preprocess_pyramid, preprocess_with, pyramid_len,
        PreprocessOptions,
    };
    use super::FAST_FINEST;
    use crate::{Heightfield, Scale, Terrain};
    use std::vec;
    use std::vec::Vec;

    fn terrain(w: u32, h: u32, seed: u64, kind: u32) -> Vec<f32> {
        let mut s = seed | 1;
        let mut r = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        };
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                let n = ((r() >> 11) % 100_000) as f32 / 100_000.0;
                match kind {
                    0 => 30.0 * libm::sinf(x * 0.11) * libm::cosf(y * 0.07) + 0.3 * x + 5.0 * n,
                    1 => (r() % 7) as f32, // small integers: many exact ties and zero errors
                    2 => 1.0e6 * n - 5.0e5, // large magnitudes: rounding in the planes
                    _ => {
                        if i == (w * h) / 2 {
                            100.0
                        } else {
                            0.0
                        }
                    }
                }
            })
            .collect()
    }

    /// Runs `f` with the neighbourhood path on and off.
    fn both<R>(mut f: impl FnMut() -> R) -> (R, R) {
        FAST_FINEST.set(true);
        let fast = f();
        FAST_FINEST.set(false);
        let reference = f();
        FAST_FINEST.set(true);
        (fast, reference)
    }

    fn bits(v: &[f32]) -> Vec<u32> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    /// [`super::round_up_inexact`] is [`super::round_up`] without its branch: the same `f32` for
    /// exact, inexact, tiny, huge and infinite values.
    #[test]
    fn round_up_inexact_is_round_up() {
        use super::{round_up, round_up_inexact};
        let mut vals = vec![
            0.0,
            f64::MIN_POSITIVE,
            1e-45,
            1.5e-45,
            1.0,
            0.1,
            1.0 / 3.0,
            f64::from(f32::MAX),
            f64::from(f32::MAX) * (1.0 + 1e-12),
            1e300,
            f64::INFINITY,
        ];
        let mut next = super::super::tests::rng(0x2545_f491_4f6c_dd1d);
        for _ in 0..100_000 {
            let x = next();
            // Random magnitudes from 1e-30 to 1e30, half of them exact in f32.
            let m = (x >> 11) as f64 / (1u64 << 53) as f64;
            let v = 10f64.powf(m * 60.0 - 30.0);
            vals.push(if x & 1 == 0 { f64::from(v as f32) } else { v });
        }
        for v in vals {
            assert_eq!(
                round_up_inexact(v).to_bits(),
                round_up(v).to_bits(),
                "{v:e}"
            );
            assert!(f64::from(round_up(v)) >= v, "{v:e}");
        }
    }

    /// Each triangle's error from the neighbourhood paths ([`super::small_error`],
    /// [`super::box_error`]) equals [`super::triangle_error`]'s bit for bit, triangle by
    /// triangle (the nested values above can hide a wrong triangle behind a child's error).
    #[test]
    fn neighbourhood_triangle_errors_match_rasterising() {
        use super::super::grid::RefineGrid;
        use super::{box_error, shape, small_error, triangle_error};
        let mut checked = 0usize;
        // The (2H + 1)^2 neighbourhood of (x, y), zero outside the grid.
        fn nb<const H: i64, const S: usize>(hf: &Heightfield<'_, f32>, x: i64, y: i64) -> [f64; S] {
            let side = 2 * H + 1;
            let mut nb = [0.0f64; S];
            for (k, v) in nb.iter_mut().enumerate() {
                let (qx, qy) = (x + k as i64 % side - H, y + k as i64 / side - H);
                if qx >= 0 && qy >= 0 && qx < hf.width() as i64 && qy < hf.height() as i64 {
                    *v = hf.local_z(qx as u32, qy as u32) as f64;
                }
            }
            nb
        }
        let sizes = [
            (17, 17, 0),
            (13, 9, 2),
            (9, 11, 1),
            (33, 33, 3),
            (41, 35, 0),
        ];
        for (w, h, kind) in sizes {
            let s = terrain(w, h, 99 + kind as u64, kind);
            let hf = Heightfield::new(&s, w, h).unwrap();
            let g = RefineGrid::new(w, h).unwrap();
            for hs in [1i64, 2, 4, 8] {
                for (pass, (x0, y0)) in [(hs, 0), (0, hs), (hs, hs)].into_iter().enumerate() {
                    for y in (y0..h as i64 - hs).step_by(2 * hs as usize) {
                        for x in (x0..w as i64 - hs).step_by(2 * hs as usize) {
                            if x < hs || y < hs {
                                continue;
                            }
                            let (diamond, _) = shape(&g, x, y, hs, pass);
                            let nb17 = nb::<8, 289>(&hf, x, y);
                            for tri in diamond.iter().flatten() {
                                let want = triangle_error(&hf, &g, *tri).to_bits();
                                let q = tri.map(|p| (p.0 - x, p.1 - y));
                                let got17 = box_error::<8, 289>(&nb17, q).to_bits();
                                assert_eq!(got17, want, "box17 ({x},{y}) h {hs} {tri:?}");
                                let own = match hs {
                                    1 => box_error::<1, 9>(&nb::<1, 9>(&hf, x, y), q),
                                    2 => box_error::<2, 25>(&nb::<2, 25>(&hf, x, y), q),
                                    4 => box_error::<4, 81>(&nb::<4, 81>(&hf, x, y), q),
                                    _ => box_error::<8, 289>(&nb17, q),
                                };
                                assert_eq!(own.to_bits(), want, "own ({x},{y}) h {hs} {tri:?}");
                                if hs == 1 {
                                    let nb3 = nb::<1, 9>(&hf, x, y);
                                    assert_eq!(small_error(&nb3, q).to_bits(), want);
                                }
                                checked += usize::from(want != 0);
                            }
                        }
                    }
                }
            }
        }
        assert!(checked > 300, "{checked}");
    }

    /// The compile-time tables of the neighbourhood path ([`super::NearShape`], half-sizes 1, 2, 4
    /// and 8) are the grid's own diamonds ([`super::shape`]) and the rasteriser's samples
    /// ([`super::super::raster`]).
    #[test]
    fn near_shapes_are_the_grid_diamonds_and_their_samples() {
        use super::super::grid::RefineGrid;
        use super::super::raster::for_each_span;
        use super::{inside_offsets, near_diamond, shape};
        let g = RefineGrid::new(65, 65).unwrap();
        for h in [1i64, 2, 4, 8] {
            // A vertex of each shape: edge passes at (3h, 2h) and (2h, 3h); centres at (3h, 3h)
            // and (5h, 3h), whose squares are cut along the two different diagonals.
            let cases = [
                (0u8, 3 * h, 2 * h, 0),
                (1, 2 * h, 3 * h, 1),
                (2, 3 * h, 3 * h, 2),
                (3, 5 * h, 3 * h, 2),
            ];
            for (p, x, y, pass) in cases {
                let (d, _) = shape(&g, x, y, h, pass);
                let want: Vec<_> = d
                    .iter()
                    .map(|t| t.unwrap().map(|q| (q.0 - x, q.1 - y)))
                    .collect();
                let got = near_diamond(h, p);
                // The same triangles (as corner sets); which diagonal a centre takes decides `p`.
                let norm = |t: [(i64, i64); 3]| {
                    let mut t = t.to_vec();
                    t.sort();
                    t
                };
                let mut a: Vec<_> = want.iter().map(|&t| norm(t)).collect();
                let mut b: Vec<_> = got.iter().map(|&t| norm(t)).collect();
                a.sort();
                b.sort();
                assert_eq!(a, b, "h {h} shape {p}");
                for t in got {
                    let (list, n) = inside_offsets(h, t);
                    let mut spans = Vec::new();
                    for_each_span(t[0], t[1], t[2], |yy, lo, hi| {
                        for xx in lo..=hi {
                            spans.push((xx as i8, yy as i8));
                        }
                    });
                    assert_eq!(list[..n].to_vec(), spans, "h {h} shape {p} {t:?}");
                }
            }
        }
    }

    /// Every preprocessing entry point stores bit-identical errors and radii with the
    /// neighbourhood path (half-sizes 1, 2, 4 and 8) and with the general (reference) path, on
    /// grids of many shapes (odd, even, tiny, non-square), four terrains, unit and non-unit
    /// scales, both sphere kinds.
    #[test]
    fn fine_level_fast_path_is_bit_identical() {
        let sizes = [
            (2, 2),
            (3, 3),
            (4, 3),
            (5, 5),
            (9, 9),
            (10, 7),
            (17, 33),
            (33, 33),
            (64, 48),
            (65, 65),
            (100, 77),
            (129, 129),
            (150, 97),
        ];
        let scales = [
            Scale::default(),
            Scale::default().with_spacing(160.0, 37.5).with_z_scale(0.1),
        ];
        let mut nonzero = 0usize;
        for (si, &(w, h)) in sizes.iter().enumerate() {
            for kind in 0..4 {
                let s = terrain(w, h, 7 + si as u64 * 31 + kind as u64, kind);
                for scale in scales {
                    let hf = Heightfield::with_scale(&s, w, h, scale).unwrap();
                    let n = hierarchy_len(w, h);
                    for contain in [true, false] {
                        let o = PreprocessOptions::default().with_contain_diamond(contain);
                        let (a, b) = both(|| {
                            let (mut e, mut r) = (vec![0.0f32; n], vec![0.0f32; n]);
                            preprocess_with(&hf, &mut e, &mut r, o).unwrap();
                            (bits(&e), bits(&r))
                        });
                        assert_eq!(a, b, "{w}x{h} kind {kind} contain {contain}");
                        nonzero += a.0.iter().filter(|&&e| e != 0).count();
                        let (a, b) = both(|| {
                            let (mut e, mut r) = (vec![0.0f32; n], vec![0.0f32; n]);
                            let mut p = vec![0.0f32; pyramid_len(w, h)];
                            preprocess_pyramid(&hf, &mut e, &mut r, &mut p, o).unwrap();
                            (bits(&e), bits(&r))
                        });
                        assert_eq!(a, b, "pyramid {w}x{h} kind {kind} contain {contain}");
                    }
                    let (a, b) = both(|| {
                        let mut e = vec![0u16; n];
                        preprocess_compact(&hf, &mut e).unwrap();
                        e
                    });
                    assert_eq!(a, b, "compact {w}x{h} kind {kind}");
                }
            }
        }
        // The comparison is not between two arrays of zeros.
        assert!(nonzero > 10_000, "{nonzero}");
    }
}
