//! The memory budget: sizes of large allocations are estimated before they are made, and an
//! estimate above the limit is an error that names the parameter to change, instead of an
//! out-of-memory abort minutes later.
//!
//! The limit is process-wide: [`set_limit`] (the command line's `--memory-limit`), else
//! [`default_limit`], three quarters of the physical memory (`MemTotal` in `/proc/meminfo`,
//! or `sysconf` where that is missing; 4 GiB when neither is known). Estimates are upper
//! bounds of what the stage keeps at its peak, from the sizes of its arrays per element
//! (each estimator states its constants); they are not measurements of the allocator.

use crate::error::{Error, ErrorKind, Result};
use std::sync::atomic::{AtomicU64, Ordering};

/// Fraction of physical memory used as the default limit.
pub const DEFAULT_FRACTION: f64 = 0.75;

/// The limit set with [`set_limit`]; 0 means "not set".
static LIMIT: AtomicU64 = AtomicU64::new(0);

/// Physical memory in bytes, when it can be found out.
pub fn physical_memory() -> Option<u64> {
    if let Ok(text) = std::fs::read_to_string("/proc/meminfo") {
        for line in text.lines() {
            if let Some(rest) = line.strip_prefix("MemTotal:") {
                let kb = rest
                    .trim()
                    .trim_end_matches("kB")
                    .trim()
                    .parse::<u64>()
                    .ok()?;
                return kb.checked_mul(1024);
            }
        }
    }
    // SAFETY: `sysconf` only reads system configuration.
    let (pages, size) = unsafe {
        (
            libc::sysconf(libc::_SC_PHYS_PAGES),
            libc::sysconf(libc::_SC_PAGESIZE),
        )
    };
    if pages > 0 && size > 0 {
        (pages as u64).checked_mul(size as u64)
    } else {
        None
    }
}

/// [`DEFAULT_FRACTION`] of [`physical_memory`], or 4 GiB when that is unknown.
pub fn default_limit() -> u64 {
    match physical_memory() {
        Some(b) => (b as f64 * DEFAULT_FRACTION) as u64,
        None => 4 << 30,
    }
}

/// The limit in force, in bytes.
pub fn limit() -> u64 {
    match LIMIT.load(Ordering::Relaxed) {
        0 => default_limit(),
        b => b,
    }
}

/// Sets the process-wide limit (`bytes ≥ 1`; 0 restores the default).
pub fn set_limit(bytes: u64) {
    LIMIT.store(bytes, Ordering::Relaxed);
}

/// Parses a size: a number of bytes with an optional suffix `K`, `M`, `G`, `T` (powers of
/// 1024; `KiB`, `MB`, … are read the same), e.g. `8G`, `512M`, `1.5G`, `1000000`.
pub fn parse_size(text: &str) -> Result<u64> {
    let t = text.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let scale: u64 = match unit.trim().to_ascii_uppercase().as_str() {
        "" | "B" => 1,
        "K" | "KB" | "KIB" => 1 << 10,
        "M" | "MB" | "MIB" => 1 << 20,
        "G" | "GB" | "GIB" => 1 << 30,
        "T" | "TB" | "TIB" => 1 << 40,
        _ => {
            return Err(Error::new(
                ErrorKind::Usage,
                format!("invalid size '{text}' (expected e.g. 8G, 512M or a number of bytes)"),
            ))
        }
    };
    let x: f64 = num.parse().map_err(|_| {
        Error::new(
            ErrorKind::Usage,
            format!("invalid size '{text}' (expected e.g. 8G, 512M or a number of bytes)"),
        )
    })?;
    let bytes = x * scale as f64;
    if !(bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(Error::new(
            ErrorKind::Usage,
            format!("size '{text}' is out of range (at least 1 byte)"),
        ));
    }
    Ok(bytes as u64)
}

/// A byte count for messages: `17.6 GiB`, `512.0 MiB`, `900 bytes`.
pub fn human(bytes: f64) -> String {
    const UNITS: [&str; 6] = ["KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    if bytes < 1024.0 {
        return format!("{bytes:.0} bytes");
    }
    let mut x = bytes / 1024.0;
    let mut u = 0;
    while x >= 1024.0 && u + 1 < UNITS.len() {
        x /= 1024.0;
        u += 1;
    }
    format!("{x:.1} {}", UNITS[u])
}

/// Checks an estimate against [`limit`]: `what` says what would be allocated, `change` which
/// parameter to lower. Estimates are `f64` so that products of large counts cannot overflow.
pub fn check(what: &str, bytes: f64, change: &str) -> Result<()> {
    check_with(limit(), what, bytes, change)
}

/// [`check`] against an explicit limit.
pub fn check_with(limit: u64, what: &str, bytes: f64, change: &str) -> Result<()> {
    if bytes.is_nan() || bytes > limit as f64 {
        return Err(Error::new(
            ErrorKind::Usage,
            format!(
                "{what} would need about {} of memory, above the limit of {}; {change}, or \
                 raise --memory-limit",
                human(bytes),
                human(limit as f64)
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes() {
        assert_eq!(parse_size("8G").unwrap(), 8 << 30);
        assert_eq!(parse_size("512MiB").unwrap(), 512 << 20);
        assert_eq!(parse_size("1.5k").unwrap(), 1536);
        assert_eq!(parse_size("1000000").unwrap(), 1_000_000);
        for bad in ["", "G", "-1G", "1X", "0", "1e99T", "nan"] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
        assert_eq!(human(900.0), "900 bytes");
        assert_eq!(human(1.5 * 1024.0 * 1024.0 * 1024.0), "1.5 GiB");
    }

    #[test]
    fn checks() {
        assert!(check_with(1000, "x", 1000.0, "lower y").is_ok());
        let e = check_with(1000, "the film", 2048.0, "lower the width")
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "the film would need about 2.0 KiB of memory, above the limit of 1000 bytes; \
             lower the width, or raise --memory-limit"
        );
        assert!(check_with(1000, "x", f64::NAN, "y").is_err());
        assert!(check_with(1000, "x", f64::INFINITY, "y").is_err());
        assert!(physical_memory().is_some_and(|b| b > 0));
        assert!(default_limit() > 0);
    }
}
