//! Traces the online estimator through one scenario's held-out flights: at every 5 % of each
//! flight (and at its first three samples) the predicted and true remaining time, the filter's
//! state and the motor commands' power, under flight-sim's record of the flight (its pack's
//! true capacity, state of charge from start to end, mean series resistance and power).
//! `cargo run --release -p replay-eval --example trace -- FAMILY SEED [STEP]`
//! (`SWEEP_SENSORS=ideal` and the like: calibrated sensors; `SWEEP_CFG`: the estimator's
//! settings; both as in the sweep example). `SWEEP_DROP_CURRENT=1` replays the flights without
//! their current column (a tuning family flown as a voltage-only log); `SWEEP_MOTOR_POWER=1`
//! gives the estimator the rotors' power read from the motor commands (`--motor-power`).

use replay::OnlineBuilder;
use replay::online::FileOnline;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let fam = flight_sim::Family::parse(args.get(1).map_or("lipo/fc-10hz/paper", String::as_str))
        .expect("a family");
    let seed: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(0);
    let step: f64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(0.05);
    let sensors = std::env::var("SWEEP_SENSORS").map_or(flight_sim::SensorErrors::Drawn, |s| {
        flight_sim::SensorErrors::parse(&s).expect("drawn, ideal-voltage, ideal-current or ideal")
    });
    let p = replay_eval::prepare_scenario_with(&fam, seed, sensors).expect("scenario");
    println!("seed {seed} {} {:?}", fam.name(), p.condition);
    for k in &p.packs {
        println!("  pack {k:?}");
    }
    let config = std::env::var("SWEEP_CFG").map_or_else(
        |_| estimator::online::OnlineConfig::default(),
        |s| replay_eval::config_from_spec(&s).expect("SWEEP_CFG"),
    );
    let drop_current = std::env::var("SWEEP_DROP_CURRENT").is_ok_and(|v| v == "1");
    let motor_map = p
        .params
        .motor
        .filter(|_| std::env::var("SWEEP_MOTOR_POWER").is_ok_and(|v| v == "1"));
    for (k, (flight, battery)) in p.flights.iter().enumerate() {
        let truth = &p.truths[k];
        let mut flight = flight.clone();
        if drop_current {
            flight.samples.current_a = None;
        }
        let flight = &flight;
        let Ok(span) = replay::cutoff::detect(flight) else {
            continue;
        };
        let setup = replay::FlightSetup::of(flight);
        let plan = replay::methods::mission_plan(flight, &span);
        let online = FileOnline::new(p.online_params(), *battery, config);
        let mut pred = online.build(&setup, &plan, span.takeoff_s).expect("online");
        let static_end =
            replay::methods::StaticModel::new(&p.params, &setup, &plan, span.takeoff_s)
                .map(|m| m.predicted_end_s())
                .unwrap_or(f64::NAN);
        println!(
            "{}: {:.0} s flight, static end error {:+.1} %, pack {:.3} Ah, R {:.4} ohm/cell, chem {:?}",
            flight.name,
            span.duration_s(),
            (static_end - span.end_s) / span.duration_s() * 100.0,
            battery.rated_capacity_ah,
            battery.series_resistance_cell_ohm,
            battery.chemistry
        );
        println!(
            "  truth: capacity {:.3} Ah, soc {:.3} -> {:.3}, series {:.4} ohm, power {:.1} W (hover {:.1} W)",
            truth.capacity_ah,
            truth.start_soc,
            truth.end_soc,
            truth.mean_airborne_series_ohm,
            truth.mean_airborne_power_w,
            truth.mean_hover_power_w,
        );
        println!(
            "  ocv {:?} rc {:.4}/{:.0}s cutoff {:.3}",
            battery.ocv_cell_v.map(|v| (v * 1000.0).round() / 1000.0),
            battery.rc_resistance_cell_ohm,
            battery.rc_time_constant_s,
            battery.cutoff_cell_v
        );
        println!(
            "  frac      t   true   pred  sigma  err%    V      I phase   | soc   cap_ah  r_ohm  extra_w  bias_v  Ah_used  motor_w"
        );
        let s = &flight.samples;
        let mut next = 0.0;
        let mut used_ah = 0.0;
        for k in 0..s.len() {
            if k > 0 {
                if let Some(c) = s.current_a.as_ref() {
                    used_ah += c[k] * (s.time_s[k] - s.time_s[k - 1]) / 3600.0;
                }
            }
            let t = s.time_s[k];
            if t > span.end_s {
                break;
            }
            let sample = replay::Sample {
                time_s: t,
                voltage_v: s.voltage_v[k],
                current_a: s.current_a.as_ref().map(|c| c[k]),
                phase: s.phase.as_ref().map(|p| p[k]),
                motor_power_w: motor_map.as_ref().and_then(|m| {
                    let us: Vec<f64> = s.motor_us.as_ref()?.iter().map(|c| c[k]).collect();
                    m.total_power_w(&us, s.voltage_v[k]).ok()
                }),
            };
            let r = pred.update(&sample);
            let frac = (t - span.takeoff_s) / span.duration_s();
            // The first three samples too (where the filter starts).
            if frac >= next || k < 3 {
                if frac >= next {
                    next += step;
                }
                let st = pred.final_state();
                let get = |n: &str| st.iter().find(|x| x.0 == n).map_or(f64::NAN, |x| x.1);
                let (pr, sg) = r.map_or((f64::NAN, f64::NAN), |r| {
                    (r.remaining_s, r.sigma_s.unwrap_or(f64::NAN))
                });
                let tr = span.end_s - t;
                println!(
                    "  {frac:4.2} {t:7.0} {tr:6.0} {pr:6.0} {sg:6.0} {:+5.1} {:6.2} {:6.2} {:8} | {:.3} {:.3} {:.4} {:+.2} {:+.3} {:.3} {:6.1}",
                    (pr - tr) / span.duration_s() * 100.0,
                    sample.voltage_v,
                    sample.current_a.unwrap_or(f64::NAN),
                    sample.phase.map_or("-", |p| p.name()),
                    get("soc"),
                    get("usable_capacity_ah"),
                    get("series_resistance_ohm"),
                    get("extra_power_w"),
                    get("curve_offset_v"),
                    used_ah,
                    sample.motor_power_w.unwrap_or(f64::NAN),
                );
            }
        }
    }
}
