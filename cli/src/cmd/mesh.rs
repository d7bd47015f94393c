//! `relief mesh`: SOAR refinement of a DEM (relief_core::refine) into an OBJ mesh, view-independent
//! (`--max-error E`) or view-dependent (`--eye --target --fov --size --pixel-error`), with the
//! mesh's vertical error measured by a full grid scan.

use crate::args::DemArgs;
use crate::{print_out, CliError, CliResult};
use clap::{Args, ValueEnum};
use relief_core::glam::Vec3;
use relief_core::refine::{
    coverage_len, hierarchy_len, pack_records, preprocess, preprocess_compact, records_len,
    scratch_len, vertical_error_partial, Criterion, FrameCounts, Hierarchy, MeshVertex,
    RecordLayout, Refiner, StripCounts, VertexRecord, View,
};
use relief_core::refine::{strip_fewest_indices, triangle_bound, vertex_bound};
use relief_core::Terrain;
use relief_core::{Camera, Heightfield};
use std::path::PathBuf;
use std::time::Instant;

/// Layout of the preprocessed data.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Layout {
    /// `f32` error and bounding-sphere radius per vertex (8 bytes).
    Full,
    /// bfloat16 error rounded up, radius from the level (2 bytes).
    Compact,
    /// 8-byte records (height, bfloat16 error and radius) in the hierarchical interleaved
    /// layout (level by level, Z-order within a level), packed from the full layout: for
    /// view-dependent refinement of large grids.
    Records,
    /// 8-byte records in row-major order.
    RecordsLinear,
}

/// What the timed extraction writes for each vertex.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum VertexFormat {
    /// World x and y and the height (`[f32; 3]`, 12 bytes).
    Positions,
    /// Grid column and row (`[u16; 2]`, 4 bytes; no height is read): the vertex format of
    /// martini and pymartini, for a vertex shader that reads heights from a texture.
    Grid,
}

/// Meshing method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Method {
    /// SOAR refinement of the regular grid (relief_core::refine).
    Rqt,
    /// Greedy-insertion Delaunay TIN (relief-tin; Garland & Heckbert 1995), view-independent.
    Tin,
}

/// Options of `relief mesh`.
#[derive(Debug, Args)]
pub struct MeshArgs {
    #[command(flatten)]
    dem: DemArgs,
    /// Meshing method: `rqt` (refinement) or `tin` (greedy Delaunay TIN, which takes
    /// --max-error and/or --max-vertices; its whole build is reported in refine_ms).
    #[arg(long, value_enum, default_value = "rqt")]
    method: Method,
    /// TIN only: stop at this many vertices.
    #[arg(long, value_name = "N")]
    max_vertices: Option<u32>,
    /// View-independent: largest vertical error allowed (world z units).
    #[arg(long, value_name = "E", conflicts_with_all = ["eye", "pixel_error"])]
    max_error: Option<f32>,
    /// View-dependent: eye position X,Y,Z in world units.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true, value_parser = crate::args::parse_vec3, requires_all = ["target", "size", "pixel_error"])]
    eye: Option<Vec3>,
    /// View-dependent: point looked at X,Y,Z.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true, value_parser = crate::args::parse_vec3)]
    target: Option<Vec3>,
    /// View-dependent: vertical field of view in degrees.
    #[arg(long, default_value_t = 60.0)]
    fov: f32,
    /// View-dependent: image size WxH in pixels.
    #[arg(long, value_name = "WxH", value_parser = crate::args::parse_size)]
    size: Option<(u32, u32)>,
    /// View-dependent: largest projected error in pixels.
    #[arg(long, value_name = "T")]
    pixel_error: Option<f32>,
    /// View-dependent: do not cull against the view frustum.
    #[arg(long)]
    no_cull: bool,
    /// View-dependent: finest levels accepted without culling (lazy culling, default 4).
    #[arg(long, value_name = "N", default_value_t = 4)]
    lazy_levels: u32,
    /// Preprocessed data layout.
    #[arg(long, value_enum, default_value = "full")]
    layout: Layout,
    /// What the timed extraction writes per vertex (refine_ms and the other refine times):
    /// `grid` times it with grid coordinates, martini's vertex format, then extracts the
    /// frame once more with positions for the OBJ and the error scan, and checks that both
    /// give the same mesh.
    #[arg(long, value_enum, default_value = "positions")]
    vertices: VertexFormat,
    /// With --layout records or records-linear: keep the preprocessed records in PATH
    /// (out-of-core, issue 6). If PATH exists it is memory-mapped instead of preprocessing
    /// (after checking that it belongs to this grid: size, layout, spacing, sampled heights,
    /// and every record's validity); otherwise the grid is preprocessed and PATH written.
    #[arg(long, value_name = "PATH", conflicts_with_all = ["tile_size", "edit"])]
    records_file: Option<PathBuf>,
    /// Output OBJ file (not with --tile-size, which writes into --out-dir).
    #[arg(long, value_name = "PATH", required_unless_present = "tile_size")]
    out: Option<PathBuf>,
    /// Tiles: mesh the DEM in tiles of N = 2^k + 1 samples sharing their borders, each
    /// preprocessed and meshed on its own, crack-free after the border protocol (--max-error or
    /// view-dependent with --eye ...; full or compact layout); writes DIR/tile_<col>_<row>.obj.
    #[arg(long, value_name = "N", requires_all = ["out_dir"], conflicts_with_all = ["edit", "out"])]
    tile_size: Option<u32>,
    /// Tiles: output folder.
    #[arg(long, value_name = "DIR", requires = "tile_size")]
    out_dir: Option<PathBuf>,
    /// Tiles: add skirts DEPTH world z units deep along every tile border (off by default).
    #[arg(long, value_name = "DEPTH", requires = "tile_size")]
    skirt: Option<f32>,
    /// Live edit: lower the samples at distance r < RADIUS from (X, Y) (grid samples) by
    /// DEPTH * (1 - (r / RADIUS)^2) (height units before --z-scale), through the incremental
    /// update of the preprocessed data, before meshing. Repeatable.
    #[arg(long, value_name = "X,Y,RADIUS,DEPTH", allow_hyphen_values = true, value_parser = super::mesh_edit::parse_edit)]
    edit: Vec<[f32; 4]>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
    /// Also preprocess N more times, each into freshly allocated buffers (allocated and freed
    /// inside the timing, as martini's createTile allocates its arrays), and report the fastest
    /// as `preprocess_repeat_ms` (null without this option): the peers' protocol of a best
    /// call in one process, next to `preprocess_ms`, the first call. Not with --records-file.
    #[arg(
        long,
        value_name = "N",
        default_value_t = 0,
        conflicts_with = "records_file"
    )]
    preprocess_repeats: u32,
    /// Detail levels below the base grid (--detail PATH --detail-factor K ...).
    #[command(flatten)]
    detail: super::mesh_detail::DetailArgs,
}

/// The preprocessed data of one layout: errors and radii (full and records layouts) or
/// compact errors, for `n` hierarchy entries; the records are allocated by
/// [`Buffers::preprocess`].
struct Buffers {
    errors_f: Vec<f32>,
    radii: Vec<f32>,
    errors_c: Vec<u16>,
    records: Vec<VertexRecord>,
}

impl Buffers {
    fn new(n: usize, layout: Layout) -> Buffers {
        let full = layout != Layout::Compact;
        Buffers {
            errors_f: vec![0.0f32; if full { n } else { 0 }],
            radii: vec![0.0f32; if full { n } else { 0 }],
            errors_c: vec![0u16; if full { 0 } else { n }],
            records: Vec::new(),
        }
    }

    /// Preprocesses `hf` into these buffers in `layout` (full preprocessing, then packing, for
    /// the records layouts).
    fn preprocess<'b>(
        &'b mut self,
        hf: &Heightfield<'_, f32>,
        layout: Layout,
    ) -> Result<Hierarchy<'b>, CliError> {
        if layout == Layout::Compact {
            return Ok(preprocess_compact(hf, &mut self.errors_c)?);
        }
        let f = preprocess(hf, &mut self.errors_f, &mut self.radii)?;
        Ok(match record_layout(layout) {
            Some(rl) => {
                let (w, h) = (hf.width(), hf.height());
                self.records = vec![VertexRecord::default(); records_len(w, h, rl)];
                pack_records(&f, hf, rl, &mut self.records)?
            }
            None => f,
        })
    }
}

/// The record layout of a records `layout`, `None` for the others.
fn record_layout(layout: Layout) -> Option<RecordLayout> {
    match layout {
        Layout::Records => Some(RecordLayout::Interleaved),
        Layout::RecordsLinear => Some(RecordLayout::Linear),
        _ => None,
    }
}

/// Runs `relief mesh`.
pub fn run(a: &MeshArgs) -> CliResult {
    let plain = a.tile_size.is_none()
        && a.edit.is_empty()
        && a.detail.detail.is_none()
        && a.method == Method::Rqt;
    if a.vertices == VertexFormat::Grid && !plain {
        return Err(CliError(
            "relief mesh --vertices grid times the refinement of one grid only (not with --tile-size, --edit, --detail or --method tin)".into(),
        ));
    }
    if let (Some(size), Some(dir)) = (a.tile_size, &a.out_dir) {
        let (dem, _) = a.dem.load()?;
        let view = match (a.max_error, a.eye, a.target, a.size, a.pixel_error) {
            (Some(_), None, ..) => None,
            (None, Some(eye), Some(target), Some((iw, ih)), Some(tau)) => {
                let cam = Camera::new(eye, target, a.fov, iw, ih)?;
                Some(
                    View::new(&cam, tau)?
                        .with_culling(!a.no_cull)
                        .with_lazy_levels(a.lazy_levels),
                )
            }
            _ => {
                return Err(CliError(
                    "relief mesh --tile-size needs --max-error E, or --eye/--target/--size/--pixel-error".into(),
                ))
            }
        };
        if !matches!(a.layout, Layout::Full | Layout::Compact) {
            return Err(CliError(
                "relief mesh --tile-size supports --layout full or compact".into(),
            ));
        }
        let o = super::mesh_tiles::TileOptions {
            tile_size: size,
            max_error: a.max_error.unwrap_or(0.0),
            view,
            compact: a.layout == Layout::Compact,
            out_dir: dir,
            skirt: a.skirt,
            json: a.json,
        };
        return super::mesh_tiles::run(&dem, &o);
    }
    let a_out = a
        .out
        .as_ref()
        .ok_or_else(|| CliError("relief mesh needs --out PATH".into()))?;
    if !a.edit.is_empty() {
        let e = super::mesh_edit::EditRun {
            dem: &a.dem,
            edits: &a.edit,
            max_error: a.max_error,
            eye: a.eye,
            target: a.target,
            fov: a.fov,
            size: a.size,
            pixel_error: a.pixel_error,
            no_cull: a.no_cull,
            lazy_levels: a.lazy_levels,
            full: a.layout == Layout::Full,
            compact: a.layout == Layout::Compact,
            out: a_out,
            json: a.json,
        };
        return super::mesh_edit::run(&e);
    }
    if a.records_file.is_some()
        && (a.detail.detail.is_some()
            || a.method == Method::Tin
            || !matches!(a.layout, Layout::Records | Layout::RecordsLinear))
    {
        return Err(CliError(
            "relief mesh --records-file needs --layout records or records-linear (and no --detail or --method tin)".into(),
        ));
    }
    if a.detail.detail.is_some() {
        let common = super::mesh_detail::Common {
            dem: &a.dem,
            eye: a.eye,
            target: a.target,
            fov: a.fov,
            size: a.size,
            pixel_error: a.pixel_error,
            no_cull: a.no_cull,
            lazy_levels: a.lazy_levels,
            compact: a.layout == Layout::Compact,
            max_error: a.max_error.is_some(),
            tin: a.method == Method::Tin,
            out: a_out,
            json: a.json,
        };
        return super::mesh_detail::run(&a.detail, common);
    }
    if a.method == Method::Tin {
        if a.eye.is_some() {
            return Err(CliError(
                "relief mesh --method tin is view-independent: give --max-error and/or --max-vertices, not --eye".into(),
            ));
        }
        let (dem, _) = a.dem.load()?;
        return super::mesh_tin::run_tin(&dem, a.max_error, a.max_vertices, a_out, a.json);
    }
    if a.max_vertices.is_some() {
        return Err(CliError("--max-vertices needs --method tin".into()));
    }
    let criterion_kind = match (a.max_error, a.eye) {
        (Some(_), None) => "view-independent",
        (None, Some(_)) => "view-dependent",
        _ => {
            return Err(CliError(
                "relief mesh needs --max-error E, or --eye/--target/--size/--pixel-error".into(),
            ))
        }
    };
    // raw-f32 inputs are memory-mapped, not read (grids larger than memory; issue 6).
    let mapped = a.dem.map_raw_f32()?;
    let dem;
    let hf = match &mapped {
        Some(m) => m.heightfield()?,
        None => {
            dem = a.dem.load()?.0;
            dem.heightfield()?
        }
    };
    let (w, h) = (hf.width(), hf.height());
    let n = hierarchy_len(w, h);
    let mut bufs = Buffers::new(n, a.layout);
    let t0 = Instant::now();
    let mapped_records;
    let mut records_file = None;
    let existing = a.records_file.as_ref().filter(|p| p.exists());
    let hier: Hierarchy<'_> = if let Some(p) = existing {
        mapped_records = relief_io::MappedRecords::open(p)?;
        let hm = mapped_records.hierarchy()?;
        check_records_file(p, &hm, &hf, a.layout)?;
        mapped_records.advise_random();
        records_file = Some("mapped");
        hm
    } else {
        let hier = bufs.preprocess(&hf, a.layout)?;
        if let (Some(p), Some(_)) = (&a.records_file, record_layout(a.layout)) {
            relief_io::write_records(p, &hier)?;
            records_file = Some("written");
        }
        hier
    };
    let preprocess_ms = t0.elapsed().as_secs_f64() * 1e3;
    let mut preprocess_repeat_ms = None::<f64>;
    for _ in 0..a.preprocess_repeats {
        let t = Instant::now();
        let mut fresh = Buffers::new(n, a.layout);
        std::hint::black_box(fresh.preprocess(&hf, a.layout)?);
        drop(fresh); // freed inside the timing, as the first call's buffers are not
        let ms = t.elapsed().as_secs_f64() * 1e3;
        preprocess_repeat_ms = Some(preprocess_repeat_ms.map_or(ms, |b| b.min(ms)));
    }
    let criterion = match (a.max_error, a.eye) {
        (Some(e), _) => Criterion::MaxError(e),
        (None, Some(eye)) => {
            let target = a
                .target
                .ok_or_else(|| CliError("--eye needs --target".into()))?;
            let (iw, ih) = a
                .size
                .ok_or_else(|| CliError("--eye needs --size WxH".into()))?;
            let tau = a
                .pixel_error
                .ok_or_else(|| CliError("--eye needs --pixel-error T".into()))?;
            let cam = Camera::new(eye, target, a.fov, iw, ih)?;
            Criterion::View(
                View::new(&cam, tau)?
                    .with_culling(!a.no_cull)
                    .with_lazy_levels(a.lazy_levels),
            )
        }
        _ => unreachable_criterion()?,
    };
    let refiner = Refiner::new(&hier, &hf, criterion)?;
    let mut scratch = vec![0u64; scratch_len(w, h)];
    let view_independent = criterion_kind == "view-independent";
    let (mut vertices, mut triangles, counts, times) = match a.vertices {
        VertexFormat::Positions => {
            timed_refine::<_, [f32; 3]>(&refiner, &mut scratch, view_independent, w, h)?
        }
        VertexFormat::Grid => {
            // Timed with grid coordinates; the OBJ and the error scan need positions, so the
            // frame is extracted once more (untimed) with them, and the two must agree.
            let (g, gt, gc, times) =
                timed_refine::<_, [u16; 2]>(&refiner, &mut scratch, view_independent, w, h)?;
            let mut v = vec![[0.0f32; 3]; gc.vertices];
            let mut t = vec![[0u32; 3]; gc.triangles];
            let c = extract(&refiner, &mut scratch, &mut v, &mut t)?;
            let s = hf.scale();
            let agree = gc == c
                && gt[..c.triangles] == t[..]
                && g[..c.vertices].iter().zip(&v).all(|(g, p)| {
                    (g[0] as f32 * s.dx).to_bits() == p[0].to_bits()
                        && (g[1] as f32 * s.dy).to_bits() == p[1].to_bits()
                });
            if !agree {
                return Err(CliError(
                    "internal error: grid vertices and positions give different meshes".into(),
                ));
            }
            (v, t, c, times)
        }
    };
    let RefineTimes {
        first: refine_ms,
        reused: refine_reused_ms,
        fresh_repeat: refine_fresh_repeat_ms,
    } = times;
    vertices.truncate(counts.vertices);
    triangles.truncate(counts.triangles);
    let strip = strip_stats(&refiner, w, h, false)?;
    let soar_strip = strip_stats(&refiner, w, h, true)?;
    let mut cov = vec![0u64; coverage_len(w, h)];
    let (max_err, uncovered) = vertical_error_partial(&hf, &vertices, &triangles, &mut cov)?;
    if criterion_kind == "view-independent" && uncovered.is_some() {
        return Err(CliError(format!(
            "internal error: the mesh leaves sample {:?} uncovered",
            uncovered
        )));
    }
    relief_io::write_obj(a_out, &vertices, &triangles)?;
    let uncovered_n = uncovered.map_or(0, |u| u.2);
    if a.json {
        let stats = |(s, fewest): (StripCounts, usize)| {
            serde_json::json!({
                "indices": s.indices,
                "triangles": s.triangles,
                "indices_per_triangle": s.indices_per_triangle(),
                "tested": s.tested,
                "fewest_indices": fewest,
            })
        };
        let strip_json = stats(strip);
        let soar_json = stats(soar_strip);
        let v = serde_json::json!({
            "width": w,
            "height": h,
            "mode": criterion_kind,
            "layout": format!("{:?}", a.layout).to_lowercase(),
            "vertex_format": format!("{:?}", a.vertices).to_lowercase(),
            "bytes_per_vertex": hier.bytes_per_vertex(),
            "vertices": counts.vertices,
            "triangles": counts.triangles,
            "max_error_measured": max_err,
            "uncovered_samples": uncovered_n,
            "preprocess_ms": preprocess_ms,
            "preprocess_repeat_ms": preprocess_repeat_ms,
            "records_file": records_file,
            "refine_ms": refine_ms,
            "refine_reused_ms": refine_reused_ms,
            "refine_fresh_repeat_ms": refine_fresh_repeat_ms,
            "refine_build": Build::detect().name(),
            "strip_length": strip.0.indices,
            "inout_strip": strip_json,
            "soar_strip": soar_json,
            "out": a_out.display().to_string(),
        });
        print_out(&format!("{v}\n"))
    } else {
        let strip_line = format!(
            "{} indices (fewest for its order {}), {} triangles ({:.3} per triangle)",
            strip.0.indices,
            strip.1,
            strip.0.triangles,
            strip.0.indices_per_triangle()
        );
        print_out(&format!(
            "{out}\n  mode        {criterion_kind}\n  size        {w} x {h}\n  vertices    {v}\n  triangles   {t}\n  max error   {max_err:.4} (measured over {cov} samples)\n  preprocess  {preprocess_ms:.1} ms ({layout:?}, {bpv} bytes/vertex{repeat})\n  refine      {refine_ms:.1} ms (fresh buffers; {refine_reused_ms:.1} ms into reused buffers)\n  strip       {strip_line}\n",
            out = a_out.display(),
            v = counts.vertices,
            t = counts.triangles,
            cov = n - uncovered_n,
            layout = a.layout,
            bpv = hier.bytes_per_vertex(),
            repeat = preprocess_repeat_ms.map_or(String::new(), |ms| format!(
                "; fastest of {} more: {ms:.1} ms",
                a.preprocess_repeats
            )),
        ))
    }
}

/// `refine_ms`, `refine_reused_ms` and `refine_fresh_repeat_ms` of one frame.
struct RefineTimes {
    first: f64,
    reused: f64,
    fresh_repeat: f64,
}

/// One frame extracted with vertices of type `P` into fresh buffers (timed: `refine_ms`), then
/// again into the same buffers and into fresh ones (fastest of 3 each); returns the first
/// call's output (buffers possibly longer than the counts) and the times.
#[allow(clippy::type_complexity)]
fn timed_refine<T: Terrain, P: MeshVertex + Default>(
    refiner: &Refiner<'_, '_, T>,
    scratch: &mut [u64],
    view_independent: bool,
    w: u32,
    h: u32,
) -> CliResult<(Vec<P>, Vec<[u32; 3]>, FrameCounts, RefineTimes)> {
    let t1 = Instant::now();
    // Fresh output buffers. View-independent: sized exactly by the extraction's own selection,
    // as martini's getMesh counts before it allocates, and filled uninitialised
    // (`triangles_uninit`: neither zeroed first, which cost 1.2-1.7 ms of the peers' protocol
    // below on Puget at E = 1 and 5 m, nor counted by a separate `count`, a second selection of
    // about 0.3 ms on a 1025^2 grid). View-dependent: bound-sized and zeroed by the allocator
    // (its list renumbers in place, so it reads its output back; counting would be a second
    // traversal), then cut to the counts; only the pages the mesh fills are touched. (Huge
    // pages for these buffers were tried: with the kernel's `defrag = madvise` each 2 MiB fault
    // may compact memory, and the pass took 1-6x longer.)
    type Mesh<P> = (Vec<P>, Vec<[u32; 3]>, FrameCounts);
    let fresh = |scratch: &mut [u64]| -> CliResult<Mesh<P>> {
        if view_independent {
            let (mut v, mut t) = (Vec::new(), Vec::new());
            let c = extract_uninit(refiner, scratch, &mut v, &mut t)?;
            Ok((v, t, c))
        } else {
            let mut v = vec![P::default(); vertex_bound(w, h)];
            let mut t = vec![[0u32; 3]; triangle_bound(w, h)];
            let c = extract(refiner, scratch, &mut v, &mut t)?;
            Ok((v, t, c))
        }
    };
    let (mut vertices, mut triangles, counts) = fresh(scratch)?;
    let first = t1.elapsed().as_secs_f64() * 1e3;
    // A library user refines every frame into the same caller buffers: the same extraction
    // again into the now-resident buffers (fastest of 3), reported next to refine_ms (which
    // pays the first touch of fresh buffers, as a one-shot tool and martini's getMesh do).
    let mut reused = f64::INFINITY;
    for _ in 0..3 {
        let t = Instant::now();
        extract(refiner, scratch, &mut vertices, &mut triangles)?;
        reused = reused.min(t.elapsed().as_secs_f64() * 1e3);
    }
    // The peers' protocol (martini's getMesh and pymartini's get_mesh, best of REPS calls in one
    // process, each allocating its output): fresh buffers on every call, fastest of 3 after the
    // first call above. glibc raises its mmap threshold to the size of a freed mapping (up to
    // 32 MiB), so a later allocation below that size comes from the heap the previous call
    // freed and skips the first-touch page faults that refine_ms pays (an allocation at or
    // above it is mapped afresh: the bound-sized triangle buffer of a 1025^2 grid, 25 MB, was,
    // and paid them on every call).
    let mut fresh_repeat = f64::INFINITY;
    for _ in 0..3 {
        let t = Instant::now();
        let (v, tr, _) = fresh(scratch)?;
        drop((v, tr)); // freed inside the timing, before the next call allocates
        fresh_repeat = fresh_repeat.min(t.elapsed().as_secs_f64() * 1e3);
    }
    let times = RefineTimes {
        first,
        reused,
        fresh_repeat,
    };
    Ok((vertices, triangles, counts, times))
}

/// The build of the extraction this CPU runs, best first: the AVX-512 one (`popcnt`,
/// `avx512f`, `avx512bw`), the `popcnt` one, or the default one.
#[derive(Clone, Copy)]
enum Build {
    #[cfg(target_arch = "x86_64")]
    Avx512,
    #[cfg(target_arch = "x86_64")]
    Popcnt,
    Default,
}

impl Build {
    fn detect() -> Build {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("popcnt") {
            let avx512 = std::is_x86_feature_detected!("avx512f")
                && std::is_x86_feature_detected!("avx512bw");
            return if avx512 { Build::Avx512 } else { Build::Popcnt };
        }
        Build::Default
    }

    /// Its name in the JSON (`refine_build`).
    fn name(self) -> &'static str {
        match self {
            #[cfg(target_arch = "x86_64")]
            Build::Avx512 => "avx512",
            #[cfg(target_arch = "x86_64")]
            Build::Popcnt => "popcnt",
            Build::Default => "default",
        }
    }
}

/// `Refiner::triangles` in the build [`Build::detect`] picks (same output).
fn extract<T: Terrain, P: MeshVertex>(
    r: &Refiner<'_, '_, T>,
    scratch: &mut [u64],
    vertices: &mut [P],
    triangles: &mut [[u32; 3]],
) -> CliResult<FrameCounts> {
    Ok(match Build::detect() {
        // SAFETY: the CPU has popcnt, AVX-512F and AVX-512BW.
        #[cfg(target_arch = "x86_64")]
        Build::Avx512 => unsafe { r.triangles_avx512(scratch, vertices, triangles) }?,
        // SAFETY: the CPU has popcnt.
        #[cfg(target_arch = "x86_64")]
        Build::Popcnt => unsafe { r.triangles_popcnt(scratch, vertices, triangles) }?,
        Build::Default => r.triangles(scratch, vertices, triangles)?,
    })
}

/// The view-independent list into `vertices` and `triangles`, emptied, then grown to exactly the
/// frame's counts by one selection (`triangles_uninit` reserves them for the counts it finds
/// and fills their spare capacity): nothing is zeroed and nothing is counted twice.
fn extract_uninit<T: Terrain, P: MeshVertex>(
    r: &Refiner<'_, '_, T>,
    scratch: &mut [u64],
    vertices: &mut Vec<P>,
    triangles: &mut Vec<[u32; 3]>,
) -> CliResult<FrameCounts> {
    vertices.clear();
    triangles.clear();
    let (v, t) = (&mut *vertices, &mut *triangles);
    let buffers = move |c: FrameCounts| {
        // Moving the borrows into the body makes the closure `FnOnce`, so that the slices it
        // returns may outlive it.
        let (v, t) = (v, t);
        v.reserve_exact(c.vertices);
        t.reserve_exact(c.triangles);
        (v.spare_capacity_mut(), t.spare_capacity_mut())
    };
    let c = match Build::detect() {
        // SAFETY: the CPU has popcnt, AVX-512F and AVX-512BW.
        #[cfg(target_arch = "x86_64")]
        Build::Avx512 => unsafe { r.triangles_uninit_avx512(scratch, buffers) }?,
        // SAFETY: the CPU has popcnt.
        #[cfg(target_arch = "x86_64")]
        Build::Popcnt => unsafe { r.triangles_uninit_popcnt(scratch, buffers) }?,
        Build::Default => r.triangles_uninit(scratch, buffers)?,
    };
    // SAFETY: on `Ok(c)`, `triangles_uninit` has written the first `c.vertices` elements of the
    // vertices' spare capacity and the first `c.triangles` of the triangles' (it checks its
    // counts against its selection and returns an error otherwise), and the capacities hold them
    // (it returns `BufferTooSmall` otherwise). Both vectors were empty, so those are their first
    // elements.
    unsafe {
        vertices.set_len(c.vertices);
        triangles.set_len(c.triangles);
    }
    Ok(c)
}

/// A mapped records file must belong to this grid: its size and layout, its spacing and
/// vertical scale, and the heights of 4096 samples spread over the grid (plus the corners) must
/// match, and every record must be valid (`check_records`, one pass over the file).
fn check_records_file(
    p: &std::path::Path,
    hm: &Hierarchy<'_>,
    hf: &Heightfield<'_, f32>,
    layout: Layout,
) -> CliResult {
    let other = |what: &str| {
        CliError(format!(
            "{}: the records file was made for another grid ({what}); delete it to preprocess again",
            p.display()
        ))
    };
    let (w, h) = (hf.width(), hf.height());
    let g = hm.grid();
    if (g.width(), g.height()) != (w, h) {
        return Err(other(&format!(
            "{}x{} samples, this one is {w}x{h}",
            g.width(),
            g.height()
        )));
    }
    let want = if layout == Layout::Records {
        RecordLayout::Interleaved
    } else {
        RecordLayout::Linear
    };
    if hm.records().map(|r| r.1) != Some(want) {
        return Err(other("another layout"));
    }
    if hm.scale() != hf.scale() {
        return Err(other("another spacing or vertical scale"));
    }
    let pts = (0..4096u64)
        .map(|k| {
            let i = k * (w as u64 * h as u64 - 1) / 4095;
            ((i % w as u64) as u32, (i / w as u64) as u32)
        })
        .chain([(w - 1, 0), (0, h - 1)]);
    for (x, y) in pts {
        if hm.record(x, y).map(|r| r.z) != Some(hf.local_z(x, y)) {
            return Err(other(&format!("height of sample ({x}, {y})")));
        }
    }
    relief_core::refine::check_records(hm)
        .map_err(|e| CliError(format!("{}: invalid records file: {e}", p.display())))
}

fn unreachable_criterion() -> CliResult<Criterion> {
    Err(CliError(
        "relief mesh needs --max-error E, or --eye/--target/--size/--pixel-error".into(),
    ))
}

/// The size of the in/out-edge strip (or SOAR's original strip with `soar`), and the fewest
/// indices any strip of its triangles in its order needs (`strip_fewest_indices`).
fn strip_stats(
    r: &Refiner<'_, '_, Heightfield<'_, f32>>,
    w: u32,
    h: u32,
    soar: bool,
) -> CliResult<(StripCounts, usize)> {
    let mut scratch = vec![0u64; scratch_len(w, h)];
    let need = if soar {
        r.soar_strip_counts(&mut scratch)?
    } else {
        r.inout_strip_counts(&mut scratch)?
    };
    let mut v = vec![[0.0f32; 3]; need.vertices];
    let mut s = vec![0u32; need.indices];
    let c = if soar {
        r.soar_strip(&mut scratch, &mut v, &mut s)?
    } else {
        r.inout_strip(&mut scratch, &mut v, &mut s)?
    };
    Ok((c, strip_fewest_indices(&s[..c.indices], true).unwrap_or(0)))
}
