//! The CPU time of the calling thread: the clock for timing fits on a shared, loaded machine,
//! where wall-clock time measures the other jobs as much as the fit.
//!
//! In: nothing. Out: seconds of user plus system time, `None` where the clock cannot be read.
//! Linux only: it reads `/proc/thread-self/stat` (100 ticks/s), the one place this otherwise
//! pure crate touches the operating system beyond `std::time`.

/// CPU time of the calling thread, s, from `/proc/thread-self/stat` (Linux, 100 ticks/s);
/// `None` elsewhere.
pub fn thread_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/thread-self/stat").ok()?;
    let rest = &stat[stat.rfind(')')? + 1..];
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let utime: f64 = fields.get(11)?.parse().ok()?;
    let stime: f64 = fields.get(12)?.parse().ok()?;
    Some((utime + stime) / 100.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On Linux the clock reads and advances (never backwards) while the thread works.
    #[test]
    #[cfg(target_os = "linux")]
    fn thread_clock_reads_and_does_not_go_back() {
        let a = thread_cpu_seconds().expect("readable on Linux");
        let mut x = 0.0_f64;
        for i in 0..20_000_000 {
            x += (i as f64).sqrt();
        }
        std::hint::black_box(x);
        let b = thread_cpu_seconds().expect("readable on Linux");
        assert!(a >= 0.0 && b >= a, "{a} then {b}");
    }
}
