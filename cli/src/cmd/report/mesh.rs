//! The report's mesh section: view-independent refinement (RQT) against the greedy TIN at equal
//! error targets, view-dependent refinement along a fly-through, and wireframes.

use super::model::{num, Figure, Section, Table};
use super::plot::{self, Chart, Series};
use super::Ctx;
use crate::{CliError, CliResult};
use relief_core::glam::Vec3;
use relief_core::refine::{
    preprocess, scratch_len, triangle_bound, vertex_bound, Criterion, Refiner, View,
};
use relief_core::{Camera, Heightfield, Terrain};
use relief_tin::{compare_method, compare_tin, ComparisonRow, GridMesh};
use serde_json::json;
use std::time::Instant;

/// A refined mesh with vertices as grid samples.
fn rqt_mesh(
    hf: &Heightfield<'_, f32>,
    r: &Refiner<'_, '_, Heightfield<'_, f32>>,
) -> Result<GridMesh, relief_core::Error> {
    let (w, h) = (hf.width(), hf.height());
    let mut scratch = vec![0u64; scratch_len(w, h)];
    let mut verts = vec![[0.0f32; 3]; vertex_bound(w, h)];
    let mut tris = vec![[0u32; 3]; triangle_bound(w, h)];
    let c = r.triangles(&mut scratch, &mut verts, &mut tris)?;
    let s = hf.scale();
    let vertices = verts[..c.vertices]
        .iter()
        .map(|v| [(v[0] / s.dx).round() as u32, (v[1] / s.dy).round() as u32])
        .collect();
    tris.truncate(c.triangles);
    Ok(GridMesh {
        vertices,
        triangles: tris,
    })
}

/// Mesh height at every grid sample (local units) by rasterising each triangle: an independent
/// scan of the mesh. Samples no triangle covers stay NaN.
fn mesh_heights(hf: &Heightfield<'_, f32>, m: &GridMesh) -> Vec<f32> {
    let (w, h) = (hf.width() as i64, hf.height() as i64);
    let mut out = vec![f32::NAN; (w * h) as usize];
    for t in &m.triangles {
        let p = t.map(|i| {
            let v = m.vertices[i as usize];
            (
                i64::from(v[0]),
                i64::from(v[1]),
                f64::from(hf.local_z(v[0], v[1])),
            )
        });
        let area =
            ((p[1].0 - p[0].0) * (p[2].1 - p[0].1) - (p[2].0 - p[0].0) * (p[1].1 - p[0].1)) as f64;
        if area == 0.0 {
            continue;
        }
        let (x0, x1) = (
            p.iter().map(|q| q.0).min().unwrap_or(0),
            p.iter().map(|q| q.0).max().unwrap_or(0),
        );
        let (y0, y1) = (
            p.iter().map(|q| q.1).min().unwrap_or(0),
            p.iter().map(|q| q.1).max().unwrap_or(0),
        );
        for y in y0.max(0)..=y1.min(h - 1) {
            for x in x0.max(0)..=x1.min(w - 1) {
                let e = |a: (i64, i64, f64), b: (i64, i64, f64)| {
                    ((b.0 - a.0) * (y - a.1) - (b.1 - a.1) * (x - a.0)) as f64
                };
                let (l0, l1, l2) = (
                    e(p[1], p[2]) / area,
                    e(p[2], p[0]) / area,
                    e(p[0], p[1]) / area,
                );
                if l0 >= 0.0 && l1 >= 0.0 && l2 >= 0.0 {
                    out[(y * w + x) as usize] = (l0 * p[0].2 + l1 * p[1].2 + l2 * p[2].2) as f32;
                }
            }
        }
    }
    out
}

/// Wireframe of a mesh over the hillshade, 768 pixels on the longer side.
fn wireframe(
    ctx: &Ctx<'_>,
    name: &str,
    hf: &Heightfield<'_, f32>,
    shade: &[f32],
    m: &GridMesh,
) -> CliResult {
    let (w, h) = (hf.width(), hf.height());
    let k = f64::from(w.max(h)) / 768.0;
    let (iw, ih) = (
        (f64::from(w) / k).ceil() as u32,
        (f64::from(h) / k).ceil() as u32,
    );
    let mut rgb = vec![0u8; (iw * ih * 3) as usize];
    for y in 0..ih {
        for x in 0..iw {
            let sx = ((f64::from(x) * k) as u32).min(w - 1);
            let sy = ((f64::from(y) * k) as u32).min(h - 1);
            let g = (shade[(sy * w + sx) as usize] * 200.0 + 40.0) as u8;
            let i = ((y * iw + x) * 3) as usize;
            rgb[i..i + 3].copy_from_slice(&[g, g, g]);
        }
    }
    let colour = plot::PALETTE[0];
    let mut put = |x: f64, y: f64| {
        let (px, py) = ((x / k) as i64, (y / k) as i64);
        if px >= 0 && py >= 0 && (px as u32) < iw && (py as u32) < ih {
            let i = ((py as u32 * iw + px as u32) * 3) as usize;
            rgb[i..i + 3].copy_from_slice(&[colour.0, colour.1, colour.2]);
        }
    };
    for t in &m.triangles {
        for e in 0..3 {
            let a = m.vertices[t[e] as usize];
            let b = m.vertices[t[(e + 1) % 3] as usize];
            let (ax, ay, bx, by) = (
                f64::from(a[0]),
                f64::from(a[1]),
                f64::from(b[0]),
                f64::from(b[1]),
            );
            let steps = ((bx - ax).abs().max((by - ay).abs()) / k * 2.0)
                .ceil()
                .max(1.0) as u32;
            for s in 0..=steps {
                let f = f64::from(s) / f64::from(steps);
                put(ax + f * (bx - ax), ay + f * (by - ay));
            }
        }
    }
    relief_io::write_png_rgb8(&ctx.fig(name), iw, ih, &rgb)?;
    Ok(())
}

fn rows_table(caption: &str, rows: &[ComparisonRow]) -> Table {
    let mut t = Table::new(
        caption,
        &[
            "method",
            "E (m)",
            "vertices",
            "triangles",
            "max error (m)",
            "RMS error (m)",
            "ms",
        ],
    );
    for r in rows {
        t.row(vec![
            r.method.clone(),
            num(r.target_error.into(), 1),
            r.vertices.to_string(),
            r.triangles.to_string(),
            num(r.max_error, 3),
            num(r.rms_error, 3),
            num(r.build_ms, 2),
        ]);
    }
    t
}

/// The section.
pub fn mesh(ctx: &Ctx<'_>) -> CliResult<Section> {
    let hf = ctx.dem.heightfield()?;
    let (w, h) = (hf.width(), hf.height());
    let errors: &[f32] = if ctx.quick {
        &[2.0, 5.0, 20.0, 50.0]
    } else {
        &[1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0]
    };
    let mut s = Section::new("mesh", "Meshes: error against triangles against time");

    // View-independent refinement.
    let t0 = Instant::now();
    let (mut err, mut rad) = (
        vec![0.0f32; vertex_bound(w, h)],
        vec![0.0f32; vertex_bound(w, h)],
    );
    let hier = preprocess(&hf, &mut err, &mut rad)?;
    let preprocess_ms = t0.elapsed().as_secs_f64() * 1e3;
    let rqt = compare_method(&hf, "rqt", errors, |e| {
        let r = Refiner::new(&hier, &hf, Criterion::MaxError(e))?;
        rqt_mesh(&hf, &r)
    })?;
    let tin = compare_tin(&hf, errors)?;
    s.text.push(format!(
        "View-independent restricted-quadtree refinement (RQT, SOAR's longest-edge bisection with the true L-infinity bound) against a greedy-insertion Delaunay TIN (Garland & Heckbert) at the same error targets E. Errors are measured over every grid sample by a full scan. RQT times are refinement only, after a {preprocess_ms:.1} ms preprocessing that every threshold shares; TIN times are the whole build."
    ));
    for r in rqt.iter().chain(&tin) {
        if r.max_error > f64::from(r.target_error) + 1e-3 {
            return Err(CliError(format!(
                "{} at E = {} measured {} > E",
                r.method, r.target_error, r.max_error
            )));
        }
    }
    let mut all = rqt.clone();
    all.extend(tin.iter().cloned());
    s.tables
        .push(rows_table("RQT and TIN at equal error targets", &all));
    let series = |rows: &[ComparisonRow], y: fn(&ComparisonRow) -> f64| -> Series {
        Series {
            label: rows.first().map_or(String::new(), |r| r.method.clone()),
            points: rows.iter().map(|r| (r.max_error.max(1e-3), y(r))).collect(),
        }
    };
    plot::line_chart(
        &ctx.fig("mesh_triangles_vs_error.png"),
        640,
        420,
        &Chart {
            title: "Triangles against measured max error",
            x_label: "measured max error (m)",
            y_label: "triangles",
            log_x: true,
            log_y: true,
            series: &[
                series(&rqt, |r| r.triangles as f64),
                series(&tin, |r| r.triangles as f64),
            ],
        },
    )?;
    s.figures.push(Figure {
        file: "mesh_triangles_vs_error.png".into(),
        caption: "Mesh size against measured error: RQT and TIN".into(),
    });
    plot::line_chart(
        &ctx.fig("mesh_time_vs_error.png"),
        640,
        420,
        &Chart {
            title: "Time against measured max error",
            x_label: "measured max error (m)",
            y_label: "ms",
            log_x: true,
            log_y: true,
            series: &[series(&rqt, |r| r.build_ms), series(&tin, |r| r.build_ms)],
        },
    )?;
    s.figures.push(Figure {
        file: "mesh_time_vs_error.png".into(),
        caption: "What accuracy costs: RQT refinement and TIN build time against measured error"
            .into(),
    });

    // Wireframes at three thresholds.
    let mut n = vec![Vec3::ZERO; (w * h) as usize];
    relief_core::normal_map(&hf, relief_core::NormalMethod::Sobel, &mut n)?;
    let sun = Vec3::new(-1.0, -1.0, 1.414).normalize();
    let shade: Vec<f32> = n.iter().map(|v| v.dot(sun).max(0.0)).collect();
    let picks = [
        errors[0],
        errors[errors.len() / 2],
        errors[errors.len() - 1],
    ];
    for e in picks {
        let r = Refiner::new(&hier, &hf, Criterion::MaxError(e))?;
        let m = rqt_mesh(&hf, &r)?;
        let name = format!("mesh_rqt_e{e}.png");
        wireframe(ctx, &name, &hf, &shade, &m)?;
        s.figures.push(Figure {
            file: name,
            caption: format!("RQT mesh at E = {e} m: {} triangles", m.triangles.len()),
        });
    }

    // View-dependent refinement along a fly-through.
    let frames = if ctx.quick { 6 } else { 24 };
    let tau = 1.0f32;
    let ext = hf.extent();
    let st = ctx.dem.stats();
    let mut ft = Table::new(
        "View-dependent refinement along a fly-through (640 x 480, 60 degrees, 1 pixel)",
        &[
            "frame",
            "triangles",
            "refine ms",
            "max screen error (px)",
            "in-view samples",
        ],
    );
    let mut frame_rows = Vec::new();
    let mut tri_pts = Vec::new();
    for f in 0..frames {
        let u = f as f32 / (frames - 1).max(1) as f32;
        let eye = Vec3::new(
            ext.x * (0.1 + 0.8 * u),
            ext.y * 0.15,
            st.max as f32 + 0.03 * ext.x.max(ext.y),
        );
        let target = eye + Vec3::new(0.2 * ext.x, 0.5 * ext.y, -(st.max - st.min) as f32);
        let cam = Camera::new(eye, target, 60.0, 640, 480)?;
        let view = View::new(&cam, tau)?;
        let r = Refiner::new(&hier, &hf, Criterion::View(view))?;
        let t = Instant::now();
        let m = rqt_mesh(&hf, &r)?;
        let ms = t.elapsed().as_secs_f64() * 1e3;
        let (px, count) = screen_error(&hf, &m, &cam);
        ft.row(vec![
            f.to_string(),
            m.triangles.len().to_string(),
            num(ms, 2),
            num(px, 3),
            count.to_string(),
        ]);
        tri_pts.push((f64::from(f), m.triangles.len() as f64));
        frame_rows.push(json!({"frame": f, "triangles": m.triangles.len(), "refine_ms": ms, "max_screen_error_px": px, "in_view_samples": count}));
        if px > f64::from(tau) * 1.0001 {
            return Err(CliError(format!(
                "frame {f}: screen-space error {px} px > {tau}"
            )));
        }
    }
    s.tables.push(ft);
    plot::line_chart(
        &ctx.fig("mesh_flythrough.png"),
        640,
        420,
        &Chart {
            title: "Fly-through: triangles per frame (1 pixel threshold)",
            x_label: "frame",
            y_label: "triangles",
            log_x: false,
            log_y: false,
            series: &[Series {
                label: "RQT view-dependent".into(),
                points: tri_pts,
            }],
        },
    )?;
    s.figures.push(Figure {
        file: "mesh_flythrough.png".into(),
        caption: "Triangles per frame of view-dependent refinement along the fly-through".into(),
    });
    s.summary = format!(
        "E = {}: rqt {} vs tin {} triangles",
        errors[errors.len() / 2],
        rqt[errors.len() / 2].triangles,
        tin[errors.len() / 2].triangles
    );
    let to_json = |r: &ComparisonRow| json!({"method": r.method, "max_error": r.target_error, "vertices": r.vertices, "triangles": r.triangles, "max_error_measured": r.max_error, "rms_error": r.rms_error, "refine_ms": r.build_ms});
    s.data = json!({
        "preprocess_ms": preprocess_ms,
        "bytes_per_vertex": hier.bytes_per_vertex(),
        "view_independent": all.iter().map(to_json).collect::<Vec<_>>(),
        "flythrough": frame_rows,
    });
    Ok(s)
}

/// Largest projected vertical error, in pixels, over the grid samples inside the view frustum,
/// and how many samples that was (CONVENTIONS: `e * (image_height / 2) / (tan(fov / 2) * d)`).
fn screen_error(hf: &Heightfield<'_, f32>, m: &GridMesh, cam: &Camera) -> (f64, usize) {
    let heights = mesh_heights(hf, m);
    let Ok(planes) = cam.frustum_planes(0.1, 1e9) else {
        return (f64::NAN, 0);
    };
    let s = hf.scale();
    let kappa = f64::from(cam.kappa());
    let (mut worst, mut count) = (0.0f64, 0usize);
    for y in 0..hf.height() {
        for x in 0..hf.width() {
            let z = hf.local_z(x, y);
            let p = Vec3::new(x as f32 * s.dx, y as f32 * s.dy, z + s.z_offset);
            if planes.iter().any(|pl| pl.dot(p.extend(1.0)) < 0.0) {
                continue;
            }
            count += 1;
            let mz = heights[(y * hf.width() + x) as usize];
            let e = if mz.is_nan() {
                f64::INFINITY
            } else {
                f64::from((mz - z).abs())
            };
            let d = f64::from((p - cam.eye).length());
            worst = worst.max(e * kappa / d);
        }
    }
    (worst, count)
}
