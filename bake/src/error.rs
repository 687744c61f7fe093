//! The bake error: what can go wrong with input the caller could not check beforehand.

use radiosity_scene::SceneError;
use std::path::PathBuf;

/// An error from loading or baking a scene. Every variant names the file, and the line where
/// one is known, so that a one-line message is enough to find the problem.
#[derive(Debug, thiserror::Error)]
pub enum BakeError {
    /// A scene file that should be text (an OBJ) holds binary data.
    #[error("{}: {message}", path.display())]
    NotText {
        /// The file.
        path: PathBuf,
        /// What was found.
        message: String,
    },
    /// The scene could not be loaded: a file missing or unreadable, a malformed statement, an
    /// invalid material or texture, a glTF problem, or no usable triangle (see
    /// [`SceneError`]); its message is the scene's own.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// The scene loaded but cannot be baked: its scale is outside what the file's f32 fields
    /// hold.
    #[error("{0}")]
    Unbakeable(String),
    /// A bake flag (or host option) is refused: out of range, unknown, contradicting another,
    /// or more than this machine can bake; the message names the flag.
    #[error("{0}")]
    Flag(String),
    /// The host cancelled the bake from its progress callback; nothing was written.
    #[error("the bake was cancelled")]
    Cancelled,
    /// A parameter is out of its documented range.
    #[error("invalid parameter: {0}")]
    InvalidParams(String),
}
