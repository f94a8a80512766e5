//! Diagnoses one training log against one held-out log with a chosen candidate list and
//! prints every candidate's scores and the selected parameters (a debugging aid):
//! `cargo run -p rig-gap --example candidates -- TRAIN.csv HELDOUT.csv [EFFECT…]`.

use import::stand::{StandLog, StandOptions};
use motor_model::Effect;
use rig_gap::diagnose::{Options, diagnose};
use rig_gap::runs_of_log;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 2 {
        return Err("usage: probe TRAIN.csv HELDOUT.csv [EFFECT…]".into());
    }
    let read = |p: &str| -> Result<_, Box<dyn std::error::Error>> {
        let log = StandLog::read(std::path::Path::new(p), &StandOptions::default())?;
        Ok(runs_of_log(&log)?)
    };
    let mut opts = Options::default();
    if args.len() > 2 {
        opts.candidates = args[2..]
            .iter()
            .map(|n| Effect::from_name(n).ok_or(format!("unknown effect {n}")))
            .collect::<Result<_, _>>()?;
    }
    let (train, held) = (read(&args[0])?, read(&args[1])?);
    if std::env::var_os("PROBE_STEPS").is_some() {
        for r in train.iter().chain(&held) {
            println!("{} tared at {} s", r.name(), r.sweep.tare_time_s);
            for o in &r.sweep.steps {
                println!("  t {} s thrust {} g", o.time_s, o.thrust_g);
            }
        }
    }
    let d = diagnose(&train, &held, &opts)?;
    println!("verdict {:?}", d.verdict);
    for c in &d.candidates {
        println!(
            "{:?} ΔBIC {:.1} held-out χ² {:.2} {:?}",
            c.effects, c.delta_bic, c.heldout_chi2_per_obs, c.rejected_because
        );
        println!("    held out by quantity {:?}", c.heldout_chi2_by_quantity);
        for (k, v) in &c.parameters {
            println!("    {k} = {:.4} ± {:.4}", v.value, v.std_error);
        }
    }
    println!("before {:?}", d.baseline.heldout_chi2_by_quantity);
    println!("after  {:?}", d.after.heldout_chi2_by_quantity);
    for (k, v) in &d.after.parameters {
        println!("{k} = {} ± {}", v.value, v.std_error);
    }
    for n in &d.notes {
        println!("note: {n}");
    }
    Ok(())
}
