//! What a run will need from the machine, checked before it is asked for: memory for a mesh of
//! a given size (so that an absurd mesh is refused with an estimate instead of aborting on
//! allocation) and the cores a thread count can use.

/// Resident bytes per tet of a run, measured with `/usr/bin/time -v tetsim run
/// scenes/bench/beam_n20.toml --frames 2` (192,000 tets, the default AMG preconditioner,
/// damping, pictures on): 351 MB peak, 1.83 KB a tet (the peak includes A·P during an AMG
/// refresh and the pictures; `tetsim bench --sizes 36` peaks at 1.49 KB a tet); rounded up.
pub const BYTES_PER_TET: f64 = 2000.0;

/// Memory the system can give a new allocation without swapping, bytes (Linux's MemAvailable;
/// None where unknown, and then nothing is refused).
pub fn available_memory() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024.0)
}

/// Why a run on `tets` tets would not fit in memory, or None when it fits (or the available
/// memory is unknown).
pub fn memory_shortfall(tets: f64) -> Option<String> {
    let need = tets * BYTES_PER_TET;
    let have = available_memory()?;
    (need > have).then(|| {
        format!(
            "{tets:.3e} tets would need about {} of memory ({BYTES_PER_TET} bytes a tet), \
             but {} is available",
            bytes(need),
            bytes(have)
        )
    })
}

/// A byte count in words (kB … PB).
pub fn bytes(b: f64) -> String {
    let units = ["bytes", "kB", "MB", "GB", "TB", "PB", "EB"];
    let mut value = b;
    let mut unit = 0;
    while value >= 1000.0 && unit + 1 < units.len() {
        value /= 1000.0;
        unit += 1;
    }
    if unit + 1 == units.len() && value >= 1000.0 {
        return format!("{b:.1e} bytes");
    }
    format!("{value:.1} {}", units[unit])
}

/// Cores this process may run on (at least 1).
pub fn available_cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_are_said_in_words() {
        assert_eq!(bytes(512.0), "512.0 bytes");
        assert_eq!(bytes(3.8e12), "3.8 TB");
        assert_eq!(bytes(1e30), "1.0e30 bytes");
    }

    #[test]
    fn an_absurd_mesh_does_not_fit() {
        if available_memory().is_some() {
            assert!(memory_shortfall(1e18).is_some());
            assert!(memory_shortfall(10.0).is_none());
        }
    }
}
