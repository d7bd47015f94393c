//! Golden-image tests of every diagram, and tests that a diagram follows the algorithm's state.
//!
//! Each diagram is compared with `tests/golden/<name>.png`: the sizes must match, and at most
//! 0.5 % of the pixels may differ by more than 2 (of 255) in some channel (room for rasteriser
//! rounding between CPUs, none for a changed drawing). On a mismatch the actual picture is
//! written next to the temporary directory's `relief-skia-<name>-actual.png`.
//!
//! Regenerate after an intended change, then look at the pictures before committing:
//! `RELIEF_BLESS=1 cargo test -p relief-skia --test golden`

use glam::{DVec2, Vec2, Vec3};
use relief_core::rbf::{
    adaptive_grid_bound, build_adaptive_grid, fit_cascades, AdaptiveGrid, CascadeOptions, Cell,
    GridOptions, InfluenceSets, Rbf, RbfOptions,
};
use relief_core::refine::{preprocess, Criterion, View};
use relief_core::{Camera, Heightfield, Scale, Terrain};
use relief_skia::dda::{dda, runs, DdaSpec, RunKind};
use relief_skia::rbf::{frustum_footprint, CascadeView};
use relief_skia::refine::{refine, refine_state, RefineInput};
use relief_skia::{hillshade, DiagramOptions, HillshadeOptions, Pixmap};
use std::path::PathBuf;

const N: u32 = 65;

/// A deterministic 65 x 65 terrain: two hills, a ridge and a gentle slope.
fn samples() -> Vec<f32> {
    let mut s = Vec::with_capacity((N * N) as usize);
    for y in 0..N {
        for x in 0..N {
            let (fx, fy) = (x as f32, y as f32);
            let hill = |cx: f32, cy: f32, r: f32, a: f32| {
                a * (-((fx - cx).powi(2) + (fy - cy).powi(2)) / (r * r)).exp()
            };
            let ridge = 6.0 * (-(fx - 0.6 * fy - 10.0).powi(2) / 30.0).exp();
            s.push(hill(20.0, 22.0, 9.0, 20.0) + hill(45.0, 44.0, 12.0, 14.0) + ridge + 0.05 * fx);
        }
    }
    s
}

fn golden_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests")
        .join("golden")
}

fn check(name: &str, actual: &Pixmap) {
    let path = golden_dir().join(format!("{name}.png"));
    if std::env::var_os("RELIEF_BLESS").is_some() {
        std::fs::create_dir_all(golden_dir()).unwrap();
        relief_skia::save_png(actual, &path).unwrap();
        return;
    }
    let expected = Pixmap::load_png(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e}; create it with RELIEF_BLESS=1 cargo test -p relief-skia --test golden",
            path.display()
        )
    });
    let dump = || {
        let p = std::env::temp_dir().join(format!("relief-skia-{name}-actual.png"));
        relief_skia::save_png(actual, &p).unwrap();
        p
    };
    if (expected.width(), expected.height()) != (actual.width(), actual.height()) {
        panic!(
            "{name}: size {}x{} vs golden {}x{} (actual written to {})",
            actual.width(),
            actual.height(),
            expected.width(),
            expected.height(),
            dump().display()
        );
    }
    let differing = expected
        .data()
        .chunks_exact(4)
        .zip(actual.data().chunks_exact(4))
        .filter(|(a, b)| a.iter().zip(b.iter()).any(|(x, y)| x.abs_diff(*y) > 2))
        .count();
    let total = (actual.width() * actual.height()) as usize;
    assert!(
        differing * 200 <= total,
        "{name}: {differing} of {total} pixels differ by more than 2 (actual written to {})",
        dump().display()
    );
}

fn opts() -> DiagramOptions<'static> {
    DiagramOptions::default().with_max_size(360)
}

fn camera() -> Camera {
    Camera::new(
        Vec3::new(6.0, 10.0, 16.0),
        Vec3::new(48.0, 40.0, 0.0),
        40.0,
        320,
        240,
    )
    .unwrap()
}

// ---------- DDA: seed 001, figure 6 ----------

#[test]
fn figure6_runs_match_the_paper() {
    let r = runs(&DdaSpec::seed001_figure6()).unwrap();
    // "we have 41 cells and 17 runs in this line segment ... r = 2 and r + 1 = 3"
    assert_eq!(r.len(), 17);
    assert_eq!(r.iter().map(|x| x.length8).sum::<u32>(), 41);
    assert!(r.iter().all(|x| x.length8 == 2 || x.length8 == 3));
    // "the run sequence lslslsslslsslslsss describes the structure of the runs": the paper's
    // string has one symbol more than its 17 runs; the 17 runs are its first 17 symbols.
    let seq: String = r.iter().map(|x| x.kind.symbol()).collect();
    assert!("lslslsslslsslslsss".starts_with(&seq), "{seq}");
    // "long runs ... correspond to the intercept values less than 7/41"; 7 of them (ratio 7/41).
    for x in &r {
        assert_eq!(
            x.kind == RunKind::Long,
            x.intercept < 7.0 / 41.0 - 1e-12,
            "{x:?}"
        );
        assert!((0.0..17.0 / 41.0).contains(&x.intercept));
    }
    assert_eq!(r.iter().filter(|x| x.kind == RunKind::Long).count(), 7);
    // Eq. 2: beta_j = alpha x_j - y_j, exactly, as printed.
    for x in &r {
        let c8 = x.run.cell(u32::from(x.extended)).unwrap();
        let num = (17 * c8[0] as i64) - 41 * c8[1] as i64;
        assert_eq!(x.intercept_label, format!("{num}/41"));
    }
    // Every run but the first is the 8-connected run extended by one cell (no corners inside).
    assert!(!r[0].extended && r[1..].iter().all(|x| x.extended));
}

#[test]
fn golden_dda_figure6() {
    let p = dda(
        &DdaSpec::seed001_figure6(),
        &DiagramOptions::default().with_max_size(800),
    )
    .unwrap();
    check("dda_figure6", &p);
}

#[test]
fn golden_dda_steep_negative() {
    let spec = DdaSpec {
        start: DVec2::new(9.3, 15.6),
        dir: DVec2::new(-3.0, -7.0),
        stop: DVec2::new(0.0, 0.0),
        cells: [12, 16],
    };
    let r = runs(&spec).unwrap();
    assert!(r.iter().all(|x| x.run.along_y));
    check("dda_steep_negative", &dda(&spec, &opts()).unwrap());
}

#[test]
fn golden_dda_over_hillshade() {
    let s = samples();
    let hf = Heightfield::new(&s, N, N).unwrap();
    let base = hillshade(&hf, &HillshadeOptions::default()).unwrap();
    let spec = DdaSpec {
        start: DVec2::new(3.5, 40.25),
        dir: DVec2::new(5.0, -2.0),
        stop: DVec2::new(30.0, 0.0),
        cells: [N - 1, N - 1],
    };
    check(
        "dda_over_hillshade",
        &dda(&spec, &opts().with_background(Some(&base))).unwrap(),
    );
}

#[test]
fn a_different_ray_draws_different_cells() {
    let a = DdaSpec::seed001_figure6();
    let b = DdaSpec {
        dir: DVec2::new(41.0, 13.0),
        ..a
    };
    let (pa, pb) = (dda(&a, &opts()).unwrap(), dda(&b, &opts()).unwrap());
    assert_ne!(pa, pb);
    // Same ray, same picture (deterministic).
    assert_eq!(pa, dda(&a, &opts()).unwrap());
}

#[test]
fn dda_rejects_bad_rays() {
    let bad = DdaSpec {
        start: DVec2::new(f64::NAN, 0.0),
        ..DdaSpec::seed001_figure6()
    };
    assert!(dda(&bad, &opts()).is_err());
    let empty = DdaSpec {
        cells: [0, 3],
        ..DdaSpec::seed001_figure6()
    };
    assert!(dda(&empty, &opts()).is_err());
}

// ---------- hillshade ----------

#[test]
fn golden_hillshade() {
    let s = samples();
    let hf = Heightfield::new(&s, N, N).unwrap();
    let p = hillshade(&hf, &HillshadeOptions::default()).unwrap();
    check("hillshade", &p);
}

#[test]
fn hillshade_rejects_bad_options() {
    let s = samples();
    let hf = Heightfield::new(&s, N, N).unwrap();
    assert!(hillshade(&hf, &HillshadeOptions::default().with_ambient(2.0)).is_err());
    assert!(hillshade(&hf, &HillshadeOptions::default().with_light(f32::NAN, 1.0)).is_err());
}

// ---------- RBF: seed 002, figure 2 ----------

fn with_rbf<R>(max_error: f32, f: impl FnOnce(&Rbf<'_>) -> R) -> R {
    let s = samples();
    let hf = Heightfield::new(&s, N, N).unwrap();
    let mut cells = vec![Cell::default(); adaptive_grid_bound(N, N).unwrap()];
    let go = GridOptions::default()
        .with_max_error(max_error)
        .with_cells(1, 16);
    let n = build_adaptive_grid(&hf, &go, &mut cells).unwrap();
    let mut index = vec![0; (N * N) as usize];
    let grid = AdaptiveGrid::new(N, N, &cells[..n], &mut index).unwrap();
    let o = RbfOptions::default();
    let mut offsets = vec![0; InfluenceSets::offsets_len(&grid)];
    let mut entries = vec![0; InfluenceSets::entries_len(&grid, &o).unwrap()];
    let sets = InfluenceSets::build(&grid, &o, &mut offsets, &mut entries).unwrap();
    let rbf = Rbf::new(grid, sets, &o).unwrap();
    f(&rbf)
}

fn chosen(rbf: &Rbf<'_>) -> Vec<usize> {
    [
        Vec2::new(40.0, 14.0),
        Vec2::new(20.0, 22.0),
        Vec2::new(4.0, 60.0),
    ]
    .iter()
    .filter_map(|p| rbf.grid().cell_containing(*p))
    .collect()
}

#[test]
fn golden_rbf() {
    with_rbf(0.5, |rbf| {
        let ch = chosen(rbf);
        assert_eq!(ch.len(), 3);
        check("rbf", &relief_skia::rbf::rbf(rbf, &ch, &opts()).unwrap());
    });
}

#[test]
fn rbf_diagram_follows_the_grid() {
    let a = with_rbf(0.5, |rbf| {
        relief_skia::rbf::rbf(rbf, &chosen(rbf), &opts()).unwrap()
    });
    let b = with_rbf(3.0, |rbf| {
        relief_skia::rbf::rbf(rbf, &chosen(rbf), &opts()).unwrap()
    });
    assert_ne!(a, b, "a coarser adaptive grid must draw differently");
}

// ---------- cascades: seed 002, figure 1a ----------

fn cascades_picture(cam: &Camera, background: Option<&Pixmap>) -> Pixmap {
    let s = samples();
    let hf = Heightfield::new(&s, N, N).unwrap();
    let mut cells = vec![Cell::default(); adaptive_grid_bound(N, N).unwrap()];
    let n =
        build_adaptive_grid(&hf, &GridOptions::default().with_max_error(1.0), &mut cells).unwrap();
    let mut index = vec![0; (N * N) as usize];
    let grid = AdaptiveGrid::new(N, N, &cells[..n], &mut index).unwrap();
    let (lo, hi) = s
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    let fit = fit_cascades(
        cam,
        &grid,
        &Scale::default(),
        (lo, hi),
        &CascadeOptions::default().with_resolution(16),
        None,
    )
    .unwrap();
    assert!(fit.visible);
    let view = CascadeView {
        camera: cam,
        scale: Scale::default(),
        size: [N, N],
    };
    relief_skia::rbf::cascades(&fit, &view, &opts().with_background(background)).unwrap()
}

#[test]
fn golden_cascades() {
    let s = samples();
    let hf = Heightfield::new(&s, N, N).unwrap();
    let base = hillshade(&hf, &HillshadeOptions::default()).unwrap();
    let cam = Camera::new(
        Vec3::new(-10.0, 20.0, 25.0),
        Vec3::new(40.0, 36.0, 0.0),
        50.0,
        320,
        240,
    )
    .unwrap();
    check("cascades", &cascades_picture(&cam, Some(&base)));
}

#[test]
fn cascades_follow_the_camera() {
    let other = Camera::new(
        Vec3::new(70.0, 70.0, 25.0),
        Vec3::new(20.0, 30.0, 0.0),
        50.0,
        320,
        240,
    )
    .unwrap();
    assert_ne!(
        cascades_picture(&camera(), None),
        cascades_picture(&other, None)
    );
}

/// The footprint drawn (frustum planes of the core's `Camera`, cut by the fit's height range)
/// agrees with the hull the core's cascade fitting built independently (from the camera's
/// corner rays): the hull is the footprint clipped to the domain, so every cascade vertex lies
/// in the footprint and every footprint vertex inside the domain is a cascade vertex.
#[test]
fn frustum_footprint_contains_the_cascade_hull() {
    let s = samples();
    let mut cells = vec![Cell::default(); adaptive_grid_bound(N, N).unwrap()];
    let hf = Heightfield::new(&s, N, N).unwrap();
    let n =
        build_adaptive_grid(&hf, &GridOptions::default().with_max_error(1.0), &mut cells).unwrap();
    let mut index = vec![0; (N * N) as usize];
    let grid = AdaptiveGrid::new(N, N, &cells[..n], &mut index).unwrap();
    let views = [
        (
            Vec3::new(-10.0, 20.0, 25.0),
            Vec3::new(40.0, 36.0, 0.0),
            50.0,
        ),
        (
            Vec3::new(70.0, 70.0, 25.0),
            Vec3::new(20.0, 30.0, 0.0),
            50.0,
        ),
        (
            Vec3::new(32.0, -40.0, 60.0),
            Vec3::new(32.0, 30.0, 0.0),
            30.0,
        ),
        (
            Vec3::new(30.0, 30.0, 10.0),
            Vec3::new(60.0, 35.0, 5.0),
            70.0,
        ),
    ];
    let mut matched = 0;
    for (eye, target, fov) in views {
        let cam = Camera::new(eye, target, fov, 320, 240).unwrap();
        let fit = fit_cascades(
            &cam,
            &grid,
            &Scale::default(),
            (0.0, 25.0),
            &CascadeOptions::default().with_resolution(16),
            None,
        )
        .unwrap();
        assert!(fit.visible);
        let foot = frustum_footprint(&cam, fit.frustum, fit.z_range).unwrap();
        assert!(foot.len() >= 3, "{eye}");
        let tol = 1e-3;
        let inside = |q: DVec2| {
            foot.iter()
                .zip(foot.iter().cycle().skip(1))
                .all(|(a, b)| (*b - *a).perp_dot(q - *a) / (*b - *a).length() >= -tol)
        };
        let hull: Vec<DVec2> = fit
            .cascades
            .iter()
            .flat_map(|k| k.polygon().iter().map(|p| p.as_dvec2()))
            .collect();
        for q in &hull {
            assert!(inside(*q), "{eye}: hull vertex {q} outside the footprint");
        }
        let edge = f64::from(N - 1);
        for p in &foot {
            if p.x > tol && p.y > tol && p.x < edge - tol && p.y < edge - tol {
                let d = hull.iter().map(|q| q.distance(*p)).fold(f64::MAX, f64::min);
                assert!(
                    d < 1e-2,
                    "{eye}: footprint vertex {p} is no hull vertex ({d})"
                );
                matched += 1;
            }
        }
        // The footprint (not a wedge) is drawn: its outline is in the picture's pixels.
        let view = CascadeView {
            camera: &cam,
            scale: Scale::default(),
            size: [N, N],
        };
        let a = relief_skia::rbf::cascades(&fit, &view, &opts()).unwrap();
        let mut lower = fit;
        lower.z_range = [0.0, 5.0];
        let b = relief_skia::rbf::cascades(&lower, &view, &opts()).unwrap();
        assert_ne!(a, b, "{eye}: the footprint must follow the height range");
    }
    assert!(
        matched >= 4,
        "{matched} footprint vertices inside the domains"
    );
}

// ---------- refine: seed 004 ----------

#[test]
fn golden_refine_max_error() {
    let s = samples();
    let hf = Heightfield::new(&s, N, N).unwrap();
    let (mut e, mut r) = (vec![0.0; (N * N) as usize], vec![0.0; (N * N) as usize]);
    let h = preprocess(&hf, &mut e, &mut r).unwrap();
    let input = RefineInput::new(&hf, &h, Criterion::MaxError(1.0)).with_circle_level(Some(9));
    check("refine_max_error", &refine(&input, &opts()).unwrap());
}

#[test]
fn golden_refine_view_culling_lazy() {
    let s = samples();
    let hf = Heightfield::new(&s, N, N).unwrap();
    let (mut e, mut r) = (vec![0.0; (N * N) as usize], vec![0.0; (N * N) as usize]);
    let h = preprocess(&hf, &mut e, &mut r).unwrap();
    let cam = camera();
    let view = View::new(&cam, 2.0).unwrap().with_lazy_levels(5);
    let input = RefineInput::new(&hf, &h, Criterion::View(view))
        .with_camera(Some(&cam))
        .with_circle_level(Some(6));
    let st = refine_state(&input).unwrap();
    // Culling dropped part of the domain: fewer triangles cover less than the full square.
    let area: f32 = st
        .triangles
        .iter()
        .map(|t| {
            let p = t.map(|i| st.vertices[i as usize]);
            ((p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]))
                .abs()
                / 2.0
        })
        .sum();
    assert!(area < ((N - 1) * (N - 1)) as f32, "nothing culled: {area}");
    let base = hillshade(&hf, &HillshadeOptions::default()).unwrap();
    check(
        "refine_view",
        &refine(&input, &opts().with_background(Some(&base))).unwrap(),
    );
}

#[test]
fn golden_strips_square_and_not() {
    use relief_skia::strip::{strip, strip_state, StripKind};
    let s = samples();
    // The square grid and a cut of it that is not (2^k+1)^2.
    let cut: Vec<f32> = (0..N - 20)
        .flat_map(|y| {
            s[(y * N) as usize..(y * N + N - 9) as usize]
                .iter()
                .copied()
        })
        .collect();
    for (name, samples, w, h, counts) in [
        ("strip_inout_square", &s, N, N, (440, Some(439))),
        ("strip_inout_cut", &cut, N - 9, N - 20, (818, Some(741))),
    ] {
        let hf = Heightfield::new(samples, w, h).unwrap();
        let n = (w * h) as usize;
        let (mut e, mut r) = (vec![0.0; n], vec![0.0; n]);
        let hi = preprocess(&hf, &mut e, &mut r).unwrap();
        let input = RefineInput::new(&hf, &hi, Criterion::MaxError(1.0));
        let st = strip_state(&input, StripKind::InOut).unwrap();
        assert_eq!(st.triangles.len(), st.counts.triangles);
        // One piece on the square; pieces joined off it.
        assert_eq!(
            st.joins.is_empty(),
            w == N,
            "{name}: {} joins",
            st.joins.len()
        );
        let soar = strip_state(&input, StripKind::Soar).unwrap();
        assert!(soar.counts.tested > st.counts.tested);
        // The title's counts, which the pixel comparison would let change by a digit.
        std::println!(
            "{name}: {} indices, fewest {:?}",
            st.counts.indices,
            st.fewest
        );
        assert_eq!((st.counts.indices, st.fewest), counts, "{name}");
        check(name, &strip(&input, StripKind::InOut, &opts()).unwrap());
    }
}

#[test]
fn a_different_threshold_draws_a_different_mesh() {
    let s = samples();
    let hf = Heightfield::new(&s, N, N).unwrap();
    let (mut e, mut r) = (vec![0.0; (N * N) as usize], vec![0.0; (N * N) as usize]);
    let h = preprocess(&hf, &mut e, &mut r).unwrap();
    let fine = RefineInput::new(&hf, &h, Criterion::MaxError(0.5));
    let coarse = RefineInput::new(&hf, &h, Criterion::MaxError(4.0));
    let (sf, sc) = (refine_state(&fine).unwrap(), refine_state(&coarse).unwrap());
    assert!(sf.triangles.len() > sc.triangles.len());
    assert_ne!(
        refine(&fine, &opts()).unwrap(),
        refine(&coarse, &opts()).unwrap()
    );
}

#[test]
fn lazy_accepted_vertices_come_from_the_core() {
    let s = samples();
    let hf = Heightfield::new(&s, N, N).unwrap();
    let (mut e, mut r) = (vec![0.0; (N * N) as usize], vec![0.0; (N * N) as usize]);
    let h = preprocess(&hf, &mut e, &mut r).unwrap();
    let cam = camera();
    let strict = View::new(&cam, 2.0).unwrap().with_lazy_levels(0);
    let st = refine_state(&RefineInput::new(&hf, &h, Criterion::View(strict))).unwrap();
    assert!(
        st.lazy_accepted.is_empty(),
        "no lazy levels, nothing lazily accepted"
    );
    let lazy = View::new(&cam, 2.0).unwrap().with_lazy_levels(6);
    let sl = refine_state(&RefineInput::new(&hf, &h, Criterion::View(lazy))).unwrap();
    // Every lazily accepted vertex is in the lazy mesh.
    for g in &sl.lazy_accepted {
        assert!(sl
            .vertices
            .iter()
            .any(|v| v[0] as u32 == g[0] && v[1] as u32 == g[1] && hf.width() > g[0]));
    }
}

#[test]
fn intercepts_and_lengths_are_consistent_in_every_octant() {
    for (k, &(dx, dy)) in [
        (41.0, 17.0),
        (-41.0, 17.0),
        (41.0, -17.0),
        (-3.0, -7.0),
        (7.0, -3.0),
        (2.0, 9.0),
        (-0.37, 0.91),
        (5.0, 1.0),
    ]
    .iter()
    .enumerate()
    {
        let start = DVec2::new(12.3 + k as f64 * 0.11, 9.7 - k as f64 * 0.07);
        let spec = DdaSpec {
            start,
            dir: DVec2::new(dx, dy),
            stop: start + DVec2::new(dx, dy) * 100.0,
            cells: [25, 20],
        };
        let r = runs(&spec).unwrap();
        let line = spec.line().unwrap();
        let n_cells = line.cells().count() as u32;
        assert_eq!(r.iter().map(|x| x.run.len).sum::<u32>(), n_cells);
        let major = if dx.abs() >= dy.abs() {
            dx.abs()
        } else {
            dy.abs()
        };
        let minor = if dx.abs() >= dy.abs() {
            dy.abs()
        } else {
            dx.abs()
        };
        let rr = (major / minor).floor() as u32;
        let alpha = minor / major;
        let (ku, kv) = if dx.abs() >= dy.abs() { (0, 1) } else { (1, 0) };
        let (su, sv, du, dv) = (start[ku], start[kv], spec.dir[ku], spec.dir[kv]);
        for (j, x) in r.iter().enumerate() {
            // The core's intercept (seed 001, eq. 2): the line's minor coordinate at the left
            // face (along the direction of travel) of the run's first 8-connected cell, less its
            // row, in the folded frame; for the first run at the start cell's face, so it may be
            // negative there.
            let range = if j == 0 { -alpha..1.0 } else { 0.0..alpha };
            assert!(range.contains(&x.intercept), "{dx},{dy} run {j}: {x:?}");
            let c8 = x.run.cell(u32::from(x.extended)).unwrap_or_else(|| {
                let a = x.run.start;
                let mut c = [a[0] as i64, a[1] as i64];
                c[ku] += i64::from(x.run.step);
                [c[0] as u32, c[1] as u32]
            });
            let face = f64::from(c8[ku]) + if du >= 0.0 { 0.0 } else { 1.0 };
            let v = sv + dv / du * (face - su);
            let row = f64::from(c8[kv]);
            let beta = if dv >= 0.0 { v - row } else { row + 1.0 - v };
            assert!(
                (beta - x.intercept).abs() < 1e-5,
                "{dx},{dy} run {j}: {x:?} vs {beta}"
            );
            let inner = j > 0 && j + 1 < r.len();
            if inner {
                assert!(x.extended, "{dx},{dy} run {j}");
                assert!(matches!(x.kind, RunKind::Short | RunKind::Long), "{x:?}");
                // Paper: long exactly when beta_j < nu = 1 - alpha r.
                let nu = 1.0 - minor / major * rr as f64;
                assert_eq!(
                    x.kind == RunKind::Long,
                    x.intercept < nu - 1e-9,
                    "{dx},{dy} {x:?}"
                );
            }
        }
    }
}

// ---------- silhouette: seed 000, figure 9 ----------

fn silhouette_camera() -> Camera {
    Camera::new(
        Vec3::new(32.0, -30.0, 28.0),
        Vec3::new(32.0, 40.0, 0.0),
        50.0,
        240,
        160,
    )
    .unwrap()
}

#[test]
fn golden_silhouette() {
    let s = samples();
    let hf = Heightfield::new(&s, N, N).unwrap();
    let p = relief_skia::silhouette::silhouette(&hf, &silhouette_camera(), 0.01, &[2, 3], &opts())
        .unwrap();
    check("silhouette", &p);
}

#[test]
fn silhouette_follows_the_camera_and_levels() {
    let s = samples();
    let hf = Heightfield::new(&s, N, N).unwrap();
    let a = relief_skia::silhouette::silhouette(&hf, &silhouette_camera(), 0.01, &[2], &opts())
        .unwrap();
    let b = relief_skia::silhouette::silhouette(&hf, &silhouette_camera(), 0.01, &[5], &opts())
        .unwrap();
    assert_ne!(a, b);
    let other = Camera::new(
        Vec3::new(10.0, -30.0, 20.0),
        Vec3::new(40.0, 40.0, 0.0),
        50.0,
        240,
        160,
    )
    .unwrap();
    let c = relief_skia::silhouette::silhouette(&hf, &other, 0.01, &[2], &opts()).unwrap();
    assert_ne!(a, c);
    assert!(relief_skia::silhouette::silhouette(&hf, &other, 0.01, &[40], &opts()).is_err());
    assert!(relief_skia::silhouette::silhouette(&hf, &other, -1.0, &[2], &opts()).is_err());
}
