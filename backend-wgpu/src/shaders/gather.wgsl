// Block gather: partial[group][row] = Σ over the band's block columns of M[row][col] · x[col].
//
// One workgroup per ROWS block rows of the band (4·ROWS output rows) and column split (a range
// of the band's block columns: splitting the columns gives a large GPU enough workgroups to
// hide memory latency; each split writes its own slab of partial sums, which the finish kernel
// adds). Its 64 invocations stride over the split's block columns; each decodes whole 4×4
// blocks and keeps four RGB sums per block row, which a tree reduction in workgroup memory
// adds up at the end. A band never crosses a tile row, and the
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
    // Block columns per column split: workgroup (x, y) takes block rows x·ROWS.. and the
    // columns col0 + y·split .. col0 + (y + 1)·split of the band.
    split: u32,
    // Slabs between one column split's partial sums and the next's.
    group_stride: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
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
fn expand565(c: u32) -> vec3<u32> {
    let r = (c >> 11u) & 31u;
    let g = (c >> 5u) & 63u;
    let b = c & 31u;
    return vec3<u32>((r << 3u) | (r >> 2u), (g << 2u) | (g >> 4u), (b << 3u) | (b >> 2u));
}

// D3D10's truncating divisions of a palette's weighted sums by 3 (sums ≤ 765), 5 (≤ 1275) and
// 7 (≤ 1785), as a multiply and a shift: an integer division is a long instruction sequence
// on GPUs. The constants are DIV3, DIV5, DIV7 in shader.rs, checked exhaustively there.
fn div3(x: vec3<u32>) -> vec3<u32> {
    return (x * DIV3_MUL) >> vec3<u32>(DIV3_SHIFT);
}
fn lerp5(a: u32, b: u32, t: u32) -> u32 {
    return (((5u - t) * a + t * b) * DIV5_MUL) >> DIV5_SHIFT;
}
fn lerp7(a: u32, b: u32, t: u32) -> u32 {
    return (((7u - t) * a + t * b) * DIV7_MUL) >> DIV7_SHIFT;
}
// Mesa's interpolation: a weight out of 256 and an arithmetic shift.
fn mesa_lerp(a: i32, b: i32, w: i32) -> i32 {
    return a + (((b - a) * w) >> 8u);
}

// The four BC1 palette codes per channel (DecodeMode::D3d10 or ::Mesa, by MESA). Both modes'
// entries are computed and one chosen by select: blocks of both modes sit side by side, and
// a branch would run both sides anyway.
fn bc1_palette(c0: u32, c1: u32) -> array<vec3<u32>, 4> {
    let a = expand565(c0);
    let b = expand565(c1);
    let four = c0 > c1;
    var p2: vec3<u32>;
    var p3: vec3<u32>;
    if MESA {
        let ai = vec3<i32>(a);
        let bi = vec3<i32>(b);
        p2 = select(
            vec3<u32>((ai + bi + 1) >> vec3<u32>(1u)),
            vec3<u32>(ai + (((bi - ai) * 85) >> vec3<u32>(8u))),
            four
        );
        p3 = select(vec3<u32>(0u), vec3<u32>(ai + (((bi - ai) * 170) >> vec3<u32>(8u))), four);
    } else {
        p2 = select((a + b) >> vec3<u32>(1u), div3(2u * a + b), four);
        p3 = select(vec3<u32>(0u), div3(a + 2u * b), four);
    }
    return array<vec3<u32>, 4>(a, b, p2, p3);
}

// The eight BC4 palette codes (DecodeMode::D3d10 or ::Mesa, by MESA), both modes computed and
// one chosen by select (see bc1_palette).
fn bc4_palette(r0: u32, r1: u32) -> array<u32, 8> {
    let eight = r0 > r1;
    var p: array<u32, 8>;
    p[0] = r0;
    p[1] = r1;
    if MESA {
        let a = i32(r0);
        let b = i32(r1);
        p[2] = u32(select(mesa_lerp(a, b, 51), mesa_lerp(a, b, 36), eight));
        p[3] = u32(select(mesa_lerp(a, b, 102), mesa_lerp(a, b, 72), eight));
        p[4] = u32(select(mesa_lerp(a, b, 153), mesa_lerp(a, b, 109), eight));
        p[5] = u32(select(mesa_lerp(a, b, 204), mesa_lerp(a, b, 145), eight));
        p[6] = u32(select(0, mesa_lerp(a, b, 182), eight));
        p[7] = u32(select(255, mesa_lerp(a, b, 218), eight));
    } else {
        p[2] = select(lerp5(r0, r1, 1u), lerp7(r0, r1, 1u), eight);
        p[3] = select(lerp5(r0, r1, 2u), lerp7(r0, r1, 2u), eight);
        p[4] = select(lerp5(r0, r1, 3u), lerp7(r0, r1, 3u), eight);
        p[5] = select(lerp5(r0, r1, 4u), lerp7(r0, r1, 4u), eight);
        p[6] = select(0u, lerp7(r0, r1, 5u), eight);
        p[7] = select(255u, lerp7(r0, r1, 6u), eight);
    }
    return p;
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
    // Four RGB sums per block row: acc<4·q + r> is row r of block row rb0 + q.
    //#ACC
    let end = min(band.col0 + band.cols, band.col0 + (wg.y + 1u) * band.split);
    var start = band.col0 + wg.y * band.split;
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
            let xc0 = x_at(col);
            let xc1 = x_at(col + 1u);
            let xc2 = x_at(col + 2u);
            let xc3 = x_at(col + 3u);
            //#BODY
        }
        start = stop;
    }
    //#REDUCE
}

// Adds the 64 invocations' sums for block row rb0 + q (acc[4q..4q+4] copied to `mine`) and
// writes its four rows. Every invocation calls it (it has barriers).
fn reduce(lid: u32, slab: u32, rb: u32, mine: array<vec3<f32>, 4>) {
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
            let o = (slab * band.n + row) * 3u;
            let v = red[lid];
            partial[o] = v.x;
            partial[o + 1u] = v.y;
            partial[o + 2u] = v.z;
        }
    }
    workgroupBarrier();
}
