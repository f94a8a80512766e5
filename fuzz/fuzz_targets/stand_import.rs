//! Fuzz the stand import (`StandLog::parse`: hoverbench sweeps, Tyto RCbenchmark / Flight
//! Stand exports, generic tables) and the characterisation seam above it
//! (`fit::sweeps`): no input may panic; accepted steps hold finite numbers.
#![no_main]

use fit::sweeps::{LimitSweep, NominalSweep, SweepFitOptions, fit_sweeps};
use import::stand::{StandLog, StandOptions};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(log) = StandLog::parse(data.to_vec(), "fuzz.csv", &StandOptions::default()) else {
        return;
    };
    for s in &log.steps {
        assert!(s.thrust_g.is_finite());
    }
    let limit = LimitSweep::from_stand(&log, None).ok();
    if let Ok(n) = NominalSweep::from_stand(&log, None) {
        if let Ok(done) = fit_sweeps(&n, limit.as_ref(), &SweepFitOptions::new(4, "fuzz")) {
            assert!(done.params.curve.valid_min >= 0.0 || n.x_name != "thrust_g");
        }
    }
});
