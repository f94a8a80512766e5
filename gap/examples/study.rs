//! Runs a small blind study and prints the summary (development aid; `hoverbench gap-eval` is
//! the user-facing command).
fn main() {
    let args: Vec<u64> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let (start, n) = (
        args.first().copied().unwrap_or(1000),
        args.get(1).copied().unwrap_or(40),
    );
    let robot = gap::truth::Robot::paper();
    let curve = gap::eval::rig_curve(&robot).expect("rig curve");
    let t0 = std::time::Instant::now();
    let rep = gap::eval::study(
        &robot,
        &curve,
        4,
        start..start + n,
        &Default::default(),
        2,
        &|_| {},
    );
    for s in &rep.scenarios {
        println!(
            "{:5} {:20} mag {:8.4} impact {:6.2}%  -> {:28} {}  held {:.2} -> {:.2}",
            s.seed,
            s.truth,
            s.magnitude,
            s.impact_pct,
            s.verdict,
            if s.correct { "ok " } else { "BAD" },
            s.heldout_before,
            s.heldout_after
        );
    }
    println!(
        "single≥2%: {:?}  fp none: {:?}  ool unexplained: {:?}  median shrink: {:?}",
        rep.single_effect_accuracy_2pct,
        rep.false_positive_rate_none,
        rep.unexplained_rate_out_of_library,
        rep.median_shrinkage_when_right
    );
    println!("{:?}", rep.detection_by_impact);
    println!("elapsed {:.1} s", t0.elapsed().as_secs_f64());
}
