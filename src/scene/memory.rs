//! A scene's memory, estimated before anything large is allocated, and the budget it
//! must fit (`BuildOptions::max_memory`, `run --max-memory`).
//!
//! The per-sample costs are peak resident bytes measured on this engine's build, two
//! bodies of the `scale` scene stepped three times, at two sizes each, the difference
//! divided by the difference in counts (`phyxel run scale --steps 3 --backend B
//! --phyxel-count N --surfels M`, under `/usr/bin/time -f %M`):
//!
//! | what | measured |
//! |---|---|
//! | `mls` phyxel, influence 2 / 3 | 3.95 / 9.75 KB |
//! | `sph` phyxel | 1.46 KB |
//! | `lj` phyxel | 2.51 KB |
//! | surfel | 163 B |
//! | `mls-implicit`, per body of n phyxels, beyond `mls` | 340 B × n^(5/3) at influence 2 (the skyline factor's band grows as n^(2/3)) |
//!
//! The model rounds these up: a phyxel costs [`PHYXEL_BASE`] plus [`PHYXEL_STENCIL`]
//! per cubed influence radius (the stencil holds about that many neighbours), the
//! implicit factor grows with the cube of the influence radius as well, and every
//! object adds [`OBJECT_BYTES`]. Small bodies cost less per phyxel (boundary phyxels
//! have fewer neighbours), so the estimate errs high.

use crate::backends;

/// Bytes per phyxel besides its stencil (columns, grids, backend state).
pub const PHYXEL_BASE: f64 = 1_600.0;
/// Bytes per phyxel per cubed influence radius (in phyxel spacings): the MLS stencil.
pub const PHYXEL_STENCIL: f64 = 310.0;
/// Bytes per phyxel of a particle backend (`sph`, `lj`: the larger, `lj`'s).
pub const PHYXEL_PARTICLE: f64 = 2_600.0;
/// Bytes per surfel (columns, binding, grids).
pub const SURFEL_BYTES: f64 = 170.0;
/// Bytes of an implicit body's factor per `n^(5/3)` at an influence radius of 2.
pub const IMPLICIT_FACTOR: f64 = 360.0;
/// Bytes of any object besides its samples.
pub const OBJECT_BYTES: f64 = 64.0 * 1024.0;
/// The default budget's share of the memory the system reports available.
pub const AVAILABLE_SHARE: f64 = 0.8;

/// The estimated bytes of one object of `phyxels` and `surfels` on `backend` ("static"
/// for a static one) with influence radius `influence` (phyxel spacings).
pub fn object_bytes(phyxels: f64, surfels: f64, backend: &str, influence: f32) -> f64 {
    let h3 = (influence as f64).powi(3);
    let per_phyxel = match backend {
        "static" => PHYXEL_BASE,
        "sph" | "lj" => PHYXEL_PARTICLE,
        _ => PHYXEL_BASE + PHYXEL_STENCIL * h3,
    };
    let factor = if backend == backends::mls::implicit::NAME {
        IMPLICIT_FACTOR * h3 / 8.0 * phyxels.powf(5.0 / 3.0)
    } else {
        0.0
    };
    OBJECT_BYTES + per_phyxel * phyxels + SURFEL_BYTES * surfels + factor
}

/// Bytes of memory the system reports available (Linux: `MemAvailable` in
/// `/proc/meminfo`); `None` where it does not say.
pub fn available() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// The default budget: [`AVAILABLE_SHARE`] of [`available`], and where it came from for
/// messages; `None` (no check) where the system does not say.
pub fn default_budget() -> Option<(u64, String)> {
    let a = available()?;
    let budget = (a as f64 * AVAILABLE_SHARE) as u64;
    Some((
        budget,
        format!(
            "{:.0}% of the {} available",
            AVAILABLE_SHARE * 100.0,
            human(a as f64)
        ),
    ))
}

/// `bytes` in the largest binary unit that keeps it above 1 (`1.5 GiB`).
pub fn human(bytes: f64) -> String {
    let units = ["B", "KiB", "MiB", "GiB", "TiB", "PiB"];
    let mut x = bytes;
    let mut k = 0;
    while x >= 1024.0 && k + 1 < units.len() {
        x /= 1024.0;
        k += 1;
    }
    if k == 0 {
        format!("{x:.0} B")
    } else {
        format!("{x:.1} {}", units[k])
    }
}

/// A size as `--max-memory` takes it: bytes, or a number with a binary suffix
/// `K`, `M`, `G`, `T` (optionally followed by `B` or `iB`): `512M`, `1.5G`, `8GiB`.
pub fn parse_size(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let upper = t.to_ascii_uppercase();
    let digits = upper.trim_end_matches("IB").trim_end_matches('B');
    let (number, scale) = match digits.chars().last() {
        Some('K') => (&digits[..digits.len() - 1], 1u64 << 10),
        Some('M') => (&digits[..digits.len() - 1], 1 << 20),
        Some('G') => (&digits[..digits.len() - 1], 1 << 30),
        Some('T') => (&digits[..digits.len() - 1], 1 << 40),
        _ => (digits, 1),
    };
    match number.trim().parse::<f64>() {
        Ok(x) if x.is_finite() && x > 0.0 && x * (scale as f64) < u64::MAX as f64 => {
            Ok((x * scale as f64) as u64)
        }
        _ => Err(format!(
            "'{text}': not a size (bytes, or a number with K, M, G or T: 512M, 1.5G)"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_with_binary_suffixes_and_bad_ones_are_refused() {
        assert_eq!(parse_size("512M"), Ok(512 << 20));
        assert_eq!(parse_size("1.5G"), Ok(3 << 29));
        assert_eq!(parse_size("8GiB"), Ok(8 << 30));
        assert_eq!(parse_size("2kb"), Ok(2048));
        assert_eq!(parse_size("1000"), Ok(1000));
        for bad in ["", "G", "-1G", "0", "1X", "nanG", "1e30T"] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
        assert_eq!(human(1536.0 * 1024.0 * 1024.0), "1.5 GiB");
    }
}
