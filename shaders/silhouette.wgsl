// Silhouette partitioning (seed 000: Jaroszewicz, "Ray tracing height fields on the GPU with
// silhouette partitioning"): no preprocessing, everything rebuilt every frame from the heights.
//
// Rows of the heightfield (the grid lines most perpendicular to the view, numbered front to
// back, v = 0 nearest) are projected to the screen. For every screen column x:
// 1. `silhouette_map` (section 4.1.2, *Intersect*): a binary search along each row for the
//    segment whose projection spans x, then linear interpolation of the screen height y and the
//    row coordinate u (*InterpolateU*). Columns a row does not cover get y = -BIG.
// 2. `silhouette_tree` (sections 4.1.3-4.1.5): the partitioning tree over rows, two levels per
//    vec4 texel as the seed packs them: from four silhouettes A, B, C, D (front to back) of the
//    level below, x = max(A, B) (the closer child of the upper level), y = A and z = C (the
//    closer children of the two lower nodes), w = max(A, B, C, D) (the node's own silhouette,
//    used to build the next pair of levels).
// 3. `silhouette_trace` (section 5, *Trace* / *InterpolateV*): per pixel a fixed-depth binary
//    search down the tree for the nearest row whose silhouette at x reaches the pixel's height,
//    then interpolation between that row and the one before by y. Fixed cost: one tree texel per
//    pair of levels plus two silhouette-map texels per pixel.
// Screen coordinates are in tangent units: x = dot(q, r) / dot(q, f), y = dot(q, u) / dot(q, f)
// for q = p - eye, the pixel centres of relief_core::Camera.

struct SilParams {
    // Eye (world, minus nothing: the grid origin is 0), then camera basis.
    eye: vec4<f32>,
    forward: vec4<f32>,
    right: vec4<f32>,
    up: vec4<f32>,
    // dx, dy, tan(fov / 2), aspect.
    lens: vec4<f32>,
    // Local height range (zmin, zmax) for colours; z_offset; unused.
    range: vec4<f32>,
    // Image width, height; sample grid width, height.
    image: vec4<u32>,
    // Row mapping: grid (gx, gy) of sample k of row v is origin + k * ustep + v * vstep.
    // origin.xy, ustep.xy as i32.
    map0: vec4<i32>,
    // vstep.xy, rows NV, row length NU.
    map1: vec4<i32>,
    // Padded row count V2 (a power of 4), pair levels P, pair level to build (tree pass), unused.
    tree: vec4<u32>,
    // Offsets of the pair levels in the tree buffer (level k at offsets[k / 4][k % 4]).
    offsets: array<vec4<u32>, 4>,
}

const BIG: f32 = 1e30;
const INF_BITS: u32 = 0x7f800000u;

@group(0) @binding(0) var<uniform> p: SilParams;
@group(0) @binding(1) var<storage, read> heights: array<f32>;
// Silhouette map: (y, u) per (row v, column x), rows padded to V2.
@group(0) @binding(2) var<storage, read_write> sil: array<vec2<f32>>;
@group(0) @binding(3) var<storage, read_write> tree: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> out_depth: array<u32>;
@group(0) @binding(5) var<storage, read_write> out_color: array<u32>;

fn grid(k: i32, v: i32) -> vec2<i32> {
    return p.map0.xy + k * p.map0.zw + v * p.map1.xy;
}

// World position of sample k of row v (local z: z_offset is added by the caller's eye).
fn world(k: i32, v: i32) -> vec3<f32> {
    let g = grid(k, v);
    let h = heights[u32(g.y) * p.image.z + u32(g.x)];
    return vec3<f32>(f32(g.x) * p.lens.x, f32(g.y) * p.lens.y, h);
}

// Screen position (tangent units) of a world point; eye is in the same local frame.
fn screen(w: vec3<f32>) -> vec2<f32> {
    let q = w - p.eye.xyz;
    let vz = dot(q, p.forward.xyz);
    return vec2<f32>(dot(q, p.right.xyz), dot(q, p.up.xyz)) / vz;
}

fn column_x(i: u32) -> f32 {
    return (2.0 * (f32(i) + 0.5) / f32(p.image.x) - 1.0) * p.lens.w * p.lens.z;
}

fn pixel_y(j: u32) -> f32 {
    return (1.0 - 2.0 * (f32(j) + 0.5) / f32(p.image.y)) * p.lens.z;
}

@compute @workgroup_size(8, 8)
fn silhouette_map(@builtin(global_invocation_id) id: vec3<u32>) {
    let x = id.x;
    let v = id.y;
    if x >= p.image.x || v >= p.tree.x {
        return;
    }
    let k = v * p.image.x + x;
    let nu = p.map1.w;
    if i32(v) >= p.map1.z {
        sil[k] = vec2<f32>(-BIG, 0.0);
        return;
    }
    let X = column_x(x);
    let a = screen(world(0, i32(v)));
    let b = screen(world(nu - 1, i32(v)));
    if X < min(a.x, b.x) || X > max(a.x, b.x) {
        sil[k] = vec2<f32>(-BIG, 0.0);
        return;
    }
    let inc = b.x > a.x;
    var lo = 0;
    var hi = nu - 1;
    // Intersect: at most log2(NU) + 1 halvings.
    for (var s = 0; s < 32 && hi - lo > 1; s++) {
        let mid = (lo + hi) / 2;
        if (screen(world(mid, i32(v))).x <= X) == inc {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    // InterpolateU.
    let s0 = screen(world(lo, i32(v)));
    let s1 = screen(world(hi, i32(v)));
    var r = 0.0;
    if s1.x != s0.x {
        r = clamp((X - s0.x) / (s1.x - s0.x), 0.0, 1.0);
    }
    sil[k] = vec2<f32>(mix(s0.y, s1.y, r), f32(lo) + r * f32(hi - lo));
}

@compute @workgroup_size(8, 8)
fn silhouette_tree(@builtin(global_invocation_id) id: vec3<u32>) {
    let x = id.x;
    let n = id.y;
    let level = p.tree.z;
    let nodes = p.tree.x >> (2u * (level + 1u));
    if x >= p.image.x || n >= nodes {
        return;
    }
    var s: array<f32, 4>;
    for (var c = 0u; c < 4u; c++) {
        let child = 4u * n + c;
        if level == 0u {
            s[c] = sil[child * p.image.x + x].x;
        } else {
            let off = p.offsets[(level - 1u) / 4u][(level - 1u) % 4u];
            s[c] = tree[off + child * p.image.x + x].w;
        }
    }
    let off = p.offsets[level / 4u][level % 4u];
    tree[off + n * p.image.x + x] = vec4<f32>(max(s[0], s[1]), s[0], s[2], max(max(s[0], s[1]), max(s[2], s[3])));
}

fn ramp(z: f32) -> vec3<f32> {
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
fn silhouette_trace(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    let j = id.y;
    if i >= p.image.x || j >= p.image.y {
        return;
    }
    let k = j * p.image.x + i;
    let y = pixel_y(j);
    let top = p.tree.y - 1u;
    let root = tree[p.offsets[top / 4u][top % 4u] + i];
    if y > root.w {
        out_depth[k] = INF_BITS;
        out_color[k] = pack4x8unorm(vec4<f32>(0.55, 0.7, 0.9, 1.0));
        return;
    }
    // Trace: two levels per texel read, from the root down.
    var n = 0u;
    for (var l = 0u; l < p.tree.y; l++) {
        let lev = top - l;
        let t = tree[p.offsets[lev / 4u][lev % 4u] + n * p.image.x + i];
        var c: u32;
        if y <= t.x {
            c = select(1u, 0u, y <= t.y);
        } else {
            c = select(3u, 2u, y <= t.z);
        }
        n = 4u * n + c;
    }
    // InterpolateV between the row before and the first row reaching y.
    let v = n;
    let s1 = sil[v * p.image.x + i];
    var vh = f32(v);
    var uh = s1.y;
    if v > 0u {
        let s0 = sil[(v - 1u) * p.image.x + i];
        if s0.x > -BIG && s1.x != s0.x {
            let r = clamp((y - s0.x) / (s1.x - s0.x), 0.0, 1.0);
            vh = f32(v - 1u) + r;
            uh = mix(s0.y, s1.y, r);
        }
    }
    // Depth: where the pixel's ray crosses the (fractional) row's vertical plane.
    let px = column_x(i);
    let dir = normalize(p.forward.xyz + px * p.right.xyz + y * p.up.xyz);
    let g0 = vec2<f32>(p.map0.xy);
    let vs = vec2<f32>(p.map1.xy);
    let us = vec2<f32>(p.map0.zw);
    let gp = g0 + vh * vs + uh * us;
    var t: f32;
    if vs.x != 0.0 {
        t = (gp.x * p.lens.x - p.eye.x) / dir.x;
    } else {
        t = (gp.y * p.lens.y - p.eye.y) / dir.y;
    }
    let z = p.eye.z + t * dir.z;
    out_depth[k] = bitcast<u32>(max(t, 0.0));
    out_color[k] = pack4x8unorm(vec4<f32>(ramp(z), 1.0));
}
