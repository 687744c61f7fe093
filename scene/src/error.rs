//! The scene error: what can be wrong with a scene file or the files it names.

use std::path::PathBuf;

/// An error from loading a scene. Every variant names the file, and the line or item where
/// one is known, so that a one-line message is enough to find the problem.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// A file could not be opened or read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// A statement in an OBJ or MTL file is malformed or out of range.
    #[error("{}:{line}: {message}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A material is physically invalid (reflectance outside `[0, 1)`, negative or
    /// non-finite emission).
    #[error("{}{}: material `{material}`: {message}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    Material {
        /// The MTL or glTF file.
        path: PathBuf,
        /// The `newmtl` line, where found.
        line: Option<usize>,
        /// The material name.
        material: String,
        /// What is wrong.
        message: String,
    },
    /// A texture (`map_Kd`, a glTF image) could not be decoded.
    #[error("{}: cannot decode texture: {message}", path.display())]
    Texture {
        /// The image file.
        path: PathBuf,
        /// The decoder's message.
        message: String,
    },
    /// A glTF file is malformed, refers to missing or short data, or holds what the loader
    /// does not read (the message says which: JSON, a buffer, an accessor, a node cycle …).
    #[error("{}: {message}", path.display())]
    Gltf {
        /// The `.gltf` or `.glb` file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A glTF file lists an extension the loader does not implement in `extensionsRequired`.
    #[error("{}: requires the glTF extension `{extension}`, which is not supported", path.display())]
    UnsupportedExtension {
        /// The `.gltf` or `.glb` file.
        path: PathBuf,
        /// The extension's name.
        extension: String,
    },
    /// The scene has no usable (non-degenerate) triangle.
    #[error("{}: the scene has no non-degenerate triangle{why}", path.display())]
    EmptyScene {
        /// The scene file.
        path: PathBuf,
        /// What the file holds instead (`""`, or `": …"` naming it).
        why: String,
    },
}
