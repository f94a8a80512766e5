//! The blind study's speed: 200 scenarios over every world family on 2 threads, as
//! `hoverbench gap-eval --scenarios 200` runs them (target: under 2 minutes on 2 cores).
//!
//! `cargo bench -p gap-eval` (release profile). `GAP_EVAL_BENCH_SCENARIOS` changes the count.

use std::time::Instant;

use gap_eval::{StudyOptions, study};

fn main() {
    let n: u64 = std::env::var("GAP_EVAL_BENCH_SCENARIOS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(200);
    let opts = StudyOptions {
        seeds: 0..n,
        ..StudyOptions::default()
    };
    let t0 = Instant::now();
    let rep = match study(&opts, &|_| {}) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("study failed: {e}");
            std::process::exit(1);
        }
    };
    let s = t0.elapsed().as_secs_f64();
    println!(
        "gap-eval study: {} scenarios ({} failed) on {} threads in {s:.1} s ({:.2} s per scenario); target < 120 s for 200",
        rep.scenarios.len(),
        rep.failed.len(),
        opts.threads,
        s / n.max(1) as f64
    );
}
