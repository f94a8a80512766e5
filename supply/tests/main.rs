//! The integration tests of `supply`, one module per file, in one test binary.

mod in_process;
mod pty;
