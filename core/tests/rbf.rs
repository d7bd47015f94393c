//! RBF approximation on adaptive grids and cascade fitting (seed 002, sections 3 and 4).

use glam::{Vec2, Vec3};
use proptest::prelude::*;
use relief_core::rbf::*;
use relief_core::{Camera, Error, Heightfield, Scale};

/// Owned buffers behind an [`Rbf`].
struct Owned {
    w: u32,
    h: u32,
    cells: Vec<Cell>,
    index: Vec<u32>,
    offsets: Vec<u32>,
    entries: Vec<u32>,
    sigma: f32,
}

impl Owned {
    fn new(w: u32, h: u32, cells: Vec<Cell>, sigma: f32) -> Owned {
        let mut index = vec![0; (w * h) as usize];
        let opts = RbfOptions::default().with_sigma(sigma);
        let (offsets, entries) = {
            let grid = AdaptiveGrid::new(w, h, &cells, &mut index).unwrap();
            (
                vec![0; InfluenceSets::offsets_len(&grid)],
                vec![0; InfluenceSets::entries_len(&grid, &opts).unwrap()],
            )
        };
        Owned {
            w,
            h,
            cells,
            index,
            offsets,
            entries,
            sigma,
        }
    }

    fn rbf(&mut self) -> Rbf<'_> {
        let opts = RbfOptions::default().with_sigma(self.sigma);
        let grid = AdaptiveGrid::new(self.w, self.h, &self.cells, &mut self.index).unwrap();
        let sets =
            InfluenceSets::build(&grid, &opts, &mut self.offsets, &mut self.entries).unwrap();
        Rbf::new(grid, sets, &opts).unwrap()
    }
}

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// A random quadtree tiling of `w x h` with roots of `max` samples: blocks that stick out are
/// split, blocks inside are split with probability `p_split` (down to size 1).
fn random_tiling(w: u32, h: u32, max: u32, p_split: f32, rng: &mut Rng) -> Vec<Cell> {
    let mut out = Vec::new();
    let mut stack = Vec::new();
    for by in (0..h).step_by(max as usize) {
        for bx in (0..w).step_by(max as usize) {
            stack.push((bx, by, max));
        }
    }
    while let Some((x, y, s)) = stack.pop() {
        if x >= w || y >= h {
            continue;
        }
        let inside = x + s <= w && y + s <= h;
        if inside && (s == 1 || rng.unit() >= p_split) {
            let v = (rng.unit() - 0.5) * 2000.0;
            out.push(Cell::new(x, y, s, v));
        } else {
            let q = s / 2;
            stack.extend([(x, y, q), (x + q, y, q), (x, y + q, q), (x + q, y + q, q)]);
        }
    }
    out
}

/// Brute-force eq. 2 over every cell, in f64 (no influence sets, no offset trick).
fn brute_force(cells: &[Cell], sigma: f32, p: Vec2) -> Option<f64> {
    let (mut sw, mut swv) = (0.0f64, 0.0f64);
    for c in cells {
        let d = (c.center() - p).as_dvec2().length() / f64::from(c.size);
        let s = f64::from(sigma);
        if d < 3.5 * s {
            let w = (-(d * d) / (2.0 * s * s)).exp() - (-3.5f64 * 3.5 / 2.0).exp();
            sw += w.max(0.0);
            swv += w.max(0.0) * f64::from(c.value);
        }
    }
    (sw > 0.0).then(|| swv / sw)
}

#[test]
fn weight_matches_equation_one() {
    for &sigma in &[0.25f32, 0.5, 1.0, 2.0, 4.0] {
        for k in 0..200 {
            let d = k as f32 * 0.05; // normalised distance |p_i - p| / c_i
            let expect = (-(d * d) / (2.0 * sigma * sigma)).exp() - (-3.5f32 * 3.5 / 2.0).exp();
            let got = gaussian_weight(d * d, sigma);
            if d < 3.5 * sigma * 0.9999 {
                assert!((got - expect.max(0.0)).abs() < 1e-6, "sigma {sigma} d {d}");
            } else if d >= 3.5 * sigma {
                assert_eq!(got, 0.0);
            }
        }
    }
}

#[test]
fn influence_sets_are_complete_and_tight() {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let cells = random_tiling(70, 45, 16, 0.6, &mut rng);
    for sigma in [0.25f32, 1.0, 2.5] {
        let mut o = Owned::new(70, 45, cells.clone(), sigma);
        let rbf = o.rbf();
        let sets_total: usize = (0..cells.len())
            .map(|j| rbf_set(&rbf, &cells, j).len())
            .sum();
        assert!(sets_total > cells.len());
        for _ in 0..3000 {
            let p = Vec2::new(rng.unit() * 70.0 - 0.5, rng.unit() * 45.0 - 0.5);
            let set = rbf.influencing(p);
            for (i, _) in cells.iter().enumerate() {
                if rbf.weight(i, p) > 0.0 {
                    assert!(
                        set.contains(&(i as u32)),
                        "cell {i} influences {p} but is missing"
                    );
                }
            }
        }
        // Tight: every member can reach its cell's area.
        for (j, cj) in cells.iter().enumerate() {
            for &i in rbf_set(&rbf, &cells, j) {
                let ci = &cells[i as usize];
                let r = 3.5 * sigma * ci.size as f32;
                assert!(cj.distance_squared_to_area(ci.center()) <= r * r * 1.0001);
            }
        }
    }
}

fn rbf_set<'a>(rbf: &Rbf<'a>, cells: &[Cell], j: usize) -> &'a [u32] {
    rbf.influencing(cells[j].center())
}

#[test]
fn evaluation_matches_brute_force() {
    let mut rng = Rng(12345);
    let cells = random_tiling(64, 64, 32, 0.5, &mut rng);
    for sigma in [0.5f32, 1.0, 3.0] {
        let mut o = Owned::new(64, 64, cells.clone(), sigma);
        let rbf = o.rbf();
        for _ in 0..2000 {
            let p = Vec2::new(rng.unit() * 64.0 - 0.5, rng.unit() * 64.0 - 0.5);
            let v = rbf.eval(p).unwrap();
            if let Some(b) = brute_force(&cells, sigma, p) {
                assert!(
                    (f64::from(v) - b).abs() < 1e-2,
                    "sigma {sigma} at {p}: {v} vs {b}"
                );
            }
        }
    }
}

#[test]
fn fallback_is_the_nearest_cell_value() {
    // sigma 0.1: a cell's own Gaussian reaches 0.35 of its size, less than its corners.
    let cells = vec![
        Cell::new(0, 0, 4, 1.0),
        Cell::new(4, 0, 4, 2.0),
        Cell::new(0, 4, 4, 3.0),
        Cell::new(4, 4, 4, 4.0),
    ];
    let mut o = Owned::new(8, 8, cells, 0.1);
    let rbf = o.rbf();
    assert_eq!(rbf.eval(Vec2::new(1.5, 1.5)), Ok(1.0)); // centre: own weight positive
                                                        // Near the shared corner but inside cell 3: no weight is positive; cell 3's centre is the
                                                        // nearest.
    let p = Vec2::new(3.6, 3.6);
    assert!(rbf
        .influencing(p)
        .iter()
        .all(|&i| rbf.weight(i as usize, p) == 0.0));
    assert_eq!(rbf.eval(p), Ok(4.0));
    assert_eq!(rbf.eval(Vec2::new(3.4, 3.4)), Ok(1.0));
}

#[test]
fn bad_input_is_typed() {
    let cells = vec![Cell::new(0, 0, 2, 0.0)];
    let mut index = vec![0; 4];
    let grid = AdaptiveGrid::new(2, 2, &cells, &mut index).unwrap();
    for s in [0.0f32, -1.0, f32::NAN, f32::INFINITY] {
        let opts = RbfOptions::default().with_sigma(s);
        assert!(matches!(
            InfluenceSets::entries_len(&grid, &opts),
            Err(Error::InvalidParameter { name: "sigma", .. })
        ));
    }
    let opts = RbfOptions::default();
    let (mut o, mut e) = (vec![0u32; 1], vec![0u32; 8]);
    assert_eq!(
        InfluenceSets::build(&grid, &opts, &mut o, &mut e).unwrap_err(),
        Error::BufferTooSmall {
            needed: 2,
            actual: 1
        }
    );
    let h = [0.0f32; 16];
    let hf = Heightfield::new(&h, 4, 4).unwrap();
    let mut cells = [Cell::default(); 16];
    for (mn, mx) in [(4, 2), (3, 4), (1, 5), (0, 1)] {
        let e = build_adaptive_grid(&hf, &GridOptions::default().with_cells(mn, mx), &mut cells);
        assert!(matches!(e, Err(Error::InvalidCellSize { .. })), "{mn} {mx}");
    }
    let non_pow = [Cell::new(0, 0, 3, 0.0)];
    let mut index = vec![0; 9];
    assert!(matches!(
        AdaptiveGrid::new(3, 3, &non_pow, &mut index),
        Err(Error::InvalidCell { index: 0, .. })
    ));
}

#[test]
fn builder_on_smooth_field_is_accurate() {
    // A smooth bump: the RBF of a fine grid stays close to the field.
    let (w, h) = (96u32, 80u32);
    let f = |x: f32, y: f32| 50.0 * (-((x - 40.0).powi(2) + (y - 30.0).powi(2)) / 600.0).exp();
    let samples: Vec<f32> = (0..w * h)
        .map(|k| f((k % w) as f32, (k / w) as f32))
        .collect();
    let hf = Heightfield::new(&samples, w, h).unwrap();
    let mut cells = vec![Cell::default(); adaptive_grid_bound(w, h).unwrap()];
    let opts = GridOptions::default().with_max_error(2.0).with_cells(1, 16);
    let n = build_adaptive_grid(&hf, &opts, &mut cells).unwrap();
    cells.truncate(n);
    assert!(
        n < (w * h / 4) as usize,
        "{n} cells: merging did not happen"
    );
    let mut o = Owned::new(w, h, cells, 1.0);
    let rbf = o.rbf();
    let mut worst = 0.0f32;
    for y in 0..h {
        for x in 0..w {
            let v = rbf.eval(Vec2::new(x as f32, y as f32)).unwrap();
            worst = worst.max((v - samples[(y * w + x) as usize]).abs());
        }
    }
    // Smoothing costs accuracy: measured 2.58 for E = 2; guard at 2 E.
    assert!(worst < 4.0, "max error {worst}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// A constant field is reproduced exactly, everywhere, for every sigma.
    #[test]
    fn constant_field_is_exact(seed in 1u64.., c in -1e6f32..1e6, sigma in 0.25f32..4.0,
                               w in 1u32..70, h in 1u32..70) {
        let mut rng = Rng(seed);
        let mut cells = random_tiling(w, h, 16, 0.5, &mut rng);
        for cell in &mut cells { cell.value = c; }
        let mut o = Owned::new(w, h, cells, sigma);
        let rbf = o.rbf();
        for _ in 0..200 {
            let p = Vec2::new(rng.unit() * (w as f32 + 4.0) - 2.5, rng.unit() * (h as f32 + 4.0) - 2.5);
            prop_assert_eq!(rbf.eval(p), Ok(c));
        }
    }

    /// Weights are non-negative and the normalised weights sum to one.
    #[test]
    fn weights_normalise(seed in 1u64.., sigma in 0.25f32..4.0) {
        let mut rng = Rng(seed);
        let cells = random_tiling(48, 40, 16, 0.55, &mut rng);
        let mut o = Owned::new(48, 40, cells, sigma);
        let rbf = o.rbf();
        for _ in 0..200 {
            let p = Vec2::new(rng.unit() * 48.0 - 0.5, rng.unit() * 40.0 - 0.5);
            let set = rbf.influencing(p);
            let ws: Vec<f32> = set.iter().map(|&i| rbf.weight(i as usize, p)).collect();
            prop_assert!(ws.iter().all(|&w| w >= 0.0 && w.is_finite()));
            let sum: f32 = ws.iter().sum();
            if sum > 0.0 {
                let norm: f32 = ws.iter().map(|w| w / sum).sum();
                prop_assert!((norm - 1.0).abs() < 1e-5, "normalised sum {}", norm);
            }
        }
    }

    /// Mixed cell sizes 1..128 and sigma 0.25..4: never NaN or infinite, and always within the
    /// range of the influencing values.
    #[test]
    fn mixed_sizes_finite_and_bounded(seed in 1u64.., sigma in 0.25f32..4.0, p_split in 0.0f32..0.7,
                                      extreme in any::<bool>()) {
        let mut rng = Rng(seed);
        let mut cells = random_tiling(256, 130, 128, p_split, &mut rng);
        if extreme {
            for c in &mut cells { c.value = if rng.unit() < 0.5 { -1e30 } else { 1e30 }; }
        }
        let mut o = Owned::new(256, 130, cells.clone(), sigma);
        let rbf = o.rbf();
        for k in 0..300 {
            let p = if k % 10 == 0 {
                // on cell boundaries and domain edges
                Vec2::new((rng.next() % 257) as f32 - 0.5, (rng.next() % 131) as f32 - 0.5)
            } else {
                Vec2::new(rng.unit() * 270.0 - 7.0, rng.unit() * 140.0 - 5.0)
            };
            let v = rbf.eval(p).unwrap();
            prop_assert!(v.is_finite());
            // Within the range of the positively weighted values at the clamped point (the
            // influence set holds them all, see influence_sets_are_complete_and_tight), or
            // exactly one influencing value where no weight is positive.
            let pc = p.max(Vec2::splat(-0.5)).min(Vec2::new(255.5, 129.5));
            let set = rbf.influencing(p);
            let positive: Vec<f32> = set
                .iter()
                .filter(|&&i| rbf.weight(i as usize, pc) > 0.0)
                .map(|&i| cells[i as usize].value)
                .collect();
            if positive.is_empty() {
                prop_assert!(set.iter().any(|&i| cells[i as usize].value == v));
            } else {
                let lo = positive.iter().copied().fold(f32::INFINITY, f32::min);
                let hi = positive.iter().copied().fold(f32::NEG_INFINITY, f32::max);
                prop_assert!(v >= lo && v <= hi, "{} outside [{}, {}]", v, lo, hi);
            }
        }
    }

    /// CPU discretization equals point evaluation at texel centres, and matches the brute-force
    /// sum; invisible texels hold 0.
    #[test]
    fn discretization_equals_point_evaluation(seed in 1u64.., ex in -20.0f32..90.0, ey in -20.0f32..60.0,
                                              ez in 5.0f32..60.0, yaw in 0.0f32..std::f32::consts::TAU, sigma in 0.5f32..2.0) {
        let mut rng = Rng(seed);
        let cells = random_tiling(80, 48, 16, 0.5, &mut rng);
        let mut o = Owned::new(80, 48, cells.clone(), sigma);
        let rbf = o.rbf();
        let eye = Vec3::new(ex, ey, ez);
        let target = eye + Vec3::new(yaw.cos() * 30.0, yaw.sin() * 30.0, -ez * 0.8);
        let cam = Camera::new(eye, target, 60.0, 64, 48).unwrap();
        let scale = Scale::default();
        let t = 48u32;
        let fit = fit_cascades(&cam, rbf.grid(), &scale, (-1000.0, 1000.0),
                               &CascadeOptions::default().with_resolution(t), None).unwrap();
        let n = (t * t) as usize;
        for c in &fit.cascades {
            let (mut mask, mut v, mut w) = (vec![0u8; n], vec![f32::NAN; n], vec![f32::NAN; n]);
            let visible = c.mask(&mut mask).unwrap();
            prop_assert_eq!(discretize(&rbf, c, &mask, &mut v, &mut w).unwrap(), visible);
            for j in 0..t {
                for i in 0..t {
                    let k = (j * t + i) as usize;
                    if mask[k] == 1 {
                        let p = c.texel_center(i, j);
                        prop_assert_eq!(v[k].to_bits(), rbf.eval(p).unwrap().to_bits());
                        prop_assert_eq!(w[k], c.blend_weight(i, j));
                        let inside = p.x >= -0.5 && p.y >= -0.5 && p.x <= 79.5 && p.y <= 47.5;
                        if inside {
                            if let Some(b) = brute_force(&cells, sigma, p) {
                                prop_assert!((f64::from(v[k]) - b).abs() < 1e-2);
                            }
                        }
                    } else {
                        prop_assert_eq!((v[k], w[k]), (0.0, 0.0));
                    }
                }
            }
        }
    }
}

// ---------------------------------------------------------------- cascades

fn flat_grid(w: u32, h: u32, min_cell: u32) -> (Vec<Cell>, Vec<u32>) {
    let mut cells = Vec::new();
    for y in (0..h).step_by(min_cell as usize) {
        for x in (0..w).step_by(min_cell as usize) {
            cells.push(Cell::new(x, y, min_cell, 0.0));
        }
    }
    (cells, vec![0; (w * h) as usize])
}

fn camera(eye: Vec3, target: Vec3) -> Camera {
    Camera::new(eye, target, 60.0, 320, 200).unwrap()
}

#[test]
fn splits_are_logarithmic_and_cascades_overlap() {
    let (cells, mut index) = flat_grid(256, 256, 4);
    let grid = AdaptiveGrid::new(256, 256, &cells, &mut index).unwrap();
    let scale = Scale::default().with_spacing(10.0, 10.0);
    let cam = camera(
        Vec3::new(100.0, 1200.0, 400.0),
        Vec3::new(1500.0, 1300.0, 0.0),
    );
    let opts = CascadeOptions::default()
        .with_resolution(256)
        .with_overlap(0.1);
    let c = fit_cascades(&cam, &grid, &scale, (0.0, 200.0), &opts, None).unwrap();
    assert!(c.visible);
    let n = c.near.max(c.far * 1e-3);
    let r = c.far / n;
    assert!((c.splits[0] - n * r.powf(1.0 / 3.0)).abs() < 1e-3 * c.far);
    assert!((c.splits[1] - n * r.powf(2.0 / 3.0)).abs() < 1e-3 * c.far);
    let k = &c.cascades;
    assert_eq!(k[0].near, c.near);
    assert_eq!(k[1].near, c.splits[0]);
    assert!(k[0].far > c.splits[0]);
    assert!((k[0].far - c.splits[0] - 0.1 * (c.splits[0] - c.near)).abs() < 1e-2);
    assert_eq!(k[2].far, c.far);
    assert!(k[0].spacing <= k[1].spacing && k[1].spacing <= k[2].spacing);
    assert!(k[0].spacing < k[2].spacing);
    for cas in k {
        assert_eq!(
            cas.spacing.log2().fract(),
            0.0,
            "spacing {} not a power of two",
            cas.spacing
        );
        // Raster covers the polygon with texel centres (in grid units), widened to min cell 4.
        let lo = cas.texel_center(0, 0);
        let hi = cas.texel_center(255, 255);
        for q in cas.polygon() {
            let g = Vec2::new(q.x / 10.0, q.y / 10.0);
            let (wl, wh) = ((g / 4.0).floor() * 4.0, (g / 4.0).ceil() * 4.0);
            assert!(wl.x >= lo.x && wl.y >= lo.y && wh.x <= hi.x && wh.y <= hi.y);
        }
    }
}

#[test]
fn blend_weights_sum_to_one_across_overlaps() {
    let (cells, mut index) = flat_grid(128, 128, 1);
    let grid = AdaptiveGrid::new(128, 128, &cells, &mut index).unwrap();
    let scale = Scale::default();
    let cam = camera(Vec3::new(-10.0, 64.0, 30.0), Vec3::new(60.0, 70.0, 0.0));
    let t = 128u32;
    let c = fit_cascades(
        &cam,
        &grid,
        &scale,
        (0.0, 10.0),
        &CascadeOptions::default()
            .with_resolution(t)
            .with_overlap(0.2),
        None,
    )
    .unwrap();
    // For each texel centre of cascade 0 inside its polygon, the weights of all cascades whose
    // offset range contains it sum to one.
    let mut checked = 0;
    let mut mask = vec![0u8; (t * t) as usize];
    c.cascades[0].mask(&mut mask).unwrap();
    let view = Vec2::new(cam.target.x - cam.eye.x, cam.target.y - cam.eye.y).normalize();
    let eye2 = Vec2::new(cam.eye.x, cam.eye.y);
    for j in 0..t {
        for i in 0..t {
            if mask[(j * t + i) as usize] == 0 {
                continue;
            }
            let p = c.cascades[0].texel_center(i, j);
            let o = (p - eye2).dot(view);
            if o < c.near || o > c.far {
                continue;
            }
            let mut sum = 0.0;
            for cas in &c.cascades {
                if o >= cas.near && o <= cas.far {
                    // weight at the same point, through the cascade's own texel lookup
                    let ti = ((p.x / cas.spacing).round() as i64 - cas.origin[0]) as u32;
                    let tj = ((p.y / cas.spacing).round() as i64 - cas.origin[1]) as u32;
                    if (p - cas.texel_center(ti, tj)).length() < 1e-4 {
                        sum += cas.blend_weight(ti, tj);
                    } else {
                        sum = f32::NAN;
                    }
                }
            }
            if sum.is_nan() {
                continue; // not a shared texel position
            }
            assert!(
                (sum - 1.0).abs() < 1e-4,
                "weights sum to {sum} at offset {o}"
            );
            checked += 1;
        }
    }
    assert!(checked > 100);
}

#[test]
fn hull_contains_every_visible_ground_point() {
    // From outside and above the box, and from inside it (eye below the highest point).
    hull_case(Vec3::new(-40.0, 200.0, 120.0), Vec3::new(300.0, 250.0, 0.0));
    hull_case(Vec3::new(150.0, 200.0, 20.0), Vec3::new(300.0, 100.0, 0.0));
}

fn hull_case(eye: Vec3, target: Vec3) {
    let (cells, mut index) = flat_grid(200, 150, 2);
    let grid = AdaptiveGrid::new(200, 150, &cells, &mut index).unwrap();
    let scale = Scale::default().with_spacing(2.0, 3.0);
    let cam = camera(eye, target);
    let (z0, z1) = (-5.0f32, 60.0f32);
    let c = fit_cascades(
        &cam,
        &grid,
        &scale,
        (z0, z1),
        &CascadeOptions::default(),
        None,
    )
    .unwrap();
    let (w, h) = (199.0 * 2.0, 149.0 * 3.0);
    let mut hits = 0;
    for j in (0..200).step_by(7) {
        for i in (0..320).step_by(7) {
            let (o, d) = cam.ray(i, j);
            for z in [z0, 0.0, 30.0, z1] {
                if d.z.abs() < 1e-6 {
                    continue;
                }
                let t = (z - o.z) / d.z;
                let p = o + d * t;
                if t <= 0.0 || p.x < 0.0 || p.y < 0.0 || p.x > w || p.y > h {
                    continue;
                }
                let q = Vec2::new(p.x, p.y);
                // inside at least one cascade polygon (within rounding)
                let inside = c.cascades.iter().any(|k| inside_poly(k.polygon(), q, 1e-3));
                assert!(
                    inside,
                    "ground point {q} of pixel ({i}, {j}) at z {z} outside every cascade"
                );
                hits += 1;
            }
        }
    }
    assert!(hits > 300, "{hits}");
}

#[test]
fn far_box_corner_is_not_lost_to_rounding() {
    // Found by the sub-texel walk: with a tolerance in the hull's turn test, the box corner at
    // the origin (the farthest visible point) vanished for the second eye, 0.4 units away,
    // because a crossing at x = -2e-13 sorted before it. n and f must move continuously.
    let (cells, mut index) = flat_grid(512, 512, 4);
    let grid = AdaptiveGrid::new(512, 512, &cells, &mut index).unwrap();
    let scale = Scale::default().with_spacing(5.0, 5.0);
    let dir = Vec3::new(-0.635_648_7, -0.771_978_5, -0.853_739_1);
    let fit = |e: Vec3| {
        fit_cascades(
            &camera(e, e + dir * 100.0),
            &grid,
            &scale,
            (0.0, 500.0),
            &CascadeOptions::default(),
            None,
        )
        .unwrap()
    };
    let a = fit(Vec3::new(1843.0565, 1673.5303, 614.70886));
    let b = fit(Vec3::new(1843.4565, 1673.1302, 614.70886));
    assert!(
        (a.far - b.far).abs() < 1.0,
        "f jumped from {} to {}",
        a.far,
        b.far
    );
    assert!((a.near - b.near).abs() < 1.0);
    // The corner (0, 0) is visible: f is its offset along the view.
    let v = Vec2::new(dir.x, dir.y).normalize();
    let corner = (Vec2::ZERO - Vec2::new(1843.4565, 1673.1302)).dot(v);
    assert!((b.far - corner).abs() < 1e-2, "{} vs {corner}", b.far);
}

#[test]
fn hull_behind_the_eye_keeps_splits_finite() {
    // Looking steeply down with a wide field of view: the bottom of the frustum reaches behind
    // the eye, so the hull's lowest offset n is negative and n (f/n)^(1/3) is undefined.
    let (cells, mut index) = flat_grid(128, 128, 1);
    let grid = AdaptiveGrid::new(128, 128, &cells, &mut index).unwrap();
    let eye = Vec3::new(64.0, 64.0, 40.0);
    let cam = Camera::new(eye, eye + Vec3::new(1.0, 0.0, -3.0), 120.0, 200, 200).unwrap();
    let c = fit_cascades(
        &cam,
        &grid,
        &Scale::default(),
        (0.0, 5.0),
        &CascadeOptions::default().with_resolution(64),
        None,
    )
    .unwrap();
    assert!(c.visible);
    assert!(c.near < 0.0, "n = {}", c.near);
    assert!(c.splits.iter().all(|s| s.is_finite()));
    assert!(c.near < c.splits[0] && c.splits[0] < c.splits[1] && c.splits[1] < c.far);
    for k in &c.cascades {
        assert!(k.polygon().len() >= 3);
        assert!(k.spacing.is_finite() && k.spacing > 0.0);
    }
}

fn inside_poly(poly: &[Vec2], q: Vec2, tol: f32) -> bool {
    poly.len() >= 3
        && (0..poly.len()).all(|k| {
            let a = poly[k];
            let b = poly[(k + 1) % poly.len()];
            (b - a).perp_dot(q - a) / (b - a).length() >= -tol
        })
}

/// Random views over a 512 x 512 grid (min cell 4, dx = 5), each followed by a walk of 20
/// camera moves shorter than the smallest texel; returns how many moves changed a spacing.
/// Every move is also checked to keep texel centres on the previous lattice.
fn sub_texel_walks(hysteresis: bool) -> (usize, usize) {
    let (cells, mut index) = flat_grid(512, 512, 4);
    let grid = AdaptiveGrid::new(512, 512, &cells, &mut index).unwrap();
    let scale = Scale::default().with_spacing(5.0, 5.0);
    let opts = CascadeOptions::default().with_resolution(256);
    let mut rng = Rng(99);
    let (mut changes, mut moves) = (0, 0);
    for _ in 0..300 {
        let eye = Vec3::new(
            rng.unit() * 2560.0,
            rng.unit() * 2560.0,
            50.0 + rng.unit() * 1000.0,
        );
        let a = rng.unit() * std::f32::consts::TAU;
        let dir = Vec3::new(a.cos(), a.sin(), -0.1 - rng.unit());
        let mut prev = fit_cascades(
            &camera(eye, eye + dir * 100.0),
            &grid,
            &scale,
            (0.0, 500.0),
            &opts,
            None,
        )
        .unwrap();
        if !prev.visible {
            continue;
        }
        let texel = prev.cascades[0].spacing * 5.0; // smallest texel in world units
        let mut pos = eye;
        for _ in 0..20 {
            let step = Vec3::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5).normalize()
                * texel
                * 0.9
                * rng.unit();
            pos += step;
            let cam = camera(pos, pos + dir * 100.0);
            let next = fit_cascades(
                &cam,
                &grid,
                &scale,
                (0.0, 500.0),
                &opts,
                hysteresis.then_some(&prev),
            )
            .unwrap();
            moves += 1;
            for (a, b) in prev.cascades.iter().zip(&next.cascades) {
                if a.spacing != b.spacing {
                    changes += 1;
                    break;
                }
                // Same spacing: the origin moved by whole texels, so an old texel still inside
                // the new raster is exactly a new texel.
                let d = b.texel_center(0, 0) - a.texel_center(0, 0);
                assert_eq!((d / a.spacing).fract(), Vec2::ZERO);
                for (i, j) in [(0u32, 0u32), (100, 120), (255, 255)] {
                    let bi = a.origin[0] + i as i64 - b.origin[0];
                    let bj = a.origin[1] + j as i64 - b.origin[1];
                    if (0..256).contains(&bi) && (0..256).contains(&bj) {
                        assert_eq!(b.texel_center(bi as u32, bj as u32), a.texel_center(i, j));
                    }
                }
            }
            prev = next;
        }
    }
    (changes, moves)
}

#[test]
fn camera_moves_below_a_texel_move_no_sample() {
    let (changes, moves) = sub_texel_walks(true);
    assert!(moves > 5000, "{moves}");
    assert_eq!(
        changes, 0,
        "{changes} of {moves} sub-texel moves changed a texel spacing"
    );
}

#[test]
fn without_hysteresis_sub_texel_moves_do_change_spacing() {
    // The walk above is sensitive: fitting every frame afresh changes spacings, which moves
    // every sample of that cascade.
    let (changes, _) = sub_texel_walks(false);
    assert!(changes > 10, "{changes}");
}

#[test]
fn visible_mask_follows_the_polygon() {
    let (cells, mut index) = flat_grid(128, 128, 1);
    let grid = AdaptiveGrid::new(128, 128, &cells, &mut index).unwrap();
    let cam = camera(Vec3::new(-10.0, 64.0, 30.0), Vec3::new(60.0, 40.0, 0.0));
    let t = 96u32;
    let c = fit_cascades(
        &cam,
        &grid,
        &Scale::default(),
        (0.0, 10.0),
        &CascadeOptions::default().with_resolution(t),
        None,
    )
    .unwrap();
    for k in &c.cascades {
        let mut mask = vec![0u8; (t * t) as usize];
        let n = k.mask(&mut mask).unwrap();
        assert_eq!(n, mask.iter().filter(|&&m| m == 1).count());
        assert!(n > 0 && n < (t * t) as usize);
        let diag = k.spacing * std::f32::consts::SQRT_2;
        for j in 0..t {
            for i in 0..t {
                let p = k.texel_center(i, j);
                let m = mask[(j * t + i) as usize];
                if inside_poly(k.polygon(), p, 0.0) {
                    assert_eq!(m, 1);
                }
                if !inside_poly(k.polygon(), p, 1.01 * diag) {
                    assert_eq!(m, 0);
                }
            }
        }
        let mut short = vec![0u8; 10];
        assert!(matches!(
            k.mask(&mut short),
            Err(Error::BufferTooSmall { .. })
        ));
    }
}

#[test]
fn cascade_input_errors() {
    let (cells, mut index) = flat_grid(16, 16, 1);
    let grid = AdaptiveGrid::new(16, 16, &cells, &mut index).unwrap();
    let cam = camera(Vec3::new(-10.0, 8.0, 10.0), Vec3::new(8.0, 8.0, 0.0));
    let s = Scale::default();
    let o = CascadeOptions::default();
    assert!(fit_cascades(&cam, &grid, &s, (1.0, 0.0), &o, None).is_err());
    assert!(fit_cascades(&cam, &grid, &s, (f32::NAN, 0.0), &o, None).is_err());
    assert!(fit_cascades(&cam, &grid, &s, (0.0, 1.0), &o.with_resolution(1), None).is_err());
    assert!(fit_cascades(&cam, &grid, &s, (0.0, 1.0), &o.with_overlap(-0.1), None).is_err());
    assert!(fit_cascades(&cam, &grid, &s, (0.0, 1.0), &o.with_near(0.0), None).is_err());
    assert!(fit_cascades(&cam, &grid, &s.with_spacing(0.0, 1.0), (0.0, 1.0), &o, None).is_err());
}
