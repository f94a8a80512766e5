//! Times the drivers against the simulated supply on a pseudo-terminal, both dialects with
//! their default configurations: `cargo run -p supply --example latency`.

use std::error::Error;
use std::time::{Duration, Instant};

use supply::sim::{Dialect, ResistiveLoad, SimConfig, SimulatedSupply};
use supply::{KoradConfig, KoradSupply, ScpiConfig, ScpiSupply, SerialSettings, Supply};

const ROUNDS: u32 = 10;

fn time<S: Supply + ?Sized>(
    psu: &mut S,
    what: &str,
    mut op: impl FnMut(&mut S) -> Result<(), supply::SupplyError>,
) -> Result<(), Box<dyn Error>> {
    let mut total = Duration::ZERO;
    let mut worst = Duration::ZERO;
    for _ in 0..ROUNDS {
        let start = Instant::now();
        op(psu)?;
        let d = start.elapsed();
        total += d;
        worst = worst.max(d);
    }
    println!(
        "  {what:<28} mean {:>7.2} ms   max {:>7.2} ms",
        total.as_secs_f64() * 1e3 / f64::from(ROUNDS),
        worst.as_secs_f64() * 1e3
    );
    Ok(())
}

fn run(psu: &mut dyn Supply) -> Result<(), Box<dyn Error>> {
    time(psu, "identify", |p| p.identify().map(drop))?;
    time(psu, "set voltage (verified)", |p| p.set_voltage(12.0))?;
    time(psu, "set current limit (verified)", |p| {
        p.set_current_limit(2.0)
    })?;
    time(psu, "output on (verified)", |p| p.set_output(true))?;
    time(psu, "measure V and I", |p| p.measure().map(drop))?;
    time(psu, "regulation mode", |p| p.mode().map(drop))?;
    Ok(())
}

fn main() -> Result<(), Box<dyn Error>> {
    let load = ResistiveLoad {
        resistance_ohm: 10.0,
    };
    for dialect in [Dialect::Scpi, Dialect::Korad] {
        let sim = SimulatedSupply::spawn(dialect, load, SimConfig::default())?;
        println!("{dialect:?} on {}", sim.port_path());
        let mut psu: Box<dyn Supply> = match dialect {
            Dialect::Scpi => Box::new(ScpiSupply::open(
                sim.port_path(),
                SerialSettings::default(),
                ScpiConfig::default(),
            )?),
            Dialect::Korad => Box::new(KoradSupply::open(
                sim.port_path(),
                SerialSettings::default(),
                KoradConfig::default(),
            )?),
        };
        run(psu.as_mut())?;
        let stats = sim.device().stats();
        println!(
            "  simulator: {} commands, {} replies, {} pacing violations, shortest gap {:?}",
            stats.commands, stats.replies, stats.pacing_violations, stats.min_command_gap
        );
    }
    Ok(())
}
