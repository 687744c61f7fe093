// Edit pass: the correction of an edited frame's exitance, x̃ = x' + K·(M·x')_S on the edited
// patches S (radiosity_core::ReflectanceEdit::correction_matrices): one invocation per edited
// patch a, summing Σ_b K_c[a·k + b]·y[S_b] per channel in b's order and adding it to x̃ at S_a.
// Only invocation a writes patch S_a, and y and x̃ are distinct buffers.

struct EditCfg {
    // Edited patches.
    k: u32,
    // Invocations per row of the dispatch grid (64 × workgroups along x).
    row: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> cfg: EditCfg;
// The edited patches, ascending.
@group(0) @binding(1) var<storage, read> patches: array<u32>;
// K_0, K_1, K_2 one after the other, each k × k row-major.
@group(0) @binding(2) var<storage, read> kmat: array<f32>;
// The first gather's y = M·x', RGB f32 per patch.
@group(0) @binding(3) var<storage, read> y: array<f32>;
// x̃: a copy of x' the pass adds the correction to, RGB f32 per patch.
@group(0) @binding(4) var<storage, read_write> x: array<f32>;

@compute @workgroup_size(64)
fn edit(@builtin(global_invocation_id) gid: vec3<u32>) {
    let a = gid.y * cfg.row + gid.x;
    if a >= cfg.k {
        return;
    }
    let kk = cfg.k * cfg.k;
    var acc = vec3<f32>(0.0);
    for (var b = 0u; b < cfg.k; b++) {
        let p = 3u * patches[b];
        let e = a * cfg.k + b;
        acc += vec3<f32>(kmat[e], kmat[kk + e], kmat[2u * kk + e])
            * vec3<f32>(y[p], y[p + 1u], y[p + 2u]);
    }
    let q = 3u * patches[a];
    x[q] += acc.x;
    x[q + 1u] += acc.y;
    x[q + 2u] += acc.z;
}
