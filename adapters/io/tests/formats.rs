//! Every input format, every void policy and every error path of the I/O adapter, on files made
//! here and on the real DEMs in `../shared/data/` (skipped with a message when absent).

use relief_io::{decode_dem, read_dem, Fill, Format, IoError, ReadOptions};
use std::io::Cursor;
use std::path::{Path, PathBuf};

fn opts(format: Format) -> ReadOptions {
    ReadOptions {
        format: Some(format),
        ..ReadOptions::default()
    }
}

fn png_bytes(w: u32, h: u32, color: png::ColorType, depth: png::BitDepth, data: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, w, h);
        enc.set_color(color);
        enc.set_depth(depth);
        let mut wr = enc.write_header().unwrap();
        wr.write_image_data(data).unwrap();
        wr.finish().unwrap();
    }
    out
}

fn tiff_bytes<C: tiff::encoder::colortype::ColorType>(
    w: u32,
    h: u32,
    data: &[C::Inner],
    nodata: Option<&str>,
) -> Vec<u8>
where
    [C::Inner]: tiff::encoder::TiffValue,
{
    let mut cur = Cursor::new(Vec::new());
    {
        let mut enc = tiff::encoder::TiffEncoder::new(&mut cur).unwrap();
        let mut img = enc.new_image::<C>(w, h).unwrap();
        if let Some(nd) = nodata {
            img.encoder()
                .write_tag(tiff::tags::Tag::GdalNodata, nd)
                .unwrap();
        }
        img.encoder()
            .write_tag(
                tiff::tags::Tag::ModelPixelScaleTag,
                &[30.0f64, 25.0, 0.0][..],
            )
            .unwrap();
        img.write_data(data).unwrap();
    }
    cur.into_inner()
}

#[test]
fn png16_gray_reads_values() {
    let vals: [u16; 6] = [0, 1, 256, 1000, 40000, 65535];
    let bytes: Vec<u8> = vals.iter().flat_map(|v| v.to_be_bytes()).collect();
    let png = png_bytes(
        3,
        2,
        png::ColorType::Grayscale,
        png::BitDepth::Sixteen,
        &bytes,
    );
    let dem = decode_dem(&png, &ReadOptions::default()).unwrap();
    assert_eq!((dem.width, dem.height), (3, 2));
    assert_eq!(dem.samples, vals.map(f32::from).to_vec());
    let png8 = png_bytes(
        2,
        2,
        png::ColorType::Grayscale,
        png::BitDepth::Eight,
        &[0, 7, 200, 255],
    );
    assert_eq!(
        decode_dem(&png8, &opts(Format::Png)).unwrap().samples,
        vec![0.0, 7.0, 200.0, 255.0]
    );
}

#[test]
fn terrain_rgb_and_terrarium_decode_per_conventions() {
    // Terrain-RGB: h = -10000 + (R*65536 + G*256 + B) * 0.1
    let rgb = [1u8, 134, 160, 0, 0, 0, 1, 134, 170, 255, 255, 255];
    let png = png_bytes(2, 2, png::ColorType::Rgb, png::BitDepth::Eight, &rgb);
    let dem = decode_dem(&png, &opts(Format::TerrainRgb)).unwrap();
    let want = [
        -10000.0 + (65536.0 + 134.0 * 256.0 + 160.0) * 0.1,
        -10000.0,
        -10000.0 + (65536.0 + 134.0 * 256.0 + 170.0) * 0.1,
        -10000.0 + (255.0 * 65536.0 + 255.0 * 256.0 + 255.0) * 0.1,
    ];
    for (g, w) in dem.samples.iter().zip(want) {
        assert!((f64::from(*g) - w).abs() < 1e-3, "{g} vs {w}");
    }
    // Terrarium: h = R*256 + G + B/256 - 32768
    let png = png_bytes(
        2,
        2,
        png::ColorType::Rgb,
        png::BitDepth::Eight,
        &[128, 0, 0, 128, 10, 128, 0, 0, 0, 130, 1, 64],
    );
    let dem = decode_dem(&png, &opts(Format::Terrarium)).unwrap();
    assert_eq!(dem.samples, vec![0.0, 10.5, -32768.0, 513.25]);
}

#[test]
fn transparent_rgba_pixels_are_voids() {
    let rgba = [
        1u8, 134, 160, 255, 1, 134, 160, 0, 1, 134, 160, 255, 1, 134, 170, 255,
    ];
    let png = png_bytes(2, 2, png::ColorType::Rgba, png::BitDepth::Eight, &rgba);
    match decode_dem(&png, &opts(Format::TerrainRgb)) {
        Err(IoError::NoData { x: 1, y: 0, .. }) => {}
        other => panic!("{other:?}"),
    }
    let o = ReadOptions {
        fill: Fill::Nearest,
        ..opts(Format::TerrainRgb)
    };
    let dem = decode_dem(&png, &o).unwrap();
    assert_eq!(dem.nodata_count, 1);
    assert_eq!(dem.samples[1], dem.samples[0]);
}

#[test]
fn colour_png_needs_an_explicit_format() {
    let png = png_bytes(2, 2, png::ColorType::Rgb, png::BitDepth::Eight, &[0; 12]);
    let e = decode_dem(&png, &ReadOptions::default()).unwrap_err();
    assert!(e.to_string().contains("--format terrain-rgb"), "{e}");
    let e = decode_dem(&png, &opts(Format::Png)).unwrap_err();
    assert!(matches!(e, IoError::Unsupported(_)), "{e}");
    let gray = png_bytes(
        2,
        2,
        png::ColorType::Grayscale,
        png::BitDepth::Eight,
        &[0; 4],
    );
    assert!(matches!(
        decode_dem(&gray, &opts(Format::Terrarium)),
        Err(IoError::Unsupported(_))
    ));
}

#[test]
fn truncated_and_corrupt_pngs_are_decode_errors() {
    let bytes: Vec<u8> = (0..64u16).flat_map(|v| (v * 1000).to_be_bytes()).collect();
    let png = png_bytes(
        8,
        8,
        png::ColorType::Grayscale,
        png::BitDepth::Sixteen,
        &bytes,
    );
    for cut in [8, 20, 33, png.len() / 2, png.len() - 13] {
        let e = decode_dem(&png[..cut], &opts(Format::Png)).unwrap_err();
        assert!(matches!(e, IoError::Decode { .. }), "cut {cut}: {e}");
        assert!(!e.to_string().contains('\n'));
    }
    let mut flipped = png.clone();
    let n = flipped.len();
    flipped[n / 2] ^= 0xff;
    assert!(decode_dem(&flipped, &opts(Format::Png)).is_err());
}

#[test]
fn tiff_sample_types_nodata_and_spacing() {
    let t = tiff_bytes::<tiff::encoder::colortype::GrayI16>(
        3,
        2,
        &[1, -2, 3, 4, 32767, 6],
        Some("32767"),
    );
    match decode_dem(&t, &ReadOptions::default()) {
        Err(IoError::NoData { x: 1, y: 1, value }) => assert_eq!(value, 32767.0),
        other => panic!("{other:?}"),
    }
    let dem = decode_dem(
        &t,
        &ReadOptions {
            fill: Fill::Min,
            ..ReadOptions::default()
        },
    )
    .unwrap();
    assert_eq!(dem.samples, vec![1.0, -2.0, 3.0, 4.0, -2.0, 6.0]);
    assert_eq!((dem.scale.dx, dem.scale.dy), (30.0, 25.0));
    // --nodata overrides the tag.
    let dem = decode_dem(
        &t,
        &ReadOptions {
            nodata: Some(-2.0),
            fill: Fill::Min,
            ..ReadOptions::default()
        },
    )
    .unwrap();
    assert_eq!(dem.samples, vec![1.0, 1.0, 3.0, 4.0, 32767.0, 6.0]);

    let t = tiff_bytes::<tiff::encoder::colortype::Gray16>(2, 2, &[0, 1, 2, 65535], None);
    assert_eq!(
        decode_dem(&t, &opts(Format::Tiff)).unwrap().samples,
        vec![0.0, 1.0, 2.0, 65535.0]
    );
    let t =
        tiff_bytes::<tiff::encoder::colortype::Gray32Float>(2, 2, &[0.5, f32::NAN, 2.0, 3.0], None);
    assert!(matches!(
        decode_dem(&t, &opts(Format::Tiff)),
        Err(IoError::NoData { x: 1, y: 0, .. })
    ));
    let t = tiff_bytes::<tiff::encoder::colortype::GrayI32>(2, 2, &[-5, 1, 2, 3], None);
    assert_eq!(
        decode_dem(&t, &opts(Format::Tiff)).unwrap().samples[0],
        -5.0
    );
    let rgb = {
        let mut cur = Cursor::new(Vec::new());
        tiff::encoder::TiffEncoder::new(&mut cur)
            .unwrap()
            .write_image::<tiff::encoder::colortype::RGB8>(2, 2, &[0; 12])
            .unwrap();
        cur.into_inner()
    };
    assert!(matches!(
        decode_dem(&rgb, &opts(Format::Tiff)),
        Err(IoError::Unsupported(_))
    ));
    let half = &t[..t.len() - 9];
    assert!(decode_dem(half, &opts(Format::Tiff)).is_err());
}

#[test]
fn raw_f32_sizes_and_voids() {
    let bytes: Vec<u8> = [1.0f32, 2.0, f32::INFINITY, 4.0, 5.0, 6.0]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let o = |w, h| ReadOptions {
        format: Some(Format::RawF32),
        width: w,
        height: h,
        ..ReadOptions::default()
    };
    assert!(matches!(
        decode_dem(&bytes, &o(None, Some(2))),
        Err(IoError::InvalidOption(_))
    ));
    assert!(matches!(
        decode_dem(&bytes, &o(Some(0), Some(2))),
        Err(IoError::InvalidOption(_))
    ));
    assert!(matches!(
        decode_dem(&bytes, &o(Some(2), Some(2))),
        Err(IoError::SizeMismatch {
            expected: 16,
            actual: 24,
            ..
        })
    ));
    assert!(matches!(
        decode_dem(&bytes, &o(Some(3), Some(2))),
        Err(IoError::NoData { x: 2, y: 0, .. })
    ));
    assert!(matches!(
        decode_dem(&bytes[..8], &o(Some(2), Some(1))),
        Err(IoError::Core(relief_core::Error::TooSmall { .. }))
    ));
    let nan: Vec<u8> = [f32::NAN; 4].iter().flat_map(|v| v.to_le_bytes()).collect();
    let all_void = ReadOptions {
        fill: Fill::Nearest,
        ..o(Some(2), Some(2))
    };
    assert!(matches!(
        decode_dem(&nan, &all_void),
        Err(IoError::AllNoData)
    ));
}

#[test]
fn given_size_must_match_the_file() {
    let png = png_bytes(
        2,
        2,
        png::ColorType::Grayscale,
        png::BitDepth::Eight,
        &[0; 4],
    );
    let o = ReadOptions {
        width: Some(3),
        ..ReadOptions::default()
    };
    assert!(matches!(
        decode_dem(&png, &o),
        Err(IoError::SizeMismatch {
            expected: 3,
            actual: 2,
            ..
        })
    ));
}

#[test]
fn missing_file_names_the_path() {
    let e = read_dem(Path::new("/nonexistent/dem.png"), &ReadOptions::default()).unwrap_err();
    assert!(e.to_string().starts_with("/nonexistent/dem.png"), "{e}");
}

#[test]
fn writers_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("h.png");
    relief_io::write_png16(&p, 3, 2, &[1, 2, 3, 4, 5, 65535]).unwrap();
    assert_eq!(
        read_dem(&p, &ReadOptions::default()).unwrap().samples,
        vec![1.0, 2.0, 3.0, 4.0, 5.0, 65535.0]
    );
    assert!(relief_io::write_png16(&p, 3, 3, &[0; 6]).is_err());
    let r = dir.path().join("d.f32");
    relief_io::write_raw_f32(&r, &[1.5, -2.0, 3.0, 4.0]).unwrap();
    let o = ReadOptions {
        width: Some(2),
        height: Some(2),
        ..ReadOptions::default()
    };
    assert_eq!(read_dem(&r, &o).unwrap().samples, vec![1.5, -2.0, 3.0, 4.0]);
    let m = dir.path().join("m.obj");
    assert!(relief_io::write_obj(&m, &[[0.0; 3]], &[[0, 1, 2]]).is_err());
    assert!(!m.exists(), "a rejected mesh must leave no file");
    // No temporary files are left behind.
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 2, "{names:?}");
}

#[test]
fn unwritable_destination_is_an_error() {
    let e = relief_io::write_raw_f32(Path::new("/nonexistent-dir/x.f32"), &[1.0]).unwrap_err();
    assert!(matches!(e, IoError::Io { .. }));
}

fn shared_data() -> Option<PathBuf> {
    let d = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data");
    if d.is_dir() {
        Some(d)
    } else {
        eprintln!("skipping: ../shared/data not found beside the repository");
        None
    }
}

#[test]
fn real_dems_decode_to_documented_sizes_and_ranges() {
    let Some(d) = shared_data() else { return };
    // (file, format, width, height, min, max) from ../shared/data/README.md.
    let cases = [
        (
            "martini_fuji.png",
            Some(Format::TerrainRgb),
            512,
            512,
            13.7,
            3751.0,
        ),
        (
            "delatin_14-2625-6369.png",
            Some(Format::TerrainRgb),
            512,
            512,
            19.0,
            251.8,
        ),
        (
            "pymartini_mapbox_st_helens.png",
            Some(Format::TerrainRgb),
            256,
            256,
            1002.0,
            1164.2,
        ),
        (
            "pymartini_terrarium.png",
            Some(Format::Terrarium),
            256,
            256,
            715.2,
            2489.0,
        ),
        ("diligent_ps_height_1k.png", None, 1025, 1025, 0.0, 43798.0),
        (
            "topotoolbox_srtm_bigtujunga30m_utm11.tif",
            None,
            1197,
            643,
            315.0,
            2295.0,
        ),
        ("pysheds_dem.tif", None, 367, 359, 147.0, 298.0),
    ];
    for (file, format, w, h, min, max) in cases {
        let o = ReadOptions {
            format,
            ..ReadOptions::default()
        };
        let dem = read_dem(&d.join(file), &o).unwrap_or_else(|e| panic!("{file}: {e}"));
        assert_eq!((dem.width, dem.height), (w, h), "{file}");
        let s = dem.stats();
        assert!(
            (s.min - min).abs() < 0.06 && (s.max - max).abs() < 0.06,
            "{file}: {s:?}"
        );
        assert_eq!(dem.nodata_count, 0, "{file}");
    }
    // The projected GeoTIFF carries its 30 m spacing.
    let t = read_dem(
        &d.join("topotoolbox_srtm_bigtujunga30m_utm11.tif"),
        &ReadOptions::default(),
    )
    .unwrap();
    assert_eq!((t.scale.dx, t.scale.dy), (30.0, 30.0));
}

#[test]
fn header_claiming_more_than_the_file_can_hold_is_rejected_without_allocating() {
    // Found by the `decode` fuzz target: a 4096 x 1024 RGB header over a few bytes of IDAT asked
    // for a 3 GB buffer before noticing the data was missing.
    let bytes: &[u8] = &[
        0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48, 0x44,
        0x52, 0x10, 0x00, 0x00, 0x04, 0x00, 0x00, 0x00, 0x04, 0x08, 0x02, 0x00, 0x00, 0x00, 0x26,
        0x93, 0x09, 0x29, 0x00, 0x00, 0x00, 0x18, 0x49, 0x44, 0x41, 0x54, 0x78, 0x9c, 0x63, 0x60,
        0x6c, 0x5b, 0xc0, 0xd8, 0xb6, 0x90, 0xb1, 0x6d, 0x11, 0x63, 0xdb, 0x62, 0x06, 0xe2, 0xff,
        0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x2a, 0xc8, 0x00, 0x00, 0x00, 0x00, 0x49, 0x45,
        0x4e, 0x44, 0xae, 0x42,
    ];
    let e = decode_dem(bytes, &opts(Format::TerrainRgb)).unwrap_err();
    assert!(matches!(e, IoError::Decode { .. }), "{e}");
}

#[cfg(unix)]
#[test]
fn written_files_are_readable_by_others_or_keep_their_permissions() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("d.f32");
    relief_io::write_raw_f32(&p, &[1.0]).unwrap();
    assert_eq!(
        std::fs::metadata(&p).unwrap().permissions().mode() & 0o777,
        0o644
    );
    std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o640)).unwrap();
    relief_io::write_raw_f32(&p, &[2.0]).unwrap();
    assert_eq!(
        std::fs::metadata(&p).unwrap().permissions().mode() & 0o777,
        0o640
    );
}
