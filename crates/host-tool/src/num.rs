//! Numbers as people and parsers read them: the shortest decimal that round-trips, without the
//! artefacts of arithmetic (`12.100000000000001`), of a sign on zero (`-0.0`) or of an `f32`
//! widened to `f64` (`30.100000381469727`); and the command line's integer and number
//! arguments, refused with what is expected.

use serde_json::Value;

/// Significant digits kept of a computed `f64`: 15, the most that every `f64` holds exactly, so
/// the noise of the last bits (`0.1 + 0.2`) goes and every measured digit stays.
const F64_DIGITS: usize = 15;

/// `x` without the noise of its last bits and without a negative zero.
pub fn tidy(x: f64) -> f64 {
    if !x.is_finite() {
        return x;
    }
    let y: f64 = format!("{:.*e}", F64_DIGITS - 1, x).parse().unwrap_or(x);
    if y == 0.0 {
        0.0
    } else {
        y
    }
}

/// An `f32` as the `f64` of its shortest decimal (30.1, not 30.100000381469727).
pub fn widen(x: f32) -> f64 {
    if x == 0.0 {
        return 0.0;
    }
    x.to_string().parse().unwrap_or(f64::from(x))
}

/// A JSON number for `x` (tidied), `null` when not finite.
pub fn json(x: f64) -> Value {
    serde_json::Number::from_f64(tidy(x)).map_or(Value::Null, Value::Number)
}

/// A JSON number for an `f32` in its shortest decimal, `null` when not finite.
pub fn json32(x: f32) -> Value {
    serde_json::Number::from_f64(widen(x)).map_or(Value::Null, Value::Number)
}

/// Every floating-point number in `v` tidied; one that is exactly an `f32` (a device's value
/// widened on its way into JSON) gets that `f32`'s shortest decimal.
pub fn clean(v: Value) -> Value {
    match v {
        Value::Number(n) if n.is_f64() => {
            let x = n.as_f64().unwrap_or(f64::NAN);
            let narrow = x as f32;
            if f64::from(narrow) == x && narrow.is_finite() {
                json32(narrow)
            } else {
                json(x)
            }
        }
        Value::Array(a) => Value::Array(a.into_iter().map(clean).collect()),
        Value::Object(o) => Value::Object(o.into_iter().map(|(k, v)| (k, clean(v))).collect()),
        other => other,
    }
}

/// `x` in fixed notation with `decimals` digits, never `-0.0` (a value that rounds to zero is
/// printed without its sign).
pub fn fixed(x: f64, decimals: usize) -> String {
    let s = format!("{x:.decimals$}");
    if s.starts_with('-') && s[1..].bytes().all(|b| b == b'0' || b == b'.') {
        s[1..].to_string()
    } else {
        s
    }
}

/// As [`fixed`], right-aligned in `width` columns.
pub fn fixed_w(x: f64, decimals: usize, width: usize) -> String {
    format!("{:>width$}", fixed(x, decimals))
}

/// A duration of `ms` milliseconds in seconds: `1.5 s`.
pub fn seconds(ms: u64) -> String {
    format!("{} s", tidy(ms as f64 / 1000.0))
}

/// `n thing` or `n things`.
pub fn plural(n: usize, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

/// Parses a count given as `flag`: digits only (no sign, no fraction), in `[min, max]`.
pub fn count(flag: &str, text: &str, min: usize, max: usize) -> Result<usize, String> {
    let t = text.trim();
    let bad = || format!("{flag} must be an integer in [{min}, {max}], got '{text}'");
    if t.is_empty() || !t.bytes().all(|b| b.is_ascii_digit()) {
        return Err(bad());
    }
    match t.parse::<usize>() {
        Ok(v) if (min..=max).contains(&v) => Ok(v),
        _ => Err(bad()),
    }
}

/// [`count`] as a clap value parser.
pub fn count_in(
    flag: &'static str,
    min: usize,
    max: usize,
) -> impl Fn(&str) -> Result<usize, String> + Clone {
    move |s: &str| count(flag, s, min, max)
}

/// A clap parser for an integer in `[lo, hi]` whose refusal says so (`1.5` is not "an
/// invalid digit" but "not a whole number").
pub fn int_in(lo: i64, hi: i64) -> impl Fn(&str) -> Result<u32, String> + Clone {
    move |s: &str| {
        let expected = format!("expected a whole number from {lo} to {hi}");
        let t = s.trim();
        match t.parse::<i64>() {
            Ok(v) if (lo..=hi).contains(&v) => u32::try_from(v).map_err(|_| expected.clone()),
            Ok(v) => Err(format!("{v} is out of range: {expected}")),
            Err(_) if t.parse::<f64>().is_ok_and(f64::is_finite) => {
                Err(format!("'{s}' is not a whole number: {expected}"))
            }
            Err(_) => Err(format!("'{s}' is not a number: {expected}")),
        }
    }
}

/// The low end of the range a number parser accepts.
#[derive(Debug, Clone, Copy)]
pub enum Low {
    /// `lo` itself is accepted.
    From(f64),
    /// Only numbers greater than `lo`.
    Above(f64),
}

/// A clap parser for a finite number from `low` to `hi` (inclusive), in `unit` (`" °C"`, or
/// `""` for a bare number): the refusal says what was given and the range expected.
pub fn ranged(
    low: Low,
    hi: f64,
    unit: &'static str,
) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync + 'static {
    let (inside, expected): (fn(f64, f64) -> bool, String) = match low {
        Low::From(lo) => (|v, lo| v >= lo, format!("from {lo} to {hi}{unit}")),
        Low::Above(lo) => (
            |v, lo| v > lo,
            format!("greater than {lo} and at most {hi}{unit}"),
        ),
    };
    let (Low::From(lo) | Low::Above(lo)) = low;
    move |s: &str| match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && inside(v, lo) && v <= hi => Ok(v),
        Ok(v) if v.is_finite() => Err(format!("{v} is out of range: expected a number {expected}")),
        _ => Err(format!(
            "'{s}' is not a finite number: expected a number {expected}"
        )),
    }
}

/// A clap parser for a finite number in `[lo, hi]`.
pub fn number_in(
    lo: f64,
    hi: f64,
) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync + 'static {
    ranged(Low::From(lo), hi, "")
}

/// A clap parser for a finite number in `(0, hi]`: a duration or a rate that must be positive.
pub fn positive_at_most(
    hi: f64,
) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync + 'static {
    ranged(Low::Above(0.0), hi, "")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arithmetic_noise_negative_zero_and_f32_widening_are_gone() {
        assert_eq!(json(12.100000000000001).to_string(), "12.1");
        assert_eq!(json(0.1 + 0.2).to_string(), "0.3");
        assert_eq!(json(-0.0).to_string(), "0.0");
        assert_eq!(json32(30.1).to_string(), "30.1");
        assert_eq!(json32(-0.0).to_string(), "0.0");
        assert_eq!(json(f64::NAN), Value::Null);
        // Measured digits stay: 15 significant digits survive.
        assert_eq!(json(1.234_567_890_123_45).to_string(), "1.23456789012345");
        let v = clean(serde_json::json!({"p": 30.1f32, "a": [12.100000000000001, -0.0], "n": 3}));
        assert_eq!(v.to_string(), r#"{"a":[12.1,0.0],"n":3,"p":30.1}"#);
    }

    #[test]
    fn positive_numbers_refuse_zero_and_the_top_of_the_range_is_inclusive() {
        let p = positive_at_most(1e9);
        assert_eq!(p("1e9"), Ok(1e9));
        assert_eq!(p("0.001"), Ok(0.001));
        assert!(p("0").unwrap_err().contains("greater than 0"));
        assert!(p("1e20").unwrap_err().contains("out of range"));
        assert!(p("inf").unwrap_err().contains("not a finite number"));
        assert!(p("-1").unwrap_err().contains("out of range"));
    }

    #[test]
    fn fixed_notation_has_no_negative_zero() {
        assert_eq!(fixed(-0.001, 1), "0.0");
        assert_eq!(fixed(-0.0, 2), "0.00");
        assert_eq!(fixed(-0.06, 1), "-0.1");
        assert_eq!(fixed_w(-0.001, 1, 5), "  0.0");
    }

    #[test]
    fn integers_refuse_fractions_and_say_what_is_expected() {
        let p = int_in(1, 50);
        assert_eq!(p("1"), Ok(1));
        assert_eq!(p("50"), Ok(50));
        let e = p("1.5").unwrap_err();
        assert!(
            e.contains("not a whole number") && e.contains("from 1 to 50"),
            "{e}"
        );
        assert!(p("0").unwrap_err().contains("out of range"));
        assert!(p("51").unwrap_err().contains("from 1 to 50"));
        assert!(p("x").unwrap_err().contains("not a number"));
        let f = number_in(0.1, 1000.0);
        assert_eq!(f("0.1"), Ok(0.1));
        assert_eq!(f("1000"), Ok(1000.0));
        assert!(f("1000.5").unwrap_err().contains("from 0.1 to 1000"));
        assert!(f("inf").unwrap_err().contains("finite"));
    }

    #[test]
    fn counts_take_digits_only_and_both_ends_of_their_range() {
        let p = count_in("--modules", 1, 10_000);
        assert_eq!(p("1"), Ok(1));
        assert_eq!(p(" 10000 "), Ok(10_000));
        for bad in [
            "0",
            "10001",
            "-1",
            "+3",
            "2.5",
            "",
            "x",
            "99999999999999999999999",
        ] {
            let e = p(bad).expect_err(bad);
            assert_eq!(
                e,
                format!("--modules must be an integer in [1, 10000], got '{bad}'")
            );
        }
        assert_eq!(count("--certify", "0", 0, 20), Ok(0));
    }

    #[test]
    fn plurals() {
        assert_eq!(plural(1, "point", "points"), "1 point");
        assert_eq!(plural(0, "step", "steps"), "0 steps");
    }
}
