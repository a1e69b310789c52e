//! The command-line conventions `hil-sim` and `host-tool` share for the simulator's options:
//! one parser for a seed, one hint for a state name the shell cut at its `&`.

/// Parses a seed: any integer. A negative seed counts modulo 2^64 (`-3` is `2^64 - 3`), so
/// every integer names one run.
pub fn parse_seed(s: &str) -> Result<u64, String> {
    let t = s.trim();
    if let Ok(v) = t.parse::<u64>() {
        return Ok(v);
    }
    match t.parse::<i64>() {
        Ok(v) => Ok(v as u64),
        Err(_) if t.parse::<f64>().is_ok() => Err(format!(
            "'{s}' is not a whole number: a seed is any integer (e.g. 1, -3)"
        )),
        Err(_) => Err(format!(
            "'{s}' is not an integer: a seed is any integer (e.g. 1, -3)"
        )),
    }
}

/// For a state argument that is a state's first half (`D` of `D&F`: an unquoted `&` made the
/// shell run the rest as another command), a hint to quote it; otherwise empty.
pub fn ampersand_hint(value: &str) -> String {
    let v = value.trim();
    if matches!(v, "F" | "D" | "f" | "d") {
        format!(
            ". An unquoted & ends a shell command: did you mean '{}&…'? Quote state names, \
             e.g. --target 'D&F'",
            v.to_ascii_uppercase()
        )
    } else {
        String::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seeds_are_any_integer() {
        assert_eq!(parse_seed("0"), Ok(0));
        assert_eq!(parse_seed("18446744073709551615"), Ok(u64::MAX));
        assert_eq!(parse_seed("-3"), Ok(u64::MAX - 2));
        assert_eq!(parse_seed("-9223372036854775808"), Ok(1 << 63));
        assert!(parse_seed("1.5").unwrap_err().contains("whole number"));
        assert!(parse_seed("x").unwrap_err().contains("any integer"));
        assert!(parse_seed("18446744073709551616").is_err());
    }

    #[test]
    fn a_state_cut_at_its_ampersand_gets_the_quoting_hint() {
        assert!(ampersand_hint("D").contains("--target 'D&F'"));
        assert!(ampersand_hint("F").contains("'F&…'"));
        assert_eq!(ampersand_hint("X&Y"), "");
    }
}
