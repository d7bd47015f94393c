//! GPU tests: every pass against the relief-core CPU result on the same input.
//!
//! They run on any adapter, Mesa's lavapipe included. Without any adapter each test prints a
//! loud notice and returns, unless `RELIEF_REQUIRE_GPU=1` (set by `.ci/run`), which turns the
//! missing adapter into a failure so a broken driver cannot pass CI.

use glam::Vec3;
use relief_core::ray::{MarchOptions, MaxMip, Ray, RayTracer};
use relief_core::refine::{
    preprocess, scratch_len, strip_bound, strip_triangles, triangle_bound, vertex_bound, Criterion,
    MorphVertex, Refiner, View,
};
use relief_core::{
    normal_map, Camera, Composed, Heightfield, NormalMethod, Scale, Surface, Terrain,
};
use relief_wgpu::mesh::{depth_to_distance, MeshStyle};
use relief_wgpu::raycast::{RayEffects, Shading};
use relief_wgpu::terrain::Crater;
use relief_wgpu::{
    DepthTarget, Effect, Gpu, GpuTerrain, MeshPass, Method, NormalPass, PassName, RayCastPass,
    Renderer, ResolvePass, Scene,
};
use std::sync::OnceLock;

fn gpu() -> Option<&'static Gpu> {
    static GPU: OnceLock<Option<Gpu>> = OnceLock::new();
    GPU.get_or_init(|| match relief_wgpu::headless() {
        Ok(g) => {
            eprintln!(
                "GPU tests on {} ({:?}, {:?}), timestamp queries: {}",
                g.info.name,
                g.info.backend,
                g.info.device_type,
                g.device
                    .features()
                    .contains(wgpu::Features::TIMESTAMP_QUERY)
            );
            Some(g)
        }
        Err(e) => {
            if std::env::var("RELIEF_REQUIRE_GPU").is_ok_and(|v| v == "1") {
                panic!("RELIEF_REQUIRE_GPU=1 but {e}");
            }
            eprintln!("\n!!!!! SKIPPING GPU TEST: {e} !!!!!\n");
            None
        }
    })
    .as_ref()
}

/// A rough synthetic terrain: sums of sines plus a hash, `w x h`.
fn synthetic(w: u32, h: u32) -> Vec<f32> {
    let mut v = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let (fx, fy) = (x as f32, y as f32);
            let hash =
                ((x.wrapping_mul(73_856_093) ^ y.wrapping_mul(19_349_663)) % 1000) as f32 / 1000.0;
            v.push(
                40.0 * (fx * 0.05).sin() * (fy * 0.07).cos()
                    + 25.0 * ((fx + 2.0 * fy) * 0.021).sin()
                    + 3.0 * hash
                    + 50.0,
            );
        }
    }
    v
}

fn puget() -> relief_io::Dem {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/puget_sound_1k.png");
    let mut dem = relief_io::read_dem(&p, &relief_io::ReadOptions::default()).unwrap();
    dem.scale = dem.scale.with_spacing(160.0, 160.0).with_z_scale(0.1);
    dem
}

/// Little-endian 32-bit words of a buffer read back from the GPU.
fn words(bytes: &[u8]) -> Vec<u32> {
    bytes
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect()
}

fn submit(g: &Gpu, f: impl FnOnce(&mut wgpu::CommandEncoder)) {
    let mut enc = g.device.create_command_encoder(&Default::default());
    f(&mut enc);
    g.queue.submit([enc.finish()]);
}

/// Fraction of pixels whose GPU depth equals the CPU's: both miss, or both hit with
/// `|t_gpu - t_cpu| <= tol(pixel)`.
fn agreement(gpu: &[f32], cpu: &[f32], tol: impl Fn(usize) -> f64) -> (f64, usize) {
    assert_eq!(gpu.len(), cpu.len());
    let mut bad = 0;
    for (i, (&g, &c)) in gpu.iter().zip(cpu).enumerate() {
        assert!(!g.is_nan(), "NaN depth at pixel {i}");
        let ok = if c.is_infinite() || g.is_infinite() {
            c == g
        } else {
            (f64::from(g) - f64::from(c)).abs() <= tol(i)
        };
        if !ok {
            if bad < 6 {
                eprintln!("  pixel {i}: gpu {g} cpu {c}");
            }
            bad += 1;
        }
    }
    (1.0 - bad as f64 / gpu.len() as f64, bad)
}

#[test]
fn maxmip_build_equals_cpu_pyramid() {
    let Some(g) = gpu() else { return };
    for (w, h) in [(2, 2), (37, 29), (129, 97), (300, 5)] {
        let s = synthetic(w, h);
        let hf = Heightfield::with_scale(&s, w, h, Scale::default().with_z_scale(0.75)).unwrap();
        let t = GpuTerrain::new(&g.device, &g.queue, &hf, false).unwrap();
        submit(g, |e| t.encode_maxmip(e));
        let gpu_mip = t.read_maxmip(&g.device, &g.queue).unwrap();
        let mut buf = vec![0.0f32; MaxMip::len(w, h).unwrap()];
        let cpu = MaxMip::build(&hf, &mut buf).unwrap();
        // GPU levels are row-major; compare node by node.
        let offsets = t.mip_offsets();
        assert_eq!(offsets.len() as u32, cpu.levels(), "{w}x{h}");
        let mut n = 0;
        for (k, &off) in offsets.iter().enumerate() {
            let lw = ((w - 2) >> k) + 1;
            let lh = ((h - 2) >> k) + 1;
            for y in 0..lh {
                for x in 0..lw {
                    let g = gpu_mip[(off + y * lw + x) as usize];
                    assert_eq!(
                        g,
                        cpu.node(k as u32, x, y),
                        "{w}x{h} level {k} node ({x}, {y})"
                    );
                    n += 1;
                }
            }
        }
        assert_eq!(n, gpu_mip.len());
    }
}

#[test]
fn normal_maps_match_cpu_central_sobel_and_composed() {
    let Some(g) = gpu() else { return };
    let (w, h) = (97, 61);
    let s = synthetic(w, h);
    let scale = Scale::default().with_spacing(2.0, 3.0).with_z_scale(0.5);
    let hf = Heightfield::with_scale(&s, w, h, scale).unwrap();
    let t = GpuTerrain::new(&g.device, &g.queue, &hf, false).unwrap();
    let check = |gpu: &[[f32; 3]], cpu: &[Vec3], what: &str| {
        let worst = gpu
            .iter()
            .zip(cpu)
            .map(|(a, b)| (Vec3::from_array(*a) - *b).length())
            .fold(0.0f32, f32::max);
        assert!(worst < 2e-5, "{what}: worst normal difference {worst}");
    };
    for method in [NormalMethod::Central, NormalMethod::Sobel] {
        let pass = NormalPass::new(&g.device, &g.queue, &t, method, None).unwrap();
        submit(g, |e| pass.encode(e));
        let gpu_n = pass.read(&g.device, &g.queue).unwrap();
        let mut cpu = vec![Vec3::ZERO; (w * h) as usize];
        normal_map(&hf, method, &mut cpu).unwrap();
        check(&gpu_n, &cpu, &format!("{method:?}"));
    }
    // Composed base + detail: the base refined by the factor (bilinear), the detail (world
    // heights) tiled over the refined grid and added; factor 1 through `new` and through
    // `new_composed`, then 2 and 4. The core's Composed takes powers of two only, and so
    // does the GPU pass (3 is refused with the core's error).
    let (dw, dh) = (7, 5);
    let detail: Vec<f32> = (0..dw * dh)
        .map(|i| ((i * 37) % 11) as f32 * 0.8 - 4.0)
        .collect();
    let dhf = Heightfield::new(&detail, dw, dh).unwrap();
    for factor in [0, 1, 2, 4] {
        let composed = Composed::new(hf, dhf, factor.max(1)).unwrap();
        let (cw, ch) = (composed.width(), composed.height());
        assert_eq!(
            (cw, ch),
            ((w - 1) * factor.max(1) + 1, (h - 1) * factor.max(1) + 1)
        );
        for method in [NormalMethod::Central, NormalMethod::Sobel] {
            let pass = if factor == 0 {
                NormalPass::new(&g.device, &g.queue, &t, method, Some((&detail, dw, dh)))
            } else {
                NormalPass::new_composed(&g.device, &g.queue, &t, method, (&detail, dw, dh), factor)
            }
            .unwrap();
            assert_eq!(pass.size(), (cw, ch));
            submit(g, |e| pass.encode(e));
            let gpu_n = pass.read(&g.device, &g.queue).unwrap();
            let mut cpu = vec![Vec3::ZERO; (cw * ch) as usize];
            normal_map(&composed, method, &mut cpu).unwrap();
            check(&gpu_n, &cpu, &format!("composed x{factor} {method:?}"));
            // The detail really changed the normals.
            let plain_c = Composed::new(
                hf,
                Heightfield::new(&[0.0f32; 4], 2, 2).unwrap(),
                factor.max(1),
            )
            .unwrap();
            let mut plain = vec![Vec3::ZERO; (cw * ch) as usize];
            normal_map(&plain_c, method, &mut plain).unwrap();
            assert!(plain
                .iter()
                .zip(&cpu)
                .any(|(a, b)| (*a - *b).length() > 1e-2));
        }
    }
    assert!(matches!(
        NormalPass::new_composed(
            &g.device,
            &g.queue,
            &t,
            NormalMethod::Sobel,
            (&detail, dw, dh),
            3
        ),
        Err(relief_wgpu::Error::Core(
            relief_core::Error::InvalidFactor { factor: 3 }
        ))
    ));
}

fn cpu_depth<T: Terrain>(
    hf: &T,
    cam: &Camera,
    mut f: impl FnMut(&Ray) -> Option<(f64, Vec3)>,
) -> (Vec<f32>, Vec<Vec3>) {
    let mut d = Vec::new();
    let mut n = Vec::new();
    let _ = hf;
    for j in 0..cam.height {
        for i in 0..cam.width {
            let (o, dir) = cam.ray(i, j);
            let r = Ray::new(o, dir).unwrap();
            match f(&r) {
                Some((t, nn)) => {
                    d.push(t as f32);
                    n.push(nn);
                }
                None => {
                    d.push(f32::INFINITY);
                    n.push(Vec3::ZERO);
                }
            }
        }
    }
    (d, n)
}

/// The CPU's exact trace of `hf` (triangles, max-mip skipping): the depth and normal of each
/// pixel of `cam`, as [`cpu_depth`].
fn cpu_trace(hf: &Heightfield<'_, f32>, cam: &Camera) -> (Vec<f32>, Vec<Vec3>) {
    let mut buf = vec![0.0f32; MaxMip::len(hf.width(), hf.height()).unwrap()];
    let mip = MaxMip::build(hf, &mut buf).unwrap();
    let tracer = RayTracer::new(hf, Surface::Triangles);
    cpu_depth(hf, cam, |r| {
        tracer
            .trace_maxmip(r, &mip)
            .unwrap()
            .hit
            .map(|h| (h.t, h.normal))
    })
}

/// An oblique 96 x 72 view over the 129 x 129 [`synthetic`] terrain.
fn oblique_view() -> Camera {
    Camera::new(
        Vec3::new(2.0, 3.0, 180.0),
        Vec3::new(64.0, 64.0, 40.0),
        60.0,
        96,
        72,
    )
    .unwrap()
}

fn gpu_rays(g: &Gpu, t: &GpuTerrain, method: Method, cam: &Camera) -> (Vec<f32>, Vec<[f32; 4]>) {
    let normals = RayEffects {
        normals: true,
        ..Default::default()
    };
    let pass = RayCastPass::new(
        &g.device, t, None, None, method, normals, cam.width, cam.height,
    )
    .unwrap();
    submit(g, |e| {
        t.encode_maxmip(e);
        pass.encode(&g.queue, e, t, cam, &Shading::default())
            .unwrap();
    });
    let o = pass.outputs();
    (
        o.read_depth(&g.device, &g.queue).unwrap(),
        o.read_normals(&g.device, &g.queue).unwrap(),
    )
}

fn cameras(hf: &impl Terrain) -> Vec<Camera> {
    let e = hf.extent();
    let (lo, hi) = (0.0f32, 1.0f32);
    let _ = (lo, hi);
    let (w, d) = (e.x, e.y);
    let top = hf.z(0, 0).max(hf.z(hf.width() / 2, hf.height() / 2));
    vec![
        // Oblique from above a corner, looking across. (Eyes stay above the domain: rays that
        // enter the prism through a side below the surface are a CPU tracer bug, see
        // `rays_entering_through_a_side_below_the_surface_hit_there`.)
        Camera::new(
            Vec3::new(0.02 * w, 0.03 * d, top + 0.3 * w),
            Vec3::new(0.6 * w, 0.7 * d, 0.0),
            55.0,
            256,
            192,
        )
        .unwrap(),
        // Low, inside the domain, grazing.
        Camera::new(
            Vec3::new(0.3 * w, 0.2 * d, top + 0.02 * w),
            Vec3::new(0.9 * w, 0.8 * d, top),
            70.0,
            200,
            150,
        )
        .unwrap(),
    ]
}

#[test]
fn maxmip_ray_casting_matches_cpu_trace() {
    let Some(g) = gpu() else { return };
    let (w, h) = (257, 193);
    let s = synthetic(w, h);
    let synth = Heightfield::with_scale(&s, w, h, Scale::default().with_spacing(2.0, 2.0)).unwrap();
    let dem = puget();
    let real = dem.heightfield().unwrap();
    for (name, hf) in [("synthetic", synth), ("puget", real)] {
        let t = GpuTerrain::new(&g.device, &g.queue, &hf, false).unwrap();
        for (k, cam) in cameras(&hf).iter().enumerate() {
            let (gd, gn) = gpu_rays(g, &t, Method::MaxMip, cam);
            let (cd, cn) = cpu_trace(&hf, cam);
            let hits = cd.iter().filter(|t| t.is_finite()).count();
            assert!(
                hits > cd.len() / 4,
                "{name} camera {k}: too few hits ({hits}) to test anything"
            );
            let (frac, bad) = agreement(&gd, &cd, |i| 1e-3 * f64::from(cd[i]));
            eprintln!("{name} camera {k}: maxmip depth agreement {frac:.6} ({bad} pixels differ)");
            assert!(frac >= 0.999, "{name} camera {k}: {frac} ({bad} pixels)");
            // Normals of agreeing hits.
            let mut close = 0;
            let mut total = 0;
            for i in 0..cd.len() {
                if cd[i].is_finite() && gd[i].is_finite() && (gd[i] - cd[i]).abs() <= 1e-3 * cd[i] {
                    total += 1;
                    assert_eq!(gn[i][3], 1.0);
                    if (Vec3::new(gn[i][0], gn[i][1], gn[i][2]) - cn[i]).length() < 1e-3 {
                        close += 1;
                    }
                }
            }
            assert!(
                close as f64 >= 0.999 * total as f64,
                "{name} camera {k}: normals {close}/{total}"
            );
        }
    }
}

#[test]
fn march_ray_casting_matches_cpu_march() {
    let Some(g) = gpu() else { return };
    let dem = puget();
    let hf = dem.heightfield().unwrap();
    // The march reads only the heights: no pyramid (a placeholder in its binding).
    let t = GpuTerrain::without_maxmip(&g.device, &g.queue, &hf, false).unwrap();
    assert!(RayCastPass::new(
        &g.device,
        &t,
        None,
        None,
        Method::MaxMip,
        RayEffects::default(),
        8,
        8
    )
    .is_err());
    let tracer = RayTracer::new(&hf, Surface::Triangles);
    let opts = MarchOptions::default();
    for (k, cam) in cameras(&hf).iter().enumerate() {
        let (gd, _) = gpu_rays(g, &t, Method::march(), cam);
        let mut brackets = Vec::new();
        let (cd, _) = cpu_depth(&hf, cam, |r| {
            let m = tracer.trace_march(r, &opts).unwrap();
            brackets.push(m.bracket);
            m.trace.hit.map(|h| (h.t, h.normal))
        });
        // The march is approximate; the GPU must find the same bracket (to f32 rounding).
        let (frac, bad) = agreement(&gd, &cd, |i| brackets[i] + 1e-3 * f64::from(cd[i]));
        eprintln!("puget camera {k}: march depth agreement {frac:.6} ({bad} pixels differ)");
        assert!(frac >= 0.999, "camera {k}: {frac} ({bad} pixels)");
    }
}

fn refined_mesh(hf: &Heightfield<'_, f32>, max_error: f32) -> (Vec<[f32; 3]>, Vec<u32>) {
    let (w, h) = (hf.width(), hf.height());
    let (mut e, mut r) = (vec![0.0; (w * h) as usize], vec![0.0; (w * h) as usize]);
    let hier = preprocess(hf, &mut e, &mut r).unwrap();
    let rf = Refiner::new(&hier, hf, Criterion::MaxError(max_error)).unwrap();
    let mut verts = vec![[0.0f32; 3]; vertex_bound(w, h)];
    let mut tris = vec![[0u32; 3]; triangle_bound(w, h)];
    let c = rf
        .triangles(&mut vec![0; scratch_len(w, h)], &mut verts, &mut tris)
        .unwrap();
    verts.truncate(c.vertices);
    tris.truncate(c.triangles);
    (verts, tris.into_iter().flatten().collect())
}

/// First hit of a ray with a triangle list (Moller-Trumbore in f64, brute force): the CPU
/// reference of what a rasteriser draws at a pixel centre.
fn mesh_hit(verts: &[[f32; 3]], idx: &[u32], o: Vec3, d: Vec3) -> Option<f64> {
    let (o, d) = (o.as_dvec3(), d.as_dvec3());
    let mut best: Option<f64> = None;
    for t in idx.chunks_exact(3) {
        let p = |k: usize| Vec3::from_array(verts[t[k] as usize]).as_dvec3();
        let (a, b, c) = (p(0), p(1), p(2));
        let (e1, e2) = (b - a, c - a);
        let pv = d.cross(e2);
        let det = e1.dot(pv);
        if det.abs() < 1e-12 {
            continue;
        }
        let s = o - a;
        let u = s.dot(pv) / det;
        if !(0.0..=1.0).contains(&u) {
            continue;
        }
        let q = s.cross(e1);
        let v = d.dot(q) / det;
        if v < 0.0 || u + v > 1.0 {
            continue;
        }
        let tt = e2.dot(q) / det;
        if tt > 0.0 && best.is_none_or(|b| tt < b) {
            best = Some(tt);
        }
    }
    best
}

#[test]
fn mesh_pass_with_reversed_z_matches_cpu_ray_mesh_intersection() {
    let Some(g) = gpu() else { return };
    let (w, h) = (65, 65);
    let s = synthetic(w, h);
    let hf = Heightfield::with_scale(&s, w, h, Scale::default().with_spacing(3.0, 3.0)).unwrap();
    let mut mesh = MeshPass::new(&g.device);
    // Two refinements of different sizes drawn through the same (growing) buffers, per frame.
    for max_error in [1.0, 0.05] {
        let (verts, idx) = refined_mesh(&hf, max_error);
        assert!(idx.len() / 3 > 200, "{} triangles", idx.len() / 3);
        for c in cameras(&hf) {
            let cam = Camera::new(c.eye, c.target, c.fov_deg, 128, 96).unwrap();
            let target = DepthTarget::new(&g.device, cam.width, cam.height).unwrap();
            mesh.upload(&g.device, &g.queue, &verts, &idx).unwrap();
            submit(g, |e| {
                mesh.encode(
                    &g.queue,
                    e,
                    &target,
                    &cam,
                    MeshStyle::Terrain { lighting: true },
                    (0.0, 120.0),
                    true,
                )
                .unwrap()
            });
            let depth = target.read_depth(&g.device, &g.queue).unwrap();
            let mut gd = Vec::new();
            let mut cd = Vec::new();
            for j in 0..cam.height {
                for i in 0..cam.width {
                    gd.push(depth_to_distance(
                        &cam,
                        1.0,
                        i,
                        j,
                        depth[(j * cam.width + i) as usize],
                    ));
                    let (o, d) = cam.ray(i, j);
                    cd.push(mesh_hit(&verts, &idx, o, d).map_or(f32::INFINITY, |t| t as f32));
                }
            }
            let hits = cd.iter().filter(|t| t.is_finite()).count();
            assert!(hits > cd.len() / 4, "too few hits: {hits}");
            let (frac, bad) = agreement(&gd, &cd, |i| 1e-3 * f64::from(cd[i]));
            eprintln!("mesh pass (E = {max_error}, {} triangles) depth agreement {frac:.6} ({bad} pixels differ)", idx.len() / 3);
            assert!(frac >= 0.999, "{frac} ({bad})");
        }
    }
}

#[test]
fn rays_entering_through_a_side_below_the_surface_hit_there() {
    // CONVENTIONS.md: a ray entering the domain prism through a side below the surface hits at
    // the side. Flat ground at z = 10; rays from x = -5 at z = 5 heading +x (slightly down).
    let Some(g) = gpu() else { return };
    let s = vec![10.0f32; 16 * 16];
    let hf = Heightfield::new(&s, 16, 16).unwrap();
    let t = GpuTerrain::new(&g.device, &g.queue, &hf, false).unwrap();
    let cam = Camera::new(
        Vec3::new(-5.0, 7.5, 5.0),
        Vec3::new(10.0, 7.5, 4.0),
        20.0,
        8,
        8,
    )
    .unwrap();
    for method in [Method::MaxMip, Method::march()] {
        let (gd, _) = gpu_rays(g, &t, method, &cam);
        for j in 0..8 {
            for i in 0..8 {
                let (o, d) = cam.ray(i, j);
                let expect = (0.0 - o.x) / d.x; // the x = 0 side
                let got = gd[(j * 8 + i) as usize];
                assert!(
                    (got - expect).abs() <= 1e-4 * expect,
                    "{method:?} pixel ({i}, {j}): {got} vs {expect}"
                );
            }
        }
    }
}

#[test]
fn depth_output_lets_terrain_and_meshes_occlude_each_other() {
    let Some(g) = gpu() else { return };
    let (w, h) = (129, 129);
    let s = synthetic(w, h);
    let hf = Heightfield::with_scale(&s, w, h, Scale::default().with_spacing(3.0, 3.0)).unwrap();
    let t = GpuTerrain::new(&g.device, &g.queue, &hf, false).unwrap();
    let cam = cameras(&hf)[0];
    let rays = RayCastPass::new(
        &g.device,
        &t,
        None,
        None,
        Method::MaxMip,
        RayEffects::default(),
        cam.width,
        cam.height,
    )
    .unwrap();
    let target = DepthTarget::new(&g.device, cam.width, cam.height).unwrap();
    let resolve = ResolvePass::new(&g.device, rays.outputs(), 1.0);
    // A vertical red wall across the view, x = 200, part in front of and part behind hills.
    let quad = [
        [200.0f32, 0.0, 0.0],
        [200.0, 384.0, 0.0],
        [200.0, 384.0, 110.0],
        [200.0, 0.0, 110.0],
    ];
    let mut mesh = MeshPass::new(&g.device);
    mesh.upload(&g.device, &g.queue, &quad, &[0, 1, 2, 0, 2, 3])
        .unwrap();
    submit(g, |e| {
        t.encode_maxmip(e);
        rays.encode(&g.queue, e, &t, &cam, &Shading::default())
            .unwrap();
        resolve.encode(&g.queue, e, &target, &cam).unwrap();
        mesh.encode(
            &g.queue,
            e,
            &target,
            &cam,
            MeshStyle::Flat([1.0, 0.0, 0.0]),
            (0.0, 1.0),
            false,
        )
        .unwrap();
    });
    let color = target.read_color(&g.device, &g.queue).unwrap();
    let ray_color = rays.outputs().read_color(&g.device, &g.queue).unwrap();
    let mut buf = vec![0.0f32; MaxMip::len(w, h).unwrap()];
    let mip = MaxMip::build(&hf, &mut buf).unwrap();
    let tracer = RayTracer::new(&hf, Surface::Triangles);
    let (mut wall, mut hidden, mut bad) = (0, 0, 0);
    for j in 0..cam.height {
        for i in 0..cam.width {
            let (o, d) = cam.ray(i, j);
            let k = (j * cam.width + i) as usize;
            let tw = (200.0 - o.x) / d.x;
            let p = o + tw * d;
            let on_wall = tw > 0.0 && p.y > 0.0 && p.y < 384.0 && p.z > 0.0 && p.z < 110.0;
            let tt = tracer
                .trace_maxmip(&Ray::new(o, d).unwrap(), &mip)
                .unwrap()
                .hit
                .map_or(f64::INFINITY, |h| h.t);
            // Skip pixels within 0.5 % of a tie or of the wall's edge.
            let margin = 0.005 * f64::from(tw);
            let edge = (p.y.min(384.0 - p.y).min(p.z).min(110.0 - p.z)).abs() < 1.0;
            if edge || (on_wall && (f64::from(tw) - tt).abs() < margin) {
                continue;
            }
            let expect_wall = on_wall && f64::from(tw) < tt;
            let got_wall = color[k] == [255, 0, 0, 255];
            if expect_wall {
                wall += 1;
            } else if on_wall {
                hidden += 1;
                if color[k] != ray_color[k] {
                    bad += 1;
                }
            }
            if expect_wall != got_wall {
                bad += 1;
            }
        }
    }
    eprintln!("depth output: {wall} wall pixels in front, {hidden} hidden by terrain, {bad} wrong");
    assert!(
        wall > 100 && hidden > 100,
        "the test scene must show both cases: {wall} / {hidden}"
    );
    assert!(
        bad as f64 <= 0.001 * f64::from(cam.width * cam.height),
        "{bad} wrong pixels"
    );
}

#[test]
fn scenes_dispatch_exactly_the_passes_their_effects_need() {
    let Some(g) = gpu() else { return };
    let (w, h) = (65, 65);
    let s = synthetic(w, h);
    let hf = Heightfield::new(&s, w, h).unwrap();
    let cam = Camera::new(
        Vec3::new(-10.0, -10.0, 160.0),
        Vec3::new(40.0, 40.0, 40.0),
        60.0,
        64,
        48,
    )
    .unwrap();
    use PassName::*;
    let cases: Vec<(Scene, Vec<PassName>, Vec<PassName>)> = vec![
        (Scene::new(), vec![MaxMipBuild, RayCast], vec![RayCast]),
        (
            Scene::new().with_method(Method::march()),
            vec![RayCast],
            vec![RayCast],
        ),
        (
            Scene::new().with_effects(&[Effect::Lighting, Effect::Fog]),
            vec![MaxMipBuild, NormalMap, RayCast],
            vec![RayCast],
        ),
        (
            Scene::new().with_effects(&[Effect::Shadows, Effect::Water, Effect::Detail]),
            vec![MaxMipBuild, RayCast],
            vec![RayCast],
        ),
        (
            Scene::new().with_effects(&[Effect::DepthOutput]),
            vec![MaxMipBuild, RayCast, DepthResolve],
            vec![RayCast, DepthResolve],
        ),
        (
            Scene::new()
                .with_effects(&[Effect::Deformations, Effect::Lighting])
                .with_craters(&[Crater {
                    center: [30.0, 30.0],
                    radius: 10.0,
                    depth: 20.0,
                }]),
            vec![Deform, MaxMipBuild, NormalMap, RayCast],
            vec![Deform, MaxMipBuild, NormalMap, RayCast],
        ),
        (
            Scene::new()
                .with_method(Method::march())
                .with_effects(&[Effect::Deformations, Effect::Lighting])
                .with_craters(&[Crater {
                    center: [30.0, 30.0],
                    radius: 10.0,
                    depth: 20.0,
                }]),
            vec![Deform, NormalMap, RayCast],
            vec![Deform, NormalMap, RayCast],
        ),
        (
            Scene::new().with_method(Method::Silhouette),
            vec![SilhouetteMap, SilhouetteTree, SilhouetteTrace],
            vec![SilhouetteMap, SilhouetteTree, SilhouetteTrace],
        ),
        (
            Scene::new()
                .with_method(Method::Silhouette)
                .with_effect(Effect::DepthOutput),
            vec![SilhouetteMap, SilhouetteTree, SilhouetteTrace, DepthResolve],
            vec![SilhouetteMap, SilhouetteTree, SilhouetteTrace, DepthResolve],
        ),
        (
            Scene::new().with_method(Method::Cascades { resolution: 64 }),
            vec![RbfDiscretize, CascadeMaxMip, CascadeRayCast, CascadeBlend],
            vec![RbfDiscretize, CascadeMaxMip, CascadeRayCast, CascadeBlend],
        ),
        (
            Scene::new()
                .with_method(Method::Cascades { resolution: 64 })
                .with_effect(Effect::DepthOutput),
            vec![
                RbfDiscretize,
                CascadeMaxMip,
                CascadeRayCast,
                CascadeBlend,
                DepthResolve,
            ],
            vec![
                RbfDiscretize,
                CascadeMaxMip,
                CascadeRayCast,
                CascadeBlend,
                DepthResolve,
            ],
        ),
    ];
    // Effects a method cannot render are refused, not silently dropped.
    for m in [Method::Silhouette, Method::Cascades { resolution: 64 }] {
        let s = Scene::new().with_method(m).with_effect(Effect::Fog);
        assert!(matches!(
            Renderer::new(&g.device, &g.queue, &hf, s),
            Err(relief_wgpu::Error::Unsupported(_))
        ));
    }
    for (scene, first, next) in cases {
        let name = format!("{:?} {:?}", scene.method(), scene.effects());
        let traces_the_pyramid = scene.method() == Method::MaxMip;
        let mut r = Renderer::new(&g.device, &g.queue, &hf, scene).unwrap();
        // Nor allocated: the terrain's max-mip pyramid only where the frame traces it.
        assert_eq!(
            r.terrain().maxmip().is_some(),
            traces_the_pyramid,
            "{name}: pyramid"
        );
        let f1 = r.render(&g.device, &g.queue, &cam).unwrap();
        assert_eq!(r.last_passes(), first.as_slice(), "{name} first frame");
        r.render(&g.device, &g.queue, &cam).unwrap();
        assert_eq!(r.last_passes(), next.as_slice(), "{name} second frame");
        assert!(
            f1.depth.iter().any(|d| d.is_finite()),
            "{name}: nothing hit"
        );
    }
}

#[test]
fn effects_change_the_colour_not_the_depth_and_craters_match_the_cpu() {
    let Some(g) = gpu() else { return };
    let (w, h) = (129, 129);
    let s = synthetic(w, h);
    let hf = Heightfield::new(&s, w, h).unwrap();
    let cam = oblique_view();
    let bare = Renderer::new(&g.device, &g.queue, &hf, Scene::new())
        .unwrap()
        .render(&g.device, &g.queue, &cam)
        .unwrap();
    for e in [
        Effect::Lighting,
        Effect::Shadows,
        Effect::Detail,
        Effect::Fog,
    ] {
        let f = Renderer::new(&g.device, &g.queue, &hf, Scene::new().with_effect(e))
            .unwrap()
            .render(&g.device, &g.queue, &cam)
            .unwrap();
        assert_eq!(f.depth, bare.depth, "{e:?} must not move the surface");
        assert_ne!(f.color, bare.color, "{e:?} must change the picture");
    }
    // Craters: GPU deformed heights and the depth image against the CPU on the same heights.
    let craters = [
        Crater {
            center: [60.0, 70.0],
            radius: 18.0,
            depth: 30.0,
        },
        Crater {
            center: [90.0, 40.0],
            radius: 9.5,
            depth: 12.0,
        },
    ];
    let scene = Scene::new()
        .with_effect(Effect::Deformations)
        .with_craters(&craters);
    let mut r = Renderer::new(&g.device, &g.queue, &hf, scene).unwrap();
    let frame = r.render(&g.device, &g.queue, &cam).unwrap();
    let gpu_h = r.terrain().read_heights(&g.device, &g.queue).unwrap();
    let cpu_h: Vec<f32> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            craters.iter().fold(s[(y * w + x) as usize], |z, c| {
                z - c.lowering(x as f32, y as f32)
            })
        })
        .collect();
    let worst = gpu_h
        .iter()
        .zip(&cpu_h)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-4, "deformed heights differ by {worst}");
    let dhf = Heightfield::new(&cpu_h, w, h).unwrap();
    let (cd, _) = cpu_trace(&dhf, &cam);
    let (frac, bad) = agreement(&frame.depth, &cd, |i| 1e-3 * f64::from(cd[i]));
    assert!(frac >= 0.999, "deformed terrain: {frac} ({bad})");
    assert_ne!(frame.depth, bare.depth, "the craters are visible");
}

/// The normal output is an effect like the others: without it the ray cast writes no normals
/// (reading them is an error and their buffer is a 16-byte placeholder), with it the frame's
/// normals are the CPU trace's, and the picture, depth and passes are the same either way.
#[test]
fn normals_are_written_only_when_the_scene_names_them() {
    let Some(g) = gpu() else { return };
    let (w, h) = (129, 129);
    let s = synthetic(w, h);
    let hf = Heightfield::new(&s, w, h).unwrap();
    let cam = oblique_view();
    let mut bare = Renderer::new(&g.device, &g.queue, &hf, Scene::new()).unwrap();
    let with = Scene::new().with_effect(Effect::NormalOutput);
    assert_eq!(with.frame_passes(), Scene::new().frame_passes());
    let mut normals = Renderer::new(&g.device, &g.queue, &hf, with).unwrap();
    let (a, b) = (
        bare.render(&g.device, &g.queue, &cam).unwrap(),
        normals.render(&g.device, &g.queue, &cam).unwrap(),
    );
    assert_eq!((&a.depth, &a.color), (&b.depth, &b.color));
    let out = bare.outputs().unwrap();
    assert!(!out.has_normals() && out.normal.size() == 16);
    assert!(out.read_normals(&g.device, &g.queue).is_err());
    let out = normals.outputs().unwrap();
    assert_eq!(out.normal.size(), 96 * 72 * 16);
    let n = out.read_normals(&g.device, &g.queue).unwrap();
    // Against the CPU trace of the same terrain: hit pixels carry its normal, misses zero.
    let (cd, cn) = cpu_trace(&hf, &cam);
    let (mut hits, mut close) = (0, 0);
    for (((gn, c), d), gd) in n.iter().zip(&cn).zip(&cd).zip(&b.depth) {
        if !gd.is_finite() {
            assert_eq!(gn, &[0.0; 4], "a miss has no normal");
        } else if d.is_finite() {
            hits += 1;
            assert_eq!(gn[3], 1.0);
            let dot = gn[0] * c.x + gn[1] * c.y + gn[2] * c.z;
            close += usize::from(dot > 0.9999);
        }
    }
    assert!(hits > n.len() / 4, "{hits} hits");
    assert!(
        close as f64 >= 0.995 * hits as f64,
        "{close} of {hits} normals agree"
    );
}

/// The depth buffer of `mesh` (already uploaded) drawn from `cam`.
fn mesh_depth(g: &Gpu, mesh: &MeshPass, cam: &Camera) -> Vec<f32> {
    let target = DepthTarget::new(&g.device, cam.width, cam.height).unwrap();
    submit(g, |e| {
        mesh.encode(
            &g.queue,
            e,
            &target,
            cam,
            MeshStyle::Terrain { lighting: false },
            (0.0, 120.0),
            true,
        )
        .unwrap()
    });
    target.read_depth(&g.device, &g.queue).unwrap()
}

/// GPU depth of `mesh` (already uploaded) against the brute-force CPU intersection of `tris`.
fn mesh_agreement(
    g: &Gpu,
    mesh: &MeshPass,
    cam: &Camera,
    verts: &[[f32; 3]],
    tris: &[u32],
) -> (f64, usize) {
    let depth = mesh_depth(g, mesh, cam);
    let mut gd = Vec::new();
    let mut cd = Vec::new();
    for j in 0..cam.height {
        for i in 0..cam.width {
            gd.push(depth_to_distance(
                cam,
                1.0,
                i,
                j,
                depth[(j * cam.width + i) as usize],
            ));
            let (o, d) = cam.ray(i, j);
            cd.push(mesh_hit(verts, tris, o, d).map_or(f32::INFINITY, |t| t as f32));
        }
    }
    let hits = cd.iter().filter(|t| t.is_finite()).count();
    assert!(hits > cd.len() / 4, "too few hits: {hits}");
    agreement(&gd, &cd, |i| 1e-3 * f64::from(cd[i]))
}

/// Where the vertex shader draws each geomorphing vertex: `base_z + morph (z - base_z)`.
fn morphed_positions(morph: &[MorphVertex]) -> Vec<[f32; 3]> {
    morph
        .iter()
        .map(|m| {
            [
                m.position[0],
                m.position[1],
                m.base_z + m.morph * (m.position[2] - m.base_z),
            ]
        })
        .collect()
}

#[test]
fn mesh_pass_draws_strips_geomorphs_and_grid_triangles_like_the_cpu() {
    let Some(g) = gpu() else { return };
    let (w, h) = (33, 33);
    let s = synthetic(w, h);
    let hf = Heightfield::with_scale(&s, w, h, Scale::default().with_spacing(3.0, 3.0)).unwrap();
    let (mut e, mut r) = (vec![0.0; (w * h) as usize], vec![0.0; (w * h) as usize]);
    let hier = preprocess(&hf, &mut e, &mut r).unwrap();
    let c0 = cameras(&hf)[0];
    let cam = Camera::new(c0.eye, c0.target, c0.fov_deg, 96, 72).unwrap();
    let mut mesh = MeshPass::new(&g.device);
    let mut scratch = vec![0; scratch_len(w, h)];

    // Seed 004's in/out-edge strip, drawn as a strip; the CPU expands it into triangles.
    let rf = Refiner::new(&hier, &hf, Criterion::MaxError(0.5)).unwrap();
    let mut verts = vec![[0.0f32; 3]; vertex_bound(w, h)];
    let mut strip = vec![0u32; strip_bound(w, h)];
    let c = rf
        .inout_strip(&mut scratch, &mut verts, &mut strip)
        .unwrap();
    verts.truncate(c.vertices);
    strip.truncate(c.indices);
    let tris: Vec<u32> = strip
        .windows(3)
        .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
        .flatten()
        .copied()
        .collect();
    assert!(
        tris.len() / 3 >= c.triangles && c.triangles > 300,
        "{} {}",
        tris.len() / 3,
        c.triangles
    );
    mesh.upload_strip(&g.device, &g.queue, &verts, &strip)
        .unwrap();
    let (frac, bad) = mesh_agreement(g, &mesh, &cam, &verts, &tris);
    eprintln!(
        "strip ({} indices, {} triangles): depth agreement {frac:.6} ({bad})",
        c.indices, c.triangles
    );
    assert!(frac >= 0.999, "strip: {frac} ({bad})");

    // Geomorphing: view-dependent refinement with a morph range; the CPU applies the morph.
    let view = View::new(&cam, 0.5).unwrap().with_geomorph(Some(4.0));
    let rf = Refiner::new(&hier, &hf, Criterion::View(view)).unwrap();
    let mut verts = vec![[0.0f32; 3]; vertex_bound(w, h)];
    let mut tris = vec![[0u32; 3]; triangle_bound(w, h)];
    let c = rf.triangles(&mut scratch, &mut verts, &mut tris).unwrap();
    let mut morph = vec![MorphVertex::default(); c.vertices];
    let n = rf.morph(&mut scratch, &mut morph).unwrap();
    assert_eq!(n, c.vertices);
    let partial = morph
        .iter()
        .filter(|m| m.morph < 0.99 && (m.position[2] - m.base_z).abs() > 0.5)
        .count();
    assert!(
        partial > 10,
        "the test needs vertices in mid-morph: {partial}"
    );
    let morphed = morphed_positions(&morph);
    let idx: Vec<u32> = tris[..c.triangles].iter().flatten().copied().collect();
    mesh.upload_morph(&g.device, &g.queue, &morph, &idx, false)
        .unwrap();
    let (frac, bad) = mesh_agreement(g, &mesh, &cam, &morphed, &idx);
    eprintln!("geomorph ({partial} vertices mid-morph): depth agreement {frac:.6} ({bad})");
    assert!(frac >= 0.999, "geomorph: {frac} ({bad})");
    // And the morph is visible: the unmorphed mesh differs from the GPU's picture.
    let unmorphed: Vec<[f32; 3]> = morph.iter().map(|m| m.position).collect();
    let (same, _) = mesh_agreement(g, &mesh, &cam, &unmorphed, &idx);
    assert!(same < 0.999, "geomorphing changed nothing ({same})");

    // The same frame as the in/out-edge strip with its own morph data (the strip's vertex
    // order): the GPU draws the strip morphed as the CPU morphs it.
    let sc = rf.inout_strip_counts(&mut scratch).unwrap();
    let mut smorph = vec![MorphVertex::default(); sc.vertices];
    assert_eq!(
        rf.inout_strip_morph(&mut scratch, &mut smorph).unwrap(),
        sc.vertices
    );
    let mut sverts = vec![[0.0f32; 3]; sc.vertices];
    let mut sidx = vec![0u32; sc.indices];
    assert_eq!(
        rf.inout_strip(&mut scratch, &mut sverts, &mut sidx)
            .unwrap(),
        sc
    );
    let smorphed = morphed_positions(&smorph);
    let stris: Vec<u32> = strip_triangles(&sidx).flatten().collect();
    mesh.upload_morph(&g.device, &g.queue, &smorph, &sidx, true)
        .unwrap();
    let (frac, bad) = mesh_agreement(g, &mesh, &cam, &smorphed, &stris);
    eprintln!(
        "geomorphed strip ({} triangles): depth agreement {frac:.6} ({bad})",
        sc.triangles
    );
    assert!(frac >= 0.999, "geomorphed strip: {frac} ({bad})");

    // Grid triangles: every sample uploaded once as a vertex, each frame only its indices.
    let mut on_grid = MeshPass::new(&g.device);
    on_grid
        .upload_grid_vertices(&g.device, &g.queue, &hf)
        .unwrap();
    let mut grid = vec![[0u32; 3]; triangle_bound(w, h)];
    for (k, tau) in [0.5f32, 4.0].into_iter().enumerate() {
        let rf = Refiner::new(&hier, &hf, Criterion::View(View::new(&cam, tau).unwrap())).unwrap();
        let c = rf.triangles(&mut scratch, &mut verts, &mut tris).unwrap();
        let idx: Vec<u32> = tris[..c.triangles].iter().flatten().copied().collect();
        let n = rf.grid_triangles(&mut grid).unwrap();
        assert_eq!(n, c.triangles);
        assert!(n > 100, "{n} triangles");
        on_grid
            .upload_grid_triangles(&g.device, &g.queue, bytemuck::cast_slice(&grid[..n]))
            .unwrap();
        mesh.upload(&g.device, &g.queue, &verts[..c.vertices], &idx)
            .unwrap();
        // The same triangles at the same positions in the same order: the same depth, bit for
        // bit.
        let (a, b) = (mesh_depth(g, &mesh, &cam), mesh_depth(g, &on_grid, &cam));
        assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()));
        if k == 0 {
            // And the picture is the CPU's mesh, not an empty frame drawn twice.
            let (frac, bad) = mesh_agreement(g, &on_grid, &cam, &verts[..c.vertices], &idx);
            eprintln!("grid triangles ({n}): depth agreement {frac:.6} ({bad})");
            assert!(frac >= 0.999, "grid triangles: {frac} ({bad})");
        }
    }
}

/// CPU model of seed 000 in f64: per column, the nearest row whose silhouette reaches the
/// pixel (linear scan instead of the tree), the same interpolation and depth as the shader.
fn silhouette_cpu(hf: &Heightfield<'_, f32>, cam: &Camera) -> Vec<f32> {
    relief_wgpu::silhouette::trace_cpu(hf, cam).unwrap().depth
}

#[test]
fn silhouette_partitioning_matches_its_cpu_model_and_approximates_the_exact_trace() {
    use relief_wgpu::silhouette::SilhouettePass;
    let Some(g) = gpu() else { return };
    let dem = puget();
    let real = dem.heightfield().unwrap();
    let (w, h) = (257, 193);
    let s = synthetic(w, h);
    let synth = Heightfield::with_scale(&s, w, h, Scale::default().with_spacing(2.0, 2.0)).unwrap();
    let cases = [
        (
            "synthetic +y",
            synth,
            Vec3::new(256.0, -150.0, 250.0),
            Vec3::new(256.0, 200.0, 0.0),
        ),
        (
            "puget +y",
            real,
            Vec3::new(82_000.0, -20_000.0, 9000.0),
            Vec3::new(82_000.0, 60_000.0, 0.0),
        ),
        (
            "puget -x",
            real,
            Vec3::new(185_000.0, 70_000.0, 9000.0),
            Vec3::new(90_000.0, 80_000.0, 0.0),
        ),
    ];
    for (name, hf, eye, target) in cases {
        let cam = Camera::new(eye, target, 50.0, 160, 120).unwrap();
        let t = GpuTerrain::new(&g.device, &g.queue, &hf, false).unwrap();
        let pass = SilhouettePass::new(&g.device, &t, cam.width, cam.height).unwrap();
        submit(g, |e| pass.encode(&g.queue, e, &t, &cam).unwrap());
        let gd = pass.outputs().read_depth(&g.device, &g.queue).unwrap();
        let model = silhouette_cpu(&hf, &cam);
        let hits = model.iter().filter(|t| t.is_finite()).count();
        assert!(hits > model.len() / 4, "{name}: too few hits {hits}");
        let (frac, bad) = agreement(&gd, &model, |i| 1e-3 * f64::from(model[i]));
        // Against the exact trace: how good the approximation is (stated, loosely bounded).
        let tracer = RayTracer::new(&hf, Surface::Triangles);
        let (exact, _) = cpu_depth(&hf, &cam, |r| {
            tracer.trace_cell_dda(r).hit.map(|h| (h.t, h.normal))
        });
        let (close, _) = agreement(&gd, &exact, |i| 0.02 * f64::from(exact[i]));
        eprintln!(
            "silhouette {name}: {} texel reads per pixel; GPU vs CPU model {frac:.6} ({bad} differ); \
             within 2% of the exact trace: {close:.4}",
            pass.reads_per_pixel()
        );
        assert!(frac >= 0.999, "{name}: {frac} ({bad})");
        assert!(
            close >= 0.9,
            "{name}: only {close} of pixels within 2% of the exact trace"
        );
        // The same method as a Scene: the Renderer dispatches exactly the three silhouette
        // passes and writes the same image; the fixed read count is the one stated.
        let mut r = Renderer::new(
            &g.device,
            &g.queue,
            &hf,
            Scene::new().with_method(Method::Silhouette),
        )
        .unwrap();
        let frame = r.render(&g.device, &g.queue, &cam).unwrap();
        assert_eq!(
            r.last_passes(),
            &[
                PassName::SilhouetteMap,
                PassName::SilhouetteTree,
                PassName::SilhouetteTrace
            ]
        );
        assert_eq!(
            frame.depth, gd,
            "{name}: Scene silhouette differs from the pass"
        );
        assert_eq!(
            r.silhouette_pass().unwrap().reads_per_pixel(),
            relief_wgpu::silhouette::reads_per_pixel(hf.width(), hf.height())
        );
    }
    // Terrain behind the camera is refused.
    let t = GpuTerrain::new(&g.device, &g.queue, &synth, false).unwrap();
    let cam = Camera::new(
        Vec3::new(256.0, 100.0, 150.0),
        Vec3::new(256.0, 300.0, 100.0),
        50.0,
        160,
        120,
    )
    .unwrap();
    let pass = SilhouettePass::new(&g.device, &t, 160, 120).unwrap();
    let mut enc = g.device.create_command_encoder(&Default::default());
    assert!(pass.encode(&g.queue, &mut enc, &t, &cam).is_err());
}

/// The caller-owned storage of an adaptive-grid RBF (seed 002) of a heightfield: cells, sample
/// index and influence sets, sized by the core's `*_len` functions.
struct RbfBuffers {
    w: u32,
    h: u32,
    cells: Vec<relief_core::rbf::Cell>,
    index: Vec<u32>,
    offsets: Vec<u32>,
    entries: Vec<u32>,
    ropts: relief_core::rbf::RbfOptions,
}

impl RbfBuffers {
    /// Fits the adaptive grid of `hf` with `gopts`.
    fn new(hf: &Heightfield<'_, f32>, gopts: &relief_core::rbf::GridOptions) -> Self {
        use relief_core::rbf::{
            adaptive_grid_bound, build_adaptive_grid, AdaptiveGrid, Cell, InfluenceSets, RbfOptions,
        };
        let (w, h) = (hf.width(), hf.height());
        let mut cells = vec![Cell::default(); adaptive_grid_bound(w, h).unwrap()];
        let n = build_adaptive_grid(hf, gopts, &mut cells).unwrap();
        cells.truncate(n);
        let mut index = vec![0u32; (w * h) as usize];
        let ropts = RbfOptions::default();
        let grid = AdaptiveGrid::new(w, h, &cells, &mut index).unwrap();
        let offsets = vec![0u32; InfluenceSets::offsets_len(&grid)];
        let entries = vec![0u32; InfluenceSets::entries_len(&grid, &ropts).unwrap()];
        RbfBuffers {
            w,
            h,
            cells,
            index,
            offsets,
            entries,
            ropts,
        }
    }

    /// The RBF over these buffers and its influence sets.
    fn rbf(
        &mut self,
    ) -> (
        relief_core::rbf::Rbf<'_>,
        relief_core::rbf::InfluenceSets<'_>,
    ) {
        use relief_core::rbf::{AdaptiveGrid, InfluenceSets, Rbf};
        let grid = AdaptiveGrid::new(self.w, self.h, &self.cells, &mut self.index).unwrap();
        let sets =
            InfluenceSets::build(&grid, &self.ropts, &mut self.offsets, &mut self.entries).unwrap();
        (Rbf::new(grid, sets, &self.ropts).unwrap(), sets)
    }
}

#[test]
fn rbf_cascade_discretization_matches_the_cpu() {
    use relief_core::rbf::{discretize, fit_cascades, CascadeOptions, GridOptions};
    let Some(g) = gpu() else { return };
    let (w, h) = (257, 257);
    let s = synthetic(w, h);
    let scale = Scale::default().with_spacing(2.0, 2.0);
    let hf = Heightfield::with_scale(&s, w, h, scale).unwrap();
    let mut store = RbfBuffers::new(
        &hf,
        &GridOptions::default().with_max_error(2.0).with_cells(1, 32),
    );
    let (rbf, sets) = store.rbf();
    let cam = Camera::new(
        Vec3::new(20.0, 30.0, 150.0),
        Vec3::new(400.0, 350.0, 40.0),
        60.0,
        640,
        480,
    )
    .unwrap();
    let cas = fit_cascades(
        &cam,
        rbf.grid(),
        &scale,
        (0.0, 130.0),
        &CascadeOptions::default().with_resolution(128),
        None,
    )
    .unwrap();
    assert!(cas.visible);
    let pass = relief_wgpu::rbf::RbfPass::new(&g.device, &rbf, &sets).unwrap();
    let mut visible_total = 0;
    for (k, c) in cas.cascades.iter().enumerate() {
        let t = (c.resolution * c.resolution) as usize;
        let (mut mask, mut cv, mut cw) = (vec![0u8; t], vec![0f32; t], vec![0f32; t]);
        c.mask(&mut mask).unwrap();
        let visible = discretize(&rbf, c, &mask, &mut cv, &mut cw).unwrap();
        visible_total += visible;
        let gv = pass.discretize(&g.device, &g.queue, c, &mask).unwrap();
        let worst = gv
            .iter()
            .zip(&cv)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        eprintln!("cascade {k}: {visible} visible texels, worst |gpu - cpu| = {worst}");
        // Values are heights around 0..130: f32 evaluation order and exp differ by ulps.
        assert!(worst <= 1e-4, "cascade {k}: worst difference {worst}");
        assert!(gv.iter().zip(&mask).all(|(v, m)| *m != 0 || *v == 0.0));
    }
    assert!(visible_total > 1000, "{visible_total}");
}

/// The visible-texel masks computed on the GPU (`RbfPass::encode_into_gpu_mask`, what the
/// cascade ray cast uses every frame) against the core's `Cascade::mask`: equal, except texels
/// whose centre lies within rounding error of the margin (the shader's division and products
/// round differently), bounded here in f64.
#[test]
fn gpu_visible_texel_masks_match_the_core() {
    use relief_core::rbf::{fit_cascades, CascadeOptions, GridOptions};
    let Some(g) = gpu() else { return };
    let (w, h) = (257, 257);
    let s = synthetic(w, h);
    let (mut texels, mut visible, mut differ) = (0usize, 0usize, 0usize);
    // Spacing 2 m, and 160 m (the Puget map's: world coordinates up to 41 km).
    for (spacing, res) in [(2.0f32, 128u32), (160.0, 200)] {
        let scale = Scale::default().with_spacing(spacing, spacing);
        let hf = Heightfield::with_scale(&s, w, h, scale).unwrap();
        let mut store = RbfBuffers::new(
            &hf,
            &GridOptions::default().with_max_error(2.0).with_cells(1, 32),
        );
        let (rbf, sets) = store.rbf();
        let pass = relief_wgpu::rbf::RbfPass::new(&g.device, &rbf, &sets).unwrap();
        let target = pass.target(&g.device, res).unwrap();
        let k = spacing / 2.0;
        let views = [
            (Vec3::new(20.0, 30.0, 150.0), Vec3::new(400.0, 350.0, 40.0)),
            (Vec3::new(480.0, 20.0, 60.0), Vec3::new(100.0, 300.0, 0.0)),
            (Vec3::new(256.0, 256.0, 400.0), Vec3::new(300.0, 200.0, 0.0)),
        ];
        for (eye, at) in views {
            let cam = Camera::new(eye * k, at * k, 60.0, 640, 480).unwrap();
            let opts = CascadeOptions::default().with_resolution(res);
            let cas = fit_cascades(&cam, rbf.grid(), &scale, (0.0, 130.0), &opts, None).unwrap();
            assert!(cas.visible);
            for c in &cas.cascades {
                let n = (res * res) as usize;
                let mut cpu = vec![0u8; n];
                visible += c.mask(&mut cpu).unwrap();
                submit(g, |e| {
                    pass.encode_into_gpu_mask(&g.queue, e, &target, c, -1e6)
                        .unwrap()
                });
                let bytes =
                    relief_wgpu::read_buffer(&g.device, &g.queue, target.mask(), n as u64 * 4)
                        .unwrap();
                let gpu_mask = words(&bytes);
                let values =
                    relief_wgpu::read_buffer(&g.device, &g.queue, target.values(), n as u64 * 4)
                        .unwrap();
                let values: Vec<f32> = words(&values).into_iter().map(f32::from_bits).collect();
                let margin = f64::from(c.mask_margin());
                let ws = c.world_spacing();
                for (t, (&m, &gm)) in cpu.iter().zip(&gpu_mask).enumerate() {
                    texels += 1;
                    assert!(gm <= 1, "mask entry {gm}");
                    // The discretization read the GPU's mask: invisible texels on the floor.
                    assert_eq!(values[t] == -1e6, gm == 0, "texel {t}: {}", values[t]);
                    if u32::from(m) == gm {
                        continue;
                    }
                    differ += 1;
                    let q = c.texel_center(t as u32 % res, t as u32 / res) * ws;
                    let (qx, qy) = (f64::from(q.x), f64::from(q.y));
                    let near_margin = c.mask_edges().any(|(a, e, len)| {
                        let (ax, ay) = (f64::from(a.x), f64::from(a.y));
                        let d = (f64::from(e.x) * (qy - ay) - f64::from(e.y) * (qx - ax))
                            / f64::from(len);
                        let tol = 1e-5 * (qx.abs() + qy.abs() + ax.abs() + ay.abs() + margin);
                        (d + margin).abs() <= tol
                    });
                    assert!(
                        near_margin,
                        "texel {t} at {q}: cpu {m}, gpu {gm}, not at the margin"
                    );
                }
            }
        }
    }
    eprintln!("visible-texel masks: {texels} texels, {visible} visible, {differ} differ from the core's (all within rounding of the margin)");
    assert!(
        visible > texels / 10 && visible < texels,
        "{visible} of {texels}"
    );
    assert!(differ * 1000 <= texels, "{differ} of {texels}");
}

#[test]
fn silhouette_map_matches_the_core_cpu_silhouette_map() {
    use relief_core::silhouette::{silhouette_map, silhouette_map_len, SilhouetteTexel};
    use relief_wgpu::silhouette::SilhouettePass;
    let Some(g) = gpu() else { return };
    let dem = puget();
    let real = dem.heightfield().unwrap();
    let (w, h) = (257, 193);
    let s = synthetic(w, h);
    let synth = Heightfield::with_scale(&s, w, h, Scale::default().with_spacing(2.0, 2.0)).unwrap();
    // Cameras looking along +y, so that the GPU's rows (nearest first) are the grid rows in
    // storage order, as the core numbers them.
    let cases = [
        (
            "synthetic",
            synth,
            Vec3::new(256.0, -150.0, 250.0),
            Vec3::new(256.0, 200.0, 0.0),
        ),
        (
            "puget",
            real,
            Vec3::new(82_000.0, -20_000.0, 9000.0),
            Vec3::new(82_000.0, 60_000.0, 0.0),
        ),
    ];
    for (name, hf, eye, target) in cases {
        let cam = Camera::new(eye, target, 50.0, 160, 120).unwrap();
        let t = GpuTerrain::new(&g.device, &g.queue, &hf, false).unwrap();
        let pass = SilhouettePass::new(&g.device, &t, cam.width, cam.height).unwrap();
        submit(g, |e| pass.encode(&g.queue, e, &t, &cam).unwrap());
        let n = (cam.width * hf.height()) as u64;
        let bytes =
            relief_wgpu::read_buffer(&g.device, &g.queue, pass.silhouette_map(), n * 8).unwrap();
        let gpu_map: Vec<f32> = words(&bytes).into_iter().map(f32::from_bits).collect();
        let mut cpu =
            vec![SilhouetteTexel::EMPTY; silhouette_map_len(cam.width, hf.height()).unwrap()];
        silhouette_map(&hf, &cam, 1e-3, &mut cpu).unwrap();
        let s = cam.tan_half_fov();
        let (mut same, mut filled) = (0usize, 0usize);
        for (k, c) in cpu.iter().enumerate() {
            let (gy, gu) = (gpu_map[2 * k], gpu_map[2 * k + 1]);
            let g_empty = gy <= -1e29;
            // GPU y is in tangent units; the core's in pixels up from the bottom edge.
            let gy_px = (gy / s + 1.0) * 0.5 * cam.height as f32;
            let ok = if c.is_empty() || g_empty {
                c.is_empty() == g_empty
            } else {
                filled += 1;
                (gy_px - c.y).abs() <= 1e-2 && (gu - c.u).abs() <= 1e-2
            };
            if ok {
                same += 1;
            }
        }
        let frac = same as f64 / cpu.len() as f64;
        eprintln!(
            "silhouette map {name}: {filled} covered texels, agreement with the core {frac:.6}"
        );
        assert!(filled > cpu.len() / 2, "{name}: {filled}");
        assert!(frac >= 0.999, "{name}: {frac}");
    }
}

#[test]
fn cascade_ray_cast_matches_the_cpu_construction() {
    use relief_core::rbf::{discretize, fit_cascades, CascadeOptions, GridOptions};
    use relief_wgpu::cascade::CascadeRayCast;
    let Some(g) = gpu() else { return };
    let (w, h) = (257, 257);
    let s = synthetic(w, h);
    let scale = Scale::default().with_spacing(2.0, 2.0);
    let hf = Heightfield::with_scale(&s, w, h, scale).unwrap();
    let gopts = GridOptions::default().with_max_error(1.0).with_cells(1, 16);
    let mut store = RbfBuffers::new(&hf, &gopts);
    let (rbf, sets) = store.rbf();
    let cam = Camera::new(
        Vec3::new(20.0, 30.0, 150.0),
        Vec3::new(150.0, 130.0, 0.0),
        60.0,
        160,
        120,
    )
    .unwrap();
    // The heights' own range (what a Renderer with Method::Cascades uses).
    let z_range = s
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    let cas = fit_cascades(
        &cam,
        rbf.grid(),
        &scale,
        z_range,
        &CascadeOptions::default().with_resolution(256),
        None,
    )
    .unwrap();
    let pass = relief_wgpu::rbf::RbfPass::new(&g.device, &rbf, &sets).unwrap();
    let rc =
        CascadeRayCast::new(&g.device, &pass, 256, scale, z_range, cam.width, cam.height).unwrap();
    submit(g, |e| rc.encode(&g.queue, e, &pass, &cas, &cam).unwrap());
    let gd = rc.read_depth(&g.device, &g.queue).unwrap();
    // The same method as a Scene: exactly the four cascade passes, the same image.
    let mut r = Renderer::new(
        &g.device,
        &g.queue,
        &hf,
        Scene::new()
            .with_method(Method::Cascades { resolution: 256 })
            .with_rbf_grid(gopts),
    )
    .unwrap();
    let frame = r.render(&g.device, &g.queue, &cam).unwrap();
    assert_eq!(
        r.last_passes(),
        &[
            PassName::RbfDiscretize,
            PassName::CascadeMaxMip,
            PassName::CascadeRayCast,
            PassName::CascadeBlend
        ]
    );
    assert_eq!(r.cascades(), Some(&cas));
    assert_eq!(frame.depth, gd, "Scene cascades differ from the pass");

    // The same construction on the CPU: discretize, invisible texels on the floor, one max-mip
    // trace per cascade (camera moved to the cascade's origin), then the blend with the core's
    // blend weights (the GPU computes its own in the blend shader).
    let floor = z_range.0 - 10.0 * (z_range.1 - z_range.0) - 1000.0;
    assert_eq!(rc.floor(), floor);
    let mut per = Vec::new();
    for c in &cas.cascades {
        let t = (c.resolution * c.resolution) as usize;
        let (mut mask, mut v, mut wt) = (vec![0u8; t], vec![0f32; t], vec![0f32; t]);
        c.mask(&mut mask).unwrap();
        discretize(&rbf, c, &mask, &mut v, &mut wt).unwrap();
        for (v, m) in v.iter_mut().zip(&mask) {
            if *m == 0 {
                *v = floor;
            }
        }
        let cs = scale.with_spacing(scale.dx * c.spacing, scale.dy * c.spacing);
        let chf = Heightfield::with_scale(&v, c.resolution, c.resolution, cs).unwrap();
        let mut buf = vec![0.0f32; MaxMip::len(c.resolution, c.resolution).unwrap()];
        let mip = MaxMip::build(&chf, &mut buf).unwrap();
        let tracer = RayTracer::new(&chf, Surface::Triangles);
        let o = Vec3::new(
            c.origin[0] as f32 * c.spacing * scale.dx,
            c.origin[1] as f32 * c.spacing * scale.dy,
            0.0,
        );
        let ccam = Camera::new(
            cam.eye - o,
            cam.target - o,
            cam.fov_deg,
            cam.width,
            cam.height,
        )
        .unwrap();
        let (d, _) = cpu_depth(&chf, &ccam, |r| {
            tracer
                .trace_maxmip(r, &mip)
                .unwrap()
                .hit
                .map(|h| (h.t, h.normal))
        });
        per.push((d, wt, *c));
    }
    let weight_at = |k: usize, t: f32, dir: Vec3| -> f32 {
        let (_, wt, c) = &per[k];
        let hit = cam.eye + t * dir;
        let gx = hit.x / scale.dx / c.spacing;
        let gy = hit.y / scale.dy / c.spacing;
        let i = (gx + 0.5).floor() as i64 - c.origin[0];
        let j = (gy + 0.5).floor() as i64 - c.origin[1];
        let r = i64::from(c.resolution);
        if i < 0 || j < 0 || i >= r || j >= r {
            return 0.0;
        }
        wt[(j * r + i) as usize]
    };
    let mut cd = vec![f32::INFINITY; (cam.width * cam.height) as usize];
    let (mut by_cascade, mut blended) = ([0usize; 3], 0usize);
    for jj in 0..cam.height {
        for ii in 0..cam.width {
            let k = (jj * cam.width + ii) as usize;
            let dir = cam.ray(ii, jj).1;
            for c in 0..3 {
                let t = per[c].0[k];
                if !t.is_finite() {
                    continue;
                }
                let wc = weight_at(c, t, dir);
                if wc <= 0.0 {
                    continue;
                }
                let mut d = t;
                if wc < 1.0 && c < 2 {
                    let tn = per[c + 1].0[k];
                    if tn.is_finite() {
                        let wn = weight_at(c + 1, tn, dir);
                        if wn > 0.0 {
                            d = (wc * t + wn * tn) / (wc + wn);
                            blended += 1;
                        }
                    }
                }
                cd[k] = d;
                by_cascade[c] += 1;
                break;
            }
        }
    }
    let hits = cd.iter().filter(|t| t.is_finite()).count();
    assert!(hits > cd.len() / 4, "too few hits {hits}");
    for (k, (d, wt, c)) in per.iter().enumerate() {
        eprintln!(
            "cascade {k}: spacing {} res {} origin {:?} raw hits {} texels w>0 {} near {} far {}",
            c.spacing,
            c.resolution,
            c.origin,
            d.iter().filter(|t| t.is_finite()).count(),
            wt.iter().filter(|w| **w > 0.0).count(),
            c.near,
            c.far
        );
    }
    let (frac, bad) = agreement(&gd, &cd, |i| 1e-3 * f64::from(cd[i]));
    // And how close the RBF cascades come to the exact trace of the heightfield itself.
    let tracer = RayTracer::new(&hf, Surface::Triangles);
    let (exact, _) = cpu_depth(&hf, &cam, |r| {
        tracer.trace_cell_dda(r).hit.map(|h| (h.t, h.normal))
    });
    let (close, _) = agreement(&gd, &exact, |i| 0.02 * f64::from(exact[i]));
    eprintln!(
        "cascade ray cast: hits per cascade {by_cascade:?}, {blended} blended in overlaps; \
         GPU vs CPU construction {frac:.6} ({bad} differ); within 2% of the exact trace {close:.4}"
    );
    assert!(
        by_cascade.iter().all(|&n| n > 100) && blended > 100,
        "{by_cascade:?} {blended}"
    );
    assert!(frac >= 0.999, "{frac} ({bad})");
    assert!(close >= 0.9, "{close}");
}

#[test]
fn water_surface_from_the_rbf_approximation_matches_the_cpu() {
    use relief_core::rbf::GridOptions;
    let Some(g) = gpu() else { return };
    let (w, h) = (129, 129);
    let s = synthetic(w, h);
    let scale = Scale::default().with_spacing(3.0, 3.0);
    let hf = Heightfield::with_scale(&s, w, h, scale).unwrap();
    // A flood's water levels (gentle waves), approximated by the adaptive-grid RBF (seed 002),
    // evaluated at every sample: the water surface.
    let levels: Vec<f32> = (0..w * h)
        .map(|i| 62.0 + 6.0 * ((i % w) as f32 * 0.05).sin())
        .collect();
    let lhf = Heightfield::with_scale(&levels, w, h, scale).unwrap();
    let mut store = RbfBuffers::new(
        &lhf,
        &GridOptions::default().with_max_error(0.5).with_cells(1, 16),
    );
    let (rbf, _) = store.rbf();
    let water: Vec<f32> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            rbf.eval(relief_core::glam::Vec2::new(x as f32, y as f32))
                .unwrap()
        })
        .collect();
    let cam = Camera::new(
        Vec3::new(10.0, 15.0, 160.0),
        Vec3::new(300.0, 280.0, 40.0),
        60.0,
        128,
        96,
    )
    .unwrap();
    let scene = Scene::new()
        .with_effect(Effect::Water)
        .with_water_surface(water.clone());
    let mut r = Renderer::new(&g.device, &g.queue, &hf, scene).unwrap();
    let frame = r.render(&g.device, &g.queue, &cam).unwrap();

    // CPU: the terrain trace, then the same water march (128 samples, 8 bisections) up to it.
    let mut buf = vec![0.0f32; MaxMip::len(w, h).unwrap()];
    let mip = MaxMip::build(&hf, &mut buf).unwrap();
    let tracer = RayTracer::new(&hf, Surface::Triangles);
    let mut cd = Vec::new();
    let (mut water_px, mut terrain_px) = (0, 0);
    for j in 0..cam.height {
        for i in 0..cam.width {
            let (o, d) = cam.ray(i, j);
            let ray = Ray::new(o, d).unwrap();
            let tt = tracer
                .trace_maxmip(&ray, &mip)
                .unwrap()
                .hit
                .map_or(f64::INFINITY, |h| h.t);
            // Local coordinates: grid units horizontally.
            let (o, d) = (o.as_dvec3(), d.as_dvec3());
            let (ol, dl) = ([o.x / 3.0, o.y / 3.0, o.z], [d.x / 3.0, d.y / 3.0, d.z]);
            let tw = relief_wgpu::raycast::water_surface_hit(&water, w, h, ol, dl, tt)
                .unwrap_or(f64::INFINITY);
            if tw < tt {
                water_px += 1;
                cd.push(tw as f32);
            } else {
                if tt.is_finite() {
                    terrain_px += 1;
                }
                cd.push(tt as f32);
            }
        }
    }
    let (frac, bad) = agreement(&frame.depth, &cd, |i| 1e-3 * f64::from(cd[i]));
    eprintln!("water surface: {water_px} water pixels, {terrain_px} terrain pixels; GPU vs CPU {frac:.6} ({bad})");
    assert!(
        water_px > 500 && terrain_px > 500,
        "{water_px} {terrain_px}"
    );
    assert!(frac >= 0.999, "{frac} ({bad})");
}

#[test]
fn pass_times_come_from_gpu_timestamps_when_the_device_has_them() {
    let Some(g) = gpu() else { return };
    let (w, h) = (129, 129);
    let s = synthetic(w, h);
    let hf = Heightfield::new(&s, w, h).unwrap();
    let cam = oblique_view();
    let timing = wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS;
    // headless() asks hardware adapters for timestamps, never CPU ones (lavapipe's do not wait
    // for compute work).
    let cpu_adapter = g.info.device_type == wgpu::DeviceType::Cpu;
    if cpu_adapter {
        assert!(!g.device.features().contains(timing));
    }
    let scene = Scene::new().with_effects(&[Effect::Lighting, Effect::DepthOutput]);
    let reference = Renderer::new(&g.device, &g.queue, &hf, scene.clone())
        .unwrap()
        .render(&g.device, &g.queue, &cam)
        .unwrap();
    // A device of our own with the timestamp features whenever the adapter offers them, so the
    // timestamp path runs on lavapipe too (its magnitudes are only checked on hardware).
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter = pollster::block_on(wgpu::util::initialize_adapter_from_env_or_default(
        &instance, None,
    ))
    .unwrap();
    let supported = adapter.features().contains(timing);
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("timestamps"),
        required_features: if supported {
            timing
        } else {
            wgpu::Features::empty()
        },
        required_limits: adapter.limits(),
        ..Default::default()
    }))
    .unwrap();
    let mut r = Renderer::new(&device, &queue, &hf, scene).unwrap();
    let expected = if supported {
        relief_wgpu::Clock::Gpu
    } else {
        relief_wgpu::Clock::Wall
    };
    assert_eq!(r.clock(), expected);
    for wall in [false, true] {
        if wall {
            r.use_wall_clock();
        }
        let start = std::time::Instant::now();
        let (frame, times) = r.render_profiled(&device, &queue, &cam).unwrap();
        let elapsed = start.elapsed().as_secs_f64() * 1e3;
        let passes: Vec<PassName> = times.iter().map(|t| t.pass).collect();
        assert_eq!(passes, r.last_passes(), "one time per pass, in order");
        let clock = if wall {
            relief_wgpu::Clock::Wall
        } else {
            expected
        };
        assert!(times
            .iter()
            .all(|t| t.clock == clock && t.ms.is_finite() && t.ms >= 0.0));
        let total: f64 = times.iter().map(|t| t.ms).sum();
        eprintln!("{clock:?} pass times {times:?}: {total:.3} ms of {elapsed:.3} ms wall");
        // Recording time: part of the frame's wall time and, on the wall clock, of each pass's.
        let cpu: f64 = times.iter().map(|t| t.cpu_ms).sum();
        assert!(times
            .iter()
            .all(|t| t.cpu_ms.is_finite() && t.cpu_ms >= 0.0));
        assert!(cpu > 0.0 && cpu <= elapsed, "{cpu} ms vs {elapsed} ms");
        if wall {
            assert!(times.iter().all(|t| t.cpu_ms <= t.ms), "{times:?}");
        }
        if clock == relief_wgpu::Clock::Wall || !cpu_adapter {
            assert!(
                total > 0.0 && total <= elapsed,
                "{total} ms vs {elapsed} ms"
            );
        }
        assert_eq!(frame, reference, "profiling must not change the frame");
    }
}

/// A second device on the test adapter with `limits` applied to the adapter's own: it stands
/// in for a smaller GPU.
fn small_gpu(g: &Gpu, limits: impl FnOnce(&mut wgpu::Limits)) -> Gpu {
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter = pollster::block_on(wgpu::util::initialize_adapter_from_env_or_default(
        &instance, None,
    ))
    .unwrap();
    let mut required = adapter.limits();
    limits(&mut required);
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        required_limits: required,
        ..Default::default()
    }))
    .unwrap();
    Gpu {
        device,
        queue,
        info: g.info.clone(),
    }
}

/// A mesh whose vertices or indices exceed the device's `max_buffer_size` is a typed error
/// (wgpu's default handler would panic on the buffer), the last mesh stays drawn, and a buffer
/// grown to the next power of two is capped at the limit (65,532 bytes here, not a power of
/// two).
#[test]
fn mesh_uploads_past_the_buffer_limit_are_errors_and_growth_stops_at_the_limit() {
    let Some(g) = gpu() else { return };
    let small = small_gpu(g, |l| l.max_buffer_size = 65_532);
    let (d, q) = (&small.device, &small.queue);
    let cam = Camera::new(Vec3::new(-10.0, 0.0, 0.0), Vec3::ZERO, 60.0, 64, 64).unwrap();
    let tri = [[0.0f32, -5.0, -5.0], [0.0, 5.0, -5.0], [0.0, 0.0, 5.0]];
    let mut mesh = MeshPass::new(d);
    mesh.upload(d, q, &tri, &[0, 1, 2]).unwrap();
    let first = mesh_depth(&small, &mesh, &cam);
    // Reversed-Z: the cleared depth is 0, a drawn pixel's is positive.
    let covered = first.iter().filter(|&&x| x > 0.0).count();
    assert!(covered > 100, "the triangle covers {covered} pixels");
    let too_large = |r: Result<(), relief_wgpu::Error>, what: &str| match r {
        Err(relief_wgpu::Error::TooLarge { what: w, limit, .. }) => {
            assert_eq!((w, limit), (what, 65_532));
        }
        other => panic!("expected {what} too large, got {other:?}"),
    };
    // 6,000 vertices: 72,000 bytes.
    let many: Vec<[f32; 3]> = tri.iter().copied().cycle().take(6000).collect();
    too_large(mesh.upload(d, q, &many, &[0, 1, 2]), "relief mesh vertices");
    // 17,001 indices: 68,004 bytes.
    let long: Vec<u32> = [0, 1, 2].into_iter().cycle().take(17_001).collect();
    too_large(mesh.upload(d, q, &tri, &long), "relief mesh indices");
    too_large(
        mesh.upload_grid_triangles(d, q, &long),
        "relief mesh indices",
    );
    // An 80 x 80 grid: 76,800 bytes of vertices.
    let s = vec![0.0f32; 80 * 80];
    let hf = Heightfield::new(&s, 80, 80).unwrap();
    too_large(mesh.upload_grid_vertices(d, q, &hf), "relief grid vertices");
    let same = |mesh: &MeshPass| {
        let now = mesh_depth(&small, mesh, &cam);
        now.iter()
            .zip(&first)
            .all(|(a, b)| a.to_bits() == b.to_bits())
    };
    assert!(same(&mesh), "a refused upload changed the mesh drawn");
    // 5,000 vertices, 60,000 bytes: the next power of two (65,536) is over the limit, so the
    // buffer is capped at 65,532 (without the cap wgpu would refuse the buffer).
    let fits: Vec<[f32; 3]> = tri.iter().copied().cycle().take(5000).collect();
    mesh.upload(d, q, &fits, &[0, 1, 2]).unwrap();
    assert!(same(&mesh), "the capped buffer draws another picture");
    // And an empty upload draws nothing.
    mesh.upload(d, q, &[], &[]).unwrap();
    assert!(mesh_depth(&small, &mesh, &cam).iter().all(|&x| x == 0.0));
}

/// Render targets and ray outputs past the device's limits are typed errors, not wgpu's
/// validation panic: a depth target wider than `max_texture_dimension_2d`, ray outputs whose
/// normals (16 bytes a pixel) exceed one storage binding, and a scene with depth output whose
/// image is too wide. The same sizes one step smaller work.
#[test]
fn render_targets_and_ray_outputs_past_the_device_limits_are_errors() {
    let Some(g) = gpu() else { return };
    let small = small_gpu(g, |l| {
        l.max_texture_dimension_2d = 256;
        l.max_storage_buffer_binding_size = 1 << 16;
    });
    let d = &small.device;
    assert!(DepthTarget::new(d, 256, 16).is_ok());
    for (w, h) in [(257, 16), (16, 257), (0, 16)] {
        let r = DepthTarget::new(d, w, h);
        assert!(
            matches!(r, Err(relief_wgpu::Error::Unsupported(_))),
            "{w}x{h}"
        );
    }
    // 64 x 64 pixels: normals 65,536 bytes, the limit; one more row is over. Without normals
    // the depth (4 bytes a pixel) reaches the limit at 64 x 256.
    use relief_wgpu::raycast::RayOutputs;
    assert!(RayOutputs::new(d, 64, 64, true).is_ok());
    assert!(RayOutputs::new(d, 64, 256, false).is_ok());
    for (h, normals, what, bytes) in [
        (65, true, "relief normals out", 66_560),
        (257, false, "relief depth", 65_792),
    ] {
        match RayOutputs::new(d, 64, h, normals) {
            Err(relief_wgpu::Error::TooLarge {
                what: w,
                bytes: b,
                limit,
            }) => {
                assert_eq!((w, b, limit), (what, bytes, 65_536));
            }
            other => panic!("expected TooLarge, got {other:?}"),
        }
    }
    let s = synthetic(33, 33);
    let hf = Heightfield::new(&s, 33, 33).unwrap();
    let scene = Scene::new().with_effects(&[Effect::DepthOutput, Effect::NormalOutput]);
    let mut r = Renderer::new(d, &small.queue, &hf, scene).unwrap();
    let (eye, at) = (Vec3::new(-20.0, -20.0, 60.0), Vec3::new(16.0, 16.0, 0.0));
    let fits = Camera::new(eye, at, 60.0, 64, 16).unwrap();
    // Outputs that fit a binding, a depth target wider than a texture may be.
    let wide = Camera::new(eye, at, 60.0, 300, 4).unwrap();
    // A depth target that fits, normals that do not.
    let tall = Camera::new(eye, at, 60.0, 64, 80).unwrap();
    assert!(r.render(d, &small.queue, &fits).is_ok());
    let e = r.render(d, &small.queue, &wide).unwrap_err();
    assert!(matches!(e, relief_wgpu::Error::Unsupported(_)), "{e}");
    let e = r.render(d, &small.queue, &tall).unwrap_err();
    assert!(matches!(e, relief_wgpu::Error::TooLarge { .. }), "{e}");
    // And the renderer still draws a frame that fits.
    assert!(r.render(d, &small.queue, &fits).is_ok());
    // Without the normal output the tall image fits.
    let scene = Scene::new().with_effect(Effect::DepthOutput);
    let mut r = Renderer::new(d, &small.queue, &hf, scene).unwrap();
    assert!(r.render(d, &small.queue, &tall).is_ok());
    // A terrain takes 4 bytes a sample, its normal map (lit scenes only) 8: 90 x 90 samples
    // (64,800 bytes of gradients) fit a 64 KiB binding lit, 100 x 100 only unlit; 129 x 129
    // (66,564 bytes of heights) not at all.
    let s90 = synthetic(90, 90);
    let hf90 = Heightfield::new(&s90, 90, 90).unwrap();
    let q = &small.queue;
    // A frame of `scene` on the small device and on the test adapter's full one, from above the
    // terrain's corner: the same pixels.
    let on_both = |hf: &Heightfield<'_, f32>, scene: Scene| {
        let n = hf.width() as f32;
        let cam = Camera::new(
            Vec3::new(-20.0, -20.0, n + 10.0),
            Vec3::new(n / 2.0, n / 2.0, 0.0),
            60.0,
            64,
            48,
        )
        .unwrap();
        let frame = |gpu: &Gpu| {
            Renderer::new(&gpu.device, &gpu.queue, hf, scene.clone())
                .unwrap()
                .render(&gpu.device, &gpu.queue, &cam)
                .unwrap()
        };
        let (s, f) = (frame(&small), frame(g));
        assert!(s.depth.iter().any(|z| z.is_finite()));
        assert_eq!((s.depth, s.color), (f.depth, f.color));
    };
    on_both(&hf90, Scene::new().with_effect(Effect::Lighting));
    let s100 = synthetic(100, 100);
    let hf100 = Heightfield::new(&s100, 100, 100).unwrap();
    assert!(Renderer::new(d, q, &hf100, Scene::new()).is_ok());
    let lit = Renderer::new(d, q, &hf100, Scene::new().with_effect(Effect::Lighting));
    assert!(matches!(
        lit,
        Err(relief_wgpu::Error::TooLarge {
            what: "relief normal map",
            ..
        })
    ));
    // 128 x 128 samples: 65,536 bytes of heights fit, their pyramid (21,590 nodes) does not.
    // Only the max-mip method allocates it, so a march scene renders this terrain.
    let s128 = synthetic(128, 128);
    let hf128 = Heightfield::new(&s128, 128, 128).unwrap();
    match GpuTerrain::new(d, q, &hf128, false) {
        Err(relief_wgpu::Error::TooLarge { what, bytes, .. }) => {
            assert_eq!((what, bytes), ("relief maxmip", 86_360));
        }
        other => panic!("expected TooLarge, got {other:?}"),
    }
    assert!(matches!(
        Renderer::new(d, q, &hf128, Scene::new()),
        Err(relief_wgpu::Error::TooLarge {
            what: "relief maxmip",
            ..
        })
    ));
    on_both(&hf128, Scene::new().with_method(Method::march()));
    let s129 = synthetic(129, 129);
    let hf129 = Heightfield::new(&s129, 129, 129).unwrap();
    let big = GpuTerrain::new(d, q, &hf129, false);
    assert!(matches!(
        big,
        Err(relief_wgpu::Error::TooLarge {
            what: "relief heights",
            ..
        })
    ));

    // Four 8 x 8 workgroups along a side: 32 threads. Wider images and terrains are refused
    // before anything is dispatched.
    let few = small_gpu(g, |l| l.max_compute_workgroups_per_dimension = 4);
    let (d, q) = (&few.device, &few.queue);
    assert!(RayOutputs::new(d, 32, 32, true).is_ok());
    for (w, h) in [(33, 8), (8, 33)] {
        let r = RayOutputs::new(d, w, h, false);
        assert!(
            matches!(r, Err(relief_wgpu::Error::Unsupported(_))),
            "{w}x{h}"
        );
    }
    let hf32 = Heightfield::new(&s[..32 * 32], 32, 32).unwrap();
    assert!(GpuTerrain::new(d, q, &hf32, true).is_ok());
    let r = GpuTerrain::new(d, q, &hf, false);
    assert!(matches!(r, Err(relief_wgpu::Error::Unsupported(_))));
    let t = GpuTerrain::new(d, q, &hf32, false).unwrap();
    assert!(NormalPass::new(d, q, &t, NormalMethod::Sobel, None).is_ok());
    // Refined twice: 63 x 63 samples, eight workgroups a side.
    let detail = [0.0f32; 4];
    let r = NormalPass::new_composed(d, q, &t, NormalMethod::Sobel, (&detail, 2, 2), 2);
    assert!(matches!(r, Err(relief_wgpu::Error::Unsupported(_))));
}
