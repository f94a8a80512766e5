//! Streaming fit: agreement with the batch fit, error handling, second pass.

use fit::{FitError, FitWarning, Input, RangeScan, StreamingPolyFit, fit_polynomial};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Thrust (g) → electrical power (W) of the reference rotor.
fn power(t: f64) -> f64 {
    0.157434234 * t + 0.341190317 * (t / 100.0).powf(5.34865728)
}

/// `n` noisy samples of the curve at random thrusts in [0, 260] g.
fn sweep(n: usize, seed: u64) -> (Vec<f64>, Vec<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let x: Vec<f64> = (0..n).map(|_| rng.random_range(0.0..260.0)).collect();
    let y = x
        .iter()
        .map(|&t| power(t) + 0.2 * (rng.random::<f64>() - 0.5))
        .collect();
    (x, y)
}

fn max_abs(v: impl IntoIterator<Item = f64>) -> f64 {
    v.into_iter().fold(0.0, |m, x| m.max(x.abs()))
}

#[test]
fn streaming_agrees_with_batch() {
    let (x, y) = sweep(6000, 7);
    let batch = fit_polynomial(&x, &y, 5).unwrap();

    let mut scan = RangeScan::new();
    scan.push_chunk(&x);
    let (lo, hi) = scan.range().unwrap();
    // A small block forces many QR updates; uneven chunks cross block edges.
    let mut stream = StreamingPolyFit::with_block_rows(5, lo, hi, 500).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let mut next = 0;
    while next < x.len() {
        let m = rng.random_range(1..1700).min(x.len() - next);
        stream
            .push_chunk(&x[next..next + m], &y[next..next + m])
            .unwrap();
        next += m;
    }
    assert_eq!(stream.n_points(), x.len());
    let streamed = stream.finish().unwrap();

    assert_eq!(streamed.center(), batch.center());
    assert_eq!(streamed.scale(), batch.scale());
    assert_eq!(streamed.domain(), batch.domain());
    let a_scale = max_abs(batch.coeffs_scaled().iter().copied());
    let da = max_abs(
        streamed
            .coeffs_scaled()
            .iter()
            .zip(batch.coeffs_scaled())
            .map(|(s, b)| s - b),
    );
    assert!(
        da <= 1e-10 * a_scale,
        "scaled coefficients differ by {da:e} (scale {a_scale})"
    );

    let y_scale = max_abs(y.iter().copied());
    let dy = max_abs((0..=260).map(|t| streamed.eval(t as f64) - batch.eval(t as f64)));
    assert!(dy <= 1e-10 * y_scale, "curves differ by {dy:e}");

    // Monomial coefficients, each weighted by its contribution at the top of the range.
    let bs = streamed.monomial_coefficients();
    let bb = batch.monomial_coefficients();
    for (k, (s, b)) in bs.iter().zip(&bb).enumerate() {
        let contribution = (s - b).abs() * hi.powi(k as i32);
        assert!(contribution <= 1e-10 * y_scale, "b{k}: {s} vs {b}");
    }

    let (ss, sb) = (streamed.stats(), batch.stats());
    assert_eq!((ss.n_points, ss.dof), (sb.n_points, sb.dof));
    assert!(
        (ss.rss - sb.rss).abs() <= 1e-9 * sb.rss,
        "{} vs {}",
        ss.rss,
        sb.rss
    );
    assert!((ss.r_squared - sb.r_squared).abs() <= 1e-12);
    assert!((ss.condition_number / sb.condition_number - 1.0).abs() <= 1e-9);
    let (es, eb) = (
        ss.std_errors_scaled.as_ref().unwrap(),
        sb.std_errors_scaled.as_ref().unwrap(),
    );
    for (s, b) in es.iter().zip(eb) {
        assert!((s / b - 1.0).abs() <= 1e-9);
    }
    assert_eq!(ss.refinement_iterations, 0);
    assert!(sb.refinement_iterations > 0);
    assert!(ss.max_residual.is_none());
    assert!(
        streamed
            .warnings()
            .contains(&FitWarning::StreamingChecksSkipped)
    );

    // A second pass finds the same largest residual as the batch fit.
    let mut pass = streamed.into_residual_scan();
    for (xc, yc) in x.chunks(1000).zip(y.chunks(1000)) {
        pass.push_chunk(xc, yc);
    }
    let with_max = pass.finish();
    let (ms, mb) = (
        with_max.stats().max_residual.unwrap(),
        sb.max_residual.unwrap(),
    );
    assert_eq!(ms.index, mb.index);
    assert_eq!(ms.x, mb.x);
    assert!((ms.residual - mb.residual).abs() <= 1e-10 * y_scale);
    assert!(
        !with_max
            .warnings()
            .contains(&FitWarning::StreamingChecksSkipped)
    );
}

#[test]
fn single_pushes_equal_chunk_pushes() {
    let (x, y) = sweep(300, 3);
    let mut a = StreamingPolyFit::with_block_rows(3, 0.0, 260.0, 64).unwrap();
    let mut b = StreamingPolyFit::with_block_rows(3, 0.0, 260.0, 64).unwrap();
    for (&xi, &yi) in x.iter().zip(&y) {
        a.push(xi, yi).unwrap();
    }
    b.push_chunk(&x, &y).unwrap();
    let (fa, fb) = (a.finish().unwrap(), b.finish().unwrap());
    assert_eq!(fa.coeffs_scaled(), fb.coeffs_scaled());
}

#[test]
fn rejected_chunks_leave_the_state_untouched() {
    let mut s = StreamingPolyFit::new(1, 0.0, 10.0).unwrap();
    s.push_chunk(&[1.0, 2.0], &[1.0, 2.0]).unwrap();
    assert_eq!(
        s.push_chunk(&[3.0, 11.0, 4.0], &[3.0, 11.0, 4.0]),
        Err(FitError::OutsideDomain {
            index: 3,
            x: 11.0,
            lo: 0.0,
            hi: 10.0
        })
    );
    assert!(matches!(
        s.push_chunk(&[3.0, 4.0], &[3.0, f64::NAN]),
        Err(FitError::NonFinite {
            input: Input::Y,
            index: 3,
            ..
        })
    ));
    assert!(matches!(
        s.push(f64::NEG_INFINITY, 1.0),
        Err(FitError::NonFinite {
            input: Input::X,
            index: 2,
            ..
        })
    ));
    assert!(matches!(
        s.push_chunk(&[1.0], &[]),
        Err(FitError::LengthMismatch { .. })
    ));
    assert_eq!(s.n_points(), 2);
    let f = s.finish().unwrap();
    assert!((f.eval(7.0) - 7.0).abs() < 1e-12);
}

#[test]
fn streaming_errors() {
    assert_eq!(
        StreamingPolyFit::new(2, 1.0, 1.0).err(),
        Some(FitError::InvalidDomain { lo: 1.0, hi: 1.0 })
    );
    assert!(matches!(
        StreamingPolyFit::new(2, f64::NAN, 1.0),
        Err(FitError::InvalidDomain { .. })
    ));
    assert!(matches!(
        StreamingPolyFit::new(25, 0.0, 1.0),
        Err(FitError::DegreeTooLarge { .. })
    ));
    assert_eq!(
        StreamingPolyFit::new(2, 0.0, 1.0).unwrap().finish(),
        Err(FitError::Empty)
    );
    let mut s = StreamingPolyFit::new(3, 0.0, 1.0).unwrap();
    s.push_chunk(&[0.0, 0.5, 0.5, 1.0, 1.0], &[1.0, 2.0, 3.0, 4.0, 5.0])
        .unwrap();
    assert_eq!(
        s.finish(),
        Err(FitError::TooFewDistinctX {
            degree: 3,
            distinct: 3
        })
    );
    let mut s = StreamingPolyFit::new(0, 0.0, 1.0).unwrap();
    s.push_chunk(&[0.5, 0.5], &[1.0, 2.0]).unwrap();
    assert_eq!(s.finish(), Err(FitError::AllXEqual { n: 2, value: 0.5 }));
    assert_eq!(RangeScan::new().range(), None);
}
