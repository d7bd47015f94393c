//! `relief rbf`: outputs, agreement with the core, and bad input.

mod common;
use common::{read_f32, relief};

use relief_core::glam::Vec2;
use relief_core::rbf::{AdaptiveGrid, Cell, InfluenceSets, Rbf, RbfOptions};
use std::path::Path;
use std::process::Output;

fn write_raw(path: &Path, values: &[f32]) {
    let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    std::fs::write(path, bytes).unwrap();
}

fn read_cells(path: &Path) -> Vec<Cell> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            assert_eq!(f.len(), 4, "{l}");
            Cell::new(
                f[0].parse().unwrap(),
                f[1].parse().unwrap(),
                f[2].parse().unwrap(),
                f[3].parse().unwrap(),
            )
        })
        .collect()
}

fn run_rbf(dir: &Path, dem: &Path, w: u32, h: u32, extra: &[&str]) -> Output {
    let (ws, hs) = (w.to_string(), h.to_string());
    let cells = dir.join("cells.csv");
    let out = dir.join("approx.f32");
    let mut args = vec![
        "rbf",
        "--dem",
        dem.to_str().unwrap(),
        "--format",
        "raw-f32",
        "--width",
        &ws,
        "--height",
        &hs,
        "--cells-out",
        cells.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    relief(&args)
}

#[test]
fn outputs_tile_the_domain_and_match_the_core() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (37u32, 29u32);
    let dem: Vec<f32> = (0..w * h)
        .map(|k| {
            let (x, y) = ((k % w) as f32, (k / w) as f32);
            if x < 16.0 {
                10.0
            } else {
                (x * 0.7).sin() * 5.0 + y * 0.3
            }
        })
        .collect();
    let path = dir.path().join("dem.f32");
    write_raw(&path, &dem);
    let out = run_rbf(
        dir.path(),
        &path,
        w,
        h,
        &[
            "--max-error",
            "0.5",
            "--min-cell",
            "1",
            "--max-cell",
            "8",
            "--sigma",
            "1.5",
            "--json",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let cells = read_cells(&dir.path().join("cells.csv"));
    assert_eq!(v["cells"].as_u64().unwrap() as usize, cells.len());
    assert!(cells.iter().any(|c| c.size == 8), "flat part should merge");
    assert_eq!(
        cells
            .iter()
            .map(|c| (c.size * c.size) as usize)
            .sum::<usize>(),
        (w * h) as usize
    );
    for key in ["build_ms", "eval_ms", "max_diff", "rms_diff"] {
        assert!(v[key].as_f64().unwrap() >= 0.0, "{key}");
    }
    // Independent evaluation through the core from the CSV (validates the tiling too).
    let mut index = vec![0; (w * h) as usize];
    let grid = AdaptiveGrid::new(w, h, &cells, &mut index).unwrap();
    let opts = RbfOptions::default().with_sigma(1.5);
    let mut o = vec![0; InfluenceSets::offsets_len(&grid)];
    let mut e = vec![0; InfluenceSets::entries_len(&grid, &opts).unwrap()];
    let sets = InfluenceSets::build(&grid, &opts, &mut o, &mut e).unwrap();
    let rbf = Rbf::new(grid, sets, &opts).unwrap();
    let approx = read_f32(&dir.path().join("approx.f32"));
    assert_eq!(approx.len(), (w * h) as usize);
    let (mut max_diff, mut sq) = (0.0f64, 0.0f64);
    for y in 0..h {
        for x in 0..w {
            let k = (y * w + x) as usize;
            let expect = rbf.eval(Vec2::new(x as f32, y as f32)).unwrap();
            assert!(
                (approx[k] - expect).abs() <= 1e-4 * expect.abs().max(1.0),
                "({x},{y})"
            );
            let d = f64::from(approx[k]) - f64::from(dem[k]);
            max_diff = max_diff.max(d.abs());
            sq += d * d;
        }
    }
    assert!((v["max_diff"].as_f64().unwrap() - max_diff).abs() < 1e-3);
    assert!((v["rms_diff"].as_f64().unwrap() - (sq / (w * h) as f64).sqrt()).abs() < 1e-3);
    // Flat left part far from the bumps: reproduced exactly.
    assert_eq!(approx[(10 * w + 2) as usize], 10.0);
}

#[test]
fn constant_dem_with_offset_is_exact() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (20u32, 17u32);
    let path = dir.path().join("dem.f32");
    write_raw(&path, &vec![3.25f32; (w * h) as usize]);
    let out = run_rbf(
        dir.path(),
        &path,
        w,
        h,
        &[
            "--max-error",
            "0",
            "--min-cell",
            "2",
            "--max-cell",
            "16",
            "--z-offset",
            "100",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let approx = read_f32(&dir.path().join("approx.f32"));
    assert!(approx.iter().all(|&v| v == 103.25));
    let cells = read_cells(&dir.path().join("cells.csv"));
    assert!(cells.iter().all(|c| c.value == 103.25));
    assert_eq!(cells[0].size, 16);
}

#[test]
fn bad_input_is_one_line_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("dem.f32");
    write_raw(&path, &[0.0f32; 64]);
    let cases: [(&[&str], &str); 6] = [
        (
            &[
                "--max-error",
                "1",
                "--min-cell",
                "1",
                "--max-cell",
                "4",
                "--sigma",
                "0",
            ],
            "sigma",
        ),
        (
            &[
                "--max-error",
                "1",
                "--min-cell",
                "1",
                "--max-cell",
                "4",
                "--sigma",
                "-2",
            ],
            "sigma",
        ),
        (
            &["--max-error", "1", "--min-cell", "8", "--max-cell", "4"],
            "min_cell",
        ),
        (
            &["--max-error", "1", "--min-cell", "3", "--max-cell", "4"],
            "power of two",
        ),
        (
            &["--max-error", "1", "--min-cell", "1", "--max-cell", "6"],
            "power of two",
        ),
        (
            &["--max-error", "nan", "--min-cell", "1", "--max-cell", "4"],
            "max_error",
        ),
    ];
    for (extra, needle) in cases {
        let out = run_rbf(dir.path(), &path, 8, 8, extra);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{extra:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{err:?}");
        assert!(err.contains(needle), "{err:?} should mention {needle}");
        assert!(!dir.path().join("approx.f32").exists());
    }
}

#[test]
fn bundled_dem_runs() {
    let dir = tempfile::tempdir().unwrap();
    let dem = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/puget_sound_1k.png");
    let cells = dir.path().join("c.csv");
    let out_f = dir.path().join("a.f32");
    let out = relief(&[
        "rbf",
        "--dem",
        dem.to_str().unwrap(),
        "--z-scale",
        "0.1",
        "--max-error",
        "20",
        "--min-cell",
        "2",
        "--max-cell",
        "64",
        "--cells-out",
        cells.to_str().unwrap(),
        "--out",
        out_f.to_str().unwrap(),
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["width"], 1025);
    let n = v["cells"].as_u64().unwrap();
    assert!(n < 1025 * 1025 / 4 + 2 * 1025, "{n}");
    let approx = read_f32(&out_f);
    assert_eq!(approx.len(), 1025 * 1025);
    assert!(approx.iter().all(|v| v.is_finite()));
    // Within the DEM's range (0 .. 4379.8 m) since every value is a convex combination.
    assert!(approx.iter().all(|&v| (-1e-3..=4379.9).contains(&v)));
}
