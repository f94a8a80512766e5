//! Crash-safe output: every file hoverbench writes goes through here.
//!
//! * [`write_atomic`] writes a file through a temporary file in the target's own folder
//!   (`tempfile`'s [`NamedTempFile::persist`](tempfile::NamedTempFile::persist)), fsyncs it
//!   before the rename and fsyncs the folder after it; on any error the temporary file is
//!   removed and the target is untouched.
//! * [`write_atomic_checked`] does the same but first refuses a target that is one of the
//!   inputs (`import X -o X` must not overwrite its input).
//! * [`StagedDir`] builds a multi-file output (a report folder) in a temporary sibling folder
//!   and renames it into place in one step; dropped without [`StagedDir::commit`], it removes
//!   itself.
//!
//! ```
//! let dir = tempfile::tempdir()?;
//! let target = dir.path().join("params.toml");
//! outfile::write_atomic(&target, b"schema = \"hoverbench.params\"\n")?;
//! assert_eq!(std::fs::read(&target)?, b"schema = \"hoverbench.params\"\n");
//! // The target may not be an input.
//! assert!(outfile::write_atomic_checked(&target, b"x", &[target.clone()]).is_err());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::io::Write;
use std::path::{Path, PathBuf};

/// Why an output could not be written. The target is untouched and no temporary file is left.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum WriteError {
    /// A file-system operation failed.
    #[error("{what} {}", path.display())]
    Io {
        /// What was being done (`writing`, `renaming into`, …).
        what: &'static str,
        /// The path it was done to.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// The target is a folder.
    #[error("{} is a folder: give a file name", path.display())]
    IsDir {
        /// The target.
        path: PathBuf,
    },
    /// The target has no file name (`..`, `/`).
    #[error("{} is not a file path", path.display())]
    NotAFile {
        /// The target.
        path: PathBuf,
    },
    /// The target is one of the inputs.
    #[error("{} is also an input: writing it would overwrite the data it is made from; choose another output", path.display())]
    SameAsInput {
        /// The target.
        path: PathBuf,
    },
}

fn io(what: &'static str, path: &Path) -> impl FnOnce(std::io::Error) -> WriteError {
    let path = path.to_owned();
    move |source| WriteError::Io { what, path, source }
}

/// The folder a target lives in (`.` for a bare file name).
fn parent_of(path: &Path) -> &Path {
    path.parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
}

/// Flushes a folder's entries (the rename) to disk; a no-op where folders cannot be opened.
fn sync_dir(dir: &Path) {
    #[cfg(unix)]
    if let Ok(d) = std::fs::File::open(dir) {
        // Best effort: some file systems refuse fsync on a folder; the data itself is synced.
        let _ = d.sync_all();
    }
    #[cfg(not(unix))]
    let _ = dir;
}

/// Writes `bytes` to `path` atomically: a temporary file beside it, fsync, rename, fsync of the
/// folder. On error the temporary file is removed and `path` keeps its old content.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), WriteError> {
    if path.is_dir() {
        return Err(WriteError::IsDir {
            path: path.to_owned(),
        });
    }
    let name = path.file_name().ok_or_else(|| WriteError::NotAFile {
        path: path.to_owned(),
    })?;
    let dir = parent_of(path);
    let mut tmp = tempfile::Builder::new()
        .prefix(&format!(".{}.", name.to_string_lossy()))
        .suffix(".tmp")
        .tempfile_in(dir)
        .map_err(io("creating a temporary file in", dir))?;
    tmp.write_all(bytes).map_err(io("writing", path))?;
    tmp.as_file().sync_all().map_err(io("syncing", path))?;
    // On failure the PersistError owns the temporary file; dropping it removes it.
    tmp.persist(path)
        .map_err(|e| io("renaming into", path)(e.error))?;
    sync_dir(dir);
    Ok(())
}

/// Whether `a` and `b` name the same existing file (same device and inode on Unix; same
/// canonical path elsewhere).
pub fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(x), Ok(y)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return x.dev() == y.dev() && x.ino() == y.ino();
        }
        false
    }
    #[cfg(not(unix))]
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}

/// [`write_atomic`], refusing a target that is the same file as one of `inputs`.
pub fn write_atomic_checked(
    path: &Path,
    bytes: &[u8],
    inputs: &[PathBuf],
) -> Result<(), WriteError> {
    check_not_input(path, inputs)?;
    write_atomic(path, bytes)
}

/// Refuses a target that is the same file as one of `inputs`.
pub fn check_not_input(path: &Path, inputs: &[PathBuf]) -> Result<(), WriteError> {
    if inputs.iter().any(|i| same_file(path, i)) {
        return Err(WriteError::SameAsInput {
            path: path.to_owned(),
        });
    }
    Ok(())
}

/// A folder built aside (a temporary sibling of the target) and renamed into place by
/// [`commit`](Self::commit). Dropped uncommitted, it is removed with everything in it.
#[derive(Debug)]
pub struct StagedDir {
    target: PathBuf,
    staging: Option<tempfile::TempDir>,
}

impl StagedDir {
    /// Starts building `target` (which may exist: it is replaced on commit).
    pub fn new(target: &Path) -> Result<Self, WriteError> {
        let name = target.file_name().ok_or_else(|| WriteError::NotAFile {
            path: target.to_owned(),
        })?;
        let parent = parent_of(target);
        std::fs::create_dir_all(parent).map_err(io("creating", parent))?;
        let staging = tempfile::Builder::new()
            .prefix(&format!(".{}.", name.to_string_lossy()))
            .suffix(".tmp")
            .tempdir_in(parent)
            .map_err(io("creating a temporary folder in", parent))?;
        Ok(Self {
            target: target.to_owned(),
            staging: Some(staging),
        })
    }

    /// The folder to write into.
    pub fn path(&self) -> &Path {
        self.staging
            .as_ref()
            .map_or(self.target.as_path(), tempfile::TempDir::path)
    }

    /// Moves the built folder into place. An existing target is moved aside first and removed
    /// once the new folder is in place (restored if the rename fails).
    pub fn commit(mut self) -> Result<PathBuf, WriteError> {
        let Some(staging) = self.staging.take() else {
            return Ok(self.target.clone());
        };
        let built = staging.keep();
        let parent = parent_of(&self.target).to_owned();
        let old = if self.target.exists() {
            let aside = parent.join(format!(
                ".{}.old{}",
                self.target
                    .file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_default(),
                std::process::id()
            ));
            if let Err(e) = std::fs::rename(&self.target, &aside) {
                let _ = std::fs::remove_dir_all(&built);
                return Err(io("moving aside", &self.target)(e));
            }
            Some(aside)
        } else {
            None
        };
        if let Err(e) = std::fs::rename(&built, &self.target) {
            if let Some(old) = &old {
                let _ = std::fs::rename(old, &self.target);
            }
            let _ = std::fs::remove_dir_all(&built);
            return Err(io("renaming into", &self.target)(e));
        }
        if let Some(old) = old {
            let _ = if old.is_dir() {
                std::fs::remove_dir_all(&old)
            } else {
                std::fs::remove_file(&old)
            };
        }
        sync_dir(&parent);
        Ok(self.target.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn leftovers(dir: &Path) -> Vec<String> {
        std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".tmp") || n.contains(".old"))
            .collect()
    }

    #[test]
    fn replaces_content_and_leaves_nothing_behind() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("a.txt");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        assert!(leftovers(d.path()).is_empty());
    }

    #[test]
    fn a_folder_target_is_refused_without_a_temporary_file() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("out");
        std::fs::create_dir(&p).unwrap();
        assert!(matches!(
            write_atomic(&p, b"x"),
            Err(WriteError::IsDir { .. })
        ));
        assert!(leftovers(d.path()).is_empty());
    }

    #[test]
    fn a_target_in_a_missing_folder_fails_cleanly() {
        let d = tempfile::tempdir().unwrap();
        let err = write_atomic(&d.path().join("missing").join("x.txt"), b"x").unwrap_err();
        assert!(matches!(err, WriteError::Io { .. }), "{err}");
        assert!(std::error::Error::source(&err).is_some());
        assert!(leftovers(d.path()).is_empty());
    }

    #[test]
    fn the_input_is_never_the_output() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("in.csv");
        std::fs::write(&p, b"data").unwrap();
        let alias = d.path().join(".").join("in.csv");
        let err = write_atomic_checked(&alias, b"x", std::slice::from_ref(&p)).unwrap_err();
        assert!(matches!(err, WriteError::SameAsInput { .. }));
        assert_eq!(std::fs::read(&p).unwrap(), b"data");
        write_atomic_checked(&d.path().join("out.csv"), b"x", &[p]).unwrap();
    }

    #[test]
    fn a_staged_folder_appears_whole_or_not_at_all() {
        let d = tempfile::tempdir().unwrap();
        let target = d.path().join("report");
        {
            let s = StagedDir::new(&target).unwrap();
            std::fs::write(s.path().join("a.svg"), b"a").unwrap();
            // dropped: nothing appears
        }
        assert!(!target.exists());
        assert!(leftovers(d.path()).is_empty());
        let s = StagedDir::new(&target).unwrap();
        std::fs::write(s.path().join("a.svg"), b"a").unwrap();
        s.commit().unwrap();
        assert_eq!(std::fs::read(target.join("a.svg")).unwrap(), b"a");
        // Replacing an existing folder.
        let s = StagedDir::new(&target).unwrap();
        std::fs::write(s.path().join("b.svg"), b"b").unwrap();
        s.commit().unwrap();
        assert!(target.join("b.svg").exists() && !target.join("a.svg").exists());
        assert!(leftovers(d.path()).is_empty());
    }
}
