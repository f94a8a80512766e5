//! `hoverbench optimise`: the battery mass that maximises endurance (Fig. 4), or a catalogue
//! ranked by endurance (Fig. 5).

use std::path::PathBuf;

use anyhow::{Context, Result};
use estimator::Battery;

use crate::output::{self, ModelArgs, Table};

/// Find the ideal and realistic battery optima, or rank a battery catalogue.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    model: ModelArgs,
    /// e_D: energy density of the batteries to optimise over (Wh/kg).
    #[arg(long, value_name = "WH_PER_KG", value_parser = output::energy_density, allow_negative_numbers = true, required_unless_present_any = ["catalogue", "paper"])]
    energy_density: Option<f64>,
    /// Rank the packs of a catalogue CSV (name, cells, capacity_mah, mass_g, optional
    /// energy_wh or energy_density_wh_per_kg) instead.
    #[arg(long, value_name = "FILE", conflicts_with = "energy_density")]
    catalogue: Option<PathBuf>,
    /// Print machine-readable JSON.
    #[arg(long)]
    json: bool,
}

#[derive(serde::Serialize)]
struct Optimum {
    battery_mass_kg: f64,
    endurance_min: f64,
    battery_energy_wh: f64,
    total_mass_kg: f64,
    payload_limit_kg: Option<f64>,
}

impl From<&estimator::Optimum> for Optimum {
    fn from(o: &estimator::Optimum) -> Self {
        Self {
            battery_mass_kg: o.battery_mass_kg,
            endurance_min: o.endurance_min,
            battery_energy_wh: o.estimate.battery_energy_wh,
            total_mass_kg: o.estimate.total_mass_kg,
            payload_limit_kg: o.estimate.payload_limit_kg,
        }
    }
}

#[derive(serde::Serialize)]
struct OptimumReport<'a> {
    source: &'a output::ModelSource,
    energy_density_wh_per_kg: f64,
    ideal: Optimum,
    realistic: Option<Optimum>,
    realistic_is_limited_by_payload: bool,
    search_range_kg: (f64, f64),
}

#[derive(serde::Serialize)]
struct Ranked {
    rank: usize,
    name: String,
    cells: u8,
    capacity_mah: f64,
    mass_g: f64,
    energy_wh: f64,
    endurance_min: f64,
    over_payload_limit: bool,
    endurance_if_it_could_fly_min: f64,
}

/// Runs the subcommand.
pub fn run(args: Args) -> Result<()> {
    let (model, payload, source) = args.model.build()?;
    if let Some(path) = &args.catalogue {
        return rank(&model, &payload, &source, path, args.json);
    }
    let e_d = args
        .energy_density
        .unwrap_or(paper::FIG4_ENERGY_DENSITY_WH_PER_KG);
    let o = model.optimise_battery(e_d, &payload)?;
    let rep = OptimumReport {
        source: &source,
        energy_density_wh_per_kg: e_d,
        ideal: (&o.ideal).into(),
        realistic: o.realistic.as_ref().map(Into::into),
        realistic_is_limited_by_payload: o.realistic_is_limited,
        search_range_kg: o.search_range_kg,
    };
    if args.json {
        return output::print_json(&rep);
    }
    println!("curve: {}", source.curve);
    println!("thrust limit: {}", source.thrust_limit);
    println!(
        "batteries of {e_d} Wh/kg from {:.3} to {:.3} kg (the range the thrust curve covers)",
        o.search_range_kg.0, o.search_range_kg.1
    );
    println!();
    let mut t = Table::new(&[
        "optimum",
        "battery m_B",
        "endurance t_E",
        "take-off m_T",
        "payload limit m_X",
    ]);
    let mut row = |name: &str, o: &Optimum| {
        t.row(vec![
            name.into(),
            format!("{:.4} kg", o.battery_mass_kg),
            format!("{:.2} min", o.endurance_min),
            format!("{:.3} kg", o.total_mass_kg),
            o.payload_limit_kg
                .map_or("-".into(), |m| format!("{m:.3} kg")),
        ]);
    };
    row("ideal", &rep.ideal);
    if let Some(r) = &rep.realistic {
        row(
            if rep.realistic_is_limited_by_payload {
                "realistic (at the payload limit)"
            } else {
                "realistic (= ideal)"
            },
            r,
        );
    }
    print!("{}", t.render());
    if rep.realistic.is_none() {
        println!(
            "\nno thrust limit known: only the ideal optimum (give --thrust-limit or a params file with one)"
        );
    }
    Ok(())
}

fn rank(
    model: &estimator::Model<estimator::PolyCurve>,
    payload: &estimator::Payload,
    source: &output::ModelSource,
    path: &std::path::Path,
    json: bool,
) -> Result<()> {
    let (table, _) = import::Table::read(path)?;
    let packs = table.catalogue()?;
    let mut ranked = Vec::with_capacity(packs.len());
    for p in &packs {
        let battery = Battery::new(p.mass_g / 1000.0, p.energy_wh)?;
        let r = model
            .rank_entry(&battery, payload)
            .with_context(|| format!("{}, line {}: pack {:?}", path.display(), p.line, p.name))?;
        ranked.push(Ranked {
            rank: 0,
            name: p.name.clone(),
            cells: p.cells,
            capacity_mah: p.capacity_mah,
            mass_g: p.mass_g,
            energy_wh: p.energy_wh,
            endurance_min: r.endurance_min,
            over_payload_limit: r.over_payload_limit,
            endurance_if_it_could_fly_min: r.estimate.endurance_min,
        });
    }
    ranked.sort_by(|a, b| b.endurance_min.total_cmp(&a.endurance_min));
    for (i, r) in ranked.iter_mut().enumerate() {
        r.rank = i + 1;
    }
    if json {
        return output::print_json(&ranked);
    }
    println!("curve: {}", source.curve);
    println!("thrust limit: {}", source.thrust_limit);
    println!();
    let mut t = Table::new(&[
        "#",
        "pack",
        "cells",
        "mAh",
        "mass",
        "energy",
        "endurance t_E",
    ]);
    for r in &ranked {
        t.row(vec![
            r.rank.to_string(),
            r.name.clone(),
            format!("{}S", r.cells),
            format!("{:.0}", r.capacity_mah),
            format!("{:.0} g", r.mass_g),
            format!("{:.1} Wh", r.energy_wh),
            if r.over_payload_limit {
                format!(
                    "0 (over the payload limit; {:.2} min if it could fly)",
                    r.endurance_if_it_could_fly_min
                )
            } else {
                format!("{:.2} min", r.endurance_min)
            },
        ]);
    }
    print!("{}", t.render());
    if ranked.iter().any(|r| r.over_payload_limit) {
        println!(
            "\nPacks over the payload limit are ranked at zero endurance, as in the paper's Fig. 5."
        );
    }
    Ok(())
}
