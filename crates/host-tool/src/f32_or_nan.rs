//! An `f32` that JSON writes as `null` when it is not a number (serde_json's form of NaN),
//! read back as NaN.

use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// Writes the number (`null` for NaN or an infinity, as serde_json does).
pub fn serialize<S: Serializer>(v: &f32, s: S) -> Result<S::Ok, S::Error> {
    v.serialize(s)
}

/// Reads a number, `null` as NaN.
pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f32, D::Error> {
    Ok(Option::<f32>::deserialize(d)?.unwrap_or(f32::NAN))
}
