//! The estimator's error type.

/// Everything that can go wrong in the estimator. Each variant names the quantity and carries
/// the offending value, so a user reads what to fix.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum EstimateError {
    /// A number that must be finite is NaN or infinite.
    #[error("{what} must be a finite number, got {value}")]
    NonFinite {
        /// The quantity.
        what: &'static str,
        /// Its value.
        value: f64,
    },
    /// A quantity that must be positive is zero or negative.
    #[error("{what} must be greater than zero, got {value}")]
    NotPositive {
        /// The quantity.
        what: &'static str,
        /// Its value.
        value: f64,
    },
    /// A quantity that must not be negative is.
    #[error("{what} must not be negative, got {value}")]
    Negative {
        /// The quantity.
        what: &'static str,
        /// Its value.
        value: f64,
    },
    /// The platform has no rotors.
    #[error("rotor count must be at least 1")]
    NoRotors,
    /// A curve has no coefficients or more than the estimator holds.
    #[error("a curve needs 1 to {} coefficients (degree ≤ {max_degree}), got {coefficients}", max_degree + 1)]
    CurveDegree {
        /// Coefficients given.
        coefficients: usize,
        /// Highest degree supported.
        max_degree: usize,
    },
    /// A curve's validity range is empty or negative.
    #[error("curve validity range must satisfy 0 ≤ min < max, got {min_g} g .. {max_g} g")]
    CurveRange {
        /// Lower end, g.
        min_g: f64,
        /// Upper end, g.
        max_g: f64,
    },
    /// The thrust asked of a rotor lies outside the measured curve.
    #[error(
        "{thrust_g:.1} g per rotor is outside the measured thrust curve ({min_g:.1}–{max_g:.1} g); \
         the curve is not extrapolated: measure the rotor over a wider range"
    )]
    ThrustOutOfRange {
        /// Thrust asked, g per rotor.
        thrust_g: f64,
        /// Curve range start, g.
        min_g: f64,
        /// Curve range end, g.
        max_g: f64,
    },
    /// A motor map's zero command is not below its full command.
    #[error("motor map: zero_us ({zero_us} µs) must be below full_us ({full_us} µs)")]
    MotorCommandRange {
        /// Command of zero duty, µs.
        zero_us: f64,
        /// Command of full duty, µs.
        full_us: f64,
    },
    /// The drive voltage of a command lies below the motor map's measured range: the motor
    /// turns slower than the sweeps' first step (at idle, expected).
    #[error(
        "drive voltage {drive_v:.3} V is below the motor map's measured range ({min_v:.3}–{max_v:.3} V): \
         the motor turns slower than the sweeps' first step; the map is not extrapolated"
    )]
    DriveBelowRange {
        /// Drive voltage asked, V.
        drive_v: f64,
        /// Map range start, V.
        min_v: f64,
        /// Map range end, V.
        max_v: f64,
    },
    /// The drive voltage of a command lies above the motor map's measured range.
    #[error(
        "drive voltage {drive_v:.3} V is above the motor map's measured range ({min_v:.3}–{max_v:.3} V); \
         the map is not extrapolated: sweep the motor to a higher drive"
    )]
    DriveAboveRange {
        /// Drive voltage asked, V.
        drive_v: f64,
        /// Map range start, V.
        min_v: f64,
        /// Map range end, V.
        max_v: f64,
    },
    /// The curve gives no positive power at the hover thrust.
    #[error(
        "total power at {total_mass_kg:.3} kg take-off mass is {power_w} W: the curve is not usable there"
    )]
    NonPositivePower {
        /// Total motor + idle power, W.
        power_w: f64,
        /// Take-off mass, kg.
        total_mass_kg: f64,
    },
    /// The take-off mass exceeds the thrust limit at minimum voltage (eq. 5: `m_X < 0`).
    #[error(
        "take-off mass {total_mass_kg:.3} kg exceeds the thrust limit m_L = {thrust_limit_kg:.3} kg \
         at minimum battery voltage (payload limit m_X = {:.3} kg < 0, eq. 5)",
        thrust_limit_kg - total_mass_kg
    )]
    OverPayloadLimit {
        /// `m_T`, kg.
        total_mass_kg: f64,
        /// `m_L`, kg.
        thrust_limit_kg: f64,
    },
    /// No battery mass keeps the take-off mass within the curve's range.
    #[error(
        "structure + payload ({fixed_mass_kg:.3} kg) leave no room for a battery within the \
         measured thrust curve, which covers take-off masses up to {max_mass_kg:.3} kg"
    )]
    NoFeasibleBattery {
        /// Structure + payload mass, kg.
        fixed_mass_kg: f64,
        /// Heaviest take-off mass the curve covers, kg.
        max_mass_kg: f64,
    },
    /// A reserve fraction outside 0..1.
    #[error("a reserve must be a fraction from 0 up to (not including) 1, got {value}")]
    ReserveFraction {
        /// The value given.
        value: f64,
    },
    /// An output buffer is shorter than needed.
    #[error("output buffer holds {given} items, {needed} needed")]
    OutputTooShort {
        /// Items needed.
        needed: usize,
        /// Items the buffer holds.
        given: usize,
    },
    /// A binary parameter blob is malformed.
    #[error("parameter blob: {reason}")]
    Blob {
        /// What is wrong.
        reason: &'static str,
    },
    /// A binary parameter blob of another layout version.
    #[error("parameter blob has layout version {found}; this estimator reads version {supported}")]
    BlobVersion {
        /// Version in the blob.
        found: u8,
        /// Version supported.
        supported: u8,
    },
    /// A battery model value that makes no sense.
    #[error("battery model: {reason} ({value})")]
    Battery {
        /// What is wrong.
        reason: &'static str,
        /// The offending value.
        value: f64,
    },
    /// Something the computation needs was not given.
    #[error("{what} is missing")]
    Missing {
        /// What is missing.
        what: &'static str,
    },
    /// A mission plan longer than the fixed-size state holds.
    #[error("a plan of {segments} segments is longer than the online estimator holds ({max})")]
    PlanTooLong {
        /// Segments given.
        segments: usize,
        /// Segments held.
        max: usize,
    },
}
