//! The oracle error budget (`replay_eval::oracle`): every scenario of a seed range prepared
//! once per sensor choice and replayed with each oracle, one file per oracle in `OUT_DIR`
//! holding the group table and the per-flight lines (`sweep`'s format with `SWEEP_FLIGHTS=1`,
//! so `sweep` outputs and these compare line by line):
//! `cargo run --release -p replay-eval --example budget -- FAMILIES FIRST_SEED COUNT OUT_DIR [ORACLE…]`
//! (default oracles: nothing, each term alone, all, and all but each term).

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 5 {
        eprintln!("usage: budget FAMILIES FIRST_SEED COUNT OUT_DIR [ORACLE…]");
        std::process::exit(2);
    }
    let families = replay_eval::select_families(&args[1]).expect("families");
    let first: u64 = args[2].parse().expect("first seed");
    let count: u64 = args[3].parse().expect("count");
    let out = std::path::PathBuf::from(&args[4]);
    std::fs::create_dir_all(&out).expect("output folder");
    let oracles: Vec<replay_eval::Oracle> = if args.len() > 5 {
        args[5..]
            .iter()
            .map(|s| replay_eval::Oracle::parse(s).expect("oracle"))
            .collect()
    } else {
        replay_eval::Oracle::budget_set()
    };
    let opts = replay_eval::StudyOptions {
        seeds: first..first + count,
        families,
        threads: 2,
        config: estimator::online::OnlineConfig::default(),
        pack_history: false,
        voltage_only: false,
        motor_power: false,
    };
    let done = std::sync::atomic::AtomicUsize::new(0);
    let studies = replay_eval::study_oracles(&opts, &oracles, &|| {
        let n = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        eprintln!("{n}/{count} scenarios");
    });
    for (o, study) in oracles.iter().zip(&studies) {
        let text = replay_eval::table(study) + &replay_eval::flight_lines(study);
        std::fs::write(out.join(format!("{}.txt", o.name())), text).expect("write");
    }
}
