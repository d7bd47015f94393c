//! `relief diagram`: every kind writes a PNG equal to the library's drawing of the same core
//! state; bad input is one line on stderr and exit code 2.

mod common;
use common::relief;

use relief_core::glam::DVec2;
use relief_core::refine::{preprocess, Criterion};
use relief_core::Heightfield;
use relief_skia::dda::DdaSpec;
use relief_skia::refine::RefineInput;
use relief_skia::{hillshade, DiagramOptions, HillshadeOptions, Pixmap};
use std::path::Path;
use std::process::Output;

const W: u32 = 33;

fn samples() -> Vec<f32> {
    (0..W * W)
        .map(|i| {
            let (x, y) = ((i % W) as f32, (i / W) as f32);
            10.0 * (-((x - 12.0).powi(2) + (y - 15.0).powi(2)) / 40.0).exp() + 0.1 * x
        })
        .collect()
}

fn write_dem(dir: &Path) -> String {
    let p = dir.join("dem.f32");
    let bytes: Vec<u8> = samples().iter().flat_map(|v| v.to_le_bytes()).collect();
    std::fs::write(&p, bytes).unwrap();
    p.to_str().unwrap().to_string()
}

fn base_args<'a>(kind: &'a str, dem: &'a str, out: &'a str) -> Vec<&'a str> {
    vec![
        "diagram",
        kind,
        "--dem",
        dem,
        "--format",
        "raw-f32",
        "--width",
        "33",
        "--height",
        "33",
        "--max-size",
        "200",
        "--out",
        out,
    ]
}

fn ok(o: &Output) {
    assert!(
        o.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
fn refine_matches_the_library() {
    let dir = tempfile::tempdir().unwrap();
    let dem = write_dem(dir.path());
    let out = dir.path().join("r.png");
    let out_s = out.to_str().unwrap();
    let mut args = base_args("refine", &dem, out_s);
    args.extend(["--max-error", "0.5", "--circle-level", "7", "--json"]);
    let o = relief(&args);
    ok(&o);
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(json["diagram"], "refine");
    let s = samples();
    let hf = Heightfield::new(&s, W, W).unwrap();
    let (mut e, mut r) = (vec![0.0; (W * W) as usize], vec![0.0; (W * W) as usize]);
    let h = preprocess(&hf, &mut e, &mut r).unwrap();
    let input = RefineInput::new(&hf, &h, Criterion::MaxError(0.5)).with_circle_level(Some(7));
    let st = relief_skia::refine::refine_state(&input).unwrap();
    assert_eq!(json["triangles"], st.triangles.len());
    let base = hillshade(&hf, &HillshadeOptions::default()).unwrap();
    let expected = relief_skia::refine::refine(
        &input,
        &DiagramOptions::default()
            .with_max_size(200)
            .with_background(Some(&base)),
    )
    .unwrap();
    assert_eq!(Pixmap::load_png(&out).unwrap(), expected);
}

#[test]
fn strip_matches_the_library() {
    use relief_skia::strip::{strip, strip_state, StripKind};
    let dir = tempfile::tempdir().unwrap();
    let dem = write_dem(dir.path());
    let s = samples();
    let hf = Heightfield::new(&s, W, W).unwrap();
    let (mut e, mut r) = (vec![0.0; (W * W) as usize], vec![0.0; (W * W) as usize]);
    let h = preprocess(&hf, &mut e, &mut r).unwrap();
    let input = RefineInput::new(&hf, &h, Criterion::MaxError(0.5));
    let base = hillshade(&hf, &HillshadeOptions::default()).unwrap();
    for (kind, flag) in [(StripKind::InOut, None), (StripKind::Soar, Some("--soar"))] {
        let out = dir.path().join("s.png");
        let out_s = out.to_str().unwrap();
        let mut args = base_args("strip", &dem, out_s);
        args.extend(["--max-error", "0.5", "--json"]);
        args.extend(flag);
        let o = relief(&args);
        ok(&o);
        let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(json["diagram"], "strip");
        let st = strip_state(&input, kind).unwrap();
        assert_eq!(json["triangles"], st.triangles.len());
        assert_eq!(json["indices"], st.counts.indices);
        assert_eq!(json["tested"], st.counts.tested);
        assert_eq!(json["joins"], 0); // a square grid: one piece
        let opts = DiagramOptions::default()
            .with_max_size(200)
            .with_background(Some(&base));
        let expected = strip(&input, kind, &opts).unwrap();
        assert_eq!(Pixmap::load_png(&out).unwrap(), expected);
    }
}

#[test]
fn dda_matches_the_library() {
    let dir = tempfile::tempdir().unwrap();
    let dem = write_dem(dir.path());
    let out = dir.path().join("d.png");
    let out_s = out.to_str().unwrap();
    let mut args = base_args("dda", &dem, out_s);
    args.extend([
        "--ray-start",
        "0,0",
        "--ray-dir",
        "41,17",
        "--ray-stop",
        "32,13.27",
        "--json",
    ]);
    let o = relief(&args);
    ok(&o);
    let spec = DdaSpec {
        start: DVec2::ZERO,
        dir: DVec2::new(41.0, 17.0),
        stop: DVec2::new(32.0, 13.27),
        cells: [W - 1, W - 1],
    };
    let s = samples();
    let hf = Heightfield::new(&s, W, W).unwrap();
    let base = hillshade(&hf, &HillshadeOptions::default()).unwrap();
    let expected = relief_skia::dda::dda(
        &spec,
        &DiagramOptions::default()
            .with_max_size(200)
            .with_background(Some(&base)),
    )
    .unwrap();
    assert_eq!(Pixmap::load_png(&out).unwrap(), expected);
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let seq = json["run_sequence"].as_str().unwrap();
    assert!(seq.starts_with("lslslss"), "{seq}");
}

#[test]
fn rbf_and_cascades_write_pictures() {
    let dir = tempfile::tempdir().unwrap();
    let dem = write_dem(dir.path());
    let out = dir.path().join("rbf.png");
    let out_s = out.to_str().unwrap();
    let mut args = base_args("rbf", &dem, out_s);
    args.extend(["--at", "12,15", "--at", "30,2", "--rbf-max-error", "0.3"]);
    ok(&relief(&args));
    let a = Pixmap::load_png(&out).unwrap();
    let out2 = dir.path().join("rbf2.png");
    let mut args = base_args("rbf", &dem, out2.to_str().unwrap());
    args.extend(["--at", "12,15", "--at", "30,2", "--rbf-max-error", "3"]);
    ok(&relief(&args));
    assert_ne!(a, Pixmap::load_png(&out2).unwrap());
    let out3 = dir.path().join("c.png");
    let mut args = base_args("cascades", &dem, out3.to_str().unwrap());
    args.extend([
        "--eye=-5,10,15",
        "--target",
        "20,20,0",
        "--resolution",
        "32",
    ]);
    ok(&relief(&args));
    assert!(Pixmap::load_png(&out3).unwrap().width() >= 200);
}

#[test]
fn silhouette_matches_the_library() {
    let dir = tempfile::tempdir().unwrap();
    let dem = write_dem(dir.path());
    let out = dir.path().join("s.png");
    let mut args = base_args("silhouette", &dem, out.to_str().unwrap());
    args.extend([
        "--eye=16,-20,15",
        "--target",
        "16,20,0",
        "--size",
        "120x80",
        "--levels",
        "1,4",
    ]);
    ok(&relief(&args));
    let s = samples();
    let hf = Heightfield::new(&s, W, W).unwrap();
    let cam = relief_core::Camera::new(
        relief_core::glam::Vec3::new(16.0, -20.0, 15.0),
        relief_core::glam::Vec3::new(16.0, 20.0, 0.0),
        60.0,
        120,
        80,
    )
    .unwrap();
    let expected = relief_skia::silhouette::silhouette(
        &hf,
        &cam,
        0.01,
        &[1, 4],
        &DiagramOptions::default().with_max_size(200),
    )
    .unwrap();
    assert_eq!(Pixmap::load_png(&out).unwrap(), expected);
}

fn fails(args: &[&str], needle: &str) {
    let o = relief(args);
    assert_eq!(o.status.code(), Some(2), "{args:?}");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains(needle), "{err}");
}

#[test]
fn bad_input_is_one_line_and_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let dem = write_dem(dir.path());
    let out = dir.path().join("x.png");
    let out_s = out.to_str().unwrap();
    fails(&base_args("dda", &dem, out_s), "--ray-start");
    let mut a = base_args("dda", &dem, out_s);
    a.extend(["--ray-start", "0,nan", "--ray-dir", "1,1"]);
    fails(&a, "error");
    fails(&base_args("cascades", &dem, out_s), "--eye");
    fails(&base_args("silhouette", &dem, out_s), "--eye");
    let mut a = base_args("silhouette", &dem, out_s);
    a.extend(["--eye=16,-20,15", "--target", "16,20,0", "--levels", "40"]);
    fails(&a, "level");
    let mut a = base_args("refine", &dem, out_s);
    a.extend(["--crop", "30,30,10,10"]);
    fails(&a, "--crop");
    let mut a = base_args("rbf", &dem, out_s);
    a.extend(["--at", "99,99"]);
    fails(&a, "outside");
    fails(
        &["diagram", "wobble", "--dem", &dem, "--out", out_s],
        "wobble",
    );
    fails(
        &[
            "diagram",
            "refine",
            "--dem",
            &dem,
            "--format",
            "raw-f32",
            "--width",
            "33",
            "--height",
            "33",
            "--max-size",
            "5",
            "--out",
            out_s,
        ],
        "too large",
    );
    assert!(!out.exists(), "no file is written on failure");
}

#[test]
fn bundled_dem_refine_and_rbf() {
    let dem = concat!(env!("CARGO_MANIFEST_DIR"), "/../data/puget_sound_1k.png");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p.png");
    let out_s = out.to_str().unwrap();
    let o = relief(&[
        "diagram",
        "refine",
        "--dem",
        dem,
        "--dx",
        "160",
        "--dy",
        "160",
        "--z-scale",
        "0.1",
        "--crop",
        "0,0,129,129",
        "--eye=-2000,-2000,3000",
        "--target",
        "10000,10000,0",
        "--pixel-error",
        "3",
        "--circle-level",
        "8",
        "--max-size",
        "300",
        "--out",
        out_s,
        "--json",
    ]);
    ok(&o);
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(json["triangles"].as_u64().unwrap() > 2);
    assert!(Pixmap::load_png(&out).unwrap().width() >= 300);
    let o = relief(&[
        "diagram",
        "rbf",
        "--dem",
        dem,
        "--z-scale",
        "0.1",
        "--crop",
        "256,256,128,128",
        "--at",
        "64,64",
        "--max-size",
        "300",
        "--out",
        out_s,
        "--json",
    ]);
    ok(&o);
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(json["cells"].as_u64().unwrap() > 1);
}
