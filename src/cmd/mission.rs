//! `hoverbench mission`: a plan of hover and ceiling-attached segments (eqs. 7–9).

use anyhow::{Context, Result};
use estimator::{Battery, Eq8Form, MissionOptions, Segment};

use crate::output::{self, ModelArgs, Table};

/// Which form of eq. (8).
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
enum Eq8 {
    /// r_Ep = r_E - t_A/t_C: the energy balance (default).
    Consistent,
    /// r_Ep = r_E - t_E·t_A/t_C with times in hours, as printed in the paper (Table I's 103.3 min).
    Printed,
}

/// Evaluate a mission plan: energy used and left, and the reserved endurance t_R, per segment.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    model: ModelArgs,
    /// The plan, e.g. "3x(hover 2m; attach 30m); hover until empty". Segments: hover DURATION,
    /// attach DURATION, hover until reserve N%, attach until reserve N%, hover until empty
    /// (`fly` is read as hover; `perch` and `attached` as attach).
    #[arg(long, value_name = "PLAN")]
    plan: String,
    /// m_B: battery mass (kg; or e.g. 144g).
    #[arg(long, value_name = "MASS", value_parser = output::positive_mass_kg, allow_negative_numbers = true)]
    battery_mass: f64,
    /// e_D: battery energy density (Wh/kg).
    #[arg(long, value_name = "WH_PER_KG", value_parser = output::energy_density, allow_negative_numbers = true, required_unless_present = "battery_energy", conflicts_with = "battery_energy")]
    energy_density: Option<f64>,
    /// c_B: battery energy (Wh), instead of --energy-density.
    #[arg(long, value_name = "WH", value_parser = output::energy_wh, allow_negative_numbers = true)]
    battery_energy: Option<f64>,
    /// Form of eq. (8).
    #[arg(long, value_enum, default_value = "consistent")]
    eq8: Eq8,
    /// Never plan below this fraction of the battery (e.g. 10%).
    #[arg(long, value_name = "FRACTION", value_parser = output::fraction, allow_negative_numbers = true, default_value = "0")]
    reserve_floor: f64,
    /// Print machine-readable JSON.
    #[arg(long)]
    json: bool,
}

#[derive(serde::Serialize)]
struct SegmentRow {
    segment: String,
    start_min: f64,
    duration_min: f64,
    energy_used_wh: f64,
    energy_left_wh: f64,
    post_ceiling_ratio: f64,
    reserved_endurance_min: f64,
}

#[derive(serde::Serialize)]
struct Depletion {
    segment_index: usize,
    segment: String,
    at_min: f64,
    hit_reserve_floor: bool,
}

#[derive(serde::Serialize)]
struct Report<'a> {
    source: &'a output::ModelSource,
    eq8: &'static str,
    total_min: f64,
    flight_min: f64,
    attached_min: f64,
    energy_left_wh: f64,
    flight_endurance_min: f64,
    ceiling_endurance_min: f64,
    depletion: Option<Depletion>,
    segments: Vec<SegmentRow>,
}

fn describe(s: &Segment) -> String {
    match *s {
        Segment::Hover { duration_min } => format!("hover {duration_min} min"),
        Segment::Attached { duration_min } => format!("attach {duration_min} min"),
        Segment::HoverUntilReserve { reserve_fraction } => {
            format!("hover until reserve {}%", reserve_fraction * 100.0)
        }
        Segment::AttachedUntilReserve { reserve_fraction } => {
            format!("attach until reserve {}%", reserve_fraction * 100.0)
        }
        Segment::HoverUntilEmpty => "hover until empty".into(),
    }
}

/// Runs the subcommand.
pub fn run(args: Args) -> Result<()> {
    let plan = estimator::plan::parse_plan(&args.plan).context("--plan")?;
    let (model, payload, source) = args.model.build()?;
    let battery = match (args.energy_density, args.battery_energy) {
        (_, Some(wh)) => Battery::new(args.battery_mass, wh)?,
        (Some(d), None) => Battery::from_density(args.battery_mass, d)?,
        (None, None) => anyhow::bail!("give --energy-density or --battery-energy"),
    };
    let (eq8, eq8_name) = match args.eq8 {
        Eq8::Consistent => (Eq8Form::Consistent, "consistent"),
        Eq8::Printed => (Eq8Form::PrintedHours, "printed"),
    };
    let options = MissionOptions {
        eq8,
        reserve_floor_fraction: args.reserve_floor,
    };
    let (summary, outcomes) = model.evaluate_mission_vec(&battery, &payload, &plan, &options)?;
    let rep = Report {
        source: &source,
        eq8: eq8_name,
        total_min: summary.total_min,
        flight_min: summary.flight_min,
        attached_min: summary.attached_min,
        energy_left_wh: summary.energy_left_wh,
        flight_endurance_min: summary.estimate.endurance_min,
        ceiling_endurance_min: summary.estimate.ceiling_endurance_min,
        depletion: summary.depletion.map(|d| Depletion {
            segment_index: d.segment_index,
            segment: describe(&plan[d.segment_index]),
            at_min: d.at_min,
            hit_reserve_floor: d.hit_reserve_floor,
        }),
        segments: outcomes
            .iter()
            .map(|o| SegmentRow {
                segment: describe(&o.segment),
                start_min: o.start_min,
                duration_min: o.duration_min,
                energy_used_wh: o.energy_used_wh,
                energy_left_wh: o.energy_left_wh,
                post_ceiling_ratio: o.post_ceiling_ratio,
                reserved_endurance_min: o.reserved_endurance_min,
            })
            .collect(),
    };
    if args.json {
        return output::print_json(&rep);
    }
    println!("curve: {}", source.curve);
    println!(
        "battery {:.2} Wh: t_E = {:.2} min hovering (eq. 4), t_C = {:.1} min attached (eq. 6); eq. (8) {}",
        battery.energy_wh, rep.flight_endurance_min, rep.ceiling_endurance_min, eq8_name
    );
    println!();
    let mut t = Table::new(&[
        "#", "segment", "start", "duration", "used", "left", "r_Ep", "t_R",
    ]);
    for (i, s) in rep.segments.iter().enumerate() {
        t.row(vec![
            (i + 1).to_string(),
            s.segment.clone(),
            format!("{:.2} min", s.start_min),
            format!("{:.2} min", s.duration_min),
            format!("{:.3} Wh", s.energy_used_wh),
            format!("{:.3} Wh", s.energy_left_wh),
            format!("{:.4}", s.post_ceiling_ratio),
            format!("{:.2} min", s.reserved_endurance_min),
        ]);
    }
    print!("{}", t.render());
    println!();
    println!(
        "total {:.2} min ({:.2} min flying, {:.2} min attached), {:.3} Wh left",
        rep.total_min, rep.flight_min, rep.attached_min, rep.energy_left_wh
    );
    if let Some(d) = &rep.depletion {
        println!(
            "warning: the plan runs out{} during segment {} ({}) at minute {:.2}; later segments were not flown",
            if d.hit_reserve_floor {
                " (reaches the reserve floor)"
            } else {
                ""
            },
            d.segment_index + 1,
            d.segment,
            d.at_min
        );
    }
    Ok(())
}
