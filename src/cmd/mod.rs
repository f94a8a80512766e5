//! One module per subcommand.

use clap::Subcommand;

pub mod battery;
pub mod characterise;
pub mod estimate;
pub mod export;
pub mod fit;
pub mod flights;
pub mod gap;
pub mod gap_eval;
pub mod gap_summary;
pub mod import;
pub mod mission;
pub mod optimise;
pub mod paper;
pub mod ports;
pub mod replay;
pub mod replay_eval;
pub mod report;
pub mod rig_gap;
pub mod rig_gap_eval;
pub mod sim_rig;
pub mod simulate_flights;
pub mod sweep;

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// The main job: nominal sweep, limit sweep, fit and params.toml in one session folder
    /// (simulated rig and supply when no ports are given).
    #[command(alias = "characterize")]
    Characterise(characterise::Args),
    /// Run one thrust-targeted sweep of a rig on a bench supply (crash-safe log, --resume).
    Sweep(sweep::Args),
    /// List serial ports with their USB ids.
    Ports(ports::Args),
    /// Fit a polynomial to a rig sweep (or any CSV) and write params.toml.
    Fit(fit::Args),
    /// Convert another thrust stand's log into a hoverbench sweep (one row per settled step).
    Import(import::Args),
    /// Estimate hover endurance for one battery and payload (eqs. 1-6).
    Estimate(estimate::Args),
    /// Write parameters for PX4, ArduPilot or C firmware from a characterisation.
    Export(export::Args),
    /// Find the battery mass that maximises endurance, or rank a battery catalogue (Fig. 4-5).
    #[command(alias = "optimize")]
    Optimise(optimise::Args),
    /// Evaluate a mission of hover and ceiling-attached segments (eqs. 7-9, Table I).
    Mission(mission::Args),
    /// Inspect flight logs: span, rate, voltage, current, energy, phases and metadata with their
    /// sources, and every skipped file with its reason.
    Flights(flights::Args),
    /// Diagnose the sim-to-real gap of a flight set: where, which effect, how far it shrinks.
    Gap(gap::Args),
    /// The gap on mission summaries (estimated vs measured endurance), e.g. the paper's Table I.
    GapSummary(gap_summary::Args),
    /// The gap diagnosis' blind study on simulated flights.
    GapEval(gap_eval::Args),
    /// Generate flight sets from the physical truth simulator (truth in a separate file).
    SimulateFlights(simulate_flights::Args),
    /// Reproduce the paper end to end from its reconstructed Fig. 3 curve.
    Paper(paper::Args),
    /// Draw the figures of a characterisation (Fig. 3-7, SVG and PNG) and an HTML report.
    Report(report::Args),
    /// Diagnose the gap between the physical motor-propeller-supply model and stand logs:
    /// where they part, which unmodelled effect causes it, how far it shrinks.
    RigGap(rig_gap::Args),
    /// The stand gap diagnosis' blind study on the stand truth simulator.
    RigGapEval(rig_gap_eval::Args),
    /// Replay flights through the online endurance estimator and its baselines (PX4, coulomb
    /// counter, static model) sample by sample, scored on flights that end at the cut-off.
    Replay(replay::Args),
    /// The pack model of a parameter file: learn it from flights into its [battery] section.
    Battery(battery::Args),
    /// The online estimator's study on simulated flights with faded, resistive or cold packs and
    /// payload changes it is not told about, per group of world families.
    ReplayEval(replay_eval::Args),
    /// Run the simulated rig (the real firmware core on simulated peripherals) behind a
    /// pseudo-terminal and print its port path.
    SimRig(sim_rig::Args),
}

/// Runs a subcommand.
pub fn run(command: Command) -> anyhow::Result<()> {
    match command {
        Command::Characterise(a) => characterise::run(a),
        Command::Sweep(a) => sweep::run(a),
        Command::Ports(a) => ports::run(a),
        Command::Fit(a) => fit::run(a),
        Command::Import(a) => import::run(a),
        Command::Estimate(a) => estimate::run(a),
        Command::Export(a) => export::run(a),
        Command::Optimise(a) => optimise::run(a),
        Command::Mission(a) => mission::run(a),
        Command::Flights(a) => flights::run(a),
        Command::Gap(a) => gap::run(a),
        Command::GapEval(a) => gap_eval::run(a),
        Command::GapSummary(a) => gap_summary::run(a),
        Command::SimulateFlights(a) => simulate_flights::run(a),
        Command::Paper(a) => paper::run(a),
        Command::Report(a) => report::run(a),
        Command::SimRig(a) => sim_rig::run(a),
        Command::RigGap(a) => rig_gap::run(a),
        Command::RigGapEval(a) => rig_gap_eval::run(a),
        Command::Replay(a) => replay::run(a),
        Command::Battery(a) => battery::run(a),
        Command::ReplayEval(a) => replay_eval::run(a),
    }
}

/// Mass options whose bare numbers are kilograms.
const MASS_FLAGS: [&str; 5] = [
    "--structure-mass",
    "--battery-mass",
    "--payload-mass",
    "--takeoff-mass",
    "--thrust-limit",
];

/// Heaviest bare mass, kg, taken at its word when a command fails: beyond it the number was more
/// likely meant in grams.
const PLAUSIBLE_BARE_MASS_KG: f64 = 20.0;

/// After a failed command: for each mass option given as a bare number too heavy to be meant in
/// kg (`--structure-mass 431`), a hint that bare numbers are kg and how to write grams.
pub fn mass_unit_hints(args: impl IntoIterator<Item = String>) -> Vec<String> {
    let args: Vec<String> = args.into_iter().collect();
    let mut hints = Vec::new();
    for (i, a) in args.iter().enumerate() {
        let (flag, value) = match a.split_once('=') {
            Some((f, v)) => (f, Some(v.to_owned())),
            None => (a.as_str(), args.get(i + 1).cloned()),
        };
        if !MASS_FLAGS.contains(&flag) {
            continue;
        }
        let Some(value) = value else { continue };
        if let Ok(v) = value.trim().parse::<f64>() {
            if v > PLAUSIBLE_BARE_MASS_KG {
                hints.push(format!(
                    "{flag} {value} is read as {value} kg (a bare number is kg); for grams write {flag} {value}g"
                ));
            }
        }
    }
    hints
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bare_heavy_masses_get_a_unit_hint() {
        let args = |s: &str| s.split(' ').map(str::to_owned).collect::<Vec<_>>();
        let h = mass_unit_hints(args("estimate --structure-mass 431 --battery-mass=144"));
        assert_eq!(
            h,
            [
                "--structure-mass 431 is read as 431 kg (a bare number is kg); for grams write --structure-mass 431g",
                "--battery-mass 144 is read as 144 kg (a bare number is kg); for grams write --battery-mass 144g",
            ]
        );
        assert!(
            mass_unit_hints(args("estimate --structure-mass 0.431 --battery-mass 144g")).is_empty()
        );
    }
}
