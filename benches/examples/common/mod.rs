//! Shared by the refinement examples (`refine_scale`, `refine_mapped`, `refine_pages`,
//! `refine_probe`) and the yardsticks (`vd_lean`, `mip_lean`, `mip_quad`, `mip_sixteen`): the bundled DEM, the benchmark
//! camera, the upsampled test grids and the warm / cold frame timing.
// Each example uses part of this module.
#![allow(dead_code)]

use relief_core::refine::{
    hierarchy_len, pack_records, preprocess, records_len, scratch_len, Criterion, Hierarchy,
    RecordLayout, Refiner, VertexRecord,
};
use relief_core::{Heightfield, Terrain};
use std::hint::black_box;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Writes the bilinear upsampling of `src` by `f` (`(n - 1) f + 1` samples a side) to `out` as
/// raw little-endian f32.
pub fn upsample(src: &Heightfield<'_, f32>, f: u32, out: &Path) {
    let n0 = src.width();
    let n = (n0 - 1) * f + 1;
    let mut w = std::io::BufWriter::with_capacity(1 << 20, std::fs::File::create(out).unwrap());
    let mut row = vec![0.0f32; n as usize];
    let mut bytes = Vec::with_capacity(4 * n as usize);
    for y in 0..n {
        let (y0, fy) = (y / f, (y % f) as f32 / f as f32);
        let y1 = (y0 + 1).min(n0 - 1);
        for (x, o) in row.iter_mut().enumerate() {
            let x = x as u32;
            let (x0, fx) = (x / f, (x % f) as f32 / f as f32);
            let x1 = (x0 + 1).min(n0 - 1);
            let a = src.local_z(x0, y0) * (1.0 - fx) + src.local_z(x1, y0) * fx;
            let b = src.local_z(x0, y1) * (1.0 - fx) + src.local_z(x1, y1) * fx;
            *o = a * (1.0 - fy) + b * fy;
        }
        bytes.clear();
        for v in &row {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        w.write_all(&bytes).unwrap();
    }
    w.flush().unwrap();
}

/// Triangles, fastest ms of `runs` back-to-back refinements (warm caches), and median ms of
/// `runs` refinements each after writing a 256 MiB buffer (cold caches: a frame after other
/// work, or out-of-core).
pub fn time<T: Terrain>(
    h: &Hierarchy<'_>,
    t: &T,
    c: Criterion,
    runs: usize,
    huge: bool,
) -> (usize, f64, f64) {
    let (w, hh) = (t.width(), t.height());
    let r = Refiner::new(h, t, c).unwrap();
    let mut scratch = Scratch::new(scratch_len(w, hh), huge);
    let scratch = scratch.as_mut_slice();
    let cnt = r.count(scratch).unwrap();
    let mut verts = vec![[0.0f32; 3]; cnt.vertices];
    let mut tris = vec![[0u32; 3]; cnt.triangles];
    let mut evict = vec![0u64; 32 << 20];
    let mut warm = f64::INFINITY;
    let mut cold: Vec<f64> = Vec::with_capacity(runs);
    for k in 0..2 * runs {
        if k % 2 == 1 {
            for (i, x) in evict.iter_mut().enumerate() {
                *x = x.wrapping_add(i as u64);
            }
            black_box(&evict);
        }
        let s = Instant::now();
        black_box(r.triangles(scratch, &mut verts, &mut tris).unwrap());
        let ms = s.elapsed().as_secs_f64() * 1e3;
        if k % 2 == 1 {
            cold.push(ms);
        } else {
            warm = warm.min(ms);
        }
    }
    cold.sort_by(f64::total_cmp);
    (cnt.triangles, warm, cold[runs / 2])
}

/// A zeroed buffer of `Pod` values: a plain `Vec`, or anonymous memory with transparent huge
/// pages requested (`relief_io::HugeBuffer`).
pub enum Buffer<T: bytemuck::Pod> {
    /// `MADV_HUGEPAGE` memory.
    Huge(relief_io::HugeBuffer<T>),
    /// A plain `Vec` (4 KiB pages under THP mode `madvise`).
    Small(Vec<T>),
}

/// The refinement scratch. The bitmap and rank prefix are indexed row-major, so on a 16385^2
/// grid (2 x 32 MiB) the few thousand vertices of a frame fall on as many different 4 KiB
/// pages; with 2 MiB pages the whole scratch is 33 TLB entries.
pub type Scratch = Buffer<u64>;

impl<T: bytemuck::Pod> Buffer<T> {
    /// `len` zeroed values, in huge pages if `huge`.
    pub fn new(len: usize, huge: bool) -> Buffer<T> {
        if huge {
            Buffer::Huge(relief_io::HugeBuffer::zeroed(len).unwrap())
        } else {
            Buffer::Small(vec![T::zeroed(); len])
        }
    }

    /// The values.
    pub fn as_slice(&self) -> &[T] {
        match self {
            Buffer::Huge(b) => b.as_slice(),
            Buffer::Small(v) => v,
        }
    }

    /// The values, mutable.
    pub fn as_mut_slice(&mut self) -> &mut [T] {
        match self {
            Buffer::Huge(b) => b.as_mut_slice(),
            Buffer::Small(v) => v,
        }
    }
}

/// What both examples read from the environment and the command line.
pub struct Args {
    /// `RUNS` (default 15): frames per measurement.
    pub runs: usize,
    /// `SCALE_DIR` (default /tmp): where the upsampled grids go.
    pub dir: PathBuf,
    /// The upsampling factors given (default 1 4 16).
    pub factors: Vec<u32>,
    /// The bundled Puget Sound DEM.
    pub dem: relief_io::Dem,
}

impl Args {
    /// Reads them.
    pub fn get() -> Args {
        let runs = std::env::var("RUNS")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(15);
        let dir = PathBuf::from(std::env::var("SCALE_DIR").unwrap_or_else(|_| "/tmp".into()));
        let mut factors: Vec<u32> = std::env::args()
            .skip(1)
            .map(|a| a.parse().expect("factor"))
            .collect();
        if factors.is_empty() {
            factors = vec![1, 4, 16];
        }
        let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/puget_sound_1k.png");
        let dem = relief_io::read_dem(&p, &Default::default()).expect("bundled DEM");
        Args {
            runs,
            dir,
            factors,
            dem,
        }
    }
}

/// The Puget Sound grid upsampled by `f` as memory-mapped files under `dir`:
/// `relief_scale_<n>.f32` (the samples, spacing `160 / f` m, z scale 0.1) and
/// `relief_scale_<n>.rec` (its interleaved records, `relief_io::write_records`), each written
/// first where missing (16385^2: minutes of preprocessing, once).
pub fn mapped_grid(
    base: &Heightfield<'_, f32>,
    f: u32,
    dir: &Path,
) -> (u32, relief_io::MappedGrid, relief_io::MappedRecords) {
    let n = (base.width() - 1) * f + 1;
    let grid_path = dir.join(format!("relief_scale_{n}.f32"));
    let rec_path = dir.join(format!("relief_scale_{n}.rec"));
    let s = 160.0 / f as f32;
    let open_grid = || {
        let mut g = relief_io::MappedGrid::open(&grid_path, n, n).unwrap();
        g.scale = g.scale.with_spacing(s, s).with_z_scale(0.1);
        g.advise_random();
        g
    };
    if !grid_path.exists() {
        upsample(base, f, &grid_path);
    }
    if !rec_path.exists() {
        let g = open_grid();
        let hf = g.heightfield().unwrap();
        let t0 = Instant::now();
        let len = hierarchy_len(n, n);
        let (mut e, mut r) = (vec![0.0f32; len], vec![0.0f32; len]);
        let full = preprocess(&hf, &mut e, &mut r).unwrap();
        let mut ri = vec![VertexRecord::default(); records_len(n, n, RecordLayout::Interleaved)];
        let il = pack_records(&full, &hf, RecordLayout::Interleaved, &mut ri).unwrap();
        relief_io::write_records(&rec_path, &il).unwrap();
        eprintln!(
            "{n}^2: preprocessed and wrote {} in {:.1} s",
            rec_path.display(),
            t0.elapsed().as_secs_f64()
        );
    }
    let t0 = Instant::now();
    let m = relief_io::MappedRecords::open(&rec_path).unwrap();
    m.advise_random();
    eprintln!(
        "{n}^2: records mapped in {:.3} ms",
        t0.elapsed().as_secs_f64() * 1e3
    );
    (n, open_grid(), m)
}

/// The `RUNS` environment variable (how many timed repetitions), `default` when unset or not
/// a number.
pub fn runs(default: usize) -> usize {
    std::env::var("RUNS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}

/// The bundled Puget Sound DEM (1025^2) at the benchmarks' scale: 160 m spacing, heights in
/// metres (`z_scale` 0.1).
pub fn puget() -> relief_io::Dem {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/puget_sound_1k.png");
    let mut dem = relief_io::read_dem(&p, &Default::default()).expect("bundled DEM");
    dem.scale = dem.scale.with_spacing(160.0, 160.0).with_z_scale(0.1);
    dem
}

/// Every sample's local height, row-major.
pub fn local_heights<T: Terrain>(t: &T) -> Vec<f32> {
    (0..t.height())
        .flat_map(|y| (0..t.width()).map(move |x| (x, y)))
        .map(|(x, y)| t.local_z(x, y))
        .collect()
}

/// What the lean yardsticks (`vd_lean`, `vd_bfs`) read, row-major: the full hierarchy's own
/// errors and radii copied out (0 at the grid's corners, which have none: they are never split
/// vertices, and the walks never read them), every sample's local height, and `cam`'s frustum
/// planes (near 0.1, far 1e5) against local heights.
pub struct LeanInputs {
    /// Nested error per sample.
    pub err: Vec<f32>,
    /// Nested bounding-sphere radius per sample.
    pub rad: Vec<f32>,
    /// Local height per sample.
    pub z: Vec<f32>,
    /// Frustum planes `[a, b, c, d]`: `a x + b y + c z_local + d >= 0` inside.
    pub planes: [[f32; 4]; 6],
}

/// The scalar type of a lean decision: `f32` (the yardsticks' own) or `f64` (as the library
/// decides).
pub trait Real:
    Copy
    + PartialOrd
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<Output = Self>
    + From<f32>
{
    /// `x` exactly (grid coordinates below `2^24`).
    fn of_u32(x: u32) -> Self;
}

impl Real for f32 {
    fn of_u32(x: u32) -> f32 {
        x as f32
    }
}

impl Real for f64 {
    fn of_u32(x: u32) -> f64 {
        f64::from(x)
    }
}

/// A lean decision's per-frame constants in one precision: spacing `sx`, `sy`, the eye in local
/// heights, `k = kappa / tau` and the frustum planes of [`LeanInputs`].
pub struct Consts<R> {
    /// Spacing in x.
    pub sx: R,
    /// Spacing in y.
    pub sy: R,
    /// Eye, local heights.
    pub eye: [R; 3],
    /// `kappa / tau`.
    pub k: R,
    /// Frustum planes.
    pub planes: [[R; 4]; 6],
}

impl<R: Real> Consts<R> {
    /// The decision for the split vertex at `(x, y)` with error `e`, radius `r` and local
    /// height `z` (SOAR's sphere test; frustum culling with the active-plane mask `planes`
    /// unless `lazy`): `None` if its sphere is outside an active plane (culled), else whether
    /// it splits and the planes still active.
    #[inline(always)]
    pub fn decide(
        &self,
        (x, y, lazy): (u32, u32, bool),
        (e, r, z): (f32, f32, f32),
        planes: u32,
    ) -> Option<(bool, u32)> {
        let zero = R::from(0.0);
        let (px, py, pz) = (R::of_u32(x) * self.sx, R::of_u32(y) * self.sy, R::from(z));
        let (e, r) = (R::from(e), R::from(r));
        let mut planes = planes;
        if planes != 0 && !lazy {
            let mut rest = planes;
            while rest != 0 {
                let i = rest.trailing_zeros() as usize;
                rest &= rest - 1;
                let q = self.planes[i];
                let c = q[0] * px + q[1] * py + q[2] * pz + q[3];
                if c + r < zero {
                    return None;
                }
                if c - r > zero {
                    planes &= !(1 << i);
                }
            }
        }
        let (dx, dy, dz) = (self.eye[0] - px, self.eye[1] - py, self.eye[2] - pz);
        let reach = e * self.k + r;
        Some((
            e > zero && reach * reach > dx * dx + dy * dy + dz * dz,
            planes,
        ))
    }
}

/// A lean yardstick's frame (`vd_lean`, `vd_bfs`): a square `2^k + 1` grid of width `w` with
/// `levels` levels, culling above `lazy_from`, and the decision's constants in `f32` and in
/// `f64`.
pub struct LeanView {
    /// Grid width.
    pub w: u32,
    /// Levels of the hierarchy.
    pub levels: u32,
    /// First level without culling (lazy culling).
    pub lazy_from: u32,
    /// The constants in `f32`.
    pub f32s: Consts<f32>,
    /// The same in `f64`, converted once per frame as the library converts them.
    pub f64s: Consts<f64>,
}

impl LeanView {
    /// The frame of `cam` at `tau` pixels over `dem` (square `2^k + 1`), lazy below the last 4
    /// levels.
    pub fn new(
        dem: &relief_io::Dem,
        cam: &relief_core::Camera,
        tau: f32,
        planes: [[f32; 4]; 6],
    ) -> LeanView {
        let levels = 2 * (dem.width - 1).trailing_zeros();
        let (sx, sy, off) = (dem.scale.dx, dem.scale.dy, dem.scale.z_offset);
        LeanView {
            w: dem.width,
            levels,
            lazy_from: levels - 4,
            f32s: Consts {
                sx,
                sy,
                eye: [cam.eye.x, cam.eye.y, cam.eye.z - off],
                k: cam.kappa() / tau,
                planes,
            },
            f64s: Consts {
                sx: f64::from(sx),
                sy: f64::from(sy),
                eye: [
                    f64::from(cam.eye.x),
                    f64::from(cam.eye.y),
                    f64::from(cam.eye.z) - f64::from(off),
                ],
                k: f64::from(cam.kappa()) / f64::from(tau),
                planes: planes.map(|q| q.map(f64::from)),
            },
        }
    }

    /// [`Consts::decide`] with the constants `c` (`self.f32s`, or `self.f64s` as the library
    /// decides) for the split vertex at `(x, y)` on `level`.
    #[inline(always)]
    pub fn decide<R: Real>(
        &self,
        c: &Consts<R>,
        (x, y, level): (u32, u32, u32),
        erz: (f32, f32, f32),
        planes: u32,
    ) -> Option<(bool, u32)> {
        c.decide((x, y, level >= self.lazy_from), erz, planes)
    }
}

/// [`LeanInputs`] of `full` (the full layout of `t`, a terrain with scale `scale`) for `cam`.
pub fn lean_inputs<T: Terrain>(
    t: &T,
    full: &relief_core::refine::Hierarchy<'_>,
    cam: &relief_core::Camera,
) -> LeanInputs {
    let (w, h) = (t.width(), t.height());
    let grid = || (0..h).flat_map(|y| (0..w).map(move |x| (x, y)));
    let err = grid()
        .map(|(x, y)| full.error(x, y).unwrap_or(0.0))
        .collect();
    let rad = grid()
        .map(|(x, y)| full.radius(x, y).unwrap_or(0.0))
        .collect();
    let planes4 = cam.frustum_planes(0.1, 0.1 * 1e6).unwrap();
    let mut planes = [[0.0f32; 4]; 6];
    let off = t.scale().z_offset;
    for (o, p) in planes.iter_mut().zip(planes4.iter()) {
        *o = [p.x, p.y, p.z, p.w + p.z * off];
    }
    LeanInputs {
        err,
        rad,
        z: local_heights(t),
        planes,
    }
}

/// The eye's x of the benchmark view (metres).
pub const BENCH_EYE_X: f32 = 112_000.0;

/// The benchmark view over the Puget Sound map: 3 km above `(eye_x, 82 km)`, looking 30 km
/// along -x down to the ground, 1280 x 720, 60 degrees (`BENCH_EYE_X` is the middle of the map).
pub fn camera(eye_x: f32) -> relief_core::Camera {
    relief_core::Camera::new(
        relief_core::glam::Vec3::new(eye_x, 82_000.0, 3_000.0),
        relief_core::glam::Vec3::new(eye_x - 30_000.0, 82_000.0, 0.0),
        60.0,
        1280,
        720,
    )
    .unwrap()
}

/// The camera and grazing views of `bench-peers/embree_rays.sh` on Puget, 384 x 256 rays each:
/// `(name, rays)`, each ray as the library's [`relief_core::ray::Ray`] and as `f32` origin and
/// direction in grid-local units (x and y in cells, z less the offset), as the ray yardsticks
/// (`mip_lean`, `mip_quad`) trace them.
pub fn embree_views(dem: &relief_io::Dem) -> Vec<(&'static str, Vec<MipRay>)> {
    use relief_core::glam::Vec3;
    let views = [
        (
            "camera",
            Vec3::new(19660.8, 14745.6, 12571.8),
            Vec3::new(90112.0, 98304.0, 0.0),
            60.0,
        ),
        (
            "grazing",
            Vec3::new(1638.4, 3276.8, 4412.568),
            Vec3::new(163840.0, 152371.2, 4363.4165),
            30.0,
        ),
    ];
    views
        .into_iter()
        .map(|(name, eye, target, fov)| (name, view_rays(dem, eye, target, fov)))
        .collect()
}

/// `bench-peers/embree_trace.py`'s `low` view on `dem` (low flight: the eye 0.2% of the map's
/// size above the highest sample within 1% of the map around the point a quarter of the way
/// in, looking level towards `(0.95, 0.85)` of the map, fov 60), 384 x 256 rays.
pub fn low_view(dem: &relief_io::Dem) -> (&'static str, Vec<MipRay>) {
    use relief_core::glam::Vec3;
    let (gw, gh) = (dem.width as usize, dem.height as usize);
    let s = dem.scale;
    let (ex, ey) = ((gw - 1) as f32 * s.dx, (gh - 1) as f32 * s.dy);
    let (cx, cy) = (
        (0.25 * (gw - 1) as f64) as usize,
        (0.25 * (gh - 1) as f64) as usize,
    );
    let (rx, ry) = ((gw / 100).max(1), (gh / 100).max(1));
    let mut near = f32::NEG_INFINITY;
    for y in cy.saturating_sub(ry)..(cy + ry + 1).min(gh) {
        for x in cx.saturating_sub(rx)..(cx + rx + 1).min(gw) {
            near = near.max(dem.samples[y * gw + x] * s.z_scale + s.z_offset);
        }
    }
    let ez = near + 0.002 * ex.max(ey);
    let eye = Vec3::new(cx as f32 * s.dx, cy as f32 * s.dy, ez);
    let target = Vec3::new(0.95 * ex, 0.85 * ey, ez);
    ("low", view_rays(dem, eye, target, 60.0))
}

/// The 384 x 256 rays of a camera at `eye` looking at `target` with vertical field of view
/// `fov` degrees, row by row, as [`MipRay`]s.
fn view_rays(
    dem: &relief_io::Dem,
    eye: relief_core::glam::Vec3,
    target: relief_core::glam::Vec3,
    fov: f32,
) -> Vec<MipRay> {
    let s = dem.scale;
    let cam = relief_core::Camera::new(eye, target, fov, 384, 256).unwrap();
    (0..256)
        .flat_map(|j| (0..384).map(move |i| (i, j)))
        .map(|(i, j)| {
            let (o, d) = cam.ray(i, j);
            MipRay {
                ray: relief_core::ray::Ray::new(o, d).unwrap(),
                o: [o.x / s.dx, o.y / s.dy, o.z - s.z_offset],
                d: [d.x / s.dx, d.y / s.dy, d.z],
            }
        })
        .collect()
}

/// A ray of [`embree_views`].
pub struct MipRay {
    /// The library's ray (world units).
    pub ray: relief_core::ray::Ray,
    /// Origin in grid-local units.
    pub o: [f32; 3],
    /// Direction in grid-local units (the same `t` as the world ray).
    pub d: [f32; 3],
}

/// `(agree, both miss, differ)`: hits within `1e-4` relative distance of each other (the
/// Embree comparison's tolerance), rays both miss, and the rest.
pub fn agreement(pairs: impl Iterator<Item = (Option<f64>, Option<f64>)>) -> (usize, usize, usize) {
    let (mut agree, mut both_miss, mut differ) = (0, 0, 0);
    for p in pairs {
        match p {
            (None, None) => both_miss += 1,
            (Some(x), Some(y)) if (x - y).abs() <= 1e-4 * x.abs().max(1.0) => agree += 1,
            _ => differ += 1,
        }
    }
    (agree, both_miss, differ)
}

/// The lowest and highest of `z`.
pub fn z_range(z: &[f32]) -> (f32, f32) {
    z.iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        })
}

/// Grid-local heights as the ray yardsticks read them: `w` samples a row, `cw x ch` cells,
/// heights in `[zlo, zhi]`.
pub struct LocalGrid {
    /// Local heights, row-major.
    pub z: Vec<f32>,
    /// Samples a row.
    pub w: usize,
    /// Rows.
    pub h: usize,
    /// Cells along x.
    pub cw: f32,
    /// Cells along y.
    pub ch: f32,
    /// Lowest height.
    pub zlo: f32,
    /// Highest height.
    pub zhi: f32,
}

impl LocalGrid {
    /// The local heights of `t` and its size and height range.
    pub fn of<T: Terrain>(t: &T) -> LocalGrid {
        let z = local_heights(t);
        let (zlo, zhi) = z_range(&z);
        let (w, h) = (t.width(), t.height());
        LocalGrid {
            z,
            w: w as usize,
            h: h as usize,
            cw: (w - 1) as f32,
            ch: (h - 1) as f32,
            zlo,
            zhi,
        }
    }

    /// The highest of cell `(x, y)`'s four corners (the finest level of a maximum mipmap).
    pub fn cell_max(&self, x: usize, y: usize) -> f32 {
        let (z, w) = (&self.z, self.w);
        let c = [
            z[y * w + x],
            z[y * w + x + 1],
            z[(y + 1) * w + x],
            z[(y + 1) * w + x + 1],
        ];
        c[0].max(c[1]).max(c[2]).max(c[3])
    }

    /// The parameter interval `(t0, t1)` of local ray `o + t d` (with `inv` its inverse x and y
    /// components) inside the grid's box, `None` when it misses it.
    pub fn clip(&self, o: [f32; 3], d: [f32; 3], inv: [f32; 2]) -> Option<(f32, f32)> {
        let (mut t0, mut t1) = (0.0f32, f32::INFINITY);
        for (k, hi) in [(0, self.cw), (1, self.ch)] {
            if d[k] == 0.0 {
                if !(o[k] >= 0.0 && o[k] <= hi) {
                    return None;
                }
            } else {
                let (a, b) = ((0.0 - o[k]) * inv[k], (hi - o[k]) * inv[k]);
                t0 = t0.max(a.min(b));
                t1 = t1.min(a.max(b));
            }
        }
        if d[2] < 0.0 {
            t0 = t0.max((self.zhi - o[2]) / d[2]);
            t1 = t1.min((self.zlo - 1.0 - o[2]) / d[2]);
        } else if d[2] > 0.0 {
            t1 = t1.min((self.zhi - o[2]) / d[2]);
        } else if o[2] > self.zhi {
            return None;
        }
        if t0.is_nan() || t1.is_nan() || t0 > t1 {
            return None;
        }
        Some((t0, t1))
    }

    /// The ray yardsticks' cell test: the two triangles of cell `(x, y)` against the local ray
    /// `o + t d` in `f64` (Moller-Trumbore), the nearest hit with `t` in `[ta, tb]` widened by
    /// `1e-4` relative.
    pub fn cell(
        &self,
        o: [f32; 3],
        d: [f32; 3],
        x: usize,
        y: usize,
        ta: f32,
        tb: f32,
    ) -> Option<f64> {
        use relief_core::glam::DVec3;
        let (z, w) = (&self.z, self.w);
        let p = |x: usize, y: usize| DVec3::new(x as f64, y as f64, z[y * w + x] as f64);
        let (a, b, c, e) = (p(x, y), p(x + 1, y), p(x + 1, y + 1), p(x, y + 1));
        let (o, d) = (
            DVec3::new(o[0] as f64, o[1] as f64, o[2] as f64),
            DVec3::new(d[0] as f64, d[1] as f64, d[2] as f64),
        );
        let mut best: Option<f64> = None;
        for (v0, v1, v2) in [(a, b, c), (a, c, e)] {
            let (e1, e2) = (v1 - v0, v2 - v0);
            let pv = d.cross(e2);
            let det = e1.dot(pv);
            if det.abs() < 1e-30 {
                continue;
            }
            let tv = o - v0;
            let u = tv.dot(pv) / det;
            let q = tv.cross(e1);
            let v = d.dot(q) / det;
            let t = e2.dot(q) / det;
            let eps = 1e-9;
            if u >= -eps && v >= -eps && u + v <= 1.0 + eps {
                let slack = 1e-4 * (tb as f64).abs().max(1.0);
                if t >= ta as f64 - slack && t <= tb as f64 + slack && best.is_none_or(|b| t < b) {
                    best = Some(t);
                }
            }
        }
        best
    }
}

/// Interleaves the bits of `v` (up to 16) with zeros.
fn spread(v: u32) -> u32 {
    let mut x = v & 0xffff;
    x = (x | (x << 8)) & 0x00ff_00ff;
    x = (x | (x << 4)) & 0x0f0f_0f0f;
    x = (x | (x << 2)) & 0x3333_3333;
    (x | (x << 1)) & 0x5555_5555
}

/// The maxima of `g`'s cells over the `2^n x 2^n` square from the origin in Morton order
/// (cells outside the grid `-inf`), then each coarser level as the maxima of `group`
/// consecutive entries (4: every level of a quadtree; 16: every other level), up to one node;
/// `levels[0]` holds the cells (the ray yardsticks `mip_quad` and `mip_sixteen`).
pub fn morton_levels(g: &LocalGrid, n: u32, group: usize) -> Vec<Vec<f32>> {
    let (cw, ch) = (g.w - 1, g.h - 1);
    let side = 1usize << n;
    let mut l0 = vec![f32::NEG_INFINITY; side * side];
    for y in 0..ch {
        for x in 0..cw {
            l0[(spread(x as u32) | spread(y as u32) << 1) as usize] = g.cell_max(x, y);
        }
    }
    let mut levels = vec![l0];
    while levels.last().is_some_and(|l| l.len() > 1) {
        let c = levels.last().unwrap();
        let p = c
            .chunks_exact(group)
            .map(|q| q.iter().fold(f32::NEG_INFINITY, |a, &b| a.max(b)))
            .collect();
        levels.push(p);
    }
    levels
}

/// `1 / v`, or `+-1e20` for a component too small to invert, so that the ray yardsticks' node
/// slabs stay finite (`mip_quad`, `mip_sixteen`).
pub fn finite_inverse(v: f32) -> f32 {
    if v.abs() > 1e-20 {
        1.0 / v
    } else {
        1e20f32.copysign(v)
    }
}

/// A ray yardstick: the hit parameter of a grid-local ray ([`MipRay`]), or `None`.
pub trait LocalTracer {
    /// Traces local origin `o` along `d`.
    fn trace(&self, o: [f32; 3], d: [f32; 3]) -> Option<f64>;
}

/// Runs a ray yardstick (`mip_lean`, `mip_quad`) against the library's `trace_maxmip` on the
/// bundled Puget grid's [`embree_views`]: the hits compared ([`agreement`]), then both timed in
/// whole passes (fastest of `RUNS`, default 9, interleaved pass by pass) and in the Embree
/// script's chunks (`relief trace --chunk-rays 4096 --chunk-reps 9`: each chunk of 4096
/// consecutive rays traced 9 times, the fastest summed). `make` builds the yardstick from the
/// grid; one line per view, `label` naming the yardstick. Returns the yardstick.
pub fn mip_yardstick<Y: LocalTracer>(label: &str, make: impl FnOnce(LocalGrid) -> Y) -> Y {
    use relief_core::ray::{MaxMip, RayTracer};
    let runs = runs(9);
    let dem = puget();
    let (w, h) = (dem.width, dem.height);
    let hf = Heightfield::with_scale(&dem.samples, w, h, dem.scale).unwrap();
    let y = make(LocalGrid::of(&hf));
    let mut buf = vec![0.0f32; MaxMip::len(w, h).unwrap()];
    let mip = MaxMip::build(&hf, &mut buf).unwrap();
    let tracer = RayTracer::new(&hf, relief_core::Surface::Triangles);
    let library = |r: &MipRay| tracer.trace_maxmip(&r.ray, &mip).ok();
    for (name, rays) in embree_views(&dem) {
        let (agree, both_miss, differ) = agreement(
            rays.iter()
                .map(|r| (library(r).unwrap().hit.map(|h| h.t), y.trace(r.o, r.d))),
        );
        // Fastest of `reps` passes over `rays` of the yardstick and of `other`, interleaved.
        let time = |rays: &[MipRay], reps: usize, other: &dyn Fn(&MipRay) -> bool| {
            let (mut best_y, mut best_l) = (f64::INFINITY, f64::INFINITY);
            for _ in 0..reps {
                let s = Instant::now();
                for r in rays {
                    black_box(y.trace(r.o, r.d));
                }
                best_y = best_y.min(s.elapsed().as_secs_f64());
                let s = Instant::now();
                for r in rays {
                    black_box(other(r));
                }
                best_l = best_l.min(s.elapsed().as_secs_f64());
            }
            (best_y, best_l)
        };
        let chunked = |other: &dyn Fn(&MipRay) -> bool| {
            rays.chunks(4096)
                .map(|c| time(c, 9, other))
                .fold((0.0, 0.0), |(a, b), (y, l)| (a + y, b + l))
        };
        let neighbour = |r: &MipRay| black_box(library(r)).is_some();
        let (pass_y, pass_l) = time(&rays, runs, &neighbour);
        let (chunk_y, chunk_l) = chunked(&neighbour);
        let m = rays.len() as f64 / 1e6;
        println!(
            "{name:8} hits agree {agree} (both miss {both_miss}), differ {differ} | M rays/s, whole passes: {label} {:.2}, trace_maxmip {:.2} ({:.2}x) | chunked: {label} {:.2}, trace_maxmip {:.2} ({:.2}x)",
            m / pass_y,
            m / pass_l,
            pass_l / pass_y,
            m / chunk_y,
            m / chunk_l,
            chunk_l / chunk_y
        );
        // The library's sixteen-wide walk (AVX-512F), chunked the same way, interleaved with
        // the yardstick chunk by chunk.
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f") {
            let wide = |r: &MipRay| {
                // SAFETY: the CPU has AVX-512F.
                black_box(unsafe { tracer.trace_maxmip_wide_avx512(&r.ray, &mip) }).is_ok()
            };
            let (chunk_y, chunk_w) = chunked(&wide);
            println!(
                "{name:8} chunked: {label} {:.2}, trace_maxmip_wide_avx512 {:.2} M rays/s ({:.2}x)",
                m / chunk_y,
                m / chunk_w,
                chunk_w / chunk_y
            );
        }
    }
    y
}

/// Child `c` (Morton order within a 4 x 4 block): its column and row (the ray yardsticks
/// `mip_sixteen` and `mip_packet`).
pub const CX: [f32; 16] = [
    0., 1., 0., 1., 2., 3., 2., 3., 0., 1., 0., 1., 2., 3., 2., 3.,
];
pub const CY: [f32; 16] = [
    0., 0., 1., 1., 0., 0., 1., 1., 2., 2., 3., 3., 2., 2., 3., 3.,
];

/// The children of a block in the order a ray of one direction octant crosses them: by
/// anti-diagonal from the block's entry corner (a ray's path through a 4 x 4 block is a
/// monotone staircase, one child per anti-diagonal, so this is the ray's order up to the
/// margin's ties). Lane `j` holds child `morton[j]` at column `cx[j]`, row `cy[j]`.
pub struct Order {
    /// The Morton index of the child in lane `j`.
    pub morton: [usize; 16],
    /// Column of the child in lane `j`.
    pub cx: [f32; 16],
    /// Row of the child in lane `j`.
    pub cy: [f32; 16],
    /// `cx` and `cy` as integers.
    pub ix: [u32; 16],
    /// See `ix`.
    pub iy: [u32; 16],
}

impl Order {
    /// The order for a ray whose x (`fx`) and y (`fy`) directions are negative or not.
    pub fn new(fx: bool, fy: bool) -> Order {
        let mut k: Vec<usize> = (0..16).collect();
        let key = |c: usize| {
            let (x, y) = (CX[c] as usize, CY[c] as usize);
            let x = if fx { 3 - x } else { x };
            let y = if fy { 3 - y } else { y };
            (x + y, c)
        };
        k.sort_by_key(|&c| key(c));
        let morton: [usize; 16] = std::array::from_fn(|j| k[j]);
        Order {
            morton,
            cx: std::array::from_fn(|j| CX[morton[j]]),
            cy: std::array::from_fn(|j| CY[morton[j]]),
            ix: std::array::from_fn(|j| CX[morton[j]] as u32),
            iy: std::array::from_fn(|j| CY[morton[j]] as u32),
        }
    }
}

/// A local ray in `f64`, with the inverses of its x and y components (infinite for zero).
#[derive(Clone, Copy)]
pub struct Ray64 {
    /// Origin.
    pub o: [f64; 3],
    /// Direction.
    pub d: [f64; 3],
    /// `1 / d` for x and y.
    pub inv: [f64; 2],
}

impl Ray64 {
    /// The `f64` ray of `f32` origin `o` and direction `d`.
    pub fn new(o: [f32; 3], d: [f32; 3]) -> Ray64 {
        let o = o.map(f64::from);
        let d = d.map(f64::from);
        Ray64 {
            o,
            d,
            inv: [1.0 / d[0], 1.0 / d[1]],
        }
    }
}

impl LocalGrid {
    /// The first hit of `r` with the two triangles of cell `(x, y)` (split along the diagonal
    /// from `(x, y)` to `(x + 1, y + 1)`, as [`LocalGrid::cell`]), with `t` in `[ta, tb]`: the
    /// ray's part inside the cell (slabs in `f64`) cut at the diagonal, each piece against its
    /// triangle's plane, where the height above the plane is linear in `t`; the first piece
    /// whose height changes sign (or starts at or below) holds the hit.
    #[inline(always)]
    pub fn cell_pieces(&self, r: &Ray64, x: usize, y: usize, ta: f32, tb: f32) -> Option<f64> {
        let (z, w) = (&self.z, self.w);
        let z00 = z[y * w + x] as f64;
        let z10 = z[y * w + x + 1] as f64;
        let z01 = z[(y + 1) * w + x] as f64;
        let z11 = z[(y + 1) * w + x + 1] as f64;
        let (xf, yf) = (x as f64, y as f64);
        let slab = |k: usize, lo: f64| {
            if r.d[k] == 0.0 {
                if r.o[k] >= lo && r.o[k] <= lo + 1.0 {
                    (f64::NEG_INFINITY, f64::INFINITY)
                } else {
                    (f64::INFINITY, f64::NEG_INFINITY)
                }
            } else {
                let (a, b) = ((lo - r.o[k]) * r.inv[k], (lo + 1.0 - r.o[k]) * r.inv[k]);
                (a.min(b), a.max(b))
            }
        };
        let (ax, bx) = slab(0, xf);
        let (ay, by) = slab(1, yf);
        let slack = 1e-4 * (tb as f64).abs().max(1.0);
        let t0 = ax.max(ay).max(ta as f64 - slack);
        let t1 = bx.min(by).min(tb as f64 + slack);
        if t0.is_nan() || t1.is_nan() || t0 > t1 {
            return None;
        }
        // u - v along the ray: zero on the diagonal.
        let (ou, ov) = (r.o[0] - xf, r.o[1] - yf);
        let (du, dv) = (r.d[0], r.d[1]);
        let side = |t: f64| (ou + du * t) - (ov + dv * t);
        // Height above the plane of the triangle on side `lower` (u >= v) at `t`.
        let above = |t: f64, lower: bool| {
            let (u, v) = (ou + du * t, ov + dv * t);
            let plane = if lower {
                z00 + (z10 - z00) * u + (z11 - z10) * v
            } else {
                z00 + (z11 - z01) * u + (z01 - z00) * v
            };
            r.o[2] + r.d[2] * t - plane
        };
        let dd = du - dv;
        let mut cuts = [t0, t1, t1];
        let mut pieces = 1;
        if dd != 0.0 {
            let td = -(ou - ov) / dd;
            if td > t0 && td < t1 {
                cuts = [t0, td, t1];
                pieces = 2;
            }
        }
        for p in 0..pieces {
            let (s, e) = (cuts[p], cuts[p + 1]);
            let lower = side(0.5 * (s + e)) >= 0.0;
            let (fs, fe) = (above(s, lower), above(e, lower));
            if fs <= 0.0 {
                return Some(s);
            }
            if fe <= 0.0 {
                return Some(s + (e - s) * (fs / (fs - fe)));
            }
        }
        None
    }
}
