//! Errors for bad input. Every variant names *what* is wrong and *where* (file, line, key), because the
//! user has to fix their file from the message alone; none of them is ever a panic.

use std::path::PathBuf;

/// Everything that can be wrong with a scene, a mesh or a PFM image handed to sism.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    /// A file could not be opened or read. (The OS error is in the message and not chained as a
    /// source, so `{:#}` does not print it twice.)
    #[error("cannot read {path}: {error}")]
    Io { path: PathBuf, error: std::io::Error },
    /// A path names a directory, FIFO, device or socket where a file is needed.
    #[error("{what} {path} is a {kind}, not a regular file")]
    NotAFile {
        path: PathBuf,
        what: String,
        kind: &'static str,
    },
    /// A file is larger than sism reads for its kind.
    #[error("{what} {path} is {bytes} bytes; at most {max} are read")]
    TooLarge {
        path: PathBuf,
        what: String,
        bytes: u64,
        max: u64,
    },
    /// A text file holds bytes that are not UTF-8.
    #[error("{what} {path}, line {line} (byte {offset}): not valid UTF-8 text")]
    NotUtf8 {
        path: PathBuf,
        what: String,
        line: usize,
        offset: usize,
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
    pub fn io(path: impl Into<PathBuf>, error: std::io::Error) -> Self {
        Self::Io {
            path: path.into(),
            error,
        }
    }
}
