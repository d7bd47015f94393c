//! Calls relief-core's public entry points with arbitrary caller input (raw pointers and
//! lengths, as an embedded C caller would). If any of them can reach a panic, the panic handler
//! below stays in the binary and its call to an undefined symbol fails the link.
#![no_std]
#![allow(clippy::missing_safety_doc)]

use core::slice;
use relief_core::glam::{Vec3, Vec4};
use relief_core::{
    normal, normal_map, Camera, Composed, Heightfield, NormalMethod, Scale, Surface, Terrain,
};

extern "C" {
    /// Defined nowhere: referencing it makes the link fail.
    fn relief_core_has_a_reachable_panic() -> !;
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    unsafe { relief_core_has_a_reachable_panic() }
}

unsafe fn view<'a, T>(p: *const T, len: usize) -> &'a [T] {
    if p.is_null() {
        &[]
    } else {
        slice::from_raw_parts(p, len)
    }
}

unsafe fn view_mut<'a, T>(p: *mut T, len: usize) -> &'a mut [T] {
    if p.is_null() {
        &mut []
    } else {
        slice::from_raw_parts_mut(p, len)
    }
}

fn scale(s: &[f32; 4]) -> Scale {
    Scale {
        dx: s[0],
        dy: s[1],
        z_scale: s[2],
        z_offset: s[3],
    }
}

fn surface(k: u32) -> Surface {
    match k % 3 {
        0 => Surface::Triangles,
        1 => Surface::Bilinear,
        _ => Surface::Nearest,
    }
}

fn method(k: u32) -> NormalMethod {
    if k % 2 == 0 {
        NormalMethod::Central
    } else {
        NormalMethod::Sobel
    }
}

/// Heightfield construction, every accessor, surfaces and gradients (u16 samples).
#[no_mangle]
pub unsafe extern "C" fn pc_heightfield_u16(
    p: *const u16,
    len: usize,
    w: u32,
    h: u32,
    s: &[f32; 4],
    x: u32,
    y: u32,
    px: f32,
    py: f32,
    k: u32,
) -> f32 {
    let Ok(hf) = Heightfield::with_scale(view(p, len), w, h, scale(s)) else {
        return -1.0;
    };
    let mut acc = hf.z(x, y) + hf.local_z(x, y);
    acc += hf.try_z(x, y).unwrap_or(0.0);
    acc += hf.position(x, y).map_or(0.0, |v| v.z);
    acc += hf.extent().x;
    acc += hf.cell_min_max(x, y).map_or(0.0, |m| m.0 + m.1);
    acc += hf.surface_height(surface(k), px, py).unwrap_or(0.0);
    acc += hf.surface_height_grid(surface(k), px, py).unwrap_or(0.0);
    acc += hf.gradient(x, y).map_or(0.0, |g| g.x);
    acc += hf.sample(x, y).map_or(0.0, f32::from);
    acc
}

/// Same for f32 samples, plus normals into a caller buffer.
#[no_mangle]
pub unsafe extern "C" fn pc_heightfield_f32_normals(
    p: *const f32,
    len: usize,
    w: u32,
    h: u32,
    s: &[f32; 4],
    out: *mut Vec3,
    out_len: usize,
    x: u32,
    y: u32,
    k: u32,
) -> f32 {
    let Ok(hf) = Heightfield::with_scale(view(p, len), w, h, scale(s)) else {
        return -1.0;
    };
    let n = normal(&hf, x, y, method(k)).map_or(0.0, |n| n.z);
    match normal_map(&hf, method(k), view_mut(out, out_len)) {
        Ok(()) => n,
        Err(_) => -n,
    }
}

/// Base + detail composition, its surfaces and summed normals.
#[no_mangle]
pub unsafe extern "C" fn pc_composed(
    b: *const i16,
    blen: usize,
    bw: u32,
    bh: u32,
    d: *const f32,
    dlen: usize,
    dw: u32,
    dh: u32,
    factor: u32,
    x: u32,
    y: u32,
    px: f32,
    py: f32,
    k: u32,
) -> f32 {
    let (Ok(base), Ok(detail)) = (
        Heightfield::new(view(b, blen), bw, bh),
        Heightfield::new(view(d, dlen), dw, dh),
    ) else {
        return -1.0;
    };
    let Ok(c) = Composed::new(base, detail, factor) else {
        return -2.0;
    };
    let mut acc = c.z(x, y) + c.base_z(x, y) + c.detail_z(x, y);
    acc += c.summed_normal(x, y).map_or(0.0, |n| n.z);
    acc += normal(&c, x, y, method(k)).map_or(0.0, |n| n.z);
    acc += c.surface_height(surface(k), px, py).unwrap_or(0.0);
    acc
}

/// The camera: construction, rays, matrices and planes.
#[no_mangle]
pub extern "C" fn pc_camera(
    e: &[f32; 3],
    t: &[f32; 3],
    fov: f32,
    w: u32,
    h: u32,
    i: u32,
    j: u32,
    near: f32,
    far: f32,
) -> f32 {
    let Ok(cam) = Camera::new(Vec3::from(*e), Vec3::from(*t), fov, w, h) else {
        return -1.0;
    };
    let (_, d) = cam.ray(i, j);
    let mut acc = d.x + cam.kappa() + cam.tan_half_fov();
    if let Ok(planes) = cam.frustum_planes(near, far) {
        acc += planes.iter().map(|p| p.dot(Vec4::ONE)).sum::<f32>();
    }
    acc
}
