//! WGSL for one matrix: the gather template (`shaders/gather.wgsl`) specialised by text for the
//! format, the stored channels, the block source and the software decode mode, and the finish
//! kernel (`shaders/finish.wgsl`).
//!
//! Specialising by text rather than by branches on uniforms keeps each kernel's inner loop free
//! of format tests, and every constant (planes, table offsets, the decode mode) is a literal the
//! driver's compiler folds.

use radiosity_core::{DecodeMode, Format};

const GATHER: &str = include_str!("shaders/gather.wgsl");
const FINISH: &str = include_str!("shaders/finish.wgsl");

/// Where the gather kernel reads blocks from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Source {
    /// A storage buffer of `u32` words, decoded in the shader.
    Buffer,
    /// BC1/BC4 textures, decoded by the texture unit (`textureLoad`).
    Texture,
}

/// Block rows one workgroup gathers: each block column's `x` is loaded once for all of them,
/// which divides the kernel's `x` traffic (12 bytes a column against a BC1 block's 8 bytes
/// for four) by this much.
pub(crate) const ROWS: usize = 4;

/// 32-bit words one block takes in one plane.
pub(crate) fn words_per_block(format: Format) -> usize {
    format.block_bytes() / 4
}

/// The gather kernel for `format` with `channels` stored, reading from `source`, decoding BC
/// palettes (buffer source) under `mode`.
pub(crate) fn gather(format: Format, channels: usize, source: Source, mode: DecodeMode) -> String {
    let planes = if format == Format::Bc1 { 1 } else { channels };
    let consts = format!(
        "const MESA: bool = {};\nconst CH: u32 = {channels}u;{}",
        mode == DecodeMode::Mesa,
        if format.is_log() {
            format!("\nvar<workgroup> tab: array<f32, {}>;", 256 * channels)
        } else {
            String::new()
        }
    );
    let src = match source {
        Source::Buffer => "@group(0) @binding(4) var<storage, read> blocks: array<u32>;".to_owned(),
        Source::Texture => (0..planes)
            .map(|p| format!("@group(0) @binding({}) var tex{p}: texture_2d<f32>;", 4 + p))
            .collect::<Vec<_>>()
            .join("\n"),
    };
    let tables = if format.is_log() {
        "workgroupBarrier();
        let tbase = tx * CH * 256u;
        for (var i = lid; i < CH * 256u; i += WG) {
            tab[i] = tables[tbase + i];
        }
        workgroupBarrier();"
    } else {
        ""
    };
    let block = match format {
        Format::Bc1 => bc1_body(source),
        _ => (0..planes)
            .map(|p| plane_body(format, source, p, channels == 1))
            .collect::<Vec<_>>()
            .join("\n"),
    };
    // The block body once per block row of the workgroup, unrolled here so that every `acc`
    // index is a constant after the driver unrolls the 16-texel loops (a runtime index would
    // put the sums in scratch memory on GPUs).
    let body = (0..ROWS)
        .map(|q| {
            format!(
                "{{\n            let rb = rb0 + {q}u;\n            if rb < band.rows {{\n            {}\n            }}\n            }}",
                block.replace("acc[i / 4u]", &format!("acc[{}u + i / 4u]", 4 * q))
            )
        })
        .collect::<Vec<_>>()
        .join("\n");
    let reduce = (0..ROWS)
        .map(|q| {
            let o = 4 * q;
            format!(
                "reduce(lid, rb0 + {q}u, array<vec3<f32>, 4>(acc[{o}u], acc[{}u], acc[{}u], acc[{}u]));",
                o + 1,
                o + 2,
                o + 3
            )
        })
        .collect::<Vec<_>>()
        .join("\n    ");
    let consts = format!(
        "{consts}\nconst ROWS: u32 = {ROWS}u;\nconst ACC: u32 = {}u;",
        4 * ROWS
    );
    GATHER
        .replace("//#CONSTS", &consts)
        .replace("//#SOURCE", &src)
        .replace("//#TABLES", tables)
        .replace("//#BODY", &body)
        .replace("//#REDUCE", &reduce)
}

/// The finish kernel for `channels` stored channels.
pub(crate) fn finish(channels: usize) -> String {
    FINISH.replace("//#CONSTS", &format!("const CH: u32 = {channels}u;"))
}

/// Texel `i`'s coordinates in a band's texture.
const TEXEL: &str = "vec2<i32>(i32(cbl * 4u + i % 4u), i32(rb * 4u + i / 4u))";

fn bc1_body(source: Source) -> String {
    match source {
        Source::Buffer => "let base = (rb * band.cols + cbl) * 2u;
            let w0 = blocks[base];
            let w1 = blocks[base + 1u];
            var pal = bc1_palette(w0 & 0xffffu, w0 >> 16u);
            var v: array<vec3<f32>, 4>;
            for (var k = 0u; k < 4u; k++) {
                let c = vec3<u32>(pal[k]);
                v[k] = vec3<f32>(tab[c.x], tab[256u + c.y], tab[512u + c.z]);
            }
            for (var i = 0u; i < 16u; i++) {
                acc[i / 4u] += v[(w1 >> (2u * i)) & 3u] * xc[i % 4u];
            }"
        .to_owned(),
        Source::Texture => format!(
            "for (var i = 0u; i < 16u; i++) {{
                let t = textureLoad(tex0, {TEXEL}, 0);
                let c = vec3<u32>(round(t.rgb * 255.0));
                acc[i / 4u] += vec3<f32>(tab[c.x], tab[256u + c.y], tab[512u + c.z]) * xc[i % 4u];
            }}"
        ),
    }
}

/// One plane of a one-channel-per-plane format: 16 values `v`, each added to every channel
/// (grey matrix) or to channel `plane` only.
fn plane_body(format: Format, source: Source, plane: usize, grey: bool) -> String {
    let words = words_per_block(format);
    let base = format!("let base = (({plane}u * band.rows + rb) * band.cols + cbl) * {words}u;");
    let add = if grey {
        "acc[i / 4u] += v * xc[i % 4u];".to_owned()
    } else {
        let c = ["x", "y", "z"][plane];
        format!("acc[i / 4u].{c} += v * xc[i % 4u].{c};")
    };
    let t = 256 * plane;
    let inner = match (format, source) {
        (Format::Bc4, Source::Buffer) => format!(
            "{base}
            let w0 = blocks[base];
            let w1 = blocks[base + 1u];
            var pal = bc4_palette(i32(w0 & 255u), i32((w0 >> 8u) & 255u));
            var pv: array<f32, 8>;
            for (var k = 0u; k < 8u; k++) {{
                pv[k] = tab[{t}u + u32(pal[k])];
            }}
            let lo = (w0 >> 16u) | (w1 << 16u);
            let hi = w1 >> 16u;
            for (var i = 0u; i < 16u; i++) {{
                let v = pv[bc4_index(lo, hi, i)];
                {add}
            }}"
        ),
        (Format::Bc4, Source::Texture) => format!(
            "for (var i = 0u; i < 16u; i++) {{
                let code = u32(round(textureLoad(tex{plane}, {TEXEL}, 0).r * 255.0));
                let v = tab[{t}u + code];
                {add}
            }}"
        ),
        (Format::U8, _) => format!(
            "{base}
            for (var i = 0u; i < 16u; i++) {{
                let code = (blocks[base + i / 4u] >> (8u * (i % 4u))) & 255u;
                let v = tab[{t}u + code];
                {add}
            }}"
        ),
        (Format::F16, _) => format!(
            "{base}
            for (var i = 0u; i < 16u; i++) {{
                let v = f16_value((blocks[base + i / 2u] >> (16u * (i % 2u))) & 0xffffu);
                {add}
            }}"
        ),
        (Format::F32, _) => format!(
            "{base}
            for (var i = 0u; i < 16u; i++) {{
                let v = bitcast<f32>(blocks[base + i]);
                {add}
            }}"
        ),
        (Format::Bc1, _) => unreachable!("BC1 has its own body"),
    };
    format!("{{\n            {inner}\n            }}")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every kernel variant parses and validates with naga (no device needed), so a WGSL slip
    /// fails here rather than at pipeline creation on some adapter.
    #[test]
    fn every_variant_validates() {
        let mut variants = Vec::new();
        for (format, channels) in Format::CASES {
            for mode in [DecodeMode::D3d10, DecodeMode::Mesa] {
                variants.push(gather(format, channels, Source::Buffer, mode));
            }
            if format.is_block_compressed() {
                variants.push(gather(format, channels, Source::Texture, DecodeMode::Mesa));
            }
        }
        variants.push(finish(1));
        variants.push(finish(3));
        for src in variants {
            let module = match naga::front::wgsl::parse_str(&src) {
                Ok(m) => m,
                Err(e) => panic!("{}\n{src}", e.emit_to_string(&src)),
            };
            naga::valid::Validator::new(
                naga::valid::ValidationFlags::all(),
                naga::valid::Capabilities::default(),
            )
            .validate(&module)
            .unwrap_or_else(|e| panic!("{e:?}\n{src}"));
        }
    }
}
