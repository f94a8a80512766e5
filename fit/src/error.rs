//! Error type shared by every fallible entry point of the crate.

use std::fmt;

/// Which input sequence an offending value came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Input {
    /// The abscissa (`x`, e.g. thrust in g).
    X,
    /// The ordinate (`y`, e.g. electrical power in W).
    Y,
    /// The per-point weights of a weighted fit.
    Weight,
    /// The throttle column of a thrust sweep.
    Throttle,
    /// The thrust column of a thrust sweep.
    Thrust,
    /// The per-step thrust standard deviations of a thrust sweep.
    ThrustStd,
    /// The supply voltage column of a sweep.
    Voltage,
    /// The electrical power column of a sweep.
    Power,
}

impl fmt::Display for Input {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Input::X => "x",
            Input::Y => "y",
            Input::Weight => "weight",
            Input::Throttle => "throttle",
            Input::Thrust => "thrust",
            Input::ThrustStd => "thrust standard deviation",
            Input::Voltage => "voltage",
            Input::Power => "power",
        })
    }
}

/// Why a fit (or a thrust-limit extraction) could not be produced.
///
/// Every variant carries enough context (index, value, sizes) to point the
/// user at the offending input. No function of this crate panics on bad
/// input; it returns one of these instead.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitError {
    /// No data points were supplied.
    #[error("no data points: a fit needs at least one point")]
    Empty,
    /// Two input sequences that must be parallel have different lengths.
    #[error("length mismatch: {first} has {first_len} values but {second} has {second_len}")]
    LengthMismatch {
        /// The first sequence.
        first: Input,
        /// Its length.
        first_len: usize,
        /// The second sequence.
        second: Input,
        /// Its length.
        second_len: usize,
    },
    /// A value is NaN or infinite.
    #[error("non-finite {input} value {value} at index {index}")]
    NonFinite {
        /// Which sequence holds the value.
        input: Input,
        /// Zero-based index (for streaming fits: the running point count).
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// A weight or standard deviation is not strictly positive.
    #[error("{input} at index {index} must be > 0, got {value}")]
    NotPositive {
        /// Which sequence holds the value.
        input: Input,
        /// Zero-based index.
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// A value that must be non-negative (a standard deviation) is negative.
    #[error("{input} at index {index} must be >= 0, got {value}")]
    Negative {
        /// Which sequence holds the value.
        input: Input,
        /// Zero-based index.
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// The requested degree exceeds the supported maximum.
    #[error(
        "polynomial degree {degree} is too large: the maximum supported degree is {max} \
         (high-degree monomial fits are numerically meaningless; split the range instead)"
    )]
    DegreeTooLarge {
        /// The requested degree.
        degree: usize,
        /// The supported maximum, [`MAX_DEGREE`](crate::MAX_DEGREE).
        max: usize,
    },
    /// Not enough distinct abscissae to determine the polynomial.
    #[error(
        "degree {degree} needs at least {} distinct x values, but the data have only {distinct}",
        degree + 1
    )]
    TooFewDistinctX {
        /// The requested degree.
        degree: usize,
        /// Number of distinct x values found.
        distinct: usize,
    },
    /// Every abscissa has the same value, so the scaling `t = (x - c)/s` is undefined.
    #[error("all {n} x values are equal to {value}: the data span no range")]
    AllXEqual {
        /// Number of points.
        n: usize,
        /// The common x value.
        value: f64,
    },
    /// The x range is too wide to be represented (`max - min` overflows).
    #[error("x range [{min}, {max}] is too wide to represent in f64")]
    RangeTooWide {
        /// Smallest x.
        min: f64,
        /// Largest x.
        max: f64,
    },
    /// A streaming fit was constructed with an unusable domain.
    #[error("invalid streaming domain [{lo}, {hi}]: need finite lo < hi with finite hi - lo")]
    InvalidDomain {
        /// Requested lower end.
        lo: f64,
        /// Requested upper end.
        hi: f64,
    },
    /// A streamed point lies outside the domain fixed at construction.
    #[error(
        "point {index} has x = {x}, outside the streaming domain [{lo}, {hi}] fixed at construction"
    )]
    OutsideDomain {
        /// Running index of the point.
        index: usize,
        /// Its x value.
        x: f64,
        /// Domain lower end.
        lo: f64,
        /// Domain upper end.
        hi: f64,
    },
    /// The throttle values of a sweep are not strictly increasing.
    #[error(
        "throttle must be strictly increasing: value {value} at index {index} \
         follows {previous}"
    )]
    ThrottleNotIncreasing {
        /// Index of the offending value.
        index: usize,
        /// The value before it.
        previous: f64,
        /// The offending value.
        value: f64,
    },
    /// Too few points for the requested analysis.
    #[error("{what} needs at least {needed} points, got {got}")]
    TooFewPoints {
        /// What was attempted.
        what: &'static str,
        /// Minimum number of points.
        needed: usize,
        /// Number supplied.
        got: usize,
    },
    /// An option has an unusable value.
    #[error("invalid option {name} = {value}: {reason}")]
    InvalidOption {
        /// Option name.
        name: &'static str,
        /// Its value.
        value: f64,
        /// What is required.
        reason: &'static str,
    },
    /// The computation produced non-finite numbers (values too extreme for `f64`).
    #[error("the fit produced non-finite coefficients: {context}")]
    NumericalFailure {
        /// Where it happened.
        context: &'static str,
    },
}
