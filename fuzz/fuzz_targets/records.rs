//! Stored 8-byte refinement records as untrusted input (a records file from elsewhere): valid
//! records packed from a random grid, then overwritten in places with the input's bytes.
//! Invariants: wrapping (`records_hierarchy`), checking (`check_records`) and refining over any
//! records never panics; unchanged records always pass the check; records that pass the check
//! give crack-free view-independent meshes (the nesting the check verifies is what keeps the
//! mesh conforming) and view-dependent meshes without culling are crack-free too.
#![no_main]

use libfuzzer_sys::fuzz_target;
use relief_core::glam::Vec3;
use relief_core::refine::{
    check_records, pack_records, preprocess, records_hierarchy, records_len, scratch_len,
    triangle_bound, vertex_bound, Criterion, RecordLayout, Refiner, VertexRecord, View,
};
use relief_core::{Camera, Heightfield, Scale};
use relief_tests::mesh_check::{check_mesh, CheckOptions};

fuzz_target!(|data: &[u8]| {
    if data.len() < 8 {
        return;
    }
    let w = u32::from(data[0] % 19) + 2;
    let h = u32::from(data[1] % 19) + 2;
    let layout = if data[2] & 1 == 0 {
        RecordLayout::Linear
    } else {
        RecordLayout::Interleaved
    };
    let e = f32::from(data[3]) * 0.25;
    let dx = 2.0f32;
    let samples: Vec<f32> = (0..w * h)
        .map(|i| (i.wrapping_mul(2_654_435_761) >> 24) as f32 * 0.1)
        .collect();
    let sc = Scale::default().with_spacing(dx, dx);
    let hf = Heightfield::with_scale(&samples, w, h, sc).unwrap();
    let (mut err, mut rad) = (
        vec![0.0f32; vertex_bound(w, h)],
        vec![0.0f32; vertex_bound(w, h)],
    );
    let hier = preprocess(&hf, &mut err, &mut rad).unwrap();
    let mut rec = vec![VertexRecord::default(); records_len(w, h, layout)];
    let z = pack_records(&hier, &hf, layout, &mut rec)
        .unwrap()
        .z_range();
    {
        let clean = records_hierarchy(&rec, layout, w, h, sc, z).unwrap();
        assert_eq!(check_records(&clean), Ok(()), "packed records rejected");
    }
    // Overwrite records: each 9 input bytes are (index, 8 record bytes).
    for chunk in data[4..].chunks_exact(9) {
        let k = usize::from(chunk[0]) % rec.len();
        let b = &chunk[1..];
        rec[k] = VertexRecord {
            z: f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            error: u16::from_le_bytes([b[4], b[5]]),
            radius: u16::from_le_bytes([b[6], b[7]]),
        };
    }
    let Ok(hr) = records_hierarchy(&rec, layout, w, h, sc, z) else {
        return;
    };
    let valid = check_records(&hr).is_ok();
    let mut scratch = vec![0u64; scratch_len(w, h)];
    let mut verts = vec![[0.0f32; 3]; vertex_bound(w, h)];
    let mut tris = vec![[0u32; 3]; triangle_bound(w, h)];
    let grid = CheckOptions::grid(w, h, f64::from(dx), f64::from(dx));
    let cam = Camera::new(
        Vec3::new(-5.0, -5.0, 20.0 + f32::from(data[4 % data.len()])),
        Vec3::new(w as f32, h as f32, 0.0),
        60.0,
        64,
        48,
    )
    .unwrap();
    let view = View::new(&cam, 1.0).unwrap().with_culling(false);
    for crit in [Criterion::MaxError(e), Criterion::View(view)] {
        let r = Refiner::new(&hr, &hf, crit).unwrap();
        match r.triangles(&mut scratch, &mut verts, &mut tris) {
            Ok(c) if valid => {
                check_mesh(&verts[..c.vertices], &tris[..c.triangles], &grid).unwrap();
            }
            Ok(_) => {}
            Err(err) => assert!(!valid, "valid records, refinement failed: {err}"),
        }
    }
});
