//! Every code of the contract between processes, as the number it is on the wire, and its
//! text: sequencer states, refusals, alarms (faults) with their axis and end, gearbox
//! couplings, commands, event kinds and bus events. Frontends decode with these and print
//! these texts, from the numbers alone, so a code reads the same everywhere. The states,
//! refusals, axes, ends, homing failures and couplings are the control core's own types
//! ([`crate::vocab`]); an alarm is the control core's fault as [`Fault`], its code here.
//!
//! The numbers are the wire format: never renumber one, only add new ones.

pub use crate::bus::nmt_state_name;
use crate::bus::{BusError, PowerState, emcy_text};
pub use crate::vocab::{Axis, Coupling, End, HomingFailure, Refusal, State};
use crate::{AlarmCode, EventSample, bus_event, bus_kind, command, event_kind, send_error};

/// The state's name, or `?<code>` for a code this build does not know.
pub fn state_name(c: u32) -> String {
    State::from_code(c).map_or_else(|| format!("?{c}"), |s| s.name().to_string())
}

/// The text of a refusal code (`?<code>` for one this build does not know).
pub fn refusal_text(c: u32) -> String {
    Refusal::from_code(c).map_or_else(|| format!("?{c}"), |r| r.text().to_string())
}

/// What stopped the machine ([`AlarmCode::code`]; 0: no alarm). Which of the alarm's
/// `axis`, `end`, `value_a`, `value_b` it uses is in [`Fault::text`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum Fault {
    SafetyChainOpen = 1,
    EmergencyStop = 2,
    /// `axis`, `end`.
    HardwareLimit = 3,
    /// `axis`, `value_a`: the commanded position.
    SoftLimit = 4,
    /// `axis`, `value_a`: the error.
    FollowingError = 5,
    /// `axis`.
    DriveFault = 6,
    VfdFault = 7,
    /// `value_a`: the error, arcsec.
    SyncLost = 8,
    /// `value_a`: set, `value_b`: actual, rpm.
    SpindleSpeed = 9,
    LubeTimeout = 10,
    ClampTimeout = 11,
    /// `axis`.
    FeedbackLost = 12,
    IoLost = 13,
    /// `axis`.
    DriveNotEnabled = 14,
    /// `axis`, `end`: a [`HomingFailure`] code.
    HomingFailed = 15,
    /// `axis`.
    PositionLost = 16,
}

// The pieces of the fault texts (literals, so that each text is one `&'static str`).

/// A fault in a cycle when X and the table can both still move (`seq_on_fault`:
/// `FaultRetract` from the cut or the infeed, else `FaultStop`).
macro_rules! reaction_retract {
    () => {
        "in the cut (or the infeed) X retracted to its safe position with the gearbox still \
         engaged, so the hob left its tooth gap (Y stopped, the X clamp opened); then the machine \
         stopped (gearbox out, spindle and axes to rest, 15 s at most) and PC-OK dropped, which \
         opens the safety chain; elsewhere in a cycle it stopped where it was, then PC-OK dropped"
    };
}

/// A fault in a cycle that the table cannot follow.
macro_rules! reaction_table_lost {
    () => {
        "in the cut the table could no longer follow: the spindle stopped and the gearbox \
         disengaged at once, X pulled the hob out of the work (Y stopped), then the machine came \
         to rest and PC-OK dropped, which opens the safety chain; elsewhere in a cycle the \
         spindle stopped and the gearbox disengaged at once, the machine stopped where it was, \
         then PC-OK dropped"
    };
}

/// A fault in a cycle under which X cannot move.
macro_rules! reaction_x_stuck {
    () => {
        "in a cycle X could not move: the machine stopped where it was, the hob in the work if \
         it was there (gearbox out, spindle and axes to rest, 15 s at most), then PC-OK dropped, \
         which opens the safety chain"
    };
}

macro_rules! reaction_outside {
    () => {
        "; outside a cycle (idle, jogging, referencing) the spindle stopped and PC-OK dropped at once"
    };
}

/// The watchdog's reaction to a loop faulted with a node lost (`hob-watchdog`).
macro_rules! reaction_watchdog {
    () => {
        "; with the loop faulted, the watchdog switched every output of the I/O coupler off by \
         SDO (spindle reference 0 V) and quick-stopped every drive"
    };
}

/// PC-OK dropped on every fault: the chain closes again only once it is back.
macro_rules! continue_reset {
    () => {
        "RESET (PC-OK comes back), then the reset button on the panel closes the safety chain \
         and the machine powers up to idle"
    };
}

macro_rules! continue_pass {
    () => {
        "CONTINUE re-enters the interrupted pass on the same tooth gaps (if a cycle was \
         interrupted and the same program is loaded), or START"
    };
}

/// What comes `before` the reset, the reset, what comes `between` it and the pass.
macro_rules! continue_after {
    ($before:literal, $between:literal) => {
        concat!($before, continue_reset!(), $between, continue_pass!())
    };
}

/// The table lost its position after the part's tooth phase was recorded.
macro_rules! continue_phase_lost {
    () => {
        "the part on the table has lost its tooth phase and cannot be finished on the same \
         gaps: CONTINUE is refused; NEW BLANK with a new part, then START"
    };
}

impl Fault {
    /// Every fault, in code order (`ALL[i].code() == i + 1`).
    pub const ALL: [Fault; 16] = [
        Fault::SafetyChainOpen,
        Fault::EmergencyStop,
        Fault::HardwareLimit,
        Fault::SoftLimit,
        Fault::FollowingError,
        Fault::DriveFault,
        Fault::VfdFault,
        Fault::SyncLost,
        Fault::SpindleSpeed,
        Fault::LubeTimeout,
        Fault::ClampTimeout,
        Fault::FeedbackLost,
        Fault::IoLost,
        Fault::DriveNotEnabled,
        Fault::HomingFailed,
        Fault::PositionLost,
    ];

    pub const fn code(self) -> u32 {
        self as u32
    }

    pub fn from_code(c: u32) -> Option<Fault> {
        c.checked_sub(1).and_then(|i| Self::ALL.get(i as usize).copied())
    }

    pub const fn name(self) -> &'static str {
        match self {
            Fault::SafetyChainOpen => "safety-chain-open",
            Fault::EmergencyStop => "emergency-stop",
            Fault::HardwareLimit => "hardware-limit",
            Fault::SoftLimit => "soft-limit",
            Fault::FollowingError => "following-error",
            Fault::DriveFault => "drive-fault",
            Fault::VfdFault => "vfd-fault",
            Fault::SyncLost => "sync-lost",
            Fault::SpindleSpeed => "spindle-speed",
            Fault::LubeTimeout => "lube-timeout",
            Fault::ClampTimeout => "clamp-timeout",
            Fault::FeedbackLost => "feedback-lost",
            Fault::IoLost => "io-lost",
            Fault::DriveNotEnabled => "drive-not-enabled",
            Fault::HomingFailed => "homing-failed",
            Fault::PositionLost => "position-lost",
        }
    }

    /// Whether the fault names an axis (its alarm is incomplete without one).
    pub const fn has_axis(self) -> bool {
        matches!(
            self,
            Fault::HardwareLimit
                | Fault::SoftLimit
                | Fault::FollowingError
                | Fault::DriveFault
                | Fault::FeedbackLost
                | Fault::DriveNotEnabled
                | Fault::HomingFailed
                | Fault::PositionLost
        )
    }

    /// The fault of an alarm: `None` for code 0, an unknown code, or a fault that names an
    /// axis without a valid one.
    pub fn of(a: &AlarmCode) -> Option<Fault> {
        let f = Fault::from_code(a.code)?;
        (!f.has_axis() || Axis::from_code(a.axis).is_some()).then_some(f)
    }

    /// Whether X can still move under this fault on `axis` (else the machine stops where
    /// it is instead of retracting): the control core's `Fault::x_can_move`, read from the
    /// wire (hob-service's tests check the two agree for every fault).
    pub fn x_can_move(self, a: &AlarmCode) -> bool {
        let x = Axis::from_code(a.axis) == Some(Axis::X);
        !match self {
            Fault::DriveFault
            | Fault::DriveNotEnabled
            | Fault::FollowingError
            | Fault::FeedbackLost
            | Fault::SoftLimit
            | Fault::PositionLost
            | Fault::HomingFailed => x,
            Fault::HardwareLimit => x && End::from_code(a.end) != Some(End::Min),
            _ => false,
        }
    }

    /// Whether the table can still follow the spindle under this fault (else the spindle
    /// stops and the gearbox disengages at once): the control core's
    /// `Fault::table_can_follow`, read from the wire.
    pub fn table_can_follow(self, a: &AlarmCode) -> bool {
        let b = Axis::from_code(a.axis) == Some(Axis::B);
        !match self {
            Fault::DriveFault
            | Fault::DriveNotEnabled
            | Fault::FollowingError
            | Fault::FeedbackLost
            | Fault::PositionLost => b,
            Fault::SyncLost => true,
            _ => false,
        }
    }

    /// What the machine did on this fault, in the operator's words (docs: README, "What a
    /// fault does"): the control core's fault reaction (`seq_on_fault`) for the alarm's
    /// axis, in the cut, elsewhere in a cycle and outside one; for a lost node also what
    /// the watchdog did once the loop stood faulted.
    pub fn reaction(self, a: &AlarmCode) -> &'static str {
        let watchdog = matches!(self, Fault::FeedbackLost | Fault::IoLost);
        match (self.x_can_move(a), self.table_can_follow(a), watchdog) {
            (false, _, false) => concat!(reaction_x_stuck!(), reaction_outside!()),
            (false, _, true) => concat!(reaction_x_stuck!(), reaction_outside!(), reaction_watchdog!()),
            (true, false, false) => concat!(reaction_table_lost!(), reaction_outside!()),
            (true, false, true) => {
                concat!(reaction_table_lost!(), reaction_outside!(), reaction_watchdog!())
            }
            (true, true, false) => concat!(reaction_retract!(), reaction_outside!()),
            (true, true, true) => concat!(reaction_retract!(), reaction_outside!(), reaction_watchdog!()),
        }
    }

    /// What the operator checks or repairs before RESET.
    pub const fn remedy(self) -> &'static str {
        match self {
            Fault::SafetyChainOpen => {
                "find what opened the chain: an e-stop button, a hardware limit switch, the VFD's \
                 fault relay or PC-OK; POWER-UP shows what the chain's reset needs (VFD ready, PC \
                 reset relay, lube and coolant pumps off, e-stop released, the reset button)"
            }
            Fault::EmergencyStop => {
                "find why the e-stop was pressed and make the machine safe, then release the e-stop \
                 button: while it is pressed the alarm comes back at once after RESET"
            }
            Fault::HardwareLimit => {
                "the slide stands on its limit switch, which keeps the safety chain open (no drive \
                 enable, so no jog) and the alarm back after RESET: move it off the switch by hand; \
                 then find why it got there (soft limits guard only a referenced axis, the work \
                 offsets, the program)"
            }
            Fault::SoftLimit => {
                "a command went outside the soft limits (soft_limit_min_mm, soft_limit_max_mm of \
                 [x] or [y] in the machine file): check the work offsets (touch-off) and the \
                 program's positions against the axis's travel"
            }
            Fault::FollowingError => {
                "the axis could not follow its command (max_following_error_mm of the axis, or of \
                 the table): look for an obstruction, a collision, a seized slide, a brake not \
                 released or a drive at its current limit"
            }
            Fault::DriveFault => {
                "read the drive's EMCY in DIAGNOSTICS (over-current, over-temperature, encoder) and \
                 repair the cause at the drive; RESET sends the drive a fault reset, and a fault \
                 still there after the drives' 2 s enable time is this alarm again"
            }
            Fault::VfdFault => {
                "read the fault code on the spindle VFD's display, repair its cause and reset the \
                 VFD: until then its fault relay keeps the safety chain open and the alarm comes back \
                 after RESET"
            }
            Fault::SyncLost => {
                "the table left the coarse window: check the spindle encoder and its coupling, \
                 the table drive's tuning and the cutting load (speeds, feed, worn hob)"
            }
            Fault::SpindleSpeed => {
                "the spindle did not reach its speed: check the VFD (enable, its own fault), the \
                 belt and the spindle encoder"
            }
            Fault::LubeTimeout => {
                "the pressure switch did not confirm: check the lubricant level, the pump and its \
                 fuse, the filter, the lines and the switch"
            }
            Fault::ClampTimeout => "check the X clamp's magnet, its supply and its feedback switch",
            Fault::FeedbackLost => {
                "the drive's position frames stopped: check its CAN cable and connectors, the bus \
                 termination and the drive's supply (did it restart?); DIAGNOSTICS lists the \
                 heartbeats and EMCYs"
            }
            Fault::IoLost => {
                "the I/O coupler stopped answering: check its CAN cable, its supply, the bus \
                 termination and its node id"
            }
            Fault::DriveNotEnabled => {
                "the drive did not reach \"operation enabled\": check its enable input (safety \
                 chain), its supply and its own fault"
            }
            Fault::HomingFailed => {
                "the alarm says why (mode not confirmed, homing not started, the drive's homing \
                 error, timeout): check the home switch and its cable, the homing method, speeds \
                 and timeout ([x.homing], [y.homing] in the machine file) and the axis's travel"
            }
            Fault::PositionLost => {
                "the drive restarted or its encoder jumped: check its supply and encoder cable; \
                 its reference (or the part's tooth phase on the table) is gone"
            }
        }
    }

    /// How work goes on after the remedy (what the control core asks of `CONTINUE`: the
    /// interrupted pass kept, X and Y referenced, the table's position kept since the
    /// part's tooth phase was recorded).
    pub const fn how_to_continue(self) -> &'static str {
        match self {
            Fault::EmergencyStop => continue_after!("with the e-stop released: ", "; then "),
            Fault::HardwareLimit => continue_after!(
                "with the slide off the switch: ",
                "; HOME the axis if its reference is in doubt; then "
            ),
            Fault::VfdFault => continue_after!("with the VFD reset: ", "; then "),
            Fault::LubeTimeout => continue_after!(
                "",
                " (RESET runs the lubrication again and the machine waits for its pressure); then "
            ),
            Fault::SoftLimit => concat!(
                continue_reset!(),
                "; START and CONTINUE check the program against the soft limits again: correct \
                 the work offsets or load a corrected program (a changed program cannot be \
                 continued: START it)"
            ),
            Fault::HomingFailed => concat!(
                continue_reset!(),
                "; HOME again: the axis that failed is not referenced (homing drops its reference \
                 first), START and CONTINUE are refused until it is; a pass interrupted before is \
                 still there for CONTINUE"
            ),
            Fault::PositionLost => concat!(
                continue_reset!(),
                "; X or Y: HOME it (its reference is gone), then CONTINUE re-enters the \
                 interrupted pass; B: ",
                continue_phase_lost!()
            ),
            Fault::FeedbackLost | Fault::IoLost => {
                "once the node answers again, restart hob-rt: the watchdog acted and re-arms only \
                 for a new loop, and a node that restarted is configured only by hob-rt's start-up; \
                 the new loop has no reference, no interrupted pass and no tooth phase: the reset \
                 button on the panel, HOME X and Y, then START; a part interrupted on the table \
                 cannot be finished on the same gaps: NEW BLANK with a new part"
            }
            Fault::SafetyChainOpen
            | Fault::FollowingError
            | Fault::DriveFault
            | Fault::SyncLost
            | Fault::SpindleSpeed
            | Fault::ClampTimeout
            | Fault::DriveNotEnabled => continue_after!("", "; then "),
        }
    }

    /// What the operator reads for an alarm of this fault (its axis, end and values
    /// from `a`); `None` if the fault names an axis and `a` has none.
    pub fn text(self, a: &AlarmCode) -> Option<String> {
        let axis = Axis::from_code(a.axis);
        let (va, vb) = (a.value_a, a.value_b);
        Some(match self {
            Fault::SafetyChainOpen => "safety chain open".into(),
            Fault::EmergencyStop => "emergency stop pressed".into(),
            Fault::HardwareLimit => {
                // End 1 is min; anything else reads as max (as it always has).
                let end = if End::from_code(a.end) == Some(End::Min) {
                    End::Min
                } else {
                    End::Max
                };
                format!("hardware limit {} {}", axis?.name(), end.name())
            }
            Fault::SoftLimit => {
                let axis = axis?;
                format!("soft limit {}: {va:.3} {}", axis.name(), axis.unit())
            }
            Fault::FollowingError => {
                let axis = axis?;
                format!("following error {}: {va:.4} {}", axis.name(), axis.unit())
            }
            Fault::DriveFault => format!("drive fault {}", axis?.name()),
            Fault::VfdFault => "spindle VFD fault".into(),
            Fault::SyncLost => format!("synchronisation lost: {va:.1} arcsec outside the coarse window"),
            Fault::SpindleSpeed => format!("spindle did not reach {va:.1} rpm (is {vb:.1} rpm)"),
            Fault::LubeTimeout => "lubrication pressure not confirmed in time".into(),
            Fault::ClampTimeout => "X clamp did not report in time".into(),
            Fault::FeedbackLost => format!("feedback of drive {} lost (bus)", axis?.name()),
            Fault::IoLost => "I/O coupler lost (bus)".into(),
            Fault::DriveNotEnabled => format!("drive {} not in \"operation enabled\"", axis?.name()),
            Fault::HomingFailed => format!(
                "referencing {} failed: {}",
                axis?.name(),
                HomingFailure::from_code(a.end).map_or("?", HomingFailure::text)
            ),
            Fault::PositionLost => {
                let axis = axis?;
                let what = if axis == Axis::B {
                    "the tooth phase of the part on the table is gone"
                } else {
                    "reference it again (hob home)"
                };
                format!(
                    "drive {} lost its position (reboot or encoder): {what}",
                    axis.name()
                )
            }
        })
    }
}

/// The recorder (`hob-logger`) as the operator is told of it: `hob status` and the HMI.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RecorderView {
    /// Something recorded is being lost, or the recorder stopped reporting: shown as an
    /// alarm (the loop goes on: a record is not worth a part).
    pub alarm: bool,
    pub text: String,
}

/// A recorder report older than this is a recorder that stopped (it reports every 200 ms).
pub const RECORDER_SILENT_NS: u64 = 2_000_000_000;

/// What to tell of the recorder, given its newest report (if any) and the reader's
/// CLOCK_MONOTONIC.
pub fn recorder_view(r: Option<&crate::RecorderSample>, now_ns: u64) -> RecorderView {
    let Some(r) = r else {
        return RecorderView {
            alarm: false,
            text: "no recorder on the bus (hob-logger not running): nothing is recorded".into(),
        };
    };
    let age_ns = now_ns.saturating_sub(r.time_ns);
    if age_ns > RECORDER_SILENT_NS {
        return RecorderView {
            alarm: true,
            text: format!(
                "the recorder stopped reporting {:.1} s ago (hob-logger ended or hangs)",
                age_ns as f64 / 1e9
            ),
        };
    }
    if r.writing == 0 {
        let since = if r.failing_since_ns > 0 {
            format!(
                " for {:.1} s",
                now_ns.saturating_sub(r.failing_since_ns) as f64 / 1e9
            )
        } else {
            String::new()
        };
        return RecorderView {
            alarm: true,
            text: format!(
                "RECORDER ALARM: cannot write{since}: {}: {} samples and {} events not written (it resumes when space returns)",
                std::io::Error::from_raw_os_error(r.last_errno),
                r.samples_unwritten,
                r.events_unwritten
            ),
        };
    }
    let mut text = format!("writing: {} samples recorded", r.samples_written);
    if r.samples_unwritten > 0 || r.events_unwritten > 0 {
        text += &format!(
            ", {} samples and {} events not written earlier (gaps.log)",
            r.samples_unwritten, r.events_unwritten
        );
    }
    if r.samples_lost > 0 {
        text += &format!(", {} samples missed on the bus", r.samples_lost);
    }
    RecorderView { alarm: false, text }
}

/// The text of an alarm ("" for none, `alarm code <c>` for one this build cannot word).
pub fn alarm_text(a: &AlarmCode) -> String {
    if a.code == 0 {
        return String::new();
    }
    Fault::of(a)
        .and_then(|f| f.text(a))
        .unwrap_or_else(|| format!("alarm code {}", a.code))
}

/// The name of a coupling code (`?` for one this build does not know).
pub fn coupling_name(c: u32) -> &'static str {
    Coupling::from_code(c).map_or("?", Coupling::name)
}

/// Every [`command`] code, in code order (declared once, with its word, in [`command`]).
pub const COMMANDS: [u32; command::ALL.len()] = command::ALL;

/// The command's name as the CLI spells it (`?` for a code this build does not know).
pub fn command_name(code: u32) -> &'static str {
    command::name(code).unwrap_or("?")
}

/// Every [`event_kind`] code, in code order (declared once, with its word, in [`event_kind`]).
pub const EVENT_KINDS: [u32; event_kind::ALL.len()] = event_kind::ALL;

/// The name of an [`event_kind`] code (`None` for one this build does not know).
pub fn event_kind_name(k: u32) -> Option<&'static str> {
    event_kind::name(k)
}

/// One line for an event (logger, `hob status --watch`, HMI).
pub fn event_text(e: &EventSample) -> String {
    match e.kind {
        event_kind::STATE_CHANGED => format!("state {} -> {}", state_name(e.a), state_name(e.b)),
        event_kind::ALARM => format!("ALARM {}", alarm_text(&e.alarm)),
        event_kind::ALARM_CLEARED => "alarm cleared".into(),
        event_kind::PASS_STARTED => format!("pass {} started", e.a),
        event_kind::PHASE_RECORDED => format!("tooth phase recorded: {:.4} deg", e.value),
        event_kind::ACCEPTED => format!("accepted: {}", command_name(e.a)),
        event_kind::REFUSED => format!(
            "refused: {}: {}",
            command_name(e.a),
            Refusal::from_code(e.b).map_or("?", Refusal::text)
        ),
        event_kind::PROGRAM_LOADED => "program loaded".into(),
        event_kind::CYCLE_DONE => "cycle done".into(),
        event_kind::BUS => bus_event_text(e),
        event_kind::MESSAGE => e.text(),
        event_kind::REFERENCED => format!("{} referenced", axis_name(e.a)),
        event_kind::DEAD_MAN_STOP if e.a == 0 => {
            "hob spindle C stopped: its renewals stopped (dead-man)".into()
        }
        event_kind::DEAD_MAN_STOP => {
            format!("jog {} stopped: its renewals stopped (dead-man)", axis_name(e.a))
        }
        event_kind::OFFSET_CHANGED => format!("touch-off: {} offset {:+.4} mm", axis_name(e.a), e.value),
        event_kind::FLANK_TOUCHED => format!(
            "flank touched, the table turned {}: tooth phase {:.4} deg; the part's phase is set when both flanks are touched",
            if e.a == u32::from(crate::direction::POSITIVE) {
                "positive"
            } else {
                "negative"
            },
            e.value
        ),
        event_kind::PHASE_ALIGNED => format!(
            "aligned to the cut gaps: tooth phase {:.4} deg, {:.4} deg of play between the flanks",
            e.value,
            f64::from(e.a) * 1e-6
        ),
        k => format!("event kind {k}"),
    }
}

fn axis_name(code: u32) -> &'static str {
    u8::try_from(code)
        .ok()
        .and_then(Axis::from_code)
        .map_or("?", Axis::name)
}

/// Every [`bus_event`] code, in code order (declared once, with its word, in [`bus_event`]).
pub const BUS_EVENTS: [u32; bus_event::ALL.len()] = bus_event::ALL;

/// The name of a [`bus_event`] code (`None` for one this build does not know).
pub fn bus_event_name(b: u32) -> Option<&'static str> {
    bus_event::name(b)
}

/// The operator's words for a bus event ([`event_kind::BUS`]).
pub fn bus_event_text(e: &EventSample) -> String {
    let node = e.a;
    match e.b {
        bus_event::EMCY => {
            let code = e.value as u16;
            format!("EMCY node {node} 0x{code:04X}: {}", emcy_text(code))
        }
        bus_event::HEARTBEAT_LOST => format!("heartbeat of node {node} lost"),
        bus_event::TPDO_MISSING => {
            let cycles = e.value;
            format!(
                "TPDO of node {} late or lost in {cycles} cycle{} since its last report, at most {} in a row",
                node & 0xFF,
                if cycles == 1.0 { "" } else { "s" },
                node >> 8
            )
        }
        bus_event::SEND_FAILED => {
            let why = match e.a {
                send_error::QUEUE_FULL => BusError::Full.to_string(),
                send_error::INTERFACE_DOWN => BusError::Down.to_string(),
                _ => BusError::Os(e.value as i32).to_string(),
            };
            format!("CAN send failed: {why}")
        }
        b => format!("bus event {b} of node {node}"),
    }
}

/// A drive's CiA 402 power state, from its statusword ([`crate::StateSample::drive_statusword`]).
pub fn cia402_state_name(statusword: u16) -> &'static str {
    PowerState::from_statusword(statusword).name()
}

/// The name of a [`bus_kind`] code.
pub fn bus_kind_name(k: u8) -> &'static str {
    match k {
        bus_kind::SHARED_MEMORY => "shm",
        _ => "socketcan",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_recorder_is_an_alarm_when_it_cannot_write_or_stops_reporting() {
        let ok = crate::RecorderSample {
            time_ns: 10_000_000_000,
            samples_written: 5000,
            writing: 1,
            ..Default::default()
        };
        let v = recorder_view(Some(&ok), 10_100_000_000);
        assert!(!v.alarm && v.text == "writing: 5000 samples recorded", "{v:?}");
        let full = crate::RecorderSample {
            writing: 0,
            failing_since_ns: 7_000_000_000,
            last_errno: 28,
            samples_unwritten: 3000,
            events_unwritten: 2,
            ..ok
        };
        let v = recorder_view(Some(&full), 10_100_000_000);
        assert!(v.alarm, "{v:?}");
        assert!(
            v.text.contains("for 3.1 s")
                && v.text.contains("No space left on device")
                && v.text.contains("3000 samples and 2 events not written"),
            "{v:?}"
        );
        let v = recorder_view(Some(&ok), 13_000_000_000);
        assert!(v.alarm && v.text.contains("stopped reporting 3.0 s ago"), "{v:?}");
        let resumed = crate::RecorderSample {
            samples_unwritten: 3000,
            ..ok
        };
        let v = recorder_view(Some(&resumed), 10_000_000_000);
        assert!(
            !v.alarm && v.text.contains("3000 samples and 0 events not written earlier"),
            "{v:?}"
        );
        assert!(!recorder_view(None, 0).alarm);
    }
    use std::collections::BTreeSet;

    fn distinct<'a>(names: impl IntoIterator<Item = &'a str>) -> bool {
        let names: Vec<&str> = names.into_iter().collect();
        names.iter().collect::<BTreeSet<_>>().len() == names.len() && names.iter().all(|n| !n.is_empty())
    }

    #[test]
    fn every_code_is_its_position_and_round_trips() {
        for (i, s) in State::ALL.into_iter().enumerate() {
            assert_eq!(s.code(), i as u32);
            assert_eq!(State::from_code(s.code()), Some(s));
        }
        for (i, r) in Refusal::ALL.into_iter().enumerate() {
            assert_eq!(r.code(), i as u32 + 1);
            assert_eq!(Refusal::from_code(r.code()), Some(r));
        }
        for (i, f) in Fault::ALL.into_iter().enumerate() {
            assert_eq!(f.code(), i as u32 + 1);
            assert_eq!(Fault::from_code(f.code()), Some(f));
        }
        for (i, c) in Coupling::ALL.into_iter().enumerate() {
            assert_eq!(c.code(), i as u32);
            assert_eq!(Coupling::from_code(c.code()), Some(c));
        }
        for (i, a) in Axis::ALL.into_iter().enumerate() {
            assert_eq!(a.code(), i as u8 + 1);
            assert_eq!(Axis::from_code(a.code()), Some(a));
            assert_eq!(Axis::parse(&a.name().to_lowercase()), Some(a));
        }
        for (i, e) in End::ALL.into_iter().enumerate() {
            assert_eq!(e.code(), i as u8 + 1);
            assert_eq!(End::from_code(e.code()), Some(e));
        }
        for (i, c) in COMMANDS.into_iter().enumerate() {
            assert_eq!(c, i as u32 + 1);
        }
        for (i, k) in EVENT_KINDS.into_iter().enumerate() {
            assert_eq!(k, i as u32 + 1);
        }
        for (i, b) in BUS_EVENTS.into_iter().enumerate() {
            assert_eq!(b, i as u32 + 1);
        }
    }

    #[test]
    fn every_code_has_a_distinct_name() {
        assert!(distinct(State::ALL.map(State::name)));
        assert!(distinct(Refusal::ALL.map(Refusal::name)));
        assert!(distinct(Refusal::ALL.map(Refusal::text)));
        assert!(distinct(Fault::ALL.map(Fault::name)));
        assert!(distinct(Coupling::ALL.map(Coupling::name)));
        assert!(distinct(Axis::ALL.map(Axis::name)));
        assert!(distinct(End::ALL.map(End::name)));
        assert!(distinct(COMMANDS.map(command_name)));
        assert!(distinct(EVENT_KINDS.map(|k| event_kind_name(k).unwrap())));
        assert!(distinct(BUS_EVENTS.map(|b| bus_event_name(b).unwrap())));
        // Every alarm reads differently, given an axis and values.
        let texts: Vec<String> = Fault::ALL
            .iter()
            .map(|f| {
                let a = AlarmCode {
                    code: f.code(),
                    axis: Axis::X.code(),
                    end: End::Min.code(),
                    value_a: 1.0,
                    value_b: 2.0,
                    ..AlarmCode::default()
                };
                alarm_text(&a)
            })
            .collect();
        assert!(distinct(texts.iter().map(String::as_str)), "{texts:?}");
    }

    #[test]
    fn unknown_codes_decode_to_none() {
        assert_eq!(State::from_code(State::ALL.len() as u32), None);
        assert_eq!(state_name(99), "?99");
        assert_eq!(Refusal::from_code(0), None);
        assert_eq!(Refusal::from_code(Refusal::ALL.len() as u32 + 1), None);
        assert_eq!(refusal_text(42), "?42");
        assert_eq!(Fault::from_code(0), None);
        assert_eq!(Fault::from_code(Fault::ALL.len() as u32 + 1), None);
        assert_eq!(Coupling::from_code(5), None);
        assert_eq!(coupling_name(5), "?");
        assert_eq!(Axis::from_code(0), None);
        assert_eq!(Axis::from_code(4), None);
        assert_eq!(Axis::parse("z"), None);
        assert_eq!(End::from_code(0), None);
        assert_eq!(End::from_code(3), None);
        assert_eq!(command_name(0), "?");
        assert_eq!(command_name(COMMANDS.len() as u32 + 1), "?");
        assert_eq!(event_kind_name(0), None);
        assert_eq!(event_kind_name(EVENT_KINDS.len() as u32 + 1), None);
        assert_eq!(bus_event_name(5), None);
        let e = EventSample {
            kind: 99,
            ..EventSample::default()
        };
        assert_eq!(event_text(&e), "event kind 99");
    }

    #[test]
    fn alarms_are_worded_from_their_numbers() {
        assert_eq!(alarm_text(&AlarmCode::default()), "");
        let a = |code: u32, axis: u8, end: u8, va: f64, vb: f64| AlarmCode {
            code,
            axis,
            end,
            value_a: va,
            value_b: vb,
            ..AlarmCode::default()
        };
        assert_eq!(alarm_text(&a(3, 3, 1, 0.0, 0.0)), "hardware limit Y min");
        assert_eq!(alarm_text(&a(3, 1, 2, 0.0, 0.0)), "hardware limit B max");
        assert_eq!(alarm_text(&a(4, 1, 0, 12.5, 0.0)), "soft limit B: 12.500 deg");
        assert_eq!(alarm_text(&a(5, 2, 0, 0.25, 0.0)), "following error X: 0.2500 mm");
        assert_eq!(
            alarm_text(&a(9, 0, 0, 119.0, 80.0)),
            "spindle did not reach 119.0 rpm (is 80.0 rpm)"
        );
        // A fault that names an axis, without one; an unknown code.
        assert_eq!(alarm_text(&a(12, 0, 0, 0.0, 0.0)), "alarm code 12");
        assert_eq!(Fault::of(&a(12, 0, 0, 0.0, 0.0)), None);
        assert_eq!(Fault::of(&a(13, 0, 0, 0.0, 0.0)), Some(Fault::IoLost));
        assert_eq!(alarm_text(&a(77, 0, 0, 0.0, 0.0)), "alarm code 77");
    }

    #[test]
    fn events_are_worded_from_their_numbers() {
        let e = |kind: u32, a: u32, b: u32| EventSample {
            kind,
            a,
            b,
            ..EventSample::default()
        };
        assert_eq!(
            event_text(&e(
                event_kind::STATE_CHANGED,
                State::Idle.code(),
                State::Cut.code()
            )),
            "state idle -> cut"
        );
        assert_eq!(
            event_text(&e(event_kind::STATE_CHANGED, 1, 40)),
            "state idle -> ?40"
        );
        assert_eq!(
            event_text(&e(event_kind::REFUSED, command::START, Refusal::NoProgram.code())),
            "refused: start: no program loaded: load one first (hob load PROGRAM)"
        );
        assert_eq!(
            event_text(&e(event_kind::REFUSED, command::START, 0)),
            "refused: start: ?"
        );
        assert_eq!(
            event_text(&e(event_kind::ACCEPTED, command::JOG, 0)),
            "accepted: jog"
        );
        let mut bus = e(event_kind::BUS, 5, bus_event::HEARTBEAT_LOST);
        assert_eq!(event_text(&bus), "heartbeat of node 5 lost");
        bus.b = 9;
        assert_eq!(event_text(&bus), "bus event 9 of node 5");
    }

    #[test]
    fn every_fault_says_what_the_machine_did_what_to_repair_and_how_to_go_on() {
        // Every code the wire can carry, with every axis and end byte an alarm can hold.
        let faults: Vec<Fault> = (0..=u32::from(u8::MAX)).filter_map(Fault::from_code).collect();
        assert_eq!(faults, Fault::ALL);
        for f in faults {
            for axis in [0u8, 1, 2, 3] {
                for end in [0u8, 1, 2] {
                    let a = AlarmCode {
                        code: f.code(),
                        axis,
                        end,
                        ..AlarmCode::default()
                    };
                    let r = f.reaction(&a);
                    assert!(
                        r.len() > 40 && r.contains("PC-OK dropped"),
                        "{f:?} axis {axis}: {r}"
                    );
                    // Outside a cycle every fault stops the spindle and drops PC-OK at once.
                    assert!(r.contains("outside a cycle"), "{f:?}: {r}");
                }
            }
            assert!(f.remedy().len() > 30, "{f:?}: {}", f.remedy());
            let c = f.how_to_continue();
            // PC-OK dropped on every fault and opened the chain: its reset button is part
            // of going on, whatever the fault.
            assert!(c.contains("reset button"), "{f:?}: {c}");
            assert!(c.contains("START"), "{f:?}: {c}");
        }
        // The three reactions are told apart by the axis.
        let b = AlarmCode {
            code: Fault::DriveFault.code(),
            axis: Axis::B.code(),
            ..AlarmCode::default()
        };
        let x = AlarmCode {
            axis: Axis::X.code(),
            ..b
        };
        let y = AlarmCode {
            axis: Axis::Y.code(),
            ..b
        };
        let texts = [
            Fault::DriveFault.reaction(&b),
            Fault::DriveFault.reaction(&x),
            Fault::DriveFault.reaction(&y),
        ];
        assert!(texts[0].contains("disengaged at once") && texts[1].contains("stopped where it was"));
        assert!(texts[2].contains("retracted to its safe position with the gearbox still engaged"));
        assert!(texts.iter().all(|t| !t.contains("watchdog")));
        // A lost node: the watchdog acts too, and only a restarted hob-rt re-arms it.
        let lost = AlarmCode {
            code: Fault::FeedbackLost.code(),
            ..y
        };
        assert!(Fault::FeedbackLost.reaction(&lost).contains("watchdog"));
        assert!(Fault::IoLost.reaction(&AlarmCode::default()).contains("watchdog"));
        for f in [Fault::FeedbackLost, Fault::IoLost] {
            assert!(f.how_to_continue().contains("restart hob-rt"), "{f:?}");
        }
    }

    #[test]
    fn continue_is_offered_only_where_the_loop_accepts_it() {
        // CONTINUE needs the interrupted pass, X and Y referenced and the table's position
        // kept (`Command::Continue` in the control core).
        let continues = |f: Fault| f.how_to_continue().contains("CONTINUE re-enters");
        for f in [
            Fault::SafetyChainOpen,
            Fault::EmergencyStop,
            Fault::FollowingError,
            Fault::DriveFault,
            Fault::SyncLost,
            Fault::LubeTimeout,
            Fault::PositionLost,
        ] {
            assert!(continues(f), "{f:?}: {}", f.how_to_continue());
        }
        // After a restart of hob-rt nothing is left to continue.
        assert!(!continues(Fault::FeedbackLost) && !continues(Fault::IoLost));
        // A table that lost its position refuses CONTINUE; an axis that lost its reference
        // needs HOME first.
        let p = Fault::PositionLost.how_to_continue();
        assert!(p.contains("CONTINUE is refused") && p.contains("NEW BLANK") && p.contains("HOME"));
        assert!(Fault::HomingFailed.how_to_continue().contains("HOME again"));
    }
}
