//! `relief mesh --detail PATH --detail-factor K` (detail levels below the base grid): the OBJ is
//! crack-free, its vertices are samples of the composed surface, and the JSON agrees with it;
//! bad detail options are one line on stderr with exit code 2.

mod common;
use common::{read_obj, relief, write_f32};

use relief_core::{Composed, Heightfield, Scale, Terrain};
use relief_tests::mesh_check::{check_mesh, CheckOptions};

fn base_samples(w: u32, h: u32) -> Vec<f32> {
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            40.0 * (-((x - 12.0).powi(2) + (y - 9.0).powi(2)) / 60.0).exp()
                + 3.0 * (x * 0.7).sin() * (y * 0.4).cos()
        })
        .collect()
}

fn detail_samples(w: u32, h: u32) -> Vec<f32> {
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            (std::f32::consts::TAU * x / w as f32).sin()
                * (std::f32::consts::TAU * 2.0 * y / h as f32).cos()
                + ((u64::from(i) * 2654435761) % 97) as f32 / 97.0
                - 0.5
        })
        .collect()
}

#[test]
fn detail_mesh_is_crack_free_and_on_the_composed_surface() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h, dw, dh, k) = (33u32, 21u32, 8u32, 6u32, 8u32);
    let bs = base_samples(w, h);
    let ds = detail_samples(dw, dh);
    let dem = write_f32(&dir.path().join("base.f32"), &bs);
    let det = write_f32(&dir.path().join("detail.f32"), &ds);
    let out = dir.path().join("d.obj");
    for (layout, extra) in [("full", None), ("compact", Some("0.05"))] {
        let mut args = vec![
            "mesh",
            "--dem",
            &dem,
            "--format",
            "raw-f32",
            "--width",
            "33",
            "--height",
            "21",
            "--dx",
            "16",
            "--dy",
            "16",
            "--detail",
            &det,
            "--detail-size",
            "8x6",
            "--detail-factor",
            "8",
            "--detail-z-scale",
            "0.5",
            "--eye",
            "60,50,20",
            "--target",
            "300,200,0",
            "--size",
            "400x300",
            "--pixel-error",
            "2",
            "--layout",
            layout,
            "--out",
            out.to_str().unwrap(),
            "--json",
        ];
        if let Some(e) = extra {
            args.extend(["--detail-error", e]);
        }
        let o = relief(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let (verts, tris) = read_obj(&out);
        assert_eq!(v["vertices"].as_u64().unwrap() as usize, verts.len());
        assert_eq!(v["triangles"].as_u64().unwrap() as usize, tris.len());
        assert_eq!(v["effective_width"], (w - 1) * k + 1);
        assert_eq!(v["effective_height"], (h - 1) * k + 1);
        assert_eq!(v["effective_resolution"], "257x161");
        let by_range: u64 = v["triangles_by_level_range"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r["triangles"].as_u64().unwrap())
            .sum();
        assert_eq!(by_range as usize, tris.len());
        let (bt, dt) = (
            v["base_triangles"].as_u64().unwrap(),
            v["detail_triangles"].as_u64().unwrap(),
        );
        assert_eq!((bt + dt) as usize, tris.len());
        assert!(bt > 0 && dt > 0, "{v}");
        assert_eq!(v["detail_errors_measured"], extra.is_none());
        let kind = if extra.is_none() { "local" } else { "constant" };
        assert_eq!(v["detail_bounds"], kind);
        // The mesh: conforming (holes only where culled) on the composed lattice.
        let mut o = CheckOptions::grid((w - 1) * k + 1, (h - 1) * k + 1, 2.0, 2.0);
        o.allow_holes = true;
        check_mesh(&verts, &tris, &o).unwrap();
        // Every vertex is a composed sample (OBJ text rounds: compare within 1e-4 relative).
        let base =
            Heightfield::with_scale(&bs, w, h, Scale::default().with_spacing(16.0, 16.0)).unwrap();
        let dscale = Scale::default().with_z_scale(0.5);
        let detail = Heightfield::with_scale(&ds, dw, dh, dscale).unwrap();
        let c = Composed::new(base, detail, k).unwrap();
        for p in &verts {
            let (x, y) = ((p[0] / 2.0).round() as u32, (p[1] / 2.0).round() as u32);
            let z = c.z(x, y);
            assert!((p[2] - z).abs() <= 1e-4 * z.abs().max(1.0), "{p:?} vs {z}");
        }
    }
}

#[test]
fn bad_detail_options_are_one_line_and_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let dem = write_f32(&dir.path().join("b.f32"), &base_samples(9, 9));
    let det = write_f32(&dir.path().join("d.f32"), &detail_samples(4, 4));
    let out = dir.path().join("x.obj");
    let o = out.to_str().unwrap();
    let base = [
        "mesh", "--dem", &dem, "--format", "raw-f32", "--width", "9", "--height", "9",
    ];
    let view = [
        "--eye",
        "1,1,5",
        "--target",
        "5,5,0",
        "--size",
        "10x10",
        "--pixel-error",
        "1",
    ];
    let cases: Vec<Vec<&str>> = vec![
        // No factor.
        [
            &view[..],
            &["--detail", &det, "--detail-size", "4x4", "--out", o],
        ]
        .concat(),
        // Not a power of two.
        [
            &view[..],
            &[
                "--detail",
                &det,
                "--detail-size",
                "4x4",
                "--detail-factor",
                "3",
                "--out",
                o,
            ],
        ]
        .concat(),
        // View-independent with detail.
        vec![
            "--detail",
            &det,
            "--detail-size",
            "4x4",
            "--detail-factor",
            "4",
            "--max-error",
            "1",
            "--out",
            o,
        ],
        // Raw detail without its size.
        [
            &view[..],
            &["--detail", &det, "--detail-factor", "4", "--out", o],
        ]
        .concat(),
        // Detail size that does not match the file.
        [
            &view[..],
            &[
                "--detail",
                &det,
                "--detail-size",
                "5x4",
                "--detail-factor",
                "4",
                "--out",
                o,
            ],
        ]
        .concat(),
        // Negative constant error.
        [
            &view[..],
            &[
                "--detail",
                &det,
                "--detail-size",
                "4x4",
                "--detail-factor",
                "4",
                "--detail-error",
                "-1",
                "--out",
                o,
            ],
        ]
        .concat(),
        // Detail options without --detail.
        [&view[..], &["--detail-factor", "4", "--out", o]].concat(),
    ];
    for c in cases {
        let args: Vec<&str> = base.iter().copied().chain(c.iter().copied()).collect();
        let r = relief(&args);
        assert_eq!(r.status.code(), Some(2), "{c:?}");
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(!err.contains("panicked"), "{c:?}: {err}");
        assert!(!out.exists(), "{c:?} wrote an output file");
    }
}
