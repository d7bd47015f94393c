// Cascade ray cast, last step (seed 002: Cornel, Horvath, Waser 2022, section 5): each pixel's
// ray has been traced through the three RBF cascades (nearest first, one maximum mipmap each,
// raycast.wgsl); here the first cascade whose hit lies on one of its visible texels gives the
// depth, and where that texel is in the overlap with the next cascade (blend weight below 1)
// the two hits are blended by the convex combination of their blend weights.

struct BlendParams {
    // World eye (x, y; z unused), camera basis.
    eye: vec4<f32>,
    forward: vec4<f32>,
    right: vec4<f32>,
    up: vec4<f32>,
    // tan(fov / 2), aspect, dx, dy of the base grid.
    lens: vec4<f32>,
    // Image width, height; unused.
    image: vec4<u32>,
    // Per cascade: origin x, origin y (texels, i32), resolution (as i32), unused.
    origin: array<vec4<i32>, 3>,
    // Per cascade: spacing (grid units per texel), unused.
    spacing: vec4<f32>,
}

@group(0) @binding(0) var<uniform> p: BlendParams;
@group(0) @binding(1) var<storage, read> depth0: array<u32>;
@group(0) @binding(2) var<storage, read> depth1: array<u32>;
@group(0) @binding(3) var<storage, read> depth2: array<u32>;
// Blend weight per texel (0 where invisible), one buffer per cascade, concatenated.
@group(0) @binding(4) var<storage, read> weights: array<f32>;
@group(0) @binding(5) var<storage, read_write> out_depth: array<u32>;

const INF_BITS: u32 = 0x7f800000u;

fn depth_of(c: u32, k: u32) -> u32 {
    if c == 0u {
        return depth0[k];
    } else if c == 1u {
        return depth1[k];
    }
    return depth2[k];
}

// Blend weight of cascade c at the hit t along dir (nearest texel; 0 outside the raster).
fn weight_at(c: u32, t: f32, dir: vec3<f32>) -> f32 {
    var base = 0u;
    for (var k = 0u; k < c; k++) {
        let r = u32(p.origin[k].z);
        base += r * r;
    }
    let hit = p.eye.xy + t * dir.xy;
    let g = hit / p.lens.zw / p.spacing[c];
    let i = i32(floor(g.x + 0.5)) - p.origin[c].x;
    let j = i32(floor(g.y + 0.5)) - p.origin[c].y;
    let res = p.origin[c].z;
    if i < 0 || j < 0 || i >= res || j >= res {
        return 0.0;
    }
    return weights[base + u32(j * res + i)];
}

@compute @workgroup_size(8, 8)
fn blend(@builtin(global_invocation_id) id: vec3<u32>) {
    let w = p.image.x;
    let h = p.image.y;
    if id.x >= w || id.y >= h {
        return;
    }
    let k = id.y * w + id.x;
    let px = (2.0 * (f32(id.x) + 0.5) / f32(w) - 1.0) * p.lens.y * p.lens.x;
    let py = (1.0 - 2.0 * (f32(id.y) + 0.5) / f32(h)) * p.lens.x;
    let dir = normalize(p.forward.xyz + px * p.right.xyz + py * p.up.xyz);
    var out = INF_BITS;
    for (var c = 0u; c < 3u; c++) {
        let bits = depth_of(c, k);
        if bits == INF_BITS {
            continue;
        }
        let t = bitcast<f32>(bits);
        let wc = weight_at(c, t, dir);
        if wc <= 0.0 {
            continue;
        }
        var d = t;
        if wc < 1.0 && c < 2u {
            let nb = depth_of(c + 1u, k);
            if nb != INF_BITS {
                let tn = bitcast<f32>(nb);
                let wn = weight_at(c + 1u, tn, dir);
                if wn > 0.0 {
                    d = (wc * t + wn * tn) / (wc + wn);
                }
            }
        }
        out = bitcast<u32>(d);
        break;
    }
    out_depth[k] = out;
}
