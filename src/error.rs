//! The error type for everything a scene can get wrong.

use std::fmt;
use std::path::{Path, PathBuf};

/// A problem with a scene: which file, which JSON key (as a path such as
/// `objects[2].material_name`), and what is wrong. Displays on one line.
#[derive(Debug, Clone)]
pub struct SceneError {
    pub file: PathBuf,
    pub key: Option<String>,
    pub message: String,
}

impl SceneError {
    pub fn new(file: &Path, key: Option<&str>, message: impl Into<String>) -> Self {
        SceneError {
            file: file.to_path_buf(),
            key: key.map(str::to_string),
            message: message.into(),
        }
    }
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file.display())?;
        if let Some(k) = &self.key {
            write!(f, ": {k}")?;
        }
        write!(f, ": {}", self.message.replace('\n', " "))
    }
}

impl std::error::Error for SceneError {}

pub type Result<T, E = SceneError> = std::result::Result<T, E>;
