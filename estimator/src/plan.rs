//! The mission plan language (`std` feature): `"hover 2m; attach 30m; hover until empty"`.
//!
//! Grammar (case-insensitive; segments separated by `;` or new lines):
//!
//! ```text
//! plan     = item { ";" item }
//! item     = N "x" "(" plan ")"                      repeat a sub-plan N times
//!          | ("hover" | "attach") DURATION           fixed time: 90s, 2m, 2min, 1.5h
//!          | ("hover" | "attach") "until" "reserve" PCT   until that fraction is left: 10%, 0.1
//!          | "hover" "until" "empty"
//! ```
//!
//! `fly` is accepted for `hover`, `attached` and `perch` for `attach`; a duration without a
//! unit is an error, so that `hover 2` cannot be read as seconds by one user and minutes by
//! another.

use crate::mission::Segment;

/// A plan that does not parse: where and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("plan, column {column}: {message} (near {near:?})")]
pub struct PlanError {
    /// 1-based character column in the plan text.
    pub column: usize,
    /// The text around the problem.
    pub near: String,
    /// What is wrong.
    pub message: String,
}

/// Largest repeat count accepted, to keep a typo from expanding into millions of segments.
const MAX_REPEAT: u32 = 1000;
/// Largest expanded plan.
const MAX_SEGMENTS: usize = 100_000;
/// Deepest nesting of repeats accepted: far beyond any real mission, far below what would
/// overflow the parser's stack (it recurses once per level).
pub const MAX_DEPTH: usize = 32;

/// Parses a plan into its flat list of segments (repeats expanded).
pub fn parse_plan(text: &str) -> Result<Vec<Segment>, PlanError> {
    let chars: Vec<char> = text.chars().collect();
    let mut p = Parser {
        chars: &chars,
        pos: 0,
    };
    let out = p.plan(0)?;
    p.skip_ws();
    if p.pos < chars.len() {
        return Err(p.error("unexpected ')'"));
    }
    if out.is_empty() {
        return Err(p.error("the plan is empty"));
    }
    Ok(out)
}

struct Parser<'a> {
    chars: &'a [char],
    pos: usize,
}

impl Parser<'_> {
    fn error(&self, message: impl Into<String>) -> PlanError {
        let start = self.pos.min(self.chars.len());
        let near: String = self.chars[start..].iter().take(16).collect();
        PlanError {
            column: start + 1,
            near: if near.is_empty() {
                "end of plan".into()
            } else {
                near
            },
            message: message.into(),
        }
    }

    fn skip_ws(&mut self) {
        while self.pos < self.chars.len()
            && self.chars[self.pos].is_whitespace()
            && self.chars[self.pos] != '\n'
        {
            self.pos += 1;
        }
    }

    fn peek(&self) -> Option<char> {
        self.chars.get(self.pos).copied()
    }

    fn word(&mut self) -> String {
        self.skip_ws();
        let start = self.pos;
        while self.pos < self.chars.len()
            && (self.chars[self.pos].is_alphanumeric()
                || matches!(self.chars[self.pos], '.' | '%' | '_'))
        {
            self.pos += 1;
        }
        self.chars[start..self.pos]
            .iter()
            .collect::<String>()
            .to_lowercase()
    }

    fn plan(&mut self, depth: usize) -> Result<Vec<Segment>, PlanError> {
        let mut out = Vec::new();
        loop {
            self.skip_ws();
            match self.peek() {
                None => break,
                Some(';' | '\n') => {
                    self.pos += 1;
                    continue;
                }
                Some(')') if depth > 0 => break,
                Some(')') => return Err(self.error("')' without a matching '('")),
                _ => {}
            }
            self.item(depth, &mut out)?;
            if out.len() > MAX_SEGMENTS {
                return Err(self.error(format!(
                    "the plan expands to more than {MAX_SEGMENTS} segments"
                )));
            }
            self.skip_ws();
            match self.peek() {
                None | Some(';' | '\n') => {}
                Some(')') if depth > 0 => {}
                Some(_) => return Err(self.error("expected ';' between segments")),
            }
        }
        Ok(out)
    }

    fn item(&mut self, depth: usize, out: &mut Vec<Segment>) -> Result<(), PlanError> {
        let at = self.pos;
        let w = self.word();
        if w.is_empty() {
            return Err(self.error("expected 'hover', 'attach' or 'N x ( … )'"));
        }
        // Repeat: "3x(" or "3 x (" or "3*("
        let repeat = w
            .strip_suffix('x')
            .and_then(|n| n.parse::<u32>().ok())
            .or_else(|| w.parse::<u32>().ok());
        if let Some(n) = repeat {
            self.skip_ws();
            if !w.ends_with('x') {
                match self.peek() {
                    Some('x' | 'X' | '*' | '×') => self.pos += 1,
                    _ => {
                        return Err(self.error(
                            "expected 'x' after a repeat count, as in 3x(hover 2m; attach 30m)",
                        ));
                    }
                }
                self.skip_ws();
            }
            if self.peek() != Some('(') {
                return Err(self.error("expected '(' after the repeat count"));
            }
            if n == 0 || n > MAX_REPEAT {
                self.pos = at;
                return Err(self.error(format!("repeat count must be 1 to {MAX_REPEAT}")));
            }
            if depth + 1 > MAX_DEPTH {
                return Err(self.error(format!("repeats are nested more than {MAX_DEPTH} deep")));
            }
            self.pos += 1;
            let body = self.plan(depth + 1)?;
            if self.peek() != Some(')') {
                return Err(self.error("missing ')'"));
            }
            self.pos += 1;
            if body.is_empty() {
                self.pos = at;
                return Err(self.error("a repeat needs at least one segment"));
            }
            for _ in 0..n {
                out.extend_from_slice(&body);
                if out.len() > MAX_SEGMENTS {
                    return Err(self.error(format!(
                        "the plan expands to more than {MAX_SEGMENTS} segments"
                    )));
                }
            }
            return Ok(());
        }
        let hover = match w.as_str() {
            "hover" | "fly" => true,
            "attach" | "attached" | "perch" => false,
            _ => {
                self.pos = at;
                self.skip_ws();
                return Err(self.error(format!(
                    "unknown segment '{w}': use 'hover', 'attach' or 'N x ( … )'"
                )));
            }
        };
        let arg_at = self.pos;
        let arg = self.word();
        if arg == "until" {
            let what = self.word();
            match what.as_str() {
                "empty" if hover => out.push(Segment::HoverUntilEmpty),
                "empty" => {
                    return Err(self.error(
                        "'attach until empty' would never fly home: use 'attach until reserve N%'",
                    ));
                }
                "reserve" => {
                    let val_at = self.pos;
                    let v = self.word();
                    let fraction = parse_fraction(&v).ok_or_else(|| {
                        self.pos = val_at;
                        self.skip_ws();
                        self.error("expected a reserve such as 10% or 0.1")
                    })?;
                    out.push(if hover {
                        Segment::HoverUntilReserve {
                            reserve_fraction: fraction,
                        }
                    } else {
                        Segment::AttachedUntilReserve {
                            reserve_fraction: fraction,
                        }
                    });
                }
                _ => return Err(self.error("expected 'until empty' or 'until reserve N%'")),
            }
            return Ok(());
        }
        let minutes = parse_duration_min(&arg).ok_or_else(|| {
            self.pos = arg_at;
            self.skip_ws();
            self.error("expected a duration with a unit, such as 90s, 2m, 2min or 1.5h")
        })?;
        out.push(if hover {
            Segment::Hover {
                duration_min: minutes,
            }
        } else {
            Segment::Attached {
                duration_min: minutes,
            }
        });
        Ok(())
    }
}

fn parse_duration_min(s: &str) -> Option<f64> {
    let split = s.find(|c: char| c.is_alphabetic())?;
    let (num, unit) = s.split_at(split);
    let v: f64 = num.parse().ok()?;
    if !v.is_finite() || v < 0.0 {
        return None;
    }
    let per_min = match unit {
        "s" | "sec" | "secs" | "second" | "seconds" => 1.0 / 60.0,
        "m" | "min" | "mins" | "minute" | "minutes" => 1.0,
        "h" | "hr" | "hrs" | "hour" | "hours" => 60.0,
        _ => return None,
    };
    Some(v * per_min)
}

fn parse_fraction(s: &str) -> Option<f64> {
    let f = if let Some(p) = s.strip_suffix('%') {
        p.parse::<f64>().ok()? / 100.0
    } else {
        s.parse::<f64>().ok()?
    };
    (f.is_finite() && (0.0..1.0).contains(&f)).then_some(f)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn table_i_plan() {
        let p = parse_plan("3x(hover 2m; attach 30m); hover until empty").unwrap();
        assert_eq!(p.len(), 7);
        assert_eq!(p[0], Segment::Hover { duration_min: 2.0 });
        assert_eq!(p[1], Segment::Attached { duration_min: 30.0 });
        assert_eq!(p[6], Segment::HoverUntilEmpty);
        assert_eq!(
            parse_plan("3 x (hover 120s\nperch 0.5h)\nhover until empty").unwrap(),
            p
        );
    }

    #[test]
    fn reserves() {
        assert_eq!(
            parse_plan("hover until reserve 25%; attach until reserve 0.1").unwrap(),
            vec![
                Segment::HoverUntilReserve {
                    reserve_fraction: 0.25
                },
                Segment::AttachedUntilReserve {
                    reserve_fraction: 0.1
                },
            ]
        );
    }

    #[test]
    fn errors_point_at_the_problem() {
        let e = parse_plan("hover 2m; jump 3m").unwrap_err();
        assert_eq!(e.column, 11);
        assert!(e.message.contains("unknown segment 'jump'"), "{e}");
        let e = parse_plan("hover 2").unwrap_err();
        assert!(e.message.contains("duration with a unit"), "{e}");
        assert!(parse_plan("").is_err());
        assert!(
            parse_plan("3x(hover 2m")
                .unwrap_err()
                .message
                .contains("missing ')'")
        );
        assert!(parse_plan("hover 2m)").is_err());
        assert!(parse_plan("0x(hover 2m)").is_err());
        assert!(parse_plan("attach until empty").is_err());
        assert!(parse_plan("hover until reserve 150%").is_err());
        assert!(parse_plan("hover -2m").is_err());
    }

    #[test]
    fn deep_nesting_is_an_error_not_a_stack_overflow() {
        // ~19,000 levels overflowed the stack before the depth limit
        let deep = format!("{}hover 2m{}", "1x(".repeat(19_000), ")".repeat(19_000));
        let e = parse_plan(&deep).unwrap_err();
        assert!(e.message.contains("nested more than 32 deep"), "{e}");
        assert_eq!(e.column, 3 * MAX_DEPTH + 3);
        // an unclosed deep plan too
        assert!(parse_plan(&"2x(".repeat(100_000)).is_err());
        // the limit itself is fine
        let ok = format!(
            "{}hover 2m{}",
            "1x(".repeat(MAX_DEPTH),
            ")".repeat(MAX_DEPTH)
        );
        assert_eq!(parse_plan(&ok).unwrap().len(), 1);
    }

    proptest! {
        #[test]
        fn never_panics(s in "\\PC{0,60}") {
            let _ = parse_plan(&s);
        }

        #[test]
        fn never_panics_on_plan_like_text(s in "[0-9x();% a-z.\\n]{0,60}") {
            let _ = parse_plan(&s);
        }

        #[test]
        fn durations_round_trip(mins in 0.0f64..1.0e4) {
            let p = parse_plan(&format!("hover {mins}m")).unwrap();
            prop_assert_eq!(p, vec![Segment::Hover { duration_min: mins }]);
        }
    }
}
