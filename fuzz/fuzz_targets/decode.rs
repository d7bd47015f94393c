//! Every I/O decoder on arbitrary bytes: never panics; a decoded DEM is void-free and valid.
#![no_main]

use libfuzzer_sys::fuzz_target;
use relief_io::{decode_dem, Fill, Format, ReadOptions};

fuzz_target!(|data: &[u8]| {
    let Some((&sel, bytes)) = data.split_first() else {
        return;
    };
    let format = match sel % 6 {
        0 => None,
        k => Some(Format::ALL[usize::from(k - 1)]),
    };
    let fill = [Fill::Error, Fill::Nearest, Fill::Min][usize::from(sel / 6 % 3)];
    let side = u32::from(sel / 18 % 8) + 1;
    let opts = ReadOptions {
        format,
        width: (format == Some(Format::RawF32)).then_some(side),
        height: (format == Some(Format::RawF32)).then(|| (bytes.len() / 4) as u32 / side),
        nodata: None,
        fill,
    };
    if let Ok(dem) = decode_dem(bytes, &opts) {
        assert_eq!(dem.samples.len(), (dem.width * dem.height) as usize);
        assert!(dem.samples.iter().all(|v| v.is_finite()));
        assert!(dem.heightfield().is_ok());
    }
});
