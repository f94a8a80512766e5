//! Analysis of the thrust-limit end (issue 14), not a study: for every replayed flight of a seed
//! range, how it really ended (flight-sim's record: for the analysis only, nothing of it reaches
//! the estimator), the last logged voltage, the logged air density, and the error at 50 % of
//! two configurations (at 50 %, or at the checkpoint `DIAG_CHECKPOINT`: 0–3 for 25, 50, 75, 90 %) (`DIAG_A`, `DIAG_B`: `SWEEP_CFG` specs; by default the thrust-limit end
//! off and the defaults), with the estimator's own thrust model at the last voltage: the
//! floor voltage where the rig's `T_L·(V/V_L)^k` meets the declared hover thrust, and the
//! ratio of that maximum thrust to the hover thrust at the last logged voltage.
//! `cargo run --release -p replay-eval --example tle_diag -- FAMILIES FIRST COUNT`.

use estimator::PowerCurve;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (families, seeds) = replay_eval::families_and_seeds(&args).expect("families");
    let cfg = |k: &str, d: &str| {
        replay_eval::config_from_spec(&std::env::var(k).unwrap_or_else(|_| d.to_owned())).expect(k)
    };
    let a = cfg("DIAG_A", "thrust_limit_end=0");
    let b = cfg("DIAG_B", "");
    let seeds: Vec<u64> = seeds.collect();
    let lines: Vec<String> = std::thread::scope(|scope| {
        let hs: Vec<_> = (0..2)
            .map(|t| {
                let seeds = &seeds;
                let families = &families;
                scope.spawn(move || {
                    let mut out = Vec::new();
                    for &s in seeds.iter().skip(t).step_by(2) {
                        let fam = replay_eval::family_of(s, families);
                        let Ok(p) = replay_eval::prepare_scenario(&fam, s) else {
                            continue;
                        };
                        let ra = replay_eval::replay_scenario(&p, &a);
                        let rb = replay_eval::replay_scenario(&p, &b);
                        for (k, (flight, _)) in p.flights.iter().enumerate() {
                            let truth = &p.truths[k];
                            let fa = ra.flights.iter().find(|f| f.name == flight.name);
                            let fb = rb.flights.iter().find(|f| f.name == flight.name);
                            let (Some(fa), Some(fb)) = (fa, fb) else { continue };
                            let cp: usize = std::env::var("DIAG_CHECKPOINT")
                                .ok()
                                .and_then(|s| s.parse().ok())
                                .unwrap_or(1);
                            let e = |f: &replay::FlightReplay| {
                                let c = &f.checkpoints[cp];
                                c.predicted_remaining_s.map_or(f64::NAN, |p| {
                                    (p - c.true_remaining_s) / f.duration_s() * 100.0
                                })
                            };
                            let sg = |f: &replay::FlightReplay| {
                                f.checkpoints[cp].sigma_s.unwrap_or(f64::NAN) / f.duration_s()
                                    * 100.0
                            };
                            let v = &flight.samples.voltage_v;
                            let tt = &flight.samples.time_s;
                            let end_idx = tt.iter().rposition(|&t| t <= fa.end_s).unwrap_or(0);
                            let v_end = v[end_idx];
                            let m = &flight.meta;
                            let mass = m.structure_mass_kg.unwrap_or(f64::NAN)
                                + m.battery_mass_kg.unwrap_or(f64::NAN)
                                + m.payload_mass_kg.unwrap_or(0.0);
                            // The estimator's own thrust model (`thrust_end`): T_L·(V/V_L)^k.
                            let op = p.online_params();
                            let (ratio, floor) = op.thrust_limit.map_or((f64::NAN, f64::NAN), |l| {
                                let top = op.curve.valid_range_g().1;
                                let vs = op.curve.supply_voltage_v().unwrap_or(12.5);
                                let k = ((top / l.per_rotor_g).ln() / (vs / l.supply_voltage_v).ln())
                                    .clamp(1.0, 3.0);
                                let hover = mass * 1000.0 / f64::from(op.rotor_count);
                                let tmax = l.per_rotor_g * (v_end / l.supply_voltage_v).powf(k);
                                (
                                    tmax / hover,
                                    l.supply_voltage_v * (hover / l.per_rotor_g).powf(1.0 / k),
                                )
                            });
                            out.push((
                                s,
                                format!(
                                    "{s:5} {:22} {:18} {:14} end {:11} soc {:+.3} rho {:.3} m {:.3} v_end {:6.2} cut {:5.2} floor {:5.2} Tmax/hover {:.3} A {:+6.1} ({:4.1}) B {:+6.1} ({:4.1}) d {:+5.1}",
                                    fam.name(),
                                    p.condition.name(),
                                    flight.name,
                                    format!("{:?}", truth.end),
                                    truth.end_soc,
                                    m.air_density_kg_m3.unwrap_or(f64::NAN),
                                    mass,
                                    v_end,
                                    m.cutoff_voltage_v.unwrap_or(f64::NAN),
                                    floor,
                                    ratio,
                                    e(fa),
                                    sg(fa),
                                    e(fb),
                                    sg(fb),
                                    e(fb).abs() - e(fa).abs(),
                                ),
                            ));
                        }
                    }
                    out
                })
            })
            .collect();
        let mut all: Vec<(u64, String)> = hs.into_iter().flat_map(|h| h.join().unwrap()).collect();
        all.sort_by_key(|x| x.0);
        all.into_iter().map(|x| x.1).collect()
    });
    for l in lines {
        println!("{l}");
    }
}
