//! Links relief-core into a `#![no_std]` static library with no allocator.
#![no_std]

use relief_core::{normal, Heightfield, NormalMethod, Terrain};

/// Uses the core so its code is really compiled into this library.
#[no_mangle]
pub extern "C" fn relief_nostd_probe(samples: *const u16, len: usize, w: u32, h: u32) -> f32 {
    if samples.is_null() {
        return f32::NAN;
    }
    // SAFETY: the caller passes a valid buffer of `len` samples.
    let s = unsafe { core::slice::from_raw_parts(samples, len) };
    match Heightfield::new(s, w, h) {
        Ok(hf) => normal(&hf, 0, 0, NormalMethod::Sobel).map_or(0.0, |n| n.z) + hf.z(0, 0),
        Err(_) => -1.0,
    }
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    loop {}
}
