//! `relief info` on the bundled DEM, on the real DEMs beside the repository, and on bad input.

mod common;
use common::{assert_one_line_error, bundled, relief, repo};

#[test]
fn info_on_bundled_dem_json() {
    let dem = bundled();
    let out = relief(&[
        "info",
        "--dem",
        &dem,
        "--z-scale",
        "0.1",
        "--dx",
        "160",
        "--dy",
        "160",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["width"], 1025);
    assert_eq!(v["height"], 1025);
    assert!((v["min"].as_f64().unwrap() - 0.0).abs() < 1e-9);
    assert!((v["max"].as_f64().unwrap() - 4379.8).abs() < 1e-3);
    let mean = v["mean"].as_f64().unwrap();
    assert!(mean > 0.0 && mean < 4379.8);
    assert_eq!(v["nodata_count"], 0);
    assert_eq!(v["dx"], 160.0);
    assert_eq!(v["format"], "png");
}

#[test]
fn info_text_output() {
    let out = relief(&["info", "--dem", &bundled()]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("1025 x 1025"), "{text}");
    assert!(text.contains("43798.000"), "{text}");
}

#[test]
fn info_on_every_shared_dem() {
    let d = repo().join("../shared/data");
    if !d.is_dir() {
        eprintln!("skipping: ../shared/data not found beside the repository");
        return;
    }
    // (file, format flag, width, height, min, max) per ../shared/data/README.md.
    let cases = [
        (
            "martini_fuji.png",
            Some("terrain-rgb"),
            512,
            512,
            13.7,
            3751.0,
        ),
        (
            "delatin_14-2625-6369.png",
            Some("terrain-rgb"),
            512,
            512,
            19.0,
            251.8,
        ),
        (
            "pymartini_mapbox_st_helens.png",
            Some("terrain-rgb"),
            256,
            256,
            1002.0,
            1164.2,
        ),
        (
            "pymartini_terrarium.png",
            Some("terrarium"),
            256,
            256,
            715.2,
            2489.0,
        ),
        ("diligent_ps_height_1k.png", None, 1025, 1025, 0.0, 43798.0),
        (
            "topotoolbox_srtm_bigtujunga30m_utm11.tif",
            None,
            1197,
            643,
            315.0,
            2295.0,
        ),
        ("pysheds_dem.tif", None, 367, 359, 147.0, 298.0),
    ];
    for (file, format, w, h, min, max) in cases {
        let path = d.join(file).display().to_string();
        let mut args = vec!["info", "--dem", path.as_str(), "--json"];
        if let Some(f) = format {
            args.extend(["--format", f]);
        }
        let out = relief(&args);
        assert!(
            out.status.success(),
            "{file}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(
            (v["width"].as_u64(), v["height"].as_u64()),
            (Some(w), Some(h)),
            "{file}"
        );
        let (lo, hi) = (v["min"].as_f64().unwrap(), v["max"].as_f64().unwrap());
        assert!(
            (lo - min).abs() < 0.06 && (hi - max).abs() < 0.06,
            "{file}: {lo}..{hi}"
        );
    }
}

#[test]
fn bad_input_gives_one_line_and_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).display().to_string();
    // Truncated PNG: the first 5000 bytes of the bundled DEM.
    let png = std::fs::read(bundled()).unwrap();
    std::fs::write(p("cut.png"), &png[..5000]).unwrap();
    std::fs::write(p("empty.png"), b"").unwrap();
    std::fs::write(p("text.dat"), b"hello").unwrap();
    let nan: Vec<u8> = [1.0f32, f32::NAN, 3.0, 4.0]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    std::fs::write(p("nan.f32"), &nan).unwrap();
    let big: Vec<u8> = [1.0f32, 1e38, 3.0, 4.0]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    std::fs::write(p("big.f32"), &big).unwrap();
    let dem = bundled();
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec!["info".into(), "--dem".into(), p("missing.png")],
            "No such file",
        ),
        (
            vec!["info".into(), "--dem".into(), p("cut.png")],
            "cannot decode png",
        ),
        (
            vec!["info".into(), "--dem".into(), p("empty.png")],
            "cannot decode png",
        ),
        (
            vec!["info".into(), "--dem".into(), p("text.dat")],
            "cannot tell the format",
        ),
        (
            vec![
                "info".into(),
                "--dem".into(),
                dem.clone(),
                "--format".into(),
                "terrarium".into(),
            ],
            "terrarium needs",
        ),
        (
            vec![
                "info".into(),
                "--dem".into(),
                dem.clone(),
                "--format".into(),
                "tiff".into(),
            ],
            "cannot decode tiff",
        ),
        (
            vec![
                "info".into(),
                "--dem".into(),
                dem.clone(),
                "--format".into(),
                "jpeg".into(),
            ],
            "unknown format",
        ),
        (
            vec![
                "info".into(),
                "--dem".into(),
                dem.clone(),
                "--width".into(),
                "1024".into(),
            ],
            "size mismatch",
        ),
        (
            vec![
                "info".into(),
                "--dem".into(),
                p("nan.f32"),
                "--width".into(),
                "2".into(),
                "--height".into(),
                "2".into(),
            ],
            "x=1, y=0",
        ),
        (
            vec![
                "info".into(),
                "--dem".into(),
                p("nan.f32"),
                "--width".into(),
                "3".into(),
                "--height".into(),
                "2".into(),
            ],
            "size mismatch",
        ),
        (
            vec![
                "info".into(),
                "--dem".into(),
                p("nan.f32"),
                "--format".into(),
                "raw-f32".into(),
            ],
            "--width and --height",
        ),
        (
            vec![
                "info".into(),
                "--dem".into(),
                p("nan.f32"),
                "--width".into(),
                "0".into(),
                "--height".into(),
                "2".into(),
            ],
            "must be positive",
        ),
        (
            vec![
                "info".into(),
                "--dem".into(),
                p("big.f32"),
                "--width".into(),
                "2".into(),
                "--height".into(),
                "2".into(),
            ],
            "x=1, y=0",
        ),
        (
            vec![
                "info".into(),
                "--dem".into(),
                dem.clone(),
                "--dx".into(),
                "0".into(),
            ],
            "invalid dx",
        ),
        (
            vec![
                "info".into(),
                "--dem".into(),
                dem.clone(),
                "--dy".into(),
                "-3".into(),
            ],
            "invalid dy",
        ),
        (
            vec![
                "info".into(),
                "--dem".into(),
                dem.clone(),
                "--z-scale".into(),
                "NaN".into(),
            ],
            "invalid z_scale",
        ),
        (
            vec![
                "info".into(),
                "--dem".into(),
                dem.clone(),
                "--z-scale".into(),
                "1e38".into(),
            ],
            "invalid z_scale: 1000",
        ),
        (
            vec![
                "info".into(),
                "--dem".into(),
                dem.clone(),
                "--nodata".into(),
                "nan".into(),
            ],
            "nodata",
        ),
        (
            vec![
                "info".into(),
                "--dem".into(),
                dem.clone(),
                "--nodata".into(),
                "0".into(),
            ],
            "--fill",
        ),
        (
            vec![
                "info".into(),
                "--dem".into(),
                dem.clone(),
                "--fill".into(),
                "zero".into(),
            ],
            "unknown fill",
        ),
        (
            vec![
                "info".into(),
                "--dem".into(),
                dir.path().display().to_string(),
            ],
            "directory",
        ),
        (vec!["info".into()], "--dem"),
        (
            vec!["info".into(), "--dem".into(), dem.clone(), "--bogus".into()],
            "--bogus",
        ),
        (vec!["frobnicate".into()], "frobnicate"),
    ];
    for (args, needle) in cases {
        let a: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = relief(&a);
        assert_one_line_error(&out, needle);
    }
}

#[test]
fn nodata_fill_policies_through_the_cli() {
    let dem = bundled();
    // Sea level (0) as no-data: the bundled map has many zero samples.
    let out = relief(&[
        "info", "--dem", &dem, "--nodata", "0", "--fill", "min", "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v["nodata_count"].as_u64().unwrap() > 0);
    assert!(v["min"].as_f64().unwrap() > 0.0);
    let out = relief(&[
        "info", "--dem", &dem, "--nodata", "0", "--fill", "nearest", "--json",
    ]);
    assert!(out.status.success());
}
