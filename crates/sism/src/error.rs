//! Errors for bad input. Every variant names *what* is wrong and *where* (file, line, key), because the
//! user has to fix their file from the message alone; none of them is ever a panic.

use std::path::PathBuf;

/// Everything that can be wrong with a scene, a mesh or a PFM image handed to sism.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    /// A file could not be opened or read. (The OS error is in the message and not chained as a
    /// source, so `{:#}` does not print it twice.)
    #[error("cannot read {path}: {error}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        error: std::io::Error,
    },
    /// A path names a directory, FIFO, device or socket where a file is needed.
    #[error("{what} {path} is a {kind}, not a regular file")]
    NotAFile {
        /// The path.
        path: PathBuf,
        /// What the file was to be, e.g. "scene file" or "mesh".
        what: String,
        /// What the path names instead, e.g. "directory" or "FIFO".
        kind: &'static str,
    },
    /// A file is larger than sism reads for its kind.
    #[error("{what} {path} is {bytes} bytes; at most {max} are read")]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// What the file is, e.g. "scene file" or "mesh".
        what: String,
        /// Its size, bytes.
        bytes: u64,
        /// The largest size read for its kind, bytes.
        max: u64,
    },
    /// A text file holds bytes that are not UTF-8.
    #[error("{what} {path}, line {line} (byte {offset}): not valid UTF-8 text")]
    NotUtf8 {
        /// The file.
        path: PathBuf,
        /// What the file is, e.g. "scene file".
        what: String,
        /// Line of the first invalid byte, 1-based.
        line: usize,
        /// Offset of the first invalid byte from the start of the file, bytes.
        offset: usize,
    },
    /// The scene TOML does not parse, or has an unknown or mistyped key (the message carries line and
    /// column from the TOML parser).
    #[error("scene file {path}: {message}")]
    Toml {
        /// The scene file.
        path: PathBuf,
        /// The TOML parser's message, with line and column.
        message: String,
    },
    /// A value in the scene file parsed but makes no sense (`key` is the dotted TOML path).
    #[error("scene file {path}: `{key}` {message}")]
    InvalidValue {
        /// The scene file.
        path: PathBuf,
        /// The dotted TOML path of the value.
        key: String,
        /// What is wrong with it.
        message: String,
    },
    /// A Wavefront OBJ file is malformed; `line` is 1-based when it could be located.
    #[error("OBJ file {path}{}: {message}", line.map(|l| format!(", line {l}")).unwrap_or_default())]
    Obj {
        /// The OBJ file.
        path: PathBuf,
        /// Line of the fault, 1-based, when it could be located.
        line: Option<usize>,
        /// What is wrong.
        message: String,
    },
    /// A mesh has no triangles at all (only points, lines, or nothing).
    #[error("mesh {path} has no triangles")]
    EmptyMesh {
        /// The mesh file.
        path: PathBuf,
    },
    /// An image file (OpenEXR, or one of unknown format) is malformed or not what was expected.
    #[error("{format} image {path}: {message}")]
    Image {
        /// The image file.
        path: PathBuf,
        /// The format it was read as, e.g. "OpenEXR".
        format: &'static str,
        /// What is wrong.
        message: String,
    },
    /// A PFM image is malformed or not what was expected.
    #[error("PFM image {path}: {message}")]
    Pfm {
        /// The PFM file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
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

/// The library's error: every fallible public function returns it. Its message names what is wrong
/// and where; [`Error::kind`] says whether the caller gave bad input or a file operation failed (a
/// binding maps those to its own errors: `ValueError`, `OSError`).
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A scene, mesh, image or other input file is unreadable or malformed.
    #[error(transparent)]
    Input(#[from] InputError),
    /// An algorithm parameter is unknown or out of range.
    #[error(transparent)]
    Param(#[from] crate::algorithms::ParamError),
    /// Two images cannot be compared (sizes differ, values out of range).
    #[error(transparent)]
    Compare(#[from] crate::metrics::CompareError),
    /// A value handed to the library is out of range or inconsistent (a parameter, a machine field,
    /// an option, a study directory's content).
    #[error("{0}")]
    Invalid(String),
    /// A file or folder could not be written, created, renamed or removed (`what`: the operation and
    /// the thing, e.g. "cannot write").
    #[error("{what} {path}: {error}")]
    Io {
        /// What was being done, e.g. "cannot write" or "cannot create folder".
        what: &'static str,
        /// The path it was done to.
        path: PathBuf,
        /// The operating system's error.
        error: std::io::Error,
    },
    /// An external program (a scheduler's command) could not run or failed.
    #[error("{0}")]
    External(String),
    /// An error with the context it happened in, outermost first (`context: inner`).
    #[error("{context}: {inner}")]
    Context {
        /// Where or in what the inner error happened.
        context: String,
        /// The error itself.
        inner: Box<Error>,
    },
}

/// What kind of failure an [`Error`] is, whatever context wraps it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorKind {
    /// The caller's input or values are wrong: fix them.
    InvalidInput,
    /// A file could not be read or written.
    Io,
    /// An external program failed.
    External,
}

/// `Result` with the library's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// An [`Error::Invalid`] with `message`.
    pub fn invalid(message: impl Into<String>) -> Error {
        Error::Invalid(message.into())
    }

    /// An [`Error::Io`]: writing `path` failed.
    pub fn write(path: impl Into<PathBuf>, error: std::io::Error) -> Error {
        Error::Io {
            what: "cannot write",
            path: path.into(),
            error,
        }
    }

    /// An [`Error::Io`]: creating the folder `path` failed.
    pub fn create_dir(path: impl Into<PathBuf>, error: std::io::Error) -> Error {
        Error::Io {
            what: "cannot create folder",
            path: path.into(),
            error,
        }
    }

    /// This error inside `context` (`context: self`).
    pub fn context(self, context: impl Into<String>) -> Error {
        Error::Context {
            context: context.into(),
            inner: Box::new(self),
        }
    }

    /// What kind of failure this is (through any context).
    pub fn kind(&self) -> ErrorKind {
        match self {
            Error::Input(InputError::Io { .. }) => ErrorKind::Io,
            Error::Input(_) | Error::Invalid(_) | Error::Compare(_) | Error::Param(_) => {
                ErrorKind::InvalidInput
            }
            Error::Io { .. } => ErrorKind::Io,
            Error::External(_) => ErrorKind::External,
            Error::Context { inner, .. } => inner.kind(),
        }
    }
}

impl From<String> for Error {
    fn from(message: String) -> Error {
        Error::Invalid(message)
    }
}

/// Adds context to a failed result: `load(path).context("the scene of the trace")?`.
pub trait Context<T> {
    /// The error, if any, inside `context`.
    fn context(self, context: impl Into<String>) -> Result<T>;
    /// The error, if any, inside the context `f` gives (computed only on failure).
    fn with_context<C: Into<String>>(self, f: impl FnOnce() -> C) -> Result<T>;
}

impl<T, E: Into<Error>> Context<T> for std::result::Result<T, E> {
    fn context(self, context: impl Into<String>) -> Result<T> {
        self.map_err(|e| e.into().context(context))
    }

    fn with_context<C: Into<String>>(self, f: impl FnOnce() -> C) -> Result<T> {
        self.map_err(|e| e.into().context(f()))
    }
}

/// Returns an [`Error::Invalid`] from the enclosing function, formatted like `format!`.
macro_rules! bail {
    ($($arg:tt)+) => {
        return Err($crate::error::Error::invalid(format!($($arg)+)))
    };
}

/// Returns an [`Error::Invalid`] (formatted like `format!`) unless `cond` holds.
macro_rules! ensure {
    ($cond:expr, $($arg:tt)+) => {
        if !$cond {
            return Err($crate::error::Error::invalid(format!($($arg)+)));
        }
    };
}

pub(crate) use {bail, ensure};
