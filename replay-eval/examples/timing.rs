//! Times the stages of one scenario: `cargo run --release -p replay-eval --example timing -- FAMILY SEED`.

use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let fam = flight_sim::Family::parse(args.get(1).map_or("lipo/fc-10hz/paper", String::as_str))
        .expect("a family");
    let seed: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(0);
    let t = Instant::now();
    let r = replay_eval::run_scenario(&fam, seed, &estimator::online::OnlineConfig::default());
    println!(
        "{:?} in {:.2} s",
        r.map(|o| (o.condition, o.flights.len())),
        t.elapsed().as_secs_f64()
    );
}
