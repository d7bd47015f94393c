//! Helpers shared by the CLI's integration tests: each test file includes this module with
//! `mod common;` (a folder module, so cargo does not build it as a test of its own).

// Each test binary uses a different subset of these helpers.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the `relief` binary with `args`.
pub fn relief(args: &[&str]) -> Output {
    relief_env(args, &[])
}

/// Runs the `relief` binary with `args` and the extra environment `env`.
pub fn relief_env(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_relief"));
    c.args(args);
    // Mesa prints a warning line of its own on stderr without a runtime dir (CI sets one).
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        c.env("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().expect("run relief")
}

/// The repository root.
pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The bundled Puget Sound DEM.
pub fn bundled() -> String {
    repo().join("data/puget_sound_1k.png").display().to_string()
}

/// Asserts a failure: exit code 2, exactly one line on stderr that starts `relief: error: `
/// and mentions `needle` (case-insensitive), no panic, nothing on stdout.
pub fn assert_one_line_error(out: &Output, needle: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "stderr: {err}");
    assert_eq!(err.lines().count(), 1, "not one line: {err:?}");
    assert!(err.starts_with("relief: error: "), "{err:?}");
    assert!(!err.contains("panicked"), "{err:?}");
    assert!(
        err.to_lowercase().contains(&needle.to_lowercase()),
        "{err:?} should mention {needle:?}"
    );
    assert!(out.stdout.is_empty(), "stdout: {:?}", out.stdout);
}

/// Asserts success and parses stdout as one JSON object.
pub fn json(o: &Output) -> serde_json::Value {
    assert!(
        o.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    serde_json::from_slice(&o.stdout).expect("one JSON object")
}

/// Writes `v` as raw little-endian f32 to `p`; returns the path as a string.
pub fn write_f32(p: &Path, v: &[f32]) -> String {
    let bytes: Vec<u8> = v.iter().flat_map(|z| z.to_le_bytes()).collect();
    std::fs::write(p, bytes).unwrap();
    p.to_str().unwrap().to_string()
}

/// Reads raw little-endian f32 from `p` (`--depth-out`, `--normals-out`, `relief rbf --out`).
pub fn read_f32(p: &Path) -> Vec<f32> {
    std::fs::read(p)
        .unwrap()
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect()
}

/// Reads an OBJ's vertices and triangles (indices from 0; `f a/b/c` forms keep the position).
pub fn read_obj(p: &Path) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let s = std::fs::read_to_string(p).unwrap();
    let mut v = Vec::new();
    let mut t = Vec::new();
    for l in s.lines() {
        let f: Vec<&str> = l.split_whitespace().collect();
        match f.first() {
            Some(&"v") => v.push([f[1], f[2], f[3]].map(|x| x.parse::<f32>().unwrap())),
            Some(&"f") => t.push(
                [f[1], f[2], f[3]]
                    .map(|x| x.split('/').next().unwrap().parse::<u32>().unwrap() - 1),
            ),
            _ => {}
        }
    }
    (v, t)
}
