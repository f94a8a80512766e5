//! The integration tests of `reports`, one module per file, in one test binary.

mod figures;
mod report;
