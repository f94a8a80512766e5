//! The integration tests of `replay-eval`, one module per file, in one test binary:
//! one link instead of one per file, and the tests of every file run in parallel (cargo
//! runs test binaries one after another).
//! Run one file's tests with `cargo test -p replay-eval --test integration <file>::`.
//!
//! A new file `tests/<file>.rs` is added below as `mod <file>;`; the last test below fails
//! for a file left out.

mod oracle;
mod separation;
mod study;

#[path = "../../test-support/test_files.rs"]
mod test_files;

/// Every `tests/*.rs` file is a module of this binary (with `autotests = false`, cargo would
/// silently build none that is left out).
#[test]
fn every_test_file_is_a_module_of_this_binary() {
    test_files::assert_every_test_file_is_a_module(env!("CARGO_MANIFEST_DIR"));
}
