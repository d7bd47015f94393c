// Mesh pass: draws a triangle list (SOAR refinement output, relief_core::refine, seed 004
// chapter 4.5, or any ordinary mesh) with reversed-Z depth into a Depth32Float buffer (seed 004,
// section 4.6.3: an infinite far plane at depth 0 and the near plane at 1, so that far mountains
// do not z-fight), as a triangle list or strip, optionally geomorphed. Positions are world
// coordinates; the eye is subtracted in the shader so the view matrix holds no large translation.

struct MeshParams {
    // Rotation + reversed-Z infinite projection, eye-relative.
    view_proj: mat4x4<f32>,
    // World eye position.
    eye: vec4<f32>,
    // Flat colour (rgb); w > 0.5 uses it instead of the height ramp.
    color: vec4<f32>,
    // World zmin, zmax for the height ramp; lighting on (> 0.5); ambient.
    range: vec4<f32>,
    // Unit direction towards the sun (world).
    sun: vec4<f32>,
}

@group(0) @binding(0) var<uniform> p: MeshParams;

struct VsOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) world: vec3<f32>,
}

fn project(position: vec3<f32>) -> VsOut {
    var out: VsOut;
    let rel = position - p.eye.xyz;
    out.pos = p.view_proj * vec4<f32>(rel, 1.0);
    out.world = rel;
    return out;
}

@vertex
fn vs_mesh(@location(0) position: vec3<f32>) -> VsOut {
    return project(position);
}

// Geomorphing (seed 004, section 4.5: SOAR's vertex morphing; relief_core::refine::MorphVertex):
// the drawn height moves from the parent edge midpoint `base_z` to the sample's height as the
// morph factor goes from 0 to 1, so vertices do not pop in when refinement adds them.
@vertex
fn vs_morph(
    @location(0) position: vec3<f32>,
    @location(1) base_z: f32,
    @location(2) morph: f32,
) -> VsOut {
    let z = base_z + morph * (position.z - base_z);
    return project(vec3<f32>(position.xy, z));
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

@fragment
fn fs_mesh(in: VsOut) -> @location(0) vec4<f32> {
    var c = ramp(in.world.z + p.eye.z);
    if p.color.w > 0.5 {
        c = p.color.xyz;
    }
    if p.range.z > 0.5 {
        var n = normalize(cross(dpdx(in.world), dpdy(in.world)));
        if n.z < 0.0 {
            n = -n;
        }
        c *= p.range.w + (1.0 - p.range.w) * max(dot(n, p.sun.xyz), 0.0);
    }
    return vec4<f32>(c, 1.0);
}
