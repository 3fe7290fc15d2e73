//! Where a scene description value came from, so errors and warnings found later
//! (when the scene is built) can name it.

use crate::error::SceneError;
use std::path::{Path, PathBuf};

/// The origin of a description value.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Source {
    /// A JSON path in the scene file, such as `objects[2].material_name` (`""`: the
    /// whole document).
    Json(String),
    /// A 1-based line and column in a file, for scene readers of formats without key
    /// paths.
    Position { file: PathBuf, line: u32, column: u32 },
    /// A key path in a document that is not a file of its own, such as
    /// `sphere.bsdf.reflectance` of a Python scene dictionary (`file` names it).
    Key { file: PathBuf, key: String },
}

impl Source {
    /// An error about the value found here. `scene` is the scene file, which a JSON
    /// path is relative to: the error reads `scene: path: message` (`scene: message`
    /// for the whole document), or `file: line L, column C: message`.
    pub fn error(&self, scene: &Path, msg: impl Into<String>) -> SceneError {
        match self {
            Source::Json(path) => SceneError::new(scene, (!path.is_empty()).then_some(path.as_str()), msg),
            Source::Position { file, line, column } => SceneError::new(file, Some(&format!("line {line}, column {column}")), msg),
            Source::Key { file, key } => SceneError::new(file, (!key.is_empty()).then_some(key.as_str()), msg),
        }
    }
}

/// A description value together with where it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct Located<T> {
    pub value: T,
    pub source: Source,
}
