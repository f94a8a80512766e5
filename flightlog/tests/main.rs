//! The integration tests of `flightlog`, one module per file, in one test binary:
//! one link instead of one per file, and the tests of every file run in parallel (cargo
//! runs test binaries one after another).
//! Run one file's tests with `cargo test -p flightlog --test integration <file>::`.
//!
//! A new file `tests/<file>.rs` is added below as `#[path = "<file>.rs"] mod <file>;`: loaded
//! by path, a file keeps its own `mod common;` (found in `tests/common/`), as it had when it
//! was a test binary of its own. The last test below fails for a file left out.

// Each file loaded by path compiles its own copy of the small `tests/common/`, as each did as a
// binary of its own; the files stay unchanged.
#![allow(clippy::duplicate_mod)]

#[path = "crazyflie.rs"]
mod crazyflie;
#[path = "dataflash.rs"]
mod dataflash;
#[path = "dataflash_text.rs"]
mod dataflash_text;
#[path = "motors.rs"]
mod motors;
#[path = "never_panics.rs"]
mod never_panics;
#[path = "real_logs.rs"]
mod real_logs;
#[path = "real_text_logs.rs"]
mod real_text_logs;
#[path = "real_tlogs.rs"]
mod real_tlogs;
#[path = "set.rs"]
mod set;
#[path = "ulog.rs"]
mod ulog;

#[path = "../../test-support/test_files.rs"]
mod test_files;

/// Every `tests/*.rs` file is a module of this binary (with `autotests = false`, cargo would
/// silently build none that is left out).
#[test]
fn every_test_file_is_a_module_of_this_binary() {
    test_files::assert_every_test_file_is_a_module(env!("CARGO_MANIFEST_DIR"));
}
