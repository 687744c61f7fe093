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

/// Invocations per workgroup of every kernel (`WG` in `gather.wgsl`, `@workgroup_size(64)`).
pub(crate) const WORKGROUP: u32 = 64;

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
    // The block body once per block row of the workgroup, without a branch: past the band's
    // last block row the last one is read again, and `reduce` writes only real rows (a branch
    // per block row kept the driver from scheduling the rows' loads together: H100, 16384
    // patches, BC1 0.376 → 0.327 ms, f16 0.740 → 0.700 ms). Everything is unrolled here, in
    // the text, down to the texel: every sum and every `x` is a scalar variable with a fixed
    // name (`acc5`, `xc2`). A loop with `acc[i / 4]` left for the driver to unroll put the sums
    // in scratch memory on an NVIDIA H100 (16384 patches BC1: 1.16 ms, unrolled here 0.38 ms;
    // ARCHITECTURE.md).
    let body = (0..ROWS)
        .map(|q| {
            let mut b = block.clone();
            for r in 0..4 {
                b = b.replace(&format!("ACC{r}"), &format!("acc{}", 4 * q + r));
            }
            format!(
                "{{\n            let rb = min(rb0 + {q}u, band.rows - 1u);\n            {b}\n            }}"
            )
        })
        .collect::<Vec<_>>()
        .join("\n");
    let accs = (0..4 * ROWS)
        .map(|i| format!("var acc{i}: vec3<f32>;"))
        .collect::<Vec<_>>()
        .join("\n    ");
    let reduce = (0..ROWS)
        .map(|q| {
            let o = 4 * q;
            format!(
                "reduce(lid, slab, rb0 + {q}u, array<vec3<f32>, 4>(acc{o}, acc{}, acc{}, acc{}));",
                o + 1,
                o + 2,
                o + 3
            )
        })
        .collect::<Vec<_>>()
        .join("\n    ");
    let divisions = [("DIV3", DIV3), ("DIV5", DIV5), ("DIV7", DIV7)]
        .map(|(name, (m, sh))| {
            format!("const {name}_MUL: u32 = {m}u;\nconst {name}_SHIFT: u32 = {sh}u;")
        })
        .join("\n");
    let consts = format!("{consts}\nconst ROWS: u32 = {ROWS}u;\n{TEX_BIAS}\n{divisions}");
    GATHER
        .replace("//#CONSTS", &consts)
        .replace("//#SOURCE", &src)
        .replace("//#TABLES", tables)
        .replace("//#ACC", &accs)
        .replace("//#BODY", &body)
        .replace(
            "//#REDUCE",
            &format!("let slab = band.group + wg.y * band.group_stride;\n    {reduce}"),
        )
}

/// The finish kernel for `channels` stored channels.
pub(crate) fn finish(channels: usize) -> String {
    FINISH.replace("//#CONSTS", &format!("const CH: u32 = {channels}u;"))
}

/// How the texture path turns the texture unit's `t` into a code: `⌊255·t + 1/14⌋`. A decoder
/// that returns whole codes (Mesa's, D3D10's) gives back its code, and one that interpolates
/// without rounding gives back exactly D3D10's truncated code, what the encoder assumes:
/// D3D10's thirds, halves, fifths and sevenths lie at least 1/7 of a code below the next whole
/// code, so a bias of half that recovers ⌊·⌋ through any float error below 1/14 of a code.
/// Rounding to nearest instead (the first version) left BC4 on an NVIDIA H100 with a lighting
/// error of 6.3e-3 against 1.6e-3 with the bias; that texture unit is off D3D10's rules in
/// other ways too, which `texture_unit` finds, so `auto` does not use it.
const TEX_BIAS: &str = "const TEX_BIAS: f32 = 0.07142857;";

/// `x / 3 == (x · 683) >> 11` for every `x ≤ 765` (the largest `2a + b` of 8-bit codes), and
/// likewise `/ 5` up to 1275 and `/ 7` up to 1785: the kernels' D3D10 palette divisions as a
/// multiply and a shift (tests check every `x`).
const DIV3: (u32, u32) = (683, 11);
const DIV5: (u32, u32) = (13108, 16);
const DIV7: (u32, u32) = (9363, 16);

/// Texel `i`'s coordinates in a band's texture.
fn texel(i: usize) -> String {
    format!(
        "vec2<i32>(i32(cbl * 4u + {}u), i32(rb * 4u + {}u))",
        i % 4,
        i / 4
    )
}

/// `ACC{row} += {value} * xc{col}` for texel `i` (`ACC` is renamed per block row later).
fn add(i: usize, value: &str) -> String {
    format!("ACC{} += {value} * xc{};", i / 4, i % 4)
}

/// The same for one channel of the sums and of `x`.
fn add_channel(i: usize, value: &str, c: &str) -> String {
    format!("ACC{}.{c} += {value} * xc{}.{c};", i / 4, i % 4)
}

/// Texel `i` of a block whose texels are packed `per_word` to a 32-bit word, `bits` each: the
/// `let` of its word (at the word's first texel, else empty) and the expression of its bits.
fn packed(i: usize, per_word: usize, bits: usize) -> (String, String) {
    let w = i / per_word;
    let word = if i.is_multiple_of(per_word) {
        format!("let w{w} = blocks[base + {w}u];\n            ")
    } else {
        String::new()
    };
    let mask = (1u32 << bits) - 1;
    (
        word,
        format!("((w{w} >> {}u) & {mask}u)", bits * (i % per_word)),
    )
}

/// `f(i)` for the 16 texels of a block, one statement a line.
fn texels(f: impl Fn(usize) -> String) -> String {
    (0..16).map(f).collect::<Vec<_>>().join("\n            ")
}

fn bc1_body(source: Source) -> String {
    match source {
        Source::Buffer => format!(
            "let base = (rb * band.cols + cbl) * 2u;
            let w0 = blocks[base];
            let w1 = blocks[base + 1u];
            let pal = bc1_palette(w0 & 0xffffu, w0 >> 16u);
            let c0 = pal[0];
            let c1 = pal[1];
            let c2 = pal[2];
            let c3 = pal[3];
            let v0 = vec3<f32>(tab[c0.x], tab[256u + c0.y], tab[512u + c0.z]);
            let v1 = vec3<f32>(tab[c1.x], tab[256u + c1.y], tab[512u + c1.z]);
            let v2 = vec3<f32>(tab[c2.x], tab[256u + c2.y], tab[512u + c2.z]);
            let v3 = vec3<f32>(tab[c3.x], tab[256u + c3.y], tab[512u + c3.z]);
            {}",
            texels(|i| {
                let v = format!(
                    "select(select(v0, v1, (w1 & {b0}u) != 0u), select(v2, v3, (w1 & {b0}u) != 0u), (w1 & {b1}u) != 0u)",
                    b0 = 1u32 << (2 * i),
                    b1 = 2u32 << (2 * i)
                );
                add(i, &v)
            })
        ),
        Source::Texture => texels(|i| {
            format!(
                "{{ let c = vec3<u32>(floor(textureLoad(tex0, {}, 0).rgb * 255.0 + TEX_BIAS)); {} }}",
                texel(i),
                add(i, "vec3<f32>(tab[c.x], tab[256u + c.y], tab[512u + c.z])")
            )
        }),
    }
}

/// One plane of a one-channel-per-plane format: 16 values, each added to every channel (grey
/// matrix) or to channel `plane` only.
fn plane_body(format: Format, source: Source, plane: usize, grey: bool) -> String {
    let words = words_per_block(format);
    let base = format!("let base = (({plane}u * band.rows + rb) * band.cols + cbl) * {words}u;");
    let add = |i: usize, v: &str| {
        if grey {
            add(i, &format!("vec3<f32>({v})"))
        } else {
            add_channel(i, v, ["x", "y", "z"][plane])
        }
    };
    let t = 256 * plane;
    let inner = match (format, source) {
        (Format::Bc4, Source::Buffer) => format!(
            "{base}
            let w0 = blocks[base];
            let w1 = blocks[base + 1u];
            let pal = bc4_palette(w0 & 255u, (w0 >> 8u) & 255u);
            let p0 = tab[{t}u + pal[0]];
            let p1 = tab[{t}u + pal[1]];
            let p2 = tab[{t}u + pal[2]];
            let p3 = tab[{t}u + pal[3]];
            let p4 = tab[{t}u + pal[4]];
            let p5 = tab[{t}u + pal[5]];
            let p6 = tab[{t}u + pal[6]];
            let p7 = tab[{t}u + pal[7]];
            let lo = (w0 >> 16u) | (w1 << 16u);
            let hi = w1 >> 16u;
            {}",
            texels(|i| {
                // The 3-bit index of texel i: bits 3i..3i+3 of the 48 (lo: 0–31, hi: 32–47).
                let b = 3 * i;
                let k = if b + 3 <= 32 {
                    format!("(lo >> {b}u) & 7u")
                } else if b >= 32 {
                    format!("(hi >> {}u) & 7u", b - 32)
                } else {
                    format!("((lo >> {b}u) | (hi << {}u)) & 7u", 32 - b)
                };
                format!(
                    "{{ let k = {k}; let b0 = (k & 1u) != 0u; let b1 = (k & 2u) != 0u; \
                     let v = select(select(select(p0, p1, b0), select(p2, p3, b0), b1), \
                     select(select(p4, p5, b0), select(p6, p7, b0), b1), k >= 4u); {} }}",
                    add(i, "v")
                )
            })
        ),
        (Format::Bc4, Source::Texture) => texels(|i| {
            format!(
                "{{ let v = tab[{t}u + u32(floor(textureLoad(tex{plane}, {}, 0).r * 255.0 + TEX_BIAS))]; {} }}",
                texel(i),
                add(i, "v")
            )
        }),
        (Format::U8, _) => format!(
            "{base}
            {}",
            texels(|i| {
                let (word, code) = packed(i, 4, 8);
                format!("{word}{}", add(i, &format!("tab[{t}u + {code}]")))
            })
        ),
        (Format::F16, _) => format!(
            "{base}
            {}",
            texels(|i| {
                let (word, bits) = packed(i, 2, 16);
                format!("{word}{}", add(i, &format!("f16_value({bits})")))
            })
        ),
        (Format::F32, _) => format!(
            "{base}
            {}",
            texels(|i| add(i, &format!("bitcast<f32>(blocks[base + {i}u])")))
        ),
        (Format::Bc1, _) => unreachable!("BC1 has its own body"),
    };
    format!("{{\n            {inner}\n            }}")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The multiply-and-shift divisions are exact over every weighted sum of 8-bit codes.
    #[test]
    fn palette_divisions_are_exact() {
        for (d, (m, sh), most) in [(3, DIV3, 765), (5, DIV5, 1275), (7, DIV7, 1785)] {
            for x in 0..=most {
                assert_eq!((x * m) >> sh, x / d, "{x} / {d}");
            }
        }
    }

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
        variants.push(include_str!("shaders/corner.wgsl").to_owned());
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

    /// The workgroup memory the device is asked for (`check_compute_limits`) covers every
    /// gather variant's workgroup variables, as naga lays them out.
    #[test]
    fn workgroup_memory_is_what_the_limit_check_asks_for() {
        for (format, channels) in Format::CASES {
            for source in [Source::Buffer, Source::Texture] {
                if source == Source::Texture && !format.is_block_compressed() {
                    continue;
                }
                let src = gather(format, channels, source, DecodeMode::D3d10);
                let module = naga::front::wgsl::parse_str(&src).unwrap();
                let mut layouter = naga::proc::Layouter::default();
                layouter.update(module.to_ctx()).unwrap();
                let bytes: u32 = module
                    .global_variables
                    .iter()
                    .filter(|(_, g)| g.space == naga::AddressSpace::WorkGroup)
                    .map(|(_, g)| layouter[g.ty].size)
                    .sum();
                let asked = crate::gather::workgroup_bytes(channels);
                assert!(bytes <= asked, "{format} ×{channels}: {bytes} > {asked}");
                // Tight for the log formats, which keep their tables in workgroup memory.
                if format.is_log() && source == Source::Buffer {
                    assert_eq!(bytes, asked, "{format} ×{channels}");
                }
            }
        }
    }
}
