//! The integration tests of `fit`, one module per file, in one test binary.

mod nist;
mod properties;
mod streaming;
mod thrust_limit;
mod warnings;
