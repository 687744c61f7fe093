// Finish: y[row] = Σ over column groups of partial[group][row] + Σ over the row's sparse
// entries of value · x[col]. One invocation per row of the sparse band (its CSR slice, with
// row offsets rebased to the slice).

struct Finish {
    // First row of this band, and rows in it.
    row0: u32,
    rows: u32,
    // Column groups in `partial`.
    groups: u32,
    // Patches.
    n: u32,
}

@group(0) @binding(0) var<uniform> fin: Finish;
@group(0) @binding(1) var<storage, read> partial: array<f32>;
@group(0) @binding(2) var<storage, read> x: array<f32>;
// rows + 1 offsets into cols, starting at 0.
@group(0) @binding(3) var<storage, read> row_ptr: array<u32>;
@group(0) @binding(4) var<storage, read> cols: array<u32>;
// CH values per entry (1: grey, the same value for each channel of x).
@group(0) @binding(5) var<storage, read> values: array<f32>;
@group(0) @binding(6) var<storage, read_write> y: array<f32>;

//#CONSTS

fn x_at(col: u32) -> vec3<f32> {
    let i = 3u * col;
    return vec3<f32>(x[i], x[i + 1u], x[i + 2u]);
}

@compute @workgroup_size(64)
fn finish(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= fin.rows {
        return;
    }
    let row = fin.row0 + i;
    var s = vec3<f32>(0.0);
    for (var g = 0u; g < fin.groups; g++) {
        let o = (g * fin.n + row) * 3u;
        s += vec3<f32>(partial[o], partial[o + 1u], partial[o + 2u]);
    }
    for (var k = row_ptr[i]; k < row_ptr[i + 1u]; k++) {
        var v: vec3<f32>;
        if CH == 1u {
            v = vec3<f32>(values[k]);
        } else {
            v = vec3<f32>(values[3u * k], values[3u * k + 1u], values[3u * k + 2u]);
        }
        s += v * x_at(cols[k]);
    }
    y[3u * row] = s.x;
    y[3u * row + 1u] = s.y;
    y[3u * row + 2u] = s.z;
}
