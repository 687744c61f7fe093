//! Accessor and buffer reading: every byte of a buffer goes through bounds-checked code here,
//! since accessor reading in the `gltf` crate can panic on a short buffer.

use super::Loader;
use crate::SceneError;
use ::gltf::accessor::{DataType, Dimensions};
use base64::Engine as _;
use std::path::{Path, PathBuf};

/// The buffers of a file, each cut to its `byteLength`.
pub(super) struct Buffers(pub(super) Vec<Vec<u8>>);

/// A view of an accessor's elements in a buffer, checked to lie inside it.
pub(super) struct Elements<'b> {
    /// From the accessor's first byte to the end of its buffer view.
    pub(super) bytes: &'b [u8],
    pub(super) count: usize,
    stride: usize,
    component: usize,
    data_type: DataType,
}

impl Elements<'_> {
    /// Component `k` of element `i` as f64 (normalised integers mapped to `[0, 1]`).
    pub(super) fn get(&self, i: usize, k: usize, normalized: bool) -> f64 {
        let at = i * self.stride + k * self.component;
        let b = &self.bytes[at..at + self.component];
        match self.data_type {
            DataType::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            DataType::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            DataType::U16 => {
                let v = f64::from(u16::from_le_bytes([b[0], b[1]]));
                if normalized { v / 65535.0 } else { v }
            }
            DataType::U8 => {
                let v = f64::from(b[0]);
                if normalized { v / 255.0 } else { v }
            }
            DataType::I16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
            DataType::I8 => f64::from(b[0] as i8),
        }
    }

    /// Element `i` as an index (for U8, U16 and U32 scalars).
    pub(super) fn index(&self, i: usize) -> u32 {
        let bytes = self.bytes;
        let at = i * self.stride;
        match self.data_type {
            DataType::U8 => u32::from(bytes[at]),
            DataType::U16 => u32::from(u16::from_le_bytes([bytes[at], bytes[at + 1]])),
            _ => u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]),
        }
    }
}

fn data_type_name(t: DataType) -> &'static str {
    match t {
        DataType::I8 => "BYTE",
        DataType::U8 => "UNSIGNED_BYTE",
        DataType::I16 => "SHORT",
        DataType::U16 => "UNSIGNED_SHORT",
        DataType::U32 => "UNSIGNED_INT",
        DataType::F32 => "FLOAT",
    }
}

fn dimensions_of(d: Dimensions) -> (usize, &'static str) {
    match d {
        Dimensions::Scalar => (1, "SCALAR"),
        Dimensions::Vec2 => (2, "VEC2"),
        Dimensions::Vec3 => (3, "VEC3"),
        Dimensions::Vec4 => (4, "VEC4"),
        Dimensions::Mat2 => (4, "MAT2"),
        Dimensions::Mat3 => (9, "MAT3"),
        Dimensions::Mat4 => (16, "MAT4"),
    }
}

/// Decodes a `data:` URI (base64 only), or `None` when `uri` is not one.
fn data_uri(uri: &str) -> Option<Result<Vec<u8>, String>> {
    let rest = uri.strip_prefix("data:")?;
    let Some((head, payload)) = rest.split_once(',') else {
        return Some(Err("data URI without a `,`".into()));
    };
    if !head.ends_with(";base64") {
        return Some(Err("data URI is not base64-encoded".into()));
    }
    Some(
        base64::engine::general_purpose::STANDARD
            .decode(payload.trim())
            .map_err(|e| format!("data URI: bad base64: {e}")),
    )
}

/// The bytes of a URI: a data URI, else a file relative to the glTF file's folder
/// (percent-encoded as URIs are).
pub(super) fn read_uri(dir: &Path, uri: &str) -> Result<Vec<u8>, (Option<PathBuf>, String)> {
    if let Some(d) = data_uri(uri) {
        return d.map_err(|m| (None, m));
    }
    if uri.contains("://") {
        return Err((None, format!("URI `{uri}` is not a relative file path")));
    }
    let name = percent_encoding::percent_decode_str(uri).decode_utf8_lossy();
    let file = dir.join(name.as_ref());
    std::fs::read(&file).map_err(|e| (Some(file), e.to_string()))
}

impl Loader<'_> {
    /// The elements of accessor `acc`, checked: its type, and that every byte it covers lies
    /// inside its buffer view and the view inside its buffer.
    pub(super) fn elements(
        &self,
        acc: &::gltf::Accessor<'_>,
        what: &str,
        types: &[DataType],
        dims: Dimensions,
    ) -> Result<Elements<'_>, SceneError> {
        let i = acc.index();
        let (n, dim_name) = dimensions_of(acc.dimensions());
        if acc.dimensions() != dims || !types.contains(&acc.data_type()) {
            let want: Vec<&str> = types.iter().map(|&t| data_type_name(t)).collect();
            return Err(self.err(format!(
                "accessor {i} ({what}) is {dim_name} {}, expected {} {}",
                data_type_name(acc.data_type()),
                dimensions_of(dims).1,
                want.join(" or ")
            )));
        }
        if acc.sparse().is_some() {
            return Err(self.err(format!(
                "accessor {i} ({what}) is sparse, which is not supported"
            )));
        }
        let component = acc.data_type().size();
        let elem = component * n;
        let count = acc.count();
        let Some(view) = acc.view() else {
            // All zeros by the specification: no surface, and a count nothing bounds.
            return Err(self.err(format!(
                "accessor {i} ({what}) has no bufferView (zero-filled accessors are not supported)"
            )));
        };
        let buffer = &self.buffers.0[view.buffer().index()];
        let v = view.index();
        let view_end = view.offset().checked_add(view.length());
        if view_end.is_none_or(|e| e > buffer.len()) {
            return Err(self.err(format!(
                "buffer view {v} (bytes {}..+{}) runs past the end of buffer {} ({} bytes)",
                view.offset(),
                view.length(),
                view.buffer().index(),
                buffer.len()
            )));
        }
        let view_bytes = &buffer[view.offset()..view.offset() + view.length()];
        let stride = view.stride().unwrap_or(elem);
        if stride < elem {
            return Err(self.err(format!(
                "buffer view {v}: byteStride {stride} is smaller than the {elem}-byte elements of accessor {i}"
            )));
        }
        if count > 0 {
            let end = (count - 1)
                .checked_mul(stride)
                .and_then(|x| x.checked_add(elem))
                .and_then(|x| x.checked_add(acc.offset()));
            if end.is_none_or(|e| e > view_bytes.len()) {
                return Err(self.err(format!(
                    "accessor {i} ({what}): {count} elements from byte {} run past the end of buffer view {v} ({} bytes)",
                    acc.offset(),
                    view_bytes.len()
                )));
            }
        }
        Ok(Elements {
            bytes: &view_bytes[acc.offset().min(view_bytes.len())..],
            count,
            stride,
            component,
            data_type: acc.data_type(),
        })
    }
}
