//! The memory-mapped raw f32 reader against the reading path.

use relief_core::Terrain;
use relief_io::{read_dem, write_raw_f32, Format, IoError, MappedGrid, ReadOptions};

#[test]
fn mapped_grid_equals_the_read_grid() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("g.f32");
    let (w, h) = (37u32, 23u32);
    let v: Vec<f32> = (0..w * h)
        .map(|i| (i as f32 * 0.37).sin() * 100.0)
        .collect();
    write_raw_f32(&p, &v).unwrap();
    let opts = ReadOptions {
        format: Some(Format::RawF32),
        width: Some(w),
        height: Some(h),
        ..Default::default()
    };
    let dem = read_dem(&p, &opts).unwrap();
    let mut g = MappedGrid::open(&p, w, h).unwrap();
    g.advise_random();
    assert_eq!(g.samples(), &dem.samples[..]);
    g.scale = g.scale.with_spacing(2.0, 3.0).with_z_scale(0.5);
    let hf = g.heightfield().unwrap();
    for (x, y) in [(0, 0), (36, 22), (5, 17)] {
        assert_eq!(hf.local_z(x, y), dem.samples[(y * w + x) as usize] * 0.5);
    }
    assert_eq!(hf.position(1, 1).unwrap().x, 2.0);
}

#[test]
fn bad_mapped_inputs_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("g.f32");
    write_raw_f32(&p, &[1.0; 12]).unwrap();
    assert!(matches!(
        MappedGrid::open(&p, 4, 4),
        Err(IoError::SizeMismatch {
            expected: 64,
            actual: 48,
            ..
        })
    ));
    assert!(matches!(
        MappedGrid::open(&p, 12, 1),
        Err(IoError::InvalidOption(_))
    ));
    let mut v = vec![0.0f32; 12];
    v[7] = f32::INFINITY;
    write_raw_f32(&p, &v).unwrap();
    let g = MappedGrid::open(&p, 4, 3).unwrap();
    let e = g.heightfield().unwrap_err();
    assert!(e.to_string().contains('3'), "{e}");
}

/// Packed records written to a file and mapped again refine to the same meshes as the packed
/// hierarchy in memory, for both layouts and a non-square grid; damaged files are errors, not
/// panics: wrong magic, unknown layout, a count or size that does not match, a bad scale, and a
/// corrupted record (found by `check`).
#[test]
fn records_file_maps_back_to_the_same_meshes_and_rejects_damage() {
    use relief_core::refine::{
        hierarchy_len, pack_records, preprocess, records_len, scratch_len, Criterion, RecordLayout,
        Refiner, VertexRecord, View,
    };
    use relief_core::{glam::Vec3, Camera, Heightfield, Scale};
    use relief_io::{write_records, IoError, MappedRecords};
    let (w, h) = (37u32, 29u32);
    let s: Vec<f32> = (0..w * h)
        .map(|i| ((i * 7919) % 101) as f32 * 0.3)
        .collect();
    let sc = Scale::default().with_spacing(10.0, 10.0).with_z_scale(2.0);
    let hf = Heightfield::with_scale(&s, w, h, sc).unwrap();
    let n = hierarchy_len(w, h);
    let (mut e, mut r) = (vec![0.0; n], vec![0.0; n]);
    let full = preprocess(&hf, &mut e, &mut r).unwrap();
    let cam = Camera::new(
        Vec3::new(-40.0, -30.0, 150.0),
        Vec3::new(200.0, 150.0, 0.0),
        60.0,
        320,
        240,
    )
    .unwrap();
    let crits = [
        Criterion::MaxError(3.0),
        Criterion::View(View::new(&cam, 1.0).unwrap()),
    ];
    let mesh = |hier: &relief_core::refine::Hierarchy<'_>, c: Criterion| {
        let rf = Refiner::new(hier, &hf, c).unwrap();
        let mut scratch = vec![0u64; scratch_len(w, h)];
        let cnt = rf.count(&mut scratch).unwrap();
        let mut v = vec![[0.0f32; 3]; cnt.vertices];
        let mut t = vec![[0u32; 3]; cnt.triangles];
        rf.triangles(&mut scratch, &mut v, &mut t).unwrap();
        (v, t)
    };
    let dir = tempfile::tempdir().unwrap();
    for layout in [RecordLayout::Linear, RecordLayout::Interleaved] {
        let mut rec = vec![VertexRecord::default(); records_len(w, h, layout)];
        let packed = pack_records(&full, &hf, layout, &mut rec).unwrap();
        let p = dir.path().join(format!("{layout:?}.rec"));
        write_records(&p, &packed).unwrap();
        let m = MappedRecords::open(&p).unwrap();
        m.check().unwrap();
        m.advise_random();
        let mapped = m.hierarchy().unwrap();
        assert_eq!(mapped.scale(), sc);
        assert_eq!(mapped.z_range(), packed.z_range());
        for c in crits {
            let (a, b) = (mesh(&packed, c), mesh(&mapped, c));
            assert!(a.1.len() > 10, "{layout:?} {c:?}: trivial mesh");
            assert_eq!(a, b, "{layout:?} {c:?}");
        }
        let good = std::fs::read(&p).unwrap();
        let damaged = |f: &dyn Fn(&mut Vec<u8>)| {
            let mut b = good.clone();
            f(&mut b);
            let q = dir.path().join("damaged.rec");
            std::fs::write(&q, &b).unwrap();
            MappedRecords::open(&q).and_then(|m| m.check())
        };
        assert!(matches!(
            damaged(&|b| b[0] = b'X'),
            Err(IoError::Decode { .. })
        ));
        assert!(matches!(
            damaged(&|b| b[8] = 7),
            Err(IoError::Decode { .. })
        ));
        assert!(matches!(
            damaged(&|b| b[44] ^= 1),
            Err(IoError::Decode { .. })
        ));
        assert!(matches!(
            damaged(&|b| b.truncate(b.len() - 8)),
            Err(IoError::SizeMismatch { .. })
        ));
        assert!(matches!(
            damaged(&|b| b.truncate(10)),
            Err(IoError::Decode { .. })
        ));
        // dx = 0.
        assert!(matches!(
            damaged(&|b| b[20..24].copy_from_slice(&0f32.to_le_bytes())),
            Err(IoError::Core(_))
        ));
        // A NaN height at corner (0, 0): the first record (linear) or the fourth from last
        // (interleaved: the square's corners come last).
        let at = 64
            + 8 * if layout == RecordLayout::Linear {
                0
            } else {
                rec.len() - 4
            };
        let nan = damaged(&|b| b[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes()));
        assert!(
            matches!(
                nan,
                Err(IoError::Core(relief_core::Error::BadSample { .. }))
            ),
            "{layout:?}: {nan:?}"
        );
    }
    // A hierarchy without records cannot be written.
    assert!(matches!(
        write_records(&dir.path().join("f32.rec"), &full),
        Err(IoError::InvalidOption(_))
    ));
}
