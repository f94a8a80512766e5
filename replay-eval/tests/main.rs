//! The integration tests of `replay-eval`, one module per file, in one test binary:
//! one link instead of one per file, and the tests of every file run in parallel (cargo
//! runs test binaries one after another).
//! Run one file's tests with `cargo test -p replay-eval --test integration <file>::`.
//!
//! A new file `tests/<file>.rs` is added below as `mod <file>;`; the last test below fails
//! for a file left out.

mod separation;
mod study;

/// Every `tests/*.rs` file is a module of this binary (with `autotests = false`, cargo would
/// silently build none that is left out).
#[test]
fn every_test_file_is_a_module_of_this_binary() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests");
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
