//! Crash-safe output: every file hoverbench writes goes through here.
//!
//! * [`write_atomic`] writes a file through a temporary file in the target's own folder
//!   (`tempfile`'s [`NamedTempFile::persist`](tempfile::NamedTempFile::persist)), fsyncs it
//!   before the rename and fsyncs the folder after it; on any error the temporary file is
//!   removed and the target is untouched.
//! * [`write_atomic_checked`] does the same but first refuses a target that is one of the
//!   inputs (`import X -o X` must not overwrite its input).
//! * [`StagedDir`] builds a multi-file output (a report folder) in a hidden sibling folder
//!   (`.NAME.staging-PID.XXXXXX`) and renames it into place in one step (on Linux an existing
//!   folder is swapped atomically); dropped without [`StagedDir::commit`], it removes itself.
//!   A folder holding files the output does not own is never replaced.
//! * A process killed mid-write (kill -9) leaves its temporary file or staging folder behind,
//!   named with its process id; the next write of the same target removes those whose process
//!   is gone.
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
    /// The target folder holds files the output does not own: replacing it would lose them.
    #[error("{} holds files this command does not write ({}): choose a new or empty folder, or one holding only an earlier run's output", path.display(), names.join(", "))]
    Foreign {
        /// The target.
        path: PathBuf,
        /// Some of the foreign entries.
        names: Vec<String>,
    },
    /// The target of a folder output is a file.
    #[error("{} is a file: give a folder", path.display())]
    NotADir {
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

/// Whether the process `pid` may still be running (unknown counts as running).
fn process_alive(pid: u32) -> bool {
    if pid == std::process::id() {
        return true;
    }
    #[cfg(unix)]
    {
        let Some(pid) = i32::try_from(pid)
            .ok()
            .and_then(rustix::process::Pid::from_raw)
        else {
            return false;
        };
        !matches!(
            rustix::process::test_kill_process(pid),
            Err(rustix::io::Errno::SRCH)
        )
    }
    #[cfg(not(unix))]
    true
}

/// The process id that names a leftover: `rest` is what follows `.NAME.` — `PID.XXXXXX.tmp`
/// (a temporary file), `staging-PID.XXXXXX` (a staging folder) or `old-PID` (a folder moved
/// aside).
fn leftover_pid(rest: &str) -> Option<u32> {
    let rest = rest
        .strip_prefix("staging-")
        .or_else(|| rest.strip_prefix("old-"))
        .unwrap_or(rest);
    let digits: &str = rest.split('.').next()?;
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    // a temporary file ends in .tmp; a staging folder has a random tail; an aside is bare
    let tail = &rest[digits.len()..];
    let ok = tail.is_empty() || tail.ends_with(".tmp") || tail.starts_with('.');
    ok.then(|| digits.parse().ok()).flatten()
}

/// Removes what an earlier, killed process left beside a target: entries of `dir` named
/// `PREFIX…` (see [`leftover_pid`]) whose process is gone. Best effort: a leftover that cannot
/// be removed stays.
fn remove_stale(dir: &Path, prefix: &str) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let name = e.file_name();
        let Some(rest) = name.to_str().and_then(|n| n.strip_prefix(prefix)) else {
            continue;
        };
        let Some(pid) = leftover_pid(rest) else {
            continue;
        };
        if process_alive(pid) {
            continue;
        }
        let path = e.path();
        let _ = match e.file_type() {
            Ok(t) if t.is_dir() => std::fs::remove_dir_all(&path),
            _ => std::fs::remove_file(&path),
        };
    }
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
    let prefix = format!(".{}.", name.to_string_lossy());
    remove_stale(dir, &prefix);
    let tmp_prefix = format!("{prefix}{}.", std::process::id());
    let mut builder = tempfile::Builder::new();
    builder.prefix(&tmp_prefix).suffix(".tmp");
    // as a plain file would be created (0o666 less the umask), not tempfile's private 0o600
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
    let mut tmp = builder
        .tempfile_in(dir)
        .map_err(io("creating a temporary file in", dir))?;
    // a replaced file keeps its permissions
    if let Ok(old) = std::fs::metadata(path) {
        let _ = tmp.as_file().set_permissions(old.permissions());
    }
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

/// A folder built aside (a hidden sibling of the target, `.NAME.staging-PID.XXXXXX`) and
/// renamed into place by [`commit`](Self::commit). Dropped uncommitted, it is removed with
/// everything in it; left behind by a killed process, the next `StagedDir` for the same target
/// removes it.
#[derive(Debug)]
pub struct StagedDir {
    target: PathBuf,
    staging: Option<tempfile::TempDir>,
    owns: fn(&str) -> bool,
}

fn owns_nothing(_: &str) -> bool {
    false
}

impl StagedDir {
    /// Starts building `target`. An existing target folder is replaced on commit only if it
    /// holds nothing but names the built folder holds too.
    pub fn new(target: &Path) -> Result<Self, WriteError> {
        Self::owning(target, owns_nothing)
    }

    /// As [`new`](Self::new), also replacing a target folder whose other entries are all
    /// names `owns` accepts (the files of an earlier run of the same output). The target is
    /// checked now, so that a folder that cannot be replaced fails before the work is done,
    /// and again on commit.
    pub fn owning(target: &Path, owns: fn(&str) -> bool) -> Result<Self, WriteError> {
        let name = target.file_name().ok_or_else(|| WriteError::NotAFile {
            path: target.to_owned(),
        })?;
        let parent = parent_of(target);
        std::fs::create_dir_all(parent).map_err(io("creating", parent))?;
        let prefix = format!(".{}.", name.to_string_lossy());
        remove_stale(parent, &prefix);
        let this = Self {
            target: target.to_owned(),
            staging: None,
            owns,
        };
        this.check_target(&[])?;
        let staging_prefix = format!("{prefix}staging-{}.", std::process::id());
        let mut builder = tempfile::Builder::new();
        builder.prefix(&staging_prefix).rand_bytes(6);
        // as a plain folder would be created (0o777 less the umask)
        #[cfg(unix)]
        builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o777));
        let staging = builder
            .tempdir_in(parent)
            .map_err(io("creating a temporary folder in", parent))?;
        Ok(Self {
            staging: Some(staging),
            ..this
        })
    }

    /// The folder to write into.
    pub fn path(&self) -> &Path {
        self.staging
            .as_ref()
            .map_or(self.target.as_path(), tempfile::TempDir::path)
    }

    /// The folder the output will have once committed.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Refuses a target that is a file, or a folder holding entries neither in `built` nor
    /// accepted by the owner's predicate.
    fn check_target(&self, built: &[std::ffi::OsString]) -> Result<(), WriteError> {
        let meta = match std::fs::symlink_metadata(&self.target) {
            Ok(m) => m,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
            Err(e) => return Err(io("reading", &self.target)(e)),
        };
        if !meta.is_dir() {
            return Err(WriteError::NotADir {
                path: self.target.clone(),
            });
        }
        let entries = std::fs::read_dir(&self.target).map_err(io("reading", &self.target))?;
        let mut foreign = Vec::new();
        for e in entries {
            let e = e.map_err(io("reading", &self.target))?;
            let name = e.file_name();
            let is_file = e.file_type().is_ok_and(|t| t.is_file());
            // a file the output writes, or an entry (file or folder) the caller names as its own
            let owned =
                (is_file && built.contains(&name)) || name.to_str().is_some_and(|n| (self.owns)(n));
            if !owned {
                foreign.push(name.to_string_lossy().into_owned());
            }
        }
        if foreign.is_empty() {
            return Ok(());
        }
        foreign.sort();
        let more = foreign.len().saturating_sub(3);
        foreign.truncate(3);
        if more > 0 {
            foreign.push(format!("and {more} more"));
        }
        Err(WriteError::Foreign {
            path: self.target.clone(),
            names: foreign,
        })
    }

    /// Moves the built folder into place: the folder appears whole or not at all. An existing
    /// target (see [`new`](Self::new)) is swapped with it in one step where the system allows
    /// (Linux), else moved aside first (`.NAME.old-PID`, restored if the rename fails); the
    /// old folder is then removed.
    pub fn commit(mut self) -> Result<PathBuf, WriteError> {
        let Some(staging) = self.staging.take() else {
            return Ok(self.target.clone());
        };
        let built_names: Vec<std::ffi::OsString> = std::fs::read_dir(staging.path())
            .map_err(io("reading", staging.path()))?
            .filter_map(|e| e.ok().map(|e| e.file_name()))
            .collect();
        // on error `staging` is dropped and removed
        self.check_target(&built_names)?;
        sync_dir(staging.path());
        let built = staging.keep();
        let parent = parent_of(&self.target).to_owned();
        let cleanup = |p: &Path| {
            let _ = std::fs::remove_dir_all(p);
        };
        if self.target.exists() {
            if exchange(&built, &self.target) {
                // `built` now holds the old folder
                cleanup(&built);
                sync_dir(&parent);
                return Ok(self.target.clone());
            }
            let aside = parent.join(format!(
                ".{}.old-{}",
                self.target
                    .file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_default(),
                std::process::id()
            ));
            cleanup(&aside);
            if let Err(e) = std::fs::rename(&self.target, &aside) {
                cleanup(&built);
                return Err(io("moving aside", &self.target)(e));
            }
            if let Err(e) = std::fs::rename(&built, &self.target) {
                let _ = std::fs::rename(&aside, &self.target);
                cleanup(&built);
                return Err(io("renaming into", &self.target)(e));
            }
            cleanup(&aside);
        } else if let Err(e) = std::fs::rename(&built, &self.target) {
            cleanup(&built);
            return Err(io("renaming into", &self.target)(e));
        }
        sync_dir(&parent);
        Ok(self.target.clone())
    }
}

/// Swaps two paths in one step (`renameat2` with `RENAME_EXCHANGE`); `false` where the system
/// or the file system cannot (the caller falls back to two renames).
fn exchange(a: &Path, b: &Path) -> bool {
    #[cfg(any(target_os = "linux", target_os = "android"))]
    {
        use rustix::fs::{CWD, RenameFlags, renameat_with};
        renameat_with(CWD, a, CWD, b, RenameFlags::EXCHANGE).is_ok()
    }
    #[cfg(not(any(target_os = "linux", target_os = "android")))]
    {
        let _ = (a, b);
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn leftovers(dir: &Path) -> Vec<String> {
        std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".tmp") || n.contains(".old") || n.contains(".staging"))
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
        // Replacing an existing folder of the same output.
        let s = StagedDir::owning(&target, |n| n.ends_with(".svg")).unwrap();
        std::fs::write(s.path().join("b.svg"), b"b").unwrap();
        s.commit().unwrap();
        assert!(target.join("b.svg").exists() && !target.join("a.svg").exists());
        assert!(leftovers(d.path()).is_empty());
    }

    #[test]
    fn a_folder_holding_other_files_is_never_replaced() {
        let d = tempfile::tempdir().unwrap();
        let target = d.path().join("out");
        std::fs::create_dir(&target).unwrap();
        std::fs::write(target.join("thesis.tex"), b"mine").unwrap();
        let err = StagedDir::new(&target).unwrap_err();
        assert!(matches!(err, WriteError::Foreign { .. }), "{err}");
        assert!(err.to_string().contains("thesis.tex"), "{err}");
        // an earlier output's files are replaced
        std::fs::remove_file(target.join("thesis.tex")).unwrap();
        std::fs::write(target.join("old.svg"), b"old").unwrap();
        let s = StagedDir::owning(&target, |n| n.ends_with(".svg")).unwrap();
        std::fs::write(s.path().join("new.svg"), b"new").unwrap();
        s.commit().unwrap();
        assert!(target.join("new.svg").exists() && !target.join("old.svg").exists());
        // a file in the way
        let f = d.path().join("file");
        std::fs::write(&f, b"x").unwrap();
        assert!(matches!(
            StagedDir::new(&f).unwrap_err(),
            WriteError::NotADir { .. }
        ));
        assert!(leftovers(d.path()).is_empty());
    }

    #[test]
    fn what_a_killed_process_left_is_removed_by_the_next_run() {
        let d = tempfile::tempdir().unwrap();
        // a process id that is not running: a child that has exited and been reaped
        let mut child = std::process::Command::new("true")
            .spawn()
            .or_else(|_| std::process::Command::new("/bin/true").spawn())
            .unwrap();
        let dead = child.id();
        child.wait().unwrap();
        let stale_dir = d.path().join(format!(".report.staging-{dead}.abc123"));
        std::fs::create_dir(&stale_dir).unwrap();
        std::fs::write(stale_dir.join("fig3.svg"), b"half").unwrap();
        let stale_old = d.path().join(format!(".report.old-{dead}"));
        std::fs::create_dir(&stale_old).unwrap();
        let stale_tmp = d.path().join(format!(".params.toml.{dead}.x1y2z3.tmp"));
        std::fs::write(&stale_tmp, b"half").unwrap();
        // a live process's staging folder (this one's) stays
        let live = d
            .path()
            .join(format!(".report.staging-{}.zzz999", std::process::id()));
        std::fs::create_dir(&live).unwrap();
        // unrelated hidden files stay
        let other = d.path().join(".report.notes");
        std::fs::write(&other, b"x").unwrap();

        let s = StagedDir::new(&d.path().join("report")).unwrap();
        assert!(!stale_dir.exists() && !stale_old.exists());
        assert!(live.exists() && other.exists());
        drop(s);
        write_atomic(&d.path().join("params.toml"), b"x").unwrap();
        assert!(!stale_tmp.exists());
        assert_eq!(leftover_pid("123.abcdef.tmp"), Some(123));
        assert_eq!(leftover_pid("staging-77.Ab3xYz"), Some(77));
        assert_eq!(leftover_pid("old-9"), Some(9));
        assert_eq!(leftover_pid("notes"), None);
        assert_eq!(leftover_pid("12abc"), None);
    }

    #[cfg(unix)]
    #[test]
    fn outputs_get_the_permissions_a_plain_file_would() {
        use std::os::unix::fs::PermissionsExt;
        let d = tempfile::tempdir().unwrap();
        let plain = d.path().join("plain");
        std::fs::write(&plain, b"x").unwrap();
        std::fs::create_dir(d.path().join("plain-dir")).unwrap();
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        let p = d.path().join("params.toml");
        write_atomic(&p, b"x").unwrap();
        assert_eq!(mode(&p), mode(&plain));
        // a replaced file keeps its own
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o640)).unwrap();
        write_atomic(&p, b"y").unwrap();
        assert_eq!(mode(&p), 0o640);
        let s = StagedDir::new(&d.path().join("report")).unwrap();
        let target = s.commit().unwrap();
        assert_eq!(mode(&target), mode(&d.path().join("plain-dir")));
    }
}
