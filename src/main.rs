//! `hoverbench`: from the thrust bench to a trustworthy endurance figure.
//!
//! A thin front end: each subcommand lives in `src/cmd/<name>.rs` with a clap `Args` struct and a
//! `run()`; the domain logic is in the library crates. Errors print as a chain and exit with
//! code 2 (bad input or a failed session); clap's usage errors exit with 2 too.

use std::process::ExitCode;

use clap::Parser;

mod cmd;
mod output;
mod overlap;

/// Thrust-bench characterisation, endurance estimation and sim-to-real diagnosis for hovering
/// robots.
#[derive(Debug, Parser)]
#[command(name = "hoverbench", version, about, long_about = None, max_term_width = 100)]
struct Cli {
    #[command(subcommand)]
    command: cmd::Command,
}

/// Restores the default SIGPIPE action, so that `hoverbench … | head` ends quietly like any
/// Unix tool instead of failing to print (Rust ignores SIGPIPE by default).
#[cfg(unix)]
#[allow(unsafe_code)]
fn restore_sigpipe() {
    // SAFETY: setting a signal's disposition to the default at start-up, before any other
    // thread exists, has no memory-safety preconditions.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

#[cfg(not(unix))]
fn restore_sigpipe() {}

fn main() -> ExitCode {
    restore_sigpipe();
    let cli = Cli::parse();
    match cmd::run(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            for cause in e.chain().skip(1) {
                eprintln!("  caused by: {cause}");
            }
            for hint in cmd::mass_unit_hints(std::env::args().skip(1)) {
                eprintln!("hint: {hint}");
            }
            ExitCode::from(2)
        }
    }
}
