// Corner pass: out[r] = Σ over corner r's weight row, in stored order from zero, of
// y[patch] · weight, per channel (Mesh::corner_indirect's order). One invocation per corner;
// the dispatch is a grid of `row` invocations per workgroup row when one dimension of
// workgroups is not enough.

struct Corners {
    // Corners (3 per triangle).
    count: u32,
    // Invocations per row of the dispatch grid (64 × workgroups along x).
    row: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> cfg: Corners;
// count + 1 row starts into `weights`.
@group(0) @binding(1) var<storage, read> rows: array<u32>;
// (patch, bits of the f32 weight) per entry: Mesh::corner_weights as stored.
@group(0) @binding(2) var<storage, read> weights: array<vec2<u32>>;
// Per-patch irradiance, RGB f32.
@group(0) @binding(3) var<storage, read> y: array<f32>;
// Per-corner irradiance, RGB f32, triangle-major.
@group(0) @binding(4) var<storage, read_write> out: array<f32>;

@compute @workgroup_size(64)
fn corners(@builtin(global_invocation_id) gid: vec3<u32>) {
    let r = gid.y * cfg.row + gid.x;
    if r >= cfg.count {
        return;
    }
    var acc = vec3<f32>(0.0);
    for (var k = rows[r]; k < rows[r + 1u]; k++) {
        let e = weights[k];
        let p = 3u * e.x;
        acc += vec3<f32>(y[p], y[p + 1u], y[p + 2u]) * bitcast<f32>(e.y);
    }
    out[3u * r] = acc.x;
    out[3u * r + 1u] = acc.y;
    out[3u * r + 2u] = acc.z;
}
