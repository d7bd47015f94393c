//! Calls relief-core's public entry points with arbitrary caller input (raw pointers and
//! lengths, as an embedded C caller would). If any of them can reach a panic, the panic handler
//! below stays in the binary and its call to an undefined symbol fails the link.
#![no_std]
#![allow(clippy::missing_safety_doc)]

use core::mem::MaybeUninit;
use core::slice;
use relief_core::glam::{Vec2, Vec3, Vec4};
use relief_core::{
    normal, normal_map, Camera, Composed, Heightfield, NormalMethod, Scale, Surface, Terrain,
};

extern "C" {
    /// Defined nowhere: referencing it makes the link fail.
    fn relief_core_has_a_reachable_panic() -> !;
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    unsafe { relief_core_has_a_reachable_panic() }
}

unsafe fn view<'a, T>(p: *const T, len: usize) -> &'a [T] {
    if p.is_null() {
        &[]
    } else {
        slice::from_raw_parts(p, len)
    }
}

unsafe fn view_mut<'a, T>(p: *mut T, len: usize) -> &'a mut [T] {
    if p.is_null() {
        &mut []
    } else {
        slice::from_raw_parts_mut(p, len)
    }
}

fn scale(s: &[f32; 4]) -> Scale {
    Scale {
        dx: s[0],
        dy: s[1],
        z_scale: s[2],
        z_offset: s[3],
    }
}

fn surface(k: u32) -> Surface {
    match k % 3 {
        0 => Surface::Triangles,
        1 => Surface::Bilinear,
        _ => Surface::Nearest,
    }
}

fn method(k: u32) -> NormalMethod {
    if k % 2 == 0 {
        NormalMethod::Central
    } else {
        NormalMethod::Sobel
    }
}

/// Heightfield construction, every accessor, surfaces and gradients (u16 samples).
#[no_mangle]
pub unsafe extern "C" fn pc_heightfield_u16(
    p: *const u16,
    len: usize,
    w: u32,
    h: u32,
    s: &[f32; 4],
    x: u32,
    y: u32,
    px: f32,
    py: f32,
    k: u32,
) -> f32 {
    let Ok(hf) = Heightfield::with_scale(view(p, len), w, h, scale(s)) else {
        return -1.0;
    };
    let mut acc = hf.z(x, y) + hf.local_z(x, y);
    acc += hf.try_z(x, y).unwrap_or(0.0);
    acc += hf.position(x, y).map_or(0.0, |v| v.z);
    acc += hf.extent().x;
    acc += hf.cell_min_max(x, y).map_or(0.0, |m| m.0 + m.1);
    acc += hf.surface_height(surface(k), px, py).unwrap_or(0.0);
    acc += hf.surface_height_grid(surface(k), px, py).unwrap_or(0.0);
    acc += hf.gradient(x, y).map_or(0.0, |g| g.x);
    acc += hf.sample(x, y).map_or(0.0, f32::from);
    acc
}

/// Same for f32 samples, plus normals into a caller buffer.
#[no_mangle]
pub unsafe extern "C" fn pc_heightfield_f32_normals(
    p: *const f32,
    len: usize,
    w: u32,
    h: u32,
    s: &[f32; 4],
    out: *mut Vec3,
    out_len: usize,
    x: u32,
    y: u32,
    k: u32,
) -> f32 {
    let Ok(hf) = Heightfield::with_scale(view(p, len), w, h, scale(s)) else {
        return -1.0;
    };
    let n = normal(&hf, x, y, method(k)).map_or(0.0, |n| n.z);
    match normal_map(&hf, method(k), view_mut(out, out_len)) {
        Ok(()) => n,
        Err(_) => -n,
    }
}

/// Base + detail composition, its surfaces and summed normals.
#[no_mangle]
pub unsafe extern "C" fn pc_composed(
    b: *const i16,
    blen: usize,
    bw: u32,
    bh: u32,
    d: *const f32,
    dlen: usize,
    dw: u32,
    dh: u32,
    factor: u32,
    x: u32,
    y: u32,
    px: f32,
    py: f32,
    k: u32,
) -> f32 {
    let (Ok(base), Ok(detail)) = (
        Heightfield::new(view(b, blen), bw, bh),
        Heightfield::new(view(d, dlen), dw, dh),
    ) else {
        return -1.0;
    };
    let Ok(c) = Composed::new(base, detail, factor) else {
        return -2.0;
    };
    let mut acc = c.z(x, y) + c.base_z(x, y) + c.detail_z(x, y);
    acc += c.summed_normal(x, y).map_or(0.0, |n| n.z);
    acc += normal(&c, x, y, method(k)).map_or(0.0, |n| n.z);
    acc += c.surface_height(surface(k), px, py).unwrap_or(0.0);
    acc
}

/// The camera: construction, rays, matrices and planes.
#[no_mangle]
pub extern "C" fn pc_camera(
    e: &[f32; 3],
    t: &[f32; 3],
    fov: f32,
    w: u32,
    h: u32,
    i: u32,
    j: u32,
    near: f32,
    far: f32,
) -> f32 {
    let Ok(cam) = Camera::new(Vec3::from(*e), Vec3::from(*t), fov, w, h) else {
        return -1.0;
    };
    let (_, d) = cam.ray(i, j);
    let mut acc = d.x + cam.kappa() + cam.tan_half_fov();
    if let Ok(planes) = cam.frustum_planes(near, far) {
        acc += planes.iter().map(|p| p.dot(Vec4::ONE)).sum::<f32>();
    }
    acc
}

// ---- Ray traversal (core::ray) ----

use relief_core::glam::DVec2;
use relief_core::ray::{GridLine, MarchOptions, MaxMip, Ray, RayTracer, RunAccel};

/// Every traversal and intersection method on a caller's grid and ray.
#[no_mangle]
pub unsafe extern "C" fn pc_rays(
    p: *const f32,
    len: usize,
    w: u32,
    h: u32,
    s: &[f32; 4],
    o: &[f32; 3],
    d: &[f32; 3],
    acc: *mut f32,
    acc_len: usize,
    mip: *mut f32,
    mip_len: usize,
    samples: u32,
    k: u32,
) -> f64 {
    let Ok(hf) = Heightfield::with_scale(view(p, len), w, h, scale(s)) else {
        return -1.0;
    };
    let Ok(ray) = Ray::new(Vec3::from(*o), Vec3::from(*d)) else {
        return -2.0;
    };
    let surf = match k % 4 {
        0 => Surface::Triangles,
        1 => Surface::Bilinear,
        2 => Surface::Plane,
        _ => Surface::Nearest,
    };
    let tracer = RayTracer::new(&hf, surf);
    let mut sum = tracer.trace_cell_dda(&ray).hit.map_or(0.0, |h| h.t) + tracer.step_bound() as f64;
    if let Ok(a) = RunAccel::build(&hf, view_mut(acc, acc_len)) {
        sum += tracer
            .trace_run_dda(&ray, &a)
            .map_or(0.0, |t| t.hit.map_or(0.0, |h| h.t));
        sum += f64::from(a.row_max(k, 0, w).unwrap_or(0.0))
            + f64::from(a.col_max(k, 0, h).unwrap_or(0.0));
    }
    let mip_buf = view_mut(mip, mip_len);
    let _ = MaxMip::update(&hf, mip_buf, k, k, k + 3, k + 2);
    if let Ok(m) = MaxMip::build(&hf, mip_buf) {
        sum += tracer
            .trace_maxmip(&ray, &m)
            .map_or(0.0, |t| t.hit.map_or(0.0, |h| h.t));
        sum += f64::from(m.node(k % 4, k, k)) + m.step_bound() as f64;
        // The packet paths, on packets of 0 to 9 rays.
        let rays = [ray; 9];
        let mut out = [relief_core::ray::Trace::default(); 9];
        let part = rays.get(..(k % 10) as usize).unwrap_or(&[]);
        if tracer.trace_maxmip_packet(part, &m, &mut out).is_ok() {
            sum += out.iter().map(|t| t.steps as f64).sum::<f64>();
        }
        #[cfg(target_arch = "x86_64")]
        if tracer
            .trace_maxmip_packet_avx512(part, &m, &mut out)
            .is_ok()
        {
            sum += out.iter().map(|t| t.cells as f64).sum::<f64>();
        }
        sum += tracer
            .trace_maxmip_wide(&ray, &m)
            .map_or(0.0, |t| t.hit.map_or(0.0, |h| h.t) + f64::from(t.steps));
        if tracer.trace_maxmip_wide_rays(part, &m, &mut out).is_ok() {
            sum += out.iter().map(|t| t.steps as f64).sum::<f64>();
        }
        #[cfg(target_arch = "x86_64")]
        {
            sum += tracer
                .trace_maxmip_wide_avx2(&ray, &m)
                .map_or(0.0, |t| t.hit.map_or(0.0, |h| h.t) + f64::from(t.cells));
            if tracer.trace_maxmip_wide_rays_avx2(part, &m, &mut out).is_ok() {
                sum += out.iter().map(|t| t.cells as f64).sum::<f64>();
            }
            sum += tracer
                .trace_maxmip_wide_avx512(&ray, &m)
                .map_or(0.0, |t| t.hit.map_or(0.0, |h| h.t) + f64::from(t.steps));
        }
    }
    let opts = MarchOptions::default()
        .with_samples(samples)
        .with_refine(k % 70);
    sum += tracer.trace_march(&ray, &opts).map_or(0.0, |m| m.bracket);
    sum
}

/// The digital lines alone.
#[no_mangle]
pub extern "C" fn pc_grid_line(s: &[f64; 2], d: &[f64; 2], e: &[f64; 2], cells: &[u32; 2]) -> u64 {
    let Ok(line) = GridLine::new(DVec2::from(*s), DVec2::from(*d), DVec2::from(*e), *cells) else {
        return 0;
    };
    let a = line
        .cells()
        .fold(0u64, |n, c| n.wrapping_add(u64::from(c[0] ^ c[1])));
    let b = line.runs().fold(0u64, |n, r| {
        n.wrapping_add(u64::from(r.len))
            .wrapping_add(r.cells().count() as u64)
    });
    let c = line.runs().with_intercepts().fold(0u64, |n, (r, beta)| {
        let (num, den) = beta.reduced();
        n.wrapping_add(u64::from(r.len))
            .wrapping_add(num as u64 ^ den as u64 ^ beta.numerator() as u64)
            .wrapping_add(beta.to_f64().to_bits() ^ u64::from(beta.extended()))
    });
    a ^ b ^ c ^ line.step_bound()
}

// ---- Refinement (core::refine) ----

use relief_core::refine::{
    check_records, pack_records, preprocess, preprocess_compact, records_hierarchy, vertical_error,
    Criterion, MorphVertex, RecordLayout, Refiner, VertexRecord, View,
};

/// Preprocessing (both layouts) and every refinement output, view-independent or view-dependent.
#[no_mangle]
pub unsafe extern "C" fn pc_refine(
    p: *const u16,
    len: usize,
    w: u32,
    h: u32,
    s: &[f32; 4],
    err: *mut f32,
    rad: *mut f32,
    qerr: *mut u16,
    n: usize,
    scratch: *mut u64,
    scratch_len: usize,
    verts: *mut [f32; 3],
    verts_len: usize,
    tris: *mut [u32; 3],
    tris_len: usize,
    strip: *mut u32,
    strip_len: usize,
    morph: *mut MorphVertex,
    morph_len: usize,
    cov: *mut u64,
    cov_len: usize,
    e: f32,
    cam: &[f32; 8],
    rec: *mut VertexRecord,
    rec_len: usize,
) -> f64 {
    let Ok(hf) = Heightfield::with_scale(view(p, len), w, h, scale(s)) else {
        return -1.0;
    };
    let mut acc = 0.0f64;
    if let Ok(hc) = preprocess_compact(&hf, view_mut(qerr, n)) {
        acc += hc.bytes_per_vertex() as f64;
        if let Ok(r) = Refiner::new(&hc, &hf, Criterion::MaxError(e)) {
            acc += r
                .count(view_mut(scratch, scratch_len))
                .map_or(0.0, |c| c.triangles as f64);
        }
    }
    let Ok(hier) = preprocess(&hf, view_mut(err, n), view_mut(rad, n)) else {
        return -2.0;
    };
    acc += f64::from(hier.error(1, 1).unwrap_or(0.0)) + f64::from(hier.radius(1, 1).unwrap_or(0.0));
    let mut criteria = [Criterion::MaxError(e), Criterion::MaxError(e)];
    if let Ok(c) = Camera::new(
        Vec3::new(cam[0], cam[1], cam[2]),
        Vec3::new(cam[3], cam[4], cam[5]),
        cam[6],
        640,
        480,
    ) {
        if let Ok(v) = View::new(&c, cam[7]) {
            criteria[1] = Criterion::View(v.with_lazy_levels(e as u32).with_geomorph(Some(cam[7])));
        }
    }
    for crit in criteria {
        let Ok(r) = Refiner::new(&hier, &hf, crit) else {
            continue;
        };
        let sc = view_mut(scratch, scratch_len);
        let vs = view_mut(verts, verts_len);
        if let Ok(c) = r.triangles(sc, vs, view_mut(tris, tris_len)) {
            let v = view(verts, c.vertices.min(verts_len));
            let t = view(tris, c.triangles.min(tris_len));
            acc += vertical_error(&hf, v, t, view_mut(cov, cov_len)).unwrap_or(0.0);
        }
        #[cfg(target_arch = "x86_64")]
        if let Ok(c) = r.triangles_popcnt(
            view_mut(scratch, scratch_len),
            view_mut(verts, verts_len),
            view_mut(tris, tris_len),
        ) {
            acc += c.triangles as f64;
        }
        let (uv, ut) = (
            verts.cast::<MaybeUninit<[f32; 3]>>(),
            tris.cast::<MaybeUninit<[u32; 3]>>(),
        );
        if let Ok(c) = r.triangles_uninit(view_mut(scratch, scratch_len), |_| {
            (view_mut(uv, verts_len), view_mut(ut, tris_len))
        }) {
            acc += c.triangles as f64;
        }
        #[cfg(target_arch = "x86_64")]
        if let Ok(c) = r.triangles_uninit_popcnt(view_mut(scratch, scratch_len), |_| {
            (view_mut(uv, verts_len), view_mut(ut, tris_len))
        }) {
            acc += c.vertices as f64;
        }
        // Grid-coordinate vertices (`[u16; 2]`, 4 bytes: `verts_len` of them fit).
        let gv = verts.cast::<[u16; 2]>();
        if let Ok(c) = r.triangles(
            view_mut(scratch, scratch_len),
            view_mut(gv, verts_len),
            view_mut(tris, tris_len),
        ) {
            acc += c.vertices as f64;
        }
        #[cfg(target_arch = "x86_64")]
        if let Ok(c) = r.triangles_popcnt(
            view_mut(scratch, scratch_len),
            view_mut(gv, verts_len),
            view_mut(tris, tris_len),
        ) {
            acc += c.vertices as f64;
        }
        #[cfg(target_arch = "x86_64")]
        if let Ok(c) = r.triangles_uninit_popcnt(view_mut(scratch, scratch_len), |_| {
            (
                view_mut(gv.cast::<MaybeUninit<[u16; 2]>>(), verts_len),
                view_mut(ut, tris_len),
            )
        }) {
            acc += c.triangles as f64;
        }
        // The AVX-512 builds, both vertex types.
        #[cfg(target_arch = "x86_64")]
        if let Ok(c) = r.triangles_avx512(
            view_mut(scratch, scratch_len),
            view_mut(verts, verts_len),
            view_mut(tris, tris_len),
        ) {
            acc += c.triangles as f64;
        }
        #[cfg(target_arch = "x86_64")]
        if let Ok(c) = r.triangles_uninit_avx512(view_mut(scratch, scratch_len), |_| {
            (
                view_mut(gv.cast::<MaybeUninit<[u16; 2]>>(), verts_len),
                view_mut(ut, tris_len),
            )
        }) {
            acc += c.vertices as f64;
        }
        acc += r
            .grid_triangles(view_mut(tris, tris_len))
            .map_or(0.0, |n| n as f64);
        acc += r
            .inout_strip(
                view_mut(scratch, scratch_len),
                view_mut(verts, verts_len),
                view_mut(strip, strip_len),
            )
            .map_or(0.0, |c| c.indices as f64);
        acc += r
            .inout_strip(
                view_mut(scratch, scratch_len),
                view_mut(verts.cast::<[u16; 2]>(), verts_len),
                view_mut(strip, strip_len),
            )
            .map_or(0.0, |c| c.indices as f64);
        acc += r
            .inout_strip_counts(view_mut(scratch, scratch_len))
            .map_or(0.0, |c| c.indices as f64);
        // Any indices at all (the caller's strip buffer as it stands), both ways round.
        let any: &[u32] = view_mut(strip, strip_len);
        acc += relief_core::refine::strip_fewest_indices(any, true).unwrap_or(0) as f64;
        acc += relief_core::refine::strip_fewest_indices(any, false).unwrap_or(0) as f64;
        let (bytes, out): (&mut [u8], &mut [u32]) = (
            view_mut(tris.cast::<u8>(), tris_len),
            view_mut(morph.cast::<u32>(), morph_len),
        );
        acc += relief_core::refine::strip_fewest(any, true, bytes, out).unwrap_or(0) as f64;
        acc += r
            .soar_strip_counts(view_mut(scratch, scratch_len))
            .map_or(0.0, |c| c.indices as f64);
        acc += r
            .morph(view_mut(scratch, scratch_len), view_mut(morph, morph_len))
            .unwrap_or(0) as f64;
        acc += r
            .inout_strip_morph(view_mut(scratch, scratch_len), view_mut(morph, morph_len))
            .unwrap_or(0) as f64;
        acc += r
            .soar_strip_morph(view_mut(scratch, scratch_len), view_mut(morph, morph_len))
            .unwrap_or(0) as f64;
    }
    // 8-byte records in both layouts (pack_records and the record decision path).
    for layout in [RecordLayout::Linear, RecordLayout::Interleaved] {
        let Ok(hr) = pack_records(&hier, &hf, layout, view_mut(rec, rec_len)) else {
            continue;
        };
        acc += f64::from(hr.error(1, 1).unwrap_or(0.0));
        acc += f64::from(u8::from(check_records(&hr).is_ok()));
        let z = hr.z_range();
        for crit in criteria {
            let Ok(r) = Refiner::new(&hr, &hf, crit) else {
                continue;
            };
            let sc = view_mut(scratch, scratch_len);
            acc += r
                .triangles(sc, view_mut(verts, verts_len), view_mut(tris, tris_len))
                .map_or(0.0, |c| c.triangles as f64);
            acc += r
                .soar_strip(
                    view_mut(scratch, scratch_len),
                    view_mut(verts, verts_len),
                    view_mut(strip, strip_len),
                )
                .map_or(0.0, |c| c.indices as f64);
        }
        // The same records wrapped again, as after mapping them from a file (caller's sizes).
        let stored: &[VertexRecord] = view_mut(rec, rec_len);
        if let Ok(again) = records_hierarchy(stored, layout, w, h, scale(s), z) {
            acc += f64::from(u8::from(check_records(&again).is_ok()));
        }
    }
    acc
}

// ---- Detail levels (core::refine::detail) ----

use relief_core::refine::{DetailBounds, DetailRefiner};

/// `DetailBounds::measure_local` and refinement with it (buffer from the caller).
#[no_mangle]
pub unsafe extern "C" fn pc_detail_local(
    p: *const u16,
    len: usize,
    w: u32,
    h: u32,
    d: *const f32,
    dlen: usize,
    dw: u32,
    dh: u32,
    factor: u32,
    local: *mut f32,
    local_len: usize,
    qerr: *mut u16,
    n: usize,
    cam: &[f32; 8],
) -> f64 {
    let Ok(hf) = Heightfield::new(view(p, len), w, h) else {
        return -1.0;
    };
    let Ok(det) = Heightfield::new(view(d, dlen), dw, dh) else {
        return -1.0;
    };
    let Ok(c) = Composed::new(hf, det, factor) else {
        return -1.0;
    };
    let Ok(b) = DetailBounds::measure_local(&c, view_mut(local, local_len)) else {
        return -2.0;
    };
    let Ok(camera) = Camera::new(
        Vec3::new(cam[0], cam[1], cam[2]),
        Vec3::new(cam[3], cam[4], cam[5]),
        cam[6],
        64,
        64,
    ) else {
        return -1.0;
    };
    let Ok(v) = View::new(&camera, cam[7]) else {
        return -1.0;
    };
    let Ok(hc) = preprocess_compact(c.base(), view_mut(qerr, n)) else {
        return -2.0;
    };
    match DetailRefiner::new(&hc, &c, &b, &v) {
        Ok(r) => r.triangle_count() as f64,
        Err(_) => -3.0,
    }
}

/// Detail refinement of a composed surface: both bounds, count-only mode and the triangle list.
#[no_mangle]
pub unsafe extern "C" fn pc_detail(
    p: *const u16,
    len: usize,
    w: u32,
    h: u32,
    d: *const f32,
    dlen: usize,
    dw: u32,
    dh: u32,
    factor: u32,
    s: &[f32; 4],
    err: *mut f32,
    rad: *mut f32,
    qerr: *mut u16,
    n: usize,
    scratch: *mut u64,
    scratch_len: usize,
    verts: *mut [f32; 3],
    verts_len: usize,
    tris: *mut [u32; 3],
    tris_len: usize,
    e: f32,
    cam: &[f32; 8],
) -> f64 {
    let Ok(hf) = Heightfield::with_scale(view(p, len), w, h, scale(s)) else {
        return -1.0;
    };
    let Ok(det) = Heightfield::new(view(d, dlen), dw, dh) else {
        return -1.0;
    };
    let Ok(c) = Composed::new(hf, det, factor) else {
        return -1.0;
    };
    let Ok(camera) = Camera::new(
        Vec3::new(cam[0], cam[1], cam[2]),
        Vec3::new(cam[3], cam[4], cam[5]),
        cam[6],
        640,
        480,
    ) else {
        return -1.0;
    };
    let Ok(v) = View::new(&camera, cam[7]) else {
        return -1.0;
    };
    let v = v.with_lazy_levels(e as u32);
    let measured = DetailBounds::measure(&c);
    let mut acc = f64::from(measured.error(0).unwrap_or(0.0));
    let constant = DetailBounds::constant(&c, e).unwrap_or(measured);
    if let Ok(hc) = preprocess_compact(c.base(), view_mut(qerr, n)) {
        if let Ok(r) = DetailRefiner::new(&hc, &c, &constant, &v) {
            acc += r.triangle_count() as f64;
            acc += r
                .count(view_mut(scratch, scratch_len))
                .map_or(0.0, |k| k.vertices as f64);
        }
    }
    let Ok(hier) = preprocess(c.base(), view_mut(err, n), view_mut(rad, n)) else {
        return -2.0;
    };
    if let Ok(r) = DetailRefiner::new(&hier, &c, &measured, &v) {
        let sc = view_mut(scratch, scratch_len);
        if let Ok(k) = r.triangles(sc, view_mut(verts, verts_len), view_mut(tris, tris_len)) {
            acc += k.detail_triangles() as f64 + f64::from(k.finest_level().unwrap_or(0));
        }
    }
    acc
}

// ---- RBF and cascades (core::rbf) ----

use relief_core::rbf::{
    build_adaptive_grid, discretize, fit_cascades, AdaptiveGrid, CascadeOptions, Cell, GridOptions,
    InfluenceSets, Rbf, RbfOptions,
};

/// Adaptive grid, influence sets, evaluation, cascades and discretization.
#[no_mangle]
pub unsafe extern "C" fn pc_rbf(
    p: *const f32,
    len: usize,
    w: u32,
    h: u32,
    cells: *mut Cell,
    cells_len: usize,
    index: *mut u32,
    index_len: usize,
    offsets: *mut u32,
    offsets_len: usize,
    entries: *mut u32,
    entries_len: usize,
    opts: &[f32; 4],
    cam: &[f32; 7],
    mask: *mut u8,
    values: *mut f32,
    weights: *mut f32,
    raster_len: usize,
) -> f32 {
    let Ok(hf) = Heightfield::new(view(p, len), w, h) else {
        return -1.0;
    };
    let go = GridOptions::default()
        .with_max_error(opts[0])
        .with_cells(opts[1] as u32, opts[2] as u32);
    let ro = RbfOptions::default().with_sigma(opts[3]);
    let cells = view_mut(cells, cells_len);
    let Ok(n) = build_adaptive_grid(&hf, &go, cells) else {
        return -2.0;
    };
    let Ok(grid) = AdaptiveGrid::new(
        w,
        h,
        cells.get(..n).unwrap_or(&[]),
        view_mut(index, index_len),
    ) else {
        return -3.0;
    };
    let Ok(sets) = InfluenceSets::build(
        &grid,
        &ro,
        view_mut(offsets, offsets_len),
        view_mut(entries, entries_len),
    ) else {
        return -4.0;
    };
    let Ok(rbf) = Rbf::new(grid, sets, &ro) else {
        return -5.0;
    };
    let mut acc = rbf.eval(Vec2::new(cam[0], cam[1])).unwrap_or(0.0);
    if let Ok(c) = Camera::new(
        Vec3::new(cam[0], cam[1], cam[2]),
        Vec3::new(cam[3], cam[4], cam[5]),
        cam[6],
        320,
        240,
    ) {
        let co = CascadeOptions::default().with_resolution(opts[1] as u32);
        if let Ok(cs) = fit_cascades(&c, &grid, &Scale::default(), (0.0, opts[0]), &co, None) {
            for cascade in &cs.cascades {
                let m = view_mut(mask, raster_len);
                acc += cascade.mask(m).unwrap_or(0) as f32;
                acc += discretize(
                    &rbf,
                    cascade,
                    view(mask, raster_len),
                    view_mut(values, raster_len),
                    view_mut(weights, raster_len),
                )
                .unwrap_or(0) as f32;
            }
        }
    }
    acc
}

// ---- Silhouette map (core::silhouette) ----

use relief_core::silhouette::{
    silhouette_envelope, silhouette_map, silhouette_map_len, tree_node_rows, SilhouetteTexel,
};

/// The silhouette map, tree rows and envelopes.
#[no_mangle]
pub unsafe extern "C" fn pc_silhouette(
    p: *const f32,
    len: usize,
    w: u32,
    h: u32,
    cam: &[f32; 7],
    sw: u32,
    sh: u32,
    near: f32,
    map: *mut SilhouetteTexel,
    map_len: usize,
    env: *mut f32,
    env_len: usize,
    level: u32,
    k: u32,
) -> f32 {
    let Ok(hf) = Heightfield::new(view(p, len), w, h) else {
        return -1.0;
    };
    let Ok(c) = Camera::new(
        Vec3::new(cam[0], cam[1], cam[2]),
        Vec3::new(cam[3], cam[4], cam[5]),
        cam[6],
        sw,
        sh,
    ) else {
        return -2.0;
    };
    let n = silhouette_map_len(sw, h).unwrap_or(0) as f32;
    let m = view_mut(map, map_len);
    if silhouette_map(&hf, &c, near, m).is_err() {
        return -3.0;
    }
    let (a, b) = tree_node_rows(h, level, k).unwrap_or((0, 0));
    n + silhouette_envelope(view(map, map_len), sw, a, b, view_mut(env, env_len))
        .map_or(0.0, |()| 1.0)
}

// ---- Live edits and tiles (core::refine::update, core::refine::tile) ----

use relief_core::refine::{
    crater, export_border, merge_border, preprocess_compact_pyramid, preprocess_pyramid, renest,
    update, update_compact, PreprocessOptions, Region, Side,
};

/// Pruned preprocessing (both layouts), a crater, the incremental updates, and the tile border
/// protocol (export, merge, re-nest) on every side.
#[no_mangle]
pub unsafe extern "C" fn pc_refine_edit(
    samples: *mut f32,
    len: usize,
    w: u32,
    h: u32,
    s: &[f32; 4],
    err: *mut f32,
    rad: *mut f32,
    qerr: *mut u16,
    n: usize,
    pyr: *mut f32,
    pyr_len: usize,
    side_e: *mut f32,
    side_r: *mut f32,
    side_len: usize,
    c: &[f32; 4],
    r: &[u32; 4],
) -> f64 {
    let o = PreprocessOptions::default();
    let mut acc = 0.0f64;
    let sm = view_mut(samples, len);
    acc += crater(sm, w, h, c[0], c[1], c[2], c[3]).map_or(0.0, |g| g.map_or(1.0, |g| g.x0 as f64));
    let Ok(hf) = Heightfield::with_scale(view(samples, len), w, h, scale(s)) else {
        return -1.0;
    };
    let region = Region::new(r[0], r[1], r[2], r[3]).unwrap_or(Region {
        x0: 0,
        y0: 0,
        x1: 0,
        y1: 0,
    });
    if let Ok(hp) = preprocess_pyramid(
        &hf,
        view_mut(err, n),
        view_mut(rad, n),
        view_mut(pyr, pyr_len),
        o,
    ) {
        acc += hp.error(1, 1).unwrap_or(0.0) as f64;
    }
    if let Ok(hu) = update(
        &hf,
        view_mut(err, n),
        view_mut(rad, n),
        view_mut(pyr, pyr_len),
        region,
        o,
    ) {
        acc += hu.error(1, 1).unwrap_or(0.0) as f64;
    }
    if let Ok(hc) = preprocess_compact_pyramid(&hf, view_mut(qerr, n), view_mut(pyr, pyr_len)) {
        acc += hc.error(1, 1).unwrap_or(0.0) as f64;
    }
    if let Ok(hc) = update_compact(&hf, view_mut(qerr, n), view_mut(pyr, pyr_len), region) {
        acc += hc.error(1, 1).unwrap_or(0.0) as f64;
    }
    for side in Side::ALL {
        let (e, rr) = (view_mut(err, n), view_mut(rad, n));
        acc += export_border(
            w,
            h,
            e,
            rr,
            side,
            view_mut(side_e, side_len),
            view_mut(side_r, side_len),
        )
        .unwrap_or(0) as f64;
        acc += merge_border(
            w,
            h,
            e,
            rr,
            side,
            view(side_e, side_len),
            view(side_r, side_len),
        )
        .unwrap_or(0) as f64;
    }
    if let Ok(hr) = renest(&hf, view_mut(err, n), view_mut(rad, n), &Side::ALL, o) {
        acc += hr.error(1, 1).unwrap_or(0.0) as f64;
    }
    acc
}

/// Skirts for a tile's mesh (core::refine::tile::skirt) on arbitrary vertices and triangles.
#[no_mangle]
pub unsafe extern "C" fn pc_refine_skirt(
    w: u32,
    h: u32,
    s: &[f32; 4],
    verts: *const [f32; 3],
    nv: usize,
    tris: *const [u32; 3],
    nt: usize,
    depth: f32,
    out_v: *mut [f32; 3],
    out_t: *mut [u32; 3],
    out_len: usize,
) -> usize {
    relief_core::refine::skirt(
        w,
        h,
        scale(s),
        view(verts, nv),
        view(tris, nt),
        &Side::ALL,
        depth,
        view_mut(out_v, out_len),
        view_mut(out_t, out_len),
    )
    .map_or(0, |(a, b)| a + b)
}

/// The compact tile border protocol (core::refine::tile, bfloat16 error codes).
#[no_mangle]
pub unsafe extern "C" fn pc_refine_tile_compact(
    samples: *const f32,
    len: usize,
    w: u32,
    h: u32,
    s: &[f32; 4],
    qerr: *mut u16,
    n: usize,
    side_e: *mut u16,
    side_len: usize,
) -> f64 {
    let mut acc = 0.0f64;
    let Ok(hf) = Heightfield::with_scale(view(samples, len), w, h, scale(s)) else {
        return -1.0;
    };
    for side in Side::ALL {
        let e = view_mut(qerr, n);
        acc += relief_core::refine::export_border_compact(w, h, e, side, view_mut(side_e, side_len))
            .unwrap_or(0) as f64;
        acc += relief_core::refine::merge_border_compact(w, h, e, side, view(side_e, side_len))
            .unwrap_or(0) as f64;
    }
    if let Ok(hr) = relief_core::refine::renest_compact(&hf, view_mut(qerr, n), &Side::ALL) {
        acc += hr.error(1, 1).unwrap_or(0.0) as f64;
    }
    acc
}
