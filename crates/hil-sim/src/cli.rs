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
/// shell run the rest as another command), a hint to quote it; for one that is a state's two
/// letters with something else (or nothing) between them (`DF`, `d/f`, `D F`), the state it
/// names; otherwise empty.
pub fn ampersand_hint(value: &str) -> String {
    let v = value.trim();
    if matches!(v, "F" | "D" | "f" | "d") {
        return format!(
            ". An unquoted & ends a shell command: did you mean '{}&…'? Quote state names, \
             e.g. --target 'D&F'",
            v.to_ascii_uppercase()
        );
    }
    let letters: Vec<char> = v
        .chars()
        .filter(char::is_ascii_alphabetic)
        .map(|c| c.to_ascii_uppercase())
        .collect();
    let others = v.chars().filter(|c| !c.is_ascii_alphabetic()).count();
    if let ([top, bottom], 0..=1) = (letters.as_slice(), others) {
        let guess = format!("{top}&{bottom}");
        if guess.parse::<geometry::TrunkState>().is_ok() && guess != v {
            return format!(". Did you mean '{guess}'?");
        }
    }
    String::new()
}

/// Parses a `--sim-trunk-scale` value: a number in [`crate::physics::spec::SCALE_RANGE`].
pub fn parse_trunk_scale(s: &str) -> Result<f64, String> {
    let v = s
        .trim()
        .parse::<f64>()
        .map_err(|_| format!("'{s}' is not a number: a snap-force scale is e.g. 0.8 or 1.2"))?;
    crate::physics::spec::check_scale(v).map_err(|e| e.to_string())
}

/// Parses a `--trunk-spread` value: a fraction in [0, 1).
pub fn parse_trunk_spread(s: &str) -> Result<f64, String> {
    let v = s
        .trim()
        .parse::<f64>()
        .map_err(|_| format!("'{s}' is not a number: a trunk spread is e.g. 0.25 (±25 %)"))?;
    crate::physics::spec::check_spread(v).map_err(|e| e.to_string())
}

/// The trunk of `--sim-trunk FILE` (the calibrated `trunks/pdf.toml` without it) with every
/// snap force times `--sim-trunk-scale K`, checked: the physics can represent it.
pub fn sim_trunk(
    file: Option<&std::path::Path>,
    scale: Option<f64>,
) -> Result<crate::physics::TrunkSpec, crate::physics::TrunkError> {
    let spec = match file {
        Some(path) => crate::physics::TrunkSpec::load(path)?,
        None => crate::physics::TrunkSpec::pdf(),
    };
    let spec = match scale {
        Some(k) => spec.scaled(k)?,
        None => spec,
    };
    spec.params()?;
    Ok(spec)
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
        assert_eq!(ampersand_hint("DF"), ". Did you mean 'D&F'?");
        assert_eq!(ampersand_hint("f/p"), ". Did you mean 'F&P'?");
        assert_eq!(ampersand_hint(" d f "), ". Did you mean 'D&F'?");
        // Letters that name no state (P is only a bottom state), or too much in between.
        assert_eq!(ampersand_hint("PD"), "");
        assert_eq!(ampersand_hint("D&&F"), "");
        assert_eq!(ampersand_hint("DFF"), "");
    }
}
