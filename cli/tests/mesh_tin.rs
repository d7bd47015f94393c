//! `relief mesh --method tin`: OBJ and JSON on the bundled DEM, vertex budgets, and bad input as
//! one line on stderr with exit code 2.

mod common;
use common::{bundled, json, read_obj, relief};

use relief_tin::{Tin, TinOptions};
use std::path::Path;

const SCALE: [&str; 6] = ["--dx", "160", "--dy", "160", "--z-scale", "0.1"];

#[test]
fn tin_mesh_of_the_bundled_dem_meets_the_error() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("tin.obj");
    let dem = bundled();
    let mut args = vec!["mesh", "--method", "tin", "--dem", &dem];
    args.extend(SCALE);
    args.extend([
        "--max-error",
        "50",
        "--out",
        out.to_str().unwrap(),
        "--json",
    ]);
    let j = json(&relief(&args));
    let measured = j["max_error_measured"].as_f64().unwrap();
    assert!(measured <= 50.0, "{measured}");
    assert!(j["rms_error"].as_f64().unwrap() <= measured);
    assert!(j["refine_ms"].as_f64().unwrap() > 0.0);
    assert_eq!(j["preprocess_ms"].as_f64(), Some(0.0));
    // The same mesh as the library builds, written in world units.
    let mut d = relief_io::read_dem(Path::new(&dem), &Default::default()).unwrap();
    d.scale = d.scale.with_spacing(160.0, 160.0).with_z_scale(0.1);
    let hf = d.heightfield().unwrap();
    let tin = Tin::build(&hf, &TinOptions::default().with_max_error(50.0)).unwrap();
    let (v, f) = read_obj(&out);
    assert_eq!(j["vertices"].as_u64(), Some(v.len() as u64));
    assert_eq!(j["triangles"].as_u64(), Some(f.len() as u64));
    assert_eq!(v.len(), tin.vertices().len());
    assert_eq!(f, tin.triangles());
    assert_eq!(measured, tin.max_error());
    for (p, q) in v.iter().zip(tin.positions(&hf)) {
        assert_eq!(*p, q);
    }
    // The crack checker of the cross-crate tests agrees that the mesh tiles the domain.
    let o = relief_tests::mesh_check::CheckOptions::grid(d.width, d.height, 160.0, 160.0);
    let r = relief_tests::mesh_check::check_mesh(&v, &f, &o).unwrap();
    assert_eq!(r.triangles, f.len());
}

#[test]
fn tin_vertex_budget() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("tin.obj");
    let dem = bundled();
    let o = relief(&[
        "mesh",
        "--method",
        "tin",
        "--dem",
        &dem,
        "--max-vertices",
        "500",
        "--out",
        out.to_str().unwrap(),
        "--json",
    ]);
    let j = json(&o);
    assert_eq!(j["vertices"].as_u64(), Some(500));
    assert_eq!(j["stop"].as_str(), Some("vertex-budget"));
    assert_eq!(read_obj(&out).0.len(), 500);
}

#[test]
fn tin_bad_input_is_one_line_and_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("tin.obj");
    let out = out.to_str().unwrap();
    let dem = bundled();
    for extra in [
        vec![],
        vec!["--max-error", "NaN"],
        vec!["--max-error", "-1"],
        vec!["--max-vertices", "2"],
        vec![
            "--max-error",
            "1",
            "--eye",
            "0,0,1000",
            "--target",
            "1,1,0",
            "--size",
            "8x8",
            "--pixel-error",
            "1",
        ],
    ] {
        let mut args = vec!["mesh", "--method", "tin", "--dem", &dem, "--out", out];
        args.extend(extra.iter().copied());
        let o = relief(&args);
        assert_eq!(o.status.code(), Some(2), "{extra:?}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(err.starts_with("relief: error: "), "{err}");
    }
    assert!(!Path::new(out).exists());
    // --max-vertices belongs to the TIN.
    let o = relief(&["mesh", "--dem", &dem, "--max-vertices", "9", "--out", out]);
    assert_eq!(o.status.code(), Some(2));
}
