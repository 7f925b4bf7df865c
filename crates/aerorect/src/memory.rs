//! How much decoded imagery a run keeps between its uses: an adjusted flight's photos and gray
//! levels, a mosaic's frames. What is kept changes no result, only how often a photo is
//! decoded (116 ms for a 16-Mpx JPEG): a flight of 167 such photos keeps their levels for
//! every matching round in 3.5 GB, and a mosaic whose tile rows cross more frames than it
//! keeps decodes each of them once per row of tiles it spans.

/// The least kept (1 GiB: the snowpeak flight's 11 photos are 525 MB and their gray levels
/// 233 MB), and what is kept where the available memory is not known.
pub const MIN_CACHE_BYTES: usize = 1 << 30;

/// The most kept (4 GiB: the gray levels of 167 photos of 16 Mpx take 3.5 GB).
pub const MAX_CACHE_BYTES: usize = 4 << 30;

/// A quarter of the memory available now (Linux's `MemAvailable`), within
/// [`MIN_CACHE_BYTES`] and [`MAX_CACHE_BYTES`]; the least where that is not known.
pub fn cache_budget_bytes() -> usize {
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|m| mem_available(&m))
        .map_or(MIN_CACHE_BYTES, |a| {
            (a / 4).clamp(MIN_CACHE_BYTES, MAX_CACHE_BYTES)
        })
}

/// `MemAvailable` of a `/proc/meminfo` text, in bytes.
fn mem_available(meminfo: &str) -> Option<usize> {
    let kb = meminfo
        .lines()
        .find_map(|l| l.strip_prefix("MemAvailable:"))?
        .trim()
        .strip_suffix("kB")?
        .trim()
        .parse::<usize>()
        .ok()?;
    kb.checked_mul(1024)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `MemAvailable` as the kernel writes it (proc(5): a value in kB), and nothing from a
    /// text without it.
    #[test]
    fn reads_the_available_memory() {
        let meminfo = "MemTotal:       24542108 kB\nMemFree:         1234567 kB\n\
                       MemAvailable:   20971520 kB\nBuffers:          123456 kB\n";
        assert_eq!(mem_available(meminfo), Some(20 << 30));
        assert_eq!(mem_available("MemTotal: 1 kB\nMemFree: 1 kB\n"), None);
        assert_eq!(mem_available("MemAvailable: lots\n"), None);
        let budget = cache_budget_bytes();
        assert!(
            (MIN_CACHE_BYTES..=MAX_CACHE_BYTES).contains(&budget),
            "{budget}"
        );
    }
}
