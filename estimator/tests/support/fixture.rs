//! The platform the online estimator's tests, its bench and the C interface's test share
//! (included with `#[path]` by `estimator/tests/online.rs`, `estimator/benches/online.rs` and
//! `estimator-c/tests/c_interface.rs`).

use estimator::online::Vehicle;
use estimator::{Params, PolyCurve};

/// A quadrotor: p(T) = 0.12 T + 0.0004 T² per rotor (in the scaled basis t = (T − 130)/130,
/// valid 0–260 g, at 12 V), a 431 g structure carrying a 144 g pack, 2.44 W of avionics. No
/// thrust limit and no `[battery]` section.
pub fn params() -> Params {
    let curve = PolyCurve::new(
        &[22.36, 29.12, 6.76],
        130.0,
        130.0,
        (0.0, 260.0),
        Some(12.0),
    )
    .expect("a valid curve");
    Params {
        rotor_count: 4,
        curve,
        thrust_limit: None,
        battery: None,
        vehicle: Some(Vehicle {
            structure_mass_kg: 0.431,
            battery_mass_kg: 0.144,
            payload_mass_kg: 0.0,
            avionics_power_w: 2.44,
            payload_power_w: 0.0,
        }),
        motor: None,
    }
}
