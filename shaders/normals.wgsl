// Normal map from finite differences (Balogh 2003, seed 004, section 2.3: the normal is
// (-dz/dx, -dz/dy, 1) normalised; Kentie 2009, seed 003, section 3.6: Sobel for smoother
// normals). Same border rule as relief_core::normal_map: a missing neighbour is replaced by the
// sample itself and the difference divided by the spacing actually spanned.
// Composed base + detail (Balogh section 7.3, summed differences) when DETAIL is set: the base is
// refined 2^shift times by bilinear interpolation (relief_core::Composed with factor 2^shift:
// output sample X lies at base position X / 2^shift) and the detail map (detail_w x detail_h
// samples, tiled with period detail_w x detail_h output samples) is added before differencing.

struct NormalParams {
    // Output (composed) grid size; the base grid is ((width - 1) >> shift) + 1 wide.
    width: u32,
    height: u32,
    detail_w: u32,
    detail_h: u32,
    // Output spacing (the base spacing divided by 2^shift).
    dx: f32,
    dy: f32,
    shift: u32,
    _pad1: u32,
}

// 0: central differences, 1: Sobel.
override SOBEL: bool = false;
override DETAIL: bool = false;

@group(0) @binding(0) var<storage, read> heights: array<f32>;
// The gradient (dz/dx, dz/dy) of each sample, 8 bytes: the normal is
// normalize(-dz/dx, -dz/dy, 1), computed where it is read (raycast.wgsl's gradient_normal, the
// same operations as relief_wgpu::NormalPass::read).
@group(0) @binding(1) var<storage, read_write> normals: array<vec2<f32>>;
@group(0) @binding(2) var<uniform> p: NormalParams;
@group(0) @binding(3) var<storage, read> detail: array<f32>;

fn lerp(a: f32, b: f32, t: f32) -> f32 {
    return (1.0 - t) * a + t * b;
}

// Bilinear base height at output sample (x, y), as relief_core::Composed::base_z.
fn base_z(x: u32, y: u32) -> f32 {
    if p.shift == 0u {
        return heights[y * p.width + x];
    }
    let bw = ((p.width - 1u) >> p.shift) + 1u;
    let bh = ((p.height - 1u) >> p.shift) + 1u;
    let f = 1u << p.shift;
    var bx = x >> p.shift;
    var fx = f32(x & (f - 1u)) / f32(f);
    if bx >= bw - 1u {
        bx = bw - 2u;
        fx = 1.0;
    }
    var by = y >> p.shift;
    var fy = f32(y & (f - 1u)) / f32(f);
    if by >= bh - 1u {
        by = bh - 2u;
        fy = 1.0;
    }
    let h00 = heights[by * bw + bx];
    let h10 = heights[by * bw + bx + 1u];
    let h01 = heights[(by + 1u) * bw + bx];
    let h11 = heights[(by + 1u) * bw + bx + 1u];
    return lerp(lerp(h00, h10, fx), lerp(h01, h11, fx), fy);
}

fn z(x: u32, y: u32) -> f32 {
    var h = base_z(x, y);
    if DETAIL {
        h += detail[(y % p.detail_h) * p.detail_w + (x % p.detail_w)];
    }
    return h;
}

@compute @workgroup_size(8, 8)
fn normal_map(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= p.width || id.y >= p.height {
        return;
    }
    let x = id.x;
    let y = id.y;
    let xl = select(x - 1u, 0u, x == 0u);
    let xr = min(x + 1u, p.width - 1u);
    let yl = select(y - 1u, 0u, y == 0u);
    let yr = min(y + 1u, p.height - 1u);
    let sx = f32(xr - xl) * p.dx;
    let sy = f32(yr - yl) * p.dy;
    var gx: f32;
    var gy: f32;
    if SOBEL {
        gx = ((z(xr, yl) + 2.0 * z(xr, y) + z(xr, yr)) - (z(xl, yl) + 2.0 * z(xl, y) + z(xl, yr))) / (4.0 * sx);
        gy = ((z(xl, yr) + 2.0 * z(x, yr) + z(xr, yr)) - (z(xl, yl) + 2.0 * z(x, yl) + z(xr, yl))) / (4.0 * sy);
    } else {
        gx = (z(xr, y) - z(xl, y)) / sx;
        gy = (z(x, yr) - z(x, yl)) / sy;
    }
    normals[y * p.width + x] = vec2<f32>(gx, gy);
}
