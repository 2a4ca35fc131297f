//! Arrays of scene files (positions, velocities, boxes, the camera) read with their
//! exact length.

use serde::Deserialize;

/// Reads an array of exactly `N` numbers: serde's arrays stop after `N` and ignore the
/// rest, so `velocity = [1, 0, 0, 5]` would run as `[1, 0, 0]` without a word.
pub fn exact_array<'de, D, const N: usize>(d: D) -> Result<[f32; N], D::Error>
where
    D: serde::Deserializer<'de>,
{
    let v = Vec::<f32>::deserialize(d)?;
    let len = v.len();
    v.try_into().map_err(|_| {
        serde::de::Error::invalid_length(len, &format!("an array of {N} numbers").as_str())
    })
}

/// [`exact_array`] for a key that may be omitted (`#[serde(default)]` gives `None`).
pub fn exact_array_opt<'de, D, const N: usize>(d: D) -> Result<Option<[f32; N]>, D::Error>
where
    D: serde::Deserializer<'de>,
{
    exact_array(d).map(Some)
}
