//! End-to-end: a failing command prints each reason once. The first line says what failed
//! (`error: …`, with the file, line and value), each `caused by: …` line says why, and no cause
//! repeats text printed above it; bad input exits with 2.

mod common;

use std::path::Path;

use common::{bin, data, replace_line};

/// `error:` and `caused by:` lines of a run's stderr, without their prefixes.
fn chain(stderr: &str) -> Vec<&str> {
    let mut lines = Vec::new();
    for l in stderr.lines() {
        if let Some(t) = l.strip_prefix("error: ") {
            lines.push(t);
        } else if let Some(t) = l.strip_prefix("  caused by: ") {
            assert!(!lines.is_empty(), "a cause before the error:\n{stderr}");
            lines.push(t);
        }
    }
    lines
}

/// Runs `hoverbench ARGS` in `dir`, asserts exit code 2, an `error:` line, at least `causes`
/// `caused by:` lines, and that no line of the chain holds another's text. Returns stderr.
fn fails_once(dir: &Path, args: &[&str], causes: usize) -> String {
    let out = bin().current_dir(dir).args(args).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "{args:?}:\n{err}");
    let lines = chain(&err);
    assert!(
        lines.len() > causes,
        "{args:?}: expected an error and {causes} cause(s):\n{err}"
    );
    for (i, later) in lines.iter().enumerate().skip(1) {
        for earlier in &lines[..i] {
            assert!(
                !earlier.contains(later) && !later.contains(earlier),
                "{args:?}: {later:?} repeats {earlier:?}:\n{err}"
            );
        }
    }
    err
}

#[test]
fn each_reason_is_printed_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let missing = d.join("missing.csv");
    let missing = missing.to_str().unwrap();

    // A file that is not there: what (the file) on the first line, why (the OS) once below.
    for args in [
        vec!["fit", missing],
        vec!["import", missing],
        vec!["rig-gap", missing],
        vec!["export", "px4", "--sweep", missing],
        vec!["flights", missing],
    ] {
        let err = fails_once(d, &args, 1);
        assert!(
            err.contains(&format!("error: cannot read {missing}")),
            "{err}"
        );
        let os = if args[0] == "flights" {
            "no such file or folder"
        } else {
            "No such file or directory"
        };
        assert_eq!(err.matches(os).count(), 1, "{args:?}:\n{err}");
    }

    // Malformed CSV: the file, line and column in one line.
    std::fs::write(d.join("quote.csv"), "thrust_g,power_w\n1,2\n\"3,4\n").unwrap();
    let err = fails_once(d, &["fit", "quote.csv"], 0);
    assert!(err.contains("quote.csv, line 3, column 1"), "{err}");

    // Parameter files: missing, malformed, and values the estimator refuses.
    let estimate = |params: &str| {
        vec![
            "estimate",
            "--params",
            params,
            "--battery-mass",
            "0.1",
            "--battery-energy",
            "10",
            "--structure-mass",
            "0.2",
            "--avionics-power",
            "1",
        ]
        .into_iter()
        .map(str::to_owned)
        .collect::<Vec<_>>()
    };
    let run = |args: Vec<String>, causes| {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        fails_once(d, &args, causes)
    };
    let err = run(estimate("missing.toml"), 1);
    assert!(err.contains("error: cannot read missing.toml"), "{err}");
    std::fs::write(d.join("bad.toml"), "nonsense = [\n").unwrap();
    let err = run(estimate("bad.toml"), 0);
    assert!(err.contains("bad.toml: line 1, column"), "{err}");
    let params = d.join("params.toml");
    let fit = bin()
        .current_dir(d)
        .args(["fit", &data("paper-sweep.csv"), "-o", "params.toml"])
        .output()
        .unwrap();
    assert!(fit.status.success(), "{fit:?}");
    let generic = d.join("generic.toml");
    std::fs::copy(&params, &generic).unwrap();
    replace_line(&params, "rotor_count", "rotor_count = 0");
    let err = run(estimate("params.toml"), 1);
    assert!(
        err.contains(
            "params.toml: line 6, column 15, rotor_count: values the estimator cannot use"
        ),
        "{err}"
    );
    assert!(
        err.contains("caused by: rotor count must be at least 1"),
        "{err}"
    );
    replace_line(&generic, "x =", "x = \"current_a\"");
    let err = run(
        ["replay", "--params", "generic.toml", "missing.csv"]
            .map(str::to_owned)
            .to_vec(),
        1,
    );
    assert!(
        err.contains("generic.toml cannot drive the estimator"),
        "{err}"
    );
    assert!(
        err.contains("caused by: the curve is power_w vs current_a"),
        "{err}"
    );

    // A flight set with no flight in it.
    std::fs::create_dir(d.join("empty")).unwrap();
    let err = fails_once(d, &["flights", "empty"], 0);
    assert!(err.contains("no flight logs"), "{err}");

    // A serial port that does not exist: what the command did, which port, why.
    let err = fails_once(
        d,
        &[
            "sweep",
            "--rig",
            "/dev/hoverbench-no-such-port",
            "--supply",
            "/dev/hoverbench-no-such-supply",
            "-o",
            "sweep.csv",
        ],
        2,
    );
    assert!(
        err.contains("serial port /dev/hoverbench-no-such-port"),
        "{err}"
    );
}

#[test]
fn every_chemistry_prior_is_accepted_and_listed() {
    let names: Vec<&str> = gap::battery::Chemistry::PRIORS
        .iter()
        .map(|c| c.name())
        .collect();
    assert!(names.contains(&"lifepo4"), "{names:?}");
    let help = bin().args(["battery", "learn", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&help.stdout);
    for args in [vec!["battery", "learn", "--params", "p.toml"], vec!["gap"]] {
        let with = |chemistry: &str| {
            let out = bin()
                .args(&args)
                .args(["--chemistry", chemistry, "missing-flights"])
                .output()
                .unwrap();
            let err = String::from_utf8_lossy(&out.stderr).into_owned();
            (out.status.code(), err)
        };
        let (code, err) = with("lead_acid");
        assert_eq!(code, Some(2), "{args:?}: {err}");
        assert!(err.contains("invalid value 'lead_acid'"), "{args:?}: {err}");
        for n in &names {
            assert!(err.contains(n), "{args:?}: {n} not listed in {err}");
            assert!(help.contains(n), "battery learn --help lacks {n}:\n{help}");
        }
        // Every listed name gets past the argument parser (to the missing files).
        for n in &names {
            let (_, err) = with(n);
            assert!(!err.contains("invalid value"), "{args:?} {n}: {err}");
        }
    }
}

/// The text from `open` (an opening bracket at `text[0]`) to its matching close, both included;
/// brackets inside string literals do not count.
fn balanced(text: &str, open: char, close: char) -> &str {
    let (mut depth, mut in_str, mut escaped) = (0usize, false, false);
    for (i, c) in text.char_indices() {
        if in_str {
            match (escaped, c) {
                (true, _) => escaped = false,
                (false, '\\') => escaped = true,
                (false, '"') => in_str = false,
                _ => {}
            }
        } else if c == '"' {
            in_str = true;
        } else if c == open {
            depth += 1;
        } else if c == close {
            depth -= 1;
            if depth == 0 {
                return &text[..=i];
            }
        }
    }
    text
}

/// What opens an error message attribute (spelt in two parts so that this file does not hold
/// one outside its scan's test).
const ERROR_ATTR: &str = concat!("#[err", "or(");

/// The offending variants of one source file: a `#[error(...)]` whose format arguments name a
/// field that is also the variant's source (`#[source]`, `#[from]` or named `source`).
fn cause_in_display(text: &str) -> Vec<String> {
    // Comments may hold brackets; the attribute and fields are what matter.
    let code: String = text
        .lines()
        .map(|l| match l.trim_start().starts_with("//") {
            true => "",
            false => l,
        })
        .collect::<Vec<_>>()
        .join("\n");
    let mut found = Vec::new();
    for (at, _) in code.match_indices(ERROR_ATTR) {
        let attr = balanced(&code[at + 7..], '(', ')');
        if attr.contains("transparent") {
            continue;
        }
        let rest = &code[at + 7 + attr.len()..];
        let Some(start) = rest.find(['{', '(', ',']) else {
            continue;
        };
        let name = rest[..start]
            .trim()
            .trim_start_matches(']')
            .trim()
            .to_owned();
        let fields = match rest.as_bytes()[start] {
            b'{' => balanced(&rest[start..], '{', '}'),
            b'(' => balanced(&rest[start..], '(', ')'),
            _ => continue,
        };
        let inner = &fields[1..fields.len() - 1];
        let mut sources = Vec::new();
        for (k, field) in inner.split(',').enumerate() {
            let field = field.trim();
            let marked = field.contains("#[source]") || field.contains("#[from]");
            let named = field
                .rsplit(']')
                .next()
                .and_then(|f| f.split(':').next())
                .map(str::trim)
                .unwrap_or_default();
            if rest.as_bytes()[start] == b'(' {
                if marked {
                    sources.push(k.to_string());
                }
            } else if marked || named == "source" {
                sources.push(named.to_owned());
            }
        }
        for s in sources {
            // `{source}`, `{0:?}`; as an argument `.source`, `.0` (not `{:.0}`), `, source`.
            let named = !s.starts_with(|c: char| c.is_ascii_digit());
            let uses = [format!("{{{s}}}"), format!("{{{s}:")]
                .iter()
                .any(|p| attr.contains(p.as_str()))
                || attr.contains(&format!(", {s})"))
                || attr.contains(&format!(", {s}."))
                || (named && attr.contains(&format!(".{s}")))
                || attr.contains(&format!("self.{s}"))
                || attr.contains(&format!("*.{s}"));
            if uses {
                let line = code[..at].lines().count() + 1;
                found.push(format!(
                    "line {line}: {name} shows its source {s} in {attr}"
                ));
            }
        }
    }
    found
}

#[test]
fn no_error_variant_shows_its_source_in_its_message() {
    // A known offender is found, so the scan below means something.
    let bad = r#"enum E {
        ATTR"{path}: {source}")]
        Io { path: String, source: std::io::Error },
        ATTR"fit: {0}")]
        Fit(#[from] F),
        ATTR"{what}")]
        Fine { what: String, #[source] error: X },
        ATTR"{:.0} g", .1)]
        Neither(#[from] F, f64),
    }"#
    .replace("ATTR", ERROR_ATTR);
    let found = cause_in_display(&bad);
    assert_eq!(found.len(), 2, "{found:?}");

    let mut stack = vec![common::root().to_path_buf()];
    let mut files = 0;
    let mut offenders = Vec::new();
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            if path.is_dir() {
                if !name.starts_with('.') && name != "target" {
                    stack.push(path);
                }
            } else if name.ends_with(".rs") {
                let text = std::fs::read_to_string(&path).unwrap();
                if text.contains(ERROR_ATTR) {
                    files += 1;
                    for f in cause_in_display(&text) {
                        offenders.push(format!("{}, {f}", path.display()));
                    }
                }
            }
        }
    }
    assert!(files > 10, "only {files} files with error enums found");
    assert!(offenders.is_empty(), "{}", offenders.join("\n"));
}
