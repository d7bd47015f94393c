//! `relief mesh` (SOAR refinement): OBJ and JSON agree, the measured error is within E, the
//! view-dependent form runs, and bad input is one line on stderr with exit code 2.

mod common;
use common::{json, relief};

use std::path::Path;

fn write_dem(dir: &Path, w: u32, h: u32) -> String {
    let p = dir.join(format!("dem_{w}x{h}.f32"));
    let bytes: Vec<u8> = (0..w * h)
        .flat_map(|i| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            let z = 40.0 * (-((x - 12.0).powi(2) + (y - 9.0).powi(2)) / 60.0).exp()
                + 3.0 * (x * 0.7).sin() * (y * 0.4).cos();
            z.to_le_bytes()
        })
        .collect();
    std::fs::write(&p, bytes).unwrap();
    p.to_str().unwrap().to_string()
}

fn obj_counts(p: &Path) -> (usize, usize) {
    let s = std::fs::read_to_string(p).unwrap();
    (
        s.lines().filter(|l| l.starts_with("v ")).count(),
        s.lines().filter(|l| l.starts_with("f ")).count(),
    )
}

#[test]
fn view_independent_mesh_writes_obj_and_stays_within_e() {
    let dir = tempfile::tempdir().unwrap();
    for (w, h, square) in [(33u32, 21u32, false), (33, 33, true)] {
        let dem = write_dem(dir.path(), w, h);
        let out = dir.path().join("m.obj");
        let (ws, hs) = (w.to_string(), h.to_string());
        for (k, layout) in ["full", "compact", "records", "records-linear"]
            .into_iter()
            .enumerate()
        {
            // Every other run also repeats the preprocessing (the peers' protocol).
            let repeats = if (k + usize::from(square)) % 2 == 0 {
                "0"
            } else {
                "2"
            };
            let o = relief(&[
                "mesh",
                "--dem",
                &dem,
                "--format",
                "raw-f32",
                "--width",
                &ws,
                "--height",
                &hs,
                "--max-error",
                "0.5",
                "--layout",
                layout,
                "--out",
                out.to_str().unwrap(),
                "--json",
                "--preprocess-repeats",
                repeats,
            ]);
            let v = json(&o);
            match repeats {
                "0" => assert!(v["preprocess_repeat_ms"].is_null()),
                _ => assert!(v["preprocess_repeat_ms"].as_f64().unwrap() >= 0.0),
            }
            let (nv, nt) = obj_counts(&out);
            assert_eq!(v["vertices"].as_u64().unwrap() as usize, nv);
            assert_eq!(v["triangles"].as_u64().unwrap() as usize, nt);
            assert!(nt > 2 && nt < 2 * (w as usize - 1) * (h as usize - 1));
            assert!(v["max_error_measured"].as_f64().unwrap() <= 0.5);
            assert!(v["preprocess_ms"].as_f64().unwrap() >= 0.0);
            assert!(v["refine_ms"].as_f64().unwrap() >= 0.0);
            assert!(v["refine_reused_ms"].as_f64().unwrap() >= 0.0);
            assert!(v["refine_fresh_repeat_ms"].as_f64().unwrap() >= 0.0);
            assert!(["avx512", "popcnt", "default"].contains(&v["refine_build"].as_str().unwrap()));
            assert!(v["strip_length"].is_u64(), "{w}x{h}");
            // Off the square no level is forced: both strips draw the mesh's triangles. Each
            // strip is at least the fewest indices for its order, and on the square within its
            // start (three indices) of it.
            for k in ["inout_strip", "soar_strip"] {
                if !square {
                    assert_eq!(v[k]["triangles"].as_u64().unwrap() as usize, nt, "{k}");
                }
                let (len, fewest) = (
                    v[k]["indices"].as_u64().unwrap(),
                    v[k]["fewest_indices"].as_u64().unwrap(),
                );
                assert!(fewest <= len && fewest > v[k]["triangles"].as_u64().unwrap());
                if square {
                    assert!(len <= fewest + 3, "{k}: {len} vs fewest {fewest}");
                }
            }
        }
    }
}

/// `--vertices grid` times the extraction with grid coordinates and writes the same OBJ as
/// positions do, view-independent (square and not, two layouts) and view-dependent.
#[test]
fn grid_vertices_write_the_same_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let view = [
        "--eye",
        "-10,-10,30",
        "--target",
        "40,40,0",
        "--size",
        "320x240",
        "--pixel-error",
        "1",
    ];
    for (w, h, layout, vd) in [
        (33u32, 33u32, "full", false),
        (33, 21, "compact", false),
        (65, 65, "full", true),
    ] {
        let dem = write_dem(dir.path(), w, h);
        let (ws, hs) = (w.to_string(), h.to_string());
        let mut objs = Vec::new();
        for format in ["positions", "grid"] {
            let out = dir.path().join(format!("{format}.obj"));
            let mut a = vec![
                "mesh",
                "--dem",
                &dem,
                "--format",
                "raw-f32",
                "--width",
                &ws,
                "--height",
                &hs,
                "--layout",
                layout,
                "--vertices",
                format,
                "--json",
            ];
            let o = out.to_str().unwrap().to_string();
            a.extend(["--out", &o]);
            if vd {
                a.extend(view);
            } else {
                a.extend(["--max-error", "0.5"]);
            }
            let v = json(&relief(&a));
            assert_eq!(v["vertex_format"], format);
            assert!(v["refine_fresh_repeat_ms"].as_f64().unwrap() >= 0.0);
            objs.push(std::fs::read(&out).unwrap());
        }
        assert!(objs[0].len() > 100);
        assert_eq!(objs[0], objs[1], "{w}x{h} {layout}");
    }
}

#[test]
fn view_dependent_mesh_runs_with_culling() {
    let dir = tempfile::tempdir().unwrap();
    let dem = write_dem(dir.path(), 65, 65);
    let out = dir.path().join("v.obj");
    let o = relief(&[
        "mesh",
        "--dem",
        &dem,
        "--format",
        "raw-f32",
        "--width",
        "65",
        "--height",
        "65",
        "--eye",
        "-10,-10,30",
        "--target",
        "40,40,0",
        "--fov",
        "50",
        "--size",
        "320x240",
        "--pixel-error",
        "1",
        "--out",
        out.to_str().unwrap(),
        "--json",
    ]);
    let v = json(&o);
    assert_eq!(v["mode"], "view-dependent");
    let (nv, nt) = obj_counts(&out);
    assert_eq!(v["triangles"].as_u64().unwrap() as usize, nt);
    assert_eq!(v["vertices"].as_u64().unwrap() as usize, nv);
    assert!(nt > 2);
}

#[test]
fn bad_input_is_one_line_and_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let dem = write_dem(dir.path(), 9, 9);
    let out = dir.path().join("x.obj");
    let o = out.to_str().unwrap();
    let base = [
        "mesh", "--dem", &dem, "--format", "raw-f32", "--width", "9", "--height", "9",
    ];
    let cases: Vec<Vec<&str>> = vec![
        vec!["--max-error", "nan", "--out", o],
        vec!["--max-error", "-1", "--out", o],
        vec!["--out", o],
        vec![
            "--eye",
            "1,1,nan",
            "--target",
            "5,5,0",
            "--size",
            "10x10",
            "--pixel-error",
            "1",
            "--out",
            o,
        ],
        vec![
            "--eye",
            "4,4,10",
            "--target",
            "4,4,0",
            "--size",
            "10x10",
            "--pixel-error",
            "1",
            "--out",
            o,
        ],
        vec![
            "--eye",
            "0,0,10",
            "--target",
            "5,5,0",
            "--size",
            "10x10",
            "--pixel-error",
            "nan",
            "--out",
            o,
        ],
        // Grid vertices time one grid's refinement only.
        vec![
            "--max-error",
            "1",
            "--method",
            "tin",
            "--vertices",
            "grid",
            "--out",
            o,
        ],
        vec![
            "--max-error",
            "1",
            "--edit",
            "4,4,2,1",
            "--vertices",
            "grid",
            "--out",
            o,
        ],
    ];
    for c in cases {
        let args: Vec<&str> = base.iter().copied().chain(c.iter().copied()).collect();
        let r = relief(&args);
        assert_eq!(r.status.code(), Some(2), "{c:?}");
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(err.trim_end().lines().count(), 1, "{c:?}: {err}");
        assert!(err.starts_with("relief: error: "), "{err}");
    }
    let r = relief(&[
        "mesh",
        "--dem",
        "/nonexistent.png",
        "--max-error",
        "1",
        "--out",
        o,
    ]);
    assert_eq!(r.status.code(), Some(2));
    assert!(!out.exists(), "no output on errors");
}

/// `--records-file`: the first run preprocesses and writes the records, the second maps them
/// (no preprocessing) and writes the same mesh, view-independent and view-dependent, for both
/// record layouts; a file of another grid, another layout or changed heights is a one-line
/// error, and so is the option without a records layout.
#[test]
fn records_file_is_written_then_mapped_for_the_same_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let dem = write_dem(dir.path(), 33, 33);
    let base = |layout: &str, rec: &Path, out: &Path, vd: bool| {
        let mut args = vec![
            "mesh", "--dem", &dem, "--format", "raw-f32", "--width", "33", "--height", "33",
            "--layout", layout, "--json",
        ]
        .into_iter()
        .map(String::from)
        .collect::<Vec<_>>();
        args.extend(["--records-file".into(), rec.to_str().unwrap().into()]);
        args.extend(["--out".into(), out.to_str().unwrap().into()]);
        if vd {
            args.extend(
                [
                    "--eye",
                    "-10,-10,30",
                    "--target",
                    "20,20,0",
                    "--size",
                    "320x240",
                    "--pixel-error",
                    "1",
                ]
                .map(String::from),
            );
        } else {
            args.extend(["--max-error".into(), "0.5".into()]);
        }
        args
    };
    for layout in ["records", "records-linear"] {
        let rec = dir.path().join(format!("{layout}.rec"));
        for vd in [false, true] {
            let _ = std::fs::remove_file(&rec);
            let (o1, o2) = (dir.path().join("a.obj"), dir.path().join("b.obj"));
            let run = |out: &Path| {
                let a = base(layout, &rec, out, vd);
                let a: Vec<&str> = a.iter().map(String::as_str).collect();
                json(&relief(&a))
            };
            let first = run(&o1);
            assert_eq!(first["records_file"], "written", "{layout} vd {vd}");
            assert!(rec.exists());
            let second = run(&o2);
            assert_eq!(second["records_file"], "mapped", "{layout} vd {vd}");
            assert_eq!(first["triangles"], second["triangles"]);
            assert!(second["triangles"].as_u64().unwrap() > 2);
            assert_eq!(
                std::fs::read(&o1).unwrap(),
                std::fs::read(&o2).unwrap(),
                "{layout} vd {vd}: the meshes differ"
            );
        }
    }
    // Another layout than the file's.
    let rec = dir.path().join("records.rec");
    let a = base("records-linear", &rec, &dir.path().join("c.obj"), false);
    let a: Vec<&str> = a.iter().map(String::as_str).collect();
    common::assert_one_line_error(&relief(&a), "another layout");
    // Changed heights, same size: the sampled heights disagree.
    let other = dir.path().join("other.f32");
    common::write_f32(&other, &vec![1.0f32; 33 * 33]);
    let a = base("records", &rec, &dir.path().join("c.obj"), false);
    let mut a: Vec<&str> = a.iter().map(String::as_str).collect();
    a[2] = other.to_str().unwrap();
    common::assert_one_line_error(&relief(&a), "another grid");
    // Another size.
    let small = write_dem(dir.path(), 17, 17);
    let a = base("records", &rec, &dir.path().join("c.obj"), false);
    let mut a: Vec<&str> = a.iter().map(String::as_str).collect();
    a[2] = &small;
    (a[6], a[8]) = ("17", "17");
    common::assert_one_line_error(&relief(&a), "17x17");
    // Without a records layout.
    let a = base("full", &rec, &dir.path().join("c.obj"), false);
    let a: Vec<&str> = a.iter().map(String::as_str).collect();
    common::assert_one_line_error(&relief(&a), "--records-file needs --layout records");
}
