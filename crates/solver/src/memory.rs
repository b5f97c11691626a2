//! The memory budget a Cholesky factorisation may use, checked after the symbolic analysis and
//! before the factor is allocated, so that a mesh too fine for the machine is refused with a
//! clear message instead of the process being killed by the kernel's out-of-memory killer.
//!
//! The budget is [`MEMORY_FRACTION`] of `MemAvailable` in `/proc/meminfo` (the rest is left for
//! the assembly buffers, the Hessian, frames and other processes), or the byte count in the
//! environment variable [`MEMORY_LIMIT_ENV`] when it is set (suffixes `K`, `M`, `G` are powers
//! of 1024; it lets tests inject a small limit and lets a user cap a run). Where neither is
//! known (no `/proc`), nothing is refused.

/// Environment variable overriding the memory budget (bytes, optional `K`/`M`/`G` suffix).
pub const MEMORY_LIMIT_ENV: &str = "THINSHELL_MEMORY_LIMIT";

/// Fraction of `MemAvailable` a factorisation may use.
pub const MEMORY_FRACTION: f64 = 0.8;

/// How the budget is set, for messages.
pub const BUDGET_RULE: &str =
    "budget: 80% of MemAvailable in /proc/meminfo, or THINSHELL_MEMORY_LIMIT bytes when set";

/// Parses a byte count with an optional binary suffix (`512M`, `2G`, `1048576`).
pub fn parse_bytes(text: &str) -> Option<u64> {
    let t = text.trim();
    let (digits, unit) = match t.char_indices().last()? {
        (i, 'k' | 'K') => (&t[..i], 1u64 << 10),
        (i, 'm' | 'M') => (&t[..i], 1 << 20),
        (i, 'g' | 'G') => (&t[..i], 1 << 30),
        _ => (t, 1),
    };
    digits.trim().parse::<u64>().ok()?.checked_mul(unit)
}

/// `MemAvailable` of `/proc/meminfo`, bytes; `None` where it cannot be read.
pub fn mem_available() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

/// The memory budget of one factorisation, bytes (see the module documentation); `None` when
/// unknown. An unparsable [`MEMORY_LIMIT_ENV`] is ignored (the `/proc` budget applies).
pub fn memory_budget() -> Option<u64> {
    if let Some(limit) = std::env::var(MEMORY_LIMIT_ENV)
        .ok()
        .and_then(|v| parse_bytes(&v))
    {
        return Some(limit);
    }
    mem_available().map(|b| (b as f64 * MEMORY_FRACTION) as u64)
}

/// Bytes in a human unit (`1.5 GiB`).
pub fn human_bytes(bytes: u64) -> String {
    let b = bytes as f64;
    match bytes {
        0..1024 => format!("{bytes} B"),
        1024..1_048_576 => format!("{:.1} KiB", b / 1024.0),
        1_048_576..1_073_741_824 => format!("{:.1} MiB", b / 1_048_576.0),
        _ => format!("{:.2} GiB", b / 1_073_741_824.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn byte_counts_parse_with_binary_suffixes() {
        assert_eq!(parse_bytes("1048576"), Some(1 << 20));
        assert_eq!(parse_bytes("512K"), Some(512 << 10));
        assert_eq!(parse_bytes("3M"), Some(3 << 20));
        assert_eq!(parse_bytes(" 2g "), Some(2 << 30));
        assert_eq!(parse_bytes("lots"), None);
        assert_eq!(parse_bytes(""), None);
    }

    #[test]
    fn proc_meminfo_is_read_on_linux() {
        if cfg!(target_os = "linux") {
            let b = mem_available().expect("MemAvailable in /proc/meminfo");
            assert!(b > 1 << 20, "MemAvailable {b} B");
        }
    }
}
