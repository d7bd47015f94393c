//! Live edits and tiles of SOAR refinement data with random grids, craters and tile sizes.
//! Invariants: after a crater, `update`/`update_compact` give bit for bit the errors, radii and
//! pyramid of preprocessing the edited map from scratch (and `preprocess_pyramid` equals
//! `preprocess`); after the tile border protocol settles, the welded union of the separately
//! meshed tiles passes the crack checker and its measured error is at most E.
#![no_main]

use libfuzzer_sys::fuzz_target;
use relief_core::refine::{
    border_len, coverage_len, crater, export_border, hierarchy_len, merge_border,
    preprocess_compact, preprocess_compact_pyramid, preprocess_pyramid, pyramid_len, renest,
    scratch_len, update, update_compact, vertical_error, Criterion, PreprocessOptions, Refiner,
    Side,
};
use relief_core::{Heightfield, Scale};
use relief_tests::mesh_check::{check_mesh, CheckOptions};
use std::collections::HashMap;

fn f32_at(d: &[u8], i: usize) -> f32 {
    f32::from(d.get(i).copied().unwrap_or(0))
}

fuzz_target!(|data: &[u8]| {
    if data.len() < 16 {
        return;
    }
    let w = u32::from(data[0] % 40) + 2;
    let h = u32::from(data[1] % 40) + 2;
    let amp = f32::from(data[2] % 16) * 0.25;
    let mut s: Vec<f32> = (0..w * h)
        .map(|i| f32_at(data, 16 + i as usize) * amp)
        .collect();
    let n = hierarchy_len(w, h);
    let o = PreprocessOptions::default().with_contain_diamond(data[3] & 1 == 0);
    let (mut e, mut r, mut p) = (vec![0.0; n], vec![0.0; n], vec![0.0; pyramid_len(w, h)]);
    let (mut ec, mut pc) = (vec![0u16; n], vec![0.0; pyramid_len(w, h)]);
    {
        let hf = Heightfield::new(&s, w, h).unwrap();
        preprocess_pyramid(&hf, &mut e, &mut r, &mut p, o).unwrap();
        preprocess_compact_pyramid(&hf, &mut ec, &mut pc).unwrap();
    }
    // A crater from the bytes (centre may lie outside the grid).
    let cx = f32::from(data[4]) * 0.2 - 4.0;
    let cy = f32::from(data[5]) * 0.2 - 4.0;
    let radius = f32::from(data[6]) * 0.25 + 0.1;
    let depth = f32::from(data[7]) - 128.0;
    if let Some(region) = crater(&mut s, w, h, cx, cy, radius, depth).unwrap() {
        let hf = Heightfield::new(&s, w, h).unwrap();
        update(&hf, &mut e, &mut r, &mut p, region, o).unwrap();
        update_compact(&hf, &mut ec, &mut pc, region).unwrap();
        let (mut e0, mut r0) = (vec![0.0; n], vec![0.0; n]);
        let mut p0 = vec![0.0; pyramid_len(w, h)];
        preprocess_pyramid(&hf, &mut e0, &mut r0, &mut p0, o).unwrap();
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&e), bits(&e0), "errors after update");
        assert_eq!(bits(&r), bits(&r0), "radii after update");
        assert_eq!(bits(&p), bits(&p0), "pyramid after update");
        let (mut e1, mut r1) = (vec![0.0; n], vec![0.0; n]);
        relief_core::refine::preprocess_with(&hf, &mut e1, &mut r1, o).unwrap();
        assert_eq!(bits(&e1), bits(&e0), "pruned vs rasterising errors");
        let mut ec0 = vec![0u16; n];
        preprocess_compact(&hf, &mut ec0).unwrap();
        assert_eq!(ec, ec0, "compact errors after update");
    }

    // Tiles of 3, 5, 9 or 17 samples with the border protocol.
    let size = (1u32 << (1 + data[8] % 4)) + 1;
    let big_e = f32::from(data[9]) * 0.05 * amp.max(0.25);
    let scale = Scale::default();
    let starts = |m: u32| -> Vec<u32> {
        (0..)
            .map(|k| k * (size - 1))
            .take_while(|&a| a + 1 < m)
            .collect()
    };
    let (xs, ys) = (starts(w), starts(h));
    struct Tile {
        x0: u32,
        y0: u32,
        w: u32,
        h: u32,
        s: Vec<f32>,
        e: Vec<f32>,
        r: Vec<f32>,
    }
    let mut tiles: Vec<Tile> = Vec::new();
    for &y0 in &ys {
        for &x0 in &xs {
            let (tw, th) = (size.min(w - x0), size.min(h - y0));
            let mut ts = Vec::new();
            for y in y0..y0 + th {
                let i = (y * w + x0) as usize;
                ts.extend_from_slice(&s[i..i + tw as usize]);
            }
            let tn = hierarchy_len(tw, th);
            let (mut te, mut tr) = (vec![0.0; tn], vec![0.0; tn]);
            let hf = Heightfield::new(&ts, tw, th).unwrap();
            preprocess_pyramid(
                &hf,
                &mut te,
                &mut tr,
                &mut vec![0.0; pyramid_len(tw, th)],
                o,
            )
            .unwrap();
            tiles.push(Tile {
                x0,
                y0,
                w: tw,
                h: th,
                s: ts,
                e: te,
                r: tr,
            });
        }
    }
    let cols = xs.len();
    let rows = ys.len();
    let nb = |k: usize, side: Side| -> Option<usize> {
        let (rr, cc) = (k / cols, k % cols);
        match side {
            Side::XMin => cc.checked_sub(1).map(|c| rr * cols + c),
            Side::XMax => (cc + 1 < cols).then_some(rr * cols + cc + 1),
            Side::YMin => rr.checked_sub(1).map(|q| q * cols + cc),
            Side::YMax => (rr + 1 < rows).then_some((rr + 1) * cols + cc),
        }
    };
    let mut settled = false;
    for _ in 0..64 {
        let mut out: HashMap<(usize, Side), (Vec<f32>, Vec<f32>)> = HashMap::new();
        for (k, t) in tiles.iter().enumerate() {
            for side in Side::ALL {
                if nb(k, side).is_some() {
                    let m = border_len(t.w, t.h, side);
                    let (mut be, mut br) = (vec![0.0; m], vec![0.0; m]);
                    export_border(t.w, t.h, &t.e, &t.r, side, &mut be, &mut br).unwrap();
                    out.insert((k, side), (be, br));
                }
            }
        }
        let mut raised = 0;
        for (k, t) in tiles.iter_mut().enumerate() {
            let mut merged = Vec::new();
            for side in Side::ALL {
                if let Some(j) = nb(k, side) {
                    let (be, br) = &out[&(j, side.opposite())];
                    let c = merge_border(t.w, t.h, &mut t.e, &mut t.r, side, be, br).unwrap();
                    if c > 0 {
                        merged.push(side);
                        raised += c;
                    }
                }
            }
            let hf = Heightfield::new(&t.s, t.w, t.h).unwrap();
            renest(&hf, &mut t.e, &mut t.r, &merged, o).unwrap();
        }
        if raised == 0 {
            settled = true;
            break;
        }
    }
    assert!(settled, "the border protocol did not settle in 64 rounds");
    let mut at: HashMap<(u32, u32), u32> = HashMap::new();
    let (mut uv, mut ut) = (Vec::new(), Vec::new());
    for t in &mut tiles {
        let hf = Heightfield::new(&t.s, t.w, t.h).unwrap();
        let hier = renest(&hf, &mut t.e, &mut t.r, &[], o).unwrap();
        let rf = Refiner::new(&hier, &hf, Criterion::MaxError(big_e)).unwrap();
        let mut sc = vec![0u64; scratch_len(t.w, t.h)];
        let c = rf.count(&mut sc).unwrap();
        let (mut v, mut tr) = (vec![[0.0f32; 3]; c.vertices], vec![[0u32; 3]; c.triangles]);
        rf.triangles(&mut sc, &mut v, &mut tr).unwrap();
        let map: Vec<u32> = v
            .iter()
            .map(|q| {
                let key = (q[0].round() as u32 + t.x0, q[1].round() as u32 + t.y0);
                *at.entry(key).or_insert_with(|| {
                    uv.push([key.0 as f32, key.1 as f32, q[2]]);
                    (uv.len() - 1) as u32
                })
            })
            .collect();
        ut.extend(tr.iter().map(|k| k.map(|i| map[i as usize])));
    }
    check_mesh(&uv, &ut, &CheckOptions::grid(w, h, 1.0, 1.0)).unwrap();
    let hf = Heightfield::with_scale(&s, w, h, scale).unwrap();
    let err = vertical_error(&hf, &uv, &ut, &mut vec![0; coverage_len(w, h)]).unwrap();
    assert!(err <= f64::from(big_e), "union error {err} > E = {big_e}");
});
