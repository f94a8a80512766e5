//! The integration tests of `rig-firmware`, one module per file, in one test binary.

mod safety;
mod safety_props;
