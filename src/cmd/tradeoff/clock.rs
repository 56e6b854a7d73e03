//! Timing a SLAM trial on the CPU clock of the thread that runs it, so that a setting's time is
//! its own even when other processes share the cores.

use std::time::Instant;

/// CPU time of the calling thread (s), where the platform has a per-thread clock. The in-process
/// graph runs on one thread, so this is a trial's own cost, unaffected by other processes
/// sharing the cores; on an idle core it equals the wall-clock time.
fn thread_cpu_s() -> Option<f64> {
    #[cfg(unix)]
    {
        let mut ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: `ts` is a valid, writable timespec; the call only writes it.
        if unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) } == 0 {
            return Some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9);
        }
    }
    None
}

/// Measures `work` on the thread CPU clock, or the wall clock where there is none.
pub(super) fn timed<T>(work: impl FnOnce() -> T) -> (T, f64) {
    let (cpu, wall) = (thread_cpu_s(), Instant::now());
    let value = work();
    let seconds = match (cpu, thread_cpu_s()) {
        (Some(start), Some(end)) => end - start,
        _ => wall.elapsed().as_secs_f64(),
    };
    (value, seconds)
}
