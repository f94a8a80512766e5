//! Units in column names: `Thrust (gf)`, `thrust_n`, `Current [mA]`, `Torque (N·m)`.

/// A physical quantity a thrust stand logs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    /// Thrust; canonical unit g (gram-force).
    Thrust,
    /// Voltage; canonical unit V.
    Voltage,
    /// Current; canonical unit A.
    Current,
    /// Electrical power; canonical unit W.
    Power,
    /// Torque; canonical unit N·m.
    Torque,
    /// Time; canonical unit s.
    Time,
    /// Rotational speed; canonical unit rpm.
    Speed,
    /// ESC command; canonical unit µs of pulse width (or a 0..1 fraction, unitless).
    Throttle,
}

impl Quantity {
    /// The canonical unit's name.
    pub fn canonical_unit(self) -> &'static str {
        match self {
            Self::Thrust => "g",
            Self::Voltage => "V",
            Self::Current => "A",
            Self::Power => "W",
            Self::Torque => "N·m",
            Self::Time => "s",
            Self::Speed => "rpm",
            Self::Throttle => "µs",
        }
    }
}

/// Standard gravity, m/s², for newtons ↔ gram-force.
pub const STANDARD_GRAVITY: f64 = 9.806_65;

/// Splits a column name into its name and unit: `Thrust (gf)` → (`Thrust`, `gf`),
/// `Current [mA]` → (`Current`, `mA`), `thrust_n` → (`thrust`, `n`). Names without a unit give
/// `None`.
pub fn split_unit(column: &str) -> (&str, Option<&str>) {
    let c = column.trim();
    for (open, close) in [('(', ')'), ('[', ']')] {
        if let (Some(i), true) = (c.rfind(open), c.ends_with(close)) {
            return (c[..i].trim(), Some(c[i + 1..c.len() - 1].trim()));
        }
    }
    match c.rsplit_once('_') {
        Some((name, unit)) if !name.is_empty() && !unit.is_empty() => (name, Some(unit)),
        _ => (c, None),
    }
}

/// Factor that turns a value in `unit` into the quantity's canonical unit, or `None` for a unit
/// this quantity cannot be in. Unit names are matched case-insensitively where that is
/// unambiguous (`mA`/`MA` are not: milliampere is the only current unit with an `m`).
pub fn factor(quantity: Quantity, unit: &str) -> Option<f64> {
    let u = unit.trim();
    let l = u
        .to_ascii_lowercase()
        .replace(['·', '*', '.', ' ', '-'], "");
    Some(match quantity {
        Quantity::Thrust => match l.as_str() {
            "g" | "gf" | "gram" | "grams" => 1.0,
            "kg" | "kgf" => 1000.0,
            "n" => 1000.0 / STANDARD_GRAVITY,
            "mn" => 1.0 / STANDARD_GRAVITY,
            "lbf" | "lb" => 453.592_37,
            "ozf" | "oz" => 28.349_523_125,
            _ => return None,
        },
        Quantity::Voltage => match l.as_str() {
            "v" => 1.0,
            "mv" => 1e-3,
            _ => return None,
        },
        Quantity::Current => match l.as_str() {
            "a" => 1.0,
            "ma" => 1e-3,
            _ => return None,
        },
        Quantity::Power => match l.as_str() {
            "w" => 1.0,
            "mw" => 1e-3,
            "kw" => 1e3,
            _ => return None,
        },
        Quantity::Torque => match l.as_str() {
            "nm" => 1.0,
            "nmm" => 1e-3,
            "kgfm" => STANDARD_GRAVITY,
            "kgfcm" => STANDARD_GRAVITY / 100.0,
            "gfcm" => STANDARD_GRAVITY / 100_000.0,
            "lbfin" | "lbin" => 0.112_984_829,
            "lbfft" | "lbft" => 1.355_817_948,
            "ozfin" | "ozin" => 0.007_061_551_8,
            _ => return None,
        },
        Quantity::Time => match l.as_str() {
            "s" | "sec" => 1.0,
            "ms" => 1e-3,
            "us" | "µs" | "μs" => 1e-6,
            "min" => 60.0,
            _ => return None,
        },
        Quantity::Speed => match l.as_str() {
            "rpm" => 1.0,
            "rads" | "rad/s" => 60.0 / (2.0 * std::f64::consts::PI),
            "hz" => 60.0,
            _ => return None,
        },
        Quantity::Throttle => match l.as_str() {
            "us" | "µs" | "μs" => 1.0,
            "%" | "pct" | "percent" => 1.0,
            "" | "frac" | "fraction" => 1.0,
            _ => return None,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splits_stand_headers() {
        assert_eq!(split_unit("Thrust (gf)"), ("Thrust", Some("gf")));
        assert_eq!(split_unit("Torque (N·m)"), ("Torque", Some("N·m")));
        assert_eq!(split_unit("Current [mA]"), ("Current", Some("mA")));
        assert_eq!(split_unit("thrust_n"), ("thrust", Some("n")));
        assert_eq!(split_unit("App message"), ("App message", None));
    }

    #[test]
    fn converts_to_canonical_units() {
        assert_eq!(factor(Quantity::Thrust, "gf"), Some(1.0));
        assert!((factor(Quantity::Thrust, "N").unwrap() - 101.971_621).abs() < 1e-5);
        assert_eq!(factor(Quantity::Thrust, "kgf"), Some(1000.0));
        assert_eq!(factor(Quantity::Current, "mA"), Some(1e-3));
        assert_eq!(factor(Quantity::Torque, "N·m"), Some(1.0));
        assert_eq!(factor(Quantity::Torque, "N*m"), Some(1.0));
        assert_eq!(factor(Quantity::Throttle, "µs"), Some(1.0));
        assert_eq!(factor(Quantity::Voltage, "A"), None);
    }
}
