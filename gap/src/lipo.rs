//! Lithium-polymer cells: open-circuit voltage against state of charge.

/// Open-circuit voltage of a LiPo cell at 0 %, 5 %, …, 100 % state of charge, V: the widely used
/// hobby-pack rest-voltage table (flat 3.7–3.9 V plateau, knee below 10 %).
pub const OCV_TABLE_V: [f64; 21] = [
    3.27, 3.61, 3.69, 3.71, 3.73, 3.75, 3.77, 3.79, 3.80, 3.82, 3.84, 3.85, 3.87, 3.91, 3.95, 3.98,
    4.02, 4.08, 4.11, 4.15, 4.20,
];

/// Open-circuit voltage of one cell at state of charge `soc` (0..1, clamped), V.
pub fn ocv_cell_v(soc: f64) -> f64 {
    let x = soc.clamp(0.0, 1.0) * 20.0;
    let i = (x.floor() as usize).min(19);
    let f = x - i as f64;
    OCV_TABLE_V[i] * (1.0 - f) + OCV_TABLE_V[i + 1] * f
}

/// State of charge whose open-circuit voltage is `v` per cell (inverse of [`ocv_cell_v`]).
pub fn soc_for_ocv(v: f64) -> f64 {
    if v <= OCV_TABLE_V[0] {
        return 0.0;
    }
    if v >= OCV_TABLE_V[20] {
        return 1.0;
    }
    let i = OCV_TABLE_V.windows(2).position(|w| v <= w[1]).unwrap_or(19);
    let (a, b) = (OCV_TABLE_V[i], OCV_TABLE_V[i + 1]);
    (i as f64 + (v - a) / (b - a)) / 20.0
}

/// Reference temperature of the pack ratings, °C.
pub const REFERENCE_TEMPERATURE_C: f64 = 25.0;

/// How a LiPo's resistance and usable capacity change with temperature, as factors on their
/// values at 25 °C: resistance rises about 1.5 % per °C colder, usable capacity falls about
/// 0.2 % per °C colder (typical of hobby pouch cells near room temperature; warmer than 25 °C is
/// taken as 25 °C for capacity). Unknown temperature: no change.
pub fn temperature_factors(ambient_c: Option<f64>) -> (f64, f64) {
    match ambient_c {
        Some(t) if t.is_finite() => {
            let colder = REFERENCE_TEMPERATURE_C - t;
            (
                (1.0 + 0.015 * colder).clamp(0.5, 3.0),
                (1.0 - 0.002 * colder.max(0.0)).clamp(0.5, 1.0),
            )
        }
        _ => (1.0, 1.0),
    }
}

/// Mean open-circuit voltage over a full discharge, V per cell: the energy a cell stores is its
/// charge times this.
pub fn mean_ocv_cell_v() -> f64 {
    // Trapezoidal integral of the piecewise-linear table.
    let s: f64 = OCV_TABLE_V.windows(2).map(|w| 0.5 * (w[0] + w[1])).sum();
    s / 20.0
}

/// Terminal current for a power draw from a source of open-circuit voltage `e` behind
/// resistance `r`: the smaller root of `r·I² − e·I + p = 0`. `None` when the source cannot
/// deliver `p` (the voltage would collapse).
pub fn current_for_power(e: f64, r: f64, p: f64) -> Option<f64> {
    if r <= 0.0 {
        return (e > 0.0).then(|| p / e);
    }
    let disc = e * e - 4.0 * r * p;
    (disc >= 0.0).then(|| (e - disc.sqrt()) / (2.0 * r))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ocv_round_trips_and_is_monotone() {
        for i in 0..=100 {
            let soc = f64::from(i) / 100.0;
            assert!((soc_for_ocv(ocv_cell_v(soc)) - soc).abs() < 1e-12);
            if i > 0 {
                assert!(ocv_cell_v(soc) > ocv_cell_v(soc - 0.01));
            }
        }
        let m = mean_ocv_cell_v();
        assert!(m > 3.7 && m < 3.95, "{m}");
    }

    #[test]
    fn current_for_power_satisfies_the_circuit() {
        let i = current_for_power(12.0, 0.05, 100.0).unwrap();
        assert!(((12.0 - 0.05 * i) * i - 100.0).abs() < 1e-9);
        assert!(current_for_power(12.0, 0.05, 1000.0).is_none());
    }
}
