//! Detail refinement (relief_core::refine::DetailRefiner) with random base and detail maps,
//! factors, bounds (constant, measured, local), cameras and capacities.
//! Invariants: without culling the mesh is crack-free over the whole composed grid (the std crack
//! checker of relief-tests) and every vertex is a composed sample; with culling it has no flipped
//! or overlapping triangles; a buffer one element too small is an error, never a truncated mesh.
#![no_main]

use libfuzzer_sys::fuzz_target;
use relief_core::glam::Vec3;
use relief_core::refine::{
    detail_scratch_len, local_bounds_len, preprocess, DetailBounds, DetailRefiner, View,
};
use relief_core::{Camera, Composed, Heightfield, Scale, Terrain};
use relief_tests::mesh_check::{check_mesh, CheckOptions};

fn f32_at(d: &[u8], i: usize) -> f32 {
    f32::from_le_bytes([0, 1, 2, 3].map(|k| d.get(i + k).copied().unwrap_or(0)))
}

fuzz_target!(|data: &[u8]| {
    if data.len() < 40 {
        return;
    }
    let (w, h) = (u32::from(data[0] % 9) + 2, u32::from(data[1] % 9) + 2);
    let (dw, dh) = (u32::from(data[2] % 7) + 2, u32::from(data[3] % 7) + 2);
    let factor = 1u32 << (data[4] % 4);
    let mode = data[5] % 3;
    let dx = f32::from(data[6] % 7 + 1);
    let byte = |i: usize| f32::from(data.get(40 + i).copied().unwrap_or(0));
    let bs: Vec<f32> = (0..(w * h) as usize).map(|i| byte(i) * 0.5).collect();
    let ds: Vec<f32> = (0..(dw * dh) as usize)
        .map(|i| (byte(100 + i) - 128.0) * 0.02)
        .collect();
    let base = Heightfield::with_scale(&bs, w, h, Scale::default().with_spacing(dx, dx)).unwrap();
    let detail = Heightfield::new(&ds, dw, dh).unwrap();
    let c = Composed::new(base, detail, factor).unwrap();
    let mut local = vec![0.0f32; local_bounds_len(w, h)];
    let bounds = match mode {
        0 => DetailBounds::constant(&c, f32::from(data[7]) * 0.01).unwrap(),
        1 => DetailBounds::measure(&c),
        _ => DetailBounds::measure_local(&c, &mut local).unwrap(),
    };
    let n = (w * h) as usize;
    let (mut err, mut rad) = (vec![0.0f32; n], vec![0.0f32; n]);
    let hier = preprocess(&base, &mut err, &mut rad).unwrap();

    let eye = Vec3::new(f32_at(data, 8), f32_at(data, 12), f32_at(data, 16));
    let target = Vec3::new(f32_at(data, 20), f32_at(data, 24), f32_at(data, 28));
    let fov = f32_at(data, 32);
    let tau = f32_at(data, 36).abs().max(0.05);
    let Ok(cam) = Camera::new(eye, target, fov, 64, 48) else {
        return;
    };
    let Ok(view) = View::new(&cam, tau) else {
        return;
    };
    let s = c.scale();
    let grid = CheckOptions::grid(c.width(), c.height(), f64::from(s.dx), f64::from(s.dy));
    for (culling, opts) in [
        (false, grid),
        (
            true,
            CheckOptions {
                allow_holes: true,
                t_junctions: false,
                ..grid
            },
        ),
    ] {
        let Ok(dr) = DetailRefiner::new(&hier, &c, &bounds, &view.with_culling(culling)) else {
            return;
        };
        let t = dr.triangle_count();
        if t > 30_000 {
            return; // keep each input fast
        }
        let mut scratch = vec![0u64; detail_scratch_len(3 * t)];
        let k = dr.count(&mut scratch).unwrap();
        assert_eq!(k.triangles, t);
        let mut v = vec![[0.0f32; 3]; k.vertices];
        let mut tr = vec![[0u32; 3]; k.triangles];
        assert_eq!(dr.triangles(&mut scratch, &mut v, &mut tr).unwrap(), k);
        check_mesh(&v, &tr, &opts).unwrap();
        if !culling {
            for p in &v {
                let (x, y) = (
                    (f64::from(p[0]) / f64::from(s.dx)).round() as u32,
                    (f64::from(p[1]) / f64::from(s.dy)).round() as u32,
                );
                assert_eq!(p[2], c.z(x, y), "vertex off the composed surface");
            }
        }
        if k.triangles > 0 {
            let mut short = vec![[0u32; 3]; k.triangles - 1];
            assert!(dr.triangles(&mut scratch, &mut v, &mut short).is_err());
        }
    }
});
