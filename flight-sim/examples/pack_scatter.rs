//! How far the simulator's drawn packs lie from their chemistry's curve, and how many draws
//! the electrodes cannot reach (those are drawn again by the simulator).
//!
//! `cargo run --release -p flight-sim --example pack_scatter [DRAWS]`

use flight_sim::Chemistry;
use flight_sim::ocv::{OcvCurve, OcvScatter};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn main() {
    let draws: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(20_000);
    println!(
        "chemistry  draws  unreachable  RMS off nominal 10–95 % (p50 / p90 / max, mV)  worst |Δ| mV"
    );
    for chem in Chemistry::ALL {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let nominal = OcvCurve::new(chem, OcvScatter::NONE);
        let (mut rms, mut worst, mut bad) = (Vec::new(), 0.0f64, 0usize);
        for _ in 0..draws {
            let Ok(c) = OcvCurve::try_new(chem, OcvScatter::draw(&mut rng)) else {
                bad += 1;
                continue;
            };
            let d: Vec<f64> = (10..=95)
                .map(|k| c.at(f64::from(k) / 100.0) - nominal.at(f64::from(k) / 100.0))
                .collect();
            worst = d.iter().fold(worst, |w, x| w.max(x.abs()));
            rms.push((d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64).sqrt());
        }
        rms.sort_by(f64::total_cmp);
        let q = |p: f64| 1e3 * rms[((rms.len() - 1) as f64 * p) as usize];
        println!(
            "{:<9} {draws:>6} {bad:>12}  {:>6.1} / {:>6.1} / {:>6.1}  {:>12.1}",
            format!("{chem:?}"),
            q(0.5),
            q(0.9),
            q(1.0),
            1e3 * worst
        );
    }
}
