//! Facts about this process from the operating system, for reports and benchmarks: memory in
//! use and at its peak, the load average. `None` where the system does not say (not Linux).

/// A `/proc/self/status` field in KiB (`VmRSS`, `VmHWM`).
fn status_kib(field: &str) -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    parse_status_kib(&s, field)
}

fn parse_status_kib(status: &str, field: &str) -> Option<u64> {
    let line = status
        .lines()
        .find(|l| l.split(':').next() == Some(field))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// Resident memory now, KiB.
pub fn rss_kib() -> Option<u64> {
    status_kib("VmRSS")
}

/// Peak resident memory of the process so far, MiB.
pub fn peak_memory_mib() -> Option<f64> {
    status_kib("VmHWM").map(|k| k as f64 / 1024.0)
}

/// The one-minute load average, as the system writes it.
pub fn load_average() -> Option<String> {
    std::fs::read_to_string("/proc/loadavg")
        .ok()?
        .split_whitespace()
        .next()
        .map(str::to_owned)
}

/// CPU time this thread has used so far (not wall time: a busy machine does not inflate it).
/// `None` where the system does not say.
pub fn thread_cpu_time() -> Option<std::time::Duration> {
    #[cfg(target_os = "linux")]
    {
        let t = nix::time::clock_gettime(nix::time::ClockId::CLOCK_THREAD_CPUTIME_ID).ok()?;
        Some(std::time::Duration::new(
            u64::try_from(t.tv_sec()).ok()?,
            u32::try_from(t.tv_nsec()).ok()?,
        ))
    }
    #[cfg(not(target_os = "linux"))]
    None
}

/// CPU time of this process so far, all threads (user + system), to the nanosecond the system
/// keeps. `None` where the system does not say.
pub fn process_cpu_time() -> Option<std::time::Duration> {
    #[cfg(target_os = "linux")]
    {
        let t = nix::time::clock_gettime(nix::time::ClockId::CLOCK_PROCESS_CPUTIME_ID).ok()?;
        Some(std::time::Duration::new(
            u64::try_from(t.tv_sec()).ok()?,
            u32::try_from(t.tv_nsec()).ok()?,
        ))
    }
    #[cfg(not(target_os = "linux"))]
    None
}

/// CPU time of this process so far (user + system, all threads), s: on a shared machine the
/// measure of work that the wall clock is not.
pub fn cpu_seconds() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/stat").ok()?;
    parse_stat_cpu_ticks(&s).map(|t| t as f64 / 100.0)
}

/// utime + stime (fields 14 and 15) of a `/proc/PID/stat` line, clock ticks (USER_HZ = 100).
fn parse_stat_cpu_ticks(stat: &str) -> Option<u64> {
    // the command name (field 2) may hold spaces: count from the closing parenthesis
    let rest = &stat[stat.rfind(')')? + 1..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let utime: u64 = f.get(11)?.parse().ok()?;
    let stime: u64 = f.get(12)?.parse().ok()?;
    Some(utime + stime)
}

#[cfg(test)]
mod tests {
    use super::parse_status_kib;

    #[test]
    fn status_fields_are_read_in_kib() {
        let s = "Name:\tluxnode\nVmHWM:\t  123456 kB\nVmRSS:\t   2048 kB\n";
        assert_eq!(parse_status_kib(s, "VmHWM"), Some(123_456));
        assert_eq!(parse_status_kib(s, "VmRSS"), Some(2048));
        assert_eq!(parse_status_kib(s, "VmSwap"), None);
        assert_eq!(parse_status_kib("VmRSS: lots kB\n", "VmRSS"), None);
    }

    #[test]
    fn thread_cpu_time_advances_with_work_not_with_sleep() {
        if let Some(t0) = super::thread_cpu_time() {
            std::thread::sleep(std::time::Duration::from_millis(50));
            let slept = super::thread_cpu_time().unwrap() - t0;
            let mut x = 0u64;
            for i in 0..20_000_000u64 {
                x = x.wrapping_mul(6364136223846793005).wrapping_add(i);
            }
            std::hint::black_box(x);
            let worked = super::thread_cpu_time().unwrap() - t0 - slept;
            assert!(slept < std::time::Duration::from_millis(20), "{slept:?}");
            assert!(worked > std::time::Duration::from_millis(1), "{worked:?}");
        }
    }

    #[test]
    fn cpu_ticks_are_fields_14_and_15() {
        let line = "42 (lux node) R 1 2 3 4 5 6 7 8 9 10 250 30 0 0 20 0 4 0";
        assert_eq!(super::parse_stat_cpu_ticks(line), Some(280));
        assert_eq!(super::parse_stat_cpu_ticks("garbage"), None);
    }

    #[test]
    fn this_process_has_memory_on_linux() {
        if cfg!(target_os = "linux") {
            let rss = super::rss_kib().expect("VmRSS on Linux");
            let peak = super::peak_memory_mib().expect("VmHWM on Linux");
            assert!(rss > 0 && peak * 1024.0 >= rss as f64 * 0.5, "{rss} {peak}");
        }
    }
}
