//! The integration tests of `fit`, one module per file, in one test binary.

mod motor_map;
mod nist;
mod properties;
mod streaming;
mod thrust_limit;
mod warnings;

#[path = "../../test-support/test_files.rs"]
mod test_files;

/// Every `tests/*.rs` file is a module of this binary (with `autotests = false`, cargo would
/// silently build none that is left out).
#[test]
fn every_test_file_is_a_module_of_this_binary() {
    test_files::assert_every_test_file_is_a_module(env!("CARGO_MANIFEST_DIR"));
}
