//! Stateless SOAR refinement (Lindstrom & Pascucci 2001; seed 004 chapters 4.5 and 5.2): the
//! per-vertex decision (nested error or projected error, frustum culling with an active-plane
//! mask, lazy culling) and the indexed-triangle-list output with vertices numbered by their rank
//! in a bitmap of kept vertices.

use super::grid::{Class, Edge, RefineGrid};
use super::layout::{interleaved_coords, interleaved_index, record_index};
use super::{ErrorStore, Hierarchy, VertexRecord};
use crate::{Camera, Error, Terrain};
use core::mem::MaybeUninit;
use glam::Vec4;

mod rows;

/// What a vertex must satisfy to be refined.
///
/// ```
/// use relief_core::refine::Criterion;
/// let c = Criterion::MaxError(0.5);
/// assert!(matches!(c, Criterion::MaxError(e) if e == 0.5));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Criterion {
    /// View-independent: every vertex with nested error `> E` (world z units) is in the mesh,
    /// so the mesh's vertical error at every grid sample is at most `E`.
    MaxError(f32),
    /// View-dependent: SOAR's projected error against a pixel threshold, with culling.
    View(View),
}

/// View-dependent refinement parameters: camera, pixel threshold, culling.
///
/// A vertex with error `e` whose bounding volume is at distance `d` from the eye (nearest point)
/// is refined when `e * kappa > tau * d`, with `kappa = (image_height / 2) / tan(fov / 2)`; the
/// test is nested (errors and volumes are), so the mesh has no cracks, and every in-view sample's
/// vertical error projects to at most `tau` pixels.
///
/// Defaults: near plane 0.1 world units, no far plane, culling on, lazy culling from the finest
/// level up 4 levels ([`View::with_lazy_levels`]), no geomorphing.
///
/// ```
/// use relief_core::{refine::View, Camera};
/// use glam::Vec3;
/// let cam = Camera::new(Vec3::new(0.0, 0.0, 10.0), Vec3::new(10.0, 10.0, 0.0), 60.0, 640, 480).unwrap();
/// let v = View::new(&cam, 1.0).unwrap();
/// assert_eq!(v.pixel_error(), 1.0);
/// assert!(View::new(&cam, f32::NAN).is_err());
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    camera: Camera,
    tau: f32,
    near: f32,
    far: Option<f32>,
    culling: bool,
    lazy_levels: u32,
    morph_range: Option<f32>,
    origin: (u32, u32),
    z_range: Option<(f32, f32)>,
}

impl View {
    /// Refinement for `camera` with a threshold of `pixel_error` pixels (finite, `>= 0`).
    ///
    /// ```
    /// # use relief_core::{refine::View, Camera, Error}; use glam::Vec3;
    /// # let cam = Camera::new(Vec3::ZERO, Vec3::X, 60.0, 4, 4).unwrap();
    /// assert_eq!(
    ///     View::new(&cam, -1.0).unwrap_err(),
    ///     Error::InvalidParameter { name: "pixel_error", value: -1.0 }
    /// );
    /// ```
    pub fn new(camera: &Camera, pixel_error: f32) -> Result<View, Error> {
        if !(pixel_error.is_finite() && pixel_error >= 0.0) {
            return Err(Error::InvalidParameter {
                name: "pixel_error",
                value: pixel_error,
            });
        }
        Ok(View {
            camera: *camera,
            tau: pixel_error,
            near: 0.1,
            far: None,
            culling: true,
            lazy_levels: 4,
            morph_range: None,
            origin: (0, 0),
            z_range: None,
        })
    }

    /// The pixel threshold.
    ///
    /// ```
    /// # use relief_core::{refine::View, Camera}; use glam::Vec3;
    /// # let cam = Camera::new(Vec3::ZERO, Vec3::X, 60.0, 4, 4).unwrap();
    /// assert_eq!(View::new(&cam, 2.0).unwrap().pixel_error(), 2.0);
    /// ```
    #[must_use]
    pub fn pixel_error(&self) -> f32 {
        self.tau
    }

    /// Camera, near, far, culling and lazy levels (for the detail refiner in `detail.rs`).
    pub(crate) fn settings(&self) -> (&Camera, f32, Option<f32>, bool, u32) {
        (
            &self.camera,
            self.near,
            self.far,
            self.culling,
            self.lazy_levels,
        )
    }

    /// Near plane distance (default 0.1) and optional far plane (default none) for culling.
    ///
    /// ```
    /// # use relief_core::{refine::View, Camera}; use glam::Vec3;
    /// # let cam = Camera::new(Vec3::ZERO, Vec3::X, 60.0, 4, 4).unwrap();
    /// let v = View::new(&cam, 1.0).unwrap().with_near_far(1.0, Some(1000.0));
    /// # let _ = v;
    /// ```
    #[must_use]
    pub fn with_near_far(mut self, near: f32, far: Option<f32>) -> Self {
        self.near = near;
        self.far = far;
        self
    }

    /// Turns frustum culling on (default) or off.
    ///
    /// ```
    /// # use relief_core::{refine::View, Camera}; use glam::Vec3;
    /// # let cam = Camera::new(Vec3::ZERO, Vec3::X, 60.0, 4, 4).unwrap();
    /// let v = View::new(&cam, 1.0).unwrap().with_culling(false);
    /// # let _ = v;
    /// ```
    #[must_use]
    pub fn with_culling(mut self, on: bool) -> Self {
        self.culling = on;
        self
    }

    /// Lazy culling (seed 004, chapter 5.2): vertices in the finest `levels` levels are not
    /// tested against the frustum but accepted as if inside (default 4; 0 tests every level).
    /// This removes the culling pop of spheres that do not contain their diamond, and leaves
    /// T-junctions only outside the view. The strips ([`Refiner::inout_strip`],
    /// [`Refiner::soar_strip`]) test culling at every level: a T-junction breaks a strip.
    ///
    /// ```
    /// # use relief_core::{refine::View, Camera}; use glam::Vec3;
    /// # let cam = Camera::new(Vec3::ZERO, Vec3::X, 60.0, 4, 4).unwrap();
    /// let strict = View::new(&cam, 1.0).unwrap().with_lazy_levels(0);
    /// # let _ = strict;
    /// ```
    #[must_use]
    pub fn with_lazy_levels(mut self, levels: u32) -> Self {
        self.lazy_levels = levels;
        self
    }

    /// Geomorphing (SOAR): a kept vertex's morph factor grows from 0 where its projected error
    /// equals the threshold to 1 where it is `range` times the threshold (`range > 1`); see
    /// [`Refiner::morph`]. Default: none.
    ///
    /// ```
    /// # use relief_core::{refine::View, Camera}; use glam::Vec3;
    /// # let cam = Camera::new(Vec3::ZERO, Vec3::X, 60.0, 4, 4).unwrap();
    /// let v = View::new(&cam, 1.0).unwrap().with_geomorph(Some(2.0));
    /// # let _ = v;
    /// ```
    #[must_use]
    pub fn with_geomorph(mut self, range: Option<f32>) -> Self {
        self.morph_range = range;
        self
    }

    /// For a tile of a larger map (see [`super::export_border`]): the tile's grid sample
    /// `(0, 0)` is the map's sample `(x, y)` (default `(0, 0)`), and the camera is in the map's
    /// world coordinates (not moved to the tile). Every view-dependent test then evaluates a
    /// vertex at the map's grid index `(x + i, y + j)`, in `f64`, so two tiles that hold the
    /// same error, radius and height for a shared border vertex decide it identically, bit for
    /// bit, even exactly at the pixel threshold.
    ///
    /// ```
    /// # use relief_core::{refine::View, Camera}; use glam::Vec3;
    /// # let cam = Camera::new(Vec3::ZERO, Vec3::X, 60.0, 4, 4).unwrap();
    /// let second_tile = View::new(&cam, 1.0).unwrap().with_grid_origin(256, 0);
    /// # let _ = second_tile;
    /// ```
    #[must_use]
    pub fn with_grid_origin(mut self, x: u32, y: u32) -> Self {
        self.origin = (x, y);
        self
    }

    /// For tiles in the compact layout (level-only bounding circles, which extend over the
    /// terrain's whole height range): the height range `[lo, hi]` of the whole map in local z
    /// ([`Terrain::local_z`](crate::Terrain::local_z): `z_scale` applied, no `z_offset`), e.g.
    /// the minimum and maximum of `local_z` over every tile, so every tile bounds its vertices by
    /// the same cylinders and decides a shared border vertex alike. The range used is the union
    /// of this one and the tile's own (a larger range only makes the bound more conservative).
    /// Default: the tile's. Ignored for sphere layouts.
    ///
    /// ```
    /// # use relief_core::{refine::View, Camera}; use glam::Vec3;
    /// # let cam = Camera::new(Vec3::ZERO, Vec3::X, 60.0, 4, 4).unwrap();
    /// let tile = View::new(&cam, 1.0).unwrap().with_grid_origin(128, 0).with_z_range(-10.0, 4000.0);
    /// # let _ = tile;
    /// ```
    #[must_use]
    pub fn with_z_range(mut self, lo: f32, hi: f32) -> Self {
        self.z_range = Some((lo, hi));
        self
    }
}

/// Sizes of one frame's mesh.
///
/// ```
/// let c = relief_core::refine::FrameCounts { vertices: 4, triangles: 2 };
/// assert_eq!(c.triangles, 2);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FrameCounts {
    /// Vertices referenced by the triangles.
    pub vertices: usize,
    /// Triangles.
    pub triangles: usize,
}

/// Sizes of one frame's triangle strip.
///
/// ```
/// let c = relief_core::refine::StripCounts { vertices: 4, indices: 4, triangles: 2, tested: 5 };
/// assert_eq!(c.indices_per_triangle(), 2.0);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct StripCounts {
    /// Vertices in the vertex buffer.
    pub vertices: usize,
    /// Indices in the strip (each consecutive three form a triangle; degenerate ones included).
    pub indices: usize,
    /// Non-degenerate triangles the strip draws.
    pub triangles: usize,
    /// Vertex decisions the strip's walk made (error test, and the frustum where the view
    /// culls), a vertex reached from both of its parents counted twice: the work that seed
    /// 004's in/out-edge strip saves over SOAR's by never testing a vertex that cannot be
    /// active.
    pub tested: usize,
}

impl StripCounts {
    /// Strip indices per drawn triangle (seed 004 measured 1.56 for SOAR's strip and 1.32 for
    /// the in/out-edge strip; here both are about 1.6, the fewest their triangle order allows,
    /// see [`strip_fewest_indices`](super::strip_fewest_indices)).
    ///
    /// ```
    /// let c = relief_core::refine::StripCounts { vertices: 9, indices: 10, triangles: 8, tested: 9 };
    /// assert_eq!(c.indices_per_triangle(), 1.25);
    /// ```
    #[must_use]
    pub fn indices_per_triangle(&self) -> f64 {
        if self.triangles == 0 {
            0.0
        } else {
            self.indices as f64 / self.triangles as f64
        }
    }
}

/// A vertex with its geomorph data, `bytemuck::Pod` for direct upload.
///
/// The rendered height is `base_z + morph * (position[2] - base_z)`.
///
/// ```
/// let v = relief_core::refine::MorphVertex { position: [0.0, 0.0, 2.0], base_z: 1.0, morph: 0.5 };
/// let bytes: &[u8] = bytemuck::bytes_of(&v);
/// assert_eq!(bytes.len(), 20);
/// ```
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MorphVertex {
    /// World position of the grid sample.
    pub position: [f32; 3],
    /// World height of the vertex's parent edge midpoint (where the morph starts).
    pub base_z: f32,
    /// Morph factor in `[0, 1]`.
    pub morph: f32,
}

/// Per-frame view data in local coordinates (`z` without `z_offset`), `f64`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ViewData {
    eye: [f64; 3],
    kappa: f64,
    tau: f64,
    kappa_over_tau: f64,
    /// The six frustum planes, then two zero entries, so that any bit index of a `u8` plane
    /// mask (`& 7`) indexes the array without a bounds check (masks have only the low six bits).
    planes: [[f64; 4]; 8],
    pub(crate) mask: u8,
    lazy_from: u32,
    z_lo: f64,
    z_hi: f64,
    morph_range: f64,
    /// Grid origin of the tile in the map ([`View::with_grid_origin`]).
    ox: i64,
    oy: i64,
    /// Grid spacing in f64 (per-frame constants of the decision).
    sx: f64,
    sy: f64,
    /// Whether the hierarchy has per-vertex spheres (else level radii and the z range).
    spheres: bool,
}

/// What a vertex's test says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Decision {
    /// Refine, with the planes still to test below.
    Split(u8),
    /// Keep the triangle unsplit.
    Keep,
    /// The volume is outside the frustum: drop the triangle.
    Cull,
}

/// A frame's refiner: the preprocessed [`Hierarchy`], the terrain it was built from, and the
/// [`Criterion`]. Each call refines from scratch (stateless) into caller buffers.
///
/// Every output call takes `scratch` of [`scratch_len`](super::scratch_len) `u64`s. Vertices
/// are numbered in row-major order of the grid samples they sit on (by rank in the bitmap of
/// kept vertices), except in view-dependent frames over interleaved records
/// ([`pack_records`](super::pack_records) with [`RecordLayout::Interleaved`]) of a
/// `(2^k + 1)^2` grid: there they are numbered in the records' order, so that on grids far
/// larger than the caches a frame's bookkeeping stays as local as its records (the same mesh,
/// the vertices in another order). Positions are world units.
///
/// [`RecordLayout::Interleaved`]: super::RecordLayout::Interleaved
///
/// ```
/// use relief_core::refine::{preprocess, scratch_len, Criterion, Refiner};
/// use relief_core::{Error, Heightfield};
/// let hf = Heightfield::new(&[0.0f32; 9], 3, 3).unwrap();
/// let (mut e, mut r) = ([0.0; 9], [0.0; 9]);
/// let h = preprocess(&hf, &mut e, &mut r).unwrap();
/// let rf = Refiner::new(&h, &hf, Criterion::MaxError(0.0)).unwrap();
/// let mut s = vec![0; scratch_len(3, 3)];
/// assert_eq!(rf.count(&mut s).unwrap().triangles, 2); // flat: two triangles
/// let (mut v, mut t) = ([[0.0f32; 3]; 4], [[0u32; 3]; 1]);
/// assert_eq!(
///     rf.triangles(&mut s, &mut v, &mut t).unwrap_err(),
///     Error::BufferTooSmall { needed: 2, actual: 1 }
/// );
/// ```
#[derive(Debug, Clone, Copy)]
pub struct Refiner<'h, 't, T: Terrain> {
    pub(crate) h: &'h Hierarchy<'h>,
    pub(crate) t: &'t T,
    pub(crate) g: RefineGrid,
    pub(crate) max_error: f32,
    pub(crate) view: Option<ViewData>,
    order: BitOrder,
}

/// A grid point with its bit index ([`BitOrder::bit`]), computed once, where the traversal
/// makes the point (the split vertex), and shared by its record load, marks and output.
pub(crate) type Pt = ((i64, i64), usize);

/// Receives the triangles of the view-dependent traversal, counter-clockwise seen from +z, with
/// their corners' bit indices.
pub(crate) trait PtSink {
    fn tri(&mut self, a: Pt, b: Pt, c: Pt);

    /// Whether vertex `m` is already in the mesh. A vertex enters the mesh only when one of the
    /// two triangles of its diamond is split, and the decision is the vertex's (nested), so
    /// the other triangle must split it too: the traversal skips the second decision.
    #[inline(always)]
    fn seen(&self, _m: Pt) -> bool {
        false
    }
}

/// Receives the triangles of the view-independent traversal, counter-clockwise seen from +z.
pub(crate) trait Sink {
    fn tri(&mut self, a: (i64, i64), b: (i64, i64), c: (i64, i64));
}

/// Runs `$run` with `$f` bound to the [`Fetch`] of the hierarchy's layout where the lean walk
/// applies (see [`Refiner::lean_frame`]) and gives `true`, or `false` where it does not.
macro_rules! lean_layouts {
    ($s:ident, $v:ident, $f:ident => $run:expr) => {{
        // The sphere layouts' decision is told that there are spheres and that `tau > 0`
        // (`Fetch::SPHERES`).
        let spheres = $v.spheres && $v.tau > 0.0;
        match ($s.h.errors, $s.h.radii()) {
            (ErrorStore::F32(err), Some(rad)) if spheres => {
                let $f = &FullFetch { err, rad, t: $s.t };
                $run;
                true
            }
            (ErrorStore::Records(recs, super::RecordLayout::Linear), _) if spheres => {
                let $f = &RecordFetch { recs };
                $run;
                true
            }
            (ErrorStore::Bf16(err), None) => {
                let $f = &CompactFetch {
                    err,
                    radius: $s.h.level_radii(),
                    t: $s.t,
                };
                $run;
                true
            }
            _ => false,
        }
    }};
}

impl<'h, 't, T: Terrain> Refiner<'h, 't, T> {
    /// A refiner for `terrain`, which must be the terrain `hierarchy` was built from (same size;
    /// [`Error::LengthMismatch`] otherwise). Checks the criterion: `E` finite and `>= 0`; the
    /// view's near/far planes valid.
    ///
    /// ```
    /// use relief_core::refine::{preprocess, Criterion, Refiner};
    /// use relief_core::{Error, Heightfield};
    /// let hf = Heightfield::new(&[0.0f32; 9], 3, 3).unwrap();
    /// let (mut e, mut r) = ([0.0; 9], [0.0; 9]);
    /// let h = preprocess(&hf, &mut e, &mut r).unwrap();
    /// assert!(Refiner::new(&h, &hf, Criterion::MaxError(f32::NAN)).is_err());
    /// let other = Heightfield::new(&[0.0f32; 4], 2, 2).unwrap();
    /// assert!(matches!(
    ///     Refiner::new(&h, &other, Criterion::MaxError(1.0)),
    ///     Err(Error::LengthMismatch { .. })
    /// ));
    /// ```
    pub fn new(
        hierarchy: &'h Hierarchy<'h>,
        terrain: &'t T,
        criterion: Criterion,
    ) -> Result<Self, Error> {
        let g = hierarchy.grid();
        if terrain.width() != g.width() || terrain.height() != g.height() {
            return Err(Error::LengthMismatch {
                expected: g.len(),
                actual: terrain.width() as usize * terrain.height() as usize,
            });
        }
        let (max_error, view) = match criterion {
            Criterion::MaxError(e) => {
                if !(e.is_finite() && e >= 0.0) {
                    return Err(Error::InvalidParameter {
                        name: "max_error",
                        value: e,
                    });
                }
                (e, None)
            }
            Criterion::View(v) => (0.0, Some(view_data(hierarchy, &v, g)?)),
        };
        // Hierarchical bit order: view-dependent frames over interleaved records of a square
        // grid (see `BitOrder`).
        let hier = view.is_some()
            && g.is_square()
            && matches!(
                hierarchy.errors,
                ErrorStore::Records(_, super::RecordLayout::Interleaved)
            );
        Ok(Refiner {
            h: hierarchy,
            t: terrain,
            g,
            max_error,
            view,
            order: BitOrder {
                w: g.width() as i64,
                side: hier.then_some(g.side() as u64),
            },
        })
    }

    /// How much this frame needs: vertices and triangles of the triangle list (view-dependent:
    /// one traversal; view-independent: a traversal of the kept part of the hierarchy for a
    /// small mesh on a square grid, one pass over the errors otherwise).
    ///
    /// ```
    /// # use relief_core::refine::{preprocess, scratch_len, Criterion, Refiner};
    /// # use relief_core::Heightfield;
    /// let s: Vec<f32> = (0..25).map(|i| (i * 7 % 5) as f32).collect();
    /// let hf = Heightfield::new(&s, 5, 5).unwrap();
    /// let (mut e, mut r) = (vec![0.0; 25], vec![0.0; 25]);
    /// let h = preprocess(&hf, &mut e, &mut r).unwrap();
    /// let coarse = Refiner::new(&h, &hf, Criterion::MaxError(100.0)).unwrap();
    /// let c = coarse.count(&mut vec![0; scratch_len(5, 5)]).unwrap();
    /// assert_eq!((c.vertices, c.triangles), (4, 2));
    /// let fine = Refiner::new(&h, &hf, Criterion::MaxError(0.0)).unwrap();
    /// let c = fine.count(&mut vec![0; scratch_len(5, 5)]).unwrap();
    /// assert!(c.vertices <= 25 && c.triangles > 2);
    /// ```
    pub fn count(&self, scratch: &mut [u64]) -> Result<FrameCounts, Error> {
        let sel = self.select(scratch)?;
        self.release(scratch, sel);
        Ok(sel.counts)
    }

    /// The indexed triangle list: fills `vertices` (world positions `[f32; 3]`, or grid
    /// coordinates `[u16; 2]`: see [`MeshVertex`]) and `triangles` (indices into `vertices`,
    /// counter-clockwise seen from +z) and returns the counts. Vertices are numbered as
    /// [`Refiner`] says; triangles come depth first down the hierarchy, except a
    /// view-independent mesh of a square grid that keeps at least a tenth of the samples,
    /// which is written row by row (the same for every build and entry point).
    /// [`Error::BufferTooSmall`] if either buffer is too small (view-independent: nothing
    /// written; view-dependent: the buffers' contents are unspecified);
    /// [`Error::SizeOverflow`] if the grid's coordinates do not fit the vertex type.
    ///
    /// ```
    /// # use relief_core::refine::{preprocess_compact, scratch_len, Criterion, Refiner};
    /// # use relief_core::Heightfield;
    /// let hf = Heightfield::new(&[0.0f32, 1.0, 2.0, 3.0], 2, 2).unwrap();
    /// let mut e = [0u16; 4];
    /// let h = preprocess_compact(&hf, &mut e).unwrap();
    /// let rf = Refiner::new(&h, &hf, Criterion::MaxError(0.0)).unwrap();
    /// let (mut v, mut t) = ([[0.0f32; 3]; 4], [[0u32; 3]; 2]);
    /// rf.triangles(&mut vec![0; scratch_len(2, 2)], &mut v, &mut t).unwrap();
    /// assert_eq!(t, [[3, 0, 1], [0, 3, 2]]);
    /// assert_eq!(v[3], [1.0, 1.0, 3.0]);
    /// ```
    pub fn triangles<P: MeshVertex>(
        &self,
        scratch: &mut [u64],
        vertices: &mut [P],
        triangles: &mut [[u32; 3]],
    ) -> Result<FrameCounts, Error> {
        if self.view.is_some() {
            return self.triangles_view(scratch, vertices, triangles);
        }
        let walk = |vs: &mut ViSquare<'_, '_, [u32; 3]>, l, r, a, d| vs.walk(l, r, a, d);
        self.triangles_vi(scratch, |_| (vertices, triangles), walk, Narrow)
    }

    /// [`Self::triangles`] into uninitialised buffers, for the view-independent criterion, sized
    /// in the same pass: selects the kept vertices, calls `buffers` once with the frame's counts
    /// and fills the buffers it returns. Fresh output (a `Vec`'s spare capacity, reserved in
    /// `buffers`) is then neither zeroed first, which on a mesh of a million triangles costs about
    /// a fifth of the extraction, nor counted by a separate [`Self::count`], which would select
    /// a second time. On `Ok(c)` the first `c.vertices` elements of the vertex buffer and the
    /// first `c.triangles` of the triangle buffer have been written (the extraction checks its
    /// own counts against the selection's and returns [`Error::Internal`] rather than `Ok` if
    /// they ever differ), so the caller may treat them as initialised; nothing else is written.
    /// [`Error::BufferTooSmall`] if a returned buffer is shorter than its count (nothing
    /// written); [`Error::Unsupported`] for the view-dependent criterion (`buffers` not called),
    /// whose list renumbers its triangles in place and so reads its output back.
    ///
    /// ```
    /// # use relief_core::refine::{preprocess_compact, scratch_len, Criterion, Refiner};
    /// # use relief_core::Heightfield;
    /// let hf = Heightfield::new(&[0.0f32, 1.0, 2.0, 3.0], 2, 2).unwrap();
    /// let mut e = [0u16; 4];
    /// let h = preprocess_compact(&hf, &mut e).unwrap();
    /// let rf = Refiner::new(&h, &hf, Criterion::MaxError(0.0)).unwrap();
    /// let (mut v, mut t): (Vec<[f32; 3]>, Vec<[u32; 3]>) = (Vec::new(), Vec::new());
    /// let (vb, tb) = (&mut v, &mut t);
    /// let c = rf
    ///     .triangles_uninit(&mut vec![0; scratch_len(2, 2)], move |c| {
    ///         // Moving the borrows into the body makes the closure `FnOnce`, so that the
    ///         // slices it returns may outlive it.
    ///         let (vb, tb) = (vb, tb);
    ///         vb.reserve_exact(c.vertices);
    ///         tb.reserve_exact(c.triangles);
    ///         (vb.spare_capacity_mut(), tb.spare_capacity_mut())
    ///     })
    ///     .unwrap();
    /// // SAFETY: `triangles_uninit` wrote the first `c.vertices` and `c.triangles` elements of
    /// // the spare capacities, which are the vectors' first elements (both were empty).
    /// unsafe {
    ///     v.set_len(c.vertices);
    ///     t.set_len(c.triangles);
    /// }
    /// assert_eq!(t, [[3, 0, 1], [0, 3, 2]]);
    /// assert_eq!(v[3], [1.0, 1.0, 3.0]);
    /// ```
    pub fn triangles_uninit<'v, 'o, P: MeshVertex>(
        &self,
        scratch: &mut [u64],
        buffers: impl FnOnce(FrameCounts) -> UninitBuffers<'v, 'o, P>,
    ) -> Result<FrameCounts, Error> {
        if self.view.is_some() {
            return Err(UNINIT_VIEW);
        }
        let walk = |vs: &mut ViSquare<'_, '_, _>, l, r, a, d| vs.walk(l, r, a, d);
        self.triangles_vi::<P, _, _, _>(scratch, buffers, walk, Narrow)
    }

    /// The view-independent list into either kind of slot ([`Slot`]), into the buffers
    /// `buffers` returns for the selection's counts: what [`Self::triangles`] and
    /// [`Self::triangles_uninit`] run, and their `popcnt` and AVX-512 builds, each with its
    /// build of the packed walk ([`ViSquare`], grids of fewer than `2^32` samples) as `walk`
    /// and of the dense selection as `fill` (inlined into the caller, whose target features
    /// both then take).
    #[inline(always)]
    fn triangles_vi<'v, 'o, P: MeshVertex, V: Slot<P> + 'v, O: Slot<[u32; 3]> + 'o, F: Fill>(
        &self,
        scratch: &mut [u64],
        buffers: impl FnOnce(FrameCounts) -> (&'v mut [V], &'o mut [O]),
        walk: impl Fn(&mut ViSquare<'_, '_, O>, u64, u64, u64, u32),
        fill: F,
    ) -> Result<FrameCounts, Error> {
        if self.packed_vi() {
            return self.vi_square(scratch, buffers, walk, fill);
        }
        let (sel, written, triangles) = self.select_into(scratch, buffers, Narrow)?;
        let (bits, prefix) = split_scratch(scratch, self.g.len());
        let mut sink = ListSink {
            bits,
            prefix,
            w: self.g.width() as i64,
            out: TriOut {
                out: triangles,
                n: 0,
            },
        };
        let n = self.g.side() as i64;
        for (l, r, a) in [((n, n), (0, 0), (n, 0)), ((0, 0), (n, n), (0, n))] {
            if self.g.is_square() {
                self.walk_vi::<_, true>(&mut sink, bits, l, r, a, 0);
            } else {
                self.walk_vi::<_, false>(&mut sink, bits, l, r, a, 0);
            }
        }
        let nt = sink.out.n;
        self.release(scratch, sel);
        checked(sel.counts, written, nt)
    }

    /// [`Self::triangles_vi`] with the packed walk ([`ViSquare`]) compiled with `popcnt`
    /// (x86-64 only; the CPU must have the instruction). The closure inherits the function's
    /// target feature.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "popcnt")]
    #[inline]
    fn triangles_vi_popcnt<'v, 'o, P: MeshVertex, V: Slot<P> + 'v, O: Slot<[u32; 3]> + 'o>(
        &self,
        scratch: &mut [u64],
        buffers: impl FnOnce(FrameCounts) -> (&'v mut [V], &'o mut [O]),
    ) -> Result<FrameCounts, Error> {
        let walk = |vs: &mut ViSquare<'_, '_, O>, l, r, a, d| vs.walk_popcnt(l, r, a, d);
        self.triangles_vi(scratch, buffers, walk, Narrow)
    }

    /// [`Self::triangles_vi_popcnt`] with the dense selection's bitmap filled a word at a time
    /// in AVX-512 mask registers ([`Wide`]).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "popcnt,avx512f,avx512bw")]
    #[inline]
    fn triangles_vi_avx512<'v, 'o, P: MeshVertex, V: Slot<P> + 'v, O: Slot<[u32; 3]> + 'o>(
        &self,
        scratch: &mut [u64],
        buffers: impl FnOnce(FrameCounts) -> (&'v mut [V], &'o mut [O]),
    ) -> Result<FrameCounts, Error> {
        let walk = |vs: &mut ViSquare<'_, '_, O>, l, r, a, d| vs.walk_popcnt(l, r, a, d);
        self.triangles_vi(scratch, buffers, walk, Wide)
    }

    /// [`Self::triangles`] compiled with the x86-64 `popcnt` instruction (x86-64 only): the same
    /// results, buffer for buffer. The view-independent extraction numbers each kept vertex by
    /// its rank in a bitmap, one population count per vertex; the default x86-64 target has no
    /// `popcnt` instruction, so [`Self::triangles`] counts bits in software; the view-dependent
    /// list renumbers its triangles' corners by the same ranks (three per triangle), and is
    /// compiled here with the instruction as well. View-independent grids of `2^32` samples or
    /// more take [`Self::triangles`] unchanged.
    ///
    /// # Safety
    ///
    /// The CPU must support `popcnt` (a `#[target_feature]` function: calling it elsewhere is
    /// undefined behaviour; check with `is_x86_feature_detected!("popcnt")` on the std side).
    /// The function itself uses no `unsafe`.
    ///
    /// ```
    /// # #[cfg(target_arch = "x86_64")] {
    /// use relief_core::refine::{preprocess, scratch_len, Criterion, Refiner};
    /// use relief_core::Heightfield;
    /// let s: Vec<f32> = (0..81).map(|i| ((i * 37) % 11) as f32).collect();
    /// let hf = Heightfield::new(&s, 9, 9).unwrap();
    /// let (mut e, mut r) = (vec![0.0; 81], vec![0.0; 81]);
    /// let h = preprocess(&hf, &mut e, &mut r).unwrap();
    /// let rf = Refiner::new(&h, &hf, Criterion::MaxError(1.0)).unwrap();
    /// let mut s = vec![0; scratch_len(9, 9)];
    /// let (mut v, mut t) = (vec![[0.0f32; 3]; 81], vec![[0u32; 3]; 128]);
    /// let c = rf.triangles(&mut s, &mut v, &mut t).unwrap();
    /// if std::is_x86_feature_detected!("popcnt") {
    ///     let (mut v2, mut t2) = (vec![[0.0f32; 3]; 81], vec![[0u32; 3]; 128]);
    ///     // SAFETY: the CPU has popcnt.
    ///     assert_eq!(unsafe { rf.triangles_popcnt(&mut s, &mut v2, &mut t2) }.unwrap(), c);
    ///     assert_eq!((v, t), (v2, t2));
    /// }
    /// # }
    /// ```
    #[cfg(target_arch = "x86_64")]
    // Not under `cfg(doctest)`: rustdoc extracts the doctests of a `#[target_feature]` function
    // only where the feature is enabled at compile time (rust-lang/rust#49864), so this example
    // would never run. The crate the doctests link against is built with the attribute.
    #[cfg_attr(not(doctest), target_feature(enable = "popcnt"))]
    pub fn triangles_popcnt<P: MeshVertex>(
        &self,
        scratch: &mut [u64],
        vertices: &mut [P],
        triangles: &mut [[u32; 3]],
    ) -> Result<FrameCounts, Error> {
        if self.view.is_some() {
            // Inlined here, so the renumbering's rank counts use the instruction.
            return self.triangles_view(scratch, vertices, triangles);
        }
        self.triangles_vi_popcnt(scratch, |_| (vertices, triangles))
    }

    /// [`Self::triangles_uninit`] compiled with the x86-64 `popcnt` instruction, as
    /// [`Self::triangles_popcnt`] is [`Self::triangles`]: the same results, buffer for buffer.
    ///
    /// # Safety
    ///
    /// As for [`Self::triangles_popcnt`]: the CPU must support `popcnt`.
    ///
    /// ```
    /// # #[cfg(target_arch = "x86_64")] {
    /// # use relief_core::refine::{preprocess_compact, scratch_len, Criterion, Refiner};
    /// # use relief_core::Heightfield;
    /// use core::mem::MaybeUninit;
    /// let hf = Heightfield::new(&[0.0f32, 1.0, 2.0, 3.0], 2, 2).unwrap();
    /// let mut e = [0u16; 4];
    /// let h = preprocess_compact(&hf, &mut e).unwrap();
    /// let rf = Refiner::new(&h, &hf, Criterion::MaxError(0.0)).unwrap();
    /// let mut v = [MaybeUninit::<[f32; 3]>::uninit(); 4];
    /// let mut t = [MaybeUninit::uninit(); 2];
    /// if std::is_x86_feature_detected!("popcnt") {
    ///     let mut s = vec![0; scratch_len(2, 2)];
    ///     // SAFETY: the CPU has popcnt.
    ///     let c = unsafe { rf.triangles_uninit_popcnt(&mut s, |_| (&mut v, &mut t)) }.unwrap();
    ///     assert_eq!((c.vertices, c.triangles), (4, 2));
    ///     // SAFETY: the first two triangles were written (the count).
    ///     assert_eq!(unsafe { t[1].assume_init() }, [0, 3, 2]);
    /// }
    /// # }
    /// ```
    #[cfg(target_arch = "x86_64")]
    // Under `cfg_attr(not(doctest))` for the reason given at `triangles_popcnt`.
    #[cfg_attr(not(doctest), target_feature(enable = "popcnt"))]
    pub fn triangles_uninit_popcnt<'v, 'o, P: MeshVertex>(
        &self,
        scratch: &mut [u64],
        buffers: impl FnOnce(FrameCounts) -> UninitBuffers<'v, 'o, P>,
    ) -> Result<FrameCounts, Error> {
        if self.view.is_some() {
            return Err(UNINIT_VIEW);
        }
        self.triangles_vi_popcnt::<P, _, _>(scratch, buffers)
    }

    /// [`Self::triangles_popcnt`] compiled with AVX-512 as well (x86-64 only): the same
    /// results, buffer for buffer. The view-independent selection then fills its bitmap of kept
    /// vertices a word (64 errors) at a time in mask registers; the traversal is
    /// [`Self::triangles_popcnt`]'s. The pass over the errors is a fixed cost per grid sample,
    /// so this matters most on coarse meshes of large grids: 1.07x on a 1025^2 grid at 305,547
    /// triangles (BENCHMARKS.md).
    ///
    /// # Safety
    ///
    /// The CPU must support `popcnt`, `avx512f` and `avx512bw` (a `#[target_feature]`
    /// function: calling it elsewhere is undefined behaviour; check each with
    /// `is_x86_feature_detected!` on the std side). The function itself uses no `unsafe`.
    ///
    /// ```
    /// # #[cfg(target_arch = "x86_64")] {
    /// use relief_core::refine::{preprocess_compact, scratch_len, Criterion, Refiner};
    /// use relief_core::Heightfield;
    /// // 70 x 50 samples, compact errors, grid-coordinate vertices.
    /// let s: Vec<f32> = (0..3500).map(|i| ((i * 7919) % 101) as f32 * 0.1).collect();
    /// let hf = Heightfield::new(&s, 70, 50).unwrap();
    /// let mut e = vec![0u16; 3500];
    /// let h = preprocess_compact(&hf, &mut e).unwrap();
    /// let rf = Refiner::new(&h, &hf, Criterion::MaxError(2.0)).unwrap();
    /// let mut scratch = vec![0; scratch_len(70, 50)];
    /// let c = rf.count(&mut scratch).unwrap();
    /// let mut plain = (vec![[0u16; 2]; c.vertices], vec![[0u32; 3]; c.triangles]);
    /// rf.triangles(&mut scratch, &mut plain.0, &mut plain.1).unwrap();
    /// if std::is_x86_feature_detected!("popcnt")
    ///     && std::is_x86_feature_detected!("avx512f")
    ///     && std::is_x86_feature_detected!("avx512bw")
    /// {
    ///     let mut wide = (vec![[0u16; 2]; c.vertices], vec![[0u32; 3]; c.triangles]);
    ///     // SAFETY: the CPU has popcnt, AVX-512F and AVX-512BW.
    ///     let got = unsafe { rf.triangles_avx512(&mut scratch, &mut wide.0, &mut wide.1) };
    ///     assert_eq!(got.unwrap(), c);
    ///     assert_eq!(wide, plain);
    /// }
    /// # }
    /// ```
    #[cfg(target_arch = "x86_64")]
    // Under `cfg_attr(not(doctest))` for the reason given at `triangles_popcnt`.
    #[cfg_attr(not(doctest), target_feature(enable = "popcnt,avx512f,avx512bw"))]
    pub fn triangles_avx512<P: MeshVertex>(
        &self,
        scratch: &mut [u64],
        vertices: &mut [P],
        triangles: &mut [[u32; 3]],
    ) -> Result<FrameCounts, Error> {
        if self.view.is_some() {
            return self.triangles_view(scratch, vertices, triangles);
        }
        self.triangles_vi_avx512(scratch, |_| (vertices, triangles))
    }

    /// [`Self::triangles_uninit`] compiled with AVX-512, as [`Self::triangles_avx512`] is
    /// [`Self::triangles`]: the same results, buffer for buffer; [`Error::Unsupported`] for a
    /// view-dependent criterion, as there.
    ///
    /// # Safety
    ///
    /// As for [`Self::triangles_avx512`]: the CPU must support `popcnt`, `avx512f` and
    /// `avx512bw`.
    ///
    /// ```
    /// # #[cfg(target_arch = "x86_64")] {
    /// use relief_core::refine::{preprocess, scratch_len, Criterion, Refiner};
    /// use relief_core::Heightfield;
    /// // Vectors grown to exactly the counts the selection finds.
    /// let s: Vec<f32> = (0..33 * 33).map(|i| ((i * 31) % 17) as f32).collect();
    /// let hf = Heightfield::new(&s, 33, 33).unwrap();
    /// let (mut e, mut r) = (vec![0.0; 33 * 33], vec![0.0; 33 * 33]);
    /// let h = preprocess(&hf, &mut e, &mut r).unwrap();
    /// let rf = Refiner::new(&h, &hf, Criterion::MaxError(4.0)).unwrap();
    /// let mut scratch = vec![0; scratch_len(33, 33)];
    /// let (mut v, mut t): (Vec<[f32; 3]>, Vec<[u32; 3]>) = (Vec::new(), Vec::new());
    /// if std::is_x86_feature_detected!("popcnt")
    ///     && std::is_x86_feature_detected!("avx512f")
    ///     && std::is_x86_feature_detected!("avx512bw")
    /// {
    ///     let (vr, tr) = (&mut v, &mut t);
    ///     let grow = move |c: relief_core::refine::FrameCounts| {
    ///         // Moved in, so the spare capacity may outlive the closure.
    ///         let (v, t) = (vr, tr);
    ///         v.reserve_exact(c.vertices);
    ///         t.reserve_exact(c.triangles);
    ///         (v.spare_capacity_mut(), t.spare_capacity_mut())
    ///     };
    ///     // SAFETY: the CPU has popcnt, AVX-512F and AVX-512BW.
    ///     let c = unsafe { rf.triangles_uninit_avx512(&mut scratch, grow) }.unwrap();
    ///     // SAFETY: the first `c.vertices` and `c.triangles` elements were written.
    ///     unsafe { (v.set_len(c.vertices), t.set_len(c.triangles)) };
    ///     assert_eq!(c, rf.count(&mut scratch).unwrap());
    ///     assert!(t.iter().flatten().all(|&i| (i as usize) < v.len()));
    /// }
    /// # }
    /// ```
    #[cfg(target_arch = "x86_64")]
    // Under `cfg_attr(not(doctest))` for the reason given at `triangles_popcnt`.
    #[cfg_attr(not(doctest), target_feature(enable = "popcnt,avx512f,avx512bw"))]
    pub fn triangles_uninit_avx512<'v, 'o, P: MeshVertex>(
        &self,
        scratch: &mut [u64],
        buffers: impl FnOnce(FrameCounts) -> UninitBuffers<'v, 'o, P>,
    ) -> Result<FrameCounts, Error> {
        if self.view.is_some() {
            return Err(UNINIT_VIEW);
        }
        self.triangles_vi_avx512::<P, _, _>(scratch, buffers)
    }

    /// The frame's triangles as indices into the whole sample grid, `y * width + x`,
    /// counter-clockwise seen from +z: the same triangles as [`Self::triangles`], each with its
    /// corners in the same order, for a vertex buffer that holds every sample (uploaded once,
    /// with the heights), so nothing is renumbered and no vertex is written per frame. The
    /// triangles come in the list's order too, except for a view-independent mesh of a square
    /// grid that keeps at least a tenth of the samples, which [`Self::triangles`] writes row by
    /// row (faster there) and this walks. One traversal, no scratch: a vertex that both
    /// triangles of its diamond reach is decided twice, with the same answer (nested errors and
    /// bounding spheres make the decision the vertex's own; [`Self::triangles`] skips the
    /// second one). Returns the triangle count;
    /// [`Error::BufferTooSmall`] if `triangles` is shorter (its contents are then unspecified),
    /// [`Error::SizeOverflow`] for a grid of more than `2^32` samples.
    ///
    /// ```
    /// use relief_core::refine::{preprocess, scratch_len, Criterion, Refiner, View};
    /// use relief_core::{Camera, Heightfield};
    /// use glam::Vec3;
    /// let s: Vec<f32> = (0..81).map(|i| ((i * 37) % 11) as f32).collect();
    /// let hf = Heightfield::new(&s, 9, 9).unwrap();
    /// let (mut e, mut r) = (vec![0.0; 81], vec![0.0; 81]);
    /// let h = preprocess(&hf, &mut e, &mut r).unwrap();
    /// let cam = Camera::new(Vec3::new(-5.0, -5.0, 20.0), Vec3::new(4.0, 4.0, 0.0), 60.0, 200, 200).unwrap();
    /// let rf = Refiner::new(&h, &hf, Criterion::View(View::new(&cam, 2.0).unwrap())).unwrap();
    /// let mut grid = vec![[0u32; 3]; 128];
    /// let n = rf.grid_triangles(&mut grid).unwrap();
    /// // The indexed list's triangles, corner for corner.
    /// let (mut v, mut t) = (vec![[0.0f32; 3]; 81], vec![[0u32; 3]; 128]);
    /// let c = rf.triangles(&mut vec![0; scratch_len(9, 9)], &mut v, &mut t).unwrap();
    /// assert_eq!(n, c.triangles);
    /// for (g, t) in grid[..n].iter().zip(&t[..n]) {
    ///     for (&gi, &ti) in g.iter().zip(t) {
    ///         let p = v[ti as usize];
    ///         assert_eq!([(gi % 9) as f32, (gi / 9) as f32], [p[0], p[1]]);
    ///     }
    /// }
    /// assert!(rf.grid_triangles(&mut grid[..n - 1]).is_err());
    /// ```
    pub fn grid_triangles(&self, triangles: &mut [[u32; 3]]) -> Result<usize, Error> {
        if self.g.len() as u64 > IDX + 1 {
            return Err(Error::SizeOverflow);
        }
        let sink = RowSink {
            w: self.g.width() as i64,
            out: TriOut {
                out: triangles,
                n: 0,
            },
        };
        let sink = self.lean_or_walk(sink);
        let n = sink.out.n;
        need(n, sink.out.out.len())?;
        Ok(n)
    }

    /// The frame into `sink` through the lean walk where it applies ([`Self::lean_frame`] on a
    /// square grid, [`Self::lean_frame_domain`] on others), through [`Self::walk_all`]
    /// otherwise. Each branch takes the sink by value: the square grids' walk, inlined here,
    /// keeps its sink in registers only while no other function holds a pointer to it (a
    /// shared sink slowed it by 2-6%, BENCHMARKS.md).
    #[inline(always)]
    fn lean_or_walk<S: LeanSink + PtSink>(&self, sink: S) -> S {
        if self.g.is_square() {
            let mut sink = sink;
            if !self.lean_frame(&mut sink) {
                self.walk_all(&mut sink, false);
            }
            sink
        } else {
            let mut sink = sink;
            if !self.lean_frame_domain(&mut sink) {
                self.walk_all(&mut sink, false);
            }
            sink
        }
    }

    /// Runs [`Self::lean_walk`] into `sink` where it applies (a view-dependent frame of a
    /// square grid whose packed points, `x | y << 32`, add without carrying, on the full
    /// layout, linear records or the compact layout: layouts whose bit order is row-major, see
    /// [`Refiner::new`]; with `tau > 0` for the first two, which have spheres) and says
    /// whether it did.
    fn lean_frame<S: LeanSink>(&self, sink: &mut S) -> bool {
        if !(self.g.is_square() && self.g.side() < 1 << 30) {
            return false;
        }
        let Some(v) = self.view.as_ref() else {
            return false;
        };
        lean_layouts!(self, v, f => self.lean_walk::<_, S, true>(v, f, sink, (0, 0, 0), 0))
    }

    /// [`Self::lean_frame`] for a grid that does not fill its hierarchy's square (the same
    /// layouts): the lean walk from each triangle inside the domain, in the order of
    /// [`Self::walk`] ([`RefineGrid::walk_edge`]: a triangle across the edge always splits
    /// with the frame's planes, as there).
    #[inline(never)]
    fn lean_frame_domain<S: LeanSink>(&self, sink: &mut S) -> bool {
        if self.g.side() >= 1 << 30 {
            return false;
        }
        let Some(v) = self.view.as_ref() else {
            return false;
        };
        lean_layouts!(self, v, f => self.g.walk_edge(|e| {
            if let Edge::Inside(l, r, a, level) = e {
                let p = |q: (i64, i64)| q.0 as u64 | ((q.1 as u64) << 32);
                self.lean_walk::<_, S, false>(v, f, sink, (p(l), p(r), p(a)), level);
            }
            true
        }))
    }

    /// [`Self::walk`] for a view-dependent frame into a [`LeanSink`], from the two roots of a
    /// square grid (`ROOTS`) or from triangle `start` at `start_level` inside the domain of
    /// another ([`Self::lean_frame_domain`]; `start` and `start_level` are unused with
    /// `ROOTS`): the
    /// same decisions ([`Self::decide_view`]), the same triangles in the same order, with less
    /// state per triangle. Corners are packed as `x | y << 32` (a hypotenuse's midpoint is half the
    /// sum of its ends: both coordinate sums are even and below `2^31`), the vertex data is
    /// read through `F` (one instance per layout), and an explicit stack replaces the
    /// recursion: the triangle being visited is held apart, a split pushes its second child and
    /// visits the first at once, and a leaf or culled triangle pops the next (so the stack
    /// grows by one entry a level: with the second root at most `levels() + 1` entries; each
    /// pass visits one triangle of the bisection tree once). Each entry carries its decision,
    /// made when it is created: a split decides both children at once, so their two record
    /// loads overlap and the visit branches on a decision made a step before. The order of the
    /// decisions changes, not their results: between deciding the second child and popping it,
    /// the walk only visits the first child's subtree, which never has the second child's split
    /// vertex as a corner (so [`LeanSink::seen`] answers the same), and the decisions are
    /// nested. Holding the visited triangle apart, instead of pushing both children and popping
    /// the first at once, took `grid_triangles` on linear records from 66 to 73 M triangles/s
    /// on the 1 px frame of `vd_bfs`; writing a split's leaf children at once, without visiting
    /// them as entries, to 77 (BENCHMARKS.md).
    fn lean_walk<F: Fetch, S: LeanSink, const ROOTS: bool>(
        &self,
        v: &ViewData,
        f: &F,
        sink: &mut S,
        start: (u64, u64, u64),
        start_level: u32,
    ) {
        // Entries `(l, r, a, level, decision)`, each decided when it is created (both children
        // of a split at once, so their two record loads overlap).
        let mut stack = [(0u64, 0u64, 0u64, 0u8, Decision::Keep); LEAN_STACK];
        let (mut cur, mut sp);
        if ROOTS {
            let n = u64::from(self.g.side());
            let p = |x: u64, y: u64| x | (y << 32);
            let root = |(l, r, a): (u64, u64, u64)| {
                (l, r, a, 0u8, self.lean_decide(v, f, sink, l, r, v.mask, 0))
            };
            // The entry being visited is kept out of the stack: a split pushes its second
            // child and visits the first at once (the order of pushing both and popping the
            // first, one push and pop fewer). The root of corner `(n, 0)` is visited first,
            // the other waits below.
            stack[0] = root((p(0, 0), p(n, n), p(0, n)));
            cur = root((p(n, n), p(0, 0), p(n, 0)));
            sp = 1usize;
        } else {
            // One triangle inside the domain ([`Self::lean_frame_domain`]) at `start_level`, with
            // the frame's planes.
            let (l, r, a) = start;
            let d = self.lean_decide(v, f, sink, l, r, v.mask, start_level);
            cur = (l, r, a, start_level as u8, d);
            sp = 0usize;
        }
        loop {
            let (l, r, a, level, d) = cur;
            // The next entry to visit, or `None` to pop one.
            let next = match d {
                Decision::Split(pl) => {
                    let m = (l + r) >> 1;
                    let level = u32::from(level) + 1;
                    let d0 = self.lean_decide(v, f, sink, a, l, pl, level);
                    let d1 = self.lean_decide(v, f, sink, r, a, pl, level);
                    let second = (r, a, m, level as u8, d1);
                    if let Decision::Split(_) = d0 {
                        let Some(top) = stack.get_mut(sp) else {
                            break;
                        };
                        *top = second;
                        sp += 1;
                        Some((a, l, m, level as u8, d0))
                    } else {
                        // A first child that is a leaf (or culled) is written at once: it comes
                        // before the second. The second is then visited without a push, or
                        // written too when it is a leaf.
                        if let Decision::Keep = d0 {
                            sink.put(a, l, m);
                        }
                        match d1 {
                            Decision::Split(_) => Some(second),
                            Decision::Keep => {
                                sink.put(r, a, m);
                                None
                            }
                            Decision::Cull => None,
                        }
                    }
                }
                Decision::Keep => {
                    sink.put(l, r, a);
                    None
                }
                Decision::Cull => None,
            };
            if let Some(e) = next {
                cur = e;
                continue;
            }
            if sp == 0 {
                break;
            }
            sp -= 1;
            let Some(&e) = stack.get(sp) else {
                break;
            };
            cur = e;
        }
    }

    /// [`Self::lean_walk`]'s decision for the triangle of hypotenuse `l-r` at `level`: `Keep`
    /// for a leaf (emitted as it is), otherwise its split vertex's decision, as in `walk`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn lean_decide<F: Fetch, S: LeanSink>(
        &self,
        v: &ViewData,
        f: &F,
        sink: &S,
        l: u64,
        r: u64,
        planes: u8,
        level: u32,
    ) -> Decision {
        if level >= self.g.levels() {
            return Decision::Keep;
        }
        let m = (l + r) >> 1;
        let (x, y) = ((m & IDX) as i64, (m >> 32) as i64);
        let i = y as usize * self.g.width() as usize + x as usize;
        // As in `walk`: a vertex already in the mesh splits without a second decision.
        if sink.seen(i) {
            return Decision::Split(planes);
        }
        match f.fetch(i, x as u32, y as u32, level) {
            Some(ezr) => self.decide_view(v, F::SPHERES, (x, y), ezr, planes, level),
            None => Decision::Split(planes),
        }
    }

    /// Whether view-independent extraction takes [`ViSquare`]'s packed walk: a grid of any
    /// shape with fewer than `2^32` samples (its row-major indices fit the packed vertices).
    fn packed_vi(&self) -> bool {
        (self.g.len() as u64) <= IDX
    }

    /// View-independent extraction through [`ViSquare`] with `walk` as its traversal (the
    /// plain or the `popcnt` build): on a square grid row by row where the selection is dense
    /// ([`by_rows`], `ViSquare::rows`), else from the two roots; on other grids, from the
    /// triangles inside the domain ([`RefineGrid::walk_edge`], in the order of
    /// [`Self::walk_vi`]).
    #[inline(always)]
    fn vi_square<'v, 'o, P: MeshVertex, V: Slot<P> + 'v, O: Slot<[u32; 3]> + 'o, F: Fill>(
        &self,
        scratch: &mut [u64],
        buffers: impl FnOnce(FrameCounts) -> (&'v mut [V], &'o mut [O]),
        walk: impl Fn(&mut ViSquare<'_, '_, O>, u64, u64, u64, u32),
        fill: F,
    ) -> Result<FrameCounts, Error> {
        let (sel, written, mut vs, depth) = self.vi_square_start(scratch, buffers, fill)?;
        if self.g.is_square() {
            if by_rows(&sel, self.g.len()) {
                vs.rows();
            } else {
                for (l, r, a) in vs.roots() {
                    walk(&mut vs, l, r, a, depth);
                }
            }
        } else {
            // The triangles inside the domain, their corners packed by row-major index (a
            // midpoint's index is the mean of its hypotenuse ends' indices in any row width).
            let (w, levels) = (i64::from(self.g.width()), self.g.levels());
            self.g.walk_edge(|e| {
                if let Edge::Inside(l, r, a, level) = e {
                    let v = |p: (i64, i64)| vs.vertex((p.1 * w + p.0) as u64);
                    let (pl, pr, pa) = (v(l), v(r), v(a));
                    walk(&mut vs, pl, pr, pa, levels.saturating_sub(level));
                }
                true
            });
        }
        let n = vs.out.n;
        self.release(scratch, sel);
        checked(sel.counts, written, n)
    }

    /// View-independent extraction through [`ViSquare`] up to the traversal: selects, checks the
    /// buffers (nothing written when one is short), writes the vertices and returns the counts,
    /// the traversal state and the roots' depth. The kept set is the bitmap (1 bit per vertex,
    /// cache-resident), so the traversal never touches the error array.
    #[inline(always)]
    fn vi_square_start<
        'a,
        'v,
        'o,
        P: MeshVertex,
        V: Slot<P> + 'v,
        O: Slot<[u32; 3]> + 'o,
        F: Fill,
    >(
        &self,
        scratch: &'a mut [u64],
        buffers: impl FnOnce(FrameCounts) -> (&'v mut [V], &'o mut [O]),
        fill: F,
    ) -> Result<(Selection, usize, ViSquare<'a, 'o, O>, u32), Error> {
        let (sel, written, triangles) = self.select_into(scratch, buffers, fill)?;
        let c = sel.counts;
        let (bits, prefix) = split_scratch(scratch, self.g.len());
        let vs = ViSquare {
            bits,
            prefix,
            out: TriOut {
                // Exactly the count (checked above): `ViSquare::last` may write one slot ahead.
                out: triangles.get_mut(..c.triangles).unwrap_or(&mut []),
                n: 0,
            },
            side: self.g.side() as u64,
        };
        Ok((sel, written, vs, self.g.levels()))
    }

    /// [`Error::SizeOverflow`] if the grid's coordinates do not fit vertex type `P`.
    #[inline(always)]
    pub(crate) fn fits_vertex<P: MeshVertex>(&self) -> Result<(), Error> {
        let most = u64::from(self.g.width().max(self.g.height())).saturating_sub(1);
        if most > P::MAX_COORD {
            return Err(Error::SizeOverflow);
        }
        Ok(())
    }

    /// View-independent extraction up to the traversal: selects, takes the buffers `buffers`
    /// returns for the counts, checks both (nothing written and the scratch released when one
    /// is short) and writes the vertices; returns the selection, how many vertices were
    /// written and the triangle buffer.
    #[inline(always)]
    fn select_into<'v, 'o, P: MeshVertex, V: Slot<P> + 'v, O: Slot<[u32; 3]> + 'o, F: Fill>(
        &self,
        scratch: &mut [u64],
        buffers: impl FnOnce(FrameCounts) -> (&'v mut [V], &'o mut [O]),
        _fill: F,
    ) -> Result<(Selection, usize, &'o mut [O]), Error> {
        self.fits_vertex::<P>()?;
        let sel = self.select_by::<F>(scratch)?;
        let c = sel.counts;
        let (vertices, triangles) = buffers(c);
        if let Err(e) = need(c.vertices, vertices.len()).and(need(c.triangles, triangles.len())) {
            self.release(scratch, sel);
            return Err(e);
        }
        let written = self.write_vertices(scratch, sel, vertices);
        Ok((sel, written, triangles))
    }

    /// View-dependent list in one traversal: triangles are written with grid indices while the
    /// bitmap is marked, then renumbered by rank. Inlined into both callers (the `popcnt` build
    /// of [`Self::triangles_popcnt`] then counts each rank with the instruction).
    #[inline(always)]
    fn triangles_view<P: MeshVertex>(
        &self,
        scratch: &mut [u64],
        vertices: &mut [P],
        triangles: &mut [[u32; 3]],
    ) -> Result<FrameCounts, Error> {
        self.fits_vertex::<P>()?;
        let mut m = marks(scratch, self.g.len())?;
        m.begin_sparse();
        let sink = GridSink {
            m: &mut m,
            out: TriOut {
                out: &mut *triangles,
                n: 0,
            },
            w: u64::from(self.g.width()),
        };
        let nt = self.lean_or_walk(sink).out.n;
        let nv = m.prefix_sparse();
        let fits = nt <= triangles.len() && nv <= vertices.len();
        if fits {
            for t in triangles.iter_mut().take(nt) {
                for k in t.iter_mut() {
                    *k = rank(m.bits, m.prefix, *k as usize);
                }
            }
            self.write_vertices_in(m.bits, m.touched(), vertices);
        }
        m.end_sparse();
        need(nt, triangles.len())?;
        need(nv, vertices.len())?;
        Ok(FrameCounts {
            vertices: nv,
            triangles: nt,
        })
    }

    /// Geomorph data for the vertices of the last selection, in vertex order: for each kept
    /// vertex its world position, the world height of the midpoint of its parent edge (where the
    /// morph starts) and its morph factor (1 without [`View::with_geomorph`], for
    /// view-independent refinement, for the square's corners and for vertices the domain
    /// border forces). Runs the selection again; `out` at least the vertex count.
    ///
    /// ```
    /// use relief_core::refine::{preprocess, scratch_len, Criterion, MorphVertex, Refiner, View};
    /// use relief_core::{Camera, Heightfield};
    /// use glam::Vec3;
    /// let s: Vec<f32> = (0..81).map(|i| ((i * 37) % 11) as f32).collect();
    /// let hf = Heightfield::new(&s, 9, 9).unwrap();
    /// let (mut e, mut r) = (vec![0.0; 81], vec![0.0; 81]);
    /// let h = preprocess(&hf, &mut e, &mut r).unwrap();
    /// let cam = Camera::new(Vec3::new(-5.0, -5.0, 20.0), Vec3::new(4.0, 4.0, 0.0), 60.0, 200, 200).unwrap();
    /// let view = View::new(&cam, 4.0).unwrap().with_geomorph(Some(2.0));
    /// let rf = Refiner::new(&h, &hf, Criterion::View(view)).unwrap();
    /// let mut out = vec![MorphVertex::default(); 81];
    /// let n = rf.morph(&mut vec![0; scratch_len(9, 9)], &mut out).unwrap();
    /// assert!(out[..n].iter().all(|v| (0.0..=1.0).contains(&v.morph)));
    /// ```
    pub fn morph(&self, scratch: &mut [u64], out: &mut [MorphVertex]) -> Result<usize, Error> {
        let sel = self.select(scratch)?;
        let c = sel.counts;
        if out.len() < c.vertices {
            self.release(scratch, sel);
        }
        need(c.vertices, out.len())?;
        let k = match marks(scratch, self.g.len()) {
            Ok(m) => self.write_morph(m.bits, m.selected_words(sel.sparse), out),
            Err(_) => 0,
        };
        self.release(scratch, sel);
        Ok(k)
    }

    /// Writes the geomorph data of the vertices marked in `bits` (in the marked `words`,
    /// increasing) into `out`, in vertex order, while there is room; returns their number.
    pub(crate) fn write_morph(
        &self,
        bits: &[u64],
        words: impl Iterator<Item = usize>,
        out: &mut [MorphVertex],
    ) -> usize {
        let o = self.order();
        let s = self.h.scale();
        let mut k = 0usize;
        for wi in words {
            let mut b = bits.get(wi).copied().unwrap_or(0);
            while b != 0 {
                let i = wi * 64 + b.trailing_zeros() as usize;
                b &= b - 1;
                let (x, y) = o.point(i);
                let z = self.t.local_z(x, y);
                let (base, f) = self.morph_of(x, y, z);
                if let Some(o) = out.get_mut(k) {
                    *o = MorphVertex {
                        position: [x as f32 * s.dx, y as f32 * s.dy, z + s.z_offset],
                        base_z: base + s.z_offset,
                        morph: f,
                    };
                }
                k += 1;
            }
        }
        k
    }

    fn morph_of(&self, x: u32, y: u32, z: f32) -> (f32, f32) {
        let Some((kind, hs)) = self.g.kind(x, y) else {
            return (z, 1.0);
        };
        let (xi, yi, hh) = (x as i64, y as i64, hs as i64);
        let ends = match kind {
            super::grid::Kind::Edge { horizontal: true } => [(xi - hh, yi), (xi + hh, yi)],
            super::grid::Kind::Edge { horizontal: false } => [(xi, yi - hh), (xi, yi + hh)],
            super::grid::Kind::Centre => {
                if super::grid::main_diagonal(xi - hh, yi - hh, 2 * hh) {
                    [(xi - hh, yi - hh), (xi + hh, yi + hh)]
                } else {
                    [(xi + hh, yi - hh), (xi - hh, yi + hh)]
                }
            }
        };
        if !ends.iter().all(|&(a, b)| self.g.in_domain(a, b)) {
            return (z, 1.0);
        }
        let base = 0.5
            * (self.t.local_z(ends[0].0 as u32, ends[0].1 as u32)
                + self.t.local_z(ends[1].0 as u32, ends[1].1 as u32));
        let Some(v) = self.view else {
            return (base, 1.0);
        };
        let i = y as usize * self.g.width() as usize + x as usize;
        let e = self.h.err_at(i) as f64;
        if v.morph_range <= 1.0 || e.is_infinite() {
            return (base, 1.0);
        }
        let level = self.g.level(x, y).unwrap_or(0);
        let r = self.h.radius_at(i, level) as f64;
        let d = self.distance(&v, [xi, yi], z as f64, r);
        // rho / tau, the projected error in units of the threshold.
        let ratio = if d > 0.0 && v.tau > 0.0 {
            e * v.kappa / (v.tau * d)
        } else {
            f64::INFINITY
        };
        let f = ((ratio - 1.0) / (v.morph_range - 1.0)).clamp(0.0, 1.0);
        (base, f as f32)
    }

    /// Marks the kept vertices in the bitmap, fills the rank prefix, returns the counts.
    ///
    /// View-dependent frames mark sparsely: a traversal marks the words the mesh touches (and
    /// their summaries, see [`Marks::begin_sparse`]), and only those get a rank prefix and are
    /// cleared by [`Self::release`]. View-independent selection of a grid of fewer than `2^32`
    /// samples whose mesh looks small ([`Self::looks_small`]) takes a traversal of the kept
    /// part of the hierarchy (nested errors: it stops at the first
    /// vertex with error `<= E`), which costs O(mesh) instead of O(grid); past
    /// `1 / VI_SPARSE_SHARE` of the grid's samples in triangles it gives up and, like every
    /// other view-independent selection, writes the whole bitmap from the error array in one
    /// vectorised pass (the same vertices either way).
    pub(crate) fn select(&self, scratch: &mut [u64]) -> Result<Selection, Error> {
        self.select_by::<Narrow>(scratch)
    }

    /// [`Self::select`] with the dense bitmap filled by `F` (inlined into its caller, so that
    /// [`Wide`] is compiled with the caller's target features).
    #[inline(always)]
    fn select_by<F: Fill>(&self, scratch: &mut [u64]) -> Result<Selection, Error> {
        #[cfg(test)]
        if let (None, Some(limit)) = (self.view, VI_LIMIT.with(|c| c.get())) {
            return self.select_within(scratch, limit);
        }
        let limit = if self.view.is_some() {
            usize::MAX
        } else if self.packed_vi() && self.looks_small() {
            self.g.len() / VI_SPARSE_SHARE
        } else {
            0
        };
        self.select_within_by::<F>(scratch, limit)
    }

    /// Whether a view-independent mesh looks small enough for the sparse selection: at most 2
    /// of `VI_PROBES` (256) vertices spread over the grid (a fixed pseudo-random sequence, so
    /// the choice is repeatable) are kept, i.e. the kept share looks below about 1%. Measured
    /// on Puget Sound (1025^2), the traversal costs about as much as the dense pass at a mesh
    /// of `samples / 32` triangles (about `2 V`), and at most 1.2x the whole extraction's time
    /// up to the budget of `samples / VI_SPARSE_SHARE`; a mesh past the budget (a kept share
    /// of 3% or more passes the probes about once in 70) wastes the traversal up to the
    /// budget. The probes only choose the method; both give the same marks.
    fn looks_small(&self) -> bool {
        let n = self.g.len() as u64;
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        let mut kept = 0;
        for _ in 0..VI_PROBES {
            x = x
                .wrapping_mul(0x5851_f42d_4c95_7f2d)
                .wrapping_add(0x1405_7b7e_f767_814f);
            // The high bits, scaled to [0, n) without a division.
            let i = ((x >> 32) * n) >> 32;
            kept += (self.h.err_at(i as usize) > self.max_error) as u32;
        }
        kept <= 2
    }

    /// [`Self::select`] with the traversal's triangle budget: past `limit` triangles
    /// (view-independent, square grids; other grids always) the bitmap is written densely.
    #[cfg(test)]
    pub(crate) fn select_within(
        &self,
        scratch: &mut [u64],
        limit: usize,
    ) -> Result<Selection, Error> {
        self.select_within_by::<Narrow>(scratch, limit)
    }

    /// [`Self::select`] with the traversal's triangle budget `limit`, the dense bitmap filled by
    /// `F` (see [`Self::select_by`]): past `limit` triangles (view-independent, square grids;
    /// other grids always) the bitmap is written densely.
    #[inline(always)]
    fn select_within_by<F: Fill>(
        &self,
        scratch: &mut [u64],
        limit: usize,
    ) -> Result<Selection, Error> {
        let n = self.g.len();
        let mut m = marks(scratch, n)?;
        let within = if self.view.is_some() {
            m.begin_sparse();
            let mut sink = MarkSink { m: &mut m, n: 0 };
            self.walk_all(&mut sink, false);
            Some(sink.n)
        } else if self.packed_vi() && limit > 0 {
            m.begin_sparse();
            self.mark_vi(&mut m, limit)
        } else {
            // Grids of `2^32` samples or more take `walk_vi`, which tests vertices the marks
            // never reached: it needs the whole bitmap.
            None
        };
        if let Some(triangles) = within {
            let vertices = m.prefix_sparse();
            return Ok(Selection {
                counts: FrameCounts {
                    vertices,
                    triangles,
                },
                sparse: true,
            });
        }
        // Dense (view-independent: the probes' choice, the budget ran out, or a grid of 2^32
        // samples or more): the summaries are stale, and the next sparse selection clears
        // everything (`begin_sparse`).
        m.dense();
        let (bits, prefix) = (m.bits, m.prefix);
        let (acc, triangles) = {
            // The kept set is known: every in-domain vertex with error > E (corners and forced
            // vertices are +inf). A triangulated rectangle has 2V - B - 2 triangles.
            let e = self.max_error;
            match self.h.errors {
                ErrorStore::F32(errs) => F::fill(bits, errs.get(..n).unwrap_or(errs), |&x| x > e),
                ErrorStore::Records(recs, layout) => {
                    let ce = bf16_floor_code(e);
                    let (w, h) = (self.g.width() as u64, self.g.height() as u64);
                    bits.fill(0);
                    for y in 0..h {
                        for x in 0..w {
                            let code = recs
                                .get(record_index(layout, &self.g, x, y))
                                .map_or(u16::MAX, |r| r.error);
                            if code > ce {
                                let i = (y * w + x) as usize;
                                if let Some(word) = bits.get_mut(i >> 6) {
                                    *word |= 1u64 << (i & 63);
                                }
                            }
                        }
                    }
                }
                ErrorStore::Bf16(errs) => {
                    // Codes are monotone in the error: compare codes with E's code, rounded
                    // so that code > c_e exactly when decode(code) > E.
                    let ce = bf16_floor_code(e);
                    F::fill(bits, errs.get(..n).unwrap_or(errs), |&c| c > ce)
                }
            }
            let border = self.border_count(bits);
            // The rank prefix counts the kept vertices on the way (one pass over the words).
            let mut acc = 0u64;
            for (p, &b) in prefix.iter_mut().zip(bits.iter()) {
                *p = acc;
                acc += b.count_ones() as u64;
            }
            (acc, (2 * acc as usize).saturating_sub(border + 2))
        };
        Ok(Selection {
            counts: FrameCounts {
                vertices: acc as usize,
                triangles,
            },
            sparse: false,
        })
    }

    /// Sparse view-independent marking (a grid of fewer than `2^32` samples): the domain's
    /// corners and every split vertex of the kept part of the hierarchy; the triangle count,
    /// or `None` past `limit` triangles.
    fn mark_vi(&self, m: &mut Marks<'_>, limit: usize) -> Option<usize> {
        let (e, ce) = (self.max_error, bf16_floor_code(self.max_error));
        let g = &self.g;
        match self.h.errors {
            ErrorStore::F32(errs) => {
                ViMark::run(m, limit, g, |i| errs.get(i).is_none_or(|&x| x > e))
            }
            ErrorStore::Bf16(errs) => {
                ViMark::run(m, limit, g, |i| errs.get(i).is_none_or(|&c| c > ce))
            }
            // Linear records are indexed like the grid; interleaved ones through `err_at`.
            ErrorStore::Records(recs, super::RecordLayout::Linear) => {
                ViMark::run(m, limit, g, |i| recs.get(i).is_none_or(|r| r.error > ce))
            }
            ErrorStore::Records(_, super::RecordLayout::Interleaved) => {
                ViMark::run(m, limit, g, |i| self.h.err_at(i) > e)
            }
        }
    }

    fn border_count(&self, bits: &[u64]) -> usize {
        let (w, h) = (self.g.width() as usize, self.g.height() as usize);
        let bit = |i: usize| bits.get(i / 64).is_some_and(|b| (b >> (i % 64)) & 1 == 1);
        let mut c = 0;
        for x in 0..w {
            c += bit(x) as usize + bit((h - 1) * w + x) as usize;
        }
        for y in 1..h - 1 {
            c += bit(y * w) as usize + bit(y * w + w - 1) as usize;
        }
        c
    }

    /// Leaves the scratch clean after [`Self::select`] (sparse marks: clears the touched words
    /// and their summaries; dense: nothing, the next selection clears the bitmap first).
    pub(crate) fn release(&self, scratch: &mut [u64], sel: Selection) {
        if sel.sparse {
            if let Ok(mut m) = marks(scratch, self.g.len()) {
                m.end_sparse();
            }
        }
    }

    /// Writes the selected vertices (positions or grid coordinates, [`MeshVertex`]), in vertex
    /// order: the touched words of sparse marks, every word of dense ones. Returns how many it
    /// wrote.
    pub(crate) fn write_vertices<P: MeshVertex, V: Slot<P>>(
        &self,
        scratch: &mut [u64],
        sel: Selection,
        vertices: &mut [V],
    ) -> usize {
        let Ok(m) = marks(scratch, self.g.len()) else {
            return 0;
        };
        self.write_vertices_in(m.bits, m.selected_words(sel.sparse), vertices)
    }

    /// Writes the marked vertices of bitmap words `words` (increasing) as `P`;
    /// returns how many it wrote (all of them, unless `vertices` is shorter).
    /// View-dependent refinement from records takes the heights from the records (the terrain's
    /// heights, packed): the traversal has just read them, while the terrain's rows are cold
    /// pages on a large grid.
    pub(crate) fn write_vertices_in<P: MeshVertex, V: Slot<P>>(
        &self,
        bits: &[u64],
        words: impl Iterator<Item = usize>,
        vertices: &mut [V],
    ) -> usize {
        let o = self.order();
        match self.h.errors {
            ErrorStore::Records(recs, _) if o.hierarchical() => {
                // Bit k is record k: its height without an index computation.
                let s = self.h.scale();
                let len = vertices.len();
                let mut slots = vertices.iter_mut();
                'words: for wi in words {
                    let mut b = bits.get(wi).copied().unwrap_or(0);
                    while b != 0 {
                        let k = wi * 64 + b.trailing_zeros() as usize;
                        b &= b - 1;
                        let Some(v) = slots.next() else {
                            break 'words;
                        };
                        let (x, y) = o.point(k);
                        let z = || recs.get(k).map_or_else(|| self.t.local_z(x, y), |r| r.z);
                        v.set(P::at(x, y, &s, z));
                    }
                }
                len - slots.len()
            }
            ErrorStore::Records(recs, layout) if self.view.is_some() => {
                self.write_positions(bits, words, vertices, |x, y| {
                    recs.get(record_index(layout, &self.g, x as u64, y as u64))
                        .map_or_else(|| self.t.local_z(x, y), |r| r.z)
                })
            }
            _ => self.write_positions(bits, words, vertices, |x, y| self.t.local_z(x, y)),
        }
    }

    /// [`Self::write_vertices_in`] with local heights from `z`.
    #[inline(always)]
    fn write_positions<P: MeshVertex, V: Slot<P>>(
        &self,
        bits: &[u64],
        words: impl Iterator<Item = usize>,
        vertices: &mut [V],
        z: impl Fn(u32, u32) -> f32,
    ) -> usize {
        let w = (self.g.width() as usize).max(1); // never 0; the max keeps a panic path out
        let s = self.h.scale();
        let len = vertices.len();
        let mut slots = vertices.iter_mut();
        'words: for wi in words {
            let word = bits.get(wi).copied().unwrap_or(0);
            if word == 0 {
                continue;
            }
            // One division per word; within the word, x and y advance incrementally.
            let i0 = wi * 64;
            let (mut y, mut x0) = (i0 / w, i0 % w);
            let mut b = word;
            let mut base = 0usize; // bit offset of column x0 in this word
            while b != 0 {
                let bit = b.trailing_zeros() as usize;
                b &= b - 1;
                let mut x = x0 + (bit - base);
                while x >= w {
                    // Bounded: at most 64 / w + 1 row changes per word.
                    base += w - x0;
                    x0 = 0;
                    y += 1;
                    x = bit - base;
                }
                let Some(v) = slots.next() else {
                    break 'words;
                };
                let (xu, yu) = (x as u32, y as u32);
                v.set(P::at(xu, yu, &s, || z(xu, yu)));
            }
        }
        len - slots.len()
    }

    /// The bit order of this frame's marks (see [`BitOrder`]).
    #[inline(always)]
    pub(crate) fn order(&self) -> BitOrder {
        self.order
    }

    /// Traverses both root triangles.
    pub(crate) fn walk_all<S: PtSink>(&self, sink: &mut S, cull_keeps: bool) {
        let n = self.g.side() as i64;
        let mask = self.view.map_or(0, |v| v.mask);
        let pt = |p: (i64, i64)| (p, self.order.bit(p));
        for (l, r, a) in [((n, n), (0, 0), (n, 0)), ((0, 0), (n, n), (0, n))] {
            let (l, r, a) = (pt(l), pt(r), pt(a));
            if self.g.is_square() {
                self.walk::<S, true>(sink, l, r, a, mask, 0, cull_keeps);
            } else {
                self.walk::<S, false>(sink, l, r, a, mask, 0, cull_keeps);
            }
        }
    }

    /// View-independent traversal driven by the bitmap of kept vertices (`SQUARE`: the grid
    /// fills the enclosing square, no domain tests). Recursion depth at most `levels() <= 60`.
    fn walk_vi<S: Sink, const SQUARE: bool>(
        &self,
        sink: &mut S,
        bits: &[u64],
        l: (i64, i64),
        r: (i64, i64),
        a: (i64, i64),
        level: u32,
    ) {
        let straddle = if SQUARE {
            false
        } else {
            match self.g.classify([l, r, a]) {
                Class::Outside => return,
                Class::Straddle => true,
                Class::Inside => false,
            }
        };
        if level >= self.g.levels() {
            sink.tri(l, r, a);
            return;
        }
        // The hypotenuse's ends have even coordinate sums: a shift halves them exactly (and
        // without the rounding fix-up a signed division needs).
        let m = ((l.0 + r.0) >> 1, (l.1 + r.1) >> 1);
        let i = (m.1 * self.g.width() as i64 + m.0) as usize;
        let kept = bits.get(i >> 6).is_some_and(|b| (b >> (i & 63)) & 1 == 1);
        if SQUARE && level + 1 == self.g.levels() {
            // The children are leaf cells: emit them here instead of recursing.
            if kept {
                sink.tri(a, l, m);
                sink.tri(r, a, m);
            } else {
                sink.tri(l, r, a);
            }
            return;
        }
        if straddle || kept {
            self.walk_vi::<S, SQUARE>(sink, bits, a, l, m, level + 1);
            self.walk_vi::<S, SQUARE>(sink, bits, r, a, m, level + 1);
        } else {
            sink.tri(l, r, a);
        }
    }

    /// Triangle `(l, r, a)`, counter-clockwise, hypotenuse `l-r`, split vertex at `level`.
    /// Recursion depth at most `levels() <= 60`.
    #[allow(clippy::too_many_arguments)]
    fn walk<S: PtSink, const SQUARE: bool>(
        &self,
        sink: &mut S,
        l: Pt,
        r: Pt,
        a: Pt,
        planes: u8,
        level: u32,
        cull_keeps: bool,
    ) {
        // A square grid fills the hierarchy's square: every triangle is inside.
        let class = if SQUARE {
            Class::Inside
        } else {
            self.g.classify([l.0, r.0, a.0])
        };
        if class == Class::Outside {
            return;
        }
        if level >= self.g.levels() {
            sink.tri(l, r, a);
            return;
        }
        // Even sums (the hypotenuse's ends): the shift is exact, see `walk_vi`.
        let m = ((l.0 .0 + r.0 .0) >> 1, (l.0 .1 + r.0 .1) >> 1);
        let m = (m, self.order.bit(m));
        let d = if class == Class::Straddle || sink.seen(m) {
            // (After `seen`, the incoming planes are a superset of those the first decision
            // left active: testing them again below is redundant, never wrong.)
            Decision::Split(planes)
        } else {
            self.decide_at(m, planes, level)
        };
        match d {
            Decision::Split(p) => {
                self.walk::<S, SQUARE>(sink, a, l, m, p, level + 1, cull_keeps);
                self.walk::<S, SQUARE>(sink, r, a, m, p, level + 1, cull_keeps);
            }
            Decision::Keep => sink.tri(l, r, a),
            Decision::Cull => {
                if cull_keeps {
                    sink.tri(l, r, a);
                }
            }
        }
    }

    /// This refiner with frustum culling tested at every level (no lazy culling), for the
    /// strips: their decisions must be nested, and lazy culling is not outside the view (a
    /// vertex below the lazy levels can be active while a parent is culled).
    pub(crate) fn strict_culling(&self) -> Self {
        Refiner {
            h: self.h,
            t: self.t,
            g: self.g,
            max_error: self.max_error,
            view: self.view.map(|v| ViewData {
                lazy_from: u32::MAX,
                ..v
            }),
            order: self.order,
        }
    }

    /// The per-vertex decision for in-domain vertex `m` at `level`.
    #[inline(always)]
    pub(crate) fn decide(&self, m: (i64, i64), planes: u8, level: u32) -> Decision {
        self.decide_at((m, self.order.bit(m)), planes, level)
    }

    /// [`Self::decide`] with `m`'s bit index already computed (the traversal's).
    #[inline(always)]
    fn decide_at(&self, mi: Pt, planes: u8, level: u32) -> Decision {
        let m = mi.0;
        let (e, z, r) = match self.h.errors {
            ErrorStore::Records(recs, layout) => {
                // One 8-byte load: error, height and radius together. The record index is the
                // bit index for linear records and in the hierarchical bit order.
                let k = match layout {
                    super::RecordLayout::Linear => mi.1,
                    super::RecordLayout::Interleaved if self.order.hierarchical() => mi.1,
                    super::RecordLayout::Interleaved => {
                        record_index(layout, &self.g, m.0 as u64, m.1 as u64)
                    }
                };
                let Some(rec) = recs.get(k) else {
                    return Decision::Split(planes);
                };
                let e = rec.error_value();
                if e == f32::INFINITY {
                    return Decision::Split(planes);
                }
                if self.view.is_none() {
                    return self.decide_vi(e, planes);
                }
                (e, rec.z as f64, rec.radius_value() as f64)
            }
            _ => {
                let i = m.1 as usize * self.g.width() as usize + m.0 as usize;
                let e = self.h.err_at(i);
                if e == f32::INFINITY {
                    return Decision::Split(planes);
                }
                if self.view.is_none() {
                    return self.decide_vi(e, planes);
                }
                let z = self.t.local_z(m.0 as u32, m.1 as u32) as f64;
                (e, z, self.h.radius_at(i, level) as f64)
            }
        };
        let Some(v) = self.view.as_ref() else {
            return self.decide_vi(e, planes);
        };
        self.decide_view(v, false, m, (e, z, r), planes, level)
    }

    /// The view-dependent part of [`Self::decide_at`] for vertex `m` with error `e` (finite),
    /// local height `z` and radius `r`. `sphere_tau`: the caller knows that the hierarchy has
    /// spheres and that `tau > 0` (a constant `true` folds those tests away where this is
    /// inlined; `false` tests them).
    #[inline(always)]
    fn decide_view(
        &self,
        v: &ViewData,
        sphere_tau: bool,
        m: (i64, i64),
        (e, z, r): (f32, f64, f64),
        planes: u8,
        level: u32,
    ) -> Decision {
        // The vertex's position from its grid index, with per-frame constants (the map's grid
        // index in f64 times the spacing: bit-identical across tiles, see `with_grid_origin`).
        let px = (m.0 + v.ox) as f64 * v.sx;
        let py = (m.1 + v.oy) as f64 * v.sy;
        let spheres = sphere_tau || v.spheres;
        let mut planes = planes;
        if planes != 0 && level < v.lazy_from {
            match cull_at(v, spheres, px, py, z, r, planes) {
                Some(p) => planes = p,
                None => return Decision::Cull,
            }
        }
        let ef = e as f64;
        let active = if spheres {
            // SOAR's form without a square root: e kappa / tau + r > |eye - p|.
            if sphere_tau || v.tau > 0.0 {
                let (dx, dy, dz) = (v.eye[0] - px, v.eye[1] - py, v.eye[2] - z);
                let reach = ef * v.kappa_over_tau + r;
                ef > 0.0 && reach * reach > dx * dx + dy * dy + dz * dz
            } else {
                ef > 0.0
            }
        } else {
            ef * v.kappa > v.tau * self.distance(v, [m.0, m.1], z, r)
        };
        if active {
            Decision::Split(planes)
        } else {
            Decision::Keep
        }
    }

    #[inline(always)]
    fn decide_vi(&self, e: f32, planes: u8) -> Decision {
        if e > self.max_error {
            Decision::Split(planes)
        } else {
            Decision::Keep
        }
    }

    /// Distance from the eye to the nearest point of the vertex's bounding volume (0 inside).
    #[inline(always)]
    fn distance(&self, v: &ViewData, m: [i64; 2], z: f64, r: f64) -> f64 {
        let s = self.h.scale();
        let (px, py) = (
            (m[0] + v.ox) as f64 * s.dx as f64,
            (m[1] + v.oy) as f64 * s.dy as f64,
        );
        let (dx, dy) = (v.eye[0] - px, v.eye[1] - py);
        if self.h.spheres() {
            let dz = v.eye[2] - z;
            (libm::sqrt(dx * dx + dy * dy + dz * dz) - r).max(0.0)
        } else {
            let dh = (libm::sqrt(dx * dx + dy * dy) - r).max(0.0);
            let dz = (v.z_lo - v.eye[2]).max(v.eye[2] - v.z_hi).max(0.0);
            libm::sqrt(dh * dh + dz * dz)
        }
    }
}

/// Tests the volume at `(px, py, z)` (local) with radius `r` against the active planes of
/// `planes` only (set bits, in plane order): `None` if outside one, else the planes the volume
/// still crosses. `spheres`: whether the volume is a sphere (`v.spheres`, passed so that a
/// caller that knows it folds the test away).
#[inline(always)]
fn cull_at(
    v: &ViewData,
    spheres: bool,
    px: f64,
    py: f64,
    z: f64,
    r: f64,
    planes: u8,
) -> Option<u8> {
    let mut out = planes;
    let mut rest = planes;
    while rest != 0 {
        // At most 6 iterations: one per set bit of a 6-plane mask.
        let k = rest.trailing_zeros();
        rest &= rest - 1;
        let p = v.planes[k as usize & 7];
        let (lo, hi) = if spheres {
            let c = p[0] * px + p[1] * py + p[2] * z + p[3];
            (c - r, c + r)
        } else {
            let hyp = libm::sqrt(p[0] * p[0] + p[1] * p[1]);
            let c = p[0] * px + p[1] * py + p[3];
            let (za, zb) = (p[2] * v.z_lo, p[2] * v.z_hi);
            (c - r * hyp + za.min(zb), c + r * hyp + za.max(zb))
        };
        if hi < 0.0 {
            return None;
        }
        if lo > 0.0 {
            out &= !(1 << k);
        }
    }
    Some(out)
}

fn view_data(h: &Hierarchy<'_>, v: &View, g: RefineGrid) -> Result<ViewData, Error> {
    let s = h.scale();
    let off = s.z_offset as f64;
    let far_given = v.far.is_some();
    let far = v.far.unwrap_or(v.near * 1e6);
    let planes4: [Vec4; 6] = v.camera.frustum_planes(v.near, far)?;
    let mut planes = [[0.0f64; 4]; 8];
    for (o, p) in planes.iter_mut().zip(planes4.iter()) {
        // n . (x, y, z_local + off) + d = n . (x, y, z_local) + (d + n.z off)
        *o = [
            p.x as f64,
            p.y as f64,
            p.z as f64,
            p.w as f64 + p.z as f64 * off,
        ];
    }
    if let Some(r) = v.morph_range {
        if !(r.is_finite() && r > 1.0) {
            return Err(Error::InvalidParameter {
                name: "geomorph_range",
                value: r,
            });
        }
    }
    let mask = if !v.culling {
        0
    } else if far_given {
        0b11_1111
    } else {
        0b01_1111
    };
    let (z_lo, z_hi) = h.z_range();
    let (mut z_lo, mut z_hi) = (z_lo as f64, z_hi as f64);
    if let Some((lo, hi)) = v.z_range {
        if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
            return Err(Error::InvalidParameter {
                name: "z_range",
                value: if lo.is_finite() { hi } else { lo },
            });
        }
        z_lo = z_lo.min(lo as f64);
        z_hi = z_hi.max(hi as f64);
    }
    let e = v.camera.eye;
    Ok(ViewData {
        eye: [e.x as f64, e.y as f64, e.z as f64 - off],
        kappa: v.camera.kappa() as f64,
        tau: v.tau as f64,
        kappa_over_tau: v.camera.kappa() as f64 / v.tau as f64,
        planes,
        mask,
        lazy_from: g.levels().saturating_sub(v.lazy_levels),
        z_lo,
        z_hi,
        morph_range: v.morph_range.map_or(0.0, |r| r as f64),
        ox: i64::from(v.origin.0),
        oy: i64::from(v.origin.1),
        sx: s.dx as f64,
        sy: s.dy as f64,
        spheres: h.spheres(),
    })
}

/// The vertex and triangle buffers that the closure of [`Refiner::triangles_uninit`] returns.
pub type UninitBuffers<'v, 'o, P = [f32; 3]> =
    (&'v mut [MaybeUninit<P>], &'o mut [MaybeUninit<[u32; 3]>]);

/// What [`Refiner::triangles_uninit`] returns for the view-dependent criterion.
const UNINIT_VIEW: Error = Error::Unsupported {
    what: "uninitialised output for the view-dependent criterion (its list renumbers in place)",
};

/// `Ok(counts)` if the extraction wrote exactly the selection's counts of vertices and
/// triangles, which the callers of [`Refiner::triangles_uninit`] rely on to treat those elements
/// as initialised; [`Error::Internal`] otherwise (never seen: the tests and fuzzing compare the
/// counts with independent ones).
#[inline(always)]
fn checked(counts: FrameCounts, vertices: usize, triangles: usize) -> Result<FrameCounts, Error> {
    if (vertices, triangles) == (counts.vertices, counts.triangles) {
        Ok(counts)
    } else {
        Err(Error::Internal {
            what: "extraction wrote other counts than its selection",
        })
    }
}

pub(crate) fn need(needed: usize, actual: usize) -> Result<(), Error> {
    if actual < needed {
        Err(Error::BufferTooSmall { needed, actual })
    } else {
        Ok(())
    }
}

/// View-independent selection of a mesh the probes find small traverses the hierarchy while
/// the mesh has at most `samples / VI_SPARSE_SHARE` triangles, and scans the error array
/// beyond (see [`Refiner::select`]).
const VI_SPARSE_SHARE: usize = 16;

/// How often (in triangles) [`ViMark`] checks its budget and projects the mesh from the area
/// done.
const VI_CHECK: usize = 512;

/// [`ViMark`] gives up as soon as the projected mesh is this many times its budget.
const VI_PROJECT_FAR: f64 = 16.0;

/// A view-independent mesh of a square grid with at least `1 / VI_ROWS_SHARE` of the samples
/// kept is written row by row ([`ViSquare::rows`]), others by the walk from the roots. Measured
/// by `relief mesh --json`'s `refine_reused_ms`, both ways alternated on the peer script's grids
/// (BENCHMARKS.md, "View-independent extraction row by row"): rows 1.2-1.5x the walk from 14%
/// kept up, about even at 10-11%, 0.95x at 7-8% and 0.85x at 5%.
const VI_ROWS_SHARE: usize = 10;

/// Whether [`Refiner::vi_square`] writes the mesh of a square grid row by row: dense selections
/// (whose rank prefix is valid for every word) with a large kept share.
fn by_rows(sel: &Selection, samples: usize) -> bool {
    let share = || sel.counts.vertices.saturating_mul(VI_ROWS_SHARE) >= samples;
    #[cfg(test)]
    let share = || VI_ROWS.with(|c| c.get()).unwrap_or_else(share);
    !sel.sparse && share()
}

#[cfg(test)]
std::thread_local! {
    /// Tests only: whether this thread's dense view-independent meshes of square grids are
    /// written row by row (`Some(true)`) or walked (`Some(false)`), instead of by the kept share.
    pub(crate) static VI_ROWS: core::cell::Cell<Option<bool>> = const { core::cell::Cell::new(None) };
}

#[cfg(test)]
std::thread_local! {
    /// Tests only: the view-independent budget of this thread's selections (`0`: dense,
    /// `usize::MAX`: sparse below `2^32` samples), instead of the probes' choice.
    pub(crate) static VI_LIMIT: core::cell::Cell<Option<usize>> = const { core::cell::Cell::new(None) };
}

/// Probes of [`Refiner::looks_small`].
const VI_PROBES: u32 = 256;

/// What [`Refiner::select`] did: the counts, and whether the marks are sparse (see
/// [`Marks::begin_sparse`]; [`Refiner::release`] clears them).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Selection {
    pub(crate) counts: FrameCounts,
    pub(crate) sparse: bool,
}

/// The scratch's parts: the bitmap of kept vertices (one bit per grid sample), the rank
/// prefix (one `u64` per bitmap word), a summary bitmap (one bit per bitmap word that has a
/// mark), a top summary (one bit per summary word that has a mark) and a marker word.
/// View-dependent refinement (and view-independent refinement of a small mesh on a square
/// grid) marks sparsely: it counts, numbers and clears only the words its mesh touches (found
/// through the two summaries, so that not even the summary is scanned whole: on a 16385^2
/// grid it has 65,536 words), so its cost follows the output, not the grid; it leaves the
/// bitmap and summaries zero and the marker [`CLEAN`], and clears everything first when the
/// marker says otherwise (a first call, garbage, or a dense view-independent call, which
/// overwrites the whole bitmap).
pub(crate) struct Marks<'s> {
    pub(crate) bits: &'s mut [u64],
    pub(crate) prefix: &'s mut [u64],
    summary: &'s mut [u64],
    top: &'s mut [u64],
    marker: &'s mut u64,
}

/// Marker of a scratch whose bitmap and summaries are all zero.
const CLEAN: u64 = 0x7265_6c69_6566_c1ea;

/// Marker of a scratch being marked sparsely (started clean: [`Marks::end_sparse`] may leave it
/// clean again); any other value but [`CLEAN`] means nothing is known.
const SPARSE: u64 = 0x7265_6c69_6566_5a5e;

/// `u64`s of scratch for a grid of `n` samples: bitmap, prefix, summary, top summary, marker.
pub(crate) const fn marks_len(n: usize) -> usize {
    let words = n.div_ceil(64);
    let summary = words.div_ceil(64);
    2 * words + summary + summary.div_ceil(64) + 1
}

pub(crate) fn marks(scratch: &mut [u64], n: usize) -> Result<Marks<'_>, Error> {
    let words = n.div_ceil(64);
    let len = scratch.len();
    let short = Error::BufferTooSmall {
        needed: marks_len(n),
        actual: len,
    };
    let (bits, rest) = scratch.split_at_mut_checked(words).ok_or(short)?;
    let (prefix, rest) = rest.split_at_mut_checked(words).ok_or(short)?;
    let sw = words.div_ceil(64);
    let (summary, rest) = rest.split_at_mut_checked(sw).ok_or(short)?;
    let (top, rest) = rest.split_at_mut_checked(sw.div_ceil(64)).ok_or(short)?;
    let marker = rest.first_mut().ok_or(short)?;
    Ok(Marks {
        bits,
        prefix,
        summary,
        top,
        marker,
    })
}

/// The set bits of `words` as indices `64 * word + bit`, increasing.
fn set_bits(words: &[u64]) -> impl Iterator<Item = usize> + '_ {
    words.iter().enumerate().flat_map(|(wi, &w)| {
        let mut b = w;
        core::iter::from_fn(move || {
            (b != 0).then(|| {
                let i = wi * 64 + b.trailing_zeros() as usize;
                b &= b - 1;
                i
            })
        })
    })
}

impl Marks<'_> {
    /// Before sparse marking: clears everything unless the scratch is known clean.
    pub(crate) fn begin_sparse(&mut self) {
        if *self.marker != CLEAN {
            self.bits.fill(0);
            self.summary.fill(0);
            self.top.fill(0);
        }
        *self.marker = SPARSE;
    }

    /// Before the whole bitmap is overwritten.
    pub(crate) fn dense(&mut self) {
        *self.marker = 0;
    }

    /// Marks vertex `i` (sparse mode: the bitmap started clean, so a word's first mark is the
    /// one that finds it zero, and only that one updates the summaries).
    #[inline(always)]
    pub(crate) fn mark(&mut self, i: usize) {
        let w = i >> 6;
        let Some(word) = self.bits.get_mut(w) else {
            return;
        };
        let old = *word;
        *word = old | 1u64 << (i & 63);
        if old == 0 {
            if let Some(s) = self.summary.get_mut(w >> 6) {
                *s |= 1u64 << (w & 63);
            }
            if let Some(t) = self.top.get_mut(w >> 12) {
                *t |= 1u64 << ((w >> 6) & 63);
            }
        }
    }

    /// The marked summary words' indices, increasing.
    fn touched_summary(&self) -> impl Iterator<Item = usize> + '_ {
        set_bits(self.top)
    }

    /// The marked words, increasing.
    pub(crate) fn touched(&self) -> impl Iterator<Item = usize> + '_ {
        let summary = &*self.summary;
        self.touched_summary().flat_map(move |si| {
            let s = summary.get(si..=si).unwrap_or(&[]);
            set_bits(s).map(move |b| si * 64 + b)
        })
    }

    /// The words a selection's vertices are in, increasing: the touched ones of sparse marks,
    /// every word of dense ones.
    pub(crate) fn selected_words(&self, sparse: bool) -> impl Iterator<Item = usize> + '_ {
        let dense = (!sparse).then_some(0..self.bits.len());
        let touched = sparse.then(|| self.touched());
        dense
            .into_iter()
            .flatten()
            .chain(touched.into_iter().flatten())
    }

    /// Rank prefix of the marked words; returns the number of marked vertices.
    pub(crate) fn prefix_sparse(&mut self) -> usize {
        let mut acc = 0u64;
        for si in set_bits(self.top) {
            let mut b = self.summary.get(si).copied().unwrap_or(0);
            while b != 0 {
                // At most 64 iterations: one per set bit.
                let w = si * 64 + b.trailing_zeros() as usize;
                b &= b - 1;
                if let Some(p) = self.prefix.get_mut(w) {
                    *p = acc;
                }
                acc += self.bits.get(w).map_or(0, |x| x.count_ones()) as u64;
            }
        }
        acc as usize
    }

    /// Clears the marked words and the summaries; the scratch is clean again. Only after
    /// [`Self::begin_sparse`]: otherwise (a dense selection since) nothing is cleared and the
    /// scratch stays unknown to the next selection.
    pub(crate) fn end_sparse(&mut self) {
        if *self.marker != SPARSE {
            return;
        }
        for si in set_bits(self.top) {
            let Some(s) = self.summary.get_mut(si) else {
                continue;
            };
            let mut b = *s;
            while b != 0 {
                // At most 64 iterations: one per set bit.
                let w = si * 64 + b.trailing_zeros() as usize;
                b &= b - 1;
                if let Some(x) = self.bits.get_mut(w) {
                    *x = 0;
                }
            }
            *s = 0;
        }
        self.top.fill(0);
        *self.marker = CLEAN;
    }
}

pub(crate) fn split_scratch(scratch: &mut [u64], n: usize) -> (&mut [u64], &mut [u64]) {
    let words = n.div_ceil(64);
    let (bits, rest) = scratch.split_at_mut(words.min(scratch.len()));
    let prefix = rest.get_mut(..words).unwrap_or(&mut []);
    (bits, prefix)
}

/// How the dense view-independent selection turns errors into the kept bitmap.
pub(crate) trait Fill: Copy {
    /// Sets bit `k` of `bits` when `keep(values[k])`; words past the values are left as they
    /// are.
    fn fill<V>(bits: &mut [u64], values: &[V], keep: impl Fn(&V) -> bool);
}

/// Eight values at a time ([`fill_bits`]): the fastest form on the default x86-64 target,
/// whose vector compares yield at most four bits at a time.
#[derive(Clone, Copy)]
pub(crate) struct Narrow;

impl Fill for Narrow {
    #[inline(always)]
    fn fill<V>(bits: &mut [u64], values: &[V], keep: impl Fn(&V) -> bool) {
        fill_bits(bits, values, keep)
    }
}

/// A whole word at a time ([`fill_words`]): inlined into a function compiled with AVX-512
/// (`avx512f` and `avx512bw`), the 64 compares become a few vector compares into mask
/// registers, whose bits are the word. Without AVX-512 the same loop compiles to slower code
/// than [`Narrow`]'s, so only the AVX-512 entry points use it.
#[cfg(any(target_arch = "x86_64", test))]
#[derive(Clone, Copy)]
pub(crate) struct Wide;

#[cfg(any(target_arch = "x86_64", test))]
impl Fill for Wide {
    #[inline(always)]
    fn fill<V>(bits: &mut [u64], values: &[V], keep: impl Fn(&V) -> bool) {
        fill_words(bits, values, keep)
    }
}

/// [`fill_bits`] a whole word of values at a time (see [`Wide`]).
#[cfg(any(target_arch = "x86_64", test))]
#[inline(always)]
fn fill_words<V>(bits: &mut [u64], values: &[V], keep: impl Fn(&V) -> bool) {
    for (chunk, word) in values.chunks(64).zip(bits.iter_mut()) {
        let mut b = 0u64;
        for (k, v) in chunk.iter().enumerate() {
            b |= u64::from(keep(v)) << k;
        }
        *word = b;
    }
}

/// Sets bit `k` of the bitmap when `keep(values[k])`, 64 values per word. Whole words go eight
/// values at a time into a byte (constant trip counts the compiler turns into vector compares
/// and mask moves: 1.6-2x the speed of one value at a time); the last, partial word value by
/// value. Words past the values are left as they are.
fn fill_bits<V>(bits: &mut [u64], values: &[V], keep: impl Fn(&V) -> bool) {
    let mut chunks = values.chunks_exact(64);
    let mut words = bits.iter_mut();
    // The chunks first: `zip` must not take a word when the whole chunks have run out.
    for (chunk, word) in (&mut chunks).zip(&mut words) {
        let mut b = 0u64;
        for (g, oct) in chunk.chunks_exact(8).enumerate() {
            let mut m = 0u8;
            for (j, v) in oct.iter().enumerate() {
                m |= u8::from(keep(v)) << j;
            }
            b |= u64::from(m) << (8 * g);
        }
        *word = b;
    }
    let rest = chunks.remainder();
    if let (false, Some(word)) = (rest.is_empty(), words.next()) {
        let mut b = 0u64;
        for (k, v) in rest.iter().enumerate() {
            b |= u64::from(keep(v)) << k;
        }
        *word = b;
    }
}

/// The largest bfloat16 code whose value is `<= e` (`e >= 0` finite): `decode(c) > e` exactly
/// when `c > bf16_floor_code(e)`.
fn bf16_floor_code(e: f32) -> u16 {
    (e.max(0.0).to_bits() >> 16) as u16
}

/// How grid points map to bits of the marks bitmap, and so the order vertices are numbered in.
///
/// Row-major (`y * width + x`) everywhere except view-dependent frames over interleaved
/// records of a square grid, where bit `k` is the point's record (SOAR's hierarchical order):
/// a frame's vertices, mostly of coarse levels, then fill a few dense runs of the bitmap and its
/// rank prefix, as they do in the records, instead of one cache line and one page each on a
/// large grid (row-major rows of a 16385^2 grid are 2 KiB of bits apart).
#[derive(Debug, Clone, Copy)]
pub(crate) struct BitOrder {
    w: i64,
    /// The square's side when hierarchical.
    side: Option<u64>,
}

impl BitOrder {
    #[inline(always)]
    pub(crate) fn bit(&self, p: (i64, i64)) -> usize {
        match self.side {
            None => (p.1 * self.w + p.0) as usize,
            Some(n) => interleaved_index(n, p.0 as u64, p.1 as u64) as usize,
        }
    }

    /// The grid point of bit `i` (row-major: one division per bit; `write_positions` walks
    /// row-major runs without one).
    #[inline(always)]
    pub(crate) fn point(&self, i: usize) -> (u32, u32) {
        match self.side {
            None => {
                let w = self.w.max(1) as usize; // never 0; the max keeps a panic path out
                ((i % w) as u32, (i / w) as u32)
            }
            Some(n) => {
                let (x, y) = interleaved_coords(n, i as u64);
                (x as u32, y as u32)
            }
        }
    }

    pub(crate) fn hierarchical(&self) -> bool {
        self.side.is_some()
    }
}

/// Rank of vertex `i` in the bitmap: its index in the vertex buffer.
#[inline(always)]
pub(crate) fn rank(bits: &[u64], prefix: &[u64], i: usize) -> u32 {
    let w = i >> 6;
    let b = bits.get(w).copied().unwrap_or(0);
    let p = prefix.get(w).copied().unwrap_or(0);
    (p + (b & ((1u64 << (i & 63)) - 1)).count_ones() as u64) as u32
}

/// What the vertex buffer of [`Refiner::triangles`] (and of its `_uninit` and `_popcnt`
/// builds) holds for each vertex:
/// - `[f32; 3]`: its position, world x and y and the local height plus the map's z offset
///   (`[x * dx, y * dy, z + z_offset]`, as [`Refiner::morph`]'s positions);
/// - `[u16; 2]`: its grid coordinates `[x, y]` (column, row), the vertex format of
///   `@mapbox/martini` and `pymartini`, for a vertex shader that reads the heights from a texture
///   of the map. No height is read. Grids of at most 65,536 samples a side
///   ([`Error::SizeOverflow`] otherwise).
///
/// The triangles are the same, index for index, whichever the vertex type.
///
/// ```
/// use relief_core::refine::{preprocess_compact, scratch_len, Criterion, Refiner};
/// use relief_core::Heightfield;
/// let s: Vec<f32> = (0..81).map(|i| ((i * 37) % 11) as f32).collect();
/// let hf = Heightfield::new(&s, 9, 9).unwrap();
/// let mut e = vec![0u16; 81];
/// let h = preprocess_compact(&hf, &mut e).unwrap();
/// let rf = Refiner::new(&h, &hf, Criterion::MaxError(1.0)).unwrap();
/// let mut scratch = vec![0; scratch_len(9, 9)];
/// let (mut p, mut t) = (vec![[0.0f32; 3]; 81], vec![[0u32; 3]; 128]);
/// let (mut g, mut t2) = (vec![[0u16; 2]; 81], vec![[0u32; 3]; 128]);
/// let c = rf.triangles(&mut scratch, &mut p, &mut t).unwrap();
/// assert_eq!(rf.triangles(&mut scratch, &mut g, &mut t2).unwrap(), c);
/// assert_eq!(t, t2);
/// for (p, g) in p[..c.vertices].iter().zip(&g[..c.vertices]) {
///     assert_eq!([p[0], p[1]], [g[0] as f32, g[1] as f32]);
/// }
/// ```
pub trait MeshVertex: sealed::Sealed + Copy + 'static {}

impl MeshVertex for [f32; 3] {}

impl MeshVertex for [u16; 2] {}

mod sealed {
    use crate::Scale;

    /// What [`super::MeshVertex`] needs, out of the public interface.
    pub trait Sealed {
        /// The largest grid coordinate the type holds.
        const MAX_COORD: u64;
        /// The vertex at grid point `(x, y)`, where `z` gives its local height (called only by
        /// a type that stores it, so the others never load it).
        fn at(x: u32, y: u32, s: &Scale, z: impl FnOnce() -> f32) -> Self;
    }

    impl Sealed for [f32; 3] {
        const MAX_COORD: u64 = u64::MAX;
        #[inline(always)]
        fn at(x: u32, y: u32, s: &Scale, z: impl FnOnce() -> f32) -> Self {
            [x as f32 * s.dx, y as f32 * s.dy, z() + s.z_offset]
        }
    }

    impl Sealed for [u16; 2] {
        const MAX_COORD: u64 = u16::MAX as u64;
        #[inline(always)]
        fn at(x: u32, y: u32, _s: &Scale, _z: impl FnOnce() -> f32) -> Self {
            // Both fit: `Refiner::fits_vertex` checked the grid's size.
            [x as u16, y as u16]
        }
    }
}

/// An element of a caller's output buffer, written once by the extraction: the value itself,
/// or an uninitialised slot ([`Refiner::triangles_uninit`]), so that fresh buffers need not be
/// zeroed before they are filled.
pub(crate) trait Slot<T> {
    /// Stores `v`.
    fn set(&mut self, v: T);
}

impl<T> Slot<T> for T {
    #[inline(always)]
    fn set(&mut self, v: T) {
        *self = v;
    }
}

impl<T> Slot<T> for MaybeUninit<T> {
    #[inline(always)]
    fn set(&mut self, v: T) {
        self.write(v);
    }
}

/// Triangles written into a caller buffer (while there is room), counted.
struct TriOut<'o, O: Slot<[u32; 3]> = [u32; 3]> {
    out: &'o mut [O],
    n: usize,
}

impl<O: Slot<[u32; 3]>> TriOut<'_, O> {
    #[inline(always)]
    fn put(&mut self, t: [u32; 3]) {
        if let Some(o) = self.out.get_mut(self.n) {
            o.set(t);
        }
        self.n += 1;
    }

    /// Writes `t` and `u` (while there is room) and counts `1 + more` (`more` 0 or 1) of them.
    #[inline(always)]
    fn put_pair(&mut self, t: [u32; 3], u: [u32; 3], more: usize) {
        if let Some(o) = self.out.get_mut(self.n) {
            o.set(t);
        }
        if let Some(o) = self.out.get_mut(self.n + 1) {
            o.set(u);
        }
        self.n += 1 + more;
    }
}

/// `item` with the attributes of `{#[...] ...}` (so that a group of attributes can be passed
/// on, and repeated, as one token tree).
macro_rules! with_attrs {
    ({$(#[$attr:meta])*} $($item:tt)*) => {
        $(#[$attr])*
        $($item)*
    };
}

/// Defines the recursive traversal of [`ViSquare`] under names (and attributes `$attrs`: the
/// same body is compiled once for the default target and once with `popcnt`, whose functions
/// must call each other to keep the feature): `$name` from a root, `$known` for a triangle
/// known to split, `$block` for one six levels above the leaves, and one function `$lv` per
/// level `$d` above that, whose children go to `$below` (one level finer).
macro_rules! vi_square_walk {
    ($attrs:tt $name:ident, $known:ident, $block:ident, [$($lv:ident = $d:literal < $below:ident),*]) => {
        with_attrs! {
            $attrs
            /// A triangle known to split, six levels above the leaves: [`Self::known6`] as a
            /// function of its own (the levels above call it).
            #[inline(never)]
            fn $block(&mut self, l: u64, r: u64, a: u64, m: u64) {
                self.known6(l, r, a, m)
            }
        }

        $(
            with_attrs! {
                $attrs
                #[doc = concat!("A triangle known to split, ", stringify!($d), " levels above the leaves.")]
                #[inline(never)]
                fn $lv(&mut self, l: u64, r: u64, a: u64, m: u64) {
                    vi_children!(self, l, r, a, m, $below)
                }
            }
        )*

        with_attrs! {
            $attrs
            /// Triangle `(l, r, a)` whose split vertex is `depth` levels above the leaves.
            /// Recursion depth at most `levels() <= 60`.
            fn $name(&mut self, l: u64, r: u64, a: u64, depth: u32) {
                match self.split(l, r) {
                    Some(m) if depth > 0 => self.$known(l, r, a, m, depth),
                    _ => self.put(l, r, a),
                }
            }
        }

        with_attrs! {
            $attrs
            /// The same for a triangle known to split at `m` (`depth > 0`). Each child's split
            /// is tested before the call, so a child that stays whole is written without one
            /// (7-10% faster on coarse meshes than a call that tests it, BENCHMARKS.md). The
            /// finest levels are one inline block without calls (`known6`): five levels were
            /// 5-13% faster than calls down to the second-finest level. Each level above has its
            /// own function (`$lv`), so the predictor keeps each level's split branches apart:
            /// 2-7% faster than one recursion for all of them; with those, a block of six levels
            /// is 1-3% faster than five, seven 7-15% slower, and functions up to 16 levels were
            /// no faster than up to 12 (BENCHMARKS.md).
            fn $known(&mut self, l: u64, r: u64, a: u64, m: u64, depth: u32) {
                match depth {
                    1 => {
                        // The children are leaf cells: emit them without recursing.
                        self.put(a, l, m);
                        self.put(r, a, m);
                    }
                    2 => self.known2(l, r, a, m),
                    6 => self.$block(l, r, a, m),
                    $($d => self.$lv(l, r, a, m),)*
                    _ => vi_children!(self, l, r, a, m, $known, depth - 1),
                }
            }
        }
    };
}

/// Writes or descends into both children of triangle `(l, r, a)` split at `m`: a child whose
/// own split vertex `c` is kept goes to `$s.$descend(l, r, a, c, extra...)`, the others are
/// written.
macro_rules! vi_children {
    ($s:ident, $l:ident, $r:ident, $a:ident, $m:ident, $descend:ident $(, $extra:expr)*) => {{
        match $s.split($a, $l) {
            Some(c) => $s.$descend($a, $l, $m, c $(, $extra)*),
            None => $s.put($a, $l, $m),
        }
        match $s.split($r, $a) {
            Some(c) => $s.$descend($r, $a, $m, c $(, $extra)*),
            None => $s.put($r, $a, $m),
        }
    }};
}

/// Defines `$name`: [`ViSquare`]'s walk of a triangle known to split, `$depth` levels above the
/// leaves, inline through `$below` (one level finer) without a call.
macro_rules! vi_known_inline {
    ($name:ident, $below:ident, $depth:literal) => {
        #[doc = concat!("A triangle known to split, ", stringify!($depth), " levels above the leaves, inline.")]
        #[inline(always)]
        fn $name(&mut self, l: u64, r: u64, a: u64, m: u64) {
            vi_children!(self, l, r, a, m, $below)
        }
    };
}

/// View-independent traversal of a grid of fewer than `2^32` samples (a square one from its two
/// roots, others from the triangles inside the domain, [`RefineGrid::walk_edge`]) driven by the
/// bitmap of kept vertices. A vertex travels as one `u64`: its row-major grid index in
/// the low 32 bits and its rank (vertex number) in the high 32 bits; a midpoint's index is the
/// mean of its hypotenuse ends' indices, and each rank is computed when the vertex is split off.
struct ViSquare<'a, 'o, O: Slot<[u32; 3]> = [u32; 3]> {
    bits: &'a [u64],
    prefix: &'a [u64],
    out: TriOut<'o, O>,
    /// Cells a side (`2^k`).
    side: u64,
}

const IDX: u64 = 0xffff_ffff;

/// Entries of the lean walk's stack (at most `levels() + 2 <= 62`).
const LEAN_STACK: usize = 64;

impl<O: Slot<[u32; 3]>> ViSquare<'_, '_, O> {
    /// The bitmap word holding grid index `i`.
    #[inline(always)]
    fn word(&self, i: u64) -> u64 {
        self.bits.get((i >> 6) as usize).copied().unwrap_or(0)
    }

    /// Packs grid index `i` (whose bitmap word is `word`) with its rank.
    #[inline(always)]
    fn pack(&self, i: u64, word: u64) -> u64 {
        let below = word & ((1u64 << (i & 63)) - 1);
        let r =
            self.prefix.get((i >> 6) as usize).copied().unwrap_or(0) + below.count_ones() as u64;
        (i & IDX) | (r << 32)
    }

    /// Packs grid index `i` with its rank.
    #[inline(always)]
    fn vertex(&self, i: u64) -> u64 {
        self.pack(i, self.word(i))
    }

    /// The midpoint of hypotenuse `l-r` (a grid index).
    #[inline(always)]
    fn mid(l: u64, r: u64) -> u64 {
        ((l & IDX) + (r & IDX)) >> 1
    }

    /// The split vertex of hypotenuse `l-r` if it is kept.
    #[inline(always)]
    fn split(&self, l: u64, r: u64) -> Option<u64> {
        let im = Self::mid(l, r);
        let word = self.word(im);
        if (word >> (im & 63)) & 1 == 0 {
            return None;
        }
        Some(self.pack(im, word))
    }

    #[inline(always)]
    fn put(&mut self, a: u64, b: u64, c: u64) {
        self.out
            .put([(a >> 32) as u32, (b >> 32) as u32, (c >> 32) as u32]);
    }

    /// The two root triangles `(l, r, a)`, their vertices numbered.
    #[inline(always)]
    fn roots(&self) -> [(u64, u64, u64); 2] {
        let (n, w) = (self.side, self.side + 1);
        let (c00, c10, c01, c11) = (
            self.vertex(0),
            self.vertex(n),
            self.vertex(n * w),
            self.vertex(n * w + n),
        );
        [(c11, c00, c10), (c00, c11, c01)]
    }

    /// A triangle known to split, two levels above the leaves: its children through
    /// [`Self::last`], without a branch.
    #[inline(always)]
    fn known2(&mut self, l: u64, r: u64, a: u64, m: u64) {
        self.last(a, l, m);
        self.last(r, a, m);
    }

    vi_known_inline!(known3, known2, 3);
    vi_known_inline!(known4, known3, 4);
    vi_known_inline!(known5, known4, 5);
    vi_known_inline!(known6, known5, 6);

    vi_square_walk!(
        {}
        walk,
        walk_known,
        known_6,
        [known_7 = 7 < known_6, known_8 = 8 < known_7, known_9 = 9 < known_8,
         known_10 = 10 < known_9, known_11 = 11 < known_10, known_12 = 12 < known_11,
         known_13 = 13 < known_12]
    );
    vi_square_walk!(
        {
            #[cfg(target_arch = "x86_64")]
            #[target_feature(enable = "popcnt")]
        }
        walk_popcnt,
        walk_known_popcnt,
        known_6_popcnt,
        [known_7_popcnt = 7 < known_6_popcnt, known_8_popcnt = 8 < known_7_popcnt,
         known_9_popcnt = 9 < known_8_popcnt, known_10_popcnt = 10 < known_9_popcnt,
         known_11_popcnt = 11 < known_10_popcnt, known_12_popcnt = 12 < known_11_popcnt,
         known_13_popcnt = 13 < known_12_popcnt]
    );

    /// [`Self::walk`] at `depth == 1`, without a branch on the split: the first slot gets
    /// `(a, l, m)` when `m` is kept and `(l, r, a)` otherwise (selected by a mask), the second
    /// always gets `(r, a, m)` and counts only when `m` is kept (otherwise the next triangle
    /// overwrites it; the output is cut to the exact count, so nothing lands past it).
    #[inline(always)]
    fn last(&mut self, l: u64, r: u64, a: u64) {
        let im = Self::mid(l, r);
        let word = self.word(im);
        let kept = (word >> (im & 63)) & 1;
        let m = self.pack(im, word);
        let keep = kept.wrapping_neg();
        let pick = |x: u64, y: u64| ((x & keep) | (y & !keep)) >> 32;
        let first = [pick(a, l) as u32, pick(l, r) as u32, pick(m, a) as u32];
        let second = [(r >> 32) as u32, (a >> 32) as u32, (m >> 32) as u32];
        self.out.put_pair(first, second, kept as usize);
    }
}

struct MarkSink<'a, 's> {
    m: &'a mut Marks<'s>,
    n: usize,
}

impl PtSink for MarkSink<'_, '_> {
    #[inline(always)]
    fn tri(&mut self, a: Pt, b: Pt, c: Pt) {
        for p in [a, b, c] {
            self.m.mark(p.1);
        }
        self.n += 1;
    }
}

/// Marks the kept part of a grid's hierarchy (see [`Refiner::mark_vi`]): vertices travel as
/// row-major grid indices (a midpoint's is the mean of its hypotenuse ends'), `kept(i)` is
/// vertex `i`'s error test.
struct ViMark<'a, 's, K: Fn(usize) -> bool> {
    m: &'a mut Marks<'s>,
    kept: K,
    /// Triangles so far.
    n: usize,
    limit: usize,
    /// Area of the triangles so far, in leaf triangles (one with its split vertex `d` levels
    /// above the leaves covers `2^d`), and of the whole square.
    area: u64,
    total: u64,
    /// Set when the budget ran out or the mesh is projected past it.
    over: bool,
}

impl<'a, 's, K: Fn(usize) -> bool> ViMark<'a, 's, K> {
    /// Marks the corners of grid `g` and the kept part below its hierarchy's two root
    /// triangles (on a grid that does not fill its square, below the triangles inside the
    /// domain, [`RefineGrid::walk_edge`]); the triangle count, or `None` past `limit`
    /// triangles.
    #[inline(always)]
    fn run(m: &'a mut Marks<'s>, limit: usize, g: &RefineGrid, kept: K) -> Option<usize> {
        let (w, h) = (g.width() as usize, g.height() as usize);
        let (w1, h1) = (w.saturating_sub(1), h.saturating_sub(1));
        let (c00, c10, c01, c11) = (0, w1, h1 * w, h1 * w + w1);
        let mut s = ViMark {
            m,
            kept,
            n: 0,
            limit,
            area: 0,
            // Leaf triangles in the domain (`2^(levels + 1)` on a square grid).
            total: 2 * w1 as u64 * h1 as u64,
            over: false,
        };
        for c in [c00, c10, c01, c11] {
            s.m.mark(c);
        }
        if g.is_square() {
            s.walk(c11, c00, c10, g.levels());
            s.walk(c00, c11, c01, g.levels());
        } else {
            // A split vertex across the edge is marked when it is in the domain and kept, as
            // the dense bitmap has it.
            let (w, h, levels) = (i64::from(g.width()), i64::from(g.height()), g.levels());
            let idx = |p: (i64, i64)| (p.1 * w + p.0) as usize;
            g.walk_edge(|e| {
                match e {
                    Edge::Inside(l, r, a, level) => {
                        s.walk(idx(l), idx(r), idx(a), levels.saturating_sub(level));
                    }
                    Edge::Split(m) => {
                        if m.0 < w && m.1 < h && (s.kept)(idx(m)) {
                            s.m.mark(idx(m));
                        }
                    }
                }
                !s.over
            });
        }
        (!s.over && s.n <= limit).then_some(s.n)
    }

    /// Counts a triangle of `2^depth` leaf triangles' area. Past the budget (checked every
    /// `VI_CHECK` triangles, and at the end) the traversal gives up; it also projects the mesh
    /// from the share of the area done so far (the traversal covers the square once) and gives
    /// up early past `VI_PROJECT_FAR` times the budget, so that a large mesh the probes missed
    /// costs the dense pass only a small prefix of the traversal. (A closer projection is not
    /// reliable: rough and flat regions of a real DEM come in long runs of the traversal
    /// order.)
    #[inline(always)]
    fn emit(&mut self, depth: u32) {
        self.n += 1;
        self.area += 1u64 << depth.min(62);
        if self.n.is_multiple_of(VI_CHECK) {
            let projected = self.n as f64 * self.total as f64 / self.area as f64;
            let far = projected > VI_PROJECT_FAR * self.limit as f64;
            self.over |= self.n > self.limit || far;
        }
    }

    /// Triangle `(l, r, a)` whose split vertex is `depth` levels above the leaves. Recursion
    /// depth at most `levels() <= 60`.
    fn walk(&mut self, l: usize, r: usize, a: usize, depth: u32) {
        if self.over {
            return;
        }
        let m = (l + r) >> 1;
        if depth == 0 || !(self.kept)(m) {
            self.emit(depth);
            return;
        }
        self.m.mark(m);
        self.walk(a, l, m, depth - 1);
        self.walk(r, a, m, depth - 1);
    }
}

/// Writes triangles as grid indices (while there is room) and marks their vertices.
struct GridSink<'a, 's, 'o> {
    m: &'a mut Marks<'s>,
    out: TriOut<'o>,
    /// Grid width (for [`LeanSink`]: row-major bit order).
    w: u64,
}

impl GridSink<'_, '_, '_> {
    /// Whether bit `i` is marked.
    #[inline(always)]
    fn marked(&self, i: usize) -> bool {
        self.m
            .bits
            .get(i >> 6)
            .is_some_and(|b| (b >> (i & 63)) & 1 == 1)
    }

    /// Marks the corners' bits and writes the triangle (while there is room).
    #[inline(always)]
    fn emit(&mut self, corners: [usize; 3]) {
        let mut t = [0u32; 3];
        for (o, i) in t.iter_mut().zip(corners) {
            self.m.mark(i);
            *o = i as u32;
        }
        self.out.put(t);
    }
}

impl PtSink for GridSink<'_, '_, '_> {
    #[inline(always)]
    fn seen(&self, m: Pt) -> bool {
        self.marked(m.1)
    }

    #[inline(always)]
    fn tri(&mut self, a: Pt, b: Pt, c: Pt) {
        self.emit([a.1, b.1, c.1]);
    }
}

/// Writes triangles as row-major grid indices (while there is room); no marks, so the
/// traversal decides every vertex it reaches.
struct RowSink<'o> {
    w: i64,
    out: TriOut<'o>,
}

impl PtSink for RowSink<'_> {
    #[inline(always)]
    fn tri(&mut self, a: Pt, b: Pt, c: Pt) {
        let idx = |p: Pt| (p.0 .1 * self.w + p.0 .0) as u32;
        self.out.put([idx(a), idx(b), idx(c)]);
    }
}

/// What [`Refiner::lean_walk`] writes into: [`PtSink`] for corners packed as `x | y << 32`,
/// with row-major bit indices.
trait LeanSink {
    fn put(&mut self, a: u64, b: u64, c: u64);

    /// [`PtSink::seen`] for the vertex of row-major index `i`.
    #[inline(always)]
    fn seen(&self, _i: usize) -> bool {
        false
    }
}

impl LeanSink for RowSink<'_> {
    #[inline(always)]
    fn put(&mut self, a: u64, b: u64, c: u64) {
        let w = self.w as u64;
        let idx = |p: u64| ((p >> 32) * w + (p & IDX)) as u32;
        self.out.put([idx(a), idx(b), idx(c)]);
    }
}

impl LeanSink for GridSink<'_, '_, '_> {
    #[inline(always)]
    fn seen(&self, i: usize) -> bool {
        self.marked(i)
    }

    #[inline(always)]
    fn put(&mut self, a: u64, b: u64, c: u64) {
        let w = self.w;
        let i = |p: u64| ((p >> 32) * w + (p & IDX)) as usize;
        self.emit([i(a), i(b), i(c)]);
    }
}

/// Where [`Refiner::lean_walk`] reads vertex `i` (row-major, at `(x, y)`): its error (finite),
/// local height and radius, as [`Refiner::decide_at`] reads them; `None` where that splits
/// without a test (an infinite error, or no storage for the vertex).
trait Fetch {
    /// Whether the layout has per-vertex spheres (then [`Refiner::lean_frame`] also checks
    /// `tau > 0`, and the decision is told both).
    const SPHERES: bool;

    /// The data of vertex `i` at `(x, y)` on `level`.
    fn fetch(&self, i: usize, x: u32, y: u32, level: u32) -> Option<(f32, f64, f64)>;
}

/// The full layout: `f32` error and radius arrays, heights from the terrain.
struct FullFetch<'a, T> {
    err: &'a [f32],
    rad: &'a [f32],
    t: &'a T,
}

impl<T: Terrain> Fetch for FullFetch<'_, T> {
    const SPHERES: bool = true;

    #[inline(always)]
    fn fetch(&self, i: usize, x: u32, y: u32, _level: u32) -> Option<(f32, f64, f64)> {
        let e = self.err.get(i).copied().unwrap_or(f32::INFINITY);
        if e == f32::INFINITY {
            return None;
        }
        let z = self.t.local_z(x, y) as f64;
        let r = self.rad.get(i).copied().unwrap_or(f32::INFINITY) as f64;
        Some((e, z, r))
    }
}

/// Linear records: one 8-byte load.
struct RecordFetch<'a> {
    recs: &'a [VertexRecord],
}

impl Fetch for RecordFetch<'_> {
    const SPHERES: bool = true;

    #[inline(always)]
    fn fetch(&self, i: usize, _x: u32, _y: u32, _level: u32) -> Option<(f32, f64, f64)> {
        let rec = self.recs.get(i)?;
        let e = rec.error_value();
        if e == f32::INFINITY {
            return None;
        }
        Some((e, rec.z as f64, rec.radius_value() as f64))
    }
}

/// The compact layout: bfloat16 errors, level-only circles, heights from the terrain.
struct CompactFetch<'a, T> {
    err: &'a [u16],
    radius: &'a [f32; 64],
    t: &'a T,
}

impl<T: Terrain> Fetch for CompactFetch<'_, T> {
    const SPHERES: bool = false;

    #[inline(always)]
    fn fetch(&self, i: usize, x: u32, y: u32, level: u32) -> Option<(f32, f64, f64)> {
        let e = self
            .err
            .get(i)
            .map_or(f32::INFINITY, |&c| super::preprocess::decode_bf16(c));
        if e == f32::INFINITY {
            return None;
        }
        let z = self.t.local_z(x, y) as f64;
        let r = self
            .radius
            .get(level as usize)
            .copied()
            .unwrap_or(f32::INFINITY) as f64;
        Some((e, z, r))
    }
}

struct ListSink<'a, 'o, O: Slot<[u32; 3]> = [u32; 3]> {
    bits: &'a [u64],
    prefix: &'a [u64],
    w: i64,
    out: TriOut<'o, O>,
}

impl<O: Slot<[u32; 3]>> Sink for ListSink<'_, '_, O> {
    #[inline(always)]
    fn tri(&mut self, a: (i64, i64), b: (i64, i64), c: (i64, i64)) {
        let idx = |p: (i64, i64)| rank(self.bits, self.prefix, (p.1 * self.w + p.0) as usize);
        self.out.put([idx(a), idx(b), idx(c)]);
    }
}

#[cfg(test)]
mod cull_tests {
    use super::*;
    use crate::refine::{preprocess, preprocess_compact};
    use crate::Heightfield;
    use glam::Vec3;

    /// The all-planes loop `cull_at` replaced (every plane visited, inactive ones skipped).
    fn reference(v: &ViewData, px: f64, py: f64, z: f64, r: f64, planes: u8) -> Option<u8> {
        let mut out = planes;
        for (k, p) in v.planes.iter().enumerate() {
            if planes & (1 << k) == 0 {
                continue;
            }
            let (lo, hi) = if v.spheres {
                let c = p[0] * px + p[1] * py + p[2] * z + p[3];
                (c - r, c + r)
            } else {
                let hyp = libm::sqrt(p[0] * p[0] + p[1] * p[1]);
                let c = p[0] * px + p[1] * py + p[3];
                let (za, zb) = (p[2] * v.z_lo, p[2] * v.z_hi);
                (c - r * hyp + za.min(zb), c + r * hyp + za.max(zb))
            };
            if hi < 0.0 {
                return None;
            }
            if lo > 0.0 {
                out &= !(1 << k);
            }
        }
        Some(out)
    }

    #[test]
    fn active_plane_iteration_matches_the_all_planes_loop() {
        let s: Vec<f32> = (0..289).map(|i| ((i * 37) % 23) as f32).collect();
        let hf = Heightfield::new(&s, 17, 17).unwrap();
        let (mut e, mut r) = (vec![0.0; 289], vec![0.0; 289]);
        let full = preprocess(&hf, &mut e, &mut r).unwrap();
        let mut c = vec![0u16; 289];
        let compact = preprocess_compact(&hf, &mut c).unwrap();
        let cam = Camera::new(
            Vec3::new(-4.0, 3.0, 30.0),
            Vec3::new(10.0, 8.0, 0.0),
            50.0,
            320,
            200,
        )
        .unwrap();
        let view = View::new(&cam, 1.0).unwrap().with_near_far(0.5, Some(40.0));
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut culled, mut kept, mut dropped) = (0, 0, 0);
        for h in [&full, &compact] {
            let rf = Refiner::new(h, &hf, Criterion::View(view)).unwrap();
            let v = rf.view.unwrap();
            assert_eq!(v.spheres, core::ptr::eq(h, &full));
            assert_eq!(v.mask, 0b11_1111);
            for _ in 0..4000 {
                let (px, py) = (next() * 60.0 - 20.0, next() * 60.0 - 20.0);
                let (z, rad) = (next() * 80.0 - 20.0, next() * 6.0);
                let planes = (next() * 64.0) as u8 & 0b11_1111;
                let got = cull_at(&v, v.spheres, px, py, z, rad, planes);
                assert_eq!(got, reference(&v, px, py, z, rad, planes));
                match got {
                    None => culled += 1,
                    Some(p) if p != planes => dropped += 1,
                    Some(_) => kept += 1,
                }
            }
        }
        // Every outcome occurs: the comparison is not vacuous.
        assert!(
            culled > 100 && dropped > 100 && kept > 100,
            "{culled} {dropped} {kept}"
        );
    }

    /// The lean walk (full layout, linear records, compact layout; square grids and three that
    /// are not, through `lean_frame_domain`) against the
    /// general walk: the same triangles in the same order, through `grid_triangles` and through
    /// `triangles`.
    #[test]
    fn lean_walk_matches_the_general_walk_triangle_for_triangle() {
        use crate::refine::{pack_records, records_len, RecordLayout, VertexRecord};
        let (mut frames, mut total) = (0, 0);
        // Square grids from their roots; the others (the last three) down the domain's edge.
        for (w, h) in [
            (17u32, 17u32),
            (33, 33),
            (65, 65),
            (17, 9),
            (40, 65),
            (100, 37),
        ] {
            let n = (w * h) as usize;
            let s: std::vec::Vec<f32> = (0..n)
                .map(|i| ((i * 37) % 23) as f32 * 0.9 + ((i / w as usize) as f32 * 0.3).sin() * 9.0)
                .collect();
            let hf = Heightfield::new(&s, w, h).unwrap();
            let (mut er, mut ra) = (vec![0.0; n], vec![0.0; n]);
            let full = preprocess(&hf, &mut er, &mut ra).unwrap();
            let mut rl = vec![VertexRecord::default(); records_len(w, h, RecordLayout::Linear)];
            let lin = pack_records(&full, &hf, RecordLayout::Linear, &mut rl).unwrap();
            let mut ec = vec![0u16; n];
            let compact = preprocess_compact(&hf, &mut ec).unwrap();
            let f = w as f32;
            for (eye, target, tau) in [
                (Vec3::new(-4.0, 3.0, 30.0), Vec3::new(10.0, 8.0, 0.0), 0.5),
                (
                    Vec3::new(f / 2.0, f / 2.0, 2.0),
                    Vec3::new(f, f / 2.0, 0.0),
                    2.0,
                ),
                (
                    Vec3::new(f / 3.0, -5.0, 8.0),
                    Vec3::new(f / 3.0, f, 4.0),
                    1.0,
                ),
            ] {
                let cam = Camera::new(eye, target, 50.0, 320, 200).unwrap();
                for view in [
                    View::new(&cam, tau).unwrap(),
                    View::new(&cam, tau).unwrap().with_lazy_levels(0),
                    View::new(&cam, tau).unwrap().with_culling(false),
                ] {
                    for hier in [&full, &lin, &compact] {
                        let rf = Refiner::new(hier, &hf, Criterion::View(view)).unwrap();
                        // The general walk into the row-major sink `grid_triangles` uses.
                        let mut buf = vec![[0u32; 3]; crate::refine::triangle_bound(w, h)];
                        let mut rows = RowSink {
                            w: i64::from(w),
                            out: TriOut {
                                out: &mut buf,
                                n: 0,
                            },
                        };
                        rf.walk_all(&mut rows, false);
                        let count = rows.out.n;
                        let general = &buf[..count];
                        let mut lean = vec![[0u32; 3]; general.len() + 1];
                        let k = rf.grid_triangles(&mut lean).unwrap();
                        assert_eq!(&lean[..k], general, "{w} {eye}");
                        // `triangles` (marks and ranks) through the lean walk as well.
                        let mut sc = vec![0u64; crate::refine::scratch_len(w, h)];
                        let mut v = vec![[0.0f32; 3]; n];
                        let mut t = vec![[0u32; 3]; k];
                        let c = rf.triangles(&mut sc, &mut v, &mut t).unwrap();
                        assert_eq!(c.triangles, k);
                        for (lt, gt) in t.iter().zip(general) {
                            for (&li, &gi) in lt.iter().zip(gt) {
                                let p = v[li as usize];
                                assert_eq!([p[0], p[1]], [(gi % w) as f32, (gi / w) as f32]);
                            }
                        }
                        frames += 1;
                        total += k;
                    }
                }
            }
        }
        assert_eq!(frames, 6 * 3 * 3 * 3);
        assert!(
            total > 20_000,
            "{total} triangles: the comparison needs real frames"
        );
    }
}

#[cfg(test)]
mod vi_domain_tests {
    use super::*;
    use crate::refine::{hierarchy_len, preprocess, scratch_len, triangle_bound};
    use crate::Heightfield;
    use std::vec;
    use std::vec::Vec;

    /// The packed walk of grids that do not fill their square (`RefineGrid::walk_edge` down to
    /// the triangles inside the domain, then `ViSquare`) against `walk_vi` into `ListSink`, the
    /// walk it replaced there: the same triangles in the same order (`triangles_popcnt` against
    /// `triangles`: `tests/tests/refine.rs`).
    #[test]
    fn packed_walk_matches_walk_vi_on_grids_of_any_size() {
        let mut total = 0;
        let mut meshes = 0;
        for (w, h) in [
            (2u32, 3u32),
            (3, 2),
            (5, 9),
            (17, 6),
            (33, 20),
            (40, 65),
            (100, 37),
            (65, 66),
            (129, 3),
        ] {
            let n = (w * h) as usize;
            let s: Vec<f32> = (0..n)
                .map(|i| {
                    let (x, y) = ((i % w as usize) as f32, (i / w as usize) as f32);
                    ((i * 37) % 23) as f32 * 0.4 + (x * 0.3).sin() * 9.0 + (y * 0.21).cos() * 7.0
                })
                .collect();
            let hf = Heightfield::new(&s, w, h).unwrap();
            let hl = hierarchy_len(w, h);
            let (mut er, mut ra) = (vec![0.0; hl], vec![0.0; hl]);
            let full = preprocess(&hf, &mut er, &mut ra).unwrap();
            for e in [0.0f32, 0.5, 2.0, 6.0, 1e9] {
                let rf = Refiner::new(&full, &hf, Criterion::MaxError(e)).unwrap();
                assert!(!rf.g.is_square() || (w == h));
                let mut sc = vec![0u64; scratch_len(w, h)];
                let mut v = vec![[0.0f32; 3]; n];
                let mut t = vec![[0u32; 3]; triangle_bound(w, h)];
                let c = rf.triangles(&mut sc, &mut v, &mut t).unwrap();
                // The reference: `walk_vi` over the same selection.
                let sel = rf.select(&mut sc).unwrap();
                let mut buf = vec![[0u32; 3]; triangle_bound(w, h)];
                {
                    let (bits, prefix) = split_scratch(&mut sc, rf.g.len());
                    let (bits, prefix) = (&*bits, &*prefix);
                    let mut sink = ListSink {
                        bits,
                        prefix,
                        w: i64::from(w),
                        out: TriOut {
                            out: &mut buf,
                            n: 0,
                        },
                    };
                    let k = rf.g.side() as i64;
                    for (l, r, a) in [((k, k), (0, 0), (k, 0)), ((0, 0), (k, k), (0, k))] {
                        rf.walk_vi::<_, false>(&mut sink, bits, l, r, a, 0);
                    }
                    assert_eq!(sink.out.n, c.triangles, "{w}x{h} E={e}");
                }
                rf.release(&mut sc, sel);
                assert_eq!(&t[..c.triangles], &buf[..c.triangles], "{w}x{h} E={e}");
                total += c.triangles;
                meshes += 1;
            }
        }
        assert_eq!(meshes, 45);
        assert!(
            total > 40_000,
            "{total} triangles: the comparison needs real meshes"
        );
    }
}

#[cfg(test)]
mod fill_tests {
    use super::{Fill, Narrow, Wide};

    /// The bitmap one value at a time: bit `k` of word `k / 64` for every kept value.
    fn reference<V>(bits: &mut [u64], values: &[V], keep: impl Fn(&V) -> bool) {
        for (k, v) in values.iter().enumerate() {
            if let Some(w) = bits.get_mut(k / 64) {
                if k % 64 == 0 {
                    *w = 0;
                }
                *w |= u64::from(keep(v)) << (k % 64);
            }
        }
    }

    /// [`Narrow`] ([`fill_bits`]) and [`Wide`] ([`fill_words`]) set the same bits as the
    /// value-by-value loop, on lengths around whole words, with NaN, negative and infinite
    /// errors and every kind of bfloat16 code, and leave the words past the values alone.
    #[test]
    fn fill_bits_matches_value_by_value() {
        fill_matches_value_by_value::<Narrow>();
        fill_matches_value_by_value::<Wide>();
    }

    fn fill_matches_value_by_value<F: Fill>() {
        let mut next = crate::refine::tests::rng(0x9e37_79b9_7f4a_7c15);
        for len in [0usize, 1, 7, 8, 63, 64, 65, 127, 128, 129, 1000, 4096] {
            let f: Vec<f32> = (0..len)
                .map(|_| match next() % 8 {
                    0 => f32::NAN,
                    1 => -((next() % 100) as f32),
                    2 => f32::INFINITY,
                    3 => 5.0,
                    _ => (next() % 1000) as f32 / 100.0,
                })
                .collect();
            let c: Vec<u16> = (0..len).map(|_| next() as u16).collect();
            let words = len.div_ceil(64) + 2;
            for e in [0.0f32, 5.0, 9.99] {
                let (mut a, mut b) = (vec![u64::MAX; words], vec![u64::MAX; words]);
                F::fill(&mut a, &f, |&v| v > e);
                reference(&mut b, &f, |&v| v > e);
                assert_eq!(a, b, "f32 len {len} e {e}");
            }
            for ce in [0u16, 0x40a0, 0x7f7f, 0xfffe] {
                let (mut a, mut b) = (vec![u64::MAX; words], vec![u64::MAX; words]);
                F::fill(&mut a, &c, |&v| v > ce);
                reference(&mut b, &c, |&v| v > ce);
                assert_eq!(a, b, "u16 len {len} ce {ce:#x}");
            }
        }
    }
}

#[cfg(test)]
mod uninit_tests {
    use super::*;
    use crate::refine::{preprocess, scratch_len};
    use crate::Heightfield;

    /// `checked` passes only the selection's own counts; anything else is `Error::Internal`,
    /// never `Ok` (the guarantee `triangles_uninit`'s callers rely on).
    #[test]
    fn checked_refuses_other_counts() {
        let c = FrameCounts {
            vertices: 5,
            triangles: 4,
        };
        assert_eq!(checked(c, 5, 4), Ok(c));
        for (v, t) in [(4, 4), (5, 3), (6, 4), (5, 5), (0, 0)] {
            assert!(matches!(checked(c, v, t), Err(Error::Internal { .. })));
        }
    }

    /// `write_vertices` reports how many slots it wrote: all the marked vertices, or the
    /// buffer's length when that is shorter.
    #[test]
    fn write_vertices_counts_what_it_wrote() {
        let s: Vec<f32> = (0..25).map(|i| ((i * 7) % 5) as f32).collect();
        let hf = Heightfield::new(&s, 5, 5).unwrap();
        let (mut e, mut r) = ([0.0; 25], [0.0; 25]);
        let h = preprocess(&hf, &mut e, &mut r).unwrap();
        let rf = Refiner::new(&h, &hf, Criterion::MaxError(0.0)).unwrap();
        let mut scratch = [0u64; 64];
        assert!(scratch.len() >= scratch_len(5, 5));
        let sel = rf.select(&mut scratch).unwrap();
        let n = sel.counts.vertices;
        assert!(n > 3);
        for room in [0, 1, n - 1, n, n + 3] {
            let mut v = [MaybeUninit::new([9.0f32; 3]); 32];
            assert_eq!(
                rf.write_vertices::<[f32; 3], _>(&mut scratch, sel, &mut v[..room]),
                room.min(n)
            );
        }
        rf.release(&mut scratch, sel);
    }

    /// The two new error variants name what went wrong.
    #[test]
    fn unsupported_and_internal_display() {
        extern crate std;
        use std::string::ToString;
        assert!(UNINIT_VIEW
            .to_string()
            .starts_with("not supported: uninitialised output"));
        let e = Error::Internal { what: "x" };
        assert_eq!(
            e.to_string(),
            "internal check failed (a bug in relief-core): x"
        );
    }
}
