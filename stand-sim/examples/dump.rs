//! Writes one scenario's training and held-out logs as CSV files, to look at or to feed to
//! `hoverbench rig-gap` by hand:
//! `cargo run -p stand-sim --example dump -- SEED DIR` → `DIR/train-SEED.csv`,
//! `DIR/heldout-SEED.csv`, and the truth on stdout.

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let seed: u64 = args.next().ok_or("usage: dump SEED DIR")?.parse()?;
    let dir = std::path::PathBuf::from(args.next().ok_or("usage: dump SEED DIR")?);
    std::fs::create_dir_all(&dir)?;
    let s = stand_sim::Scenario::draw(seed);
    std::fs::write(dir.join(format!("train-{seed}.csv")), &s.train_csv)?;
    std::fs::write(dir.join(format!("heldout-{seed}.csv")), &s.heldout_csv)?;
    println!(
        "seed {seed}: truth {} magnitude {:.2} fitted impact {:.2} %",
        s.truth.label(),
        s.magnitude,
        100.0 * s.power_impact
    );
    Ok(())
}
