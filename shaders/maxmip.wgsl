// Maximum-mipmap build (Tevs, Ihrke, Seidel 2008, section 4; seed 002, section 5, uses one
// pyramid per cascade). Same layout as relief_core::ray::MaxMip: level 0 holds the maximum of
// each cell's four corner heights, level k the maximum of 2 x 2 nodes of level k - 1 (odd sizes
// round up), levels stored one after another. One dispatch per level.

struct MipParams {
    // Sample grid width (level 0 reads corners from the heights).
    grid_width: u32,
    level: u32,
    src_offset: u32,
    dst_offset: u32,
    src_w: u32,
    src_h: u32,
    dst_w: u32,
    dst_h: u32,
}

@group(0) @binding(0) var<storage, read> heights: array<f32>;
@group(0) @binding(1) var<storage, read_write> mip: array<f32>;
@group(0) @binding(2) var<uniform> p: MipParams;

@compute @workgroup_size(8, 8)
fn build_level(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= p.dst_w || id.y >= p.dst_h {
        return;
    }
    var m: f32;
    if p.level == 0u {
        let i = id.y * p.grid_width + id.x;
        m = max(max(heights[i], heights[i + 1u]), max(heights[i + p.grid_width], heights[i + p.grid_width + 1u]));
    } else {
        let x0 = 2u * id.x;
        let y0 = 2u * id.y;
        let x1 = min(x0 + 1u, p.src_w - 1u);
        let y1 = min(y0 + 1u, p.src_h - 1u);
        let r0 = p.src_offset + y0 * p.src_w;
        let r1 = p.src_offset + y1 * p.src_w;
        m = max(max(mip[r0 + x0], mip[r0 + x1]), max(mip[r1 + x0], mip[r1 + x1]));
    }
    mip[p.dst_offset + id.y * p.dst_w + id.x] = m;
}
