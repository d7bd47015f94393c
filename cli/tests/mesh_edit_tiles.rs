//! `relief mesh --edit` (incremental update) and `relief mesh --tile-size --out-dir` (tiles
//! without skirts): the edited mesh equals the mesh of a DEM edited beforehand, and the tiles'
//! union is crack-free, within E and reported consistently.

mod common;
use common::{json, read_obj, relief, write_f32};

use relief_tests::mesh_check::{check_mesh, CheckOptions};
use std::collections::HashMap;

fn heights(w: u32, h: u32) -> Vec<f32> {
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            40.0 * (-((x - 12.0).powi(2) + (y - 9.0).powi(2)) / 60.0).exp()
                + 3.0 * (x * 0.7).sin() * (y * 0.4).cos()
        })
        .collect()
}

/// The crater of issue 6, written out here (not the library's): samples at distance r < radius
/// from (x, y) are lowered by depth * (1 - (r / radius)^2).
fn dig(s: &mut [f32], w: u32, x: f32, y: f32, radius: f32, depth: f32) {
    for (i, z) in s.iter_mut().enumerate() {
        let (dx, dy) = ((i as u32 % w) as f32 - x, (i as u32 / w) as f32 - y);
        let r = (dx * dx + dy * dy).sqrt();
        if r < radius {
            let q = r / radius;
            *z -= depth * (1.0 - q * q);
        }
    }
}

#[test]
fn edited_mesh_equals_mesh_of_the_dem_edited_beforehand() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (33u32, 21u32);
    let s = heights(w, h);
    let dem = write_f32(&dir.path().join("dem.f32"), &s);
    let mut edited = s.clone();
    dig(&mut edited, w, 10.0, 7.0, 4.0, 5.0);
    dig(&mut edited, w, 25.5, 15.0, 2.5, -3.0);
    let dem2 = write_f32(&dir.path().join("edited.f32"), &edited);
    let (ws, hs) = (w.to_string(), h.to_string());
    let raw = ["--format", "raw-f32", "--width", &ws, "--height", &hs];
    for layout in ["full", "compact"] {
        for crit in [
            vec!["--max-error", "0.5"],
            vec![
                "--eye",
                "-10,-10,30",
                "--target",
                "16,10,0",
                "--size",
                "320x200",
                "--pixel-error",
                "1",
            ],
        ] {
            let a = dir.path().join("a.obj");
            let b = dir.path().join("b.obj");
            let mut args = vec!["mesh", "--dem", &dem];
            args.extend(raw);
            args.extend(["--layout", layout, "--json"]);
            args.extend(&crit);
            let mut with_edit = args.clone();
            let a_s = a.to_str().unwrap();
            with_edit.extend([
                "--edit",
                "10,7,4,5",
                "--edit",
                "25.5,15,2.5,-3",
                "--out",
                a_s,
            ]);
            let v = json(&relief(&with_edit));
            assert_eq!(v["edits"], 2);
            assert!(v["update_ms"].as_f64().unwrap() >= 0.0);
            assert!(v["full_preprocess_ms"].as_f64().unwrap() > 0.0);
            assert_eq!(v["edit_region"], serde_json::json!([7, 4, 27, 17]));
            let mut plain = args.clone();
            plain[2] = &dem2;
            plain.extend(["--out", b.to_str().unwrap()]);
            let u = json(&relief(&plain));
            assert_eq!(v["triangles"], u["triangles"], "{layout} {crit:?}");
            assert_eq!(v["max_error_measured"], u["max_error_measured"]);
            let (fa, fb) = (std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
            assert!(fa == fb, "{layout} {crit:?}: the meshes differ");
            // And the edit changed the mesh (the control).
            let mut unedited = args.clone();
            unedited.extend(["--out", b.to_str().unwrap()]);
            json(&relief(&unedited));
            assert!(std::fs::read(&b).unwrap() != fa);
        }
    }
    // An edit outside the grid is one line and exit 2.
    let mut args = vec!["mesh", "--dem", &dem];
    args.extend(raw);
    let out = dir.path().join("c.obj");
    args.extend([
        "--max-error",
        "1",
        "--edit",
        "500,500,3,1",
        "--out",
        out.to_str().unwrap(),
    ]);
    let o = relief(&args);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(String::from_utf8_lossy(&o.stderr).trim().lines().count(), 1);
}

#[test]
fn tiles_union_is_crack_free_and_within_e() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (41u32, 30u32); // tiles of 9: the last row of tiles is 6 samples high
    let dem = write_f32(&dir.path().join("dem.f32"), &heights(w, h));
    let (ws, hs) = (w.to_string(), h.to_string());
    let out = dir.path().join("tiles");
    let os = out.to_str().unwrap();
    for skirt in [None, Some("2.5")] {
        let mut args = vec![
            "mesh",
            "--dem",
            &dem,
            "--format",
            "raw-f32",
            "--width",
            &ws,
            "--height",
            &hs,
            "--dx",
            "2",
            "--dy",
            "3",
            "--max-error",
            "0.4",
            "--tile-size",
            "9",
            "--out-dir",
            os,
            "--json",
        ];
        if let Some(d) = skirt {
            args.extend(["--skirt", d]);
        }
        let v = json(&relief(&args));
        assert_eq!(
            (v["tiles_x"].as_u64(), v["tiles_y"].as_u64()),
            (Some(5), Some(4))
        );
        assert!(v["max_error_measured"].as_f64().unwrap() <= 0.4);
        let tiles = v["tiles"].as_array().unwrap();
        assert_eq!(tiles.len(), 20);
        // Weld every tile's OBJ by position and check the union (skirts: only the top faces).
        let mut at: HashMap<(i64, i64), u32> = HashMap::new();
        let (mut uv, mut ut) = (Vec::new(), Vec::new());
        let mut total = 0;
        for t in tiles {
            let (c, r) = (t["col"].as_u64().unwrap(), t["row"].as_u64().unwrap());
            let (tv, tt) = read_obj(&out.join(format!("tile_{c}_{r}.obj")));
            assert_eq!(tt.len() as u64, t["triangles"].as_u64().unwrap());
            total += tt.len();
            for tri in tt {
                let p = tri.map(|i| tv[i as usize]);
                let vertical = (p[1][0] - p[0][0]) * (p[2][1] - p[0][1])
                    - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0]);
                if vertical == 0.0 {
                    assert!(skirt.is_some(), "a vertical triangle without skirts");
                    continue;
                }
                ut.push(p.map(|q| {
                    let key = ((q[0] / 2.0).round() as i64, (q[1] / 3.0).round() as i64);
                    *at.entry(key).or_insert_with(|| {
                        uv.push(q);
                        (uv.len() - 1) as u32
                    })
                }));
            }
        }
        assert_eq!(total as u64, v["triangles"].as_u64().unwrap());
        assert_eq!(ut.len() as u64, v["union_triangles"].as_u64().unwrap());
        if skirt.is_some() {
            assert!(total > ut.len());
        }
        check_mesh(&uv, &ut, &CheckOptions::grid(w, h, 2.0, 3.0)).unwrap();
    }
    // A tile size that is not 2^k + 1 is one line and exit 2.
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
        "1",
        "--tile-size",
        "10",
        "--out-dir",
        os,
    ]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn view_dependent_tiles_in_both_layouts_weld_crack_free() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (41u32, 30u32);
    let dem = write_f32(&dir.path().join("dem.f32"), &heights(w, h));
    let (ws, hs) = (w.to_string(), h.to_string());
    let out = dir.path().join("vd");
    let os = out.to_str().unwrap();
    for layout in ["full", "compact"] {
        for cull in [false, true] {
            // The eye above the tiled area, near the corner shared by four tiles.
            let mut args = vec![
                "mesh",
                "--dem",
                &dem,
                "--format",
                "raw-f32",
                "--width",
                &ws,
                "--height",
                &hs,
                "--dx",
                "2",
                "--dy",
                "3",
                "--eye",
                "33,49,12",
                "--target",
                "70,80,0",
                "--size",
                "640x480",
                "--pixel-error",
                "1",
                "--lazy-levels",
                "0",
                "--layout",
                layout,
                "--tile-size",
                "9",
                "--out-dir",
                os,
                "--json",
            ];
            if !cull {
                args.push("--no-cull");
            }
            let v = json(&relief(&args));
            assert_eq!(v["mode"], "view-dependent");
            assert_eq!(v["layout"], layout);
            let mut at: HashMap<(i64, i64), u32> = HashMap::new();
            let (mut uv, mut ut) = (Vec::new(), Vec::new());
            for t in v["tiles"].as_array().unwrap() {
                let (c, r) = (t["col"].as_u64().unwrap(), t["row"].as_u64().unwrap());
                let (tv, tt) = read_obj(&out.join(format!("tile_{c}_{r}.obj")));
                for tri in tt {
                    ut.push(tri.map(|i| {
                        let q = tv[i as usize];
                        let key = ((q[0] / 2.0).round() as i64, (q[1] / 3.0).round() as i64);
                        *at.entry(key).or_insert_with(|| {
                            uv.push(q);
                            (uv.len() - 1) as u32
                        })
                    }));
                }
            }
            assert_eq!(ut.len() as u64, v["union_triangles"].as_u64().unwrap());
            let mut o = CheckOptions::grid(w, h, 2.0, 3.0);
            o.allow_holes = cull;
            let rep =
                check_mesh(&uv, &ut, &o).unwrap_or_else(|m| panic!("{layout} cull {cull}: {m}"));
            let full_area = 40.0 * 2.0 * 29.0 * 3.0;
            if cull {
                assert!(rep.area < full_area, "{layout}: nothing culled");
            } else {
                assert!((rep.area - full_area).abs() < 1e-6, "{layout}");
            }
        }
    }
}
