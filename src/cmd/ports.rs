//! `hoverbench ports`: the serial ports of this machine with their USB ids.

use anyhow::Result;

use crate::output::{self, Table};

/// List serial ports (with USB vendor/product ids, serial number and names where the system
/// reports them), to find the rig and the bench supply.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Print machine-readable JSON.
    #[arg(long)]
    json: bool,
}

/// Runs the subcommand.
pub fn run(args: Args) -> Result<()> {
    let ports = rig_host::link::list_ports()?;
    if args.json {
        return output::print_json(&ports);
    }
    if ports.is_empty() {
        println!("no serial ports found");
        return Ok(());
    }
    let mut t = Table::new(&[
        "port",
        "type",
        "vid:pid",
        "serial",
        "manufacturer",
        "product",
    ]);
    for p in &ports {
        t.row(vec![
            p.path.clone(),
            p.kind.to_owned(),
            match (p.vid, p.pid) {
                (Some(v), Some(d)) => format!("{v:04x}:{d:04x}"),
                _ => "-".into(),
            },
            p.serial_number.clone().unwrap_or_else(|| "-".into()),
            p.manufacturer.clone().unwrap_or_else(|| "-".into()),
            p.product.clone().unwrap_or_else(|| "-".into()),
        ]);
    }
    print!("{}", t.render());
    Ok(())
}
