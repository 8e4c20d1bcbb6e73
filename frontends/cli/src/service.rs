//! `hob status|load|start|hold|resume|stop|reset|jog`: the running service, through the
//! same shared-memory interfaces as every frontend (the HMI included): the `state`,
//! `events` and `stats` streams, and the `command` request-response service; through
//! `hob-gateway` when `HOB_GATEWAY` names its socket (a user who is not the bus's).

use crate::error::Error;
use hob_ipc::codec;
use hob_ipc::{CommandRequest, CommandResponse, EventSample, Feed, StateSample, StatsSample};
use std::fmt::Write as _;
use std::path::Path;
use std::time::{Duration, Instant};

/// How long a command may wait for the loop's answer.
const ANSWER: Duration = Duration::from_secs(3);

/// Why a command to the running loop did not succeed: exit status 2 for a refusal (the
/// loop's, the builder's, or the command line's), 1 for a loop that cannot be reached or
/// does not answer.
#[derive(Debug)]
pub enum ServiceError {
    /// The loop's services (or the gateway) could not be reached.
    Unreachable(hob_ipc::IpcError),
    /// The loop did not answer in time.
    NoAnswer(hob_ipc::IpcError),
    /// The loop refused, in its words; `code` its refusal (0: the request was malformed).
    Refused { code: u32, text: String },
    /// A program file that could not be read.
    ProgramFile {
        path: std::path::PathBuf,
        error: std::io::Error,
    },
    /// A command's word the builder refused (or a program too long to send).
    Request(hob_ipc::Error),
    /// `jog-hold --seconds` that is not a duration.
    BadSeconds(f64),
    /// `status --watch`: the loop stopped publishing its state.
    Stopped,
    /// `status`: no state to show.
    Snapshot(Error),
    /// A command line's value that does not read (`hob can sdo`).
    Usage(Error),
    /// A CAN command that failed (`hob can sdo`).
    Can(Error),
}

impl ServiceError {
    /// A touch-off the loop asks the operator to confirm: the loop's words (the offset it
    /// would set and why it asks), and how to confirm it here: `again`, the same command,
    /// with `--confirm`.
    pub fn with_confirm_hint(self, again: &str) -> Self {
        match self {
            ServiceError::Refused { code, text }
                if code == codec::Refusal::OffsetNeedsConfirmation.code() =>
            {
                ServiceError::Refused {
                    code,
                    text: format!(
                        "{text}\n  if the gauge's value and the hob's position are right, set it: {again} --confirm"
                    ),
                }
            }
            other => other,
        }
    }

    /// The exit status: 2 refused, 1 failed.
    pub fn exit_code(&self) -> u8 {
        match self {
            ServiceError::Refused { .. }
            | ServiceError::ProgramFile { .. }
            | ServiceError::Request(_)
            | ServiceError::BadSeconds(_)
            | ServiceError::Usage(_) => 2,
            ServiceError::Unreachable(_)
            | ServiceError::NoAnswer(_)
            | ServiceError::Stopped
            | ServiceError::Snapshot(_)
            | ServiceError::Can(_) => 1,
        }
    }
}

impl std::fmt::Display for ServiceError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ServiceError::Unreachable(e) | ServiceError::NoAnswer(e) => write!(f, "{e}"),
            ServiceError::Refused { text, .. } => f.write_str(text),
            ServiceError::ProgramFile { path, error } => write!(f, "{}: {error}", path.display()),
            ServiceError::Request(e) => write!(f, "{e}"),
            ServiceError::BadSeconds(s) => write!(f, "jog-hold: --seconds {s} is not a duration"),
            ServiceError::Stopped => f.write_str("hob-rt stopped publishing"),
            ServiceError::Snapshot(e) | ServiceError::Usage(e) | ServiceError::Can(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for ServiceError {}

/// Sends a request; Ok(text) when accepted, else why not ([`ServiceError::exit_code`]: 2
/// refused, 1 no answer).
pub fn request(req: &CommandRequest) -> Result<String, ServiceError> {
    let mut client =
        hob_ipc::commands(&format!("hob-cli-{}", std::process::id())).map_err(ServiceError::Unreachable)?;
    let r: CommandResponse = client.request(req, ANSWER).map_err(ServiceError::NoAnswer)?;
    if r.accepted != 0 {
        Ok(r.text())
    } else {
        Err(ServiceError::Refused {
            code: r.refusal,
            text: r.text(),
        })
    }
}

pub fn load(program: &Path) -> Result<String, ServiceError> {
    let text = std::fs::read_to_string(program).map_err(|error| ServiceError::ProgramFile {
        path: program.to_path_buf(),
        error,
    })?;
    load_text(&program.display().to_string(), &text)
}

/// Sends a self-contained program's text (a library tool already resolved:
/// [`crate::library::load_text`]) under `name`.
pub fn load_text(name: &str, text: &str) -> Result<String, ServiceError> {
    let req = CommandRequest::load_program(name, text).map_err(refused)?;
    request(&req)
}

pub fn simple(code: u32) -> CommandRequest {
    hob_ipc::request::simple(code)
}

pub fn start(single: bool) -> CommandRequest {
    hob_ipc::request::start(single)
}

fn refused(e: hob_ipc::Error) -> ServiceError {
    ServiceError::Request(e)
}

pub fn jog(axis: &str, distance: f64) -> Result<CommandRequest, ServiceError> {
    hob_ipc::request::jog(axis, distance).map_err(refused)
}

/// `hob home x|y|all`.
pub fn home(axes: &str) -> Result<CommandRequest, ServiceError> {
    hob_ipc::request::home(axes).map_err(refused)
}

/// `hob override feed|spindle PERCENT`.
pub fn override_request(what: &str, percent: f64) -> Result<CommandRequest, ServiceError> {
    hob_ipc::request::override_request(what, percent).map_err(refused)
}

/// `hob pitch-compensation on|off`.
pub fn pitch_compensation(switch: &str) -> Result<CommandRequest, ServiceError> {
    hob_ipc::request::pitch_compensation(switch).map_err(refused)
}

/// `hob touch-off x --diameter D` or `hob touch-off y --height H`, `--confirm`ed or not.
pub fn touch_off(
    axis: &str,
    diameter: Option<f64>,
    height: Option<f64>,
    confirm: bool,
) -> Result<CommandRequest, ServiceError> {
    hob_ipc::request::touch_off(axis, diameter, height, confirm).map_err(refused)
}

/// The command line that repeats a touch-off (the gauge written so that it reads back to
/// the same number: the loop applies a confirmed offset only for the gauge it asked about).
pub fn touch_off_again(axis: &str, diameter: Option<f64>, height: Option<f64>) -> String {
    let mut line = format!("hob touch-off {axis}");
    if let Some(d) = diameter {
        line += &format!(" --diameter {d}");
    }
    if let Some(h) = height {
        line += &format!(" --height {h}");
    }
    line
}

pub fn touch_flank(turned: &str) -> Result<CommandRequest, ServiceError> {
    hob_ipc::request::touch_flank(turned).map_err(refused)
}

/// How often a continuous jog is renewed (the machine file's dead-man time is longer).
pub const JOG_RENEWAL: Duration = Duration::from_millis(100);

/// `hob jog-hold AXIS +|-`: renews a continuous jog every [`JOG_RENEWAL`] for `seconds`,
/// then releases it (or, with `release` false, just stops renewing, as a lost frontend).
pub fn jog_hold(
    axis: &str,
    direction: &str,
    speed: f64,
    seconds: f64,
    release: bool,
) -> Result<String, ServiceError> {
    let r = hob_ipc::request::jog_continuous(axis, direction, speed).map_err(refused)?;
    // The builder accepted the axis: its code names it.
    let axis_name = codec::Axis::from_code(r.axis).map_or("?", codec::Axis::name);
    if !(seconds.is_finite() && seconds >= 0.0) {
        return Err(ServiceError::BadSeconds(seconds));
    }
    let mut client =
        hob_ipc::commands(&format!("hob-cli-{}", std::process::id())).map_err(ServiceError::Unreachable)?;
    let end = Instant::now() + Duration::from_secs_f64(seconds);
    let mut renewals = 0u32;
    loop {
        let answer: CommandResponse = client.request(&r, ANSWER).map_err(ServiceError::NoAnswer)?;
        if answer.accepted == 0 {
            return Err(ServiceError::Refused {
                code: answer.refusal,
                text: answer.text(),
            });
        }
        renewals += 1;
        if Instant::now() >= end {
            break;
        }
        std::thread::sleep(JOG_RENEWAL);
    }
    if release {
        let answer: CommandResponse = client
            .request(&hob_ipc::request::jog_release(), ANSWER)
            .map_err(ServiceError::NoAnswer)?;
        if answer.accepted == 0 {
            return Err(ServiceError::Refused {
                code: answer.refusal,
                text: answer.text(),
            });
        }
        Ok(format!(
            "jog {axis_name} {direction}: {renewals} renewals, released\n"
        ))
    } else {
        Ok(format!(
            "jog {axis_name} {direction}: {renewals} renewals, then none (the dead-man stops it)\n"
        ))
    }
}

/// What `hob status` shows.
#[derive(Debug, Clone)]
pub struct Snapshot {
    pub state: StateSample,
    pub stats: Option<StatsSample>,
    pub events: Vec<EventSample>,
    /// The recorder as the operator is told of it (`hob-logger`'s newest report).
    pub recorder: codec::RecorderView,
    pub recorder_report: Option<hob_ipc::RecorderSample>,
}

/// CLOCK_MONOTONIC, ns: the clock of the recorder's reports.
fn monotonic_ns() -> u64 {
    nix::time::clock_gettime(nix::time::ClockId::CLOCK_MONOTONIC).map_or(0, |t| {
        (t.tv_sec() as u64).saturating_mul(1_000_000_000) + t.tv_nsec() as u64
    })
}

/// Reads the newest state, the loop's stats and the recent events.
pub fn snapshot(ports: &mut dyn Feed) -> Result<Snapshot, Error> {
    let state = ports
        .wait_state(Duration::from_secs(2))
        .ok_or_else(|| Error::NoState {
            instance: hob_ipc::instance(),
        })?;
    // Stats come twice a second (the newest is kept for late subscribers).
    let end = Instant::now() + Duration::from_millis(1200);
    let mut stats = ports.latest_stats();
    while stats.is_none() && Instant::now() < end {
        std::thread::sleep(Duration::from_millis(20));
        stats = ports.latest_stats();
    }
    // The recorder reports every 200 ms (its newest is kept for late subscribers).
    let end = Instant::now() + Duration::from_millis(300);
    let mut recorder_report = ports.latest_recorder();
    while recorder_report.is_none() && Instant::now() < end {
        std::thread::sleep(Duration::from_millis(20));
        recorder_report = ports.latest_recorder();
    }
    let mut events = Vec::new();
    while let Some(e) = ports.next_event() {
        events.push(e);
    }
    Ok(Snapshot {
        state,
        stats,
        events,
        recorder: codec::recorder_view(recorder_report.as_ref(), monotonic_ns()),
        recorder_report,
    })
}

fn us(ns: u64) -> f64 {
    ns as f64 / 1e3
}

/// `hob status`'s text: the state and alarm, the axes and set-up, the drives, the loop's
/// timing, the recorder and the recent events.
pub fn status_text(s: &Snapshot) -> String {
    let st = &s.state;
    let mut o = String::new();
    state_lines(&mut o, st);
    axes_lines(&mut o, st);
    drive_lines(&mut o, st);
    match &s.stats {
        Some(x) => loop_lines(&mut o, x),
        None => {
            let _ = writeln!(o, "loop     no stats from hob-rt yet");
        }
    }
    let _ = writeln!(o, "recorder {}", s.recorder.text);
    if !s.events.is_empty() {
        let _ = writeln!(o, "events   (newest last)");
        for e in s.events.iter().rev().take(10).rev() {
            let _ = writeln!(o, "  #{:<6} cycle {:<9} {}", e.seq, e.cycle, codec::event_text(e));
        }
    }
    o
}

/// The state, pass and program; the alarm with the machine's reaction, the remedy and how
/// to continue.
fn state_lines(o: &mut String, st: &StateSample) {
    let hold = if st.hold != 0 { " (feed hold)" } else { "" };
    let _ = writeln!(
        o,
        "state    {}{hold}   cycle {}   pass {}/{}   program {}",
        codec::state_name(st.state),
        st.cycle,
        st.pass,
        st.passes_total,
        if st.program_loaded != 0 { "loaded" } else { "none" }
    );
    let alarm = codec::alarm_text(&st.alarm);
    let _ = writeln!(
        o,
        "alarm    {}",
        if alarm.is_empty() { "none".into() } else { alarm }
    );
    if let Some(reported) = codec::drive_reported(&st.alarm, &st.last_emcy_code) {
        let _ = writeln!(o, "         {reported}");
    }
    if let Some(f) = codec::Fault::of(&st.alarm) {
        let _ = writeln!(o, "         the machine: {}", f.reaction(&st.alarm));
        let _ = writeln!(o, "         remedy: {}", f.remedy());
        let _ = writeln!(o, "         to continue: {}", f.how_to_continue());
    }
}

/// The axes, the set-up (references, offsets, overrides) and the spindle.
fn axes_lines(o: &mut String, st: &StateSample) {
    let _ = writeln!(
        o,
        "axes     X {:9.3} mm (cmd {:9.3})  Y {:9.3} mm (cmd {:9.3})  B {:10.4} deg",
        st.x_mm.actual, st.x_mm.command, st.y_mm.actual, st.y_mm.command, st.table_deg.actual
    );
    let referenced = |bit: u8| {
        if st.referenced & (1 << bit) != 0 {
            "referenced"
        } else {
            "NOT REFERENCED"
        }
    };
    let _ = writeln!(
        o,
        "set-up   X {}  Y {}  table position {}   offsets X {:+.4} Y {:+.4} mm   override feed {:.0} % spindle {:.0} %{}",
        referenced(1),
        referenced(2),
        if st.referenced & 1 != 0 { "whole" } else { "LOST" },
        st.x_offset_mm,
        st.y_offset_mm,
        st.feed_override_percent,
        st.spindle_override_percent,
        if st.continue_pass > 0 && st.continue_from_y_mm.is_finite() {
            format!(
                "   continue from pass {} at Y {:.3} mm",
                st.continue_pass, st.continue_from_y_mm
            )
        } else if st.continue_pass > 0 {
            format!("   continue from pass {}", st.continue_pass)
        } else {
            String::new()
        }
    );
    let _ = writeln!(
        o,
        "spindle  {:7.2} rpm (set {:7.2})   gearbox {}   sync error {:7.3} arcsec   CCC {:6.3} arcsec   pitch compensation {}",
        st.spindle_rpm,
        st.spindle_set_rpm,
        codec::coupling_name(st.coupling),
        st.sync_error_arcsec,
        st.ccc_arcsec,
        hob_ipc::pitch_compensation::name(st.pitch_compensation)
    );
}

/// The drives enabled, the I/O, and each CAN node's state.
fn drive_lines(o: &mut String, st: &StateSample) {
    let drives: Vec<&str> = ["B", "X", "Y"]
        .iter()
        .enumerate()
        .filter(|(i, _)| st.drives_enabled & (1 << i) != 0)
        .map(|(_, n)| *n)
        .collect();
    let _ = writeln!(
        o,
        "drives   enabled [{}]   I/O {}   inputs 0x{:06X}   outputs 0x{:04X}",
        drives.join(" "),
        if st.io_valid != 0 { "valid" } else { "NOT VALID" },
        st.digital_inputs,
        st.digital_outputs
    );
    let nodes: Vec<String> = ["B", "X", "Y", "I/O"]
        .iter()
        .enumerate()
        .map(|(i, n)| {
            let cia = if i < 3 {
                format!(", {}", codec::cia402_state_name(st.drive_statusword[i]))
            } else {
                String::new()
            };
            format!("{n} {}{cia}", codec::nmt_state_name(st.nmt_state[i]))
        })
        .collect();
    let _ = writeln!(o, "nodes    {}", nodes.join("   "));
}

/// The loop's real-time set-up, its timing and its counters.
fn loop_lines(o: &mut String, x: &StatsSample) {
    let _ = writeln!(
        o,
        "loop     {}   {}   {}   {}   bus {}   period {} us",
        if x.fifo_priority > 0 {
            format!("SCHED_FIFO {}", x.fifo_priority)
        } else {
            "NOT SCHED_FIFO".into()
        },
        if x.core >= 0 {
            format!("core {}", x.core)
        } else {
            "not pinned".into()
        },
        if x.memory_locked != 0 {
            "memory locked"
        } else {
            "memory NOT locked"
        },
        if x.cpu_dma_latency_us >= 0 {
            format!("idle exit <= {} us", x.cpu_dma_latency_us)
        } else {
            "idle states NOT limited".into()
        },
        if x.bus_kind == hob_ipc::bus_kind::SHARED_MEMORY {
            "shared-memory virtual CAN"
        } else {
            "SocketCAN"
        },
        x.period_ns / 1000
    );
    for (name, p) in [("wake us ", &x.wake_latency), ("compute ", &x.compute)] {
        let _ = writeln!(
            o,
            "{name} min {:7.1}  p50 {:7.1}  p90 {:7.1}  p99 {:7.1}  p99.9 {:7.1}  p99.99 {:7.1}  max {:8.1}  ({} cycles)",
            us(p.min_ns),
            us(p.p50_ns),
            us(p.p90_ns),
            us(p.p99_ns),
            us(p.p999_ns),
            us(p.p9999_ns),
            us(p.max_ns),
            p.count
        );
    }
    let _ = writeln!(
        o,
        "         overruns {}   CAN send errors {}   in cycles: system heap allocations {}, pool blocks {}",
        x.overruns,
        x.tx_errors,
        if x.system_allocations_in_cycle == u64::MAX {
            "not counted".into()
        } else {
            x.system_allocations_in_cycle.to_string()
        },
        x.pool_allocations_in_cycle
    );
}

/// The CAN nodes as the loop sees them: each drive's CiA 402 state and statusword, each
/// node's NMT state and the cycles since its heartbeat.
fn drives_json(st: &hob_ipc::StateSample) -> serde_json::Value {
    let node = |i: usize| {
        serde_json::json!({
            "nmt": codec::nmt_state_name(st.nmt_state[i]),
            "heartbeat_age_cycles": st.heartbeat_age_cycles[i],
        })
    };
    let mut nodes = serde_json::Map::new();
    for (i, name) in ["B", "X", "Y"].iter().enumerate() {
        let mut n = node(i);
        n["cia402"] = codec::cia402_state_name(st.drive_statusword[i]).into();
        n["statusword"] = format!("0x{:04X}", st.drive_statusword[i]).into();
        nodes.insert((*name).into(), n);
    }
    nodes.insert("io".into(), node(3));
    nodes.into()
}

pub fn status_json(s: &Snapshot) -> String {
    let st = &s.state;
    let p = |p: &hob_ipc::Percentiles| {
        serde_json::json!({"count": p.count, "min_ns": p.min_ns, "p50_ns": p.p50_ns, "p90_ns": p.p90_ns,
            "p99_ns": p.p99_ns, "p999_ns": p.p999_ns, "p9999_ns": p.p9999_ns, "max_ns": p.max_ns})
    };
    let stats = s.stats.as_ref().map(|x| {
        serde_json::json!({
            "cycle": x.cycle, "period_ns": x.period_ns, "overruns": x.overruns, "tx_errors": x.tx_errors,
            "wake_latency": p(&x.wake_latency), "compute": p(&x.compute),
            "system_allocations_in_cycle": x.system_allocations_in_cycle,
            "pool_allocations_in_cycle": x.pool_allocations_in_cycle,
            "fifo_priority": x.fifo_priority, "core": x.core, "memory_locked": x.memory_locked != 0,
            "cpu_dma_latency_us": (x.cpu_dma_latency_us >= 0).then_some(x.cpu_dma_latency_us),
            "bus": codec::bus_kind_name(x.bus_kind),
        })
    });
    let events: Vec<serde_json::Value> = s
        .events
        .iter()
        .map(|e| serde_json::json!({"seq": e.seq, "cycle": e.cycle, "text": codec::event_text(e)}))
        .collect();
    let j = serde_json::json!({
        "cycle": st.cycle,
        "sync_time_ns": st.sync_time_ns,
        "state": codec::state_name(st.state),
        "hold": st.hold != 0,
        "pass": st.pass,
        "passes_total": st.passes_total,
        "program_loaded": st.program_loaded != 0,
        "alarm": codec::alarm_text(&st.alarm),
        "alarm_drive_reported": codec::drive_reported(&st.alarm, &st.last_emcy_code),
        "alarm_reaction": codec::Fault::of(&st.alarm).map_or(String::new(), |f| f.reaction(&st.alarm).to_string()),
        "alarm_remedy": codec::Fault::of(&st.alarm).map_or("", codec::Fault::remedy),
        "alarm_how_to_continue": codec::Fault::of(&st.alarm).map_or("", codec::Fault::how_to_continue),
        "program_hash": (st.program_hash != 0).then(|| format!("{:016x}", st.program_hash)),
        "drives": drives_json(st),
        "x_mm": st.x_mm.actual,
        "y_mm": st.y_mm.actual,
        "table_deg": st.table_deg.actual,
        "spindle_rpm": st.spindle_rpm,
        "sync_error_arcsec": st.sync_error_arcsec,
        "coupling": codec::coupling_name(st.coupling),
        "io_valid": st.io_valid != 0,
        "digital_outputs": st.digital_outputs,
        "x_referenced": st.referenced & 0b010 != 0,
        "y_referenced": st.referenced & 0b100 != 0,
        "table_position_whole": st.referenced & 0b001 != 0,
        "x_offset_mm": st.x_offset_mm,
        "y_offset_mm": st.y_offset_mm,
        "feed_override_percent": st.feed_override_percent,
        "spindle_override_percent": st.spindle_override_percent,
        "continue_pass": (st.continue_pass > 0).then_some(st.continue_pass),
        "continue_from_y_mm": (st.continue_pass > 0 && st.continue_from_y_mm.is_finite())
            .then_some(st.continue_from_y_mm),
        "stats": stats,
        "recorder": {
            "alarm": s.recorder.alarm,
            "text": s.recorder.text,
            "writing": s.recorder_report.map(|r| r.writing != 0),
            "samples_written": s.recorder_report.map(|r| r.samples_written),
            "samples_unwritten": s.recorder_report.map(|r| r.samples_unwritten),
            "events_unwritten": s.recorder_report.map(|r| r.events_unwritten),
            "samples_lost": s.recorder_report.map(|r| r.samples_lost),
        },
        "events": events,
    });
    format!("{j:#}\n")
}

/// `hob status`: once, or `--watch` (a line per half second until interrupted).
pub fn status(watch: bool, json: bool) -> Result<String, ServiceError> {
    let mut ports =
        hob_ipc::follow(&format!("hob-status-{}", std::process::id())).map_err(ServiceError::Unreachable)?;
    let snap = snapshot(ports.as_mut()).map_err(ServiceError::Snapshot)?;
    if !watch {
        return Ok(if json {
            status_json(&snap)
        } else {
            status_text(&snap)
        });
    }
    print!("{}", status_text(&snap));
    let mut recorder = snap.recorder_report;
    let mut recorder_alarm = snap.recorder.alarm;
    loop {
        std::thread::sleep(Duration::from_millis(500));
        // The recorder's alarm when it comes and when it goes.
        recorder = ports.latest_recorder().or(recorder);
        let view = codec::recorder_view(recorder.as_ref(), monotonic_ns());
        if view.alarm != recorder_alarm {
            recorder_alarm = view.alarm;
            println!("recorder {}", view.text);
        }
        while let Some(e) = ports.next_event() {
            println!("  #{:<6} cycle {:<9} {}", e.seq, e.cycle, codec::event_text(&e));
        }
        let Some(st) = ports.wait_state(Duration::from_secs(1)) else {
            return Err(ServiceError::Stopped);
        };
        let alarm = codec::alarm_text(&st.alarm);
        println!(
            "cycle {:>9}  {:<12} pass {}/{}  X {:8.3}  Y {:8.3}  spindle {:6.1} rpm  sync {:7.3} arcsec  wake {:6.1} us  {}",
            st.cycle,
            codec::state_name(st.state),
            st.pass,
            st.passes_total,
            st.x_mm.actual,
            st.y_mm.actual,
            st.spindle_rpm,
            st.sync_error_arcsec,
            f64::from(st.wake_latency_ns) / 1e3,
            alarm
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hob_ipc::AlarmCode;
    use hob_ipc::codec::{Axis, Fault};

    fn snapshot(alarm: AlarmCode) -> Snapshot {
        Snapshot {
            state: StateSample {
                alarm,
                ..StateSample::default()
            },
            stats: None,
            events: Vec::new(),
            recorder: codec::recorder_view(None, 0),
            recorder_report: None,
        }
    }

    #[test]
    fn an_active_alarm_is_shown_with_the_reaction_the_remedy_and_how_to_continue() {
        let alarm = AlarmCode {
            code: Fault::DriveFault.code(),
            axis: Axis::Y.code(),
            ..AlarmCode::default()
        };
        let text = status_text(&snapshot(alarm));
        let f = Fault::DriveFault;
        for line in [
            "alarm    drive fault Y".to_string(),
            format!("         the machine: {}", f.reaction(&alarm)),
            format!("         remedy: {}", f.remedy()),
            format!("         to continue: {}", f.how_to_continue()),
        ] {
            assert!(text.lines().any(|l| l == line), "no line {line:?} in\n{text}");
        }
    }

    #[test]
    fn a_touch_off_to_confirm_says_how_and_other_refusals_are_left_alone() {
        let again = touch_off_again("x", Some(194.94), None);
        assert_eq!(again, "hob touch-off x --diameter 194.94");
        // The gauge reads back to the number that was sent, to the bit.
        let sent = 0.1 + 0.2;
        let line = touch_off_again("y", None, Some(sent));
        let read: f64 = line.rsplit(' ').next().unwrap().parse().unwrap();
        assert_eq!(read.to_bits(), sent.to_bits());
        let asked = ServiceError::Refused {
            code: codec::Refusal::OffsetNeedsConfirmation.code(),
            text: "touch-off refused: ... X offset -0.0050 mm -> +49.9950 mm".into(),
        };
        let text = asked.with_confirm_hint(&again).to_string();
        assert!(text.starts_with("touch-off refused: ... X offset"), "{text}");
        assert!(
            text.ends_with("set it: hob touch-off x --diameter 194.94 --confirm"),
            "{text}"
        );
        let other = ServiceError::Refused {
            code: codec::Refusal::BadValue.code(),
            text: "touch-off refused: the value".into(),
        };
        assert_eq!(
            other.with_confirm_hint(&again).to_string(),
            "touch-off refused: the value"
        );
    }

    #[test]
    fn without_an_alarm_there_is_nothing_to_remedy() {
        let text = status_text(&snapshot(AlarmCode::default()));
        assert!(text.lines().any(|l| l == "alarm    none"), "{text}");
        assert!(
            !text.contains("remedy:") && !text.contains("to continue:"),
            "{text}"
        );
    }
}
