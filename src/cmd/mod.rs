//! One module per subcommand.

use clap::Subcommand;

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
    }
}
