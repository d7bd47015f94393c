//! Heightfield construction, composition, surfaces and normals on arbitrary bytes.
//! Invariants: construction either fails with an error or yields a view whose surfaces are
//! finite inside the domain and `None` outside, and whose normals are unit and point up.
#![no_main]

use libfuzzer_sys::fuzz_target;
use relief_core::{normal, Composed, Heightfield, NormalMethod, Scale, Surface, Terrain};

fn f32_at(d: &[u8], i: usize) -> f32 {
    let b = [0, 1, 2, 3].map(|k| d.get(i + k).copied().unwrap_or(0));
    f32::from_le_bytes(b)
}

fuzz_target!(|data: &[u8]| {
    if data.len() < 24 {
        return;
    }
    let w = u32::from(data[0] % 9);
    let h = u32::from(data[1] % 9);
    let scale = Scale {
        dx: f32_at(data, 2),
        dy: f32_at(data, 6),
        z_scale: f32_at(data, 10),
        z_offset: f32_at(data, 14),
    };
    let samples: Vec<f32> = data[18..].chunks_exact(4).map(|c| f32_at(c, 0)).collect();
    let n = ((w * h) as usize).min(samples.len());
    let Ok(hf) = Heightfield::with_scale(&samples[..n], w, h, scale) else {
        return;
    };
    let ext = hf.extent();
    for k in 0..8u32 {
        let px = ext.x * (k as f32 / 7.0);
        let py = ext.y * (((k * 3) % 8) as f32 / 7.0);
        for s in [Surface::Triangles, Surface::Bilinear, Surface::Nearest] {
            if let Some(z) = hf.surface_height(s, px, py) {
                assert!(z.is_finite(), "{s:?} at ({px},{py}) = {z}");
            }
            assert!(hf.surface_height(s, -1.0 - px, py).is_none());
            assert!(hf.surface_height(s, f32::NAN, py).is_none());
        }
    }
    for y in 0..h {
        for x in 0..w {
            for m in [NormalMethod::Central, NormalMethod::Sobel] {
                let nrm = normal(&hf, x, y, m).unwrap();
                assert!(nrm.is_finite() && (nrm.length() - 1.0).abs() <= 1e-6 && nrm.z > 0.0);
            }
        }
    }
    // Compose the grid with itself as detail.
    let factor = 1u32 << (data[0] >> 5);
    if let Ok(c) = Composed::new(hf, hf, factor) {
        for y in 0..c.height().min(20) {
            for x in 0..c.width().min(20) {
                assert!(c.z(x, y).is_finite());
                let nrm = c.summed_normal(x, y).unwrap();
                assert!(nrm.is_finite() && (nrm.length() - 1.0).abs() <= 1e-6 && nrm.z > 0.0);
            }
        }
    }
});
