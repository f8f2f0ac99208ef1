//! An output folder written whole or not at all. A run that writes many files into one folder (a
//! trace run's frames) writes them into a sibling work folder, `.NAME.partial-PID`; only when every
//! file is written does [`StagedDir::commit`] put a marker in it and swap it in for the old folder.
//! So the folder under its name is always one complete run, the old or the new: a failed or
//! interrupted run leaves the old run as it was, never old frames mixed with new ones under the old
//! summary. A reader that trusts the folder (a later `--reference`) checks the marker with
//! [`ensure_complete`].

use std::path::{Path, PathBuf};

/// The marker file a complete run's folder holds; its first line names the kind of run.
pub const MARKER: &str = ".sism-complete";

/// A folder being written: files go into [`StagedDir::path`]; [`StagedDir::commit`] puts it in
/// place. Dropped uncommitted (an error, a panic), the work folder is removed and the old folder
/// stays as it was.
pub struct StagedDir {
    target: PathBuf,
    work: PathBuf,
    kind: String,
    committed: bool,
}

fn io(what: &'static str, path: &Path, error: std::io::Error) -> crate::Error {
    crate::Error::Io {
        what,
        path: path.to_path_buf(),
        error,
    }
}

/// The marker's first line for a run of `kind`.
fn marker_line(kind: &str) -> String {
    format!("sism {kind}")
}

/// Whether `dir` holds a complete run of `kind` (its marker names it).
pub fn is_complete(dir: &Path, kind: &str) -> bool {
    // Read directly, not through `input` (which notes its files as inputs never to be written): the
    // marker of a folder about to be replaced is not an input of the run replacing it.
    let path = dir.join(MARKER);
    let regular_and_small = std::fs::metadata(&path).is_ok_and(|m| m.is_file() && m.len() <= 4096);
    regular_and_small
        && std::fs::read_to_string(&path).is_ok_and(|t| t.lines().next() == Some(marker_line(kind).as_str()))
}

/// An error unless `dir` is a complete run of `kind` (`what` names the folder's role, e.g.
/// "--reference").
pub fn ensure_complete(dir: &Path, kind: &str, what: &str) -> crate::Result<()> {
    if !dir.is_dir() {
        let meta = std::fs::metadata(dir);
        return Err(match meta {
            Err(e) => io("cannot read", dir, e),
            Ok(m) => crate::Error::invalid(format!(
                "{what} {}: a {}, not a folder",
                dir.display(),
                crate::input::kind_of(&m)
            )),
        }
        .context(what.to_string()));
    }
    if !is_complete(dir, kind) {
        return Err(crate::Error::invalid(format!(
            "{what} {}: not a complete {kind} (no {MARKER} marker naming one): the run that wrote it failed, \
             was interrupted, or was made by an older sism; run it again",
            dir.display()
        )));
    }
    Ok(())
}

impl StagedDir {
    /// Starts writing the folder `target` for a run of `kind` (e.g. "trace run"). Refused when
    /// `target` is or holds an input ([`super::guard`]), is not a folder, or holds files that are not
    /// a complete run of `kind` (the user's other files are never replaced).
    pub fn new(target: &Path, kind: &str) -> crate::Result<StagedDir> {
        super::guard::check_replaced_dir(target)?;
        match std::fs::symlink_metadata(target) {
            Ok(m) if m.is_dir() => {
                let empty = std::fs::read_dir(target)
                    .map_err(|e| io("cannot read", target, e))?
                    .next()
                    .is_none();
                if !empty && !is_complete(target, kind) {
                    return Err(crate::Error::invalid(format!(
                        "output folder {} holds files that are not a complete {kind}: refusing to replace \
                         it; choose another --out, or remove it",
                        target.display()
                    )));
                }
            }
            Ok(m) => {
                return Err(crate::Error::invalid(format!(
                    "output folder {}: a {}, not a folder",
                    target.display(),
                    if m.file_type().is_symlink() {
                        "link"
                    } else {
                        crate::input::kind_of(&m)
                    }
                )))
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(io("cannot read", target, e)),
        }
        let name = target
            .file_name()
            .ok_or_else(|| {
                crate::Error::invalid(format!("output folder {}: no folder name", target.display()))
            })?
            .to_string_lossy()
            .into_owned();
        let parent = match target.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        std::fs::create_dir_all(&parent).map_err(|e| crate::Error::create_dir(&parent, e))?;
        let work = parent.join(format!(".{name}.partial-{}", std::process::id()));
        if work.exists() {
            std::fs::remove_dir_all(&work).map_err(|e| io("cannot remove", &work, e))?;
        }
        std::fs::create_dir(&work).map_err(|e| crate::Error::create_dir(&work, e))?;
        Ok(StagedDir {
            target: target.to_path_buf(),
            work,
            kind: kind.to_string(),
            committed: false,
        })
    }

    /// The work folder: write the run's files here.
    pub fn path(&self) -> &Path {
        &self.work
    }

    /// Marks the run complete and puts it in place of the old folder (removed). Returns the folder.
    pub fn commit(mut self) -> crate::Result<PathBuf> {
        super::write_atomic(
            &self.work.join(MARKER),
            (marker_line(&self.kind) + "\n").as_bytes(),
        )?;
        let old = self.work.with_file_name(format!(
            ".{}.old-{}",
            self.target.file_name().unwrap_or_default().to_string_lossy(),
            std::process::id()
        ));
        let had_old = self.target.exists();
        if had_old {
            std::fs::rename(&self.target, &old).map_err(|e| io("cannot move aside", &self.target, e))?;
        }
        if let Err(e) = std::fs::rename(&self.work, &self.target) {
            if had_old {
                let _ = std::fs::rename(&old, &self.target);
            }
            return Err(io("cannot put in place", &self.target, e));
        }
        self.committed = true;
        if had_old {
            std::fs::remove_dir_all(&old).map_err(|e| io("cannot remove the previous run", &old, e))?;
        }
        Ok(self.target.clone())
    }
}

impl Drop for StagedDir {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_dir_all(&self.work);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_folder_is_the_old_run_or_the_new_one() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("run");
        let s = StagedDir::new(&out, "test run").unwrap();
        std::fs::write(s.path().join("a"), "1").unwrap();
        s.commit().unwrap();
        assert!(is_complete(&out, "test run"));
        assert!(!is_complete(&out, "other run"));
        // A failed second run (dropped before commit) leaves the first whole.
        let s = StagedDir::new(&out, "test run").unwrap();
        std::fs::write(s.path().join("a"), "2").unwrap();
        drop(s);
        assert_eq!(std::fs::read_to_string(out.join("a")).unwrap(), "1");
        // A completed one replaces it entirely.
        let s = StagedDir::new(&out, "test run").unwrap();
        std::fs::write(s.path().join("b"), "3").unwrap();
        s.commit().unwrap();
        assert!(!out.join("a").exists() && out.join("b").exists());
        // No work or old folders are left beside it.
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .flatten()
            .map(|e| e.file_name())
            .collect();
        assert_eq!(names.len(), 1, "{names:?}");
        // A folder of other files is never replaced.
        let other = dir.path().join("mine");
        std::fs::create_dir(&other).unwrap();
        std::fs::write(other.join("notes.txt"), "x").unwrap();
        let e = StagedDir::new(&other, "test run").err().unwrap().to_string();
        assert!(e.contains("not a complete test run"), "{e}");
        let e = ensure_complete(&other, "test run", "--reference")
            .unwrap_err()
            .to_string();
        assert!(e.contains("--reference") && e.contains(MARKER), "{e}");
    }
}
