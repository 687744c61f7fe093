// The gpu_engine example's drawing: a shadow pass (distance from the point light into one
// face of a cube map) and the main pass (radiance of the full-detail mesh).
//
// Vertex buffer 0, one vertex per triangle corner (48 bytes): position, the triangle's unit
// normal, reflectance, emission. Vertex buffer 1: the corner pass's indirect irradiance
// (12 bytes, RGB f32).

struct Scene {
    // Camera (main pass) or cube face (shadow pass) view-projection.
    view_proj: mat4x4<f32>,
    // Point light position (w unused) and intensity in W/sr (w unused).
    light: vec4<f32>,
    intensity: vec4<f32>,
    // x: shadow bias as a share of the distance to the light.
    shadow: vec4<f32>,
}

@group(0) @binding(0) var<uniform> scene: Scene;

struct Corner {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) reflectance: vec3<f32>,
    @location(3) emission: vec3<f32>,
}

struct ShadowOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
}

@vertex
fn shadow_vs(c: Corner) -> ShadowOut {
    var o: ShadowOut;
    o.clip = scene.view_proj * vec4<f32>(c.position, 1.0);
    o.world = c.position;
    return o;
}

@fragment
fn shadow_fs(i: ShadowOut) -> @location(0) vec4<f32> {
    return vec4<f32>(length(i.world - scene.light.xyz), 0.0, 0.0, 0.0);
}

@group(0) @binding(1) var shadow_map: texture_cube<f32>;
@group(0) @binding(2) var shadow_sampler: sampler;

struct MainOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) @interpolate(flat) normal: vec3<f32>,
    @location(2) @interpolate(flat) reflectance: vec3<f32>,
    @location(3) @interpolate(flat) emission: vec3<f32>,
    @location(4) indirect: vec3<f32>,
}

@vertex
fn main_vs(c: Corner, @location(4) indirect: vec3<f32>) -> MainOut {
    var o: MainOut;
    o.clip = scene.view_proj * vec4<f32>(c.position, 1.0);
    o.world = c.position;
    o.normal = c.normal;
    o.reflectance = c.reflectance;
    o.emission = c.emission;
    o.indirect = indirect;
    return o;
}

// Radiance (E + ρ∘(H_direct + H_indirect))/π: the point light's inverse-square cosine law
// (radiosity_core::Light::Point), shadowed by the cube map, plus the baked indirect light
// interpolated from the corners. The back of a one-sided surface sends nothing.
@fragment
fn main_fs(i: MainOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    if !front {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    let d = scene.light.xyz - i.world;
    let r2 = dot(d, d);
    var direct = vec3<f32>(0.0);
    if r2 > 0.0 {
        let r = sqrt(r2);
        let cos = dot(i.normal, d / r);
        // No derivatives (the branches above are not uniform): the base level, nearest texel.
        let stored = textureSampleLevel(shadow_map, shadow_sampler, -d, 0.0).x;
        if cos > 0.0 && r <= stored + scene.shadow.x * r {
            direct = scene.intensity.xyz * (cos / r2);
        }
    }
    let b = i.emission + i.reflectance * (direct + i.indirect);
    return vec4<f32>(b * 0.31830988618379067, 1.0);
}
