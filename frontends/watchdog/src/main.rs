//! `hob-watchdog`: the independent safety channel. It follows two signs of the loop's
//! life (module `liveness`): the `state` stream on shared memory (one sample per cycle)
//! and the SYNC frames on the CAN bus, heard on a socket of its own (the loop's real
//! output: a loop that keeps publishing but no longer drives the bus is caught too). When
//! either is missing for longer than its deadline (`service.watchdog_deadline_ms`,
//! 10 ms), or the loop reports that it lost the machine (faulted with a drive or the I/O
//! coupler gone from the bus), it
//! 1. switches every digital output of the I/O coupler off by SDO, PC-OK among them: the
//!    safety relay chain opens (docs/domain.md section 6), the drives lose power (STO), the VFD
//!    stops; the spindle reference goes to 0 V;
//! 2. sends quick stop (controlword 0x0002) to every drive by SDO;
//!
//! and reports what it did (stderr, and one JSON line on stdout). It re-arms when a new
//! loop starts publishing.
//!
//! usage: hob-watchdog [--machine FILE] [--iface IFACE|shm] [--deadline-ms N]

mod liveness;

use hob_can_transport::shm::open_bus;
use hob_canopen::bus::CanBus;
use hob_canopen::cia402::{command, object};
use hob_canopen::frame::{Cob, Frame};
use hob_canopen::sdo::SdoClient;
use hob_config::machine::MachineConfig;
use hob_ipc::codec::{self, Fault, State};
use hob_ipc::{AlarmCode, StateSample};
use hob_process_image::plan::{ANALOG_OUTPUTS, BusPlan, DIGITAL_OUTPUTS};
use hob_rt_os as rt;
use hob_rt_os::{RtReport, now_ns, sleep_until_ns};
use liveness::{Channel, Liveness, Silence};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::Ordering;

const POLL_NS: u64 = 1_000_000;

#[derive(Debug)]
struct Args {
    machine: PathBuf,
    iface: Option<String>,
    deadline_ms: Option<u32>,
}

/// A command line the watchdog cannot take.
#[derive(Debug)]
enum ArgError {
    /// An option (named) given last, without its value.
    NeedsValue(String),
    /// `--deadline-ms` with what is not a number of milliseconds.
    DeadlineNotANumber(String),
    Unknown(String),
}

impl std::fmt::Display for ArgError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ArgError::NeedsValue(option) => write!(f, "{option} needs a value"),
            ArgError::DeadlineNotANumber(v) => write!(f, "--deadline-ms: not a number: {v}"),
            ArgError::Unknown(arg) => write!(f, "unknown argument {arg}"),
        }
    }
}

impl std::error::Error for ArgError {}

fn parse_args() -> Result<Args, ArgError> {
    let mut a = Args {
        machine: PathBuf::from("config/machine.toml"),
        iface: None,
        deadline_ms: None,
    };
    let mut it = std::env::args().skip(1);
    while let Some(arg) = it.next() {
        let mut value = || it.next().ok_or_else(|| ArgError::NeedsValue(arg.clone()));
        match arg.as_str() {
            "--machine" => a.machine = value()?.into(),
            "--iface" => a.iface = Some(value()?),
            "--deadline-ms" => {
                let v = value()?;
                a.deadline_ms = Some(v.parse().map_err(|_| ArgError::DeadlineNotANumber(v))?);
            }
            other => return Err(ArgError::Unknown(other.to_string())),
        }
    }
    Ok(a)
}

/// Why the watchdog acted.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Trip {
    Silent(Silence),
    LoopLostMachine(AlarmCode),
}

/// The loop reports that it lost the machine: faulted with a drive's feedback or the I/O
/// coupler gone (it can no longer make the machine safe by itself).
fn lost_machine(s: &StateSample) -> Option<AlarmCode> {
    if State::from_code(s.state) != Some(State::Faulted) {
        return None;
    }
    match Fault::of(&s.alarm)? {
        Fault::FeedbackLost | Fault::IoLost => Some(s.alarm),
        _ => None,
    }
}

/// The frames of the reaction, in order: outputs off, spindle reference 0, quick stops.
fn reaction(plan: &BusPlan) -> Vec<Frame> {
    let mut frames = Vec::new();
    let io = plan.io.node;
    for sub in 1..=2u8 {
        if let Ok(f) = SdoClient::new(io).download(DIGITAL_OUTPUTS, sub, &[0]) {
            frames.push(f);
        }
    }
    let ch = 1 + plan.spindle_analog_channel;
    if let Ok(f) = SdoClient::new(io).download(ANALOG_OUTPUTS, ch, &0i16.to_le_bytes()) {
        frames.push(f);
    }
    for node in plan.drives.map(|d| d.node) {
        if let Ok(f) =
            SdoClient::new(node).download(object::CONTROLWORD, 0, &command::QUICK_STOP.to_le_bytes())
        {
            frames.push(f);
        }
    }
    frames
}

fn main() -> ExitCode {
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!(
                "hob-watchdog: {e}\nusage: hob-watchdog [--machine FILE] [--iface IFACE|shm] [--deadline-ms N]"
            );
            return ExitCode::from(2);
        }
    };
    let machine = match load_machine(&args.machine) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("hob-watchdog: refused: {e}");
            return ExitCode::from(2);
        }
    };
    match run(&args, &machine) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("hob-watchdog: {e}");
            ExitCode::from(1)
        }
    }
}

fn run(args: &Args, machine: &MachineConfig) -> Result<(), String> {
    let stop = rt::termination_flag();
    let deadline_ms = args.deadline_ms.unwrap_or(machine.service.watchdog_deadline_ms);
    if deadline_ms < 2 {
        return Err(format!("--deadline-ms must be at least 2 (is {deadline_ms})"));
    }
    let deadline_ns = u64::from(deadline_ms) * 1_000_000;
    let iface = args
        .iface
        .clone()
        .unwrap_or_else(|| machine.can.interface.clone());
    let mut bus = open_bus(&iface, "hob-watchdog-can")?;
    let ports = hob_ipc::Ports::subscribe("hob-watchdog").map_err(|e| e.to_string())?;
    let plan = BusPlan::from_machine(machine);
    let frames = reaction(&plan);

    let mut report = RtReport::default();
    // Off the loop's core: a loop that runs away at its higher priority would otherwise
    // starve the very process that must notice it.
    if !rt::keep_off_core(machine.service.loop_core) {
        eprintln!(
            "hob-watchdog: note: shares the loop's core {} (no other core allowed)",
            machine.service.loop_core
        );
    }
    rt::set_fifo(machine.service.watchdog_priority, &mut report);
    for p in &report.problems {
        eprintln!("hob-watchdog: DEGRADED: {p}");
    }
    eprintln!("hob-watchdog: watching the loop on {iface}, deadline {deadline_ms} ms");

    let mut last_cycle: Option<u64> = None;
    let mut alive = Liveness::new(deadline_ns);
    let mut tripped = false;
    let mut next = now_ns();
    while !stop.load(Ordering::Relaxed) {
        next += POLL_NS;
        sleep_until_ns(next);
        let now = now_ns();
        if now > next + POLL_NS {
            next = now;
        }
        // Our own socket: the loop's SYNCs (its other sign of life); the rest is drained.
        while let Ok(Some(f)) = bus.try_recv() {
            if matches!(Cob::of(f.id), Cob::Sync) {
                if !alive.armed(Channel::Sync) && !tripped {
                    eprintln!("hob-watchdog: SYNC heard on {iface}: watching it too");
                }
                alive.sync_seen(now);
            }
        }
        let mut newest = None;
        while let Some(s) = ports.next_state() {
            newest = Some(s);
        }
        if let Some(s) = newest {
            let restarted = last_cycle.is_some_and(|c| s.cycle < c);
            if tripped && restarted {
                tripped = false;
                alive.rearm();
                eprintln!(
                    "hob-watchdog: a new loop is publishing (cycle {}): re-armed",
                    s.cycle
                );
            }
            if last_cycle.is_none() {
                eprintln!("hob-watchdog: armed at cycle {}", s.cycle);
            }
            last_cycle = Some(s.cycle);
            alive.state_seen(now);
            if !tripped && let Some(a) = lost_machine(&s) {
                act(&mut bus, &frames, Trip::LoopLostMachine(a), s.cycle, &iface);
                tripped = true;
            }
        }
        if !tripped && let Some(silence) = alive.check(now) {
            act(
                &mut bus,
                &frames,
                Trip::Silent(silence),
                last_cycle.unwrap_or(0),
                &iface,
            );
            tripped = true;
        }
    }
    Ok(())
}

/// Sends the reaction and reports it.
fn act(bus: &mut Box<dyn CanBus>, frames: &[Frame], why: Trip, cycle: u64, iface: &str) {
    let t0 = now_ns();
    let mut sent = 0;
    let mut errors = Vec::new();
    for f in frames {
        match bus.send(f) {
            Ok(()) => sent += 1,
            Err(e) => errors.push(format!("0x{:03X}: {e}", f.id)),
        }
    }
    let send_us = (now_ns() - t0) as f64 / 1e3;
    // The nodes' SDO answers (up to 50 ms).
    let mut acks = Vec::new();
    let end = now_ns() + 50_000_000;
    while now_ns() < end && acks.len() < frames.len() {
        match bus.try_recv() {
            Ok(Some(f)) if matches!(Cob::of(f.id), Cob::SdoTx(n) if n > 0) => {
                acks.push(format!("0x{:03X}:{:02X}", f.id, f.data[0]))
            }
            Ok(_) => std::thread::sleep(std::time::Duration::from_micros(200)),
            Err(_) => break,
        }
    }
    let reason = match why {
        Trip::Silent(Silence {
            channel: Channel::State,
            silence_ms,
            other_alive,
        }) => format!(
            "loop's state stream silent for {silence_ms:.1} ms after cycle {cycle}{}",
            if other_alive {
                format!(" (its SYNC still on {iface})")
            } else {
                String::new()
            }
        ),
        Trip::Silent(Silence {
            channel: Channel::Sync,
            silence_ms,
            other_alive,
        }) => format!(
            "no SYNC on {iface} for {silence_ms:.1} ms (last state cycle {cycle}{})",
            if other_alive {
                ", the state stream still live"
            } else {
                ""
            }
        ),
        Trip::LoopLostMachine(a) => format!("loop reports it lost the machine: {}", codec::alarm_text(&a)),
    };
    let (channel, silence_ms) = match why {
        Trip::Silent(s) => (s.channel.name(), Some(s.silence_ms)),
        Trip::LoopLostMachine(_) => ("loop", None),
    };
    eprintln!(
        "hob-watchdog: TRIPPED: {reason}: I/O coupler outputs off (PC-OK dropped, safety chain opens), \
         spindle reference 0 V, quick stop to the drives: {sent}/{} frames sent in {send_us:.0} us, {} answered{}",
        frames.len(),
        acks.len(),
        if errors.is_empty() {
            String::new()
        } else {
            format!(", errors: {}", errors.join(", "))
        }
    );
    // One JSON line for the tests and the logs (serde_json: the reason may hold any text).
    println!(
        "{}",
        serde_json::json!({
            "tripped": true,
            "channel": channel,
            "silence_ms": silence_ms,
            "send_us": send_us,
            "reason": reason,
            "last_cycle": cycle,
            "frames_sent": sent,
            "answers": acks.len(),
            "errors": errors.len(),
        })
    );
}

/// The machine file, read here (the watchdog links no set-up code and no store): its text
/// parsed and validated by `hob-config`, as every process reads it.
fn load_machine(file: &std::path::Path) -> Result<MachineConfig, hob_config::LoadError> {
    let src = std::fs::read_to_string(file).map_err(|error| hob_config::LoadError::Io {
        file: file.to_path_buf(),
        error,
    })?;
    MachineConfig::parse(file, &src)
}
