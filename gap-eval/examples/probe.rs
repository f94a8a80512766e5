//! Prints scenarios one line each (development aid for tuning on the tuning families; the
//! user-facing command is `hoverbench gap-eval`).
//!
//! `cargo run --release -p gap-eval --example probe -- FAMILIES SEED…`, e.g. `tuning 1 2 3`.

fn main() {
    let mut args = std::env::args().skip(1);
    let filter = args.next().unwrap_or_else(|| "tuning".to_owned());
    let families = match gap_eval::select_families(&filter) {
        Ok(f) => f,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(2);
        }
    };
    for seed in args.filter_map(|a| a.parse::<u64>().ok()) {
        match gap_eval::run_scenario(seed, &families) {
            Ok(s) => println!(
                "{:5} {:24} {:18} {:9.4} {:14} impact {:7.2} %  -> {:56} {}  held-out endurance {:?} -> {:?}{}",
                s.seed,
                s.family,
                s.truth,
                s.magnitude,
                s.unit,
                s.impact_pct,
                s.verdict,
                if !s.strict_scored {
                    "n/a"
                } else if s.strict_correct {
                    "ok "
                } else {
                    "BAD"
                },
                s.heldout_endurance_before_pct,
                s.heldout_endurance_after_pct,
                s.miss.as_ref().map_or(String::new(), |m| format!(
                    "  missed: {} ({})",
                    m.cause.name(),
                    m.detail
                ))
            ),
            Err(e) => println!("{seed:5} failed: {e}"),
        }
    }
}
