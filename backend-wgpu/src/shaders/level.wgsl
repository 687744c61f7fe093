// A level's light between systems (radiosity_core::systems::Systems::update, on the GPU).
// Per system s, before its gather (`couple`): for each of its patches i, the light the other
// systems send, g_i = Σ_k vals[k] · exitance[cols[k]] over row i of the coupling in stored
// order, kept in `gathered`, and the system's gather input x_i = first_i + ρ_i · g_i.
// After its gather (`update`): gathered_i = g_i + y_i, exitance_i = first_i + ρ_i · gathered_i.
// One invocation per patch of the system; RGB as three f32 a patch.

struct System {
    // The system's first patch in the level.
    start: u32,
    // Its patches.
    count: u32,
    // Invocations per row of the dispatch grid (64 × workgroups along x).
    row: u32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> sys: System;
// The coupling: n + 1 row starts, then each entry's column and value.
@group(0) @binding(1) var<storage, read> row_ptr: array<u32>;
@group(0) @binding(2) var<storage, read> cols: array<u32>;
@group(0) @binding(3) var<storage, read> vals: array<f32>;
// Per patch of the level.
@group(0) @binding(4) var<storage, read> first: array<f32>;
@group(0) @binding(5) var<storage, read> rho: array<f32>;
@group(0) @binding(6) var<storage, read_write> exitance: array<f32>;
@group(0) @binding(7) var<storage, read_write> gathered: array<f32>;
// Per patch of the system: its gather's input and output.
@group(0) @binding(8) var<storage, read_write> xs: array<f32>;
@group(0) @binding(9) var<storage, read> ys: array<f32>;

@compute @workgroup_size(64)
fn couple(@builtin(global_invocation_id) gid: vec3<u32>) {
    let r = gid.y * sys.row + gid.x;
    if r >= sys.count {
        return;
    }
    let i = sys.start + r;
    var g = vec3<f32>(0.0);
    for (var k = row_ptr[i]; k < row_ptr[i + 1u]; k++) {
        let j = 3u * cols[k];
        g += vec3<f32>(exitance[j], exitance[j + 1u], exitance[j + 2u]) * vals[k];
    }
    let f = vec3<f32>(first[3u * i], first[3u * i + 1u], first[3u * i + 2u]);
    let p = vec3<f32>(rho[3u * i], rho[3u * i + 1u], rho[3u * i + 2u]);
    let x = f + p * g;
    for (var c = 0u; c < 3u; c++) {
        gathered[3u * i + c] = g[c];
        xs[3u * r + c] = x[c];
    }
}

@compute @workgroup_size(64)
fn update(@builtin(global_invocation_id) gid: vec3<u32>) {
    let r = gid.y * sys.row + gid.x;
    if r >= sys.count {
        return;
    }
    let i = sys.start + r;
    let y = vec3<f32>(ys[3u * r], ys[3u * r + 1u], ys[3u * r + 2u]);
    let g = vec3<f32>(gathered[3u * i], gathered[3u * i + 1u], gathered[3u * i + 2u]) + y;
    let f = vec3<f32>(first[3u * i], first[3u * i + 1u], first[3u * i + 2u]);
    let p = vec3<f32>(rho[3u * i], rho[3u * i + 1u], rho[3u * i + 2u]);
    let b = f + p * g;
    for (var c = 0u; c < 3u; c++) {
        gathered[3u * i + c] = g[c];
        exitance[3u * i + c] = b[c];
    }
}
