//! `relief trace` on the bundled DEM: every method, the depth file per CONVENTIONS.md, the JSON
//! fields, and one-line errors with exit code 2 on bad input.

mod common;
use common::{assert_one_line_error, bundled, read_f32, relief};

use std::path::{Path, PathBuf};

fn trace(dir: &Path, method: &str, surface: &str, extra: &[&str]) -> (Vec<f32>, serde_json::Value) {
    let out_path: PathBuf = dir.join(format!("{method}-{surface}.f32"));
    let dem = bundled();
    let out_s = out_path.display().to_string();
    let mut args = vec![
        "trace",
        "--dem",
        &dem,
        "--dx",
        "160",
        "--dy",
        "160",
        "--z-scale",
        "0.1",
        "--eye",
        "20000,15000,9000",
        "--target",
        "90000,100000,0",
        "--fov",
        "60",
        "--size",
        "40x24",
        "--method",
        method,
        "--surface",
        surface,
        "--out",
        &out_s,
        "--json",
    ];
    args.extend_from_slice(extra);
    let out = relief(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    let depth = read_f32(&out_path);
    assert_eq!(depth.len(), 40 * 24);
    (depth, v)
}

#[test]
fn all_methods_write_the_same_depth_image() {
    let dir = tempfile::tempdir().unwrap();
    for surface in ["triangles", "bilinear", "plane", "nearest"] {
        let (base, v) = trace(dir.path(), "cell-dda", surface, &[]);
        assert!(base.iter().all(|d| !d.is_nan() && *d > 0.0));
        let hits = base.iter().filter(|d| d.is_finite()).count() as u64;
        assert!(hits > 100 && hits < 40 * 24, "{hits}");
        for key in [
            "rays",
            "hits",
            "preprocess_ms",
            "trace_ms",
            "rays_per_s",
            "cells_visited",
        ] {
            assert!(v.get(key).is_some(), "missing {key}");
        }
        assert_eq!(v["rays"], 960);
        assert_eq!(v["hits"], hits);
        for method in ["run-dda", "maxmip"] {
            let (d, v) = trace(dir.path(), method, surface, &["--threads", "2"]);
            assert_eq!(v["hits"], hits);
            for (a, b) in base.iter().zip(&d) {
                assert_eq!(a.is_finite(), b.is_finite());
                if a.is_finite() {
                    assert!((a - b).abs() <= 1e-5 * a, "{method} {surface}: {a} vs {b}");
                }
            }
        }
    }
    let (d, v) = trace(dir.path(), "march", "triangles", &["--samples", "64"]);
    assert!(d.iter().all(|x| !x.is_nan()));
    assert!(v["march_step_cells_max"].as_f64().unwrap() > 0.0);
}

#[test]
fn bad_input_gives_one_line_and_exit_2() {
    let dem = bundled();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("d.f32").display().to_string();
    let base = |eye: &str, target: &str, size: &str, extra: &[&str]| {
        let mut a = vec![
            "trace", "--dem", &dem, "--eye", eye, "--target", target, "--size", size, "--out", &out,
        ]
        .into_iter()
        .map(String::from)
        .collect::<Vec<_>>();
        a.extend(extra.iter().map(|s| s.to_string()));
        let refs: Vec<&str> = a.iter().map(|s| s.as_str()).collect();
        relief(&refs)
    };
    assert_one_line_error(&base("1,2", "5,5,0", "8x8", &[]), "X,Y,Z");
    assert_one_line_error(&base("1,2,nan", "5,5,0", "8x8", &[]), "finite");
    assert_one_line_error(&base("1,2,3", "5,5,0", "8by8", &[]), "WxH");
    assert_one_line_error(&base("1,2,3", "5,5,0", "0x8", &[]), "at least");
    assert_one_line_error(&base("5,5,10", "5,5,0", "8x8", &[]), "straight");
    assert_one_line_error(&base("1,2,3", "5,5,0", "8x8", &["--fov", "190"]), "fov");
    assert_one_line_error(&base("1,2,3", "5,5,0", "8x8", &["--method", "bvh"]), "bvh");
    assert_one_line_error(
        &base("1,2,3", "5,5,0", "8x8", &["--surface", "cubic"]),
        "cubic",
    );
    assert_one_line_error(
        &base(
            "1,2,3",
            "5,5,0",
            "8x8",
            &["--method", "march", "--samples", "0"],
        ),
        "samples",
    );
    assert_one_line_error(&base("1,2,3", "5,5,0", "8x8", &["--samples", "8"]), "march");
    assert_one_line_error(
        &base("1,2,3", "5,5,0", "8x8", &["--threads", "0"]),
        "threads",
    );
    assert!(!Path::new(&out).exists());
}

#[test]
fn maxmip_packet_and_ray_by_ray_write_identical_images() {
    let dir = tempfile::tempdir().unwrap();
    for surface in ["triangles", "bilinear", "plane", "nearest"] {
        let (p, vp) = trace(dir.path(), "maxmip", surface, &[]);
        let packet = vp["packet"].as_str().unwrap().to_string();
        // The default path: packets (AVX-512 or portable), or on a CPU with AVX2 and without
        // AVX-512 rows as slices to the sixteen-wide walk in AVX2 (two rays interleaved).
        let expect = match wide_kind() {
            "avx2" => ("wide-avx2", "wide-avx2"),
            "avx512" if avx512_packets() => ("avx512", "neighbour"),
            _ => ("portable", "neighbour"),
        };
        assert_eq!((packet.as_str(), vp["walk"].as_str().unwrap()), expect);
        let (s, vs) = trace(dir.path(), "maxmip", surface, &["--no-packet"]);
        assert_eq!(vs["packet"], "off");
        assert_eq!(vs["walk"], "neighbour");
        // Bit for bit; with the same work counters where both take the neighbour walk.
        let bits = |d: &[f32]| d.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&p), bits(&s), "{surface} ({packet})");
        if vp["walk"] == "neighbour" {
            assert_eq!(vp["cells_visited"], vs["cells_visited"]);
            assert_eq!(vp["steps"], vs["steps"]);
        }
        // The sixteen-wide walk, in the best form for this CPU: the same image, the same
        // cells or fewer (cells the rays only touch at a point are skipped), fewer (wider)
        // steps.
        let (w, vw) = trace(dir.path(), "maxmip", surface, &["--no-packet", "--wide"]);
        assert_eq!(vw["walk"], format!("wide-{}", wide_kind()));
        assert_eq!(bits(&w), bits(&s), "{surface} (wide)");
        assert!(vw["cells_visited"].as_u64() <= vs["cells_visited"].as_u64());
        assert!(vw["cells_visited"].as_u64() > Some(0));
        assert!(vw["steps"].as_u64() < vs["steps"].as_u64(), "{vw} {vs}");
    }
    let (_, v) = trace(dir.path(), "cell-dda", "triangles", &[]);
    assert_eq!(v["packet"], "off");
}

#[test]
fn maxmip_every_packet_path_this_cpu_runs_writes_the_same_image() {
    let dir = tempfile::tempdir().unwrap();
    let mut paths = vec![("portable", "neighbour")];
    if wide_kind() != "portable" {
        paths.push(("wide-avx2", "wide-avx2"));
    }
    if avx512_packets() {
        paths.push(("avx512", "neighbour"));
    }
    for surface in ["triangles", "bilinear"] {
        let (s, _) = trace(dir.path(), "maxmip", surface, &["--no-packet"]);
        let bits = |d: &[f32]| d.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for (path, walk) in &paths {
            let (p, v) = trace(dir.path(), "maxmip", surface, &["--packet-path", path]);
            assert_eq!(
                (v["packet"].as_str(), v["walk"].as_str()),
                (Some(*path), Some(*walk))
            );
            assert_eq!(bits(&p), bits(&s), "{surface} ({path})");
        }
    }
}

/// Whether `relief trace` should take the AVX-512 packets by default (AVX-512F and DQ).
fn avx512_packets() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx512f") && std::is_x86_feature_detected!("avx512dq")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The form of the sixteen-wide walk `relief trace --wide` should pick on this CPU.
fn wide_kind() -> &'static str {
    #[cfg(target_arch = "x86_64")]
    {
        if std::is_x86_feature_detected!("avx512f") {
            return "avx512";
        }
        if std::is_x86_feature_detected!("avx2") {
            return "avx2";
        }
    }
    "portable"
}

#[test]
fn march_view_dependent_samples_are_reported() {
    let dir = tempfile::tempdir().unwrap();
    let (_, fixed) = trace(dir.path(), "march", "triangles", &["--samples", "64"]);
    assert_eq!(fixed["samples_mode"], "fixed");
    assert_eq!(fixed["march_samples_mean"], 64.0);
    assert!(fixed.get("min_samples").is_none());
    let (d, v) = trace(
        dir.path(),
        "march",
        "triangles",
        &["--samples", "64", "--view-dependent-samples", "8"],
    );
    assert!(d.iter().all(|x| !x.is_nan()));
    assert_eq!(v["samples_mode"], "view-dependent");
    assert_eq!(v["min_samples"], 8);
    // lerp(8, 64, 1 - |dir.z|) per ray: strictly between the two for this oblique camera.
    let mean = v["march_samples_mean"].as_f64().unwrap();
    assert!(mean > 8.0 && mean < 64.0, "{mean}");

    let dem = bundled();
    let out = dir.path().join("bad.f32").display().to_string();
    let bad = |extra: &[&str]| {
        let mut a = vec![
            "trace", "--dem", &dem, "--eye", "1,2,3", "--target", "5,5,0", "--size", "8x8",
            "--out", &out,
        ];
        a.extend_from_slice(extra);
        relief(&a)
    };
    assert_one_line_error(
        &bad(&[
            "--method",
            "march",
            "--samples",
            "16",
            "--view-dependent-samples",
            "32",
        ]),
        "view-dependent",
    );
    assert_one_line_error(
        &bad(&["--method", "march", "--view-dependent-samples", "0"]),
        "view-dependent",
    );
    assert_one_line_error(&bad(&["--view-dependent-samples", "8"]), "march");
    assert_one_line_error(&bad(&["--method", "run-dda", "--no-packet"]), "maxmip");
    assert_one_line_error(&bad(&["--wide"]), "--no-packet");
    assert_one_line_error(
        &bad(&["--method", "run-dda", "--no-packet", "--wide"]),
        "--no-packet",
    );
    assert_one_line_error(
        &bad(&["--method", "run-dda", "--packet-path", "portable"]),
        "--packet-path",
    );
    assert_one_line_error(
        &bad(&["--no-packet", "--packet-path", "portable"]),
        "--packet-path",
    );
    if !avx512_packets() {
        assert_one_line_error(&bad(&["--packet-path", "avx512"]), "lacks");
    }
    assert!(!Path::new(&out).exists());
}
