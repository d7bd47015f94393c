// Cascade ray cast, last step (seed 002: Cornel, Horvath, Waser 2022, section 5): each pixel's
// ray has been traced through the three RBF cascades (nearest first, one maximum mipmap each,
// raycast.wgsl); here the first cascade whose hit lies on one of its visible texels gives the
// depth, and where that texel is in the overlap with the next cascade (blend weight below 1)
// the two hits are blended by the convex combination of their blend weights.
//
// The blend weights are computed here, on the GPU, as relief_core::rbf::Cascade::blend_weight
// does on the CPU: the weight of the texel nearest the hit is 0 where the texel is invisible
// (mask), else the product of the linear fade-in and fade-out ramps at the offset of the
// texel's centre along the projected view vector, measured from the eye's ground position.

struct BlendParams {
    // World eye (x, y, z), unused.
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
    // Per cascade: spacing (grid units per texel); unused.
    spacing: vec4<f32>,
    // Eye ground position (x, y), normalised ground projection of the view vector (x, y).
    view: vec4<f32>,
    // Per cascade: fade-in offsets (from, to), fade-out offsets (from, to); empty ramps
    // (to <= from) mean no fade.
    fade: array<vec4<f32>, 3>,
    // World height range for the colour ramp (min, max); unused.
    range: vec4<f32>,
}

@group(0) @binding(0) var<uniform> p: BlendParams;
@group(0) @binding(1) var<storage, read> depth0: array<u32>;
@group(0) @binding(2) var<storage, read> depth1: array<u32>;
@group(0) @binding(3) var<storage, read> depth2: array<u32>;
// Visible-texel masks (1 visible, 0 not), one per cascade.
@group(0) @binding(4) var<storage, read> mask0: array<u32>;
@group(0) @binding(5) var<storage, read> mask1: array<u32>;
@group(0) @binding(6) var<storage, read> mask2: array<u32>;
@group(0) @binding(7) var<storage, read_write> out_depth: array<u32>;
@group(0) @binding(8) var<storage, read_write> out_color: array<u32>;

const INF_BITS: u32 = 0x7f800000u;

fn depth_of(c: u32, k: u32) -> u32 {
    if c == 0u {
        return depth0[k];
    } else if c == 1u {
        return depth1[k];
    }
    return depth2[k];
}

fn mask_of(c: u32, k: u32) -> u32 {
    if c == 0u {
        return mask0[k];
    } else if c == 1u {
        return mask1[k];
    }
    return mask2[k];
}

// Cascade::blend_weight_at_offset.
fn ramp(o: f32, a: f32, b: f32) -> f32 {
    if b > a {
        return clamp((o - a) / (b - a), 0.0, 1.0);
    } else if o >= a {
        return 1.0;
    }
    return 0.0;
}

fn weight_at_offset(c: u32, o: f32) -> f32 {
    let f = p.fade[c];
    var up = 1.0;
    if f.y > f.x {
        up = ramp(o, f.x, f.y);
    }
    var down = 1.0;
    if f.w > f.z {
        down = 1.0 - ramp(o, f.z, f.w);
    }
    return up * down;
}

// Blend weight of cascade c at the hit t along dir: that of the nearest texel (0 outside the
// raster or on an invisible texel).
fn weight_at(c: u32, t: f32, dir: vec3<f32>) -> f32 {
    let hit = p.eye.xy + t * dir.xy;
    let g = hit / p.lens.zw / p.spacing[c];
    let i = i32(floor(g.x + 0.5)) - p.origin[c].x;
    let j = i32(floor(g.y + 0.5)) - p.origin[c].y;
    let res = p.origin[c].z;
    if i < 0 || j < 0 || i >= res || j >= res {
        return 0.0;
    }
    if mask_of(c, u32(j * res + i)) == 0u {
        return 0.0;
    }
    // Texel centre in world units (Cascade::texel_center times dx, dy).
    let centre = vec2<f32>(f32(p.origin[c].x + i), f32(p.origin[c].y + j)) * p.spacing[c] * p.lens.zw;
    return weight_at_offset(c, dot(centre - p.view.xy, p.view.zw));
}

fn ramp_colour(z: f32) -> vec3<f32> {
    let s = clamp((z - p.range.x) / max(p.range.y - p.range.x, 1e-6), 0.0, 1.0);
    let low = vec3<f32>(0.25, 0.45, 0.2);
    let mid = vec3<f32>(0.55, 0.45, 0.3);
    let high = vec3<f32>(0.95, 0.95, 0.95);
    if s < 0.6 {
        return mix(low, mid, s / 0.6);
    }
    return mix(mid, high, (s - 0.6) / 0.4);
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
    var colour = vec3<f32>(0.55, 0.7, 0.9);
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
        colour = ramp_colour(p.eye.z + d * dir.z);
        break;
    }
    out_depth[k] = out;
    out_color[k] = pack4x8unorm(vec4<f32>(colour, 1.0));
}
