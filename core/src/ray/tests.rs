//! Tests of the ray module: DDA equivalence (exact rational reference, property tests),
//! brute-force triangle reference, agreement of all exact methods, and the named hard cases
//! listed in HARD_CASES.md.

use super::*;
use crate::{Heightfield, Scale, Surface};
use glam::{DVec2, DVec3, Vec3};
use proptest::prelude::*;

const SURFACES: [Surface; 4] = [
    Surface::Triangles,
    Surface::Bilinear,
    Surface::Plane,
    Surface::Nearest,
];

// ---------------------------------------------------------------------------------------------
// Exact rational reference DDA.

/// 4-connected cells of the line from `s / 2^21` along integer direction `(p, q)` until it
/// leaves the `nx x ny` grid, by exact rational comparison of the crossing parameters
/// (Amanatides & Woo with exact arithmetic; diagonal step on exact corner ties).
fn reference_cells(sx: i128, sy: i128, p: i128, q: i128, nx: i128, ny: i128) -> Vec<[u32; 2]> {
    let d = 1i128 << 21;
    let start_cell = |s: i128, v: i128, n: i128| -> i128 {
        let c = if v > 0 {
            s.div_euclid(d)
        } else if v < 0 {
            // Point on a face: the cell ahead in the negative direction.
            (s + d - 1).div_euclid(d) - 1
        } else if s == n * d {
            n - 1
        } else {
            s.div_euclid(d)
        };
        c.clamp(0, n - 1)
    };
    let (mut cx, mut cy) = (start_cell(sx, p, nx), start_cell(sy, q, ny));
    let mut out = Vec::new();
    while cx >= 0 && cy >= 0 && cx < nx && cy < ny {
        out.push([cx as u32, cy as u32]);
        if p == 0 && q == 0 {
            break;
        }
        // Distances to the next faces ahead (in units of 1/d), as |face - s|.
        let fx = if p > 0 { (cx + 1) * d } else { cx * d };
        let fy = if q > 0 { (cy + 1) * d } else { cy * d };
        let lx = (fx - sx).abs() * q.abs(); // lambda_x * |p| |q| d
        let ly = (fy - sy).abs() * p.abs();
        let step_x = p != 0 && (q == 0 || lx <= ly);
        let step_y = q != 0 && (p == 0 || ly <= lx);
        if step_x {
            cx += p.signum();
        }
        if step_y {
            cy += q.signum();
        }
    }
    out
}

/// `out` with the items of `it` pushed through `Iterator::fold` (the DDAs' own loops).
fn pushed<I: Iterator>(out: Vec<I::Item>, it: I) -> Vec<I::Item> {
    it.fold(out, |mut o, x| {
        o.push(x);
        o
    })
}

fn line_for(sx: i128, sy: i128, p: i128, q: i128, nx: u32, ny: u32) -> GridLine {
    let d = (1i128 << 21) as f64;
    let start = DVec2::new(sx as f64 / d, sy as f64 / d);
    let dir = DVec2::new(p as f64, q as f64);
    // Far past the grid: traverse to the border.
    let stop = start + dir * 1e6;
    GridLine::new(start, dir, stop, [nx, ny]).unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn dda_matches_exact_rational_reference(
        nx in 1u32..40, ny in 1u32..40,
        fx in 0.0f64..1.0, fy in 0.0f64..1.0,
        // Coarse fractions make exact corner hits common.
        grid in prop_oneof![Just(1i128), Just(4), Just(1 << 21)],
        p in -9i128..10, q in -9i128..10,
    ) {
        let d = 1i128 << 21;
        let sx = ((fx * nx as f64 * grid as f64) as i128) * (d / grid);
        let sy = ((fy * ny as f64 * grid as f64) as i128) * (d / grid);
        let line = line_for(sx, sy, p, q, nx, ny);
        let want = reference_cells(sx, sy, p, q, nx as i128, ny as i128);
        let cells: Vec<[u32; 2]> = line.cells().collect();
        prop_assert_eq!(&cells, &want);
        let from_runs: Vec<[u32; 2]> = line.runs().flat_map(|r| r.cells()).collect();
        prop_assert_eq!(&from_runs, &want);
        prop_assert!(cells.len() as u64 <= line.step_bound());
        // Internal iteration (`fold`, the loops without a column test) gives the same cells.
        let folded: Vec<[u32; 2]> = pushed(Vec::new(), line.cells());
        prop_assert_eq!(&folded, &want);
        let runs: Vec<CellRun> = line.runs().collect();
        let folded_runs: Vec<CellRun> = pushed(Vec::new(), line.runs());
        prop_assert_eq!(&folded_runs, &runs);
    }

    #[test]
    fn run_dda_implies_cell_dda_for_any_float_ray(
        nx in 1u32..300, ny in 1u32..300,
        sx in 0.0f64..1.0, sy in 0.0f64..1.0,
        ang in 0.0f64..core::f64::consts::TAU,
        len in 0.0f64..500.0,
        skip in 0.0f64..1.0,
    ) {
        let start = DVec2::new(sx * nx as f64, sy * ny as f64);
        let dir = DVec2::new(libm::cos(ang), libm::sin(ang));
        let line = GridLine::new(start, dir, start + dir * len, [nx, ny]).unwrap();
        let cells: Vec<[u32; 2]> = line.cells().collect();
        let runs: Vec<CellRun> = line.runs().collect();
        let from_runs: Vec<[u32; 2]> = runs.iter().flat_map(|r| r.cells()).collect();
        prop_assert_eq!(&from_runs, &cells);
        prop_assert!(!cells.is_empty());
        // `fold` after `skip` items taken by `next`: the same sequences, in the loops without a
        // column test.
        let skip = (skip * cells.len() as f64) as usize;
        let mut it = line.cells();
        let mut folded: Vec<[u32; 2]> = it.by_ref().take(skip).collect();
        folded = pushed(folded, it);
        prop_assert_eq!(&folded, &cells);
        let skip = skip.min(runs.len());
        let mut it = line.runs();
        let mut folded: Vec<CellRun> = it.by_ref().take(skip).collect();
        folded = pushed(folded, it);
        prop_assert_eq!(&folded, &runs);
        prop_assert!(runs.iter().all(|r| r.len >= 1));
        // 4-connected except diagonal corner steps.
        for w in cells.windows(2) {
            let dx = (w[1][0] as i64 - w[0][0] as i64).abs();
            let dy = (w[1][1] as i64 - w[0][1] as i64).abs();
            prop_assert!(dx <= 1 && dy <= 1 && dx + dy >= 1);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// Start, direction and stop anywhere, inside or outside the grid, the stop possibly behind
    /// the start: `fold` (the loops bounded by `GridLine::v_end`) and `next` walk the same cells
    /// and runs.
    #[test]
    fn dda_fold_matches_next_for_any_stop(
        nx in 1u32..60, ny in 1u32..60,
        s in prop::array::uniform2(-20.0f64..80.0),
        d in prop::array::uniform2(-3.0f64..3.0),
        e in prop::array::uniform2(-20.0f64..80.0),
        coarse in any::<bool>(),
    ) {
        // Coarse values put starts, stops and slopes on grid lines and corners.
        let q = |x: f64| if coarse { libm::round(x * 2.0) / 2.0 } else { x };
        let (s, d, e) = (DVec2::new(q(s[0]), q(s[1])), DVec2::new(q(d[0]), q(d[1])), DVec2::new(q(e[0]), q(e[1])));
        let line = GridLine::new(s, d, e, [nx, ny]).unwrap();
        let cells: Vec<[u32; 2]> = line.cells().collect();
        let folded: Vec<[u32; 2]> = pushed(Vec::new(), line.cells());
        prop_assert_eq!(&folded, &cells);
        let runs: Vec<CellRun> = line.runs().collect();
        let folded: Vec<CellRun> = pushed(Vec::new(), line.runs());
        prop_assert_eq!(&folded, &runs);
        let from_runs: Vec<[u32; 2]> = runs.iter().flat_map(|r| r.cells()).collect();
        prop_assert_eq!(&from_runs, &cells);
        prop_assert!(cells.len() as u64 <= line.step_bound());
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// `GridLine::v_end` (an `f64` quotient corrected with `i128` products) equals the exact
    /// `i128` quotient, on grids up to the largest allowed (`2^30` cells an axis), where the
    /// line's height reaches 2^92 intercept units.
    #[test]
    fn dda_last_row_is_the_exact_quotient(
        lx in 0u32..31, ly in 0u32..31,
        s in prop::array::uniform2(0.0f64..1.0),
        ang in 0.0f64..core::f64::consts::TAU,
        len in prop::array::uniform2(0.0f64..1.5),
        corners in any::<bool>(),
    ) {
        let (nx, ny) = (1u32 << lx, 1u32 << ly);
        let mut start = DVec2::new(s[0] * nx as f64, s[1] * ny as f64);
        let mut dir = DVec2::new(libm::cos(ang), libm::sin(ang));
        if corners {
            // Integer starts and small integer slopes: the line meets grid corners exactly,
            // where the estimate's `f64` rounding lands on the wrong side of the quotient.
            start = DVec2::new(libm::floor(start.x), libm::floor(start.y));
            dir = DVec2::new(libm::round(dir.x * 7.0), libm::round(dir.y * 7.0));
        }
        let stop = start + DVec2::new(dir.x * len[0] * nx as f64, dir.y * len[1] * ny as f64);
        let stop = if corners { DVec2::new(libm::floor(stop.x), libm::floor(stop.y)) } else { stop };
        let l = GridLine::new(start, dir, stop, [nx, ny]).unwrap();
        let want = if l.u_last < l.u0 || l.v_last < l.v0 {
            l.v0 - 1
        } else {
            let h = l.b0 as i128 + (l.u_last - l.u0 + 1) as i128 * l.a as i128;
            let top = (h - 1).div_euclid(l.q as i128).max(0) as i64;
            l.v_last.min(l.v0 + top)
        };
        prop_assert_eq!(l.v_end, want);
    }
}

#[test]
fn dda_slope_one_over_k_has_one_run_length() {
    for k in 2..12i128 {
        // Start fraction with 21 bits: the line never passes a corner for k < 12.
        let line = line_for(0, (1 << 18) + 12345, k, 1, 200, 30);
        let lens: Vec<u32> = line.runs().map(|r| r.len).collect();
        // After the truncated first run and before the last, all runs have k + 1 cells (4-conn).
        let inner = &lens[1..lens.len() - 1];
        assert!(inner.iter().all(|&l| l as i128 == k + 1), "k={k}: {lens:?}");
        // Through corners: start at a corner, one run length k, no extension.
        let line = line_for(0, 0, k, 1, 200, 30);
        let lens: Vec<u32> = line.runs().map(|r| r.len).collect();
        assert!(
            lens[..lens.len() - 1].iter().all(|&l| l as i128 == k),
            "{lens:?}"
        );
    }
}

#[test]
fn dda_two_run_lengths_17_over_41() {
    // The paper's example line y = 17/41 x: runs of 2 and 3 (8-connected), 3 and 4 here.
    let line = line_for(0, 0, 41, 17, 41, 17);
    let lens: Vec<u32> = line.runs().map(|r| r.len).collect();
    assert_eq!(lens.len(), 17);
    assert!(lens.iter().all(|&l| (2..=4).contains(&l)), "{lens:?}");
    let cells: usize = lens.iter().map(|&l| l as usize).sum();
    assert_eq!(cells, line.cells().count());
}

// ---------------------------------------------------------------------------------------------
// Helpers for tracing.

fn tracer_all<'a>(
    hf: &'a Heightfield<'a, f32>,
    surface: Surface,
    rbuf: &'a mut Vec<f32>,
    mbuf: &'a mut Vec<f32>,
) -> (
    RayTracer<'a, Heightfield<'a, f32>>,
    RunAccel<'a>,
    MaxMip<'a>,
) {
    let (w, h) = (hf.width(), hf.height());
    rbuf.resize(RunAccel::len(w, h).unwrap(), 0.0);
    mbuf.resize(MaxMip::len(w, h).unwrap(), 0.0);
    let acc = RunAccel::build(hf, rbuf).unwrap();
    let mip = MaxMip::build(hf, mbuf).unwrap();
    (RayTracer::new(hf, surface), acc, mip)
}

/// Traces with every exact method, asserts they agree, returns the cell-DDA hit.
fn trace_exact(hf: &Heightfield<'_, f32>, surface: Surface, ray: &Ray) -> Option<Hit> {
    let (mut a, mut b) = (Vec::new(), Vec::new());
    let (t, acc, mip) = tracer_all(hf, surface, &mut a, &mut b);
    let c = t.trace_cell_dda(ray);
    let r = t.trace_run_dda(ray, &acc).unwrap();
    let m = t.trace_maxmip(ray, &mip).unwrap();
    // The packet entry point gives the same trace (hit and counters) alone and inside a
    // packet of other rays; the AVX-512 variant is checked the same way in
    // tests/tests/rays_packet.rs (the core forbids the `unsafe` its call needs).
    let mut packet = [Trace::default(); 3];
    let down = Ray::new(glam::Vec3::new(0.5, 0.5, 1e3), -glam::Vec3::Z).unwrap();
    t.trace_maxmip_packet(&[down, *ray, *ray], &mip, &mut packet)
        .unwrap();
    assert_eq!(packet[1], m);
    assert_eq!(packet[2], m);
    assert_eq!(packet[0], t.trace_maxmip(&down, &mip).unwrap());
    // The sixteen-wide walk (portable form): the same hit, the same cells or fewer; its slice
    // form the same trace alone and among other rays.
    let wide = t.trace_maxmip_wide(ray, &mip).unwrap();
    assert_eq!(wide.hit, m.hit, "wide walk for {ray:?}");
    assert!(wide.cells <= m.cells, "{wide:?} {m:?}");
    let mut wides = [Trace::default(); 3];
    t.trace_maxmip_wide_rays(&[*ray, down, *ray], &mip, &mut wides)
        .unwrap();
    assert_eq!(
        wides,
        [wide, t.trace_maxmip_wide(&down, &mip).unwrap(), wide]
    );
    assert!(c.steps as u64 <= t.step_bound());
    assert!(
        (m.steps as u64) < mip.step_bound(),
        "max-mip hit its step bound"
    );
    for (name, other) in [("run-dda", r.hit), ("maxmip", m.hit)] {
        match (c.hit, other) {
            (None, None) => {}
            (Some(x), Some(y)) => assert!(
                (x.t - y.t).abs() <= 1e-9 * x.t.abs().max(1.0),
                "{surface:?} {name}: cell-dda t={} vs {}",
                x.t,
                y.t
            ),
            (x, y) => panic!("{surface:?} {name}: cell-dda {x:?} vs {y:?} for {ray:?}"),
        }
    }
    c.hit
}

fn grid(w: u32, h: u32, mut f: impl FnMut(u32, u32) -> f32) -> Vec<f32> {
    let mut out = Vec::new();
    for y in 0..h {
        for x in 0..w {
            out.push(f(x, y));
        }
    }
    out
}

/// Brute force: smallest t >= 0 over every triangle of the `triangles` surface (Moller-Trumbore
/// in f64, unit spacing, no scale).
fn brute_force_triangles(s: &[f32], w: u32, h: u32, o: DVec3, d: DVec3) -> Option<f64> {
    let p = |x: u32, y: u32| DVec3::new(x as f64, y as f64, s[(y * w + x) as usize] as f64);
    let mut best: Option<f64> = None;
    for cy in 0..h - 1 {
        for cx in 0..w - 1 {
            let (a, b, c, e) = (p(cx, cy), p(cx + 1, cy), p(cx + 1, cy + 1), p(cx, cy + 1));
            for (v0, v1, v2) in [(a, b, c), (a, c, e)] {
                let e1 = v1 - v0;
                let e2 = v2 - v0;
                let pv = d.cross(e2);
                let det = e1.dot(pv);
                if det.abs() < 1e-300 {
                    continue;
                }
                let tv = o - v0;
                let u = tv.dot(pv) / det;
                let qv = tv.cross(e1);
                let v = d.dot(qv) / det;
                let t = e2.dot(qv) / det;
                let eps = 1e-12;
                if u >= -eps && v >= -eps && u + v <= 1.0 + eps && t >= 0.0 {
                    best = Some(best.map_or(t, |b: f64| b.min(t)));
                }
            }
        }
    }
    best
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn triangles_match_brute_force_on_small_grids(
        w in 2u32..9, h in 2u32..9,
        seed in any::<u64>(),
        // Origins above the domain (a ray entering through a side below the surface hits the
        // side by this module's rule, which a triangle mesh does not have).
        ox in 0.0f64..1.0, oy in 0.0f64..1.0, oz in 10.5f64..20.0,
        tx in 0.0f64..1.0, ty in 0.0f64..1.0, tz in -1.0f64..10.0,
    ) {
        let mut st = seed | 1;
        let s = grid(w, h, |_, _| {
            st ^= st << 13; st ^= st >> 7; st ^= st << 17;
            (st % 1000) as f32 / 100.0
        });
        let hf = Heightfield::new(&s, w, h).unwrap();
        let o = DVec3::new(ox * (w - 1) as f64, oy * (h - 1) as f64, oz);
        let target = DVec3::new(tx * (w - 1) as f64, ty * (h - 1) as f64, tz);
        let d = (target - o).normalize();
        let ray = Ray::new_f64(o, d).unwrap();
        let got = trace_exact(&hf, Surface::Triangles, &ray).map(|h| h.t);
        let want = brute_force_triangles(&s, w, h, o, d);
        match (got, want) {
            (None, None) => {}
            (Some(g), Some(b)) => prop_assert!((g - b).abs() <= 1e-9 * b.max(1.0), "got {} want {}", g, b),
            (g, b) => prop_assert!(false, "got {:?} want {:?}", g, b),
        }
    }

    #[test]
    fn all_exact_methods_agree_for_every_surface(
        w in 2u32..24, h in 2u32..24,
        seed in any::<u64>(),
        ox in -5.0f64..30.0, oy in -5.0f64..30.0, oz in -2.0f64..20.0,
        dx in -1.0f64..1.0, dy in -1.0f64..1.0, dz in -1.0f64..0.3,
        si in 0usize..4,
    ) {
        prop_assume!(dx != 0.0 || dy != 0.0 || dz != 0.0);
        let mut st = seed | 1;
        let s = grid(w, h, |_, _| {
            st ^= st << 13; st ^= st >> 7; st ^= st << 17;
            (st % 800) as f32 / 100.0
        });
        let hf = Heightfield::new(&s, w, h).unwrap();
        let ray = Ray::new_f64(DVec3::new(ox, oy, oz), DVec3::new(dx, dy, dz)).unwrap();
        if let Some(hit) = trace_exact(&hf, SURFACES[si], &ray) {
            // The hit is on or below the surface there, and inside the domain.
            let p = hit.position;
            prop_assert!(p.x >= -1e-9 && p.x <= (w - 1) as f64 + 1e-9);
            prop_assert!(p.y >= -1e-9 && p.y <= (h - 1) as f64 + 1e-9);
            prop_assert!(hit.normal.is_finite() && (hit.normal.length() - 1.0).abs() < 1e-5);
            if matches!(SURFACES[si], Surface::Triangles | Surface::Bilinear) {
                // At or below the surface (on it, unless the ray started below or came in
                // through a side below it).
                let [cx, cy] = hit.cell;
                let c = hf.cell_corners(cx, cy).map(f64::from);
                let fx = (p.x - cx as f64).clamp(0.0, 1.0);
                let fy = (p.y - cy as f64).clamp(0.0, 1.0);
                let sfc = cell::surface_at(SURFACES[si], &c, fx, fy);
                prop_assert!(p.z <= sfc + 1e-9, "{} above {}", p.z, sfc);
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Named hard cases (HARD_CASES.md, "Rays").

fn flat(w: u32, h: u32, z: f32) -> Vec<f32> {
    vec![z; (w * h) as usize]
}

fn ray(o: [f64; 3], d: [f64; 3]) -> Ray {
    Ray::new_f64(DVec3::from_array(o), DVec3::from_array(d)).unwrap()
}

fn assert_t(hit: Option<Hit>, want: f64, rel: f64) {
    let h = hit.expect("expected a hit");
    assert!(
        (h.t - want).abs() <= rel * want.abs().max(1.0),
        "t = {} want {}",
        h.t,
        want
    );
}

#[test]
fn hard_ray_through_grid_vertices() {
    // A cone peak at (4, 4); the ray passes exactly through vertices (2,2), (3,3), (4,4).
    let s = grid(9, 9, |x, y| {
        8.0 - (x as f32 - 4.0).abs().max((y as f32 - 4.0).abs())
    });
    let hf = Heightfield::new(&s, 9, 9).unwrap();
    for surface in SURFACES {
        let hit = trace_exact(&hf, surface, &ray([0.0, 0.0, 7.0], [1.0, 1.0, 0.0]));
        // z = 8 - (4 - x) = 7 at x = 3 (a vertex) for the exact surfaces.
        if surface != Surface::Nearest {
            assert_t(hit, 3.0, 1e-12);
            assert_eq!(hit.unwrap().position.truncate(), DVec2::new(3.0, 3.0));
        } else {
            assert!(hit.is_some());
        }
    }
}

#[test]
fn hard_ray_along_grid_line() {
    // Along x = 3 exactly, in +y and -y; a ridge across y = 5 of height 2 on the line.
    let s = grid(7, 9, |_, y| if y == 5 { 2.0 } else { 0.0 });
    let hf = Heightfield::new(&s, 7, 9).unwrap();
    for surface in [Surface::Triangles, Surface::Bilinear, Surface::Plane] {
        assert_t(
            trace_exact(&hf, surface, &ray([3.0, 0.0, 1.0], [0.0, 1.0, 0.0])),
            4.5,
            1e-12,
        );
        assert_t(
            trace_exact(&hf, surface, &ray([3.0, 8.0, 1.0], [0.0, -1.0, 0.0])),
            2.5,
            1e-12,
        );
    }
}

#[test]
fn hard_origin_x_exactly_integer() {
    // Origins on integer x, moving in x: the start cell is the one ahead.
    let s = grid(8, 4, |x, _| x as f32);
    let hf = Heightfield::new(&s, 8, 4).unwrap();
    for surface in [Surface::Triangles, Surface::Bilinear, Surface::Plane] {
        // From (2, 1.5, 5) towards +x: z = x reaches 5 at x = 5.
        let h = trace_exact(&hf, surface, &ray([2.0, 1.5, 5.0], [1.0, 0.0, 0.0]));
        assert_t(h, 3.0, 1e-12);
        // Towards -x from x = 5 at z = 4.5: below the surface at once (z(5) = 5).
        let h = trace_exact(&hf, surface, &ray([5.0, 1.5, 4.5], [-1.0, 0.0, 0.0]));
        assert_t(h, 0.0, 0.0);
    }
}

#[test]
fn hard_exactly_diagonal() {
    let s = grid(6, 6, |x, y| if x == 4 && y == 4 { 5.0 } else { 0.0 });
    let hf = Heightfield::new(&s, 6, 6).unwrap();
    let r = ray([0.0, 0.0, 2.5], [1.0, 1.0, 0.0]);
    let (mut a, mut b) = (Vec::new(), Vec::new());
    let (t, _, _) = tracer_all(&hf, Surface::Triangles, &mut a, &mut b);
    let line = t.line(&t.local(&r).unwrap()).unwrap();
    let cells: Vec<_> = line.cells().collect();
    assert_eq!(cells, vec![[0, 0], [1, 1], [2, 2], [3, 3], [4, 4]]);
    // Along the diagonal of cells (3,3): 0 -> 5 over one diagonal; z = 2.5 at x = 3.5.
    assert_t(trace_exact(&hf, Surface::Triangles, &r), 3.5, 1e-12);
}

#[test]
fn hard_slope_one_over_k() {
    // A wall at x = 20; rays with slope 1/k from a corner hit it at t = 20 in x.
    let s = grid(24, 24, |x, _| if x >= 20 { 10.0 } else { 0.0 });
    let hf = Heightfield::new(&s, 24, 24).unwrap();
    for k in 2..6 {
        let d = [k as f64, 1.0, 0.0];
        let h = trace_exact(&hf, Surface::Triangles, &ray([0.0, 0.0, 5.0], d));
        // Hits the ramp between x = 19 and 20 at z = 5: x = 19.5.
        assert_t(h, 19.5 / k as f64, 1e-12);
    }
}

#[test]
fn hard_axis_aligned_rays() {
    let s = grid(9, 9, |x, y| if x == 4 && y == 4 { 4.0 } else { 0.0 });
    let hf = Heightfield::new(&s, 9, 9).unwrap();
    for (o, d) in [
        ([0.0, 4.0, 2.0], [1.0, 0.0, 0.0]),
        ([8.0, 4.0, 2.0], [-1.0, 0.0, 0.0]),
        ([4.0, 0.0, 2.0], [0.0, 1.0, 0.0]),
        ([4.0, 8.0, 2.0], [0.0, -1.0, 0.0]),
    ] {
        for surface in [Surface::Triangles, Surface::Bilinear, Surface::Plane] {
            assert_t(trace_exact(&hf, surface, &ray(o, d)), 3.5, 1e-12);
        }
    }
}

#[test]
fn hard_straight_down_onto_vertex() {
    let s = grid(5, 5, |x, y| (x * 10 + y) as f32);
    let hf = Heightfield::new(&s, 5, 5).unwrap();
    for surface in SURFACES {
        for (x, y) in [(0.0, 0.0), (2.0, 3.0), (4.0, 4.0), (4.0, 0.0)] {
            let h = trace_exact(&hf, surface, &ray([x, y, 100.0], [0.0, 0.0, -1.0])).unwrap();
            let z = x * 10.0 + y;
            assert!(
                (h.t - (100.0 - z)).abs() < 1e-9,
                "{surface:?} at {x},{y}: {}",
                h.t
            );
        }
    }
}

#[test]
fn hard_grazing_1e6_rad_over_flat_ground() {
    let s = flat(400, 3, 0.0);
    let hf = Heightfield::new(&s, 400, 3).unwrap();
    let a = 1e-6f64;
    let r = ray([0.0, 1.0, 3e-4], [libm::cos(a), 0.0, -libm::sin(a)]);
    for surface in SURFACES {
        let want = 3e-4 / libm::sin(a);
        assert_t(trace_exact(&hf, surface, &r), want, 1e-9);
    }
}

#[test]
fn hard_start_inside_terrain() {
    let s = flat(4, 4, 5.0);
    let hf = Heightfield::new(&s, 4, 4).unwrap();
    for surface in SURFACES {
        // Below the surface, looking up or sideways: hit at the origin.
        let h = trace_exact(&hf, surface, &ray([1.5, 1.5, 1.0], [0.3, 0.1, 1.0])).unwrap();
        assert_eq!(h.t, 0.0);
        // Even below the lowest sample (outside the clipping box).
        let h = trace_exact(&hf, surface, &ray([1.5, 1.5, -50.0], [0.0, 0.0, -1.0])).unwrap();
        assert_eq!(h.t, 0.0);
    }
}

#[test]
fn hard_start_on_its_cells_highest_corner() {
    // Heights fall along x and y: the start cell (2, 2)'s highest corner is the start's own
    // vertex (2, 2), at 78, below the grid's highest sample (100), so the start test runs. A
    // start exactly on that corner is on every surface: a hit at the start (the start test's
    // bounding-box reject, `RayTracer::test_cell`, passes a start at the cell's highest corner
    // to the exact test; the walk would also find this hit at its first cell), and a start
    // clearly above it, heading up and away, misses. A shortcut that skipped starts below that corner fails
    // `hard_start_inside_terrain` (the start below the lowest sample).
    let s = grid(6, 6, |x, y| 100.0 - (x * 10 + y) as f32);
    let hf = Heightfield::new(&s, 6, 6).unwrap();
    for surface in SURFACES {
        let h = trace_exact(&hf, surface, &ray([2.0, 2.0, 78.0], [0.6, 0.3, 0.2])).unwrap();
        assert_eq!(h.t, 0.0, "{surface:?}");
        let miss = trace_exact(&hf, surface, &ray([2.0, 2.0, 78.001], [0.6, 0.3, 0.2]));
        assert!(miss.is_none(), "{surface:?}: {miss:?}");
    }
}

#[test]
fn hard_start_outside_and_entering() {
    let s = flat(5, 5, 1.0);
    let hf = Heightfield::new(&s, 5, 5).unwrap();
    for surface in SURFACES {
        let h = trace_exact(&hf, surface, &ray([-10.0, 2.0, 11.0], [1.0, 0.0, -1.0]));
        assert_t(h, 10.0, 1e-12); // hits z = 1 at x = 0, the domain's side
    }
}

#[test]
fn hard_never_entering() {
    let s = flat(5, 5, 1.0);
    let hf = Heightfield::new(&s, 5, 5).unwrap();
    for surface in SURFACES {
        // Beside the domain, above it going up, parallel above it.
        assert!(trace_exact(&hf, surface, &ray([-1.0, -1.0, 0.0], [-1.0, 0.2, -0.1])).is_none());
        assert!(trace_exact(&hf, surface, &ray([2.0, 2.0, 3.0], [0.1, 0.2, 1.0])).is_none());
        assert!(trace_exact(&hf, surface, &ray([-3.0, 2.0, 1.5], [1.0, 0.0, 0.0])).is_none());
        assert!(trace_exact(&hf, surface, &ray([-3.0, 7.0, 0.5], [1.0, 0.0, 0.0])).is_none());
    }
}

#[test]
fn hard_tangent_to_ridge() {
    // A ridge of height 3 along x = 4; a horizontal ray at exactly 3 touches it.
    let s = grid(9, 5, |x, _| if x == 4 { 3.0 } else { 0.0 });
    let hf = Heightfield::new(&s, 9, 5).unwrap();
    for surface in [Surface::Triangles, Surface::Bilinear, Surface::Plane] {
        assert_t(
            trace_exact(&hf, surface, &ray([0.0, 2.5, 3.0], [1.0, 0.0, 0.0])),
            4.0,
            1e-12,
        );
        assert!(trace_exact(&hf, surface, &ray([0.0, 2.5, 3.0 + 1e-9], [1.0, 0.0, 0.0])).is_none());
    }
}

#[test]
fn hard_origin_at_1e6_offsets() {
    // z_offset 1e6 and an eye 1e6 units away horizontally.
    let s = grid(11, 11, |x, y| (x + y) as f32 * 0.5);
    let hf = Heightfield::with_scale(&s, 11, 11, Scale::default().with_z_offset(1e6)).unwrap();
    let base = Heightfield::new(&s, 11, 11).unwrap();
    for surface in [Surface::Triangles, Surface::Bilinear, Surface::Plane] {
        let near = trace_exact(&base, surface, &ray([-1.0, 3.25, 6.0], [1.0, 0.0, -1.0])).unwrap();
        let far = trace_exact(
            &hf,
            surface,
            &ray([-1.0, 3.25, 1e6 + 6.0], [1.0, 0.0, -1.0]),
        )
        .unwrap();
        assert!((near.t - far.t).abs() < 1e-9, "{} vs {}", near.t, far.t);
        assert!((far.position.z - 1e6 - near.position.z).abs() < 1e-9);
        // Eye at x = -1e6: same hit point, t larger by exactly the extra distance.
        let d = DVec3::new(1e6, 0.0, -0.5).normalize();
        let o = DVec3::new(-1e6 + 2.0, 3.25, 1e6 + 2.0 + 0.5);
        let h = trace_exact(&hf, surface, &Ray::new_f64(o, d).unwrap()).unwrap();
        let back = o + h.t * d;
        let sfc = hf
            .surface_height(Surface::Triangles, back.x as f32, back.y as f32)
            .unwrap();
        assert!((back.z - sfc as f64).abs() < 1e-3, "{back:?} vs {sfc}");
    }
}

#[test]
fn hard_heights_scaled_1e_minus_3_and_1e4() {
    let s = grid(9, 9, |x, y| ((x * 7 + y * 3) % 5) as f32);
    for zs in [1e-3f32, 1e4] {
        let hf = Heightfield::with_scale(&s, 9, 9, Scale::default().with_z_scale(zs)).unwrap();
        let unit = Heightfield::new(&s, 9, 9).unwrap();
        for surface in SURFACES {
            let zsd = zs as f64;
            let a = trace_exact(&unit, surface, &ray([-1.0, 2.3, 6.0], [1.0, 0.37, -0.8]));
            let b = trace_exact(
                &hf,
                surface,
                &ray([-1.0, 2.3, 6.0 * zsd], [1.0, 0.37, -0.8 * zsd]),
            );
            let (a, b) = (a.unwrap(), b.unwrap());
            // Scaling z of the scene and the ray keeps the parameter.
            assert!(
                (a.t - b.t).abs() <= 1e-6 * a.t,
                "{surface:?} {zs}: {} vs {}",
                a.t,
                b.t
            );
        }
    }
}

#[test]
fn hard_one_cell_spike_thinner_than_march_step() {
    let mut s = flat(200, 3, 0.0);
    s[200 + 120] = 50.0; // (120, 1)
    let hf = Heightfield::new(&s, 200, 3).unwrap();
    let r = ray([0.0, 1.0, 10.0], [1.0, 0.0, 0.0]);
    let exact = trace_exact(&hf, Surface::Triangles, &r).unwrap();
    assert_t(Some(exact), 119.2, 1e-12);
    let t = RayTracer::new(&hf, Surface::Triangles);
    let coarse = t
        .trace_march(&r, &MarchOptions::default().with_samples(16))
        .unwrap();
    // 16 samples over 199 cells: the march reports a step over 12 cells and misses the spike.
    assert!(coarse.step_cells > 12.0);
    assert!(coarse.trace.hit.is_none());
    let fine = t
        .trace_march(
            &r,
            &MarchOptions::default().with_samples(4000).with_refine(20),
        )
        .unwrap();
    let ft = fine.trace.hit.unwrap().t;
    assert!(fine.step_cells < 0.1);
    assert!(ft >= exact.t - 1e-9 && ft - exact.t <= fine.bracket + 1e-9);
}

#[test]
fn hard_two_by_two_grid() {
    let s = [0.0f32, 1.0, 1.0, 2.0];
    let hf = Heightfield::new(&s, 2, 2).unwrap();
    for surface in SURFACES {
        let h = trace_exact(&hf, surface, &ray([0.25, 0.25, 10.0], [0.0, 0.0, -1.0])).unwrap();
        let z = match surface {
            Surface::Nearest => 0.0,
            _ => 0.5, // triangles, bilinear and plane all give 0.5 at (0.25, 0.25)
        };
        assert!((h.t - (10.0 - z)).abs() < 1e-12, "{surface:?}: {}", h.t);
    }
}

#[test]
fn hard_nan_ray_is_an_error() {
    let e = Error::NonFiniteInput { name: "ray origin" };
    assert_eq!(Ray::new(Vec3::new(f32::NAN, 0.0, 0.0), Vec3::X), Err(e));
    assert!(Ray::new(Vec3::ZERO, Vec3::new(0.0, f32::NAN, 1.0)).is_err());
}

#[test]
fn hard_infinite_or_zero_direction_is_an_error() {
    let e = Error::NonFiniteInput {
        name: "ray direction",
    };
    assert_eq!(
        Ray::new(Vec3::ZERO, Vec3::new(f32::INFINITY, 0.0, 0.0)),
        Err(e)
    );
    assert_eq!(Ray::new(Vec3::ZERO, Vec3::ZERO), Err(e));
    assert!(Ray::new_f64(DVec3::ZERO, DVec3::splat(1e300)).is_err());
}

#[test]
fn hard_flat_sea_at_minimum_height() {
    // Everything at exactly the minimum: clipping must keep a margin.
    for z in [0.0f32, -432.0, 1e5] {
        let s = flat(16, 16, z);
        let hf = Heightfield::new(&s, 16, 16).unwrap();
        for surface in SURFACES {
            let h = trace_exact(
                &hf,
                surface,
                &ray([3.3, 4.4, z as f64 + 2.0], [1.0, 0.5, -0.25]),
            );
            assert_t(h, 8.0, 1e-9);
        }
    }
}

#[test]
fn hard_run_ending_exactly_at_grid_edge() {
    // A hit only in the very last cell of the grid, reached by a run ending at the edge.
    let s = grid(33, 5, |x, _| if x == 32 { 4.0 } else { 0.0 });
    let hf = Heightfield::new(&s, 33, 5).unwrap();
    for surface in [Surface::Triangles, Surface::Bilinear, Surface::Plane] {
        let h = trace_exact(&hf, surface, &ray([0.0, 1.0, 3.0], [32.0, 1.0, 0.0])).unwrap();
        assert_eq!(h.cell[0], 31);
        assert!((h.position.x - 31.75).abs() < 1e-9, "{:?}", h.position);
    }
}

#[test]
fn hard_eye_on_vertex_diagonal_view() {
    let s = grid(8, 8, |x, y| ((x * 5 + y * 3) % 7) as f32);
    let hf = Heightfield::new(&s, 8, 8).unwrap();
    for surface in SURFACES {
        for d in [
            [1.0, 1.0, -0.3],
            [-1.0, 1.0, -0.3],
            [1.0, -1.0, -0.3],
            [-1.0, -1.0, -0.3],
        ] {
            // Eye exactly on vertex (4, 4), above it.
            let _ = trace_exact(&hf, surface, &ray([4.0, 4.0, 7.5], d));
        }
    }
}

#[test]
fn hard_descending_ray_rejected_by_exit_height_not_entry() {
    // Cell maximum 1; the ray enters the cell at z = 2 and leaves at z = 0.5.
    let s = [1.0f32, 1.0, 1.0, 1.0, 1.0, 1.0];
    let hf = Heightfield::new(&s, 3, 2).unwrap();
    for surface in SURFACES {
        let h = trace_exact(&hf, surface, &ray([0.0, 0.5, 2.0], [1.0, 0.0, -1.5]));
        assert_t(h, 2.0 / 3.0, 1e-12);
    }
}

#[test]
fn hard_triangles_leak_through_diagonal() {
    // h00 = h11 = 1 (ridge on the diagonal), h10 = h01 = 0; above the surface at both faces.
    let s = [1.0f32, 0.0, 0.0, 1.0];
    let hf = Heightfield::new(&s, 2, 2).unwrap();
    let h = trace_exact(
        &hf,
        Surface::Triangles,
        &ray([0.0, 0.5, 0.9], [1.0, 0.0, 0.0]),
    );
    // Triangle (x,y),(x+1,y+1),(x,y+1) for fx < fy: z = 1 - fy + fx... = 0.9 at fx = 0.4.
    assert_t(h, 0.4, 1e-12);
}

#[test]
fn hard_bilinear_dips_between_positive_ends() {
    // Saddle h00 = h11 = 0, h10 = h01 = 1: along the diagonal S = 2 s (1 - s).
    let s = [0.0f32, 1.0, 1.0, 0.0];
    let hf = Heightfield::new(&s, 2, 2).unwrap();
    let h = trace_exact(
        &hf,
        Surface::Bilinear,
        &ray([0.0, 0.0, 0.4], [1.0, 1.0, 0.0]),
    );
    let want = (2.0 - libm::sqrt(4.0 - 3.2)) / 4.0;
    assert_t(h, want, 1e-12);
}

#[test]
fn hard_plane_two_face_interpolation() {
    // Seed 001: heights on the entry and exit faces, linear in between. A ray along y = 0.5
    // sees the faces at 0.5 (x = 0: h00 = 0, h01 = 1) and 1.5 (x = 1: h10 = 1, h11 = 2).
    let s = [0.0f32, 1.0, 1.0, 2.0];
    let hf = Heightfield::new(&s, 2, 2).unwrap();
    let h = trace_exact(&hf, Surface::Plane, &ray([0.0, 0.5, 1.25], [1.0, 0.0, 0.0]));
    assert_t(h, 0.75, 1e-12);
    assert!(hf.surface_height(Surface::Plane, 0.3, 0.7).is_some());
}

#[test]
fn hard_nearest_sample_box_wall() {
    let s = [0.0f32, 0.0, 5.0, 0.0, 0.0, 5.0];
    let hf = Heightfield::new(&s, 3, 2).unwrap();
    // Sample (2, 0) and (2, 1) have height 5: their boxes start at x = 1.5.
    let h = trace_exact(
        &hf,
        Surface::Nearest,
        &ray([0.0, 0.5, 1.0], [1.0, 0.0, 0.0]),
    )
    .unwrap();
    assert!((h.t - 1.5).abs() < 1e-12);
    assert_eq!(h.normal, Vec3::new(-1.0, 0.0, 0.0));
}

#[test]
fn hard_along_upper_domain_border() {
    // Along y = height - 1 (the last grid line) in +x: still inside the domain.
    let s = grid(6, 4, |x, _| if x == 4 { 3.0 } else { 0.0 });
    let hf = Heightfield::new(&s, 6, 4).unwrap();
    for surface in [Surface::Triangles, Surface::Bilinear, Surface::Plane] {
        assert_t(
            trace_exact(&hf, surface, &ray([0.0, 3.0, 1.5], [1.0, 0.0, 0.0])),
            3.5,
            1e-12,
        );
        assert_t(
            trace_exact(&hf, surface, &ray([5.0, 3.0, 1.5], [-1.0, 0.0, 0.0])),
            0.5,
            1e-12,
        );
    }
}

#[test]
fn hard_tiny_horizontal_component() {
    // Nearly vertical rays: the projected direction is tiny but not zero.
    let s = grid(5, 5, |x, y| (x + 2 * y) as f32);
    let hf = Heightfield::new(&s, 5, 5).unwrap();
    for surface in SURFACES {
        let h = trace_exact(&hf, surface, &ray([2.5, 2.5, 50.0], [1e-13, -1e-14, -1.0]));
        assert!(h.is_some());
    }
}

#[test]
fn maxmip_update_matches_rebuild() {
    let mut s = grid(37, 21, |x, y| ((x * 13 + y * 7) % 11) as f32);
    let mut buf = vec![0.0f32; MaxMip::len(37, 21).unwrap()];
    MaxMip::build(&Heightfield::new(&s, 37, 21).unwrap(), &mut buf).unwrap();
    for (x, y, v) in [
        (5u32, 6u32, 40.0f32),
        (36, 20, -3.0),
        (0, 0, 20.0),
        (17, 3, 0.0),
    ] {
        s[(y * 37 + x) as usize] = v;
        let hf = Heightfield::new(&s, 37, 21).unwrap();
        MaxMip::update(&hf, &mut buf, x, y, x, y).unwrap();
        let mut fresh = vec![0.0f32; buf.len()];
        MaxMip::build(&hf, &mut fresh).unwrap();
        assert_eq!(buf, fresh);
    }
    let hf = Heightfield::new(&s, 37, 21).unwrap();
    assert!(MaxMip::update(&hf, &mut buf, 3, 3, 2, 2).is_err());
    assert!(MaxMip::update(&hf, &mut buf, 0, 0, 37, 0).is_err());
}

/// Rays on both sides of the max-mip walk's climbing rule (`maxmip::CLIMB_RELIEF`): steep
/// descents walk without climbing, shallow ones climb; both find the cell DDA's hit and stay
/// under the step bound.
#[test]
fn maxmip_walks_with_and_without_climbing_find_the_cell_dda_hit() {
    let (w, h) = (97u32, 80u32);
    let mut st = 0x2545_f491_4f6c_dd1du64;
    let s = grid(w, h, |x, y| {
        st ^= st << 13;
        st ^= st >> 7;
        st ^= st << 17;
        (x as f32 * 0.37).sin() * 9.0 + (y as f32 * 0.21).cos() * 6.0 + (st % 300) as f32 / 100.0
    });
    let hf = Heightfield::new(&s, w, h).unwrap();
    let t = RayTracer::new(&hf, Surface::Triangles);
    let (mut climbing, mut not) = (0, 0);
    for i in 0..400u32 {
        let az = i as f64 * 0.7;
        // Descents from 0.01 to about 6 height units per cell: the rule's threshold lies
        // between (about 0.5 per cell on this grid).
        let slope = 0.01 * 1.3f64.powi((i % 25) as i32);
        let d = DVec3::new(az.cos(), az.sin(), -slope);
        let o = DVec3::new(48.0, 40.0, 30.0) - d * 60.0;
        let ray = Ray::new_f64(o, d).unwrap();
        match t.local(&ray).map(|lr| t.climbs(&lr)) {
            Some(true) => climbing += 1,
            Some(false) => not += 1,
            None => {}
        }
        // Max-mip against the cell DDA (and the run DDA and packets), under the step bound.
        trace_exact(&hf, Surface::Triangles, &ray);
    }
    assert!(climbing > 50 && not > 50, "{climbing} climbing, {not} not");
}

#[test]
fn march_error_is_bounded_by_its_bracket_on_smooth_terrain() {
    let s = grid(64, 64, |x, y| {
        (libm::sinf(x as f32 * 0.2) + libm::cosf(y as f32 * 0.15)) * 3.0 + 6.0
    });
    let hf = Heightfield::new(&s, 64, 64).unwrap();
    let t = RayTracer::new(&hf, Surface::Triangles);
    let mut checked = 0;
    for i in 0..50 {
        let a = i as f64 * 0.13;
        let r = ray(
            [-5.0, 30.0, 14.0],
            [libm::cos(a * 0.3), libm::sin(a * 0.3) * 0.5, -0.3],
        );
        let exact = t.trace_cell_dda(&r).hit;
        let m = t
            .trace_march(
                &r,
                &MarchOptions::default().with_samples(2048).with_refine(16),
            )
            .unwrap();
        if let (Some(e), Some(h)) = (exact, m.trace.hit) {
            assert!(
                h.t >= e.t - 1e-9,
                "march found a hit before the first crossing"
            );
            assert!(
                h.t - e.t <= m.bracket + 1e-9,
                "{} {} {}",
                h.t,
                e.t,
                m.bracket
            );
            checked += 1;
        }
    }
    assert!(checked > 20);
}

#[test]
fn march_view_dependent_uses_fewer_samples_for_steep_rays() {
    let s = flat(32, 32, 0.0);
    let hf = Heightfield::new(&s, 32, 32).unwrap();
    let t = RayTracer::new(&hf, Surface::Bilinear);
    let o = MarchOptions::default()
        .with_samples(512)
        .with_view_dependent(32);
    let steep = t
        .trace_march(&ray([5.0, 5.0, 10.0], [0.01, 0.0, -1.0]), &o)
        .unwrap();
    let flatr = t
        .trace_march(&ray([0.0, 5.0, 1.0], [1.0, 0.0, -0.05]), &o)
        .unwrap();
    assert!(
        steep.samples < 40 && flatr.samples > 480,
        "{} {}",
        steep.samples,
        flatr.samples
    );
}

/// Found by the `rays` fuzz target: a minor component too small to register in fixed point
/// (`-1e-30` against `1`) must not fold the start across its row boundary, or the cell DDA takes
/// a corner step out of the grid while the run DDA runs along the row.
#[test]
fn minor_component_that_rounds_to_zero_folds_like_an_exact_zero() {
    use crate::ray::GridLine;
    use glam::DVec2;
    for (start, dir, want) in [
        (DVec2::new(0.5, 0.0), DVec2::new(1.0, -1e-30), 0u32),
        (DVec2::new(0.5, 0.0), DVec2::new(1.0, 0.0), 0),
        (DVec2::new(0.5, 1.0), DVec2::new(1.0, -1e-30), 1),
        (DVec2::new(0.5, 3.0), DVec2::new(1.0, 1e-30), 2),
        (
            DVec2::new(0.0, 2.2958874e-41),
            DVec2::new(1.6878482e22, -4.239017e-18),
            0,
        ),
        // The float end point drifts across the row boundary the start lies on.
        (DVec2::new(0.0, 2.0), DVec2::new(1.0, -1e-17), 2),
        // A start that rounds onto the upper border of the last row, exactly parallel.
        (DVec2::new(0.0, 2.9999998), DVec2::new(2.67, 0.0), 2),
    ] {
        let line = GridLine::new(start, dir, start + dir * 64.0, [3, 3]).unwrap();
        let cells: std::vec::Vec<[u32; 2]> = line.cells().collect();
        let runs: std::vec::Vec<[u32; 2]> = line.runs().flat_map(|r| r.cells()).collect();
        assert_eq!(cells, runs, "{start} {dir}");
        assert_eq!(
            cells,
            std::vec![[0, want], [1, want], [2, want]],
            "{start} {dir}"
        );
    }
}

/// Found by the `rays` fuzz target: a ray starting below the surface on a grid line, with a
/// minor component that rounds to zero in fixed point, must hit at its start with every exact
/// method (the cell DDA used to visit no cell at all).
#[test]
fn start_below_surface_on_a_grid_line_hits_at_start_with_every_method() {
    use crate::ray::{MaxMip, Ray, RayTracer, RunAccel};
    let mut s = std::vec![0.0f32; 36];
    s[2] = 38.0;
    let hf = crate::Heightfield::new(&s, 6, 6).unwrap();
    let ray = Ray::new(
        glam::Vec3::new(2.0, 0.0, 0.0),
        glam::Vec3::new(-4822272.0, 1.6852324e22, 1.6852366e22),
    )
    .unwrap();
    let t = RayTracer::new(&hf, crate::Surface::Triangles);
    let mut acc = std::vec![0.0f32; RunAccel::len(6, 6).unwrap()];
    let acc = RunAccel::build(&hf, &mut acc).unwrap();
    let mut mip = std::vec![0.0f32; MaxMip::len(6, 6).unwrap()];
    let mip = MaxMip::build(&hf, &mut mip).unwrap();
    for tr in [
        t.trace_cell_dda(&ray),
        t.trace_run_dda(&ray, &acc).unwrap(),
        t.trace_maxmip(&ray, &mip).unwrap(),
    ] {
        assert_eq!(tr.hit.map(|h| h.t), Some(0.0), "{tr:?}");
    }
}

/// A horizontal direction component so small that its reciprocal overflows (subnormal in grid
/// units) folds like an exact zero, on grid lines and on both domain borders: every exact
/// method finds the axis-parallel ray's hit. Before, `0 * inf = NaN` slab parameters made the
/// cell DDA, the run DDA and the max-mip walk disagree, and miss hits the exact-zero ray has.
#[test]
fn hard_subnormal_direction_component_folds_like_an_exact_zero() {
    let s = grid(9, 9, |x, y| ((x * 7 + y * 3) % 5) as f32);
    let hf = Heightfield::new(&s, 9, 9).unwrap();
    for surface in SURFACES {
        for o in [0.0f64, 4.0, 8.0] {
            for tiny in [1e-320f64, -1e-320, 5e-324, -5e-324] {
                for (origin, dir, exact) in [
                    ([o, -1.0, 10.0], [tiny, 1.0, -1.5], [0.0, 1.0, -1.5]),
                    ([-1.0, o, 10.0], [1.0, tiny, -1.5], [1.0, 0.0, -1.5]),
                    ([o, o, 10.0], [tiny, tiny, -1.0], [0.0, 0.0, -1.0]),
                ] {
                    let r = Ray::new_f64(DVec3::from(origin), DVec3::from(dir)).unwrap();
                    let z = Ray::new_f64(DVec3::from(origin), DVec3::from(exact)).unwrap();
                    let (h, hz) = (trace_exact(&hf, surface, &r), trace_exact(&hf, surface, &z));
                    assert!(hz.is_some(), "{surface:?} {origin:?}");
                    assert_eq!(
                        h.map(|h| h.t),
                        hz.map(|h| h.t),
                        "{surface:?} {origin:?} {dir:?}"
                    );
                }
            }
        }
    }
}
