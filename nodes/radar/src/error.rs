//! Errors of the radar front end. None of them is a panic: bad scene files and bad parameters
//! come back as values naming the file and the field.

use std::path::PathBuf;

/// One invalid field of a scene file: its dotted path (`targets[3].size_m`) and what is wrong.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{field}: {problem}")]
pub struct FieldError {
    /// Dotted path of the field inside the scene file, e.g. `trajectory.speed_mps`.
    pub field: String,
    /// What is wrong with it, including the allowed range where there is one.
    pub problem: String,
}

impl FieldError {
    /// A field error.
    pub fn new(field: impl Into<String>, problem: impl Into<String>) -> Self {
        Self {
            field: field.into(),
            problem: problem.into(),
        }
    }
}

/// Why a scene could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The scene file could not be read (missing, unreadable).
    #[error("cannot read scene file {}: {source}", path.display())]
    Read {
        /// The path that was tried (already resolved against the base directory).
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file is not valid TOML for the scene schema (syntax, unknown or missing field).
    #[error("scene file {origin}: {message}")]
    Parse {
        /// The file path, or a label for text not read from a file.
        origin: String,
        /// The TOML parser's message (names the key and line).
        message: String,
    },
    /// The file parsed but describes an impossible scene.
    #[error("scene file {origin}: {error}")]
    Invalid {
        /// The file path, or a label for text not read from a file.
        origin: String,
        /// The offending field.
        error: FieldError,
    },
}

impl SceneError {
    /// The offending field, when the scene parsed but failed validation.
    pub fn field(&self) -> Option<&str> {
        match self {
            SceneError::Invalid { error, .. } => Some(&error.field),
            _ => None,
        }
    }
}

/// Why the radar front end could not be set up.
#[derive(Debug, thiserror::Error)]
pub enum RadarError {
    /// A parameter is out of range.
    #[error("radar parameter {0}")]
    Param(#[from] nrslam_runtime::InvalidParam),
    /// The scene file is missing or invalid.
    #[error(transparent)]
    Scene(#[from] SceneError),
}
