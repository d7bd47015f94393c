//! Every subcommand on bad input: corrupt and truncated files, wrong sizes, NaN data, absurd
//! options (zero or huge sizes, negative or NaN errors, unknown names) and unwritable output
//! paths. Each must print exactly one line `relief: error: ...`, exit with code 2, print no
//! panic message, and leave no output file behind.

use std::path::{Path, PathBuf};
use std::process::Command;

struct Files {
    _dir: tempfile::TempDir,
    root: PathBuf,
}

impl Files {
    fn new() -> Files {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().to_path_buf();
        // A valid 33 x 33 DEM (a ramp with a bump).
        let v: Vec<u16> = (0..33 * 33)
            .map(|i| {
                let (x, y) = ((i % 33) as f32, (i / 33) as f32);
                (100.0
                    + 3.0 * x
                    + 2.0 * y
                    + 50.0 * (-((x - 16.0).powi(2) + (y - 16.0).powi(2)) / 30.0).exp())
                    as u16
            })
            .collect();
        relief_io::write_png16(&root.join("ok.png"), 33, 33, &v).unwrap();
        let png = std::fs::read(root.join("ok.png")).unwrap();
        std::fs::write(root.join("cut.png"), &png[..png.len() / 2]).unwrap();
        std::fs::write(root.join("junk.png"), b"\x89PNG\r\n\x1a\nthis is not a png").unwrap();
        std::fs::write(root.join("text.txt"), b"hello").unwrap();
        let mut raw: Vec<u8> = (0..16).flat_map(|i| (i as f32).to_le_bytes()).collect();
        raw[20..24].copy_from_slice(&f32::NAN.to_le_bytes());
        std::fs::write(root.join("nan.f32"), &raw).unwrap();
        Files { _dir: dir, root }
    }

    fn p(&self, name: &str) -> String {
        self.root.join(name).display().to_string()
    }
}

fn run(args: &[String]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_relief"))
        .args(args)
        // No GPU adapter at all: GPU paths must fail with one line.
        .env("VK_ICD_FILENAMES", "/nonexistent")
        .env("WGPU_BACKEND", "vulkan")
        .output()
        .unwrap()
}

fn assert_bad(args: &[String], out_file: Option<&Path>) {
    let o = run(args);
    let err = String::from_utf8_lossy(&o.stderr);
    let shown = args.join(" ");
    assert_eq!(o.status.code(), Some(2), "{shown}\nstderr: {err}");
    assert_eq!(err.lines().count(), 1, "{shown}: not one line: {err:?}");
    assert!(err.starts_with("relief: error: "), "{shown}: {err:?}");
    assert!(
        !err.contains("panicked") && !err.contains("RUST_BACKTRACE"),
        "{shown}: {err:?}"
    );
    if let Some(f) = out_file {
        assert!(!f.exists(), "{shown}: left {} behind", f.display());
    }
}

fn s(v: &[&str]) -> Vec<String> {
    v.iter().map(|x| (*x).to_string()).collect()
}

/// Replaces the value after `flag` in `args` (or appends the flag and value).
fn with(args: &[String], flag: &str, value: &str) -> Vec<String> {
    let mut a = args.to_vec();
    if let Some(i) = a.iter().position(|x| x == flag) {
        a[i + 1] = value.to_string();
    } else {
        a.push(flag.to_string());
        a.push(value.to_string());
    }
    a
}

#[test]
fn every_subcommand_rejects_bad_input_in_one_line() {
    let f = Files::new();
    let ok = f.p("ok.png");
    let out = f.p("out.bin");
    let cam = [
        "--eye",
        "-5,-5,400",
        "--target",
        "16,16,100",
        "--fov",
        "60",
        "--size",
        "16x12",
    ];
    let mut bases: Vec<(&str, Vec<String>)> = vec![
        ("info", s(&["info", "--dem", &ok])),
        (
            "mesh",
            s(&["mesh", "--dem", &ok, "--max-error", "2", "--out", &out]),
        ),
        (
            "mesh view",
            [
                s(&["mesh", "--dem", &ok, "--pixel-error", "1", "--out", &out]),
                s(&cam),
            ]
            .concat(),
        ),
        (
            "mesh tin",
            s(&[
                "mesh",
                "--method",
                "tin",
                "--dem",
                &ok,
                "--max-error",
                "2",
                "--out",
                &out,
            ]),
        ),
        (
            "trace",
            [
                s(&[
                    "trace",
                    "--dem",
                    &ok,
                    "--method",
                    "maxmip",
                    "--surface",
                    "triangles",
                    "--out",
                    &out,
                ]),
                s(&cam),
            ]
            .concat(),
        ),
        (
            "rbf",
            s(&[
                "rbf",
                "--dem",
                &ok,
                "--max-error",
                "2",
                "--min-cell",
                "1",
                "--max-cell",
                "8",
                "--cells-out",
                &f.p("cells.csv"),
                "--out",
                &out,
            ]),
        ),
        (
            "render",
            [
                s(&[
                    "render",
                    "--dem",
                    &ok,
                    "--backend",
                    "cpu",
                    "--method",
                    "maxmip",
                    "--out",
                    &f.p("img.png"),
                ]),
                s(&cam),
            ]
            .concat(),
        ),
        (
            "diagram",
            s(&[
                "diagram",
                "dda",
                "--dem",
                &ok,
                "--ray-start",
                "0.5,0.5",
                "--ray-dir",
                "3,1",
                "--out",
                &f.p("d.png"),
            ]),
        ),
        (
            "report",
            s(&["report", "--quick", "--dem", &ok, "--out", &f.p("rep")]),
        ),
    ];
    // Each base works (so the failures below are the bad input's doing).
    for (name, args) in &bases {
        let o = run(args);
        assert!(
            o.status.success(),
            "{name} should succeed: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    for p in ["out.bin", "cells.csv", "img.png", "d.png"] {
        let _ = std::fs::remove_file(f.root.join(p));
    }
    let _ = std::fs::remove_dir_all(f.root.join("rep"));
    let outp = f.root.join("out.bin");
    // Bad DEMs, for every subcommand that reads one.
    for (name, args) in &bases {
        for bad in ["missing.png", "cut.png", "junk.png", "text.txt"] {
            let a = with(args, "--dem", &f.p(bad));
            assert_bad(&a, Some(&outp));
        }
        // Raw f32 with NaN samples, and with a size that does not match the file.
        if !name.starts_with("report") {
            let nan = [
                with(args, "--dem", &f.p("nan.f32")),
                s(&["--width", "4", "--height", "4"]),
            ]
            .concat();
            assert_bad(&nan, Some(&outp));
            let wrong = [
                with(args, "--dem", &f.p("nan.f32")),
                s(&["--width", "5", "--height", "4"]),
            ]
            .concat();
            assert_bad(&wrong, Some(&outp));
            assert_bad(&with(args, "--dx", "0"), Some(&outp));
            assert_bad(&with(args, "--z-scale", "NaN"), Some(&outp));
        }
        let _ = name;
    }
    let get = |n: &str| {
        bases
            .iter()
            .find(|(k, _)| *k == n)
            .map(|(_, a)| a.clone())
            .unwrap()
    };
    let unwritable = "/nonexistent-dir/out.bin";
    let cases: Vec<Vec<String>> = vec![
        with(&get("mesh"), "--max-error", "-1"),
        with(&get("mesh"), "--max-error", "NaN"),
        with(&get("mesh"), "--max-error", "inf"),
        with(&get("mesh"), "--out", unwritable),
        with(&get("mesh view"), "--pixel-error", "-2"),
        with(&get("mesh view"), "--fov", "0"),
        with(&get("mesh view"), "--fov", "NaN"),
        with(&get("mesh view"), "--size", "0x0"),
        with(&get("mesh view"), "--eye", "16,16,400"), // looking straight down
        with(&get("mesh view"), "--eye", "NaN,0,0"),
        with(&get("mesh tin"), "--max-error", "-1"),
        with(&get("mesh tin"), "--out", unwritable),
        with(&get("trace"), "--size", "0x0"),
        with(&get("trace"), "--size", "100000x100000"),
        with(&get("trace"), "--size", "ax3"),
        with(&get("trace"), "--fov", "180"),
        with(&get("trace"), "--eye", "1,2"),
        with(&get("trace"), "--method", "teleport"),
        with(&get("trace"), "--surface", "sphere"),
        with(&get("trace"), "--samples", "0"),
        with(&get("trace"), "--threads", "0"),
        with(&get("trace"), "--out", unwritable),
        with(&get("rbf"), "--sigma", "0"),
        with(&get("rbf"), "--sigma", "-1"),
        with(&get("rbf"), "--sigma", "NaN"),
        with(&get("rbf"), "--max-error", "NaN"),
        with(&get("rbf"), "--min-cell", "3"),
        with(&get("rbf"), "--min-cell", "16"),
        with(&get("rbf"), "--max-cell", "0"),
        with(&get("rbf"), "--out", unwritable),
        with(&get("rbf"), "--cells-out", unwritable),
        with(&get("render"), "--size", "0x0"),
        with(&get("render"), "--size", "100000x100000"),
        with(&get("render"), "--fov", "-5"),
        with(&get("render"), "--effects", "sparkles"),
        with(&get("render"), "--effects", "depth"), // GPU-only effect on the CPU backend
        with(&get("render"), "--method", "cascades"), // GPU-only method on the CPU backend
        with(&get("render"), "--backend", "gpu"),   // no adapter (VK_ICD_FILENAMES points nowhere)
        with(&get("render"), "--out", unwritable),
        with(&get("diagram"), "--out", unwritable),
        with(&get("report"), "--out", "/dev/null/rep"),
        s(&["diagram", "hexagons", "--dem", &ok, "--out", &f.p("d.png")]),
        s(&["mesh", "--dem", &ok, "--out", &out]), // neither --max-error nor a view
    ];
    for a in &cases {
        assert_bad(a, Some(&outp));
    }
    bases.clear();
}
