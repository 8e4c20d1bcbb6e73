//! # hob-rt-os: the operating system's real-time helpers
//!
//! The real-time set-up of the loop thread and its clock: memory lock, stack pre-fault,
//! core pinning, SCHED_FIFO, the idle-state latency request, the helper threads kept off
//! the loop's core, absolute sleeps on CLOCK_MONOTONIC. Start-up only, except
//! [`now_ns`] and [`sleep_until_ns`] which the loop calls once per cycle.
//!
//! What the service needs (never root): `CAP_SYS_NICE` or `RLIMIT_RTPRIO` >= the loop's
//! priority for SCHED_FIFO, and `RLIMIT_MEMLOCK` unlimited (or `CAP_IPC_LOCK`) for
//! `mlockall`. `deploy/systemd/hob-rt.service` grants both. Write access to
//! `/dev/cpu_dma_latency` for the idle-state request (`deploy/udev/` grants it to the
//! group `hob`).
//!
//! And [`durable`]: files replaced whole or not at all (temporary file, `fsync`, rename,
//! `fsync` of the directory), for every file the project writes for the operator (the
//! library and the machine state through `hob_store::atomic`, the logger's index).

pub mod alloc_guard;
pub mod durable;

use nix::sys::mman::{MlockAllFlags, mlockall};
use nix::sys::resource::{Resource, getrlimit};
use nix::sys::signal::{SaFlags, SigAction, SigHandler, SigSet, Signal, sigaction};
use nix::sys::time::TimeSpec;
use nix::time::{ClockId, ClockNanosleepFlags, clock_gettime, clock_nanosleep};
use std::sync::atomic::{AtomicBool, Ordering};

/// What the set-up achieved; each failure says why and how to fix it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RtReport {
    pub memory_locked: bool,
    pub core: Option<u32>,
    pub fifo_priority: Option<u32>,
    /// The PM QoS idle-state latency held while the loop runs, us (None: not held).
    pub cpu_dma_latency_us: Option<u32>,
    pub problems: Vec<String>,
}

impl RtReport {
    pub fn is_complete(&self) -> bool {
        self.problems.is_empty()
    }
}

fn limit(r: Resource) -> String {
    match getrlimit(r) {
        Ok((soft, _)) if soft == libc::RLIM_INFINITY => "unlimited".into(),
        Ok((soft, _)) => soft.to_string(),
        Err(e) => format!("unknown ({e})"),
    }
}

/// Locks current and future memory. Call after the shared-memory ports exist: under a
/// small `RLIMIT_MEMLOCK`, `MCL_FUTURE` makes later mappings fail.
pub fn lock_memory(report: &mut RtReport) {
    match mlockall(MlockAllFlags::MCL_CURRENT | MlockAllFlags::MCL_FUTURE) {
        Ok(()) => report.memory_locked = true,
        Err(e) => report.problems.push(format!(
            "mlockall failed ({e}): RLIMIT_MEMLOCK is {} bytes; give the service LimitMEMLOCK=infinity \
             or CAP_IPC_LOCK (the systemd unit does)",
            limit(Resource::RLIMIT_MEMLOCK)
        )),
    }
}

/// Touches `bytes` of stack so the loop never page-faults on it.
pub fn prefault_stack(bytes: usize) {
    fn touch<const N: usize>() {
        let buf = [0u8; N];
        std::hint::black_box(&buf);
    }
    // In 64 KiB steps so the frames really are that deep.
    fn rec(left: usize) {
        touch::<65536>();
        if left > 65536 {
            rec(left - 65536);
        }
    }
    rec(bytes);
}

/// Pins the calling thread to `core`. Any core the kernel has may be named, also one this
/// process was not started on: an isolated core (`isolcpus`) is outside every process's
/// default affinity, and a parent that keeps itself off the loop's core passes that on.
pub fn pin(core: u32, report: &mut RtReport) {
    if core as usize >= libc::CPU_SETSIZE as usize {
        report.problems.push(format!(
            "core {core} is beyond the {} a CPU set can name: set service.loop_core",
            libc::CPU_SETSIZE
        ));
        return;
    }
    // Not `core_affinity::get_core_ids()`: it lists only the cores already allowed.
    if core_affinity::set_for_current(core_affinity::CoreId { id: core as usize }) {
        report.core = Some(core);
    } else {
        let e = std::io::Error::last_os_error();
        report.problems.push(format!(
            "could not pin the loop to core {core} ({e}): the core does not exist, is offline \
             or outside this service's cpuset (systemd AllowedCPUs, docker --cpuset-cpus); \
             {} cores online: set service.loop_core",
            std::thread::available_parallelism().map_or(0, |n| n.get())
        ));
    }
}

/// Keeps the calling (helper) thread off the loop's `core`: allowed on every other core
/// this process may use. Without isolated cores a helper would otherwise share the loop's
/// core, and on a kernel without full preemption its system calls delay the loop's
/// wake-up. Does nothing when `core` is the only core. Returns whether it moved.
pub fn keep_off_core(core: u32) -> bool {
    use nix::sched::{CpuSet, sched_getaffinity, sched_setaffinity};
    use nix::unistd::Pid;
    let Ok(mut set) = sched_getaffinity(Pid::from_raw(0)) else {
        return false;
    };
    let others = (0..CpuSet::count())
        .filter(|&c| c != core as usize && set.is_set(c).unwrap_or(false))
        .count();
    if others == 0 || set.unset(core as usize).is_err() {
        return false;
    }
    sched_setaffinity(Pid::from_raw(0), &set).is_ok()
}

/// [`keep_off_core`] for every thread of this process (each in `/proc/self/task`), for a
/// process that learns the loop's core only after it started its threads; threads started
/// later inherit it from the thread that starts them. False if any thread could not be
/// moved.
pub fn keep_process_off_core(core: u32) -> bool {
    use nix::sched::{CpuSet, sched_getaffinity, sched_setaffinity};
    use nix::unistd::Pid;
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return false;
    };
    let mut all = true;
    for tid in tasks
        .flatten()
        .filter_map(|e| e.file_name().to_str()?.parse::<i32>().ok())
    {
        let pid = Pid::from_raw(tid);
        let Ok(mut set) = sched_getaffinity(pid) else {
            all = false;
            continue;
        };
        let others = (0..CpuSet::count())
            .filter(|&c| c != core as usize && set.is_set(c).unwrap_or(false))
            .count();
        all &= others > 0 && set.unset(core as usize).is_ok() && sched_setaffinity(pid, &set).is_ok();
    }
    all
}

/// A held PM QoS request on `/dev/cpu_dma_latency`: while the file stays open no CPU
/// enters an idle state that takes longer than the value to leave. Dropping it releases
/// the request.
#[derive(Debug)]
pub struct IdleLatencyRequest {
    _file: std::fs::File,
}

/// Asks the kernel to keep every CPU out of idle states slower than `latency_us` to leave
/// (0: none but polling), for as long as the returned request lives. cyclictest does the
/// same unless `--laptop`: without it, waking a deeply idle core costs tens of us on every
/// cycle (measured on this project's VM: hob-rt's wake-up p50 53 us vs cyclictest's 20,
/// 22.6 vs 22.0 with the request held).
pub fn hold_cpu_dma_latency(latency_us: u32, report: &mut RtReport) -> Option<IdleLatencyRequest> {
    use std::io::Write as _;
    const PATH: &str = "/dev/cpu_dma_latency";
    let value = i32::try_from(latency_us).unwrap_or(i32::MAX);
    let held = std::fs::OpenOptions::new()
        .write(true)
        .open(PATH)
        .and_then(|mut f| f.write_all(&value.to_ne_bytes()).map(|()| f));
    match held {
        Ok(file) => {
            report.cpu_dma_latency_us = Some(latency_us);
            Some(IdleLatencyRequest { _file: file })
        }
        Err(e) => {
            report.problems.push(format!(
                "{PATH}: {e}: the CPUs may enter deep idle states and every cycle pays their \
                 exit latency; give the service write access (deploy/udev/90-hob.rules)"
            ));
            None
        }
    }
}

/// Makes the calling thread SCHED_FIFO at `priority`.
#[allow(unsafe_code)]
pub fn set_fifo(priority: u32, report: &mut RtReport) {
    let param = libc::sched_param {
        sched_priority: priority as libc::c_int,
    };
    // SAFETY: plain FFI call on the current thread with a valid, initialised parameter.
    let rc = unsafe { libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) };
    if rc == 0 {
        report.fifo_priority = Some(priority);
    } else {
        report.problems.push(format!(
            "SCHED_FIFO {priority} refused ({}): RLIMIT_RTPRIO is {}; give the service \
             CAP_SYS_NICE or LimitRTPRIO={priority} (the systemd unit does)",
            std::io::Error::from_raw_os_error(rc),
            limit(Resource::RLIMIT_RTPRIO)
        ));
    }
}

static TERMINATION: AtomicBool = AtomicBool::new(false);

extern "C" fn on_signal(_: libc::c_int) {
    TERMINATION.store(true, Ordering::Relaxed);
}

/// Turns SIGTERM and SIGINT into a flag the loop reads (for a controlled stop).
#[allow(unsafe_code)]
pub fn termination_flag() -> &'static AtomicBool {
    let action = SigAction::new(
        SigHandler::Handler(on_signal),
        SaFlags::SA_RESTART,
        SigSet::empty(),
    );
    for sig in [Signal::SIGTERM, Signal::SIGINT] {
        // SAFETY: the handler only stores into an atomic (async-signal-safe).
        let _ = unsafe { sigaction(sig, &action) };
    }
    &TERMINATION
}

/// Whether the running kernel is PREEMPT_RT.
pub fn kernel_is_preempt_rt() -> bool {
    std::fs::read_to_string("/sys/kernel/realtime").is_ok_and(|s| s.trim() == "1")
}

/// CLOCK_MONOTONIC now, ns.
pub fn now_ns() -> u64 {
    clock_gettime(ClockId::CLOCK_MONOTONIC).map_or(0, |t| {
        (t.tv_sec() as u64)
            .wrapping_mul(1_000_000_000)
            .wrapping_add(t.tv_nsec() as u64)
    })
}

/// Sleeps until the absolute CLOCK_MONOTONIC time `t_ns` (returns at once if it passed;
/// an interruption by a signal just returns early).
pub fn sleep_until_ns(t_ns: u64) {
    let ts = TimeSpec::new((t_ns / 1_000_000_000) as _, (t_ns % 1_000_000_000) as _);
    let _ = clock_nanosleep(ClockId::CLOCK_MONOTONIC, ClockNanosleepFlags::TIMER_ABSTIME, &ts);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_absolute_sleep_never_returns_before_its_deadline() {
        let t = now_ns() + 2_000_000;
        sleep_until_ns(t);
        assert!(now_ns() >= t);
    }

    /// The cores the calling thread may run on.
    fn allowed_cores() -> Vec<usize> {
        use nix::sched::{CpuSet, sched_getaffinity};
        let set = sched_getaffinity(nix::unistd::Pid::from_raw(0)).unwrap();
        (0..CpuSet::count()).filter(|&c| set.is_set(c).unwrap()).collect()
    }

    #[test]
    fn a_helper_thread_leaves_the_loop_core_to_the_loop() {
        let usable = allowed_cores();
        let core = usable[0];
        let (moved, after) = std::thread::spawn(move || (keep_off_core(core as u32), allowed_cores()))
            .join()
            .unwrap();
        if usable.len() > 1 {
            assert!(moved);
            assert_eq!(after, usable[1..]);
        } else {
            // The only core: nowhere else to go, the thread stays.
            assert!(!moved);
            assert_eq!(after, usable);
        }
    }

    const DMA_LATENCY: &str = "/dev/cpu_dma_latency";

    /// The strictest idle-state request in force, us: reading the device gives it.
    fn latency_in_force() -> i32 {
        use std::io::Read as _;
        let mut b = [0u8; 4];
        std::fs::File::open(DMA_LATENCY)
            .and_then(|mut f| f.read_exact(&mut b))
            .unwrap();
        i32::from_ne_bytes(b)
    }

    /// This process's descriptors on the device, each as whether it is open for writing
    /// (`/proc/self/fdinfo`'s flags). No other test of this crate opens the device.
    fn own_descriptors_on_device() -> Vec<bool> {
        let mut found = Vec::new();
        for fd in std::fs::read_dir("/proc/self/fd").unwrap().flatten() {
            if std::fs::read_link(fd.path()).is_ok_and(|l| l == std::path::Path::new(DMA_LATENCY)) {
                let info = std::fs::read_to_string(format!(
                    "/proc/self/fdinfo/{}",
                    fd.file_name().to_string_lossy()
                ))
                .unwrap();
                let flags = info
                    .lines()
                    .find_map(|l| l.strip_prefix("flags:"))
                    .and_then(|f| i32::from_str_radix(f.trim(), 8).ok())
                    .unwrap();
                found.push(flags & libc::O_ACCMODE != libc::O_RDONLY);
            }
        }
        found
    }

    /// Whether another process may hold a request of its own (it has the device open, or
    /// its descriptors cannot be read): the value in force may then be its, not ours.
    fn another_process_may_hold() -> bool {
        let me = std::process::id().to_string();
        std::fs::read_dir("/proc").unwrap().flatten().any(|p| {
            let name = p.file_name();
            let Some(pid) = name.to_str() else { return false };
            if pid == me || !pid.bytes().all(|b| b.is_ascii_digit()) {
                return false;
            }
            match std::fs::read_dir(p.path().join("fd")) {
                Ok(fds) => fds.flatten().any(|fd| {
                    std::fs::read_link(fd.path()).is_ok_and(|l| l == std::path::Path::new(DMA_LATENCY))
                }),
                // Gone meanwhile: holds nothing; not ours to read: may hold.
                Err(e) => e.kind() == std::io::ErrorKind::PermissionDenied,
            }
        })
    }

    /// Which answer is right is decided here first, on its own: whether this process may
    /// open the device for writing (root may; the service may through deploy/udev). Then:
    /// granted, the request holds the device open for writing while it lives, no CPU may
    /// use an idle state slower than 7 us to leave (exactly 7 in force when no other
    /// request is), and dropping it closes the device and lifts the limit; refused, the
    /// report says why (the device, the system's error) and how to get it (the udev rule,
    /// which exists and grants the device).
    #[test]
    fn the_idle_state_request_holds_while_it_lives_or_says_how_to_get_it() {
        let may_write = std::fs::OpenOptions::new()
            .write(true)
            .open(DMA_LATENCY)
            .map(drop);
        assert_eq!(
            own_descriptors_on_device(),
            Vec::<bool>::new(),
            "before the request"
        );
        let others_before = another_process_may_hold();
        let in_force_before = may_write.as_ref().map_or(i32::MIN, |()| latency_in_force());
        let mut r = RtReport::default();
        let held = hold_cpu_dma_latency(7, &mut r);
        match (may_write, held) {
            (Ok(()), Some(request)) => {
                eprintln!("granted ({DMA_LATENCY} writable; {in_force_before} us in force before)");
                assert_eq!(r.cpu_dma_latency_us, Some(7));
                assert!(r.problems.is_empty(), "{:?}", r.problems);
                assert_eq!(
                    own_descriptors_on_device(),
                    [true],
                    "the request holds the device open for writing"
                );
                let held_in_force = latency_in_force();
                // Only ours can be in force: no other process has the device, and nothing
                // stricter than 7 us was before.
                let ours_alone = in_force_before > 7 && !others_before && !another_process_may_hold();
                assert!(
                    held_in_force <= 7,
                    "{held_in_force} us in force while the request of 7 us lives"
                );
                if ours_alone {
                    assert_eq!(held_in_force, 7, "ours is the only request in force");
                }
                drop(request);
                assert_eq!(
                    own_descriptors_on_device(),
                    Vec::<bool>::new(),
                    "the dropped request left the device open"
                );
                let after = latency_in_force();
                if ours_alone && !another_process_may_hold() {
                    assert!(
                        after > 7,
                        "{after} us still in force after the request was dropped (before: {in_force_before})"
                    );
                }
            }
            (Err(why), None) => {
                eprintln!("refused ({DMA_LATENCY}: {why})");
                assert_eq!(r.cpu_dma_latency_us, None);
                assert_eq!(r.problems.len(), 1, "{:?}", r.problems);
                let p = &r.problems[0];
                assert!(
                    p.starts_with(&format!("{DMA_LATENCY}: {why}: "))
                        && p.ends_with("give the service write access (deploy/udev/90-hob.rules)"),
                    "{p}"
                );
                // The rule named is shipped and grants the device.
                let rules = std::fs::read_to_string(concat!(
                    env!("CARGO_MANIFEST_DIR"),
                    "/../../deploy/udev/90-hob.rules"
                ))
                .unwrap();
                assert!(
                    rules
                        .lines()
                        .any(|l| l.starts_with("KERNEL==\"cpu_dma_latency\"") && l.contains("MODE=\"0660\"")),
                    "{rules}"
                );
                assert_eq!(
                    own_descriptors_on_device(),
                    Vec::<bool>::new(),
                    "nothing left open"
                );
            }
            (may_write, held) => panic!(
                "{DMA_LATENCY} opens for writing here: {may_write:?}; the request: {held:?}, {:?}",
                r.problems
            ),
        }
    }

    #[test]
    fn the_loop_pins_to_a_core_its_parent_kept_off() {
        let usable = allowed_cores();
        if usable.len() < 2 {
            return; // one core: nothing to keep off
        }
        let loop_core = usable[1] as u32;
        let r = std::thread::spawn(move || {
            // The benchmark keeps itself off the loop's core and starts hob-rt (as an
            // isolated core is outside a service's default affinity).
            assert!(keep_off_core(loop_core));
            let mut r = RtReport::default();
            pin(loop_core, &mut r);
            (r, allowed_cores())
        })
        .join()
        .unwrap();
        assert_eq!(r.0.core, Some(loop_core), "{:?}", r.0.problems);
        assert_eq!(r.1, vec![loop_core as usize]);
    }

    #[test]
    fn a_missing_core_is_reported_not_panicked() {
        let mut r = RtReport::default();
        pin(100_000, &mut r);
        assert_eq!(r.core, None);
        assert!(r.problems[0].contains("service.loop_core"), "{:?}", r.problems);
        // Within a CPU set but not on this machine (run in a thread: a success would move it).
        let r = std::thread::spawn(|| {
            let mut r = RtReport::default();
            pin(1000, &mut r);
            r
        })
        .join()
        .unwrap();
        assert_eq!(r.core, None);
        assert!(r.problems[0].contains("does not exist"), "{:?}", r.problems);
    }
}
