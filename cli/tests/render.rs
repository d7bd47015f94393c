//! `relief render`: GPU and CPU depth images agree, JSON lists the passes of the effects named,
//! PNG output, one-line errors with exit code 2 (no adapter, unknown effect, GPU-only methods).
//! Without any GPU adapter the GPU cases print a loud notice and return, unless
//! `RELIEF_REQUIRE_GPU=1` (CI), which makes them fail.

mod common;
use common::{assert_one_line_error, bundled, read_f32, relief_env};

use std::path::Path;

const CAM: [&str; 8] = [
    "--eye",
    "20000,10000,6000",
    "--target",
    "90000,90000,500",
    "--fov",
    "60",
    "--size",
    "160x120",
];

/// Runs `relief render` with `extra`; `None` when the GPU is wanted and no adapter exists
/// (loud skip) unless RELIEF_REQUIRE_GPU=1.
fn render(dir: &Path, name: &str, extra: &[&str]) -> Option<(serde_json::Value, Vec<f32>)> {
    let dem = bundled();
    let png = dir.join(format!("{name}.png")).display().to_string();
    let depth = dir.join(format!("{name}.f32")).display().to_string();
    let mut args = vec![
        "render",
        "--dem",
        &dem,
        "--dx",
        "160",
        "--dy",
        "160",
        "--z-scale",
        "0.1",
        "--json",
        "--out",
        &png,
        "--depth-out",
        &depth,
    ];
    args.extend_from_slice(&CAM);
    args.extend_from_slice(extra);
    let out = relief_env(&args, &[]);
    let err = String::from_utf8_lossy(&out.stderr);
    if out.status.code() == Some(2) && err.contains("no GPU adapter") {
        assert!(
            std::env::var("RELIEF_REQUIRE_GPU").as_deref() != Ok("1"),
            "RELIEF_REQUIRE_GPU=1 but {err}"
        );
        eprintln!("\n!!!!! SKIPPING GPU CLI TEST: {err} !!!!!\n");
        return None;
    }
    assert!(out.status.success(), "{err}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let d = read_f32(Path::new(&depth));
    assert_eq!(d.len(), 160 * 120);
    let png_bytes = std::fs::read(&png).unwrap();
    assert_eq!(&png_bytes[1..4], b"PNG");
    Some((v, d))
}

fn pass_names(v: &serde_json::Value, key: &str) -> Vec<String> {
    v[key]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            assert!(p["ms"].as_f64().unwrap() >= 0.0);
            p["name"].as_str().unwrap().to_string()
        })
        .collect()
}

#[test]
fn gpu_and_cpu_depth_agree_and_json_lists_the_passes() {
    let dir = tempfile::tempdir().unwrap();
    let (cpu, cd) =
        render(dir.path(), "cpu", &["--backend", "cpu"]).expect("the CPU backend needs no adapter");
    assert_eq!(pass_names(&cpu, "passes"), ["trace"]);
    let Some((gpu, gd)) = render(dir.path(), "gpu", &[]) else {
        return;
    };
    assert_eq!(pass_names(&gpu, "setup_passes"), ["maxmip_build"]);
    assert_eq!(pass_names(&gpu, "passes"), ["raycast"]);
    assert_eq!(gpu["width"], 160);
    assert_eq!(gpu["hits"], cpu["hits"]);
    let same = gd
        .iter()
        .zip(&cd)
        .filter(|(g, c)| (g.is_infinite() && c.is_infinite()) || (*g - *c).abs() <= 1e-3 * c.abs())
        .count();
    assert!(
        same as f64 >= 0.999 * cd.len() as f64,
        "{same} of {}",
        cd.len()
    );
    // Effects: lighting adds the normal map once, depth output a per-frame pass.
    let Some((lit, ld)) = render(
        dir.path(),
        "lit",
        &["--effects", "lighting,fog,depth", "--repeat", "2"],
    ) else {
        return;
    };
    assert_eq!(
        pass_names(&lit, "setup_passes"),
        ["maxmip_build", "normal_map"]
    );
    assert_eq!(pass_names(&lit, "passes"), ["raycast", "depth_resolve"]);
    assert_eq!(ld, gd, "lighting and fog do not move the surface");
    let Some((mesh, md)) = render(dir.path(), "mesh", &["--method", "mesh"]) else {
        return;
    };
    assert_eq!(pass_names(&mesh, "passes"), ["refine", "mesh"]);
    // The grid's vertices uploaded once (setup), each frame only its grid indices; the indexed
    // list (the path of grids too large for one device buffer) draws the same picture.
    assert_eq!(
        pass_names(&mesh, "setup_passes"),
        ["preprocess", "grid_vertices"]
    );
    let args = ["--method", "mesh", "--mesh-list"];
    let Some((list, listd)) = render(dir.path(), "mesh_list", &args) else {
        return;
    };
    assert_eq!(pass_names(&list, "setup_passes"), ["preprocess"]);
    assert!(md.iter().any(|d| d.is_finite()), "the mesh covers no pixel");
    assert!(md
        .iter()
        .zip(&listd)
        .all(|(a, b)| a.to_bits() == b.to_bits()));
    assert_eq!(
        read_png(&dir.path().join("mesh.png")),
        read_png(&dir.path().join("mesh_list.png"))
    );
    // Silhouette partitioning needs the terrain in front: a camera south of the map.
    let dem = bundled();
    let png = dir.path().join("sil.png").display().to_string();
    let out = relief_env(
        &[
            "render",
            "--dem",
            &dem,
            "--dx",
            "160",
            "--dy",
            "160",
            "--z-scale",
            "0.1",
            "--eye",
            "82000,-20000,9000",
            "--target",
            "82000,60000,0",
            "--size",
            "160x120",
            "--method",
            "silhouette",
            "--json",
            "--out",
            &png,
        ],
        &[],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        pass_names(&v, "passes"),
        ["silhouette_map", "silhouette_tree", "silhouette_trace"]
    );
    // The CPU backend's silhouette trace (the f64 model of the GPU pass) agrees.
    let depth_of = |backend: &str| -> Vec<f32> {
        let d = dir.path().join(format!("sil_{backend}.f32"));
        let d = d.display().to_string();
        let out = relief_env(
            &[
                "render",
                "--dem",
                &dem,
                "--dx",
                "160",
                "--dy",
                "160",
                "--z-scale",
                "0.1",
                "--eye",
                "82000,-20000,9000",
                "--target",
                "82000,60000,0",
                "--size",
                "160x120",
                "--method",
                "silhouette",
                "--backend",
                backend,
                "--out",
                &png,
                "--depth-out",
                &d,
            ],
            &[],
        );
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        read_f32(Path::new(&d))
    };
    let (sc, sg) = (depth_of("cpu"), depth_of("gpu"));
    let same = sg
        .iter()
        .zip(&sc)
        .filter(|(g, c)| (g.is_infinite() && c.is_infinite()) || (*g - *c).abs() <= 1e-3 * c.abs())
        .count();
    assert!(
        same as f64 >= 0.999 * sc.len() as f64,
        "silhouette CPU vs GPU: {same} of {}",
        sc.len()
    );
    assert!(sc.iter().filter(|d| d.is_finite()).count() > sc.len() / 4);
    // 1025 rows padded to 4^6: six packed tree texels and two silhouette-map texels per pixel.
    assert_eq!(v["reads_per_pixel"], 8);
    assert!(v["hits"].as_u64().unwrap() > 160 * 120 / 4);
    for j in [&gpu, &lit, &mesh, &v] {
        assert!(j["timing"] == "gpu" || j["timing"] == "wall", "{j}");
    }
    assert_eq!(cpu["timing"], "wall");
    // The CPU's recording time of a GPU scene's frame: positive and within the frame's pass
    // times when those are wall-clock (each pass's wall time includes its recording); none for
    // the CPU backend or the mesh method (not a Scene).
    for j in [&gpu, &lit, &v] {
        let rec = j["record_ms"].as_f64().unwrap();
        assert!(rec > 0.0, "{j}");
        if j["timing"] == "wall" {
            assert!(rec <= j["frame_ms"].as_f64().unwrap(), "{j}");
        }
    }
    assert_eq!(cpu["record_ms"], serde_json::Value::Null);
    assert_eq!(mesh["record_ms"], serde_json::Value::Null);
    assert_eq!(gpu["reads_per_pixel"], serde_json::Value::Null);
    // The RBF cascade ray cast (seed 002): its four passes, and a depth image close to the
    // exact ray cast of the DEM it approximates.
    let Some((cas, cas_d)) = render(
        dir.path(),
        "cascades",
        &["--method", "cascades", "--cascade-resolution", "256"],
    ) else {
        return;
    };
    assert_eq!(pass_names(&cas, "setup_passes"), Vec::<String>::new());
    let ks = cas["cascades"].as_array().unwrap();
    assert_eq!(ks.len(), 3);
    for (a, b) in ks.iter().zip(&ks[1..]) {
        assert!(a["spacing"].as_f64() <= b["spacing"].as_f64(), "{a} {b}");
        assert!(a["near"].as_f64() < b["near"].as_f64(), "{a} {b}");
    }
    assert!(ks.iter().all(|k| k["resolution"] == 256));
    assert_eq!(gpu["cascades"], serde_json::Value::Null);
    assert_eq!(
        pass_names(&cas, "passes"),
        [
            "rbf_discretize",
            "cascade_maxmip",
            "cascade_raycast",
            "cascade_blend"
        ]
    );
    let close = cas_d
        .iter()
        .zip(&gd)
        .filter(|(a, e)| (a.is_infinite() && e.is_infinite()) || (*a - *e).abs() <= 0.05 * e.abs())
        .count();
    eprintln!(
        "cascades: {close} of {} pixels within 5% of the exact depth",
        gd.len()
    );
    assert!(
        close as f64 >= 0.9 * gd.len() as f64,
        "{close} of {}",
        gd.len()
    );
}

#[test]
fn no_adapter_unknown_effects_and_silhouette_are_one_line_errors() {
    let dem = bundled();
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("x.png").display().to_string();
    let mut args = vec!["render", "--dem", &dem, "--out", &png];
    args.extend_from_slice(&CAM);
    // dx12 is not compiled in on Linux: wgpu finds no adapter at all.
    let out = relief_env(&args, &[("WGPU_BACKEND", "dx12")]);
    assert_one_line_error(&out, "no GPU adapter");
    let mut bad = args.clone();
    bad.extend_from_slice(&["--effects", "lighting,sparkles"]);
    assert_one_line_error(&relief_env(&bad, &[]), "unknown effect 'sparkles'");
    // The CPU renders silhouettes too, but only with the whole terrain in front (CAM is above
    // the map).
    let mut sil = args.clone();
    sil.extend_from_slice(&["--method", "silhouette", "--backend", "cpu"]);
    assert_one_line_error(
        &relief_env(&sil, &[]),
        "whole terrain in front of the camera",
    );
    let mut cas = args.clone();
    cas.extend_from_slice(&["--method", "cascades", "--backend", "cpu"]);
    assert_one_line_error(&relief_env(&cas, &[]), "need --backend gpu");
    let mut cas_fog = args.clone();
    cas_fog.extend_from_slice(&["--method", "cascades", "--effects", "fog"]);
    let out = relief_env(&cas_fog, &[]);
    if !String::from_utf8_lossy(&out.stderr).contains("no GPU adapter") {
        assert_one_line_error(&out, "take only the depth output effect");
    }
    let mut cpu = args.clone();
    cpu.extend_from_slice(&["--backend", "cpu", "--effects", "depth"]);
    assert_one_line_error(&relief_env(&cpu, &[]), "needs --backend gpu");
    let mut ws = args.clone();
    ws.extend_from_slice(&["--water-surface", "/nonexistent.f32"]);
    assert_one_line_error(&relief_env(&ws, &[]), "needs --effects water");
    assert!(!dir.path().join("x.png").exists());
}

/// On an adapter that lacks optional capabilities (wgpu's GL backend on Mesa cannot copy depth
/// textures, which the mesh method's depth readback needs) every method ends either in a
/// picture or in one line with exit code 2, never in a panic. Without any GL adapter the run is
/// a one-line "no GPU adapter" error, which passes too.
#[test]
fn downlevel_adapter_is_a_one_line_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let dem = bundled();
    let png = dir.path().join("gl.png").display().to_string();
    for method in ["mesh", "maxmip", "march"] {
        let mut args = vec!["render", "--dem", &dem, "--dx", "160", "--dy", "160"];
        args.extend_from_slice(&["--z-scale", "0.1", "--method", method, "--out", &png]);
        args.extend_from_slice(&CAM);
        let out = relief_env(&args, &[("WGPU_BACKEND", "gl")]);
        let err = String::from_utf8_lossy(&out.stderr);
        eprintln!(
            "{method} on WGPU_BACKEND=gl: {:?} {err:?}",
            out.status.code()
        );
        if !out.status.success() {
            assert_one_line_error(&out, "");
        }
    }
}

#[test]
fn water_surface_file_is_rendered_and_checked() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("water.f32");
    // A flat flood at 30 m over the whole bundled map (1025 x 1025 samples).
    let bytes: Vec<u8> = (0..1025 * 1025)
        .flat_map(|_| 30.0f32.to_le_bytes())
        .collect();
    std::fs::write(&path, &bytes).unwrap();
    let p = path.display().to_string();
    let Some((v, d)) = render(
        dir.path(),
        "water",
        &["--effects", "water", "--water-surface", &p],
    ) else {
        return;
    };
    assert!(v["hits"].as_u64().unwrap() > 160 * 120 / 4);
    let Some((_, dry)) = render(dir.path(), "dry", &[]) else {
        return;
    };
    // The water hides low ground: some pixels are nearer than the bare terrain.
    assert!(d.iter().zip(&dry).any(|(w, t)| w < t));
    let short = dir.path().join("short.f32");
    std::fs::write(&short, &bytes[..400]).unwrap();
    let dem = bundled();
    let s = short.display().to_string();
    let png = dir.path().join("y.png").display().to_string();
    let mut args = vec![
        "render",
        "--dem",
        &dem,
        "--out",
        &png,
        "--effects",
        "water",
        "--water-surface",
        &s,
    ];
    args.extend_from_slice(&CAM);
    let out = relief_env(&args, &[]);
    let err = String::from_utf8_lossy(&out.stderr);
    if err.contains("no GPU adapter") {
        return;
    }
    assert_one_line_error(&out, "expected");
}

/// The CPU backend marches a water surface file as the GPU does: the same depths (to `1e-3`)
/// on 99.9% of the pixels, water in front of the terrain on a good share of them, and the
/// surface's waves matter (a flat flood at the mean level gives other depths).
#[test]
fn cpu_backend_renders_a_water_surface_like_the_gpu() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    // Waves of +-12 m around 30 m over the bundled map (1025 x 1025 samples).
    let wave = |i: usize| 30.0 + 12.0 * ((i % 1025) as f32 * 0.02).sin();
    let write = |name: &str, f: &dyn Fn(usize) -> f32| {
        let path = p.join(name);
        let bytes: Vec<u8> = (0..1025 * 1025).flat_map(|i| f(i).to_le_bytes()).collect();
        std::fs::write(&path, bytes).unwrap();
        path.display().to_string()
    };
    let waves = write("waves.f32", &wave);
    let flat = write("flat.f32", &|_| 30.0);
    let water = ["--effects", "water", "--water-surface"];
    let cpu = |name: &str, file: &str| {
        render(
            p,
            name,
            &[&["--backend", "cpu"][..], &water[..], &[file]].concat(),
        )
        .unwrap()
        .1
    };
    let cd = cpu("cpu_waves", &waves);
    let (_, dry) = render(p, "cpu_dry", &["--backend", "cpu"]).unwrap();
    let wet = cd.iter().zip(&dry).filter(|(w, t)| w < t).count();
    assert!(wet > cd.len() / 20, "water in front on only {wet} pixels");
    let fd = cpu("cpu_flat", &flat);
    let moved = cd.len() - same_depth(&cd, &fd, 1e-3);
    assert!(moved > cd.len() / 50, "the waves moved only {moved} pixels");
    let Some((_, gd)) = render(p, "gpu_waves", &[&water[..], &[&waves]].concat()) else {
        return;
    };
    let same = same_depth(&gd, &cd, 1e-3);
    eprintln!(
        "water surface: {wet} wet, {moved} moved by the waves, CPU = GPU on {same} of {}",
        cd.len()
    );
    assert!(
        same as f64 >= 0.999 * cd.len() as f64,
        "water surface: CPU and GPU depth agree on {same} of {}",
        cd.len()
    );
}

fn read_png(path: &Path) -> Vec<[u8; 4]> {
    let dec = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let mut reader = dec.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    buf[..info.buffer_size()]
        .chunks_exact(4)
        .map(|c| [c[0], c[1], c[2], c[3]])
        .collect()
}

/// Pixels where both depths miss, or both hit within `rel` of each other.
fn same_depth(a: &[f32], b: &[f32], rel: f32) -> usize {
    a.iter()
        .zip(b)
        .filter(|(x, y)| (x.is_infinite() && y.is_infinite()) || (*x - *y).abs() <= rel * y.abs())
        .count()
}

#[test]
fn cpu_backend_renders_deformations_water_and_detail_like_the_gpu() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    let (_, plain) = render(p, "cpu_plain", &["--backend", "cpu"]).unwrap();
    let fx = ["--effects", "deformations,water"];
    let (cpu, cd) = render(p, "cpu_fx", &[&["--backend", "cpu"][..], &fx[..]].concat()).unwrap();
    assert_eq!(
        pass_names(&cpu, "passes"),
        ["deform", "maxmip_build", "trace"]
    );
    // The craters and the water really moved the surface.
    let moved = plain.len() - same_depth(&cd, &plain, 1e-3);
    assert!(moved > plain.len() / 50, "only {moved} pixels changed");
    // Detail changes the colour only.
    let (_, dd) = render(
        p,
        "cpu_detail",
        &["--backend", "cpu", "--effects", "detail"],
    )
    .unwrap();
    assert_eq!(dd, plain);
    let (cpu_plain_png, cpu_detail_png) = (
        read_png(&p.join("cpu_plain.png")),
        read_png(&p.join("cpu_detail.png")),
    );
    assert!(
        cpu_plain_png
            .iter()
            .zip(&cpu_detail_png)
            .filter(|(a, b)| a != b)
            .count()
            > 1000
    );
    let Some((gpu, gd)) = render(p, "gpu_fx", &fx) else {
        return;
    };
    assert_eq!(
        pass_names(&gpu, "passes"),
        ["deform", "maxmip_build", "raycast"]
    );
    let same = same_depth(&gd, &cd, 1e-3);
    assert!(
        same as f64 >= 0.999 * cd.len() as f64,
        "deformations + water: CPU and GPU depth agree on {same} of {}",
        cd.len()
    );
    // Without lighting the colour is the height ramp times the detail texel: the backends
    // agree to a few levels nearly everywhere.
    if render(p, "gpu_detail", &["--effects", "detail"]).is_none() {
        return;
    }
    let gpu_png = read_png(&p.join("gpu_detail.png"));
    assert_colours_close(&gpu_png, &cpu_detail_png, "detail");
}

/// At least 99 % of the pixels of `a` and `b` agree to 3 of 255 in every channel.
fn assert_colours_close(a: &[[u8; 4]], b: &[[u8; 4]], what: &str) {
    assert_eq!(a.len(), b.len());
    let close = a
        .iter()
        .zip(b)
        .filter(|(a, b)| a.iter().zip(b.iter()).all(|(x, y)| x.abs_diff(*y) <= 3))
        .count();
    assert!(
        close as f64 >= 0.99 * a.len() as f64,
        "{what}: colours within 3 levels on {close} of {}",
        a.len()
    );
}

/// The CPU backend lights with the GPU's normals: the core's Sobel normal map of the traced
/// heights (the detail composed, the craters applied), sampled as the shader samples its own,
/// so lit colours agree to a few levels nearly everywhere (with the hit triangle's face
/// normal, as before, 85-92 % of the pixels did). Each backend builds only what its scene
/// names: the normal map for lighting, the pyramid for max-mip tracing.
#[test]
fn cpu_backend_lights_like_the_gpu_and_builds_only_what_the_scene_names() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    let (cpu, _) = render(
        p,
        "cpu_march_lit",
        &[
            "--backend",
            "cpu",
            "--method",
            "march",
            "--effects",
            "lighting",
        ],
    )
    .unwrap();
    assert_eq!(pass_names(&cpu, "setup_passes"), ["normal_map"]);
    let (cpu, _) = render(p, "cpu_march", &["--backend", "cpu", "--method", "march"]).unwrap();
    assert!(pass_names(&cpu, "setup_passes").is_empty());
    for (k, effects) in [
        "lighting",
        "lighting,detail",
        "lighting,deformations,shadows",
    ]
    .into_iter()
    .enumerate()
    {
        let (cpu, cd) = render(
            p,
            &format!("cpu_lit{k}"),
            &["--backend", "cpu", "--effects", effects],
        )
        .unwrap();
        let built = if effects.contains("deformations") {
            pass_names(&cpu, "passes")
        } else {
            pass_names(&cpu, "setup_passes")
        };
        assert!(
            built.contains(&"normal_map".to_string()),
            "{effects}: {built:?}"
        );
        let Some((gpu, gd)) = render(p, &format!("gpu_lit{k}"), &["--effects", effects]) else {
            return;
        };
        let key = if effects.contains("deformations") {
            "passes"
        } else {
            "setup_passes"
        };
        assert!(pass_names(&gpu, key).contains(&"normal_map".to_string()));
        let same = same_depth(&gd, &cd, 1e-3);
        assert!(
            same as f64 >= 0.999 * cd.len() as f64,
            "{effects}: depth agrees on {same}"
        );
        let (c, g) = (
            read_png(&p.join(format!("cpu_lit{k}.png"))),
            read_png(&p.join(format!("gpu_lit{k}.png"))),
        );
        assert_colours_close(&c, &g, effects);
    }
}

/// Images past what the adapter holds in one texture side (`--method mesh`, depth output), in
/// one storage buffer binding (the ray casters' per-pixel outputs, 16 bytes a pixel for the
/// normals) or in one dispatch end in one line with exit code 2, not in wgpu's validation
/// panic. On an adapter
/// large enough (not lavapipe, whose limits are a 16384 texture side and a 128 MiB binding)
/// they may render instead; a run without any adapter is a one-line error too.
#[test]
fn images_too_large_for_the_adapter_are_one_line_errors_not_panics() {
    let dir = tempfile::tempdir().unwrap();
    let dem = bundled();
    let png = dir.path().join("big.png").display().to_string();
    let cases: [(&str, &[&str]); 5] = [
        ("20000x64", &["--method", "mesh"]),
        ("20000x64", &["--effects", "depth"]),
        ("8192x8192", &["--method", "cascades"]),
        ("8192x8192", &["--method", "maxmip"]),
        // 125,000 workgroups of 8 x 8 along x: past every adapter's 65,535.
        ("1000000x2", &["--method", "march"]),
    ];
    for (size, extra) in cases {
        let mut args = vec!["render", "--dem", &dem, "--dx", "160", "--dy", "160"];
        args.extend_from_slice(&["--z-scale", "0.1", "--out", &png, "--size", size]);
        args.extend_from_slice(&["--eye", "82000,-20000,9000", "--target", "82000,60000,0"]);
        args.extend_from_slice(extra);
        let out = relief_env(&args, &[]);
        let err = String::from_utf8_lossy(&out.stderr);
        eprintln!("{size} {extra:?}: {:?} {err:?}", out.status.code());
        if !out.status.success() {
            assert_one_line_error(&out, "");
            assert!(
                err.contains("no GPU adapter")
                    || err.contains("this device allows")
                    || err.contains("max_texture_dimension_2d")
                    || err.contains("max_compute_workgroups_per_dimension"),
                "{err}"
            );
        }
    }
}

/// `--effects normals --normals-out` writes three f32 a pixel: unit normals facing up where the
/// depth image hits, zeros where it misses; the picture and depth are those of the scene
/// without the effect, and the CPU backend writes the same normals. Without the effect the
/// option is refused.
#[test]
fn normals_out_writes_the_hits_normals_only_when_the_effect_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let nf = dir.path().join("n.f32").display().to_string();
    let Some((v, d)) = render(
        dir.path(),
        "normals",
        &["--effects", "normals", "--normals-out", &nf],
    ) else {
        return;
    };
    assert_eq!(v["effects"], serde_json::json!(["normals"]));
    let Some((_, bare)) = render(dir.path(), "bare", &[]) else {
        return;
    };
    assert!(d.iter().zip(&bare).all(|(a, b)| a.to_bits() == b.to_bits()));
    assert_eq!(
        read_png(&dir.path().join("normals.png")),
        read_png(&dir.path().join("bare.png"))
    );
    let n = read_f32(Path::new(&nf));
    assert_eq!(n.len(), 3 * d.len());
    let hits = d.iter().filter(|x| x.is_finite()).count();
    assert!(hits > d.len() / 4, "{hits} hits");
    for (p, t) in n.chunks_exact(3).zip(&d) {
        let len = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        if t.is_finite() {
            assert!((len - 1.0).abs() < 1e-4 && p[2] > 0.0, "{p:?}");
        } else {
            assert_eq!(p, [0.0; 3]);
        }
    }
    // The CPU backend: the same normals on the pixels where both hit the same point.
    let cf = dir.path().join("c.f32").display().to_string();
    let Some((_, cd)) = render(
        dir.path(),
        "cpu",
        &[
            "--backend",
            "cpu",
            "--effects",
            "normals",
            "--normals-out",
            &cf,
        ],
    ) else {
        return;
    };
    let c = read_f32(Path::new(&cf));
    let (mut both, mut same) = (0, 0);
    for (((p, q), t), u) in n.chunks_exact(3).zip(c.chunks_exact(3)).zip(&d).zip(&cd) {
        if !u.is_finite() {
            assert_eq!(q, [0.0; 3]);
        } else if t.is_finite() && (t - u).abs() <= 1e-3 * u {
            both += 1;
            same += usize::from(p[0] * q[0] + p[1] * q[1] + p[2] * q[2] > 0.9999);
        }
    }
    assert!(both > hits * 9 / 10, "{both} of {hits} hits agree in depth");
    assert!(same * 1000 >= both * 995, "{same} of {both} normals agree");
    let dem = bundled();
    let png = dir.path().join("x.png").display().to_string();
    let mut args = vec!["render", "--dem", &dem, "--out", &png];
    args.extend_from_slice(&CAM);
    args.extend_from_slice(&["--normals-out", &nf]);
    assert_one_line_error(&relief_env(&args, &[]), "--effects normals");
}
