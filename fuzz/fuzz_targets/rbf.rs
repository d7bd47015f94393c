//! RBF on adaptive grids from random heightfields and options: building never panics, and every
//! evaluation is finite and within the range of the cell values (a convex combination).
#![no_main]

use libfuzzer_sys::fuzz_target;
use relief_core::glam::Vec2;
use relief_core::rbf::{
    adaptive_grid_bound, build_adaptive_grid, AdaptiveGrid, Cell, GridOptions, InfluenceSets, Rbf,
    RbfOptions,
};
use relief_core::Heightfield;

fn f32_at(d: &[u8], i: usize) -> f32 {
    f32::from_le_bytes([0, 1, 2, 3].map(|k| d.get(i + k).copied().unwrap_or(0)))
}

fuzz_target!(|data: &[u8]| {
    if data.len() < 16 {
        return;
    }
    let w = u32::from(data[0] % 24) + 1;
    let h = u32::from(data[1] % 24) + 1;
    let min_cell = 1u32 << (data[2] % 4);
    let max_cell = 1u32 << (data[3] % 7);
    let max_error = f32_at(data, 4);
    let sigma = f32_at(data, 8);
    let samples: Vec<f32> = (0..w * h)
        .map(|i| f32::from(data.get(12 + i as usize).copied().unwrap_or(0)) * 3.0)
        .collect();
    let Ok(hf) = Heightfield::new(&samples, w.max(2), h.max(2)) else {
        return;
    };
    let opts = GridOptions::default()
        .with_max_error(max_error)
        .with_cells(min_cell, max_cell);
    let rbf_opts = RbfOptions::default().with_sigma(sigma);
    let (gw, gh) = (w.max(2), h.max(2));
    let Some(bound) = adaptive_grid_bound(gw, gh) else {
        return;
    };
    let mut cells = vec![Cell::default(); bound];
    let Ok(n) = build_adaptive_grid(&hf, &opts, &mut cells) else {
        return;
    };
    let mut index = vec![0u32; bound];
    let grid =
        AdaptiveGrid::new(gw, gh, &cells[..n], &mut index).expect("builder output must validate");
    let Ok(entries_len) = InfluenceSets::entries_len(&grid, &rbf_opts) else {
        return;
    };
    if entries_len > 1 << 22 {
        return;
    }
    let mut offsets = vec![0u32; InfluenceSets::offsets_len(&grid)];
    let mut entries = vec![0u32; entries_len];
    let sets = InfluenceSets::build(&grid, &rbf_opts, &mut offsets, &mut entries)
        .expect("sized by entries_len");
    let rbf = Rbf::new(grid, sets, &rbf_opts).expect("valid options");
    let (lo, hi) = cells[..n]
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), c| {
            (a.min(c.value), b.max(c.value))
        });
    for k in 0..16u32 {
        let p = Vec2::new(
            (gw - 1) as f32 * (k % 4) as f32 / 3.0,
            (gh - 1) as f32 * (k / 4) as f32 / 3.0,
        );
        let v = rbf.eval(p).expect("point inside the domain");
        assert!(v.is_finite(), "eval at {p} = {v}");
        let slack = 1e-3 * (hi - lo).abs().max(1.0);
        assert!(
            v >= lo - slack && v <= hi + slack,
            "{v} outside [{lo}, {hi}]"
        );
    }
});
