//! Prints the candidates of one blind-study scenario (development aid for tuning on the tuning
//! seeds).
fn main() {
    let seeds: Vec<u64> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let robot = gap::truth::Robot::paper();
    let curve = gap::eval::rig_curve(&robot).expect("rig curve");
    for seed in seeds {
        let truth = gap::eval::draw_truth(seed);
        let set = gap::eval::generate(&robot, seed, truth);
        let train: Vec<_> = set.train.iter().collect();
        let held: Vec<_> = set.heldout.iter().collect();
        let model = gap::model::Model {
            curve: &curve,
            rotor_count: 4,
        };
        let d = match gap::diagnose::diagnose(model, &train, &held, &Default::default()) {
            Ok(d) => d,
            Err(e) => {
                println!("seed {seed}: {e}");
                continue;
            }
        };
        println!(
            "seed {seed} truth {:?} -> {} (base chi2/obs {:.2}, after {:.2})",
            truth,
            gap::eval::label_of_verdict(&d),
            d.baseline.training.chi2_per_obs,
            d.after.training.chi2_per_obs
        );
        println!("   stability {:?}", d.stability);
        let mut c = d.candidates.clone();
        c.sort_by(|a, b| a.bic.total_cmp(&b.bic));
        for c in c.iter().take(6) {
            println!(
                "   {:?} {:?} bic {:.1} chi2 {:.1} cv {:?} held {:.2}",
                c.effects,
                c.values,
                c.bic,
                c.chi2,
                c.cv_chi2.map(|x| x.round()),
                c.heldout.headline()
            );
        }
    }
}
