// Ray casting compute pass: one invocation per pixel (8 x 8 workgroups), camera of
// CONVENTIONS.md (relief_core::Camera), writing depth (distance t along the unit ray, +inf for a
// miss), the world normal and the colour.
//
// Methods (override METHOD), both ported from relief_core::ray in f32 and heightfield-local
// coordinates (x / dx, y / dy, z - z_offset), with the same clipping to the domain prism and the
// height range:
// - 0: maximum-mipmap traversal (Tevs, Ihrke, Seidel 2008, section 4; seed 002, section 5 traces
//   every cascade this way) with the exact test of the `triangles` surface at the leaves;
// - 1: linear + binary search march (Kentie 2009, seed 003, sections 3.3-3.4) over the
//   `triangles` surface.
// Effects are override constants (seed 003, section 4 / table 1 costs each feature separately):
// an effect that is off is a constant `false` and its code is removed when the pipeline is
// specialised, so it costs nothing.

struct RayParams {
    // Eye in local coordinates (x / dx, y / dy, z - z_offset).
    eye: vec4<f32>,
    forward: vec4<f32>,
    right: vec4<f32>,
    up: vec4<f32>,
    // dx, dy, tan(fov / 2), aspect (w / h).
    spacing: vec4<f32>,
    // Local height range widened by the tracer's margin: zlo, zhi; then zmin, zmax for colours.
    range: vec4<f32>,
    // Unit direction towards the sun (world), ambient term in w.
    sun: vec4<f32>,
    // Fog colour (rgb) and density per world unit (w).
    fog: vec4<f32>,
    // Water colour (rgb) and the local water level (w).
    water: vec4<f32>,
    // Detail gain (x), detail_w (y), detail_h (z) as floats.
    detail: vec4<f32>,
    // Image width, height; sample grid width, height.
    image: vec4<u32>,
    // Max-mip levels, traversal step bound, march samples, march refinement steps.
    mip: vec4<u32>,
    // Offsets of the max-mip levels (level k at offsets[k / 4][k % 4]).
    offsets: array<vec4<u32>, 9>,
}

override METHOD: u32 = 0u;
override LIGHTING: bool = false;
override SHADOWS: bool = false;
override DETAIL: bool = false;
override FOG: bool = false;
override WATER: bool = false;
// With WATER: the water surface is a heightfield (`water_surface`, e.g. the RBF approximation of
// a flood simulation's water levels, seed 002) instead of the plane at `water.w`.
override WATER_SURFACE: bool = false;
// Each pixel's world normal to `out_normal` (a placeholder buffer without it).
override NORMALS: bool = false;
const WATER_STEPS: u32 = 128u;
const WATER_REFINE: u32 = 8u;

const BIG: f32 = 1e30;
const INF_BITS: u32 = 0x7f800000u;

@group(0) @binding(0) var<uniform> p: RayParams;
@group(0) @binding(1) var<storage, read> heights: array<f32>;
@group(0) @binding(2) var<storage, read> mip: array<f32>;
// Gradients (dz/dx, dz/dy) per sample (normals.wgsl).
@group(0) @binding(3) var<storage, read> normal_map: array<vec2<f32>>;
@group(0) @binding(4) var<storage, read> detail: array<f32>;
@group(0) @binding(5) var<storage, read_write> out_depth: array<u32>;
@group(0) @binding(6) var<storage, read_write> out_normal: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> out_color: array<u32>;
// Water surface heights (local), one per sample, used with WATER_SURFACE.
@group(0) @binding(8) var<storage, read> water_surface: array<f32>;

struct LRay {
    o: vec3<f32>,
    d: vec3<f32>,
    t0: f32,
    t1: f32,
    ok: bool,
}

struct THit {
    t: f32,
    // Unnormalised normal in grid units (local heights).
    n: vec3<f32>,
    hit: bool,
}

fn h(x: u32, y: u32) -> f32 {
    return heights[y * p.image.z + x];
}

fn cells() -> vec2<f32> {
    return vec2<f32>(f32(max(p.image.z - 1u, 1u)), f32(max(p.image.w - 1u, 1u)));
}

// The ray clipped to the domain prism and the height range (RayTracer::local). Slabs here
// divide by the direction component rather than multiply by its reciprocal: a subnormal
// component (not flushed) then gives +-inf or 0 parameters, never the `0 * inf = NaN` that the
// CPU's reciprocals had to fold away (HARD_CASES.md, subnormal direction components); where the
// GPU flushes subnormals, `dc == 0.0` holds and the zero branch takes the ray.
fn clip(o: vec3<f32>, d: vec3<f32>) -> LRay {
    var r: LRay;
    r.o = o;
    r.d = d;
    r.ok = false;
    var t0 = 0.0;
    var t1 = BIG;
    let ext = cells();
    for (var i = 0; i < 2; i++) {
        let oc = o[i];
        let dc = d[i];
        if dc == 0.0 {
            if !(oc >= 0.0 && oc <= ext[i]) {
                return r;
            }
        } else {
            let a = (0.0 - oc) / dc;
            let b = (ext[i] - oc) / dc;
            t0 = max(t0, min(a, b));
            t1 = min(t1, max(a, b));
        }
    }
    if !(t0 <= t1) {
        return r;
    }
    let zlo = p.range.x;
    let zhi = p.range.y;
    if d.z == 0.0 {
        if o.z > zhi {
            return r;
        }
    } else if d.z < 0.0 {
        t0 = max(t0, (zhi - o.z) / d.z);
        if t0 > t1 {
            return r;
        }
        t1 = min(t1, max(t0, (zlo - o.z) / d.z));
    } else {
        t1 = min(t1, (zhi - o.z) / d.z);
        if t0 > t1 {
            return r;
        }
    }
    if !(t0 <= t1) || t1 >= BIG {
        return r;
    }
    r.t0 = t0;
    r.t1 = t1;
    r.ok = true;
    return r;
}

fn tri_height(c: vec4<f32>, fx: f32, fy: f32, upper: bool) -> f32 {
    // c = (h00, h10, h01, h11)
    if upper {
        return c.x + fx * (c.w - c.z) + fy * (c.z - c.x);
    }
    return c.x + fx * (c.y - c.x) + fy * (c.w - c.y);
}

fn tri_normal(c: vec4<f32>, upper: bool) -> vec3<f32> {
    if upper {
        return vec3<f32>(-(c.w - c.z), -(c.z - c.x), 1.0);
    }
    return vec3<f32>(-(c.y - c.x), -(c.w - c.y), 1.0);
}

// Exact test of the `triangles` surface of cell (cx, cy) over [ta, tb] (cell.rs, triangles_hit).
fn cell_hit(r: LRay, cx: u32, cy: u32, ta: f32, tb: f32) -> THit {
    var out: THit;
    out.hit = false;
    let c = vec4<f32>(h(cx, cy), h(cx + 1u, cy), h(cx, cy + 1u), h(cx + 1u, cy + 1u));
    let px = r.o.x - f32(cx);
    let py = r.o.y - f32(cy);
    let g0 = px - py;
    let gd = r.d.x - r.d.y;
    var cuts = array<f32, 3>(ta, tb, tb);
    var n = 2;
    if gd != 0.0 {
        let td = -g0 / gd;
        if td > ta && td < tb {
            cuts = array<f32, 3>(ta, td, tb);
            n = 3;
        }
    }
    for (var k = 0; k + 1 < n; k++) {
        let a = cuts[k];
        let b = cuts[k + 1];
        let mid = 0.5 * (a + b);
        let upper = (py + mid * r.d.y) > (px + mid * r.d.x);
        let fa = r.o.z + a * r.d.z - tri_height(c, clamp(px + a * r.d.x, 0.0, 1.0), clamp(py + a * r.d.y, 0.0, 1.0), upper);
        if fa <= 0.0 {
            out.t = a;
            out.n = tri_normal(c, upper);
            out.hit = true;
            return out;
        }
        let fb = r.o.z + b * r.d.z - tri_height(c, clamp(px + b * r.d.x, 0.0, 1.0), clamp(py + b * r.d.y, 0.0, 1.0), upper);
        if fb <= 0.0 {
            out.t = clamp(a + (b - a) * (fa / (fa - fb)), a, b);
            out.n = tri_normal(c, upper);
            out.hit = true;
            return out;
        }
    }
    return out;
}

fn level_offset(k: u32) -> u32 {
    return p.offsets[k / 4u][k % 4u];
}

fn dim(n: u32, k: u32) -> u32 {
    return ((n - 1u) >> k) + 1u;
}

fn slab(o: f32, d: f32, lo: f32, hi: f32) -> vec2<f32> {
    if d == 0.0 {
        return vec2<f32>(-BIG, BIG);
    }
    let a = (lo - o) / d;
    let b = (hi - o) / d;
    return vec2<f32>(min(a, b), max(a, b));
}

// Maximum-mipmap traversal (maxmip.rs, trace_maxmip).
fn trace_maxmip(r: LRay) -> THit {
    var miss: THit;
    miss.hit = false;
    let nx = max(p.image.z - 1u, 1u);
    let ny = max(p.image.w - 1u, 1u);
    let top = p.mip.x - 1u;
    var lvl = top;
    var ix = 0i;
    var iy = 0i;
    var t = r.t0;
    let sx = r.d.x >= 0.0;
    let sy = r.d.y >= 0.0;
    for (var steps = 0u; steps < p.mip.y; steps++) {
        let s = 1i << lvl;
        let x0 = f32(ix * s);
        let x1 = f32(min((ix + 1i) * s, i32(nx)));
        let y0 = f32(iy * s);
        let y1 = f32(min((iy + 1i) * s, i32(ny)));
        let sxr = slab(r.o.x, r.d.x, x0, x1);
        let syr = slab(r.o.y, r.d.y, y0, y1);
        let ta = max(t, max(sxr.x, syr.x));
        let tb = min(r.t1, min(sxr.y, syr.y));
        var descend = false;
        if ta <= tb {
            let w = dim(nx, lvl);
            let m = mip[level_offset(lvl) + u32(iy) * w + u32(ix)];
            if min(r.o.z + ta * r.d.z, r.o.z + tb * r.d.z) <= m {
                if lvl == 0u {
                    let c = cell_hit(r, u32(ix), u32(iy), ta, tb);
                    if c.hit {
                        return c;
                    }
                } else {
                    descend = true;
                }
            }
        }
        if descend {
            lvl -= 1u;
            t = ta;
            let cs = f32(1u << lvl);
            let px = r.o.x + ta * r.d.x;
            let py = r.o.y + ta * r.d.y;
            let w = i32(dim(nx, lvl));
            let hh = i32(dim(ny, lvl));
            ix = min(clamp(i32(floor(px / cs)), 2i * ix, 2i * ix + 1i), w - 1i);
            iy = min(clamp(i32(floor(py / cs)), 2i * iy, 2i * iy + 1i), hh - 1i);
            continue;
        }
        let exit = min(sxr.y, syr.y);
        if exit > t {
            t = exit;
        }
        if t > r.t1 || lvl == top {
            return miss;
        }
        let ox = ix;
        let oy = iy;
        if sxr.y <= syr.y {
            ix += select(-1i, 1i, sx);
        }
        if syr.y <= sxr.y {
            iy += select(-1i, 1i, sy);
        }
        let w = i32(dim(nx, lvl));
        let hh = i32(dim(ny, lvl));
        if ix < 0i || iy < 0i || ix >= w || iy >= hh {
            return miss;
        }
        if (ix >> 1u) != (ox >> 1u) || (iy >> 1u) != (oy >> 1u) {
            lvl += 1u;
            ix = ix >> 1u;
            iy = iy >> 1u;
        }
    }
    return miss;
}

// Height of the `triangles` surface at grid position (gx, gy) (Terrain::surface_height_grid).
fn surface_at(gx: f32, gy: f32) -> f32 {
    let cx = min(u32(floor(gx)), p.image.z - 2u);
    let cy = min(u32(floor(gy)), p.image.w - 2u);
    let fx = gx - f32(cx);
    let fy = gy - f32(cy);
    let h00 = h(cx, cy);
    let h10 = h(cx + 1u, cy);
    let h01 = h(cx, cy + 1u);
    let h11 = h(cx + 1u, cy + 1u);
    if fx >= fy {
        return (1.0 - fx) * h00 + (fx - fy) * h10 + fy * h11;
    }
    return (1.0 - fy) * h00 + (fy - fx) * h01 + fx * h11;
}

fn below(r: LRay, t: f32) -> bool {
    let ext = cells();
    let gx = clamp(r.o.x + t * r.d.x, 0.0, ext.x);
    let gy = clamp(r.o.y + t * r.d.y, 0.0, ext.y);
    return r.o.z + t * r.d.z <= surface_at(gx, gy);
}

// Linear + binary search march (march.rs, trace_march, fixed sample count).
fn trace_march(r: LRay) -> THit {
    var out: THit;
    out.hit = false;
    let n = p.mip.z;
    let step = (r.t1 - r.t0) / f32(n);
    var prev = r.t0;
    var lo = 0.0;
    var hi = 0.0;
    for (var i = 0u; i <= n; i++) {
        var t = r.t0 + step * f32(i);
        if i == n {
            t = r.t1;
        }
        if below(r, t) {
            lo = prev;
            hi = t;
            out.hit = true;
            break;
        }
        prev = t;
    }
    if !out.hit {
        return out;
    }
    if hi > lo {
        for (var k = 0u; k < p.mip.w; k++) {
            let mid = 0.5 * (lo + hi);
            if below(r, mid) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
    }
    let ext = cells();
    let gx = clamp(r.o.x + hi * r.d.x, 0.0, ext.x);
    let gy = clamp(r.o.y + hi * r.d.y, 0.0, ext.y);
    let cx = min(u32(floor(gx)), p.image.z - 2u);
    let cy = min(u32(floor(gy)), p.image.w - 2u);
    let h00 = h(cx, cy);
    let h10 = h(cx + 1u, cy);
    let h01 = h(cx, cy + 1u);
    let h11 = h(cx + 1u, cy + 1u);
    let fx = gx - f32(cx);
    let fy = gy - f32(cy);
    let k = h00 - h10 - h01 + h11;
    out.n = vec3<f32>(-(h10 - h00 + k * fy), -(h01 - h00 + k * fx), 1.0);
    out.t = hi;
    return out;
}

fn trace(o: vec3<f32>, d: vec3<f32>) -> THit {
    let r = clip(o, d);
    if !r.ok {
        var miss: THit;
        miss.hit = false;
        return miss;
    }
    if METHOD == 1u {
        return trace_march(r);
    }
    return trace_maxmip(r);
}

fn sample_normal_map(gx: f32, gy: f32) -> vec3<f32> {
    let w = p.image.z;
    let x0 = min(u32(floor(gx)), w - 1u);
    let y0 = min(u32(floor(gy)), p.image.w - 1u);
    let x1 = min(x0 + 1u, w - 1u);
    let y1 = min(y0 + 1u, p.image.w - 1u);
    let fx = clamp(gx - f32(x0), 0.0, 1.0);
    let fy = clamp(gy - f32(y0), 0.0, 1.0);
    let a = mix(gradient_normal(y0 * w + x0), gradient_normal(y0 * w + x1), fx);
    let b = mix(gradient_normal(y1 * w + x0), gradient_normal(y1 * w + x1), fx);
    return normalize(mix(a, b, fy));
}

// The unit normal of sample i from its stored gradient: normalize(-dz/dx, -dz/dy, 1), scaled by
// the largest component first so the squares cannot overflow (relief_wgpu::NormalPass::read
// does the same on the CPU).
fn gradient_normal(i: u32) -> vec3<f32> {
    let g = normal_map[i];
    let m = max(max(abs(g.x), abs(g.y)), 1.0);
    return normalize(vec3<f32>(-g.x / m, -g.y / m, 1.0 / m));
}

fn albedo(z: f32) -> vec3<f32> {
    let s = clamp((z - p.range.z) / max(p.range.w - p.range.z, 1e-6), 0.0, 1.0);
    let low = vec3<f32>(0.25, 0.45, 0.2);
    let mid = vec3<f32>(0.55, 0.45, 0.3);
    let high = vec3<f32>(0.95, 0.95, 0.95);
    if s < 0.6 {
        return mix(low, mid, s / 0.6);
    }
    return mix(mid, high, (s - 0.6) / 0.4);
}

// Bilinear water surface height at grid position (gx, gy), clamped to the grid.
fn water_at(gx: f32, gy: f32) -> f32 {
    let ext = cells();
    let x = clamp(gx, 0.0, ext.x);
    let y = clamp(gy, 0.0, ext.y);
    let x0 = min(u32(floor(x)), p.image.z - 2u);
    let y0 = min(u32(floor(y)), p.image.w - 2u);
    let fx = x - f32(x0);
    let fy = y - f32(y0);
    let w = p.image.z;
    let a = mix(water_surface[y0 * w + x0], water_surface[y0 * w + x0 + 1u], fx);
    let b = mix(water_surface[(y0 + 1u) * w + x0], water_surface[(y0 + 1u) * w + x0 + 1u], fx);
    return mix(a, b, fy);
}

// First point at or below the water surface along the ray inside the domain before `t_end`:
// WATER_STEPS linear samples, then WATER_REFINE bisections (the march of seed 003); BIG if none.
fn trace_water(o: vec3<f32>, d: vec3<f32>, t_end: f32) -> f32 {
    var t0 = 0.0;
    var t1 = t_end;
    let ext = cells();
    for (var i = 0; i < 2; i++) {
        if d[i] == 0.0 {
            if !(o[i] >= 0.0 && o[i] <= ext[i]) {
                return BIG;
            }
        } else {
            let a = (0.0 - o[i]) / d[i];
            let b = (ext[i] - o[i]) / d[i];
            t0 = max(t0, min(a, b));
            t1 = min(t1, max(a, b));
        }
    }
    if !(t0 <= t1) || t1 >= BIG {
        return BIG;
    }
    let step = (t1 - t0) / f32(WATER_STEPS);
    var prev = t0;
    var lo = 0.0;
    var hi = 0.0;
    var found = false;
    for (var i = 0u; i <= WATER_STEPS; i++) {
        var t = t0 + step * f32(i);
        if i == WATER_STEPS {
            t = t1;
        }
        let q = o + t * d;
        if q.z <= water_at(q.x, q.y) {
            lo = prev;
            hi = t;
            found = true;
            break;
        }
        prev = t;
    }
    if !found {
        return BIG;
    }
    for (var k = 0u; k < WATER_REFINE && hi > lo; k++) {
        let mid = 0.5 * (lo + hi);
        let q = o + mid * d;
        if q.z <= water_at(q.x, q.y) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    return hi;
}

const SKY: vec3<f32> = vec3<f32>(0.55, 0.7, 0.9);

@compute @workgroup_size(8, 8)
fn raycast(@builtin(global_invocation_id) id: vec3<u32>) {
    let w = p.image.x;
    let hgt = p.image.y;
    if id.x >= w || id.y >= hgt {
        return;
    }
    let i = id.y * w + id.x;
    // Camera::ray in f32: dir = normalize(f + px r + py u).
    let px = (2.0 * (f32(id.x) + 0.5) / f32(w) - 1.0) * p.spacing.w * p.spacing.z;
    let py = (1.0 - 2.0 * (f32(id.y) + 0.5) / f32(hgt)) * p.spacing.z;
    let dir = normalize(p.forward.xyz + px * p.right.xyz + py * p.up.xyz);
    let o = p.eye.xyz;
    let d = vec3<f32>(dir.x / p.spacing.x, dir.y / p.spacing.y, dir.z);
    let hit = trace(o, d);

    var color = SKY;
    var depth = BIG;
    var normal = vec4<f32>(0.0, 0.0, 0.0, 0.0);
    if hit.hit {
        depth = hit.t;
        let hp = o + hit.t * d;
        let n = normalize(vec3<f32>(hit.n.x / p.spacing.x, hit.n.y / p.spacing.y, hit.n.z));
        normal = vec4<f32>(n, 1.0);
        color = albedo(hp.z);
        if DETAIL {
            let dw = u32(p.detail.y);
            let dh = u32(p.detail.z);
            let dx = u32(floor(hp.x)) % dw;
            let dy = u32(floor(hp.y)) % dh;
            color *= 1.0 + clamp(detail[dy * dw + dx] * p.detail.x, -0.3, 0.3);
        }
        var lit = 1.0;
        if SHADOWS {
            let ls = vec3<f32>(p.sun.x / p.spacing.x, p.sun.y / p.spacing.y, p.sun.z);
            let lift = 1e-3 * max(p.range.w - p.range.z, 1.0);
            let sh = trace(hp + vec3<f32>(0.0, 0.0, lift), ls);
            if sh.hit {
                lit = 0.0;
            }
        }
        if LIGHTING {
            let sn = sample_normal_map(hp.x, hp.y);
            let diffuse = max(dot(sn, p.sun.xyz), 0.0) * lit;
            color *= p.sun.w + (1.0 - p.sun.w) * diffuse;
        } else if SHADOWS {
            color *= mix(0.55, 1.0, lit);
        }
    }
    if WATER && WATER_SURFACE {
        let tw = trace_water(o, d, min(depth, BIG * 0.5));
        if tw < depth {
            let below_water = select(0.0, min((depth - tw) * 0.002, 1.0), depth < BIG);
            color = mix(mix(color, p.water.xyz, 0.5), p.water.xyz * 0.6, below_water);
            depth = tw;
            normal = vec4<f32>(0.0, 0.0, 1.0, 1.0);
        }
    } else if WATER && d.z < 0.0 && o.z > p.water.w {
        let tw = (p.water.w - o.z) / d.z;
        let wp = o + tw * d;
        let ext = cells();
        if tw < depth && wp.x >= 0.0 && wp.y >= 0.0 && wp.x <= ext.x && wp.y <= ext.y {
            let below_water = select(0.0, min((depth - tw) * 0.002, 1.0), depth < BIG);
            color = mix(mix(color, p.water.xyz, 0.5), p.water.xyz * 0.6, below_water);
            depth = tw;
            normal = vec4<f32>(0.0, 0.0, 1.0, 1.0);
        }
    }
    if FOG && depth < BIG {
        color = mix(color, p.fog.xyz, 1.0 - exp(-p.fog.w * depth));
    }
    out_depth[i] = select(bitcast<u32>(depth), INF_BITS, depth >= BIG);
    if NORMALS {
        out_normal[i] = normal;
    }
    out_color[i] = pack4x8unorm(vec4<f32>(clamp(color, vec3<f32>(0.0), vec3<f32>(1.0)), 1.0));
}
