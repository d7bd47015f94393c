// Deformations (craters): dynamic height changes applied on the GPU every frame, after which the
// maximum mipmap is rebuilt (Tevs et al. 2008: maximum mipmaps exist so that dynamic height
// fields stay fast; Kentie 2009, seed 003, section 3.8 deforms the height map on the GPU).
// Each crater lowers the surface by depth * (1 - (r / radius)^2) inside its radius (grid units).

struct DeformParams {
    width: u32,
    height: u32,
    craters: u32,
    _pad: u32,
}

@group(0) @binding(0) var<storage, read> base: array<f32>;
@group(0) @binding(1) var<storage, read_write> heights: array<f32>;
@group(0) @binding(2) var<uniform> p: DeformParams;
// (center x, center y, radius, depth) in grid units / local height units.
@group(0) @binding(3) var<storage, read> craters: array<vec4<f32>>;

@compute @workgroup_size(8, 8)
fn deform(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= p.width || id.y >= p.height {
        return;
    }
    let i = id.y * p.width + id.x;
    var h = base[i];
    for (var k = 0u; k < p.craters; k++) {
        let c = craters[k];
        let d = vec2<f32>(f32(id.x), f32(id.y)) - c.xy;
        let q = dot(d, d) / (c.z * c.z);
        if q < 1.0 {
            h -= c.w * (1.0 - q);
        }
    }
    heights[i] = h;
}
