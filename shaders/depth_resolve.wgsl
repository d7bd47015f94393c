// Depth output (Kentie 2009, seed 003, section 3.7): the ray caster's distances become a real
// depth buffer so that ray-cast terrain and ordinary rasterised meshes occlude each other. A
// full-screen triangle writes the ray-cast colour and, per pixel, the reversed-Z depth
// `near / view_z` (view_z = t * dot(dir, forward)) of an infinite far plane (seed 004, section
// 4.6.3: reversed-Z with a 32-bit float depth buffer), matching MeshPass's projection. A miss
// writes 0 (the far plane).

struct ResolveParams {
    forward: vec4<f32>,
    right: vec4<f32>,
    up: vec4<f32>,
    // tan(fov / 2), aspect, near, unused.
    lens: vec4<f32>,
    // Image width, height.
    image: vec4<u32>,
}

@group(0) @binding(0) var<uniform> p: ResolveParams;
@group(0) @binding(1) var<storage, read> depth: array<u32>;
@group(0) @binding(2) var<storage, read> color: array<u32>;

struct VsOut {
    @builtin(position) pos: vec4<f32>,
}

@vertex
fn vs_fullscreen(@builtin(vertex_index) vi: u32) -> VsOut {
    let x = f32((vi << 1u) & 2u) * 2.0 - 1.0;
    let y = f32(vi & 2u) * 2.0 - 1.0;
    var out: VsOut;
    out.pos = vec4<f32>(x, y, 0.0, 1.0);
    return out;
}

struct FsOut {
    @location(0) color: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}

@fragment
fn fs_resolve(in: VsOut) -> FsOut {
    let i = u32(in.pos.x);
    let j = u32(in.pos.y);
    let k = min(j, p.image.y - 1u) * p.image.x + min(i, p.image.x - 1u);
    let bits = depth[k];
    var out: FsOut;
    out.color = unpack4x8unorm(color[k]);
    if bits == 0x7f800000u {
        out.depth = 0.0;
        return out;
    }
    let t = bitcast<f32>(bits);
    let w = f32(p.image.x);
    let h = f32(p.image.y);
    let px = (2.0 * (f32(i) + 0.5) / w - 1.0) * p.lens.y * p.lens.x;
    let py = (1.0 - 2.0 * (f32(j) + 0.5) / h) * p.lens.x;
    let dir = normalize(p.forward.xyz + px * p.right.xyz + py * p.up.xyz);
    let view_z = t * dot(dir, p.forward.xyz);
    out.depth = clamp(p.lens.z / max(view_z, 1e-30), 0.0, 1.0);
    return out;
}
