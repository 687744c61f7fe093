//! The scene formats: one table from file extension to reader.
//!
//! [`crate::Scene::load_with`] reads a file with the row its extension names, and anything
//! else that asks what a path holds (a host refusing binary data in a text format, say) asks
//! [`of`]. A file whose extension no row names is read as OBJ, the last row.

use crate::{LoadOptions, Scene, SceneError};
use std::path::Path;

/// What a row reads, for callers that treat one format apart.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FormatKind {
    /// Wavefront OBJ with its MTL libraries (text).
    Obj,
    /// glTF 2.0: `.gltf` JSON with its buffers and images, or a `.glb` container.
    Gltf,
}

/// A reader: the scene in a file, under the load options.
type Reader = fn(&Path, &LoadOptions) -> Result<Scene, SceneError>;

/// One scene format: the extensions it is chosen by and the reader that loads it.
#[derive(Debug)]
pub struct Format {
    /// Which format it is.
    pub kind: FormatKind,
    /// The file extensions, lower case without the dot; a path's extension matches in any
    /// case.
    pub extensions: &'static [&'static str],
    reader: Reader,
}

/// Every format the crate reads, each extension in one row; the last row (OBJ) also reads
/// files whose extension no row names.
pub const FORMATS: &[Format] = &[
    Format {
        kind: FormatKind::Gltf,
        extensions: &["gltf", "glb"],
        reader: crate::gltf::load,
    },
    Format {
        kind: FormatKind::Obj,
        extensions: &["obj"],
        reader: crate::obj::load,
    },
];

impl Format {
    /// Loads the scene in `path` with this format's reader.
    pub fn read(&self, path: &Path, options: &LoadOptions) -> Result<Scene, SceneError> {
        (self.reader)(path, options)
    }
}

/// The format `path` is read as: the row naming its extension (in any case), else the last
/// row.
pub fn of(path: &Path) -> &'static Format {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    FORMATS
        .iter()
        .find(|f| f.extensions.iter().any(|e| e.eq_ignore_ascii_case(ext)))
        .unwrap_or(&FORMATS[FORMATS.len() - 1])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extensions_pick_their_row_in_any_case() {
        for (name, kind) in [
            ("a.gltf", FormatKind::Gltf),
            ("dir.obj/a.GLB", FormatKind::Gltf),
            ("a.Gltf", FormatKind::Gltf),
            ("a.obj", FormatKind::Obj),
            ("a.OBJ", FormatKind::Obj),
            ("a.glb.obj", FormatKind::Obj),
        ] {
            assert_eq!(of(Path::new(name)).kind, kind, "{name}");
        }
    }

    #[test]
    fn an_unknown_or_missing_extension_is_read_as_obj() {
        for name in ["scene.txt", "scene", "dir.gltf/scene", ".glb", "a.gltf~"] {
            assert_eq!(of(Path::new(name)).kind, FormatKind::Obj, "{name}");
        }
    }

    #[test]
    fn every_extension_is_in_one_row_in_lower_case() {
        let all: Vec<&str> = FORMATS
            .iter()
            .flat_map(|f| f.extensions.iter().copied())
            .collect();
        for (i, e) in all.iter().enumerate() {
            assert_eq!(*e, e.to_ascii_lowercase(), "{e}");
            assert!(!e.starts_with('.') && !e.is_empty(), "{e:?}");
            assert!(!all[i + 1..].contains(e), "{e} is in two rows");
        }
    }
}
