//! NIST StRD accuracy bar: the Wampler1–5 fifth-degree polynomial problems.
//!
//! Certified values and data are parsed from the unmodified `.dat` files in
//! `tests/data/nist/`. Accuracy is measured as the log relative error
//! `LRE = −log10(|b − b_cert| / |b_cert|)` (absolute error when
//! `b_cert = 0`), capped at 15 as NIST does.

use std::path::PathBuf;

use fit::fit_polynomial;

struct Certified {
    coeffs: Vec<f64>,
    coeff_sd: Vec<f64>,
    residual_sd: f64,
    r_squared: f64,
    x: Vec<f64>,
    y: Vec<f64>,
}

fn parse(name: &str) -> Certified {
    let path =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("tests/data/nist/{name}.dat"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut coeffs = Vec::new();
    let mut coeff_sd = Vec::new();
    let mut residual_sd = None;
    let mut r_squared = None;
    let mut x = Vec::new();
    let mut y = Vec::new();
    let mut in_data = false;
    let mut lines = text.lines();
    while let Some(line) = lines.next() {
        let words: Vec<&str> = line.split_whitespace().collect();
        let num = |s: &str| {
            s.parse::<f64>()
                .unwrap_or_else(|e| panic!("{name}: {s:?}: {e}"))
        };
        if in_data {
            if let [yv, xv] = words[..] {
                y.push(num(yv));
                x.push(num(xv));
            }
            continue;
        }
        match words[..] {
            [b, est, sd] if b.len() == 2 && b.starts_with('B') => {
                coeffs.push(num(est));
                coeff_sd.push(num(sd));
            }
            ["Residual"] => {
                let next = lines.next().expect("residual sd line");
                let v = next.split_whitespace().last().expect("value");
                residual_sd = Some(num(v));
            }
            ["R-Squared", v] => r_squared = Some(num(v)),
            ["Data:", "y", "x"] => in_data = true,
            _ => {}
        }
    }
    assert_eq!(coeffs.len(), 6, "{name}: certified coefficients");
    assert_eq!(x.len(), 21, "{name}: observations");
    Certified {
        coeffs,
        coeff_sd,
        residual_sd: residual_sd.expect("residual sd"),
        r_squared: r_squared.expect("R²"),
        x,
        y,
    }
}

fn lre(value: f64, certified: f64) -> f64 {
    let err = if certified == 0.0 {
        (value - certified).abs()
    } else {
        ((value - certified) / certified).abs()
    };
    if err == 0.0 {
        15.0
    } else {
        (-err.log10()).min(15.0)
    }
}

/// Minimum coefficient LRE for one data set, and the statistics checks.
fn check(name: &str, numpy_lre: f64) -> f64 {
    let c = parse(name);
    let f = fit_polynomial(&c.x, &c.y, 5).expect("fit");
    let b = f.monomial_coefficients();
    let min_lre = b
        .iter()
        .zip(&c.coeffs)
        .map(|(&v, &cert)| lre(v, cert))
        .fold(f64::INFINITY, f64::min);
    println!("{name}: min LRE {min_lre:.2} (numpy.polyfit {numpy_lre}), coefficients {b:?}");
    assert!(
        min_lre >= 10.0,
        "{name}: min LRE {min_lre:.2} < 10 (numpy {numpy_lre})"
    );
    assert!(min_lre >= numpy_lre);

    let s = f.stats();
    assert_eq!((s.n_points, s.dof), (21, 15));
    let sd = s.residual_std.expect("dof > 0");
    if c.residual_sd == 0.0 {
        // Exact data: residuals vanish relative to the data scale.
        let y_scale = c.y.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        assert!(sd <= 1e-12 * y_scale, "{name}: residual sd {sd}");
        assert_eq!(s.r_squared, 1.0, "{name}");
    } else {
        assert!(
            lre(sd, c.residual_sd) >= 12.0,
            "{name}: residual sd {sd} vs {}",
            c.residual_sd
        );
        assert!(
            lre(s.r_squared, c.r_squared) >= 12.0,
            "{name}: R² {} vs {}",
            s.r_squared,
            c.r_squared
        );
        let se = s.std_errors_monomial.as_ref().expect("dof > 0");
        println!(
            "{name}: LRE residual sd {:.1}, R² {:.1}, coefficient sds {:?}",
            lre(sd, c.residual_sd),
            lre(s.r_squared, c.r_squared),
            se.iter()
                .zip(&c.coeff_sd)
                .map(|(&g, &c)| (lre(g, c) * 10.0).round() / 10.0)
                .collect::<Vec<_>>()
        );
        for (k, (&got, &cert)) in se.iter().zip(&c.coeff_sd).enumerate() {
            assert!(lre(got, cert) >= 12.0, "{name}: sd(B{k}) {got} vs {cert}");
        }
    }
    min_lre
}

#[test]
fn wampler1() {
    check("Wampler1", 8.9);
}

#[test]
fn wampler2() {
    check("Wampler2", 13.2);
}

#[test]
fn wampler3() {
    check("Wampler3", 9.3);
}

#[test]
fn wampler4() {
    check("Wampler4", 8.2);
}

#[test]
fn wampler5() {
    check("Wampler5", 6.2);
}

/// The parser must see the certified values it is checking against.
#[test]
fn certified_values_are_parsed() {
    let c = parse("Wampler5");
    assert_eq!(c.coeffs, vec![1.0; 6]);
    assert_eq!(c.residual_sd, 23601450.2379268);
    assert_eq!(c.r_squared, 0.224668921574940E-02);
    assert_eq!((c.x[20], c.y[20]), (20.0, 10_958_421.0));
}
