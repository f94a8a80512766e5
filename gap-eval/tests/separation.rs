//! The truth and the diagnosis stay apart: the dependency graph, and what crosses between them
//! (flight-log files only).

use flight_sim::{Family, Logging, Withheld, generate};

#[path = "../../test-support/workspace_deps.rs"]
mod workspace_deps;
use workspace_deps::reach;

#[test]
fn truth_and_diagnosis_do_not_depend_on_each_other() {
    let r = reach();
    for bad in ["flight-sim", "gap-eval"] {
        assert!(!r["gap"].contains(bad), "gap reaches {bad}");
    }
    for bad in ["gap", "sim", "gap-eval"] {
        assert!(!r["flight-sim"].contains(bad), "flight-sim reaches {bad}");
    }
    for needed in ["flight-sim", "gap", "flightlog"] {
        assert!(r["gap-eval"].contains(needed), "gap-eval needs {needed}");
    }
}

#[test]
fn every_family_reads_back_through_the_flight_log_reader() {
    for fam in Family::all()
        .into_iter()
        .filter(|f| f.logging != Logging::Blackbox50Hz)
    {
        let set = generate(&fam, &Withheld::NONE, 11);
        let flights = gap_eval::read_back(&set.train).unwrap();
        for (f, s) in flights.iter().zip(&set.train) {
            assert_eq!(f.samples.len(), s.samples, "{}", fam.name());
            assert_eq!(
                f.samples.current_a.is_some(),
                fam.logging != Logging::VoltageOnly5Hz
            );
            assert!(f.samples.phase.is_some());
            assert_eq!(f.meta.cells, Some(u32::from(fam.chemistry.cells())));
            assert_eq!(f.meta.end, Some(flightlog::End::Cutoff));
            assert!(f.meta.take_off_mass_kg().unwrap() > 0.4);
        }
        gap_eval::rig_curve(&set.rig).unwrap();
    }
}
