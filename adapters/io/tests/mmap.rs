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
