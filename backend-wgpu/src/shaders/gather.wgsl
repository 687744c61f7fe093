// Block gather: partial[group][row] = Σ over the band's block columns of M[row][col] · x[col].
//
// One workgroup per block row of the band (four output rows). Its 64 invocations stride over
// the band's block columns; each decodes whole 4×4 blocks and keeps four RGB sums, which a tree
// reduction in workgroup memory adds up at the end. A band never crosses a tile row, and the
// columns are walked tile by tile so that the tile's 256-entry log tables (one per stored
// channel) are copied into workgroup memory once per tile.
//
// `shader.rs` fills in the lines marked `//#`: constants, the block source (storage buffer or
// BC textures) and the per-block body for the format.

struct Band {
    // First block row of the padded matrix this band covers (its workgroup 0).
    row0: u32,
    // First block column, and block columns covered.
    col0: u32,
    cols: u32,
    // Block rows in the band (storage-buffer source: the stride between planes).
    rows: u32,
    // Tile side in blocks.
    tile_blocks: u32,
    // The column group this band's partial sums go to.
    group: u32,
    // Patches (rows written are those below n).
    n: u32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> band: Band;
// One 256-entry decode table per tile of the band's tile row and stored channel (log formats
// only), tile after tile.
@group(0) @binding(1) var<storage, read> tables: array<f32>;
// Exitance, RGB per column, zero past n up to the padded size.
@group(0) @binding(2) var<storage, read> x: array<f32>;
// Partial sums, RGB per row, one n-row slab per column group.
@group(0) @binding(3) var<storage, read_write> partial: array<f32>;

const WG: u32 = 64u;
//#CONSTS

//#SOURCE

var<workgroup> red: array<vec3<f32>, 256>;

fn x_at(col: u32) -> vec3<f32> {
    let i = 3u * col;
    return vec3<f32>(x[i], x[i + 1u], x[i + 2u]);
}

// 565 → 8-bit RGB by bit replication.
fn expand565(c: u32) -> vec3<i32> {
    let r = (c >> 11u) & 31u;
    let g = (c >> 5u) & 63u;
    let b = c & 31u;
    return vec3<i32>(vec3<u32>((r << 3u) | (r >> 2u), (g << 2u) | (g >> 4u), (b << 3u) | (b >> 2u)));
}

// The four BC1 palette codes per channel (DecodeMode::D3d10 or ::Mesa, by MESA).
fn bc1_palette(c0: u32, c1: u32) -> array<vec3<i32>, 4> {
    let a = expand565(c0);
    let b = expand565(c1);
    var p: array<vec3<i32>, 4>;
    p[0] = a;
    p[1] = b;
    if c0 > c1 {
        if MESA {
            p[2] = a + (((b - a) * 85) >> vec3<u32>(8u));
            p[3] = a + (((b - a) * 170) >> vec3<u32>(8u));
        } else {
            p[2] = (2 * a + b) / 3;
            p[3] = (a + 2 * b) / 3;
        }
    } else {
        if MESA {
            p[2] = (a + b + 1) >> vec3<u32>(1u);
        } else {
            p[2] = (a + b) / 2;
        }
        p[3] = vec3<i32>(0);
    }
    return p;
}

// The eight BC4 palette codes (DecodeMode::D3d10 or ::Mesa, by MESA).
fn bc4_palette(r0: i32, r1: i32) -> array<i32, 8> {
    var p: array<i32, 8>;
    p[0] = r0;
    p[1] = r1;
    if r0 > r1 {
        for (var t = 1; t < 7; t++) {
            if MESA {
                p[1 + t] = r0 + (((r1 - r0) * ((255 * t) / 7)) >> 8u);
            } else {
                p[1 + t] = ((7 - t) * r0 + t * r1) / 7;
            }
        }
    } else {
        for (var t = 1; t < 5; t++) {
            if MESA {
                p[1 + t] = r0 + (((r1 - r0) * ((255 * t) / 5)) >> 8u);
            } else {
                p[1 + t] = ((5 - t) * r0 + t * r1) / 5;
            }
        }
        p[6] = 0;
        p[7] = 255;
    }
    return p;
}

// 3-bit index of texel i from the 48 index bits: lo = bits 0..31, hi = bits 32..47.
fn bc4_index(lo: u32, hi: u32, i: u32) -> u32 {
    let b = 3u * i;
    if b < 30u {
        return (lo >> b) & 7u;
    }
    if b == 30u {
        return ((lo >> 30u) | (hi << 2u)) & 7u;
    }
    return (hi >> (b - 32u)) & 7u;
}

// IEEE binary16 → f32, exact (subnormal halves become normal floats).
fn f16_value(h: u32) -> f32 {
    let e = (h >> 10u) & 31u;
    let m = h & 1023u;
    var v: f32;
    if e == 0u {
        v = f32(m) * 5.9604644775390625e-8; // m · 2⁻²⁴
    } else {
        v = bitcast<f32>(((e + 112u) << 23u) | (m << 13u));
    }
    if (h >> 15u) == 1u {
        v = -v;
    }
    return v;
}

@compute @workgroup_size(64)
fn gather(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    // This workgroup's first block row in the band; it takes ROWS of them (fewer at the end).
    let rb0 = wg.x * ROWS;
    let ty = (band.row0 + rb0) / band.tile_blocks;
    // Four RGB sums per block row: acc[4·q + r] is row r of block row rb0 + q.
    var acc: array<vec3<f32>, ACC>;
    let end = band.col0 + band.cols;
    var start = band.col0;
    loop {
        if start >= end {
            break;
        }
        let tx = start / band.tile_blocks;
        let stop = min((tx + 1u) * band.tile_blocks, end);
        //#TABLES
        for (var gc = start + lid; gc < stop; gc += WG) {
            let cbl = gc - band.col0;
            let col = gc * 4u;
            // x of the block's four columns, shared by the ROWS blocks below.
            var xc = array<vec3<f32>, 4>(x_at(col), x_at(col + 1u), x_at(col + 2u), x_at(col + 3u));
            //#BODY
        }
        start = stop;
    }
    //#REDUCE
}

// Adds the 64 invocations' sums for block row rb0 + q (acc[4q..4q+4] copied to `mine`) and
// writes its four rows. Every invocation calls it (it has barriers).
fn reduce(lid: u32, rb: u32, mine: array<vec3<f32>, 4>) {
    for (var r = 0u; r < 4u; r++) {
        red[lid * 4u + r] = mine[r];
    }
    workgroupBarrier();
    for (var s = WG / 2u; s > 0u; s >>= 1u) {
        if lid < s {
            for (var r = 0u; r < 4u; r++) {
                red[lid * 4u + r] += red[(lid + s) * 4u + r];
            }
        }
        workgroupBarrier();
    }
    if lid < 4u && rb < band.rows {
        let row = (band.row0 + rb) * 4u + lid;
        if row < band.n {
            let o = (band.group * band.n + row) * 3u;
            let v = red[lid];
            partial[o] = v.x;
            partial[o + 1u] = v.y;
            partial[o + 2u] = v.z;
        }
    }
    workgroupBarrier();
}
