//! Durations and sizes as people write them on the command line (`7d`, `12h`, `500MB`, `20GB`)
//! and sizes as they read them (`1.2 GB`).

use std::time::Duration;

/// Splits `text` into its number and its unit (lower case, possibly empty); `expected` names
/// what the number should look like in the error.
fn number_and_unit(text: &str, expected: &str) -> Result<(f64, String), String> {
    let t = text.trim();
    let split = t.find(|c: char| c.is_ascii_alphabetic()).unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let n: f64 = num
        .trim()
        .parse()
        .map_err(|_| format!("\"{text}\": expected {expected}"))?;
    Ok((n, unit.trim().to_ascii_lowercase()))
}

/// Parses `N[s|m|h|d|w]` (a bare number is seconds; `N` may have a fraction).
pub fn parse_duration(text: &str) -> Result<Duration, String> {
    let (n, unit) = number_and_unit(text, "a duration such as 30s, 10m, 12h, 7d")?;
    let scale = match unit.as_str() {
        "" | "s" => 1.0,
        "m" | "min" => 60.0,
        "h" => 3600.0,
        "d" => 86400.0,
        "w" => 7.0 * 86400.0,
        u => {
            return Err(format!(
                "\"{text}\": unknown unit \"{u}\" (s, m, h, d or w)"
            ))
        }
    };
    let s = n * scale;
    if !(0.0..=100.0 * 365.0 * 86400.0).contains(&s) {
        return Err(format!("\"{text}\": out of range"));
    }
    Ok(Duration::from_secs_f64(s))
}

/// Parses `N[B|KB|MB|GB|TB]` (decimal units; KiB, MiB, GiB, TiB binary; a bare number is bytes).
pub fn parse_size(text: &str) -> Result<u64, String> {
    let (n, unit) = number_and_unit(text, "a size such as 500MB or 20GB")?;
    let scale = match unit.as_str() {
        "" | "b" => 1.0,
        "k" | "kb" => 1e3,
        "m" | "mb" => 1e6,
        "g" | "gb" => 1e9,
        "t" | "tb" => 1e12,
        "kib" => 1024.0,
        "mib" => 1024.0 * 1024.0,
        "gib" => 1024.0 * 1024.0 * 1024.0,
        "tib" => 1024.0 * 1024.0 * 1024.0 * 1024.0,
        u => {
            return Err(format!(
                "\"{text}\": unknown unit \"{u}\" (B, KB, MB, GB, TB)"
            ))
        }
    };
    let b = n * scale;
    if !(0.0..1.8e19).contains(&b) {
        return Err(format!("\"{text}\": out of range"));
    }
    Ok(b.round() as u64)
}

/// `1234567` → `1.2 MB`.
pub fn format_bytes(b: u64) -> String {
    const UNITS: [&str; 5] = ["B", "KB", "MB", "GB", "TB"];
    let mut v = b as f64;
    let mut i = 0;
    while v >= 1000.0 && i + 1 < UNITS.len() {
        v /= 1000.0;
        i += 1;
    }
    if i == 0 {
        format!("{b} B")
    } else {
        format!("{v:.1} {}", UNITS[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations() {
        assert_eq!(
            parse_duration("7d").unwrap(),
            Duration::from_secs(7 * 86400)
        );
        assert_eq!(parse_duration("90").unwrap(), Duration::from_secs(90));
        assert_eq!(parse_duration("1.5h").unwrap(), Duration::from_secs(5400));
        assert_eq!(parse_duration("10m").unwrap(), Duration::from_secs(600));
        assert!(parse_duration("7y").is_err());
        assert!(parse_duration("-1d").is_err());
        assert!(parse_duration("d").is_err());
    }

    #[test]
    fn sizes() {
        assert_eq!(parse_size("500MB").unwrap(), 500_000_000);
        assert_eq!(parse_size("1GiB").unwrap(), 1 << 30);
        assert_eq!(parse_size("0").unwrap(), 0);
        assert_eq!(parse_size("2.5 gb").unwrap(), 2_500_000_000);
        assert!(parse_size("5 parsecs").is_err());
        assert_eq!(format_bytes(999), "999 B");
        assert_eq!(format_bytes(1_234_567), "1.2 MB");
    }
}
