//! Greedy-insertion Delaunay TIN.
//!
//! Implements the optimised greedy insertion of Garland & Heckbert, *Fast polygonal approximation
//! of terrains and height fields*, CMU-CS-95-181 (1995), in its Delaunay variant (only the
//! triangles an insertion changed are rescanned; per-triangle candidates are kept in a heap), on
//! spade's incremental [`DelaunayTriangulation`]:
//!
//! 1. Triangulate the four corners of the domain (so the mesh covers exactly the domain).
//! 2. For every triangle, scan the grid samples it covers (exact integer rasterisation) and keep
//!    its *candidate*: the sample with the largest vertical error `|h - plane|`. Faces whose
//!    candidate is above the target live in an indexed max-heap keyed by that error; a rescanned
//!    face has its key changed in place (or leaves the heap), so no entry is ever stale.
//! 3. Pop the worst candidate, insert it into the triangulation, and rescan only the faces
//!    incident to the new vertex: Delaunay insertion (split, then Lawson flips) changes no other
//!    face, since every flip it makes creates an edge from the new vertex.
//! 4. Stop when the worst candidate's error is at most the requested error, or before a vertex or
//!    triangle budget would be exceeded.
//!
//! The error a candidate carries is the mesh vertical error of CONVENTIONS.md at that sample, in
//! world z units (`z_scale` applied; `z_offset` cancels), so when the build stops on error the
//! worst remaining candidate *is* the mesh's measured error, bit for bit equal to what
//! [`mesh_error`](crate::mesh_error) reports.

use crate::heap::FaceHeap;
use crate::scan::{for_each_span, local_heights, orient, Plane};
use crate::shapes::Shapes;
use crate::MeshError;
use relief_core::{Error, Terrain};
use spade::handles::{FixedDirectedEdgeHandle, FixedFaceHandle, FixedVertexHandle, InnerTag};
use spade::{DelaunayTriangulation, LastUsedVertexHintGenerator, Point2, Triangulation};

/// Grid coordinates are stored as `f32` (exact up to 2^24; half the memory traffic of `f64` in
/// spade's point location). Every insertion passes an explicit hint, a corner of the face holding
/// the sample, so spade's hierarchy hint generator would cost upkeep without shortening a walk.
type Dt = DelaunayTriangulation<Point2<f32>, (), (), (), LastUsedVertexHintGenerator>;

/// Largest grid side: `f32` holds every integer coordinate up to `2^24` exactly.
const MAX_SIDE: u32 = (1 << 24) + 1;

/// Options of [`Tin::build`]: the error to reach and the budgets not to exceed.
///
/// Defaults: `max_error = 0` (reproduce the `triangles` surface exactly), no vertex budget
/// (`u32::MAX`), no triangle budget (`u32::MAX`). The build stops at whichever limit it meets
/// first.
///
/// ```
/// use relief_tin::TinOptions;
/// let o = TinOptions::default().with_max_error(2.5).with_max_vertices(1000);
/// assert_eq!((o.max_error, o.max_vertices, o.max_triangles), (2.5, 1000, u32::MAX));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TinOptions {
    /// Stop once the mesh vertical error (world z units) is at most this (default 0).
    pub max_error: f32,
    /// Never have more vertices than this; at least 4, the domain's corners (default `u32::MAX`).
    pub max_vertices: u32,
    /// Never have more triangles than this; at least 2 (default `u32::MAX`).
    pub max_triangles: u32,
}

impl Default for TinOptions {
    fn default() -> Self {
        TinOptions {
            max_error: 0.0,
            max_vertices: u32::MAX,
            max_triangles: u32::MAX,
        }
    }
}

impl TinOptions {
    /// Returns the options with the error target `max_error` (world z units, default 0).
    ///
    /// ```
    /// assert_eq!(relief_tin::TinOptions::default().with_max_error(1.0).max_error, 1.0);
    /// ```
    #[must_use]
    pub fn with_max_error(mut self, max_error: f32) -> Self {
        self.max_error = max_error;
        self
    }

    /// Returns the options with the vertex budget `max_vertices` (default `u32::MAX`).
    ///
    /// ```
    /// assert_eq!(relief_tin::TinOptions::default().with_max_vertices(9).max_vertices, 9);
    /// ```
    #[must_use]
    pub fn with_max_vertices(mut self, max_vertices: u32) -> Self {
        self.max_vertices = max_vertices;
        self
    }

    /// Returns the options with the triangle budget `max_triangles` (default `u32::MAX`).
    ///
    /// ```
    /// assert_eq!(relief_tin::TinOptions::default().with_max_triangles(8).max_triangles, 8);
    /// ```
    #[must_use]
    pub fn with_max_triangles(mut self, max_triangles: u32) -> Self {
        self.max_triangles = max_triangles;
        self
    }

    /// Checks the options: `max_error` finite and not negative, `max_vertices >= 4`,
    /// `max_triangles >= 2`; otherwise [`Error::InvalidParameter`] naming the field.
    ///
    /// ```
    /// use relief_core::Error;
    /// use relief_tin::TinOptions;
    /// assert!(TinOptions::default().validate().is_ok());
    /// let nan = TinOptions::default().with_max_error(f32::NAN).validate().unwrap_err();
    /// assert!(matches!(nan, Error::InvalidParameter { name: "max_error", .. }));
    /// assert_eq!(
    ///     TinOptions::default().with_max_vertices(3).validate(),
    ///     Err(Error::InvalidParameter { name: "max_vertices", value: 3.0 })
    /// );
    /// ```
    pub fn validate(&self) -> Result<(), Error> {
        if !(self.max_error.is_finite() && self.max_error >= 0.0) {
            return Err(Error::InvalidParameter {
                name: "max_error",
                value: self.max_error,
            });
        }
        if self.max_vertices < 4 {
            return Err(Error::InvalidParameter {
                name: "max_vertices",
                value: self.max_vertices as f32,
            });
        }
        if self.max_triangles < 2 {
            return Err(Error::InvalidParameter {
                name: "max_triangles",
                value: self.max_triangles as f32,
            });
        }
        Ok(())
    }
}

/// Why [`Tin::build`] stopped.
///
/// ```
/// use relief_core::Heightfield;
/// use relief_tin::{StopReason, Tin, TinOptions};
/// let hf = Heightfield::new(&[0.0f32; 9], 3, 3).unwrap();
/// let tin = Tin::build(&hf, &TinOptions::default()).unwrap();
/// assert_eq!(tin.stop_reason(), StopReason::ErrorReached);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum StopReason {
    /// The mesh error is at most [`TinOptions::max_error`].
    ErrorReached,
    /// One more vertex would exceed [`TinOptions::max_vertices`].
    VertexBudget,
    /// One more insertion could exceed [`TinOptions::max_triangles`].
    TriangleBudget,
}

/// A triangulated irregular network over a terrain's grid, built by greedy insertion.
///
/// Vertices are grid samples `[x, y]` (column, row), in insertion order: the four domain corners
/// `(0, 0)`, `(w-1, 0)`, `(w-1, h-1)`, `(0, h-1)` first, then the samples in the order the
/// greedy algorithm picked them. Triangles index the vertices, counter-clockwise seen from +z
/// (CONVENTIONS.md), and tile the domain exactly.
///
/// ```
/// use relief_core::Heightfield;
/// use relief_tin::{Tin, TinOptions};
/// // A single spike in the middle of a flat 3 x 3 grid.
/// let mut s = [0.0f32; 9];
/// s[1 * 3 + 1] = 10.0;
/// let hf = Heightfield::new(&s, 3, 3).unwrap();
/// let tin = Tin::build(&hf, &TinOptions::default().with_max_error(0.0)).unwrap();
/// assert_eq!(tin.vertices().len(), 5);
/// assert_eq!(tin.vertices()[4], [1, 1]);
/// assert_eq!(tin.triangles().len(), 4);
/// assert_eq!(tin.max_error(), 0.0);
/// assert_eq!(tin.measure(&hf).unwrap().max, 0.0);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Tin {
    width: u32,
    height: u32,
    vertices: Vec<[u32; 2]>,
    triangles: Vec<[u32; 3]>,
    max_error: f64,
    stop: StopReason,
}

/// Worst sample of a triangle: `(error, x, y)`; error 0 and the first corner when the triangle
/// covers no sample but its corners.
#[cfg(test)]
fn scan_triangle(heights: &[f32], width: usize, c: [(i64, i64); 3]) -> (f64, u32, u32) {
    let z = |p: (i64, i64)| height(heights, width, p);
    scan_triangle_z(heights, width, &mut Shapes::default(), c, || c.map(z))
}

/// Local height of grid sample `p` (0 outside `heights`, which a valid corner never is).
#[inline(always)]
fn height(heights: &[f32], width: usize, p: (i64, i64)) -> f64 {
    f64::from(
        heights
            .get(p.1 as usize * width + p.0 as usize)
            .map_or(0.0, |&h| h),
    )
}

/// [`scan_triangle`] with the corner heights given by `corner_z` (called only if the triangle
/// covers a sample besides its corners); small triangles read the samples `shapes` lists for
/// their shape, larger ones are rasterised row by row. Both give the same candidate: the
/// first sample in row order (`y`, then `x`) with the largest error.
#[inline]
fn scan_triangle_z(
    heights: &[f32],
    width: usize,
    shapes: &mut Shapes,
    c: [(i64, i64); 3],
    corner_z: impl FnOnce() -> [f64; 3],
) -> (f64, u32, u32) {
    // A lattice triangle of area 1/2 holds no sample but its corners (Pick's theorem: 2A =
    // 2 interior + boundary - 2, and the corners alone give 2A = 1): nothing to read. Most
    // triangles near full resolution are such, and their corner heights are cache misses.
    let area2 = orient(c[0], c[1], c[2]).abs();
    if area2 == 1 {
        return (0.0, c[0].0 as u32, c[0].1 as u32);
    }
    // The corners in (y, x) order, as the plane takes them.
    let key = |k: usize| (c[k].1, c[k].0);
    let mut o = [0usize, 1, 2];
    if key(o[1]) < key(o[0]) {
        o.swap(0, 1);
    }
    if key(o[2]) < key(o[1]) {
        o.swap(1, 2);
    }
    if key(o[1]) < key(o[0]) {
        o.swap(0, 1);
    }
    let s = o.map(|k| c[k]);
    let d = |k: usize| (s[k].0 - s[0].0, s[k].1 - s[0].1);
    if let Some(samples) = shapes.samples(d(1), d(2)) {
        let mut best = (0.0f64, c[0].0 as u32, c[0].1 as u32);
        let cz = corner_z();
        let Some(plane) = Plane::sorted(o.map(|k| (c[k].0, c[k].1, cz[k]))) else {
            return best;
        };
        let base = s[0].1 * width as i64 + s[0].0;
        let mut best_err = 0.0f64;
        let mut at = (0i64, 0i64);
        for &(dx, dy) in samples {
            let (dx, dy) = (i64::from(dx), i64::from(dy));
            let h = heights
                .get((base + dy * width as i64 + dx) as usize)
                .map_or(0.0, |&h| f64::from(h));
            let e = (h - plane.at_offset(dx, dy)).abs();
            if e > best_err {
                best_err = e;
                at = (dx, dy);
            }
        }
        if best_err > 0.0 {
            best = (best_err, (s[0].0 + at.0) as u32, (s[0].1 + at.1) as u32);
        }
        return best;
    }
    scan_rows(heights, width, c, corner_z(), area2)
}

/// The row-by-row scan of [`scan_triangle_z`] for triangles of any size: corner heights `cz`,
/// doubled area `area2`.
fn scan_rows(
    heights: &[f32],
    width: usize,
    c: [(i64, i64); 3],
    cz: [f64; 3],
    area2: i64,
) -> (f64, u32, u32) {
    let z = |x: i64, y: i64| height(heights, width, (x, y));
    let mut best = (0.0f64, c[0].0 as u32, c[0].1 as u32);
    let Some(plane) = Plane::new([
        (c[0].0, c[0].1, cz[0]),
        (c[1].0, c[1].1, cz[1]),
        (c[2].0, c[2].1, cz[2]),
    ]) else {
        return best;
    };
    // Doubled area 2: Pick's theorem leaves one boundary sample besides the corners (2 interior
    // + boundary = 4), the midpoint of the one edge whose both differences are even.
    if area2 == 2 {
        for k in 0..3 {
            let (p, q) = (c[k], c[(k + 1) % 3]);
            if (p.0 - q.0) % 2 == 0 && (p.1 - q.1) % 2 == 0 {
                let (x, y) = ((p.0 + q.0) / 2, (p.1 + q.1) / 2);
                let d = (z(x, y) - plane.at_row(x, plane.row(y))).abs();
                if d > 0.0 {
                    best = (d, x as u32, y as u32);
                }
                return best;
            }
        }
    }
    let mut best_err = 0.0f64;
    let (mut bx, mut by) = (c[0].0, c[0].1);
    for_each_span(c[0], c[1], c[2], |y, mut lo, mut hi| {
        // A corner on this row is an end of the row's span (a corner of a convex polygon is
        // never inside one of its chords): trim the corners off instead of testing each sample.
        if c.contains(&(lo, y)) {
            lo += 1;
        }
        if hi >= lo && c.contains(&(hi, y)) {
            hi -= 1;
        }
        if hi < lo {
            return;
        }
        let base = y as usize * width;
        let Some(row) = heights.get(base + lo as usize..=base + hi as usize) else {
            return;
        };
        if let Some((d, i)) = plane.row_max(row, lo, plane.row(y), best_err) {
            best_err = d;
            bx = lo + i as i64;
            by = y;
        }
    });
    if best_err > 0.0 {
        best = (best_err, bx as u32, by as u32);
    }
    best
}

/// Mutable state of one greedy build.
struct Builder<'h> {
    heights: &'h [f32],
    width: usize,
    /// Candidates with an error above this go into the heap; the others can never be picked.
    limit: f64,
    dt: Dt,
    /// Candidate of each face (by spade's face index); the faces above `limit` by error.
    heap: FaceHeap,
    /// The out-edges around a new vertex (reused buffer): the edge's face if inner, the far
    /// vertex's index and grid position.
    ring: Vec<RingEdge>,
    /// Samples covered by small triangles, by shape.
    shapes: Shapes,
}

/// One out-edge of a new vertex, see [`Builder::ring`].
#[derive(Clone, Copy)]
struct RingEdge {
    edge: FixedDirectedEdgeHandle,
    face: Option<FixedFaceHandle<InnerTag>>,
    vertex: u32,
    at: (i64, i64),
}

/// Where spade's corner list (`vertices()`) of the face left of out-edge `e` of a vertex `v`
/// starts in `(v, e.to, e.next.to)`: at the origin of the face's adjacent edge's predecessor.
fn first_corner(dt: &Dt, e: FixedDirectedEdgeHandle) -> usize {
    let e = dt.directed_edge(e);
    let Some(face) = e.face().as_inner() else {
        return 0;
    };
    let adjacent = face.adjacent_edge().fix();
    if adjacent == e.fix() {
        2
    } else if adjacent == e.next().fix() {
        0
    } else {
        1
    }
}

/// Grid position of a vertex (its coordinates are exact integers).
#[inline(always)]
fn grid_at(p: Point2<f32>) -> (i64, i64) {
    (p.x as i64, p.y as i64)
}

impl Builder<'_> {
    /// Scans the triangle `c` (vertex indices `vs`, corner heights from `corner_z`) and records
    /// its candidate as face `face`'s; spade lists the face's corners from `c[first(dt)]` on
    /// (asked only for a candidate that goes into the heap: the others never need a hint).
    #[inline]
    fn scan(
        &mut self,
        face: FixedFaceHandle<InnerTag>,
        c: [(i64, i64); 3],
        vs: [u32; 3],
        first: impl FnOnce(&Dt) -> usize,
        corner_z: impl FnOnce() -> [f64; 3],
    ) {
        let (err, x, y) = scan_triangle_z(self.heights, self.width, &mut self.shapes, c, corner_z);
        let queued = err > self.limit;
        if !queued {
            self.heap.set(face.index() as u32, err, x, y, vs[0], false);
            return;
        }
        let first = first(&self.dt);
        // Start spade's point location at the corner nearest the candidate: its walk then
        // ends after one look at that vertex's neighbours.
        let d2 = |k: usize| {
            let (dx, dy) = (c[k].0 - i64::from(x), c[k].1 - i64::from(y));
            dx * dx + dy * dy
        };
        // Corners in spade's order for the face (from its adjacent edge), so that a tie in
        // distance picks the same hint whichever edge the corners were listed from: the walk
        // then finds the same edge for a sample on one, and the faces keep the same indices.
        let k = (first..first + 3)
            .map(|k| k % 3)
            .min_by_key(|&k| d2(k))
            .unwrap_or(0);
        self.heap.set(face.index() as u32, err, x, y, vs[k], true);
    }

    /// Scans face `face` of the triangulation.
    fn scan_face(&mut self, face: FixedFaceHandle<InnerTag>) {
        let f = self.dt.face(face);
        let vs = f.vertices();
        let c = vs.map(|v| grid_at(v.position()));
        let vs = vs.map(|v| v.fix().index() as u32);
        let (heights, width) = (self.heights, self.width);
        self.scan(face, c, vs, |_| 0, || c.map(|p| height(heights, width, p)));
    }

    /// Inserts sample `(x, y)` (walking from vertex `hint`); rescans the faces around the new
    /// vertex. Returns whether face `top` was among them. Returns false as well if the
    /// triangulation did not gain a vertex (cannot happen for a candidate, which is never an
    /// existing vertex; checked so the loop always progresses).
    fn insert(&mut self, hint: u32, x: u32, y: u32, top: u32) -> bool {
        let before = self.dt.num_vertices();
        let hint = FixedVertexHandle::from_index(hint as usize);
        let Ok(v) = self
            .dt
            .insert_with_hint(Point2::new(x as f32, y as f32), hint)
        else {
            return false;
        };
        if self.dt.num_vertices() != before + 1 {
            return false;
        }
        // The faces around `v` in counter-clockwise order: the face left of out-edge `k` is
        // `(v, to_k, to_k+1)`, so every corner position is read once for its two faces.
        let mut ring = std::mem::take(&mut self.ring);
        ring.clear();
        let vertex = self.dt.vertex(v);
        ring.extend(vertex.out_edges().map(|e| {
            let to = e.to();
            RingEdge {
                edge: e.fix(),
                face: e.face().as_inner().map(|f| f.fix()),
                vertex: to.fix().index() as u32,
                at: grid_at(to.position()),
            }
        }));
        let pv = grid_at(vertex.position());
        let iv = v.index() as u32;
        let (heights, width) = (self.heights, self.width);
        let zv = height(heights, width, pv);
        let mut seen_top = false;
        for k in 0..ring.len() {
            let (a, b) = (ring[k], ring[(k + 1) % ring.len()]);
            let Some(face) = a.face else {
                continue;
            };
            seen_top |= face.index() as u32 == top;
            let c = [pv, a.at, b.at];
            self.scan(
                face,
                c,
                [iv, a.vertex, b.vertex],
                |dt| first_corner(dt, a.edge),
                || {
                    [
                        zv,
                        height(heights, width, a.at),
                        height(heights, width, b.at),
                    ]
                },
            );
        }
        self.ring = ring;
        seen_top
    }
}

impl Tin {
    /// Builds a TIN of `terrain` by greedy insertion (see the [module docs](crate)) until the
    /// mesh vertical error is at most `options.max_error` or a budget would be exceeded.
    ///
    /// Works on any [`Terrain`] (a [`Heightfield`](relief_core::Heightfield) or a
    /// [`Composed`](relief_core::Composed) surface) of any size. Errors:
    /// [`Error::InvalidParameter`] from [`TinOptions::validate`], [`Error::SizeOverflow`] when the
    /// grid has more than `u32::MAX` samples or a side longer than `2^24 + 1`.
    ///
    /// ```
    /// use relief_core::{Error, Heightfield};
    /// use relief_tin::{Tin, TinOptions};
    /// let s: Vec<f32> = (0..64).map(|i| ((i * 37) % 11) as f32).collect();
    /// let hf = Heightfield::new(&s, 8, 8).unwrap();
    /// let tin = Tin::build(&hf, &TinOptions::default().with_max_error(2.0)).unwrap();
    /// assert!(tin.max_error() <= 2.0);
    /// assert_eq!(tin.measure(&hf).unwrap().max, tin.max_error());
    /// let bad = TinOptions::default().with_max_error(-1.0);
    /// assert!(matches!(Tin::build(&hf, &bad), Err(Error::InvalidParameter { .. })));
    /// ```
    pub fn build<T: Terrain + ?Sized>(terrain: &T, options: &TinOptions) -> Result<Tin, Error> {
        options.validate()?;
        let (w, h) = (terrain.width(), terrain.height());
        if u64::from(w) * u64::from(h) > u64::from(u32::MAX) || w > MAX_SIDE || h > MAX_SIDE {
            return Err(Error::SizeOverflow);
        }
        let heights = local_heights(terrain)?;
        let limit = f64::from(options.max_error);
        let mut b = Builder {
            heights: &heights,
            width: w as usize,
            limit,
            dt: Dt::new(),
            heap: FaceHeap::default(),
            ring: Vec::new(),
            shapes: Shapes::default(),
        };
        let (x1, y1) = ((w - 1) as f32, (h - 1) as f32);
        for p in [(0.0, 0.0), (x1, 0.0), (x1, y1), (0.0, y1)] {
            b.dt.insert(Point2::new(p.0, p.1))
                .map_err(|_| Error::SizeOverflow)?;
        }
        let faces: Vec<_> = b.dt.fixed_inner_faces().collect();
        for f in faces {
            b.scan_face(f);
        }
        let mut max_error = None;
        let mut stop = StopReason::ErrorReached;
        // Each pass pops the worst face and inserts its candidate, a grid sample that is not yet
        // a vertex: at most `width * height` passes.
        while let Some((err, face)) = b.heap.peek() {
            if b.dt.num_vertices() >= options.max_vertices as usize {
                stop = StopReason::VertexBudget;
                max_error = Some(err);
                break;
            }
            if b.dt.num_inner_faces() + 2 > options.max_triangles as usize {
                stop = StopReason::TriangleBudget;
                max_error = Some(err);
                break;
            }
            let cand = b.heap.candidate(face);
            // The popped face stays at the top while the new vertex's faces are rescanned: the
            // triangulation reuses its index for one of them, whose rescan then changes its key
            // in place (one sift instead of a removal and an insertion). Should it not be
            // among them (a failed insertion, unreachable for a valid triangulation), it
            // leaves the heap, so the loop always progresses.
            if !b.insert(cand.hint, cand.x, cand.y, face) {
                b.heap.remove(face);
            }
        }
        // Stopped on error: every face's candidate is within the limit; the worst one is the
        // mesh error.
        let max_error = max_error.unwrap_or_else(|| {
            b.heap
                .max_error(b.dt.fixed_inner_faces().map(|f| f.index()))
        });
        let vertices =
            b.dt.vertices()
                .map(|v| {
                    let p = v.position();
                    [p.x as u32, p.y as u32]
                })
                .collect();
        let triangles =
            b.dt.inner_faces()
                .map(|f| f.vertices().map(|v| v.fix().index() as u32))
                .collect();
        Ok(Tin {
            width: w,
            height: h,
            vertices,
            triangles,
            max_error,
            stop,
        })
    }

    /// Grid size `(width, height)` of the terrain the TIN was built on.
    ///
    /// ```
    /// let hf = relief_core::Heightfield::new(&[0u8; 6], 3, 2).unwrap();
    /// let tin = relief_tin::Tin::build(&hf, &Default::default()).unwrap();
    /// assert_eq!(tin.size(), (3, 2));
    /// ```
    #[must_use]
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// The vertices as grid samples `[x, y]`, corners first, then in insertion order.
    ///
    /// ```
    /// let hf = relief_core::Heightfield::new(&[0u8; 6], 3, 2).unwrap();
    /// let tin = relief_tin::Tin::build(&hf, &Default::default()).unwrap();
    /// assert_eq!(tin.vertices(), &[[0, 0], [2, 0], [2, 1], [0, 1]]);
    /// ```
    #[must_use]
    pub fn vertices(&self) -> &[[u32; 2]] {
        &self.vertices
    }

    /// The triangles, vertex indices counter-clockwise seen from +z.
    ///
    /// ```
    /// let hf = relief_core::Heightfield::new(&[0u8; 6], 3, 2).unwrap();
    /// let tin = relief_tin::Tin::build(&hf, &Default::default()).unwrap();
    /// assert_eq!(tin.triangles().len(), 2);
    /// ```
    #[must_use]
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// The worst remaining vertical error (world z units) when the build stopped; equal to the
    /// measured mesh error ([`Tin::measure`]).
    ///
    /// ```
    /// let hf = relief_core::Heightfield::new(&[0.0f32, 0.0, 0.0, 0.0, 3.0, 0.0], 3, 2).unwrap();
    /// let o = relief_tin::TinOptions::default().with_max_vertices(4);
    /// let tin = relief_tin::Tin::build(&hf, &o).unwrap();
    /// assert_eq!(tin.max_error(), 3.0);
    /// ```
    #[must_use]
    pub fn max_error(&self) -> f64 {
        self.max_error
    }

    /// Why the build stopped.
    ///
    /// ```
    /// use relief_tin::{StopReason, Tin, TinOptions};
    /// let hf = relief_core::Heightfield::new(&[0.0f32, 0.0, 0.0, 0.0, 3.0, 0.0], 3, 2).unwrap();
    /// let tin = Tin::build(&hf, &TinOptions::default().with_max_triangles(2)).unwrap();
    /// assert_eq!(tin.stop_reason(), StopReason::TriangleBudget);
    /// ```
    #[must_use]
    pub fn stop_reason(&self) -> StopReason {
        self.stop
    }

    /// World positions `[x * dx, y * dy, z]` of the vertices, for
    /// [`relief_io::write_obj`](https://docs.rs/relief-io)-style consumers. `terrain` should be
    /// the one the TIN was built on (heights are read from it; coordinates are clamped into it).
    ///
    /// ```
    /// use relief_core::{Heightfield, Scale};
    /// let s = [1.0f32, 2.0, 3.0, 4.0];
    /// let hf = Heightfield::with_scale(&s, 2, 2, Scale::default().with_spacing(10.0, 20.0)).unwrap();
    /// let tin = relief_tin::Tin::build(&hf, &Default::default()).unwrap();
    /// assert_eq!(tin.positions(&hf)[2], [10.0, 20.0, 4.0]);
    /// ```
    #[must_use]
    pub fn positions<T: Terrain + ?Sized>(&self, terrain: &T) -> Vec<[f32; 3]> {
        let s = terrain.scale();
        self.vertices
            .iter()
            .map(|&[x, y]| [x as f32 * s.dx, y as f32 * s.dy, terrain.z(x, y)])
            .collect()
    }

    /// Measures the mesh against `terrain` with the full-grid scan of
    /// [`mesh_error`](crate::mesh_error).
    ///
    /// ```
    /// let hf = relief_core::Heightfield::new(&[0.0f32, 5.0, 1.0, 0.0], 2, 2).unwrap();
    /// let tin = relief_tin::Tin::build(&hf, &Default::default()).unwrap();
    /// assert_eq!(tin.measure(&hf).unwrap().max, 0.0);
    /// ```
    pub fn measure<T: Terrain + ?Sized>(&self, terrain: &T) -> Result<MeshError, Error> {
        crate::mesh_error(terrain, &self.vertices, &self.triangles)
    }
}

#[cfg(test)]
mod tests {
    use crate::scan::{for_each_span, orient, Plane};

    type Corners = [(i64, i64); 3];

    /// Every lattice triangle of doubled area `area2` with corners in an `n x n` box, with the
    /// samples `for_each_span` covers (corners included), sorted.
    fn lattice_triangles(n: i64, area2: i64) -> Vec<(Corners, Vec<(i64, i64)>)> {
        let pts: Vec<(i64, i64)> = (0..n * n).map(|i| (i % n, i / n)).collect();
        let mut out = Vec::new();
        for &a in &pts {
            for &b in &pts {
                for &c in &pts {
                    if orient(a, b, c).abs() == area2 {
                        let mut covered = Vec::new();
                        for_each_span(a, b, c, |y, lo, hi| {
                            covered.extend((lo..=hi).map(|x| (x, y)))
                        });
                        covered.sort_unstable();
                        out.push(([a, b, c], covered));
                    }
                }
            }
        }
        out
    }

    /// The shape table gives what the row scan gives, bit for bit (error and sample), on the
    /// lattice triangles with corners in a 10 x 10 box (every pair of first corners, every third
    /// position of the last one; corner offsets up to 9, past the table's box, so the fallback to
    /// the row scan is exercised too), with heights that tie often.
    #[test]
    fn shape_table_scan_equals_row_scan() {
        let n = 10i64;
        let heights: Vec<f32> = (0..n * n).map(|i| ((i * 7919) % 5) as f32 * 0.5).collect();
        let z = |p: (i64, i64)| f64::from(heights[(p.1 * n + p.0) as usize]);
        let mut shapes = super::Shapes::default();
        let pts: Vec<(i64, i64)> = (0..n * n).map(|i| (i % n, i / n)).collect();
        let mut checked = 0usize;
        for (i, &a) in pts.iter().enumerate() {
            for &b in &pts[i + 1..] {
                for &c in &pts {
                    let area2 = orient(a, b, c);
                    if area2 < 2 || (c.1 * n + c.0) % 3 != 0 {
                        continue;
                    }
                    let t = [a, b, c];
                    let want = super::scan_rows(&heights, n as usize, t, t.map(z), area2);
                    let got =
                        super::scan_triangle_z(&heights, n as usize, &mut shapes, t, || t.map(z));
                    assert_eq!(got.0.to_bits(), want.0.to_bits(), "{t:?}");
                    if want.0 > 0.0 {
                        assert_eq!((got.1, got.2), (want.1, want.2), "{t:?}");
                    }
                    checked += 1;
                }
            }
        }
        assert!(checked > 50_000, "{checked}");
    }

    /// The fast path of `scan_triangle`: a lattice triangle of doubled area 1 covers no sample
    /// but its corners (checked by rasterising every such triangle with corners in a 5 x 5 box).
    #[test]
    fn unit_area_triangles_cover_only_their_corners() {
        let all = lattice_triangles(5, 1);
        for (t, covered) in &all {
            let mut corners = t.to_vec();
            corners.sort_unstable();
            assert_eq!(covered, &corners, "{t:?}");
        }
        assert!(all.len() > 1000, "{}", all.len());
    }

    /// The other fast path: a lattice triangle of doubled area 2 covers exactly one sample
    /// besides its corners, the midpoint of its one edge with both differences even; and
    /// `scan_triangle` reports that sample's error as the span scan measures it.
    #[test]
    fn doubled_area_two_triangles_cover_one_edge_midpoint() {
        let heights: Vec<f32> = (0..36).map(|i| ((i * 7919) % 23) as f32 * 0.37).collect();
        let all = lattice_triangles(6, 2);
        for (t, covered) in &all {
            let [a, b, c] = *t;
            let inner: Vec<_> = covered.iter().copied().filter(|s| !t.contains(s)).collect();
            let even = [(a, b), (b, c), (c, a)]
                .into_iter()
                .filter(|(p, q)| (p.0 - q.0) % 2 == 0 && (p.1 - q.1) % 2 == 0)
                .map(|(p, q)| ((p.0 + q.0) / 2, (p.1 + q.1) / 2))
                .collect::<Vec<_>>();
            assert_eq!(inner, even, "{t:?}");
            // The span scan's answer: plane error at the covered non-corner samples.
            let z = |p: (i64, i64)| f64::from(heights[(p.1 * 6 + p.0) as usize]);
            let plane = Plane::new(t.map(|p| (p.0, p.1, z(p)))).unwrap();
            let mut want = (0.0, a.0 as u32, a.1 as u32);
            for &(x, y) in &inner {
                let d = (z((x, y)) - plane.at_row(x, plane.row(y))).abs();
                if d > want.0 {
                    want = (d, x as u32, y as u32);
                }
            }
            assert_eq!(super::scan_triangle(&heights, 6, *t), want, "{t:?}");
        }
        assert!(all.len() > 1000, "{}", all.len());
    }
}
