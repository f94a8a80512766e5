//! How the simulated flights end, per world family (paper robot, no withheld effect): at the
//! autopilot's voltage cut-off, at the thrust limit, with exhausted electrodes, or landed; the
//! state of charge left and the last logged voltage per cell above the cut-off (ideal sensors).
//!
//! `cargo run --release -p flight-sim --example flight_ends [SEEDS]`

use std::collections::BTreeMap;

use flight_sim::{Family, FlightEnd, RobotVariant, clean_flights};

fn main() {
    let seeds: u64 = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(5);
    println!(
        "family                 flights  cutoff thrust exhausted landed   end soc p10/p50/p90   last V/cell above cut-off p50/max, mV"
    );
    for fam in Family::all() {
        if fam.robot != RobotVariant::Paper {
            continue;
        }
        let mut counts: BTreeMap<String, usize> = BTreeMap::new();
        let (mut end_soc, mut above_mv) = (Vec::new(), Vec::new());
        let cells = f64::from(fam.chemistry.cells());
        let cutoff_cell_v = fam.chemistry.cutoff_cell_v();
        for (f, t) in clean_flights(&fam, 0..seeds) {
            *counts.entry(format!("{:?}", t.end)).or_default() += 1;
            end_soc.push(t.end_soc);
            let last_v = f.last_voltage_v().unwrap_or(f64::NAN);
            above_mv.push(1e3 * (last_v / cells - cutoff_cell_v));
        }
        end_soc.sort_by(f64::total_cmp);
        above_mv.sort_by(f64::total_cmp);
        let q = |v: &[f64], p: f64| v[((v.len() - 1) as f64 * p) as usize];
        let n = |e: FlightEnd| counts.get(&format!("{e:?}")).copied().unwrap_or(0);
        println!(
            "{:<22} {:>7} {:>7} {:>6} {:>9} {:>6}   {:>6.3} {:>6.3} {:>6.3}   {:>6.0} {:>6.0}",
            fam.name(),
            end_soc.len(),
            n(FlightEnd::Cutoff),
            n(FlightEnd::ThrustLimit),
            n(FlightEnd::Exhausted),
            n(FlightEnd::Landed),
            q(&end_soc, 0.1),
            q(&end_soc, 0.5),
            q(&end_soc, 0.9),
            q(&above_mv, 0.5),
            q(&above_mv, 1.0),
        );
    }
}
