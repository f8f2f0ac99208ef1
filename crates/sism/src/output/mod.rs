//! Files a render writes (CONTRACTS.md "Images written by a render") and reads back. The statistics'
//! files are written by [`crate::stats::StatsReport::write`].

pub mod exr;
pub mod guard;
pub mod pfm;
pub mod pictures;
pub mod plots;
pub mod report;
pub mod staged;

use std::io::Write;
use std::path::Path;

/// Writes `bytes` to `path` whole or not at all: through a temporary file in the same folder, synced
/// and renamed over `path`, so that no reader (a later run, a watching `collect`) sees a partial
/// file under the name. Every file sism writes goes through here, so here is where it refuses to
/// write over its own inputs ([`guard`]: a file this process read, or one inside a folder it reads)
/// and to replace anything but a regular file (a device, a FIFO, a folder at that name).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> crate::Result<()> {
    guard::check_output(path)?;
    // What the name holds now (through a link): only a regular file may be replaced.
    if let Ok(meta) = std::fs::metadata(path) {
        if !meta.is_file() {
            return Err(crate::Error::write(
                path,
                std::io::Error::other(format!(
                    "it is a {}, not a regular file; refusing to replace it",
                    crate::input::kind_of(&meta)
                )),
            ));
        }
    }
    // A link is written through: its target is the file replaced, the link stays.
    let target = if path.is_symlink() {
        std::fs::canonicalize(path).map_err(|e| crate::Error::write(path, e))?
    } else {
        path.to_path_buf()
    };
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy())
        .unwrap_or_default();
    let tmp = target.with_file_name(format!(".{name}.tmp-{}", std::process::id()));
    let write = || -> std::io::Result<()> {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, &target)
    };
    write().map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        crate::Error::write(path, e)
    })
}

/// Reads a visibility image from a PFM or an OpenEXR file, told apart by their first bytes (not by
/// the name): `compare`, `bench --truth` and `trace run --reference` take either.
pub fn read_visibility(path: &Path) -> Result<crate::VisibilityImage, crate::InputError> {
    let bytes = crate::input::read_file(path, "visibility image", crate::input::MAX_IMAGE_BYTES)?;
    if bytes.starts_with(&exr::MAGIC) {
        exr::decode_visibility(path, &bytes)
    } else if bytes.starts_with(b"P") {
        pfm::decode_pfm(path, &bytes)
    } else {
        Err(crate::InputError::Image {
            path: path.into(),
            format: "visibility",
            message: "is neither a PFM (starts with `Pf`) nor an OpenEXR file".into(),
        })
    }
}

/// Writes `image` to `path` as PNG (encoded in memory, then [`write_atomic`]).
pub fn save_png(path: &Path, image: &image::RgbImage) -> crate::Result<()> {
    let mut bytes = Vec::new();
    image
        .write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
        .map_err(|e| crate::Error::write(path, std::io::Error::other(e)))?;
    write_atomic(path, &bytes)
}
