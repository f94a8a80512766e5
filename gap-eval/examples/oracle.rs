//! The oracle-battery budget of the blind study (issue 9): the study as `hoverbench gap-eval
//! --json` prints it, with the switch of [`gap_eval::oracle`] read from
//! `GAP_EVAL_BATTERY_ORACLE` (`off`, `ocv`, `ocv+all`); or, with `curves`, how far each learned
//! curve is from the truth's (one JSON line per battery type).
//!
//! `GAP_EVAL_BATTERY_ORACLE=ocv cargo run --release -p gap-eval --example oracle -- study
//! tuning 0 40 > ocv.json`; `cargo run --release -p gap-eval --example oracle -- curves
//! tuning 0 40`.

use gap_eval::oracle::{BatteryOracle, curve_errors};
use gap_eval::{StudyOptions, select_families, study_with_oracle};

fn main() {
    if let Err(e) = run() {
        eprintln!("error: {e}");
        std::process::exit(2);
    }
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [mode, filter, start, count] = args.as_slice() else {
        return Err("usage: oracle study|curves FAMILIES SEED_START COUNT".into());
    };
    let start: u64 = start.parse().map_err(|e| format!("{start}: {e}"))?;
    let count: u64 = count.parse().map_err(|e| format!("{count}: {e}"))?;
    let families = select_families(filter).map_err(|e| e.to_string())?;
    match mode.as_str() {
        "study" => {
            let oracle = BatteryOracle::from_env()?;
            eprintln!("battery oracle: {}", oracle.name());
            let opts = StudyOptions {
                seeds: start..start + count,
                families,
                ..StudyOptions::default()
            };
            let rep = study_with_oracle(&opts, oracle, &|n| eprint!("\r{n}/{count}"))
                .map_err(|e| e.to_string())?;
            eprintln!();
            println!(
                "{}",
                serde_json::to_string_pretty(&rep).map_err(|e| e.to_string())?
            );
        }
        "curves" => {
            for seed in start..start + count {
                match curve_errors(seed, &families) {
                    Ok(rows) => {
                        for r in rows {
                            println!("{}", serde_json::to_string(&r).map_err(|e| e.to_string())?);
                        }
                    }
                    Err(e) => eprintln!("seed {seed}: {e}"),
                }
            }
        }
        m => return Err(format!("unknown mode {m:?}: study or curves")),
    }
    Ok(())
}
