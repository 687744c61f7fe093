// Probe pass: out[p] = Σ over probe p's weight row of (x − E + ρ∘y)[patch] · sh, per SH
// coefficient and channel (radiosity_core::Probes::gather on the reflected radiosity
// B − E = x − E + ρ∘y). One workgroup per probe: each of its 64 invocations sums every 64th
// weight of the row, then a tree reduction in workgroup memory adds the 64 partial sums.

struct ProbeCfg {
    // Probes.
    count: u32,
    // Workgroups per row of the dispatch grid.
    row: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> cfg: ProbeCfg;
// count + 1 row starts into `weights`.
@group(0) @binding(1) var<storage, read> rows: array<u32>;
// ProbeWeight as stored (6 words): the patch, then nine binary16 SH weights two a word,
// the first in the low half, and a zero half.
@group(0) @binding(2) var<storage, read> weights: array<u32>;
// First exitance x, RGB f32 per patch.
@group(0) @binding(3) var<storage, read> x: array<f32>;
// Gathered irradiance y = M·x, RGB f32 per patch.
@group(0) @binding(4) var<storage, read> y: array<f32>;
// Per patch: emission E (RGB), then reflectance ρ (RGB).
@group(0) @binding(5) var<storage, read> table: array<f32>;
// Per probe: nine RGB f32 SH coefficients of reflected radiance (27 floats).
@group(0) @binding(6) var<storage, read_write> out: array<f32>;

var<workgroup> part: array<array<vec3<f32>, 9>, 64>;

@compute @workgroup_size(64)
fn probes(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(local_invocation_index) li: u32,
) {
    let p = wg.y * cfg.row + wg.x;
    if p >= cfg.count {
        return;
    }
    var acc: array<vec3<f32>, 9>;
    for (var c = 0u; c < 9u; c++) {
        acc[c] = vec3<f32>(0.0);
    }
    for (var k = rows[p] + li; k < rows[p + 1u]; k += 64u) {
        let base = 6u * k;
        let j = weights[base];
        let e = 6u * j;
        let r = vec3<f32>(x[3u * j], x[3u * j + 1u], x[3u * j + 2u])
            - vec3<f32>(table[e], table[e + 1u], table[e + 2u])
            + vec3<f32>(table[e + 3u], table[e + 4u], table[e + 5u])
            * vec3<f32>(y[3u * j], y[3u * j + 1u], y[3u * j + 2u]);
        for (var c = 0u; c < 4u; c++) {
            let h = unpack2x16float(weights[base + 1u + c]);
            acc[2u * c] += r * h.x;
            acc[2u * c + 1u] += r * h.y;
        }
        acc[8] += r * unpack2x16float(weights[base + 5u]).x;
    }
    part[li] = acc;
    workgroupBarrier();
    for (var s = 32u; s > 0u; s >>= 1u) {
        if li < s {
            for (var c = 0u; c < 9u; c++) {
                part[li][c] += part[li + s][c];
            }
        }
        workgroupBarrier();
    }
    if li == 0u {
        for (var c = 0u; c < 9u; c++) {
            let v = part[0][c];
            out[27u * p + 3u * c] = v.x;
            out[27u * p + 3u * c + 1u] = v.y;
            out[27u * p + 3u * c + 2u] = v.z;
        }
    }
}
