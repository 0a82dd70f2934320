//! Parsers of the command line's values: on/off, levels, non-negative
//! numbers, seconds and memory sizes with binary units.

/// `on` or `off`.
pub fn on_off(value: &str) -> Result<bool, String> {
    match value {
        "on" => Ok(true),
        "off" => Ok(false),
        _ => Err("expected on or off".into()),
    }
}

/// `auto`, `finest` or a level number.
pub fn level_choice(value: &str) -> Result<qm::LevelChoice, String> {
    match value {
        "auto" => Ok(qm::LevelChoice::Auto),
        "finest" => Ok(qm::LevelChoice::Finest),
        _ => match value.parse::<u32>() {
            Ok(level) if level <= qm::lift::MAX_LEVEL => Ok(qm::LevelChoice::Fixed(level)),
            _ => Err(format!(
                "expected auto, finest or a level from 0 to {}",
                qm::lift::MAX_LEVEL
            )),
        },
    }
}

/// A finite number, 0 or more.
pub fn non_negative(value: &str) -> Result<f64, String> {
    match value.trim().parse::<f64>() {
        Ok(x) if x.is_finite() && x >= 0.0 => Ok(x),
        _ => Err("expected a finite number, 0 or more".into()),
    }
}

/// A time in seconds, more than 0 and at most an hour.
pub fn seconds(value: &str) -> Result<f64, String> {
    match value.trim().parse::<f64>() {
        Ok(s) if s > 0.0 && s <= 3600.0 => Ok(s),
        _ => Err("expected seconds, more than 0 and at most 3600".into()),
    }
}

/// A memory size: bytes, or a number with K, M, G or T (powers of 1024;
/// `MiB`, `GB` and the like mean the same), e.g. `512M`, `1.5G`.
pub fn memory_size(value: &str) -> Result<u64, String> {
    let text = value.trim();
    let split = text
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(text.len());
    let (number, unit) = text.split_at(split);
    let shift = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 0,
        "k" | "kb" | "kib" => 10,
        "m" | "mb" | "mib" => 20,
        "g" | "gb" | "gib" => 30,
        "t" | "tb" | "tib" => 40,
        _ => return Err(format!("unknown unit {unit:?} (use K, M, G or T)")),
    };
    let x: f64 = number
        .parse()
        .map_err(|_| format!("{value:?} is not a size such as 512M or 2G"))?;
    let bytes = x * (1u64 << shift) as f64;
    if !(bytes.is_finite() && (1.0..1.8e19).contains(&bytes)) {
        return Err(format!("{value:?} is not a size between 1 byte and 16 EiB"));
    }
    Ok(bytes as u64)
}

#[cfg(test)]
mod tests {
    use super::memory_size;

    #[test]
    fn memory_sizes_parse_with_binary_units() {
        assert_eq!(memory_size("1024"), Ok(1024));
        assert_eq!(memory_size("512M"), Ok(512 << 20));
        assert_eq!(memory_size("512MiB"), Ok(512 << 20));
        assert_eq!(memory_size("1.5G"), Ok(3 << 29));
        assert_eq!(memory_size("2 gb"), Ok(2 << 30));
        for bad in ["", "G", "12Q", "-1M", "0", "1e99", "nan"] {
            assert!(memory_size(bad).is_err(), "{bad:?}");
        }
    }
}
