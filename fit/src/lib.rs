//! Accurate least-squares polynomial fits for motor/propeller characterisation.
//!
//! `fit` turns thrust-bench measurements into the smooth thrust → power
//! curve used by hoverbench's endurance estimate (a fifth-degree polynomial
//! in the paper), and extracts the rotor thrust limit `m_L` from a sweep at
//! minimum battery voltage. It does **no I/O**: callers hand it slices (or
//! chunks of a stream).
//!
//! # Main types
//! * [`fit_polynomial`] / [`fit_polynomial_weighted`] → [`PolyFit`]: batch
//!   fit with extended-precision refinement, statistics ([`FitStats`]) and
//!   non-fatal diagnostics ([`FitWarning`]).
//! * [`StreamingPolyFit`]: the same model over an unbounded stream with
//!   memory independent of the number of points ([`RangeScan`] finds the
//!   domain in a cheap first pass, [`ResidualScan`] finds the largest
//!   residual in an optional second pass).
//! * [`thrust_limit`] → [`ThrustLimit`]: maximum sustained thrust of a sweep.
//! * [`sweeps::fit_sweeps`]: the characterisation seam — a nominal sweep and an optional
//!   limit sweep (already parsed by `import`) → `params.toml` and a [`sweeps::FitSummary`].
//! * [`motor::fit_motor_map`] → [`motor::MotorMapFit`]: per-rotor power against the ESC's
//!   drive voltage (`duty · V`) from sweeps at two supply voltages, the `[motor]` section (not in
//!   the paper).
//! * [`FitError`]: every failure, with the offending index and value. No
//!   function panics on any input.
//!
//! # Example
//! ```
//! use fit::{fit_polynomial, FitWarning};
//!
//! // Electrical power (W) against thrust (g), one reading per 10 g step.
//! let thrust: Vec<f64> = (0..=26).map(|i| 10.0 * i as f64).collect();
//! let power: Vec<f64> = thrust
//!     .iter()
//!     .map(|&t| 0.157434234 * t + 0.341190317 * (t / 100.0).powf(5.34865728))
//!     .collect();
//!
//! let curve = fit_polynomial(&thrust, &power, 5)?;
//! assert!(curve.warnings().iter().all(|w| !matches!(w, FitWarning::NotMonotoneIncreasing { .. })));
//! assert!(curve.stats().r_squared > 0.9999);
//! // Power to hover one rotor at 130 g, and the coefficients in W/gᵏ.
//! let p_hover = curve.eval(130.0);
//! assert!((p_hover - (0.157434234 * 130.0 + 0.341190317 * 1.3f64.powf(5.34865728))).abs() < 0.05);
//! let b = curve.monomial_coefficients();
//! assert_eq!(b.len(), 6);
//! # Ok::<(), fit::FitError>(())
//! ```
//!
//! # Numerical method
//! * **Scaled basis.** The abscissa is centred and scaled,
//!   `t = (x − c)/s` with `c` the midpoint and `s` the half-width of the data
//!   range, so the data lie in `t ∈ [−1, 1]` and the Vandermonde matrix in
//!   `t` is well conditioned (≈ 10² for degree 5). The solution is kept in
//!   this basis and evaluated by Horner's scheme in `t`;
//!   [`PolyFit::monomial_coefficients`] reports the physical coefficients.
//! * **Orthogonal primary solve.** The least-squares problem is solved by
//!   Householder QR (faer) of `[A | y]` — never by forming the normal
//!   equations `AᵀA` for the primary solve. The last diagonal entry of the
//!   triangle is the residual norm.
//! * **Extended-precision refinement (batch fits).** `t` is formed in
//!   double-double (`x − c` exactly, then the division), and the QR solution
//!   is refined by corrected semi-normal equations: `a ← a + R⁻¹R⁻ᵀ Aᵀ(y − Aa)`
//!   with the residual and `Aᵀr` evaluated in double-double. The triangle `R`
//!   comes from the QR factorisation, so the refinement only *uses* it as a
//!   preconditioner; its fixed point satisfies the exact normal equations and
//!   each step contracts the error by ≈ `ε·κ²`. Coefficients are kept in
//!   double-double and converted to the monomial basis in double-double. On
//!   the NIST StRD Wampler1–5 problems this yields ≥ 13 correct digits
//!   (see `tests/nist.rs`).
//! * **Streaming.** [`StreamingPolyFit`] updates the triangle block by block
//!   (`QR([R; block])`) and keeps nothing else but a few running sums; it
//!   cannot revisit the data, so it returns the plain QR solution.
//!
//! # Invariants
//! * No I/O, no global state, no `unsafe`.
//! * Results are deterministic for a given input order.
//! * Every public function validates its input and returns [`FitError`]
//!   rather than panicking.

mod assemble;
mod batch;
mod dd;
mod error;
pub mod export;
pub mod motor;
mod poly;
mod qr;
mod scale;
mod streaming;
pub mod sweeps;
mod thrust;

pub use batch::{fit_polynomial, fit_polynomial_weighted};
pub use error::{FitError, Input};
pub use poly::{
    DEFAULT_DEGREE, FitStats, FitWarning, ILL_CONDITIONED_THRESHOLD, MAX_DEGREE, MaxResidual,
    PolyFit, ResidualScan,
};
pub use streaming::{RangeScan, StreamingPolyFit};
pub use thrust::{ThrustLimit, ThrustLimitKind, ThrustLimitOptions, ThrustSag, thrust_limit};
