//! A small study of the online estimator on simulated flights: what it must always do, and the
//! issue's targets (ignored while they are not met; the numbers are in the report and README).

use estimator::online::OnlineConfig;
use replay_eval::{Condition, StudyOptions, Targets, select_families, study};

fn small(families: &str, seeds: std::ops::Range<u64>) -> replay_eval::Study {
    study(
        &StudyOptions {
            seeds,
            families: select_families(families).unwrap(),
            threads: 2,
            config: OnlineConfig::default(),
        },
        &|| {},
    )
}

#[test]
fn conditions_are_drawn_evenly_from_the_seed() {
    let mut counts = [0usize; 7];
    for s in 0..700 {
        let c = Condition::draw(s);
        counts[Condition::NAMES
            .iter()
            .position(|n| *n == c.name())
            .unwrap()] += 1;
        assert_eq!(c, Condition::draw(s));
    }
    assert!(
        counts.iter().all(|&n| (70..=130).contains(&n)),
        "{counts:?}"
    );
}

#[test]
fn a_small_study_scores_every_held_out_flight_at_the_cut_off() {
    let s = small("lipo/lab-1hz/paper,nca/fc-10hz/varied", 0..4);
    for (seed, fam, r) in &s.scenarios {
        let o = r
            .as_ref()
            .unwrap_or_else(|e| panic!("seed {seed} {}: {e}", fam.name()));
        // Both pack types learned; every held-out flight flown to the cut-off and scored.
        assert_eq!(o.packs.len(), 2);
        assert!(o.skipped.is_empty(), "{:?}", o.skipped);
        assert_eq!(o.flights.len(), 4);
        for f in &o.flights {
            assert_eq!(f.checkpoints.len(), 4);
            for c in &f.checkpoints {
                let p = c.predicted_remaining_s.expect("online prediction");
                assert!(p.is_finite() && p >= 0.0);
                assert!(c.sigma_s.is_some_and(|s| s > 0.0));
            }
        }
    }
    let held = s
        .groups
        .iter()
        .find(|g| g.name == "all held-out families")
        .unwrap();
    assert_eq!(held.split, "held out");
    assert_eq!(held.replay.summary.scored_flights, 8);
}

/// The issue's targets on held-out families. Ignored: not met by the current online
/// estimator (see the replay report for the numbers).
#[test]
#[ignore = "issue 14 targets not met yet: see README (replay) for the measured numbers"]
fn heldout_families_meet_issue_14_targets() {
    let s = small("heldout", 0..40);
    let held = s
        .groups
        .iter()
        .find(|g| g.name == "all held-out families")
        .unwrap();
    let t = Targets::of(&held.replay.summary);
    assert!(t.all_met(), "{t:?}");
}
