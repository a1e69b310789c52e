//! A trunk state as its name (`D&F`); read with `TrunkState`'s parser (any case, `-` for `&`).

use geometry::TrunkState;
use serde::{de, Deserialize, Deserializer, Serializer};

/// Writes the name.
pub fn serialize<S: Serializer>(state: &TrunkState, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(state.name())
}

/// Reads a name; the error names the six states.
pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<TrunkState, D::Error> {
    let name = String::deserialize(d)?;
    name.parse().map_err(|e| {
        de::Error::custom(format!(
            "invalid trunk state '{name}': {e}{}",
            hil_sim::cli::ampersand_hint(&name)
        ))
    })
}

/// The same for an optional state (`null`: none).
pub mod option {
    use geometry::TrunkState;
    use serde::{Deserialize, Deserializer, Serializer};

    /// Writes the name or `null`.
    pub fn serialize<S: Serializer>(state: &Option<TrunkState>, s: S) -> Result<S::Ok, S::Error> {
        match state {
            Some(st) => s.serialize_some(st.name()),
            None => s.serialize_none(),
        }
    }

    /// Reads a name or `null`.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<TrunkState>, D::Error> {
        #[derive(Deserialize)]
        struct Name(#[serde(with = "super")] TrunkState);
        Ok(Option::<Name>::deserialize(d)?.map(|n| n.0))
    }
}
