//! Helpers shared by the end-to-end test binaries (`mod common;` in each).
// Each test binary uses its own subset.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

/// The `hoverbench` binary under test.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_hoverbench"))
}

/// Runs `hoverbench ARGS` to completion.
pub fn run(args: &[&str]) -> Output {
    bin().args(args).output().unwrap()
}

/// Asserts that `hoverbench ARGS` succeeded and returns its stdout.
pub fn success(args: &[&str], out: Output) -> String {
    assert!(
        out.status.success(),
        "hoverbench {args:?} failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// Runs `hoverbench ARGS`, asserts success and returns stdout.
pub fn ok(args: &[&str]) -> String {
    success(args, run(args))
}

/// Runs `hoverbench ARGS`, asserts success and parses stdout as JSON.
pub fn json(args: &[&str]) -> Value {
    serde_json::from_str(&ok(args)).unwrap()
}

/// Runs `hoverbench ARGS`: (exit code, stdout, stderr), the code -1 when a signal ended it.
pub fn outcome(args: &[&str]) -> (i32, String, String) {
    let out = run(args);
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
    )
}

/// The workspace root (where the binary's `Cargo.toml` is).
pub fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// A file of `tests/data`.
pub fn data_path(name: &str) -> PathBuf {
    root().join("tests/data").join(name)
}

/// A file of `tests/data`, as a string argument.
pub fn data(name: &str) -> String {
    data_path(name).to_str().unwrap().to_owned()
}

/// A file of the shared real data (`../shared/data/real`, which CI has beside the clone).
pub fn shared_path(rel: &str) -> PathBuf {
    root().join("../shared/data/real").join(rel)
}

/// A file of the shared real data, as a string argument.
pub fn shared(rel: &str) -> String {
    shared_path(rel).to_str().unwrap().to_owned()
}

/// The names of the entries of a folder, sorted.
pub fn file_names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// Asserts that an HTML report refers to nothing outside itself.
pub fn assert_self_contained(html: &str) {
    for bad in [
        "http://", "https://", "file:", "<script", "<link", "<img", "@import", "url(",
    ] {
        assert!(
            !html.contains(bad),
            "the report refers outside itself: {bad:?}"
        );
    }
}

/// Asserts that a run was refused as bad input: exit code 2 and `needle` in its stderr.
/// Returns the stderr.
pub fn refused(out: &Output, needle: &str) -> String {
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains(needle), "expected {needle:?} in {err}");
    err
}

/// A mission plan nested `depth` deep: `1x(1x(…hover 2m…))`.
pub fn nested_plan(depth: usize) -> String {
    format!("{}hover 2m{}", "1x(".repeat(depth), ")".repeat(depth))
}

/// Replaces each line of a text file that starts with `key` (indentation aside) by `line`.
/// Panics when no line does; returns the 1-based number of the first one replaced.
pub fn replace_line(path: &Path, key: &str, line: &str) -> usize {
    let text = std::fs::read_to_string(path).unwrap();
    let mut first = None;
    let new: Vec<&str> = text
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if l.trim_start().starts_with(key) {
                first.get_or_insert(i + 1);
                line
            } else {
                l
            }
        })
        .collect();
    let first = first.unwrap_or_else(|| panic!("{key} not in {}", path.display()));
    std::fs::write(path, new.join("\n") + "\n").unwrap();
    first
}

/// `csv` with the cell of `column` in data row `row` (0: the first row under the header, the
/// first line that is not a `#` comment) set to `value`; returns the text and the 1-based line
/// of that row. Panics when the column or the row is absent.
pub fn with_cell(csv: &str, row: usize, column: &str, value: &str) -> (String, usize) {
    let mut lines: Vec<String> = csv.lines().map(str::to_owned).collect();
    let header = lines.iter().position(|l| !l.starts_with('#')).unwrap();
    let col = lines[header]
        .split(',')
        .position(|c| c == column)
        .unwrap_or_else(|| panic!("no column {column} in {}", lines[header]));
    let at = header + 1 + row;
    let mut cells: Vec<String> = lines[at].split(',').map(str::to_owned).collect();
    cells[col] = value.to_owned();
    lines[at] = cells.join(",");
    (lines.join("\n") + "\n", at + 1)
}

/// The paper's platform and its Battery A (Table I) as `estimate` flags.
pub const BATTERY_A_MISSION: [&str; 8] = [
    "--structure-mass",
    "431g",
    "--avionics-power",
    "2.44",
    "--battery-mass",
    "144g",
    "--energy-density",
    "164",
];
