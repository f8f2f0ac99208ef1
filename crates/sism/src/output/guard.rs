//! A command never writes over its own inputs. Every file sism reads through [`crate::input`] is
//! noted here (resolved: links followed, `..` gone), as is every folder a command reads from lazily
//! (a trace run's `--reference`, declared with [`protect_dir`] before the work starts); every file
//! sism writes goes through [`crate::output::write_atomic`], which asks [`check_output`] first, and
//! a folder replaced whole (a trace run's `--out`) asks [`check_replaced_dir`]. So `trace make
//! --out scene.toml`, `trace run --out R --reference R` and `calibrate --out M --machine M` are
//! errors naming both paths, before anything is written.
//!
//! The inputs are the process's: a command line is one process. A long-lived caller (a notebook
//! binding) that reads and later rewrites the same file on purpose calls [`forget_inputs`] between
//! its calls.

use std::path::{Component, Path, PathBuf};
use std::sync::Mutex;

/// An input: its resolved path, what it is ("scene file", "--reference"), and whether it is a
/// folder (then nothing inside it may be written either).
struct Input {
    path: PathBuf,
    what: String,
    folder: bool,
}

static INPUTS: Mutex<Vec<Input>> = Mutex::new(Vec::new());

/// Most inputs remembered (a process reading more forgets the oldest: the guard is for a command's
/// handful of files, not a log).
const MAX_INPUTS: usize = 4096;

fn remember(path: &Path, what: &str, folder: bool) {
    let path = resolve(path);
    let mut inputs = INPUTS.lock().unwrap_or_else(|e| e.into_inner());
    if inputs.iter().any(|i| i.path == path && i.folder == folder) {
        return;
    }
    if inputs.len() == MAX_INPUTS {
        inputs.remove(0);
    }
    inputs.push(Input {
        path,
        what: what.to_string(),
        folder,
    });
}

/// Notes that this process read the file at `path` (`what` names it in errors).
pub fn note_input(path: &Path, what: &str) {
    remember(path, what, false);
}

/// Declares that this process reads from the folder `dir` (`what` names it in errors, e.g.
/// "--reference"): no output may be written inside it, nor may an output folder contain it.
pub fn protect_dir(dir: &Path, what: &str) {
    remember(dir, what, true);
}

/// Forgets every input noted so far.
pub fn forget_inputs() {
    INPUTS.lock().unwrap_or_else(|e| e.into_inner()).clear();
}

/// `path` absolute, with the part that exists resolved (links followed) and the rest appended with
/// `.` and `..` applied: two spellings of one file give one path, whether or not it exists yet.
pub fn resolve(path: &Path) -> PathBuf {
    let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut existing = abs.clone();
    let mut rest = Vec::new();
    let base = loop {
        if let Ok(c) = std::fs::canonicalize(&existing) {
            break c;
        }
        match (existing.file_name().map(|n| n.to_os_string()), existing.parent()) {
            (Some(name), Some(parent)) => {
                rest.push(name);
                existing = parent.to_path_buf();
            }
            // Nothing of it exists (or it ends in `..`): lexical.
            _ => break PathBuf::new(),
        }
    };
    let mut out = base;
    let tail: PathBuf = rest.iter().rev().collect();
    let source = if out.as_os_str().is_empty() { abs } else { tail };
    for c in source.components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            other => out.push(other),
        }
    }
    out
}

fn refused(output: &Path, message: String) -> crate::Error {
    crate::Error::write(
        output,
        std::io::Error::other(format!(
            "{message}: a command never writes over its own inputs; choose another output"
        )),
    )
}

/// Refuses to write the file `output` when it is a file this process read, or lies inside a folder
/// it reads from.
pub fn check_output(output: &Path) -> crate::Result<()> {
    let out = resolve(output);
    let inputs = INPUTS.lock().unwrap_or_else(|e| e.into_inner());
    for i in inputs.iter() {
        if out == i.path {
            return Err(refused(
                output,
                format!("it is the {} this command reads", i.what),
            ));
        }
        if i.folder && out.starts_with(&i.path) {
            return Err(refused(
                output,
                format!(
                    "it is inside {} {}, which this command reads",
                    i.what,
                    i.path.display()
                ),
            ));
        }
    }
    Ok(())
}

/// Refuses to replace the folder `dir` whole when it is, holds, or lies inside an input.
pub fn check_replaced_dir(dir: &Path) -> crate::Result<()> {
    let d = resolve(dir);
    let inputs = INPUTS.lock().unwrap_or_else(|e| e.into_inner());
    for i in inputs.iter() {
        let how = if d == i.path {
            "is"
        } else if i.path.starts_with(&d) {
            "holds"
        } else if i.folder && d.starts_with(&i.path) {
            "is inside"
        } else {
            continue;
        };
        return Err(refused(
            dir,
            format!(
                "this folder {how} the {} {}, which this command reads",
                i.what,
                i.path.display()
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resolve_applies_dots_and_links() {
        let dir = tempfile::tempdir().unwrap();
        let real = std::fs::canonicalize(dir.path()).unwrap();
        std::fs::create_dir(real.join("a")).unwrap();
        assert_eq!(resolve(&real.join("a/../b/./c")), real.join("b/c"));
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(real.join("a"), real.join("l")).unwrap();
            assert_eq!(resolve(&real.join("l/x.pfm")), real.join("a/x.pfm"));
        }
    }

    #[test]
    fn outputs_over_inputs_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let real = std::fs::canonicalize(dir.path()).unwrap();
        let scene = real.join("guard-scene.toml");
        std::fs::write(&scene, "x").unwrap();
        note_input(&real.join("./guard-scene.toml"), "scene file");
        let e = check_output(&scene).unwrap_err().to_string();
        assert!(e.contains("guard-scene.toml") && e.contains("scene file"), "{e}");
        assert!(check_output(&real.join("other.toml")).is_ok());
        let e = check_replaced_dir(&real).unwrap_err().to_string();
        assert!(e.contains("holds"), "{e}");
        let refs = real.join("ref");
        protect_dir(&refs, "--reference");
        let e = check_output(&refs.join("frame_0000.pfm"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("inside --reference"), "{e}");
        let e = check_replaced_dir(&refs.join("sub")).unwrap_err().to_string();
        assert!(e.contains("is inside"), "{e}");
    }
}
