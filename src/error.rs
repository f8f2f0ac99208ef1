//! Errors for bad input. Every variant names *what* is wrong and *where* (file, line, key), because the
//! user has to fix their file from the message alone; none of them is ever a panic.

use std::path::PathBuf;

/// Everything that can be wrong with a scene, a mesh or a PFM image handed to sism.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    /// A file could not be opened or read.
    #[error("cannot read {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The scene TOML does not parse, or has an unknown or mistyped key (the message carries line and
    /// column from the TOML parser).
    #[error("scene file {path}: {message}")]
    Toml { path: PathBuf, message: String },
    /// A value in the scene file parsed but makes no sense (`key` is the dotted TOML path).
    #[error("scene file {path}: `{key}` {message}")]
    InvalidValue {
        path: PathBuf,
        key: String,
        message: String,
    },
    /// A Wavefront OBJ file is malformed; `line` is 1-based when it could be located.
    #[error("OBJ file {path}{}: {message}", line.map(|l| format!(", line {l}")).unwrap_or_default())]
    Obj {
        path: PathBuf,
        line: Option<usize>,
        message: String,
    },
    /// A mesh has no triangles at all (only points, lines, or nothing).
    #[error("mesh {path} has no triangles")]
    EmptyMesh { path: PathBuf },
    /// A PFM image is malformed or not what was expected.
    #[error("PFM image {path}: {message}")]
    Pfm { path: PathBuf, message: String },
}

impl InputError {
    /// Builds an [`InputError::Io`] for `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io {
            path: path.into(),
            source,
        }
    }
}
