//! `hob doctor`: is this PC ready to hold the 1 ms loop? Checks and explains, with the fix
//! for each: PREEMPT_RT kernel, the loop core's isolation (isolcpus, nohz_full, interrupt
//! affinity), CPU frequency governor and idle states, the real-time limits and capabilities,
//! the CAN interface, iceoryx2's shared-memory directories, the clock source; then a short
//! cyclictest on the loop's core and priority judged by LinuxCNC's guidance (max jitter
//! under 20 us very good, under 50 us acceptable).
//!
//! Everything is read from /sys and /proc, except the CAN details (`ip -details -json link`)
//! and the cyclictest run. Exit status 0 when nothing failed, 1 otherwise.

use hob_setup::config::machine::MachineConfig;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Level {
    Ok,
    Info,
    Warn,
    Fail,
}

#[derive(Debug, Clone, Serialize)]
pub struct Finding {
    pub check: &'static str,
    pub level: Level,
    pub found: String,
    /// What to do (empty when nothing is to be done).
    pub fix: String,
}

fn finding(check: &'static str, level: Level, found: impl Into<String>, fix: impl Into<String>) -> Finding {
    Finding {
        check,
        level,
        found: found.into(),
        fix: fix.into(),
    }
}

fn read(path: impl AsRef<Path>) -> Option<String> {
    std::fs::read_to_string(path).ok().map(|s| s.trim().to_string())
}

/// A kernel CPU list ("1-3,5") as numbers.
pub fn cpu_list(s: &str) -> Vec<u32> {
    let mut v = Vec::new();
    for part in s.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        match part.split_once('-') {
            Some((a, b)) => {
                if let (Ok(a), Ok(b)) = (a.parse::<u32>(), b.parse::<u32>()) {
                    v.extend(a..=b);
                }
            }
            None => v.extend(part.parse::<u32>().ok()),
        }
    }
    v
}

fn others(core: u32) -> String {
    let n = std::thread::available_parallelism().map_or(1, |n| n.get() as u32);
    let rest: Vec<String> = (0..n).filter(|&c| c != core).map(|c| c.to_string()).collect();
    if rest.is_empty() {
        "0".into()
    } else {
        rest.join(",")
    }
}

fn kernel(core: u32) -> Vec<Finding> {
    let release = read("/proc/sys/kernel/osrelease").unwrap_or_default();
    let mut v = vec![if read("/sys/kernel/realtime").as_deref() == Some("1") {
        finding(
            "PREEMPT_RT kernel",
            Level::Ok,
            format!("{release}, /sys/kernel/realtime = 1"),
            "",
        )
    } else {
        finding(
            "PREEMPT_RT kernel",
            Level::Fail,
            format!("{release} is not PREEMPT_RT (no /sys/kernel/realtime = 1): latencies are not bounded"),
            "apt install linux-image-rt-amd64, reboot and choose it (Debian's real-time kernel)",
        )
    }];
    let cmdline = "add to GRUB_CMDLINE_LINUX in /etc/default/grub, then update-grub and reboot";
    let isolated = cpu_list(&read("/sys/devices/system/cpu/isolated").unwrap_or_default());
    v.push(if isolated.contains(&core) {
        finding(
            "isolated loop core",
            Level::Ok,
            format!("core {core} is in isolcpus"),
            "",
        )
    } else {
        finding(
            "isolated loop core",
            Level::Warn,
            format!("core {core} (service.loop_core) is not isolated (isolated: {isolated:?})"),
            format!(
                "isolcpus={core} ({cmdline}); CPUAffinity in deploy/systemd keeps the other processes off it"
            ),
        )
    });
    let nohz = cpu_list(&read("/sys/devices/system/cpu/nohz_full").unwrap_or_default());
    v.push(if nohz.contains(&core) {
        finding("nohz_full", Level::Ok, format!("core {core} runs tickless"), "")
    } else {
        finding(
            "nohz_full",
            Level::Warn,
            format!("core {core} is not in nohz_full: the scheduler tick interrupts the loop"),
            format!("nohz_full={core} rcu_nocbs={core} ({cmdline})"),
        )
    });
    // Interrupts that may land on the loop's core.
    let mut on_core = Vec::new();
    if let Ok(dir) = std::fs::read_dir("/proc/irq") {
        for e in dir.flatten() {
            let name = e.file_name().to_string_lossy().to_string();
            if name.parse::<u32>().is_err() {
                continue;
            }
            let list = read(e.path().join("smp_affinity_list")).unwrap_or_default();
            if cpu_list(&list).contains(&core) {
                on_core.push(name);
            }
        }
    }
    on_core.sort_by_key(|s| s.parse::<u32>().unwrap_or(0));
    v.push(if on_core.is_empty() {
        finding("interrupt affinity", Level::Ok, format!("no interrupt may run on core {core}"), "")
    } else {
        finding(
            "interrupt affinity",
            Level::Warn,
            format!(
                "{} interrupts may run on core {core} (IRQ {})",
                on_core.len(),
                on_core.iter().take(8).cloned().collect::<Vec<_>>().join(", ")
            ),
            format!(
                "irqaffinity={} ({cmdline}), or echo {} > /proc/irq/N/smp_affinity_list (the CAN adapter's interrupt may stay, see its IRQ in /proc/interrupts)",
                others(core),
                others(core)
            ),
        )
    });
    v
}

fn cpu(core: u32) -> Vec<Finding> {
    let base = format!("/sys/devices/system/cpu/cpu{core}");
    let mut v = vec![match read(format!("{base}/cpufreq/scaling_governor")) {
        Some(g) if g == "performance" => finding("CPU frequency governor", Level::Ok, "performance", ""),
        Some(g) => finding(
            "CPU frequency governor",
            Level::Warn,
            format!("core {core}: {g}: frequency changes add latency"),
            "cpupower frequency-set -g performance (package linux-cpupower), or cpufreq.default_governor=performance on the kernel command line",
        ),
        None => finding(
            "CPU frequency governor",
            Level::Info,
            "no cpufreq (fixed frequency, or a virtual machine)",
            "",
        ),
    }];
    let mut deep = Vec::new();
    if let Ok(dir) = std::fs::read_dir(format!("{base}/cpuidle")) {
        for e in dir.flatten() {
            let p = e.path();
            let latency: u64 = read(p.join("latency")).and_then(|s| s.parse().ok()).unwrap_or(0);
            let disabled = read(p.join("disable")).as_deref() == Some("1");
            if latency > 10 && !disabled {
                deep.push(format!(
                    "{} ({latency} us)",
                    read(p.join("name")).unwrap_or_default()
                ));
            }
        }
    }
    v.push(if deep.is_empty() {
        finding("CPU idle states", Level::Ok, format!("no idle state deeper than 10 us exit latency enabled on core {core}"), "")
    } else {
        deep.sort();
        finding(
            "CPU idle states",
            Level::Warn,
            format!("core {core} may sleep in {}", deep.join(", ")),
            "processor.max_cstate=1 intel_idle.max_cstate=1 on the kernel command line, or echo 1 > /sys/devices/system/cpu/cpuN/cpuidle/stateM/disable",
        )
    });
    v
}

/// Effective capability bits of this process.
fn cap_eff() -> u64 {
    read("/proc/self/status")
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("CapEff:"))
                .and_then(|l| u64::from_str_radix(l.trim_start_matches("CapEff:").trim(), 16).ok())
        })
        .unwrap_or(0)
}

fn limits(priority: u32) -> Vec<Finding> {
    const CAP_IPC_LOCK: u32 = 14;
    const CAP_SYS_NICE: u32 = 23;
    let caps = cap_eff();
    let has = |bit: u32| caps & (1 << bit) != 0;
    let rtprio = nix::sys::resource::getrlimit(nix::sys::resource::Resource::RLIMIT_RTPRIO)
        .map_or(0, |(soft, _)| soft);
    let memlock = nix::sys::resource::getrlimit(nix::sys::resource::Resource::RLIMIT_MEMLOCK)
        .map_or(0, |(soft, _)| soft);
    let unit = "deploy/systemd/hob-rt.service grants both (AmbientCapabilities, LimitRTPRIO, LimitMEMLOCK); for a login user: /etc/security/limits.d/hob.conf with `hob - rtprio 95` and `hob - memlock unlimited`";
    let fifo = if has(CAP_SYS_NICE) || rtprio >= u64::from(priority) {
        finding(
            "SCHED_FIFO allowed",
            Level::Ok,
            format!(
                "this user: RLIMIT_RTPRIO {rtprio}, CAP_SYS_NICE {}",
                has(CAP_SYS_NICE)
            ),
            "",
        )
    } else {
        finding(
            "SCHED_FIFO allowed",
            Level::Warn,
            format!(
                "this user: RLIMIT_RTPRIO {rtprio} < service.loop_priority {priority} and no CAP_SYS_NICE: hob-rt would run degraded"
            ),
            unit,
        )
    };
    let lock = if has(CAP_IPC_LOCK) || memlock == nix::libc::RLIM_INFINITY {
        finding(
            "memory lock allowed",
            Level::Ok,
            format!(
                "this user: RLIMIT_MEMLOCK {}, CAP_IPC_LOCK {}",
                if memlock == nix::libc::RLIM_INFINITY {
                    "unlimited".to_string()
                } else {
                    memlock.to_string()
                },
                has(CAP_IPC_LOCK)
            ),
            "",
        )
    } else {
        finding(
            "memory lock allowed",
            Level::Warn,
            format!("this user: RLIMIT_MEMLOCK {memlock} bytes and no CAP_IPC_LOCK: mlockall would fail"),
            unit,
        )
    };
    let idle = if nix::unistd::access("/dev/cpu_dma_latency", nix::unistd::AccessFlags::W_OK).is_ok() {
        finding(
            "idle-state request",
            Level::Ok,
            "this user may write /dev/cpu_dma_latency (service.cpu_dma_latency_us holds the CPUs out of deep idle states)",
            "",
        )
    } else {
        finding(
            "idle-state request",
            Level::Warn,
            "this user cannot write /dev/cpu_dma_latency: hob-rt would run degraded, every wake-up paying the exit from a deep idle state",
            "deploy/udev/90-hob.rules gives the group hob write access (cp to /etc/udev/rules.d/, udevadm control --reload, udevadm trigger)",
        )
    };
    vec![fifo, lock, idle]
}

fn can(iface: &str, bitrate: u32) -> Finding {
    let check = "CAN interface";
    if iface == "shm" {
        return finding(
            check,
            Level::Info,
            "shm: the shared-memory virtual bus (simulation only)",
            "",
        );
    }
    if !Path::new("/sys/class/net").join(iface).exists() {
        return finding(
            check,
            Level::Fail,
            format!("{iface} (can.interface) does not exist"),
            format!(
                "connect the adapter (its driver must load), then: ip link set {iface} type can bitrate {bitrate} restart-ms 100 && ip link set {iface} up"
            ),
        );
    }
    let out = Command::new("ip")
        .args(["-details", "-json", "link", "show", iface])
        .output();
    let Ok(out) = out else {
        return finding(
            check,
            Level::Warn,
            format!("{iface} exists; `ip` is missing"),
            "apt install iproute2",
        );
    };
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_default();
    let link = &j[0];
    let kind = link["linkinfo"]["info_kind"].as_str().unwrap_or("");
    let up = link["flags"]
        .as_array()
        .is_some_and(|f| f.iter().any(|x| x.as_str() == Some("UP")));
    let up_fix = format!("ip link set {iface} up");
    match kind {
        "vcan" => finding(
            check,
            if up { Level::Info } else { Level::Fail },
            format!(
                "{iface}: virtual CAN (test bed), {}",
                if up { "up" } else { "down" }
            ),
            if up { String::new() } else { up_fix },
        ),
        "can" => {
            let data = &link["linkinfo"]["info_data"];
            let rate = data["bittiming"]["bitrate"].as_u64().unwrap_or(0);
            let state = data["state"].as_str().unwrap_or("?");
            let restart = data["restart_ms"].as_u64().unwrap_or(0);
            let mut problems = Vec::new();
            if !up {
                problems.push("down".to_string());
            }
            if rate != u64::from(bitrate) {
                problems.push(format!("bitrate {rate}, configured {bitrate}"));
            }
            if state != "ERROR-ACTIVE" {
                problems.push(format!("state {state}"));
            }
            if restart == 0 {
                problems.push("no automatic restart after bus-off (restart-ms 0)".into());
            }
            let found = format!(
                "{iface}: {} bit/s, {state}, restart-ms {restart}, {}",
                rate,
                if up { "up" } else { "down" }
            );
            if problems.is_empty() {
                finding(check, Level::Ok, found, "")
            } else {
                finding(
                    check,
                    Level::Fail,
                    format!("{found}: {}", problems.join("; ")),
                    format!(
                        "ip link set {iface} down; ip link set {iface} type can bitrate {bitrate} restart-ms 100; ip link set {iface} up (check wiring and 120 ohm termination if it is error-passive or bus-off)"
                    ),
                )
            }
        }
        other => finding(
            check,
            Level::Fail,
            format!("{iface} is not a CAN interface ({other})"),
            "set can.interface in the machine configuration",
        ),
    }
}

fn shared_memory() -> Vec<Finding> {
    let mut v = Vec::new();
    let shm = Path::new("/dev/shm");
    let stat = nix::sys::statvfs::statvfs(shm);
    v.push(match stat {
        Ok(s) if s.blocks_available() * s.fragment_size() >= 64 << 20 => {
            let free_mb = (s.blocks_available() * s.fragment_size()) >> 20;
            let writable = nix::unistd::access(shm, nix::unistd::AccessFlags::W_OK).is_ok();
            if writable {
                finding(
                    "iceoryx2 shared memory",
                    Level::Ok,
                    format!("/dev/shm writable, {free_mb} MiB free"),
                    "",
                )
            } else {
                finding(
                    "iceoryx2 shared memory",
                    Level::Fail,
                    "/dev/shm is not writable for this user",
                    "mount /dev/shm as tmpfs with mode 1777",
                )
            }
        }
        Ok(_) => finding(
            "iceoryx2 shared memory",
            Level::Warn,
            "/dev/shm has less than 64 MiB free",
            "enlarge the tmpfs (mount -o remount,size=256M /dev/shm)",
        ),
        Err(e) => finding(
            "iceoryx2 shared memory",
            Level::Fail,
            format!("/dev/shm: {e}"),
            "mount a tmpfs on /dev/shm",
        ),
    });
    let tmp = Path::new("/tmp/iceoryx2");
    v.push(
        if !tmp.exists() || nix::unistd::access(tmp, nix::unistd::AccessFlags::W_OK).is_ok() {
            finding(
                "iceoryx2 directory",
                Level::Ok,
                "/tmp/iceoryx2 usable (created on first use)",
                "",
            )
        } else {
            finding(
                "iceoryx2 directory",
                Level::Fail,
                "/tmp/iceoryx2 exists but is not writable for this user (left by another user?)",
                "run every hob process as the same user, or remove /tmp/iceoryx2 with nothing running",
            )
        },
    );
    v
}

fn clocksource() -> Finding {
    let cs = read("/sys/devices/system/clocksource/clocksource0/current_clocksource").unwrap_or_default();
    match cs.as_str() {
        "tsc" => finding("clock source", Level::Ok, "tsc", ""),
        "kvm-clock" | "hyperv_clocksource_tsc_page" | "xen" => finding(
            "clock source",
            Level::Info,
            format!("{cs} (a virtual machine)"),
            "",
        ),
        _ => finding(
            "clock source",
            Level::Warn,
            format!("{cs}: slow to read"),
            "clocksource=tsc tsc=reliable on the kernel command line (if the TSC is invariant: grep constant_tsc /proc/cpuinfo)",
        ),
    }
}

/// LinuxCNC's guidance on the maximum jitter.
pub fn verdict(max_us: u64) -> (Level, &'static str) {
    match max_us {
        0..20 => (Level::Ok, "very good: this PC can hold the 1 ms loop"),
        20..50 => (Level::Ok, "acceptable for the 1 ms loop"),
        50..200 => (
            Level::Warn,
            "too much jitter for a guaranteed 1 ms loop: isolate the core, check the BIOS (SMI, power saving), then run again",
        ),
        _ => (Level::Fail, "this PC cannot hold the 1 ms loop as it is"),
    }
}

fn cyclictest(core: u32, priority: u32, seconds: u32) -> Finding {
    let check = "cyclictest";
    if seconds == 0 {
        return finding(check, Level::Info, "skipped (--cyclictest-seconds 0)", "");
    }
    let json = std::env::temp_dir().join(format!("hob-doctor-{}.json", std::process::id()));
    let out = Command::new("cyclictest")
        .args(["-m", "-q", "-t", "1", "-i", "1000", "-h", "10000"])
        .arg("-p")
        .arg(priority.to_string())
        .arg("-a")
        .arg(core.to_string())
        .arg("-D")
        .arg(seconds.to_string())
        .arg(format!("--json={}", json.display()))
        .output();
    let out = match out {
        Ok(o) => o,
        Err(_) => {
            return finding(
                check,
                Level::Warn,
                "cyclictest is not installed",
                "apt install rt-tests, then run hob doctor again",
            );
        }
    };
    let text = std::fs::read_to_string(&json).unwrap_or_default();
    let _ = std::fs::remove_file(&json);
    let j: serde_json::Value = serde_json::from_str(&text).unwrap_or_default();
    let t = &j["thread"]["0"];
    let (Some(max), Some(avg)) = (t["max"].as_u64(), t["avg"].as_f64()) else {
        return finding(
            check,
            Level::Warn,
            format!(
                "cyclictest failed: {}",
                String::from_utf8_lossy(&out.stderr).trim()
            ),
            "run hob doctor with the service's privileges (CAP_SYS_NICE, memlock)",
        );
    };
    let (level, say) = verdict(max);
    finding(
        check,
        level,
        format!(
            "{seconds} s at 1 ms, SCHED_FIFO {priority}, core {core}: max {max} us, avg {avg:.1} us: {say}"
        ),
        if level == Level::Ok {
            String::new()
        } else {
            "see the other findings; on a virtual machine the hypervisor decides the maximum".into()
        },
    )
}

/// Whether the machine file's drive delay was measured on this machine (`hob commission
/// delay`); hob-rt checks at boot that the drive the record names is the one on the bus.
pub fn commissioning(machine: &MachineConfig) -> Finding {
    use hob_setup::config::machine::commissioning::identity_text;
    let delay_us = machine.control.drive_delay_us;
    match machine
        .commissioning
        .as_ref()
        .and_then(|c| c.drive_delay.as_ref())
    {
        None => finding(
            "drive delay commissioned",
            Level::Warn,
            format!(
                "control.drive_delay_us {delay_us} us was not measured on this machine: hob-rt refuses START and CONTINUE"
            ),
            "with hob-rt running, idle, the table clear: hob commission delay --machine FILE, then restart hob-rt",
        ),
        Some(r) => finding(
            "drive delay commissioned",
            Level::Ok,
            format!(
                "control.drive_delay_us {delay_us} us, measured {} ({:.1} us found) on the table drive {}; hob-rt checks at boot that it is the one on the bus",
                r.utc,
                r.found_us,
                identity_text(
                    r.table_drive_vendor_id,
                    r.table_drive_product_code,
                    r.table_drive_serial
                )
            ),
            "",
        ),
    }
}

/// A table gauge named in the machine file (`hob commission backlash`): mounted for
/// commissioning, not for production, where its TPDO only takes the bus's margin.
pub fn table_gauge(machine: &MachineConfig) -> Option<Finding> {
    let g = machine.io.analog_inputs.table_gauge?;
    let measured = machine
        .commissioning
        .as_ref()
        .and_then(|c| c.table_backlash.as_ref())
        .map_or("not measured yet".to_string(), |b| {
            format!(
                "lost motion {:.2} arcsec measured {}",
                b.lost_motion_arcsec, b.utc
            )
        });
    Some(finding(
        "table gauge",
        Level::Info,
        format!(
            "io.analog_inputs.table_gauge names the coupler's analog input {}: the coupler sends it every {} SYNCs ({measured})",
            g.channel,
            hob_setup::config::machine::TABLE_GAUGE_EVERY_SYNCS
        ),
        "once the backlash is measured and the gauge is off the table: remove [io.analog_inputs] table_gauge, then restart hob-rt",
    ))
}

pub fn run(machine: &MachineConfig, cyclictest_seconds: u32) -> Vec<Finding> {
    let core = machine.service.loop_core;
    let prio = machine.service.loop_priority;
    let mut v = kernel(core);
    v.extend(cpu(core));
    v.extend(limits(prio));
    v.push(can(&machine.can.interface, machine.can.bitrate_bit_s));
    v.extend(shared_memory());
    v.push(clocksource());
    v.push(cyclictest(core, prio, cyclictest_seconds));
    v.push(commissioning(machine));
    v.extend(table_gauge(machine));
    v
}

pub fn text(findings: &[Finding]) -> String {
    let mut o = String::new();
    for f in findings {
        let tag = match f.level {
            Level::Ok => "ok  ",
            Level::Info => "info",
            Level::Warn => "WARN",
            Level::Fail => "FAIL",
        };
        let _ = writeln!(o, "[{tag}] {:<24} {}", f.check, f.found);
        if !f.fix.is_empty() {
            let _ = writeln!(o, "       {:<24} fix: {}", "", f.fix);
        }
    }
    let fails = findings.iter().filter(|f| f.level == Level::Fail).count();
    let warns = findings.iter().filter(|f| f.level == Level::Warn).count();
    let _ = writeln!(
        o,
        "{}: {fails} failed, {warns} warnings",
        if fails == 0 { "ready" } else { "NOT READY" }
    );
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_lists_of_the_kernel() {
        assert_eq!(cpu_list("1-3,5"), vec![1, 2, 3, 5]);
        assert_eq!(cpu_list(""), Vec::<u32>::new());
        assert_eq!(cpu_list("0"), vec![0]);
    }

    #[test]
    fn verdict_follows_linuxcnc() {
        assert_eq!(verdict(12).0, Level::Ok);
        assert!(verdict(12).1.starts_with("very good"));
        assert!(verdict(35).1.starts_with("acceptable"));
        assert_eq!(verdict(120).0, Level::Warn);
        assert_eq!(verdict(5000).0, Level::Fail);
    }

    #[test]
    fn the_drive_delay_is_commissioned_or_said_not_to_be() {
        let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/machine.toml");
        let mut m = hob_store::files::load_machine(&shipped).unwrap();
        let f = commissioning(&m);
        assert_eq!(f.level, Level::Ok, "{f:?}");
        assert!(f.found.contains("serial 0x00001002"), "{f:?}");
        m.commissioning = None;
        let f = commissioning(&m);
        assert_eq!(f.level, Level::Warn, "{f:?}");
        assert!(f.fix.contains("hob commission delay"), "{f:?}");
    }

    #[test]
    fn a_named_table_gauge_is_said_with_what_it_measured() {
        let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/machine.toml");
        let mut m = hob_store::files::load_machine(&shipped).unwrap();
        assert!(table_gauge(&m).is_none());
        m.io.analog_inputs.table_gauge = Some(hob_setup::config::machine::AnalogBinding { channel: 1 });
        let f = table_gauge(&m).unwrap();
        assert_eq!(f.level, Level::Info, "{f:?}");
        assert!(
            f.found.contains("analog input 1") && f.found.contains("not measured yet"),
            "{f:?}"
        );
        assert!(f.fix.contains("remove [io.analog_inputs] table_gauge"), "{f:?}");
    }

    #[test]
    fn a_missing_can_interface_fails_with_the_ip_command() {
        let f = can("can-none-7", 1_000_000);
        assert_eq!(f.level, Level::Fail);
        assert!(f.fix.contains("bitrate 1000000 restart-ms 100"), "{}", f.fix);
    }
}
