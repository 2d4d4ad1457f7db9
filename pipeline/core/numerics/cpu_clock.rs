//! The CPU time of the calling thread: the clock for timing fits on a shared, loaded machine,
//! where wall-clock time measures the other jobs as much as the fit.
//!
//! In: nothing. Out: seconds of user plus system time, `None` where the clock cannot be read.
//! A clock like `std::time::Instant` (POSIX `CLOCK_THREAD_CPUTIME_ID`), not a file read: the
//! crate stays free of file-system access.

/// CPU time of the calling thread, s (POSIX thread CPU-time clock); `None` where there is none.
#[cfg(unix)]
pub fn thread_cpu_seconds() -> Option<f64> {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec that outlives the call, which only writes it.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    (rc == 0).then_some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
}

/// CPU time of the calling thread: not available on this platform.
#[cfg(not(unix))]
pub fn thread_cpu_seconds() -> Option<f64> {
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On Unix the clock reads and advances (never backwards) while the thread works.
    #[test]
    #[cfg(unix)]
    fn thread_clock_reads_and_advances() {
        let a = thread_cpu_seconds().expect("readable on Unix");
        let mut x = 0.0_f64;
        for i in 0..20_000_000 {
            x += (i as f64).sqrt();
        }
        std::hint::black_box(x);
        let b = thread_cpu_seconds().expect("readable on Unix");
        assert!(a >= 0.0 && b > a, "{a} then {b}");
    }
}
