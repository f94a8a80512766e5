//! Shared by the integration-test binaries that declare each `tests/*.rs` file as a module
//! of one `tests/main.rs` (`autotests = false`): with that setting cargo silently builds no
//! file that is left out, so each binary checks its own folder with this.
//!
//! A plain file included with `#[path]`, not a crate: it adds no package to the workspace.

use std::path::Path;

/// Panics naming every `tests/*.rs` file under `manifest_dir` that `tests/main.rs` does not
/// declare as `mod <file>;` (alone on its line, or after a `#[path]` line).
pub fn assert_every_test_file_is_a_module(manifest_dir: &str) {
    let dir = Path::new(manifest_dir).join("tests");
    let main = std::fs::read_to_string(dir.join("main.rs")).expect("tests/main.rs");
    let mut missing = Vec::new();
    for entry in std::fs::read_dir(&dir).expect("tests/") {
        let name = entry
            .expect("entry")
            .file_name()
            .to_string_lossy()
            .into_owned();
        if let Some(stem) = name.strip_suffix(".rs")
            && stem != "main"
            && !main.lines().any(|l| l.trim() == format!("mod {stem};"))
        {
            missing.push(name);
        }
    }
    assert!(
        missing.is_empty(),
        "not declared in tests/main.rs: {missing:?}"
    );
}
