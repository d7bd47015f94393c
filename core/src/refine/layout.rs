//! Compact 8-byte vertex records and their memory layouts for view-dependent refinement
//! (Lindstrom & Pascucci 2001, "Visualization of large terrains made easy", section on data
//! layout; seed 004, chapter 4.5: "store the surface vertices in an order that is close to the
//! refinement order").
//!
//! A [`VertexRecord`] holds everything the per-vertex decision reads: the height (`f32`), the
//! nested error and the nested bounding-sphere radius (both bfloat16, rounded up). One record is
//! one load instead of three (error, radius and height arrays), and 8 bytes instead of 12.
//!
//! Two layouts ([`RecordLayout`]):
//! - **Linear**: row-major, record `y * width + x`, like the heightfield.
//! - **Interleaved**: hierarchical, after SOAR's interleaved quadtrees. The vertices of each
//!   half-size `s` (from the coarsest, `N / 2`, to 1; `N` the enclosing square's side) are
//!   stored together, in Z-order (Morton: bits of the lattice coordinates interleaved) of the
//!   `m x m` squares of side `2s` (`m = N / 2s`): each square's centre with its lower and
//!   left edge midpoints (three records: two of the centre's four children sit next to it),
//!   then the edge midpoints of the right column and the top row; the square's four corners
//!   come last. The coarse levels, which every frame visits,
//!   are dense and small (the top `2j` levels fit in about `4^j` records), and a vertex's
//!   children sit at the same Z-order position in the same or the next half-size, so a
//!   subtree's records on each level form a few contiguous runs (SOAR stores its quadtrees with
//!   parent-to-child index arithmetic; this computes the same kind of index from `(x, y)`).
//!   Storing a half-size's centres and edge midpoints in one Z-order instead of three
//!   lattices made view-dependent frames 1-20% faster (fewer cache lines and pages per frame;
//!   BENCHMARKS.md, "Out-of-core and layouts").
//!   It needs `(N + 1)^2` records (exactly the grid for `(2^k + 1)^2` grids, more otherwise;
//!   [`records_len`]).
//!
//! Quantising radii up breaks exact sphere nesting (a parent's rounded radius can fall short of a
//! child's rounded radius plus their distance), so [`pack_records`] re-nests the rounded radii
//! bottom-up: the refinement stays crack-free and the error bound stays true.

use super::grid::RefineGrid;
use super::preprocess::{decode_bf16, encode_bf16_up, round_up_inexact};
use super::{ErrorStore, Hierarchy};
use crate::{Error, Terrain};

/// One vertex's refinement data, 8 bytes, `bytemuck::Pod`.
///
/// ```
/// use relief_core::refine::VertexRecord;
/// assert_eq!(core::mem::size_of::<VertexRecord>(), 8);
/// let r = VertexRecord { z: 1.5, error: 0x3f80, radius: 0x4000 };
/// assert_eq!((r.error_value(), r.radius_value()), (1.0, 2.0));
/// ```
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct VertexRecord {
    /// Local height of the sample (world z without `z_offset`).
    pub z: f32,
    /// Nested vertical error, bfloat16 (upper 16 bits of an `f32`), rounded up; `+inf` (0x7f80)
    /// for vertices that are always in the mesh.
    pub error: u16,
    /// Nested bounding-sphere radius, bfloat16, rounded up.
    pub radius: u16,
}

impl VertexRecord {
    /// The error as an `f32`.
    ///
    /// ```
    /// let r = relief_core::refine::VertexRecord { z: 0.0, error: 0x7f80, radius: 0 };
    /// assert_eq!(r.error_value(), f32::INFINITY);
    /// ```
    #[must_use]
    pub fn error_value(&self) -> f32 {
        decode_bf16(self.error)
    }

    /// The radius as an `f32`.
    ///
    /// ```
    /// let r = relief_core::refine::VertexRecord { z: 0.0, error: 0, radius: 0x3f80 };
    /// assert_eq!(r.radius_value(), 1.0);
    /// ```
    #[must_use]
    pub fn radius_value(&self) -> f32 {
        decode_bf16(self.radius)
    }
}

/// Order of the records in memory.
///
/// ```
/// use relief_core::refine::RecordLayout;
/// assert_eq!(RecordLayout::default(), RecordLayout::Interleaved);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RecordLayout {
    /// Row-major, `y * width + x`.
    Linear,
    /// Subtree-contiguous Z-order (Morton) over the enclosing square (default).
    #[default]
    Interleaved,
}

/// Number of records [`pack_records`] needs: `width * height` (linear) or `(N + 1)^2`
/// (interleaved, `N` the enclosing square's side); 0 for grids [`RefineGrid::new`] rejects.
///
/// ```
/// use relief_core::refine::{records_len, RecordLayout};
/// assert_eq!(records_len(1025, 1025, RecordLayout::Interleaved), 1025 * 1025);
/// assert_eq!(records_len(1000, 600, RecordLayout::Linear), 600_000);
/// assert_eq!(records_len(1000, 600, RecordLayout::Interleaved), 1025 * 1025);
/// ```
#[must_use]
pub fn records_len(width: u32, height: u32, layout: RecordLayout) -> usize {
    let Ok(g) = RefineGrid::new(width, height) else {
        return 0;
    };
    match layout {
        RecordLayout::Linear => g.len(),
        RecordLayout::Interleaved => {
            let n = g.side() as usize + 1;
            n.saturating_mul(n)
        }
    }
}

/// Spreads the low 32 bits of `v` to the even bits of a `u64`.
#[inline(always)]
fn spread(v: u64) -> u64 {
    let mut v = v & 0xffff_ffff;
    v = (v | (v << 16)) & 0x0000_ffff_0000_ffff;
    v = (v | (v << 8)) & 0x00ff_00ff_00ff_00ff;
    v = (v | (v << 4)) & 0x0f0f_0f0f_0f0f_0f0f;
    v = (v | (v << 2)) & 0x3333_3333_3333_3333;
    (v | (v << 1)) & 0x5555_5555_5555_5555
}

/// Morton code of `(a, b)`.
#[inline(always)]
fn morton(a: u64, b: u64) -> u64 {
    spread(a) | (spread(b) << 1)
}

/// Where the record of grid point `(x, y)` of a `width x height` grid sits in
/// [`pack_records`]' output for `layout`; `None` outside the grid or for grids
/// [`RefineGrid::new`] rejects. For data kept beside the records (or to read one record of a
/// mapped file).
///
/// ```
/// use relief_core::refine::{record_position, RecordLayout};
/// assert_eq!(record_position(5, 5, RecordLayout::Linear, 3, 1), Some(8));
/// // Interleaved: the centre of the square comes first, its corners last.
/// assert_eq!(record_position(5, 5, RecordLayout::Interleaved, 2, 2), Some(0));
/// assert_eq!(record_position(5, 5, RecordLayout::Interleaved, 4, 4), Some(24));
/// assert_eq!(record_position(5, 5, RecordLayout::Linear, 5, 0), None);
/// ```
#[must_use]
pub fn record_position(
    width: u32,
    height: u32,
    layout: RecordLayout,
    x: u32,
    y: u32,
) -> Option<usize> {
    let g = RefineGrid::new(width, height).ok()?;
    (x < width && y < height).then(|| record_index(layout, &g, x as u64, y as u64))
}

/// Gathers the even bits of `v` into the low 32 bits (the inverse of [`spread`]).
#[inline(always)]
fn gather(v: u64) -> u64 {
    let mut v = v & 0x5555_5555_5555_5555;
    v = (v | (v >> 1)) & 0x3333_3333_3333_3333;
    v = (v | (v >> 2)) & 0x0f0f_0f0f_0f0f_0f0f;
    v = (v | (v >> 4)) & 0x00ff_00ff_00ff_00ff;
    v = (v | (v >> 8)) & 0x0000_ffff_0000_ffff;
    (v | (v >> 16)) & 0x0000_0000_ffff_ffff
}

/// The grid point `(x, y)` of interleaved index `k` in a square of side `n = 2^k` (the inverse
/// of [`interleaved_index`]); `(0, 0)` for indices past `(n + 1)^2`. O(1): the half-size comes
/// from the index's magnitude (the records of the `j` coarsest half-sizes number
/// `(2^j + 1)^2 - 4`), the quad from a Morton decode.
#[inline(always)]
pub(crate) fn interleaved_coords(n: u64, k: u64) -> (u64, u64) {
    let corners = (n + 1) * (n + 1) - 4;
    if k >= corners {
        let c = k - corners;
        return (n * (c & 1), n * ((c >> 1) & 1));
    }
    // j: the largest with (2^j + 1)^2 - 4 <= k; from the bit length of k + 4, then corrected.
    let first = |j: u32| ((1u64 << j) + 1) * ((1u64 << j) + 1) - 4;
    let mut j = (63 - (k + 4).leading_zeros()) / 2;
    while j > 0 && first(j) > k {
        j -= 1; // at most twice
    }
    while j + 1 < 32 && first(j + 1) <= k {
        j += 1; // at most twice
    }
    let m = 1u64 << j; // quads per side at this half-size
    let t = n.trailing_zeros().saturating_sub(j + 1); // s = 2^t
    let off = k - first(j);
    let (xs, ys) = if off < 3 * m * m {
        let (q, low) = (off / 3, off % 3);
        let (a, b) = (gather(q), gather(q >> 1));
        // low 0: the centre (2a+1, 2b+1); 1: (2a+1, 2b); 2: (2a, 2b+1). Branch-free: the
        // three kinds alternate, so a branch on them mispredicts.
        (2 * a + u64::from(low != 2), 2 * b + u64::from(low != 1))
    } else if off < 3 * m * m + m {
        (2 * m, 2 * (off - 3 * m * m) + 1)
    } else {
        (2 * (off - 3 * m * m - m) + 1, 2 * m)
    };
    (xs << t, ys << t)
}

/// Record index of grid point `(x, y)` (inside the grid) for a layout.
#[inline(always)]
pub(crate) fn record_index(layout: RecordLayout, g: &RefineGrid, x: u64, y: u64) -> usize {
    match layout {
        RecordLayout::Linear => (y * g.width() as u64 + x) as usize,
        RecordLayout::Interleaved => interleaved_index(g.side() as u64, x, y) as usize,
    }
}

/// The interleaved index in a square of side `n = 2^k`: half-size by half-size from the
/// coarsest, and within a half-size `s` in Z-order of its quads (see the module documentation).
///
/// In units of `s` the points of half-size `s` are the `(X, Y)`, `0 <= X, Y <= 2m`, not both
/// even (`m = n / 2s`): quad `(X / 2, Y / 2)` holds a square's centre `(2a+1, 2b+1)` and its
/// lower and left edge midpoints `(2a+1, 2b)`, `(2a, 2b+1)`, three records from
/// `3 * morton(a, b)`, the centre first; the right column `X = 2m` and the top row `Y = 2m` follow.
#[inline(always)]
pub(crate) fn interleaved_index(n: u64, x: u64, y: u64) -> u64 {
    let bits = x | y;
    let t = bits.trailing_zeros() & 63;
    let s = 1u64 << t;
    if bits == 0 || s >= n {
        // The square's four corners, last.
        let c = u64::from(x != 0) + 2 * u64::from(y != 0);
        return (n + 1) * (n + 1) - 4 + c;
    }
    let m = n >> (t + 1); // quads per side at this half-size
    let (xs, ys) = (x >> t, y >> t);
    let base = m * m + 2 * m - 3; // records of all coarser half-sizes
    if xs == 2 * m {
        base + 3 * m * m + (ys >> 1)
    } else if ys == 2 * m {
        base + 3 * m * m + m + (xs >> 1)
    } else {
        // The centre (both odd) first, then (X odd, Y even), then (X even, Y odd).
        let low = ((xs & 1) | ((ys & 1) << 1)) % 3;
        base + 3 * morton(xs >> 1, ys >> 1) + low
    }
}

/// Packs a preprocessed hierarchy and its terrain into [`VertexRecord`]s in `layout` order
/// (`out` at least [`records_len`] long) and returns a [`Hierarchy`] that refines from the
/// records alone (heights included), usable with [`Refiner`](super::Refiner) like any other.
///
/// Errors are `hierarchy`'s rounded up to bfloat16 (still nested and still a true bound);
/// radii are `hierarchy`'s spheres (or level circles for the compact layout) rounded up and
/// re-nested so that each sphere contains its children's rounded spheres. Records that belong
/// to no grid sample (interleaved layout of a grid smaller than its square) are zeroed. The
/// mesh of a frame is the same for both layouts.
///
/// ```
/// use relief_core::refine::{pack_records, preprocess, records_len, scratch_len};
/// use relief_core::refine::{Criterion, RecordLayout, Refiner, VertexRecord};
/// use relief_core::Heightfield;
/// let s: Vec<f32> = (0..81).map(|i| ((i * 37) % 11) as f32).collect();
/// let hf = Heightfield::new(&s, 9, 9).unwrap();
/// let (mut e, mut r) = (vec![0.0; 81], vec![0.0; 81]);
/// let h = preprocess(&hf, &mut e, &mut r).unwrap();
/// let mut rec = vec![VertexRecord::default(); records_len(9, 9, RecordLayout::Interleaved)];
/// let packed = pack_records(&h, &hf, RecordLayout::Interleaved, &mut rec).unwrap();
/// assert_eq!(packed.bytes_per_vertex(), 8);
/// assert!(packed.error(4, 4).unwrap() >= h.error(4, 4).unwrap());
/// let rf = Refiner::new(&packed, &hf, Criterion::MaxError(2.0)).unwrap();
/// assert!(rf.count(&mut vec![0; scratch_len(9, 9)]).unwrap().triangles > 2);
/// ```
pub fn pack_records<'a, T: Terrain>(
    hierarchy: &Hierarchy<'_>,
    terrain: &T,
    layout: RecordLayout,
    out: &'a mut [VertexRecord],
) -> Result<Hierarchy<'a>, Error> {
    let g = hierarchy.grid();
    if terrain.width() != g.width() || terrain.height() != g.height() {
        return Err(Error::LengthMismatch {
            expected: g.len(),
            actual: terrain.width() as usize * terrain.height() as usize,
        });
    }
    let need = records_len(g.width(), g.height(), layout);
    if out.len() < need {
        return Err(Error::BufferTooSmall {
            needed: need,
            actual: out.len(),
        });
    }
    if layout == RecordLayout::Interleaved && need != g.len() {
        out.iter_mut()
            .take(need)
            .for_each(|r| *r = VertexRecord::default());
    }
    let (w, h) = (g.width() as u64, g.height() as u64);
    let s = terrain.scale();
    let pos = |x: u64, y: u64| -> [f64; 3] {
        [
            x as f64 * s.dx as f64,
            y as f64 * s.dy as f64,
            terrain.local_z(x as u32, y as u32) as f64,
        ]
    };
    // Corners and heights first: every in-domain sample.
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            if let Some(r) = out.get_mut(record_index(layout, &g, x, y)) {
                *r = VertexRecord {
                    z: terrain.local_z(x as u32, y as u32),
                    error: encode_bf16_up(hierarchy.err_at(i)),
                    radius: 0x7f80,
                };
            }
        }
    }
    // Radii bottom-up: half-size 1 first; edges of half-size s before the centres of the same
    // half-size (a centre's children are edges of its half-size, an edge's children are centres
    // of half its size).
    let side = g.side() as u64;
    let mut hs = 1u64;
    while hs < side {
        for (x0, y0) in [(hs, 0), (0, hs), (hs, hs)] {
            let mut y = y0;
            while y < h {
                let mut x = x0;
                while x < w {
                    let (xu, yu) = (x as u32, y as u32);
                    let Some(level) = g.level(xu, yu) else {
                        x += 2 * hs;
                        continue;
                    };
                    let i = (y * w + x) as usize;
                    let p = pos(x, y);
                    let mut rad = hierarchy.radius_at(i, level) as f64;
                    for &(cx, cy) in g.children(xu, yu).iter().flatten() {
                        if g.in_domain(cx, cy) {
                            let (cx, cy) = (cx as u64, cy as u64);
                            let rc = out
                                .get(record_index(layout, &g, cx, cy))
                                .map_or(f64::INFINITY, |r| r.radius_value() as f64);
                            let c = pos(cx, cy);
                            let d = libm::sqrt(
                                (p[0] - c[0]) * (p[0] - c[0])
                                    + (p[1] - c[1]) * (p[1] - c[1])
                                    + (p[2] - c[2]) * (p[2] - c[2]),
                            );
                            rad = rad.max((d + rc) * (1.0 + RENEST_MARGIN));
                        }
                    }
                    if let Some(r) = out.get_mut(record_index(layout, &g, x, y)) {
                        r.radius = encode_bf16_up(round_up_inexact(rad));
                    }
                    x += 2 * hs;
                }
                y += 2 * hs;
            }
        }
        hs *= 2;
    }
    let (z_min, z_max) = hierarchy.z_range();
    let out: &'a [VertexRecord] = out;
    Ok(Hierarchy::assemble(
        g,
        terrain.scale(),
        ErrorStore::Records(out, layout),
        None,
        z_min,
        z_max,
    ))
}

/// A [`Hierarchy`] over records that [`pack_records`] wrote earlier, for example into a file
/// that is now memory-mapped: SOAR's out-of-core use, where the preprocessed data of a grid far
/// larger than memory is paged in only where the mesh is. `scale` and `z_range` (the smallest and
/// largest local height, as [`Hierarchy::z_range`] gave when the records were packed) are stored
/// beside the records by the caller.
///
/// This is O(1): it checks sizes and parameters, not the records. Records from an untrusted
/// source should be checked once with [`check_records`] (a full pass): refinement over bad
/// records never panics, but meshes may crack or miss the error bound.
///
/// ```
/// use relief_core::refine::{pack_records, preprocess, records_hierarchy, records_len};
/// use relief_core::refine::{RecordLayout, VertexRecord};
/// use relief_core::{Heightfield, Terrain};
/// let s: Vec<f32> = (0..25).map(|i| ((i * 7) % 5) as f32).collect();
/// let hf = Heightfield::new(&s, 5, 5).unwrap();
/// let (mut e, mut r) = (vec![0.0; 25], vec![0.0; 25]);
/// let h = preprocess(&hf, &mut e, &mut r).unwrap();
/// let mut rec = vec![VertexRecord::default(); records_len(5, 5, RecordLayout::Interleaved)];
/// let packed = pack_records(&h, &hf, RecordLayout::Interleaved, &mut rec).unwrap();
/// let (z, e22) = (packed.z_range(), packed.error(2, 2));
/// // ... rec saved to a file and mapped again ...
/// let again = records_hierarchy(&rec, RecordLayout::Interleaved, 5, 5, hf.scale(), z).unwrap();
/// assert_eq!(again.error(2, 2), e22);
/// assert!(records_hierarchy(&rec[..24], RecordLayout::Interleaved, 5, 5, hf.scale(), z).is_err());
/// ```
pub fn records_hierarchy(
    records: &[VertexRecord],
    layout: RecordLayout,
    width: u32,
    height: u32,
    scale: crate::Scale,
    z_range: (f32, f32),
) -> Result<Hierarchy<'_>, Error> {
    let g = RefineGrid::new(width, height)?;
    scale.validate()?;
    let (lo, hi) = z_range;
    for (name, v) in [("z_min", lo), ("z_max", hi)] {
        if !v.is_finite() {
            return Err(Error::InvalidParameter { name, value: v });
        }
    }
    if lo > hi {
        return Err(Error::InvalidParameter {
            name: "z_min",
            value: lo,
        });
    }
    let need = records_len(width, height, layout);
    if records.len() < need {
        return Err(Error::BufferTooSmall {
            needed: need,
            actual: records.len(),
        });
    }
    Ok(Hierarchy::assemble(
        g,
        scale,
        ErrorStore::Records(records, layout),
        None,
        lo,
        hi,
    ))
}

/// Checks, in one pass over the grid, that a records [`Hierarchy`] keeps the invariants
/// [`pack_records`] establishes: every in-domain record has a finite height inside the
/// hierarchy's z range, an error that is not NaN and not negative (nor `-0`) and a finite
/// non-negative radius (`+inf` errors are allowed: always kept, and required where the vertex's
/// diamond crosses the domain's border); each vertex's error is at least
/// its children's and its sphere contains theirs with [`pack_records`]' relative margin of
/// 2^-20, so that decisions in floating point stay nested. Returns [`Error::BadSample`] naming the first
/// vertex (row-major order) that breaks one, or [`Error::InvalidParameter`] for a hierarchy that
/// is not made of records.
///
/// ```
/// use relief_core::refine::{check_records, pack_records, preprocess, records_hierarchy};
/// use relief_core::refine::{records_len, RecordLayout, VertexRecord};
/// use relief_core::{Error, Heightfield, Terrain};
/// let s: Vec<f32> = (0..25).map(|i| ((i * 7) % 5) as f32).collect();
/// let hf = Heightfield::new(&s, 5, 5).unwrap();
/// let (mut e, mut r) = (vec![0.0; 25], vec![0.0; 25]);
/// let h = preprocess(&hf, &mut e, &mut r).unwrap();
/// let mut rec = vec![VertexRecord::default(); records_len(5, 5, RecordLayout::Linear)];
/// let z = pack_records(&h, &hf, RecordLayout::Linear, &mut rec).unwrap().z_range();
/// let ok = records_hierarchy(&rec, RecordLayout::Linear, 5, 5, hf.scale(), z).unwrap();
/// assert_eq!(check_records(&ok), Ok(()));
/// rec[1 * 5 + 2].error = 0xffc0; // NaN at (2, 1)
/// let bad = records_hierarchy(&rec, RecordLayout::Linear, 5, 5, hf.scale(), z).unwrap();
/// assert_eq!(check_records(&bad), Err(Error::BadSample { x: 2, y: 1 }));
/// ```
pub fn check_records(hierarchy: &Hierarchy<'_>) -> Result<(), Error> {
    let ErrorStore::Records(recs, layout) = hierarchy.errors else {
        return Err(Error::InvalidParameter {
            name: "hierarchy (not records)",
            value: 0.0,
        });
    };
    let g = hierarchy.grid();
    let s = hierarchy.scale();
    let (lo, hi) = hierarchy.z_range();
    let rec = |x: u32, y: u32| recs.get(record_index(layout, &g, x as u64, y as u64));
    let own = |x: u32, y: u32| -> Option<VertexRecord> {
        let r = *rec(x, y)?;
        let e = r.error_value();
        let z_ok = r.z.is_finite() && r.z >= lo && r.z <= hi;
        // On codes: non-negative (no sign bit, so no -0.0, whose code would compare above
        // every positive error's) and not NaN; radii finite too.
        // A vertex whose diamond crosses the domain's border must always be split (+inf), as
        // preprocessing makes it, or a grid smaller than its square cracks at its border.
        let straddles = || {
            g.diamond(x, y)
                .iter()
                .flatten()
                .any(|t| g.classify(*t) == super::grid::Class::Straddle)
        };
        let ok = if g.level(x, y).is_none() {
            // A corner of the grid's square: always kept, its radius is never read.
            e == f32::INFINITY
        } else {
            r.error <= 0x7f80 && r.radius < 0x7f80 && (e == f32::INFINITY || !straddles())
        };
        (z_ok && ok).then_some(r)
    };
    // First each record on its own (so a bad record is named, not its parent), then nesting.
    for y in 0..g.height() {
        for x in 0..g.width() {
            if own(x, y).is_none() {
                return Err(Error::BadSample { x, y });
            }
        }
    }
    // Every record is valid on its own now; only the nesting is left to check.
    for y in 0..g.height() {
        for x in 0..g.width() {
            let bad = Err(Error::BadSample { x, y });
            let Some(&r) = rec(x, y) else {
                return bad;
            };
            let (e, rad) = (r.error_value(), r.radius_value() as f64);
            let p = [x as f64 * s.dx as f64, y as f64 * s.dy as f64, r.z as f64];
            for &(cx, cy) in g.children(x, y).iter().flatten() {
                if !g.in_domain(cx, cy) {
                    continue;
                }
                let Some(c) = rec(cx as u32, cy as u32) else {
                    return bad;
                };
                let (dx, dy, dz) = (
                    p[0] - cx as f64 * s.dx as f64,
                    p[1] - cy as f64 * s.dy as f64,
                    p[2] - c.z as f64,
                );
                let d = libm::sqrt(dx * dx + dy * dy + dz * dz);
                // The margin pack_records re-nests with, so that decisions in floating point
                // stay nested (a sphere exactly touching its child's is not enough).
                if c.error_value() > e
                    || rad < (d + c.radius_value() as f64) * (1.0 + RENEST_MARGIN)
                {
                    return bad;
                }
            }
        }
    }
    Ok(())
}

/// Relative inflation when re-nesting rounded radii (floating point).
const RENEST_MARGIN: f64 = 1.0 / (1u64 << 20) as f64;

#[cfg(test)]
mod index_tests {
    use super::*;
    use std::vec;

    /// `interleaved_coords` inverts `interleaved_index` on every point of squares up to 256.
    #[test]
    fn interleaved_coords_inverts_the_index() {
        for n in [1u64, 2, 4, 8, 16, 64, 256] {
            for y in 0..=n {
                for x in 0..=n {
                    let k = interleaved_index(n, x, y);
                    assert_eq!(interleaved_coords(n, k), (x, y), "n {n} ({x}, {y}) k {k}");
                }
            }
        }
        // Large squares: the corners, the centre and points of the finest half-size.
        for n in [1u64 << 14, 1 << 16, 1 << 20] {
            for (x, y) in [
                (0, 0),
                (n, n),
                (n / 2, n / 2),
                (1, 0),
                (n - 1, n),
                (12345 % n, 77),
            ] {
                assert_eq!(interleaved_coords(n, interleaved_index(n, x, y)), (x, y));
            }
        }
    }

    /// The interleaved index is a bijection of the `(N + 1)^2` points onto `0..(N + 1)^2`, and
    /// the coarse levels come first.
    #[test]
    fn interleaved_index_is_a_permutation() {
        for k in 1..=7 {
            let n = 1u64 << k;
            let mut seen = vec![false; ((n + 1) * (n + 1)) as usize];
            for y in 0..=n {
                for x in 0..=n {
                    let i = interleaved_index(n, x, y) as usize;
                    assert!(!seen[i], "n={n} ({x},{y}) -> {i} twice");
                    seen[i] = true;
                }
            }
            assert!(seen.iter().all(|&s| s));
            let c = n / 2;
            assert_eq!(interleaved_index(n, c, c), 0);
            let g = RefineGrid::new(n as u32 + 1, n as u32 + 1).unwrap();
            let li = |x: u64, y: u64| (g.level(x as u32, y as u32), interleaved_index(n, x, y));
            for (x, y) in [(1, 1), (3, 2), (n - 1, n)] {
                for (x2, y2) in [(c, 0), (0, c)] {
                    let ((l1, i1), (l2, i2)) = (li(x, y), li(x2, y2));
                    if l1 > l2 {
                        assert!(i1 > i2);
                    }
                }
            }
        }
    }
}
