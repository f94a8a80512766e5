//! Property tests of the estimator's invariants over random platforms, batteries and plans.

use estimator::{
    Battery, Eq8Form, FnCurve, MissionOptions, Model, Payload, Platform, Segment, SegmentOutcome,
};
use proptest::prelude::*;

fn paper_curve(t: f64) -> f64 {
    0.157434234 * t + 0.341190317 * (t / 100.0).powf(5.34865728)
}

/// The estimator over the paper's reconstructed curve.
type PaperModel = Model<FnCurve<fn(f64) -> f64>>;

fn model(structure_kg: f64, avionics_w: f64) -> PaperModel {
    Model::new(
        FnCurve::new(paper_curve as fn(f64) -> f64, (0.0, 260.0)),
        Platform {
            structure_mass_kg: structure_kg,
            avionics_power_w: avionics_w,
            rotor_count: 4,
        },
    )
}

fn segment() -> impl Strategy<Value = Segment> {
    prop_oneof![
        (0.0f64..20.0).prop_map(|d| Segment::Hover { duration_min: d }),
        (0.0f64..200.0).prop_map(|d| Segment::Attached { duration_min: d }),
        (0.0f64..0.9).prop_map(|r| Segment::HoverUntilReserve {
            reserve_fraction: r
        }),
        (0.0f64..0.9).prop_map(|r| Segment::AttachedUntilReserve {
            reserve_fraction: r
        }),
        Just(Segment::HoverUntilEmpty),
    ]
}

proptest! {
    /// More payload mass never lengthens the flight; more payload power never does either.
    #[test]
    fn endurance_falls_with_payload(
        structure in 0.2f64..0.5, battery in 0.05f64..0.3, m1 in 0.0f64..0.1, dm in 0.0f64..0.1,
        p1 in 0.0f64..10.0, dp in 0.0f64..10.0,
    ) {
        let m = model(structure, 2.44);
        let b = Battery::from_density(battery, 164.0).unwrap();
        let light = m.estimate(&b, &Payload { mass_kg: m1, power_w: p1 }).unwrap();
        let heavy = m.estimate(&b, &Payload { mass_kg: m1 + dm, power_w: p1 + dp }).unwrap();
        prop_assert!(heavy.endurance_min <= light.endurance_min + 1e-12);
    }

    /// The ideal optimum is at least as good as any battery mass in the searched range.
    #[test]
    fn ideal_optimum_beats_every_other_mass(structure in 0.2f64..0.6, e_d in 80.0f64..300.0, probe in 0.0f64..1.0) {
        let m = model(structure, 2.44);
        let o = m.optimise_battery(e_d, &Payload::default()).unwrap();
        let (lo, hi) = o.search_range_kg;
        let mb = lo + probe * (hi - lo);
        let e = m.estimate(&Battery::from_density(mb, e_d).unwrap(), &Payload::default()).unwrap();
        prop_assert!(e.endurance_min <= o.ideal.endurance_min + 1e-9);
    }

    /// Energy is conserved over any plan: what was used plus what is left is the battery; time
    /// adds up; nothing goes below zero; the consistent and printed forms agree on hover-only plans.
    #[test]
    fn missions_conserve_energy(plan in proptest::collection::vec(segment(), 1..12), printed in any::<bool>()) {
        let m = model(0.431, 2.44);
        let b = Battery::from_density(0.144, 164.0).unwrap();
        let opts = MissionOptions {
            eq8: if printed { Eq8Form::PrintedHours } else { Eq8Form::Consistent },
            ..Default::default()
        };
        let mut out = vec![SegmentOutcome::EMPTY; plan.len()];
        let s = m.evaluate_mission(&b, &Payload::default(), &plan, &opts, &mut out).unwrap();
        let used: f64 = out[..s.segments_evaluated].iter().map(|o| o.energy_used_wh).sum();
        prop_assert!((used + s.energy_left_wh - b.energy_wh).abs() < 1e-9);
        prop_assert!(s.energy_left_wh >= -1e-9);
        prop_assert!((s.flight_min + s.attached_min - s.total_min).abs() < 1e-9);
        for w in out[..s.segments_evaluated].windows(2) {
            prop_assert!((w[0].start_min + w[0].duration_min - w[1].start_min).abs() < 1e-9);
        }
        if let Some(d) = s.depletion {
            prop_assert_eq!(d.segment_index + 1, s.segments_evaluated);
        }
    }
}
