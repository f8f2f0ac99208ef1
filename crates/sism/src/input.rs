//! Reading the files users hand sism (scenes, meshes, images, machine files, records): regular
//! files only, never more than a stated size, so a FIFO, a device, a directory or a runaway file is
//! an error naming it instead of a hang, an abort or garbage.

use std::io::Read;
use std::path::Path;

use crate::error::InputError;

/// Largest scene or machine TOML file accepted, bytes.
pub const MAX_TEXT_BYTES: u64 = 16 << 20;
/// Largest OBJ mesh file accepted, bytes (1 GiB: about 30M triangles of text).
pub const MAX_MESH_BYTES: u64 = 1 << 30;
/// Largest PFM image accepted, bytes (a 2^27-pixel image and its header).
pub const MAX_IMAGE_BYTES: u64 = (1 << 29) + 4096;
/// Largest records file accepted, bytes.
pub const MAX_RECORDS_BYTES: u64 = 64 << 30;

/// The bytes of the regular file at `path` (`what` names it in errors: "scene file", "mesh"), at
/// most `max_bytes`. FIFOs, devices, sockets and directories are errors (checked before opening, so
/// a FIFO cannot block), as is a file that grows past the limit while it is read.
pub fn read_file(path: &Path, what: &str, max_bytes: u64) -> Result<Vec<u8>, InputError> {
    let meta = std::fs::metadata(path).map_err(|e| InputError::io(path, e))?;
    let kind = file_kind(&meta);
    if kind != "regular file" {
        return Err(InputError::NotAFile {
            path: path.into(),
            what: what.into(),
            kind,
        });
    }
    if meta.len() > max_bytes {
        return Err(InputError::TooLarge {
            path: path.into(),
            what: what.into(),
            bytes: meta.len(),
            max: max_bytes,
        });
    }
    let file = std::fs::File::open(path).map_err(|e| InputError::io(path, e))?;
    crate::output::guard::note_input(path, what);
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    file.take(max_bytes + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| InputError::io(path, e))?;
    if bytes.len() as u64 > max_bytes {
        return Err(InputError::TooLarge {
            path: path.into(),
            what: what.into(),
            bytes: bytes.len() as u64,
            max: max_bytes,
        });
    }
    Ok(bytes)
}

/// [`read_file`] as UTF-8 text; invalid UTF-8 is an error naming the line (1-based) and byte offset.
pub fn read_text(path: &Path, what: &str, max_bytes: u64) -> Result<String, InputError> {
    let bytes = read_file(path, what, max_bytes)?;
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = 1 + e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count();
        InputError::NotUtf8 {
            path: path.into(),
            what: what.into(),
            line,
            offset: at,
        }
    })
}

/// What kind of file `meta` describes, in words ("regular file", "directory", "FIFO", …).
pub fn kind_of(meta: &std::fs::Metadata) -> &'static str {
    file_kind(meta)
}

/// What kind of file `meta` describes, in words.
fn file_kind(meta: &std::fs::Metadata) -> &'static str {
    let t = meta.file_type();
    if t.is_file() {
        return "regular file";
    }
    if t.is_dir() {
        return "directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "FIFO";
        }
        if t.is_char_device() || t.is_block_device() {
            return "device";
        }
        if t.is_socket() {
            return "socket";
        }
    }
    "special file"
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn special_files_and_limits_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        let e = read_file(dir.path(), "mesh", 100).unwrap_err().to_string();
        assert!(e.contains("directory") && e.contains("mesh"), "{e}");
        let e = read_file(Path::new("/dev/zero"), "mesh", 100)
            .unwrap_err()
            .to_string();
        assert!(e.contains("device"), "{e}");
        let big = dir.path().join("big");
        std::fs::write(&big, vec![b'x'; 200]).unwrap();
        let e = read_file(&big, "mesh", 100).unwrap_err().to_string();
        assert!(e.contains("200 bytes") && e.contains("100"), "{e}");
        let bad = dir.path().join("bad.toml");
        std::fs::write(&bad, b"a = 1\nb = 2\nc = \"\xff\"\n").unwrap();
        let e = read_text(&bad, "scene file", 100).unwrap_err().to_string();
        assert!(e.contains("line 3") && e.contains("UTF-8"), "{e}");
    }

    #[cfg(unix)]
    #[test]
    fn a_fifo_is_refused_without_blocking() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("fifo");
        let status = std::process::Command::new("mkfifo").arg(&fifo).status();
        if !status.is_ok_and(|s| s.success()) {
            eprintln!("skipping: mkfifo unavailable");
            return;
        }
        let e = read_file(&fifo, "mesh", 100).unwrap_err().to_string();
        assert!(e.contains("FIFO"), "{e}");
    }
}
