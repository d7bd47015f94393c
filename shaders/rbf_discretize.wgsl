// RBF cascade discretization (seed 002: Cornel, Horvath, Waser 2022, section 4, last
// paragraph): the truncated Gaussian RBF approximation on the adaptive grid (eq. 1-2) evaluated
// at the centre of every visible texel of one cascade. A port of relief_core::rbf::Rbf::eval:
// the cell containing the point, its precomputed influence set, weights
// `exp(-q / (2 sigma^2)) - remainder` truncated at q = (3.5 sigma)^2, the weighted mean of cell
// values relative to the containing cell's value, clamped to the values that contributed.
// One invocation per texel, 8 x 8 workgroups; invisible texels get a given value (0 as on the
// CPU, or far below the terrain for the cascade ray cast, so rays fall through them).
//
// The visible-texel mask comes from the CPU (uploaded) or from the entry point `visible`, which
// computes it in a dispatch of its own before `discretize` reads it: a texel is visible when its
// centre lies within `margin` of the cascade's convex ground polygon, relief_core::rbf::
// Cascade::mask's test (every edge's signed distance at least -margin), with the edges' vectors
// and lengths computed on the CPU, so a frame uploads the polygon instead of the mask.

struct RbfParams {
    // Grid width, height; cascade resolution; polygon edges (for `visible`).
    dims: vec4<u32>,
    // Cascade origin (texel units, i32) and unused.
    origin: vec4<i32>,
    // Texel spacing (grid units), sigma, truncation remainder, value of invisible texels.
    misc: vec4<f32>,
    // World units per grid unit in x and y, the mask's margin (world units), unused.
    world: vec4<f32>,
}

@group(0) @binding(0) var<uniform> p: RbfParams;
// (x, y, size, value) per cell.
@group(0) @binding(1) var<storage, read> cells: array<vec4<f32>>;
// Cell index per sample.
@group(0) @binding(2) var<storage, read> index: array<u32>;
// Influence sets: entries[offsets[j] .. offsets[j + 1]].
@group(0) @binding(3) var<storage, read> offsets: array<u32>;
@group(0) @binding(4) var<storage, read> entries: array<u32>;
// Visibility mask per texel (0 or 1): read by `discretize`, written by `visible`.
@group(0) @binding(5) var<storage, read_write> mask: array<u32>;
@group(0) @binding(6) var<storage, read_write> values: array<f32>;
// The polygon's edges for `visible`, two entries each: (start x, start y, edge x, edge y) and
// (edge length, unused), world units.
@group(0) @binding(7) var<storage, read> edges: array<vec4<f32>>;

const TRUNCATION: f32 = 3.5;

fn gaussian(q: f32, sigma: f32) -> f32 {
    let s2 = sigma * sigma;
    if q >= TRUNCATION * TRUNCATION * s2 || q < 0.0 {
        return 0.0;
    }
    return max(exp(-q / (2.0 * s2)) - p.misc.z, 0.0);
}

// The texel's centre in grid units (relief_core::rbf::Cascade::texel_center).
fn texel_center(id: vec2<u32>) -> vec2<f32> {
    return vec2<f32>(f32(p.origin.x + i32(id.x)), f32(p.origin.y + i32(id.y))) * p.misc.x;
}

@compute @workgroup_size(8, 8)
fn visible(@builtin(global_invocation_id) id: vec3<u32>) {
    let res = p.dims.z;
    if id.x >= res || id.y >= res {
        return;
    }
    let q = texel_center(id.xy) * p.world.xy;
    let n = p.dims.w;
    var inside = n >= 3u;
    for (var e = 0u; e < n; e++) {
        let a = edges[2u * e];
        let len = edges[2u * e + 1u].x;
        let d = q - a.xy;
        if len > 0.0 && (a.z * d.y - a.w * d.x) / len < -p.world.z {
            inside = false;
            break;
        }
    }
    mask[id.y * res + id.x] = select(0u, 1u, inside);
}

@compute @workgroup_size(8, 8)
fn discretize(@builtin(global_invocation_id) id: vec3<u32>) {
    let res = p.dims.z;
    if id.x >= res || id.y >= res {
        return;
    }
    let k = id.y * res + id.x;
    if mask[k] == 0u {
        values[k] = p.misc.w;
        return;
    }
    let w = p.dims.x;
    let h = p.dims.y;
    let pt = clamp(texel_center(id.xy), vec2<f32>(-0.5), vec2<f32>(f32(w) - 0.5, f32(h) - 0.5));
    let sx = u32(clamp(floor(pt.x + 0.5), 0.0, f32(w - 1u)));
    let sy = u32(clamp(floor(pt.y + 0.5), 0.0, f32(h - 1u)));
    let j = index[sy * w + sx];
    let v_ref = cells[j].w;
    var sw = 0.0;
    var swv = 0.0;
    var lo = 3.4e38;
    var hi = -3.4e38;
    var nearest = v_ref;
    var nearest_d = 3.4e38;
    let a = offsets[j];
    let b = offsets[j + 1u];
    for (var e = a; e < b; e++) {
        let c = cells[entries[e]];
        let half = (c.z - 1.0) * 0.5;
        let d = vec2<f32>(c.x + half, c.y + half) - pt;
        let d2 = dot(d, d);
        let wt = gaussian(d2 / (c.z * c.z), p.misc.y);
        if wt > 0.0 {
            sw += wt;
            swv += wt * (c.w - v_ref);
            lo = min(lo, c.w);
            hi = max(hi, c.w);
        }
        if d2 < nearest_d {
            nearest_d = d2;
            nearest = c.w;
        }
    }
    if sw <= 0.0 {
        values[k] = nearest;
        return;
    }
    values[k] = clamp(v_ref + swv / sw, lo, hi);
}
