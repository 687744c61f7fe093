// Probe pass for factored probes (radiosity_core::ProbeFactors, P ≈ C·V), two dispatches:
// `modes` takes t = V·(B − E) (one workgroup per mode: its 64 invocations sum every 64th
// patch, then a tree reduction), `probes` each probe's C_p·t (one invocation per probe and SH
// coefficient, the k products in order). B − E = x − E + ρ∘y, as in probes.wgsl.

struct FactorCfg {
    // Probes.
    count: u32,
    // Workgroups per row of the `probes` dispatch grid (64 coefficients each).
    row: u32,
    // Rank k.
    rank: u32,
    // Patches n.
    patches: u32,
    // Workgroups per row of the `modes` dispatch grid.
    mode_row: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> cfg: FactorCfg;
// V: k rows of n binary16 weights, row-major, two a word (the first in the low half).
@group(0) @binding(1) var<storage, read> basis: array<u32>;
// C: per probe and SH coefficient, k binary16 weights, packed as `basis`.
@group(0) @binding(2) var<storage, read> coefficients: array<u32>;
// First exitance x, RGB f32 per patch.
@group(0) @binding(3) var<storage, read> x: array<f32>;
// Gathered irradiance y = M·x, RGB f32 per patch.
@group(0) @binding(4) var<storage, read> y: array<f32>;
// Per patch: emission E (RGB), then reflectance ρ (RGB).
@group(0) @binding(5) var<storage, read> table: array<f32>;
// Per probe: nine RGB f32 SH coefficients of reflected radiance (27 floats).
@group(0) @binding(6) var<storage, read_write> out: array<f32>;
// The frame's modes t, RGB f32 each (written by `modes`, read by `probes`).
@group(0) @binding(7) var<storage, read_write> modes_out: array<f32>;

var<workgroup> part: array<vec3<f32>, 64>;

fn basis_at(i: u32) -> f32 {
    let h = unpack2x16float(basis[i >> 1u]);
    return select(h.x, h.y, (i & 1u) == 1u);
}

fn coefficient_at(i: u32) -> f32 {
    let h = unpack2x16float(coefficients[i >> 1u]);
    return select(h.x, h.y, (i & 1u) == 1u);
}

@compute @workgroup_size(64)
fn modes(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(local_invocation_index) li: u32,
) {
    let q = wg.y * cfg.mode_row + wg.x;
    if q >= cfg.rank {
        return;
    }
    var acc = vec3<f32>(0.0);
    let base = q * cfg.patches;
    for (var j = li; j < cfg.patches; j += 64u) {
        let e = 6u * j;
        let r = vec3<f32>(x[3u * j], x[3u * j + 1u], x[3u * j + 2u])
            - vec3<f32>(table[e], table[e + 1u], table[e + 2u])
            + vec3<f32>(table[e + 3u], table[e + 4u], table[e + 5u])
            * vec3<f32>(y[3u * j], y[3u * j + 1u], y[3u * j + 2u]);
        acc += r * basis_at(base + j);
    }
    part[li] = acc;
    workgroupBarrier();
    for (var s = 32u; s > 0u; s >>= 1u) {
        if li < s {
            part[li] += part[li + s];
        }
        workgroupBarrier();
    }
    if li == 0u {
        let v = part[0];
        modes_out[3u * q] = v.x;
        modes_out[3u * q + 1u] = v.y;
        modes_out[3u * q + 2u] = v.z;
    }
}

@compute @workgroup_size(64)
fn probes(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(local_invocation_index) li: u32,
) {
    // One invocation per probe and SH coefficient: a dot product of k, no reduction.
    let i = 64u * (wg.y * cfg.row + wg.x) + li;
    if i >= 9u * cfg.count {
        return;
    }
    var acc = vec3<f32>(0.0);
    let base = i * cfg.rank;
    for (var q = 0u; q < cfg.rank; q++) {
        let t = vec3<f32>(modes_out[3u * q], modes_out[3u * q + 1u], modes_out[3u * q + 2u]);
        acc += t * coefficient_at(base + q);
    }
    out[3u * i] = acc.x;
    out[3u * i + 1u] = acc.y;
    out[3u * i + 2u] = acc.z;
}
