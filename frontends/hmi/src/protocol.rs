//! What travels between the HMI's server and the browser (JSON over one WebSocket, `t`
//! names the message), and the loop's samples turned into named values: every name and
//! text comes from `hob_ipc::codec` and the machine file, the page only shows them.

use crate::error::Error;
use crate::reduce::PlotPoint;
use crate::words::tr;
use hob_gearing::iso1328::single_pitch_tolerance_um;
use hob_gearing::units::um_to_arcsec_at_radius;
use hob_ipc::codec::{self, Axis};
use hob_ipc::{CommandRequest, EventSample, StateSample, StatsSample, event_kind, request};
use hob_setup::config::machine::IoMap;
use serde::{Deserialize, Serialize};

/// The ISO 1328-1 grade whose single pitch tolerance sets the plot's bound (a quarter of
/// it: the share of the pitch error the project allows the synchronisation).
pub const BOUND_GRADE: u8 = 5;

#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AxisView {
    pub act: f64,
    pub cmd: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AlarmView {
    pub code: u32,
    pub text: String,
    /// What the alarm's drive reported itself (its last EMCY, by the drive's name), when
    /// the alarm names a drive that sent one.
    pub drive_reported: Option<String>,
    pub reaction: String,
    pub remedy: String,
    pub how_to_continue: String,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Signal {
    pub name: &'static str,
    pub bit: u8,
    pub active: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Referenced {
    pub x: bool,
    pub y: bool,
    /// The table's position is whole (its tooth phase can be trusted).
    pub table: bool,
}

/// A CAN node as the loop sees it: its NMT state from the heartbeat, the heartbeat's age,
/// and for a drive its CiA 402 state and statusword.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NodeView {
    pub name: &'static str,
    pub nmt: &'static str,
    pub heartbeat_age_ms: f64,
    pub cia402: Option<&'static str>,
    pub statusword: Option<String>,
    /// The node's last EMCY, code and meaning (none: none since power-up, or reset).
    pub emcy: Option<String>,
}

/// The nodes of a state sample, in the bus plan's order; `period_ns` dates the heartbeats.
pub fn nodes(s: &StateSample, period_ns: u64) -> Vec<NodeView> {
    ["B", "X", "Y", "I/O"]
        .iter()
        .enumerate()
        .map(|(i, name)| NodeView {
            name,
            nmt: codec::nmt_state_name(s.nmt_state[i]),
            heartbeat_age_ms: f64::from(s.heartbeat_age_cycles[i]) * period_ns as f64 / 1e6,
            cia402: (i < 3).then(|| codec::cia402_state_name(s.drive_statusword[i])),
            statusword: (i < 3).then(|| format!("0x{:04X}", s.drive_statusword[i])),
            emcy: codec::emcy_words(s.last_emcy_code[i]).as_deref().map(tr),
        })
        .collect()
}

/// One state sample in words.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StateView {
    pub cycle: u64,
    pub state: String,
    /// The state in the operator's words (`State::words`; the page translates them).
    pub state_words: &'static str,
    pub hold: bool,
    pub program_loaded: bool,
    pub pass: u32,
    pub passes: u32,
    pub tooth: u32,
    pub coupling: &'static str,
    pub x_mm: AxisView,
    pub y_mm: AxisView,
    pub b_deg: AxisView,
    pub spindle_rpm: f64,
    pub spindle_set_rpm: f64,
    pub sync_error_arcsec: f64,
    pub alarm: Option<AlarmView>,
    pub referenced: Referenced,
    pub moving_axis: Option<&'static str>,
    pub continue_pass: Option<u32>,
    /// Where "continue" re-enters that pass's cut (none: at its start).
    pub continue_from_y_mm: Option<f64>,
    pub feed_override_percent: f64,
    pub spindle_override_percent: f64,
    pub x_offset_mm: f64,
    pub y_offset_mm: f64,
    /// The pitch compensation `hob-rt` loaded for the machine's worm set, as the loop has it:
    /// `none` (none loaded), `off`, `on` (`?`: a code this HMI does not know).
    pub pitch_compensation: &'static str,
    pub drives_enabled: Vec<&'static str>,
    pub drives_silent: Vec<&'static str>,
    pub io_valid: bool,
    pub inputs: Vec<Signal>,
    pub outputs: Vec<Signal>,
    pub overruns: u64,
    pub events_lost: u64,
    /// The plot's bound for the loaded gear, arcsec (none without a program).
    pub bound_arcsec: Option<f64>,
    /// The loaded gear's pitch radius (0 without a program).
    pub pitch_radius_mm: f64,
    /// The loaded program's text hash (0: none); not sent (a u64 is not a JS number).
    #[serde(skip)]
    pub program_hash: u64,
    /// The CAN nodes (drives and coupler).
    pub nodes: Vec<NodeView>,
}

fn axes(bits: u8) -> Vec<&'static str> {
    [(0, "B"), (1, "X"), (2, "Y")]
        .iter()
        .filter(|(i, _)| bits & (1 << i) != 0)
        .map(|(_, n)| *n)
        .collect()
}

/// The pitch compensation's state (`hob_ipc::vocab::pitch_compensation`) as the page
/// names it: the wire's own words.
pub fn pitch_compensation_name(code: u8) -> &'static str {
    hob_ipc::pitch_compensation::name(code)
}

/// The alarm in the operator's words, with what the machine did and what to do.
pub fn alarm_view(a: &hob_ipc::AlarmCode, last_emcy_code: &[u16; 4]) -> Option<AlarmView> {
    if a.code == 0 {
        return None;
    }
    let f = codec::Fault::of(a);
    let drive_reported = codec::drive_reported(a, last_emcy_code);
    Some(AlarmView {
        code: a.code,
        text: tr(&codec::alarm_text(a)),
        drive_reported: drive_reported.as_deref().map(tr),
        reaction: tr(f.map_or("", |f| f.reaction(a))),
        remedy: tr(f.map_or("", codec::Fault::remedy)),
        how_to_continue: tr(f.map_or("", codec::Fault::how_to_continue)),
    })
}

/// The bound of the synchronisation error for a gear: a quarter of its grade-5 single
/// pitch tolerance at the pitch circle, in arcsec.
pub fn bound_arcsec(pitch_radius_mm: f64, normal_module_mm: f64) -> Option<f64> {
    (pitch_radius_mm > 0.0 && normal_module_mm > 0.0).then(|| {
        let tol_um = single_pitch_tolerance_um(2.0 * pitch_radius_mm, normal_module_mm, BOUND_GRADE);
        um_to_arcsec_at_radius(tol_um / 4.0, pitch_radius_mm)
    })
}

impl StateView {
    /// `period_ns`: the loop's period (the heartbeats' age is counted in cycles).
    pub fn of(s: &StateSample, io: &IoMap, period_ns: u64) -> Self {
        let signals = |list: &[(&'static str, hob_setup::config::machine::DigitalBinding)], raw: u32| {
            list.iter()
                .map(|(name, b)| Signal {
                    name,
                    bit: b.bit,
                    active: b.is_active(raw),
                })
                .collect()
        };
        Self {
            cycle: s.cycle,
            state: codec::state_name(s.state),
            state_words: codec::State::from_code(s.state).map_or("?", codec::State::words),
            hold: s.hold != 0,
            program_loaded: s.program_loaded != 0,
            pass: s.pass,
            passes: s.passes_total,
            tooth: s.tooth,
            coupling: codec::coupling_name(s.coupling),
            x_mm: AxisView {
                act: s.x_mm.actual,
                cmd: s.x_mm.command,
            },
            y_mm: AxisView {
                act: s.y_mm.actual,
                cmd: s.y_mm.command,
            },
            b_deg: AxisView {
                act: s.table_deg.actual,
                cmd: s.table_deg.command,
            },
            spindle_rpm: s.spindle_rpm,
            spindle_set_rpm: s.spindle_set_rpm,
            sync_error_arcsec: s.sync_error_arcsec,
            alarm: alarm_view(&s.alarm, &s.last_emcy_code),
            referenced: Referenced {
                x: s.referenced & 2 != 0,
                y: s.referenced & 4 != 0,
                table: s.referenced & 1 != 0,
            },
            moving_axis: Axis::from_code(s.moving_axis).map(Axis::name),
            continue_pass: (s.continue_pass > 0).then_some(s.continue_pass),
            continue_from_y_mm: (s.continue_pass > 0 && s.continue_from_y_mm.is_finite())
                .then_some(s.continue_from_y_mm),
            feed_override_percent: s.feed_override_percent,
            spindle_override_percent: s.spindle_override_percent,
            x_offset_mm: s.x_offset_mm,
            y_offset_mm: s.y_offset_mm,
            pitch_compensation: pitch_compensation_name(s.pitch_compensation),
            drives_enabled: axes(s.drives_enabled),
            drives_silent: axes(s.drives_silent),
            io_valid: s.io_valid != 0,
            inputs: signals(&io.inputs.bindings(), s.digital_inputs),
            outputs: signals(&io.outputs.bindings(), s.digital_outputs),
            overruns: s.overruns,
            events_lost: s.events_lost,
            bound_arcsec: bound_arcsec(s.pitch_radius_mm, s.normal_module_mm),
            pitch_radius_mm: s.pitch_radius_mm,
            program_hash: s.program_hash,
            nodes: nodes(s, period_ns),
        }
    }
}

/// One event in words; `operator`: an answer to a command (accepted or refused), not
/// something the machine did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EventView {
    pub seq: u64,
    pub cycle: u64,
    pub kind: &'static str,
    pub operator: bool,
    pub text: String,
    pub alarm: Option<AlarmView>,
    /// Wall-clock time in ms since the epoch, from the cycle (the events carry none).
    pub utc_ms: Option<u64>,
    /// For the event log's filters (`codec::event_class`): `alarm`, `operator`, `bus`,
    /// `cycle` or `service`; `alarm`, `warning` or `info`; the axis where it names one.
    pub group: &'static str,
    pub severity: &'static str,
    pub axis: Option<&'static str>,
}

impl EventView {
    /// `clock`: a newest cycle with its wall time and the period, to date the event.
    pub fn of(e: &EventSample, clock: Option<CycleClock>) -> Self {
        Self {
            seq: e.seq,
            cycle: e.cycle,
            kind: codec::event_kind_name(e.kind).unwrap_or("?"),
            operator: matches!(e.kind, event_kind::ACCEPTED | event_kind::REFUSED),
            text: tr(&codec::event_text(e)),
            alarm: if e.kind == event_kind::ALARM {
                // What the drive reported is a bus event of its own in the list.
                alarm_view(&e.alarm, &[0; 4])
            } else {
                None
            },
            utc_ms: clock.map(|c| c.utc_ms(e.cycle)),
            ..Self::classed(codec::event_class(e))
        }
    }

    /// The filter fields of an event's class; the rest is filled by the caller.
    fn classed(c: codec::EventClass) -> Self {
        Self {
            seq: 0,
            cycle: 0,
            kind: "?",
            operator: false,
            text: String::new(),
            alarm: None,
            utc_ms: None,
            group: c.group,
            severity: c.severity.name(),
            axis: c.axis.map(codec::Axis::name),
        }
    }
}

impl EventView {
    /// An event read back from the logger's `events.log` (older than the HMI's own ring):
    /// the text as recorded, an alarm's advice from its recorded code (none on a line
    /// written before the codes were).
    pub fn of_logged(e: &hob_logger::export::LoggedEvent, clock: Option<CycleClock>) -> Self {
        Self {
            seq: e.seq,
            cycle: e.cycle,
            kind: codec::event_kind_name(e.kind).unwrap_or("?"),
            operator: matches!(e.kind, event_kind::ACCEPTED | event_kind::REFUSED),
            text: tr(&e.text),
            alarm: if e.kind == event_kind::ALARM {
                e.alarm.as_ref().and_then(|a| alarm_view(a, &[0; 4]))
            } else {
                None
            },
            utc_ms: clock.map(|c| c.utc_ms(e.cycle)),
            // The record keeps the kind, an alarm's code and another event's arguments.
            ..Self::classed(codec::event_class(&hob_ipc::EventSample {
                kind: e.kind,
                a: e.args.0,
                b: e.args.1,
                alarm: e.alarm.unwrap_or_default(),
                ..Default::default()
            }))
        }
    }
}

/// Dates cycles: a cycle whose wall-clock time is known, and the loop's period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CycleClock {
    pub cycle: u64,
    pub utc_ms: u64,
    pub period_ns: u64,
}

impl CycleClock {
    pub fn utc_ms(self, cycle: u64) -> u64 {
        let back_ms = (self.cycle.saturating_sub(cycle)).saturating_mul(self.period_ns) / 1_000_000;
        self.utc_ms.saturating_sub(back_ms)
    }
}

/// The loop's timing summary, us.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StatsView {
    pub cycle: u64,
    pub period_us: f64,
    pub overruns: u64,
    pub wake_us: PercentilesView,
    pub compute_us: PercentilesView,
    pub system_allocations_in_cycle: u64,
    pub pool_allocations_in_cycle: u64,
    pub fifo_priority: i32,
    pub core: i32,
    pub memory_locked: bool,
    pub bus: &'static str,
    pub tx_errors: u64,
    pub wake_bars: Vec<BarView>,
    pub compute_bars: Vec<BarView>,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PercentilesView {
    pub count: u64,
    pub min: f64,
    pub p50: f64,
    pub p99: f64,
    pub p999: f64,
    pub max: f64,
}

/// One bar of a histogram: values from `lo_us` up to `hi_us`, and how many.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BarView {
    pub lo_us: f64,
    pub hi_us: f64,
    pub count: u64,
}

/// The bars of a power-of-two histogram from its lowest to its highest filled bucket (empty
/// ones between them kept, so that a tail stands apart).
pub fn bars(h: &hob_ipc::Log2Histogram) -> Vec<BarView> {
    let filled = |i: &usize| h.counts[*i] > 0;
    let (Some(lo), Some(hi)) = (
        (0..h.counts.len()).find(filled),
        (0..h.counts.len()).rev().find(filled),
    ) else {
        return Vec::new();
    };
    (lo..=hi)
        .map(|i| BarView {
            lo_us: if i == 0 { 0.0 } else { (1u64 << i) as f64 / 1e3 },
            hi_us: (1u64 << (i + 1)) as f64 / 1e3,
            count: h.counts[i],
        })
        .collect()
}

impl StatsView {
    pub fn of(s: &StatsSample) -> Self {
        let p = |x: &hob_ipc::Percentiles| PercentilesView {
            count: x.count,
            min: x.min_ns as f64 / 1e3,
            p50: x.p50_ns as f64 / 1e3,
            p99: x.p99_ns as f64 / 1e3,
            p999: x.p999_ns as f64 / 1e3,
            max: x.max_ns as f64 / 1e3,
        };
        Self {
            cycle: s.cycle,
            period_us: s.period_ns as f64 / 1e3,
            overruns: s.overruns,
            wake_us: p(&s.wake_latency),
            compute_us: p(&s.compute),
            system_allocations_in_cycle: s.system_allocations_in_cycle,
            pool_allocations_in_cycle: s.pool_allocations_in_cycle,
            fifo_priority: s.fifo_priority,
            core: s.core,
            memory_locked: s.memory_locked != 0,
            bus: codec::bus_kind_name(s.bus_kind),
            tx_errors: s.tx_errors,
            wake_bars: bars(&s.wake_histogram),
            compute_bars: bars(&s.compute_histogram),
        }
    }
}

/// What the server sends every frame.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Frame {
    /// Frame number (the page sees skipped frames from it).
    pub seq: u64,
    /// How old the newest sample is, from its SYNC time (the bus included).
    pub loop_age_ms: Option<f64>,
    /// The wall-clock time of the newest sample's SYNC, ms since the epoch (the page
    /// measures the state-to-screen latency against it).
    pub sample_utc_ms: Option<f64>,
    /// No sample from the loop for this long (over the silence limit), ms.
    pub silent_ms: Option<u64>,
    /// Cycles the HMI never received since it started, and loop restarts it saw.
    pub samples_missed: u64,
    pub loop_restarts: u32,
    pub state: Option<StateView>,
    /// The axes' actual speeds over the frame's interval, from the newest samples' positions
    /// and SYNC times (none before two frames with samples).
    pub speeds: Option<Speeds>,
    pub plot: Option<PlotPoint>,
    pub events_head: u64,
    /// The recorder (`hob-logger`) as the operator is told of it: an alarm when it cannot
    /// write or stopped reporting (`hob_ipc::codec::recorder_view`, as `hob status`).
    pub recorder: RecorderView,
}

/// The actual feed of Y and the table's speed, for AUTOMATIC.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Speeds {
    pub y_feed_mm_min: f64,
    pub x_feed_mm_min: f64,
    pub table_rpm: f64,
}

impl Speeds {
    /// From two samples' actual positions and SYNC times; none when no time passed between
    /// them (the same sample, or a restarted loop's clock).
    pub fn between(a: &StateSample, b: &StateSample) -> Option<Self> {
        let dt_min = b.sync_time_ns.checked_sub(a.sync_time_ns).filter(|d| *d > 0)? as f64 / 60e9;
        // The table's angle may be given modulo a turn: a frame's interval is far less.
        let turned = b.table_deg.actual - a.table_deg.actual;
        let turned = turned - 360.0 * (turned / 360.0).round();
        Some(Self {
            y_feed_mm_min: (b.y_mm.actual - a.y_mm.actual) / dt_min,
            x_feed_mm_min: (b.x_mm.actual - a.x_mm.actual) / dt_min,
            table_rpm: turned / 360.0 / dt_min,
        })
    }
}

/// [`hob_ipc::codec::RecorderView`] for the page.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct RecorderView {
    pub alarm: bool,
    pub text: String,
}

impl From<hob_ipc::codec::RecorderView> for RecorderView {
    fn from(v: hob_ipc::codec::RecorderView) -> Self {
        Self {
            alarm: v.alarm,
            text: v.text,
        }
    }
}

/// A number the operator typed: JSON's number, or the field's text as typed (`94,94` with a
/// decimal comma), read by `hob_ipc::number` (the CLI's reading) when the command is built,
/// so that a typo is refused in words naming the field.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum Typed {
    Number(f64),
    Text(String),
}

impl Typed {
    pub fn read(&self, field: &str) -> Result<f64, hob_ipc::Error> {
        match self {
            Typed::Number(x) if x.is_finite() => Ok(*x),
            Typed::Number(x) => hob_ipc::number::parse(field, &x.to_string()),
            Typed::Text(t) => hob_ipc::number::parse(field, t),
        }
    }
}

/// The operation of a command from the page.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(tag = "op", rename_all = "snake_case", deny_unknown_fields)]
pub enum Op {
    Reset {},
    Home {
        axis: String,
    },
    Jog {
        axis: String,
        distance: f64,
    },
    Hold {},
    Resume {},
    Stop {},
    Continue {},
    NewBlank {},
    Start {
        single: bool,
    },
    Override {
        what: String,
        percent: f64,
    },
    /// `confirm`: the operator confirmed the offset the loop asked about (its CONFIRM).
    TouchOff {
        axis: String,
        value: Typed,
        #[serde(default)]
        confirm: bool,
    },
    /// A flank of a cut gap touched, the table turned `+` or `-` to it.
    TouchFlank {
        turned: String,
    },
    Spindle {
        rpm: Typed,
    },
    /// The loaded pitch compensation applied to the table (`on`) or not: the loop refuses
    /// it in a cycle, with the gearbox coupled, or `on` without one loaded.
    PitchCompensation {
        on: bool,
    },
    /// A library program by name: the server reads and resolves it (`hob load --lib`).
    Load {
        program: String,
    },
}

/// Messages from the page (a command's own fields are checked by [`Op`]: serde cannot deny
/// unknown fields beside a flattened one).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(tag = "t", rename_all = "snake_case")]
pub enum ClientMsg {
    Hello {
        last_event: u64,
    },
    Cmd {
        id: u64,
        #[serde(flatten)]
        op: Op,
    },
    JogHold {
        id: u64,
        axis: String,
        dir: String,
        /// mm/min (deg/min for B); the hob spindle C's rpm, as typed.
        speed: Typed,
    },
    JogRenew,
    JogRelease,
    /// A commissioning key pressed (starts its procedure: `delay`, the table drive's delay,
    /// `encoder`, the spindle encoder's error, `backlash`, the table's lost motion, or
    /// `response`, the table's frequency response; a page that names none means `delay`),
    /// held (renewed every 100 ms: its enable) and let go.
    CommissionHold {
        id: u64,
        #[serde(default = "delay_procedure")]
        procedure: String,
    },
    CommissionRenew,
    CommissionRelease,
    /// Write the measured proposal into the machine file.
    CommissionWrite {
        id: u64,
    },
    Visibility {
        visible: bool,
    },
}

/// The procedure of a commissioning hold that names none (the pages before the encoder's).
fn delay_procedure() -> String {
    "delay".into()
}

impl Op {
    /// The loop command, encoded by the same builders as the CLI's (`hob_ipc::request`);
    /// `Load` is read from the library by the caller. A refusal in the builders' words (the
    /// page shows it; the fuzz harness, `bench/fuzz-harness`, checks it has words).
    pub fn request(&self) -> Result<CommandRequest, Error> {
        use hob_ipc::command as c;
        let built = match self {
            Op::Reset {} => Ok(request::simple(c::RESET)),
            Op::Home { axis } => request::home(axis),
            Op::Jog { axis, distance } => request::jog(axis, *distance),
            Op::Hold {} => Ok(request::simple(c::FEED_HOLD)),
            Op::Resume {} => Ok(request::simple(c::RESUME)),
            Op::Stop {} => Ok(request::simple(c::STOP)),
            Op::Continue {} => Ok(request::simple(c::CONTINUE)),
            Op::NewBlank {} => Ok(request::simple(c::NEW_BLANK)),
            Op::Start { single } => Ok(request::start(*single)),
            Op::Override { what, percent } => request::override_request(what, *percent),
            Op::TouchOff { axis, value, confirm } => {
                let field = if axis.eq_ignore_ascii_case("y") {
                    "Y: gauge top above the table"
                } else {
                    "X: gauge diameter"
                };
                value
                    .read(field)
                    .and_then(|v| request::touch_off_value(axis, v, *confirm))
            }
            Op::TouchFlank { turned } => request::touch_flank(turned),
            Op::Spindle { rpm } => rpm.read("spindle speed").map(|rpm| {
                if rpm == 0.0 {
                    request::simple(c::SPINDLE_OFF)
                } else {
                    request::spindle_on(rpm)
                }
            }),
            Op::PitchCompensation { on } => request::pitch_compensation(if *on { "on" } else { "off" }),
            Op::Load { program } => {
                return Err(Error::LoadFromLibrary {
                    program: program.clone(),
                });
            }
        };
        built.map_err(Error::Request)
    }
}

/// The answer to one command, by its id.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Answer {
    pub id: u64,
    pub ok: bool,
    /// The loop's refusal word (`codec::Refusal`), none when accepted or not the loop's.
    pub refusal: Option<&'static str>,
    pub text: String,
}

impl Answer {
    pub fn of(id: u64, r: &hob_ipc::CommandResponse) -> Self {
        let ok = r.accepted != 0;
        Self {
            id,
            ok,
            refusal: if ok {
                None
            } else {
                codec::Refusal::from_code(r.refusal).map(codec::Refusal::name)
            },
            text: tr(&r.text()),
        }
    }

    /// A refusal before the loop was asked (bad request, library, no answer).
    pub fn refused(id: u64, text: impl Into<String>) -> Self {
        Self {
            id,
            ok: false,
            refusal: None,
            text: tr(&text.into()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> ClientMsg {
        serde_json::from_str(s).unwrap_or_else(|e| panic!("{s}: {e}"))
    }

    #[test]
    fn every_command_of_the_page_is_the_request_the_cli_sends() {
        let cases: &[(&str, CommandRequest)] = &[
            (
                r#"{"t":"cmd","id":1,"op":"home","axis":"all"}"#,
                request::home("all").expect("home"),
            ),
            (
                r#"{"t":"cmd","id":1,"op":"home","axis":"y"}"#,
                request::home("y").expect("home"),
            ),
            (
                r#"{"t":"cmd","id":1,"op":"jog","axis":"x","distance":-0.1}"#,
                request::jog("x", -0.1).expect("jog"),
            ),
            (
                r#"{"t":"cmd","id":1,"op":"override","what":"feed","percent":80}"#,
                request::override_request("feed", 80.0).expect("override"),
            ),
            (
                r#"{"t":"cmd","id":1,"op":"touch_off","axis":"x","value":120.005}"#,
                request::touch_off("x", Some(120.005), None, false).expect("touch-off"),
            ),
            (
                r#"{"t":"cmd","id":1,"op":"touch_off","axis":"x","value":194.94,"confirm":true}"#,
                request::touch_off("x", Some(194.94), None, true).expect("touch-off"),
            ),
            (
                r#"{"t":"cmd","id":1,"op":"touch_off","axis":"x","value":"94,94"}"#,
                request::touch_off("x", Some(94.94), None, false).expect("touch-off"),
            ),
            (
                r#"{"t":"cmd","id":1,"op":"touch_off","axis":"y","value":" 120.5 "}"#,
                request::touch_off("y", None, Some(120.5), false).expect("touch-off"),
            ),
            (
                r#"{"t":"cmd","id":1,"op":"spindle","rpm":"80,5"}"#,
                request::spindle_on(80.5),
            ),
            (
                r#"{"t":"cmd","id":1,"op":"start","single":true}"#,
                request::start(true),
            ),
            (
                r#"{"t":"cmd","id":1,"op":"continue"}"#,
                request::simple(hob_ipc::command::CONTINUE),
            ),
            (
                r#"{"t":"cmd","id":1,"op":"spindle","rpm":0}"#,
                request::simple(hob_ipc::command::SPINDLE_OFF),
            ),
            (
                r#"{"t":"cmd","id":1,"op":"touch_flank","turned":"-"}"#,
                request::touch_flank("-").expect("touch flank"),
            ),
            (
                r#"{"t":"cmd","id":1,"op":"pitch_compensation","on":true}"#,
                CommandRequest {
                    value: 1.0,
                    ..CommandRequest::new(hob_ipc::command::PITCH_COMPENSATION)
                },
            ),
            (
                r#"{"t":"cmd","id":1,"op":"pitch_compensation","on":false}"#,
                CommandRequest::new(hob_ipc::command::PITCH_COMPENSATION),
            ),
        ];
        for (json, want) in cases {
            let ClientMsg::Cmd { op, .. } = parse(json) else {
                panic!("{json}: not a command")
            };
            assert_eq!(op.request().ok().as_ref(), Some(want), "{json}");
        }
    }

    #[test]
    fn a_malformed_message_or_value_is_refused_before_the_loop() {
        for bad in [
            r#"{"t":"cmd","id":1,"op":"format_disk"}"#,
            r#"{"t":"cmd","id":1,"op":"jog","axis":"x"}"#,
            r#"{"t":"cmd","id":1,"op":"reset","extra":1}"#,
            r#"{"t":"jog_hold","axis":"x","dir":"+","speed":100}"#,
            r#"{"t":"cmd","id":1,"op":"touch_off","axis":"x","value":94.94,"confirm":"yes"}"#,
            r#"{"t":"cmd","id":1,"op":"pitch_compensation","on":1}"#,
            r#"{"t":"cmd","id":1,"op":"pitch_compensation"}"#,
        ] {
            assert!(serde_json::from_str::<ClientMsg>(bad).is_err(), "{bad} parsed");
        }
        let ClientMsg::Cmd { op, .. } = parse(r#"{"t":"cmd","id":1,"op":"home","axis":"b"}"#) else {
            panic!("not a command")
        };
        assert!(op.request().is_err(), "the table needs no reference");
        let ClientMsg::Cmd { op, .. } = parse(r#"{"t":"cmd","id":1,"op":"touch_flank","turned":"up"}"#)
        else {
            panic!("not a command")
        };
        assert!(op.request().is_err(), "a flank touch needs + or -");
        for (json, words) in [
            (
                r#"{"t":"cmd","id":1,"op":"touch_off","axis":"x","value":"1.094,94"}"#,
                "X: gauge diameter: \"1.094,94\" is not a number",
            ),
            (
                r#"{"t":"cmd","id":1,"op":"touch_off","axis":"y","value":""}"#,
                "Y: gauge top above the table: \"\" is not a number",
            ),
            (
                r#"{"t":"cmd","id":1,"op":"spindle","rpm":"80 rpm"}"#,
                "spindle speed: \"80 rpm\" is not a number",
            ),
        ] {
            let ClientMsg::Cmd { op, .. } = parse(json) else {
                panic!("{json}: not a command")
            };
            let e = op.request().expect_err(json).to_string();
            assert!(e.starts_with(words), "{json}: {e}");
        }
    }

    #[test]
    fn every_state_and_fault_code_has_words() {
        for code in 0..codec::State::ALL.len() as u32 {
            assert!(!codec::state_name(code).starts_with('?'), "state {code}");
        }
        let s = StateSample {
            alarm: hob_ipc::AlarmCode {
                code: 1,
                ..Default::default()
            },
            ..Default::default()
        };
        let io: IoMap = hob_store::files::load_machine(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/machine.toml"
        )))
        .expect("the shipped machine file")
        .io;
        let v = StateView::of(&s, &io, 1_000_000);
        let a = v.alarm.expect("an alarm");
        assert!(
            !a.text.is_empty() && !a.remedy.is_empty() && !a.how_to_continue.is_empty(),
            "{a:?}"
        );
        assert_eq!(v.inputs.len(), io.inputs.bindings().len());
    }

    #[test]
    fn histogram_bars_span_the_filled_buckets_and_keep_the_empty_ones_between() {
        let mut h = hob_ipc::Log2Histogram::default();
        h.add(20_000, 990);
        h.add(300_000, 1);
        let b = bars(&h);
        assert_eq!(b.len(), 5, "2^14 .. 2^18 ns");
        assert_eq!((b[0].lo_us, b[0].count), (16.384, 990));
        assert_eq!((b[4].hi_us, b[4].count), (524.288, 1));
        assert!(b[1..4].iter().all(|x| x.count == 0));
        assert!(bars(&hob_ipc::Log2Histogram::default()).is_empty());
    }

    #[test]
    fn the_nodes_are_named_from_their_statuswords_and_heartbeats() {
        let s = StateSample {
            drive_statusword: [0x0237, 0x0008, 0x0040],
            nmt_state: [0x05, 0x7F, 0x04, hob_ipc::NMT_NOT_HEARD],
            heartbeat_age_cycles: [10, 0, 250, u32::MAX],
            last_emcy_code: [0, 0x2310, 0, 0],
            ..Default::default()
        };
        let n = nodes(&s, 2_000_000);
        let emcy: Vec<_> = n.iter().map(|n| n.emcy.as_deref()).collect();
        assert_eq!(
            emcy,
            [None, Some("EMCY 0x2310 continuous over-current"), None, None]
        );
        let got: Vec<_> = n.iter().map(|n| (n.name, n.nmt, n.cia402)).collect();
        assert_eq!(
            got,
            [
                ("B", "operational", Some("operation enabled")),
                ("X", "pre-operational", Some("fault")),
                ("Y", "stopped", Some("switch on disabled")),
                ("I/O", "not heard", None),
            ]
        );
        assert_eq!(n[0].heartbeat_age_ms, 20.0);
        assert_eq!(n[2].statusword.as_deref(), Some("0x0040"));
    }

    #[test]
    fn the_bound_is_a_quarter_of_the_grade_5_pitch_tolerance() {
        // spur-z17-m5: d = 85 mm, m = 5 mm: f_pt(5) / 4 = 1.77 um = 8.6 arcsec at r = 42.5 mm.
        let b = bound_arcsec(42.5, 5.0).expect("a bound");
        let um = hob_gearing::units::arcsec_to_um_at_radius(b, 42.5);
        assert!((um - single_pitch_tolerance_um(85.0, 5.0, 5) / 4.0).abs() < 1e-9);
        assert!((8.0..9.0).contains(&b), "{b}");
        assert_eq!(bound_arcsec(0.0, 0.0), None);
    }

    #[test]
    fn an_event_is_dated_from_its_cycle() {
        let clock = CycleClock {
            cycle: 10_000,
            utc_ms: 1_000_000,
            period_ns: 1_000_000,
        };
        assert_eq!(clock.utc_ms(9_000), 999_000);
        let e = EventSample {
            seq: 3,
            cycle: 9_000,
            kind: event_kind::REFUSED,
            ..Default::default()
        };
        let v = EventView::of(&e, Some(clock));
        assert!(
            v.operator && v.utc_ms == Some(999_000) && v.kind == "refused",
            "{v:?}"
        );
    }

    #[test]
    fn a_commissioning_hold_names_its_procedure_or_means_the_delay() {
        let hold = |json: &str| match parse(json) {
            ClientMsg::CommissionHold { id, procedure } => (id, procedure),
            m => panic!("{json}: {m:?}"),
        };
        // A page from before the encoder's key names none: the table drive's delay.
        assert_eq!(
            hold(r#"{"t":"commission_hold","id":5}"#),
            (5, "delay".to_string())
        );
        assert_eq!(
            hold(r#"{"t":"commission_hold","id":6,"procedure":"encoder"}"#),
            (6, "encoder".to_string())
        );
        // An unknown name is the session's to refuse in words (nothing runs).
        assert_eq!(
            hold(r#"{"t":"commission_hold","id":7,"procedure":"bogus"}"#),
            (7, "bogus".to_string())
        );
        assert!(
            serde_json::from_str::<ClientMsg>(r#"{"t":"commission_hold","id":8,"procedure":3}"#).is_err()
        );
    }
}
