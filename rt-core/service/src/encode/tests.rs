//! Every control-core value encodes to a code whose `hob_ipc::codec` text is what the
//! codec printed for it when it still took the control core's types (the operator's words
//! do not change), and decodes back where the loop has a decoder.

use super::*;
use codec::{alarm_text, event_text};
use hob_canopen::bus::BusError;
use hob_canopen::emcy::{Emcy, emcy_text};
use hob_control::State;
use hob_control::egb::Coupling;
use hob_control::fault::{End, HomingFailure, Refusal};
use hob_ipc::{AlarmCode, codec};
use hob_master::BusEvent;

/// The texts as the old codec (`hob_ipc::codec` on the control core's types) printed them.
mod old {
    use hob_control::Command;
    use hob_control::fault::{Axis, End, Fault, HomingFailure, Refusal};

    fn unit(a: Axis) -> &'static str {
        if a == Axis::B { "deg" } else { "mm" }
    }

    pub fn fault_text(f: Fault) -> String {
        match f {
            Fault::SafetyChainOpen => "safety chain open".into(),
            Fault::EmergencyStop => "emergency stop pressed".into(),
            Fault::HardwareLimit { axis, end } => format!(
                "hardware limit {} {}",
                axis.name(),
                if end == End::Min { "min" } else { "max" }
            ),
            Fault::SoftLimit { axis, position } => {
                format!("soft limit {}: {position:.3} {}", axis.name(), unit(axis))
            }
            Fault::FollowingError { axis, error } => {
                format!("following error {}: {error:.4} {}", axis.name(), unit(axis))
            }
            Fault::DriveFault { axis } => format!("drive fault {}", axis.name()),
            Fault::VfdFault => "spindle VFD fault".into(),
            Fault::SyncLost { error_arcsec } => {
                format!("synchronisation lost: {error_arcsec:.1} arcsec outside the coarse window")
            }
            Fault::SpindleSpeed { set_rpm, actual_rpm } => {
                format!("spindle did not reach {set_rpm:.1} rpm (is {actual_rpm:.1} rpm)")
            }
            Fault::LubeTimeout => "lubrication pressure not confirmed in time".into(),
            Fault::ClampTimeout => "X clamp did not report in time".into(),
            Fault::FeedbackLost { axis } => format!("feedback of drive {} lost (bus)", axis.name()),
            Fault::IoLost => "I/O coupler lost (bus)".into(),
            Fault::DriveNotEnabled { axis } => format!("drive {} not in \"operation enabled\"", axis.name()),
            // Added with referencing (issue 14).
            Fault::HomingFailed { axis, why } => format!(
                "referencing {} failed: {}",
                axis.name(),
                match why {
                    HomingFailure::ModeNotConfirmed => "the drive did not confirm the mode of operation (0x6061)",
                    HomingFailure::NotStarted => "the drive did not start homing",
                    HomingFailure::DriveError => {
                        "the drive reported a homing error (home switch not found before a limit?)"
                    }
                    HomingFailure::Timeout => "homing took longer than homing.timeout_s",
                }
            ),
            Fault::PositionLost { axis: Axis::B } => {
                "drive B lost its position (reboot or encoder): the tooth phase of the part on the table is gone"
                    .into()
            }
            Fault::PositionLost { axis } => format!(
                "drive {} lost its position (reboot or encoder): reference it again (HOME)",
                axis.name()
            ),
        }
    }

    pub fn refusal_text(r: Refusal) -> &'static str {
        match r {
            Refusal::NoProgram => "no program loaded: load one first",
            Refusal::CycleRunning => "a cycle is running: stop it first",
            Refusal::Faulted => "the machine is in fault: remove the cause, then reset",
            Refusal::NotReady => "power-up not finished (lubrication, safety chain, drives)",
            Refusal::NothingToDo => "nothing to do in this state",
            Refusal::OutsideSoftLimits => "the move would leave the soft limits",
            Refusal::NoSingleDepth => "the program has no single-mode depth",
            Refusal::BadValue => "the value is not a finite number in range",
            Refusal::SafetyChainOpen => "the safety chain is open: close it with the reset button first",
            Refusal::DrivesNotEnabled => "not every drive reports \"operation enabled\" yet",
            Refusal::NotReferenced => {
                "X and Y are not referenced: only referencing (HOME) and slow jogs until they are"
            }
            Refusal::TablePositionLost => {
                "the table lost its position since the tooth phase was recorded: continuing would cut a new set of gaps into this part (touch both flanks of a cut gap to align to it)"
            }
            Refusal::JogActive => "a jog is running: release it (or stop) first",
            Refusal::SpindleTurning => {
                "the spindle turns: a flank touch needs the hob standing still (spindle off)"
            }
            Refusal::FlanksCrossed => {
                "this flank lies on the wrong side of the other one: the table is turned positive to touch one flank of the gap and negative to touch the other"
            }
            Refusal::ProgramChanged => {
                "the program was changed since it was loaded: load it again to cut the changed program"
            }
            Refusal::OffsetNeedsConfirmation => {
                "this touch-off does not fit what the machine knows (the loaded blank, the previous offset, where the hob stands): check the gauge's value and the hob's position, and confirm the new offset only if both are right; nothing was changed"
            }
            Refusal::DelayNotCommissioned => {
                "the table drive's delay was not measured on this machine's table drive: run hob commission delay, then restart hob-rt (a wrong delay faults the cut at engagement)"
            }
            Refusal::NoCompensation => {
                "no pitch compensation was loaded for this machine's worm set: measure a gear, run hob compensate, then restart hob-rt"
            }
        }
    }

    pub fn command_name(c: Command) -> &'static str {
        match c {
            Command::Start { .. } => "start",
            Command::FeedHold => "hold",
            Command::Resume => "resume",
            Command::Stop => "stop",
            Command::Reset => "reset",
            Command::Jog { .. } => "jog",
            Command::SpindleOn { .. } => "spindle on",
            Command::SpindleOff => "spindle off",
            Command::NewBlank => "new blank",
            Command::Home { .. } => "home",
            Command::JogContinuous { .. } => "jog continuous",
            Command::JogRelease => "jog release",
            Command::ExciteTable { .. } => "excite table",
            Command::PitchCompensation { .. } => "pitch compensation",
            Command::FeedOverride { .. } => "feed override",
            Command::SpindleOverride { .. } => "spindle override",
            Command::TouchOff { .. } => "touch-off",
            Command::Continue => "continue",
            Command::SpindleHold { .. } => "spindle hold",
            Command::TouchFlank { .. } => "touch flank",
        }
    }
}

/// The old table of refusals, code = index + 1.
const OLD_REFUSALS: [Refusal; 10] = [
    Refusal::NoProgram,
    Refusal::CycleRunning,
    Refusal::Faulted,
    Refusal::NotReady,
    Refusal::NothingToDo,
    Refusal::OutsideSoftLimits,
    Refusal::NoSingleDepth,
    Refusal::BadValue,
    Refusal::SafetyChainOpen,
    Refusal::DrivesNotEnabled,
];

const AXES: [Axis; 3] = [Axis::B, Axis::X, Axis::Y];

/// Every fault variant, with every axis and end.
fn every_fault() -> Vec<Fault> {
    let mut v = vec![
        Fault::SafetyChainOpen,
        Fault::EmergencyStop,
        Fault::VfdFault,
        Fault::SyncLost { error_arcsec: 61.25 },
        Fault::SpindleSpeed {
            set_rpm: 119.0,
            actual_rpm: 80.04,
        },
        Fault::LubeTimeout,
        Fault::ClampTimeout,
        Fault::IoLost,
    ];
    for axis in AXES {
        for end in [End::Min, End::Max] {
            v.push(Fault::HardwareLimit { axis, end });
        }
        v.push(Fault::SoftLimit {
            axis,
            position: -12.3456,
        });
        v.push(Fault::FollowingError { axis, error: 0.25 });
        v.push(Fault::DriveFault { axis });
        v.push(Fault::FeedbackLost { axis });
        v.push(Fault::DriveNotEnabled { axis });
        v.push(Fault::PositionLost { axis });
    }
    for axis in [Axis::X, Axis::Y] {
        for why in [
            HomingFailure::ModeNotConfirmed,
            HomingFailure::NotStarted,
            HomingFailure::DriveError,
            HomingFailure::Timeout,
        ] {
            v.push(Fault::HomingFailed { axis, why });
        }
    }
    v
}

fn every_command() -> Vec<Command> {
    let mut v = vec![
        Command::Start { single: false },
        Command::Start { single: true },
        Command::FeedHold,
        Command::Resume,
        Command::Stop,
        Command::Reset,
        Command::SpindleOn { rpm: 100.0 },
        Command::SpindleOff,
        Command::NewBlank,
        Command::Home { axes: HomeAxes::X },
        Command::Home { axes: HomeAxes::Y },
        Command::Home { axes: HomeAxes::Both },
        Command::JogRelease,
        Command::ExciteTable {
            frequency_hz: 42.5,
            creep: Direction::Negative,
        },
        Command::PitchCompensation { on: true },
        Command::PitchCompensation { on: false },
        Command::FeedOverride { percent: 87.5 },
        Command::SpindleOverride { percent: 110.0 },
        Command::Continue,
        Command::SpindleHold { rpm: 42.5 },
        Command::TouchFlank {
            turned: Direction::Negative,
        },
        Command::TouchFlank {
            turned: Direction::Positive,
        },
    ];
    for axis in AXES {
        v.push(Command::Jog {
            axis,
            distance: -12.5,
        });
        for confirmed in [false, true] {
            v.push(Command::TouchOff {
                axis,
                value_mm: 101.5,
                confirmed,
            });
        }
        for direction in [Direction::Positive, Direction::Negative] {
            v.push(Command::JogContinuous {
                axis,
                direction,
                speed_per_min: 300.0,
            });
        }
    }
    v
}

#[test]
fn every_refusal_has_its_old_code_and_text() {
    for (i, r) in OLD_REFUSALS.into_iter().enumerate() {
        assert_eq!(r.code(), i as u32 + 1, "{r:?}");
        assert_eq!(r.text(), old::refusal_text(r));
        assert_eq!(codec::refusal_text(r.code()), old::refusal_text(r));
        assert_eq!(Refusal::from_code(r.code()), Some(r));
    }
    for c in Refusal::ALL {
        assert_eq!(Refusal::from_code(c.code()), Some(c));
        assert_eq!(codec::refusal_text(c.code()), old::refusal_text(c));
    }
}

#[test]
fn every_fault_has_its_old_text_and_round_trips() {
    let faults = every_fault();
    assert_eq!(faults.len(), 8 + 3 * 8 + 2 * 4);
    let mut codes = std::collections::BTreeSet::new();
    for f in faults {
        let a = Fault::alarm(Some(f));
        codes.insert(a.code);
        assert_eq!(alarm_text(&a), old::fault_text(f), "{f:?}");
        assert_eq!(Fault::of_alarm(&a), Some(f));
    }
    // Every fault code of the contract is used.
    assert_eq!(codes.len(), codec::Fault::ALL.len());
    assert_eq!(Fault::alarm(None), AlarmCode::default());
    assert_eq!(alarm_text(&Fault::alarm(None)), "");
    assert_eq!(Fault::of_alarm(&Fault::alarm(None)), None);
}

#[test]
fn the_old_alarm_numbers_are_kept() {
    let a = Fault::alarm(Some(Fault::HardwareLimit {
        axis: Axis::Y,
        end: End::Min,
    }));
    assert_eq!((a.code, a.axis, a.end), (3, 3, 1));
    let a = Fault::alarm(Some(Fault::SpindleSpeed {
        set_rpm: 119.0,
        actual_rpm: 80.0,
    }));
    assert_eq!((a.code, a.value_a, a.value_b), (9, 119.0, 80.0));
    assert_eq!(
        Fault::alarm(Some(Fault::DriveNotEnabled { axis: Axis::B })).code,
        14
    );
    assert_eq!(Fault::alarm(Some(Fault::FeedbackLost { axis: Axis::X })).axis, 2);
}

#[test]
fn every_coupling_has_its_old_code_and_name() {
    let old = [
        (Coupling::Disengaged, "disengaged"),
        (Coupling::Engaging, "engaging"),
        (Coupling::Phasing, "phasing"),
        (Coupling::Synchronised, "synchronised"),
        (Coupling::Disengaging, "disengaging"),
    ];
    for (i, (c, name)) in old.into_iter().enumerate() {
        assert_eq!(c.code(), i as u32);
        assert_eq!(codec::coupling_name(c.code()), name);
    }
}

#[test]
fn every_command_round_trips_with_its_old_name() {
    for c in every_command() {
        let a = command_code(c);
        assert_eq!(codec::command_name(a.code), old::command_name(c), "{c:?}");
        assert_eq!(command_from_code(&a), Some(c));
        // Through a request and back, as the command thread sees it.
        let mut r = hob_ipc::CommandRequest::new(0);
        a.to_request(&mut r);
        assert_eq!(Args::from_request(&r), a);
    }
    let args = |code, single, axis, direction, value| Args {
        code,
        single,
        axis,
        direction,
        confirm: 0,
        value,
    };
    assert_eq!(
        command_code(Command::Start { single: true }),
        args(2, 1, 0, 0, 0.0)
    );
    assert_eq!(
        command_code(Command::Jog {
            axis: Axis::Y,
            distance: 1.5
        }),
        args(7, 0, 3, 0, 1.5)
    );
    assert_eq!(
        command_code(Command::JogContinuous {
            axis: Axis::X,
            direction: Direction::Negative,
            speed_per_min: 250.0
        }),
        args(12, 0, 2, 2, 250.0)
    );
    assert_eq!(
        command_code(Command::Home { axes: HomeAxes::Both }),
        args(11, 0, 0, 0, 0.0)
    );
    assert_eq!(command_from_code(&args(command::JOG, 0, 9, 0, 1.0)), None);
    assert_eq!(
        command_from_code(&args(command::LOAD_PROGRAM, 0, 0, 0, 0.0)),
        None
    );
    assert_eq!(command_from_code(&args(99, 0, 0, 0, 0.0)), None);
    // A continuous jog needs a direction; homing the table is not a command.
    assert_eq!(
        command_from_code(&args(command::JOG_CONTINUOUS, 0, 2, 0, 100.0)),
        None
    );
    assert_eq!(command_from_code(&args(command::HOME, 0, 1, 0, 0.0)), None);
    // A touch-off's confirmation travels in the byte that was padding; any other value
    // than 0 confirms.
    let touch = Command::TouchOff {
        axis: Axis::X,
        value_mm: 194.94,
        confirmed: true,
    };
    assert_eq!(
        command_code(touch),
        Args {
            confirm: 1,
            ..args(16, 0, 2, 0, 194.94)
        }
    );
    assert_eq!(
        command_from_code(&Args {
            confirm: 7,
            ..args(16, 0, 2, 0, 194.94)
        }),
        Some(touch)
    );
    let e = event_sample(
        0,
        &Event {
            cycle: 0,
            kind: EventKind::Accepted(touch),
        },
    );
    assert_eq!(
        (e.a, e.b, e.value),
        (command::TOUCH_OFF, 1 << 24 | 2 << 8, 194.94)
    );
}

#[test]
fn every_event_has_its_old_text() {
    let mut cases: Vec<(EventKind, String)> = vec![
        (EventKind::FaultCleared, "alarm cleared".into()),
        (EventKind::PassStarted { pass: 3 }, "pass 3 started".into()),
        (
            EventKind::PhaseRecorded { phase_deg: 12.34567 },
            "tooth phase recorded: 12.3457 deg".into(),
        ),
        (EventKind::ProgramLoaded, "program loaded".into()),
        (EventKind::CycleDone, "cycle done".into()),
        (
            EventKind::FlankTouched {
                turned: Direction::Negative,
                phase_deg: -3.25,
            },
            "flank touched, the table turned negative: tooth phase -3.2500 deg; the part's phase is set when both flanks are touched".into(),
        ),
        (
            EventKind::FlankTouched {
                turned: Direction::Positive,
                phase_deg: 1.5,
            },
            "flank touched, the table turned positive: tooth phase 1.5000 deg; the part's phase is set when both flanks are touched".into(),
        ),
        (
            EventKind::PhaseAligned {
                phase_deg: 12.5,
                play_deg: 1.234567,
            },
            "aligned to the cut gaps: tooth phase 12.5000 deg, 1.2346 deg of play between the flanks".into(),
        ),
    ];
    for (from, to) in State::ALL.into_iter().zip(State::ALL.into_iter().rev()) {
        cases.push((
            EventKind::StateChanged { from, to },
            format!("state {} -> {}", from.name(), to.name()),
        ));
    }
    for f in every_fault() {
        cases.push((EventKind::Fault(f), format!("ALARM {}", old::fault_text(f))));
    }
    for c in every_command() {
        cases.push((
            EventKind::Accepted(c),
            format!("accepted: {}", old::command_name(c)),
        ));
        for r in OLD_REFUSALS {
            cases.push((
                EventKind::Refused {
                    command: c,
                    reason: r,
                },
                format!("refused: {}: {}", old::command_name(c), old::refusal_text(r)),
            ));
        }
    }
    for (kind, text) in cases {
        let e = event_sample(42, &Event { cycle: 7, kind });
        assert_eq!((e.seq, e.cycle, e.text_len), (42, 7, 0), "{kind:?}");
        assert_eq!(event_text(&e), text, "{kind:?}");
    }
    // Accepted carries its arguments.
    let e = event_sample(
        0,
        &Event {
            cycle: 0,
            kind: EventKind::Accepted(Command::Jog {
                axis: Axis::X,
                distance: 2.0,
            }),
        },
    );
    assert_eq!((e.a, e.b, e.value), (command::JOG, 2 << 8, 2.0));
}

#[test]
fn every_bus_event_is_worded_from_its_numbers() {
    let cases = [
        (
            BusEvent::Emcy(Emcy {
                node: 3,
                code: 0x8611,
                register: 0,
                vendor: [0; 5],
            }),
            format!("EMCY node 3 0x8611: {}", emcy_text(0x8611)),
        ),
        (
            BusEvent::HeartbeatLost { node: 5 },
            "heartbeat of node 5 lost".into(),
        ),
        (
            BusEvent::TpdoMissing {
                node: 2,
                missed: 37,
                longest_in_a_row: 4,
            },
            "TPDO of node 2 late or lost in 37 cycles since its last report, at most 4 in a row".into(),
        ),
        (
            BusEvent::TpdoMissing {
                node: 127,
                missed: 1,
                longest_in_a_row: 1,
            },
            "TPDO of node 127 late or lost in 1 cycle since its last report, at most 1 in a row".into(),
        ),
        (
            BusEvent::SendFailed(BusError::Full),
            "CAN send failed: transmit queue full".into(),
        ),
        (
            BusEvent::SendFailed(BusError::Down),
            "CAN send failed: interface down".into(),
        ),
        (
            BusEvent::SendFailed(BusError::Os(105)),
            "CAN send failed: OS error 105".into(),
        ),
    ];
    for (be, text) in cases {
        let e = bus_event_sample(7, &be);
        assert_eq!((e.kind, e.cycle, e.text_len), (event_kind::BUS, 7, 0), "{be:?}");
        assert_eq!(event_text(&e), text);
    }
}

#[test]
fn the_wires_fault_reaction_is_the_control_cores() {
    // hob_ipc::codec words the reaction from the wire (it links no control core): its
    // reading of "X can move" and "the table can follow" must be the control core's.
    for f in every_fault() {
        let a = Fault::alarm(Some(f));
        let c = codec::Fault::of(&a).expect("a fault on the wire");
        assert_eq!(c.x_can_move(&a), f.x_can_move(), "{f:?}: X can move");
        assert_eq!(
            c.table_can_follow(&a),
            f.table_can_follow(),
            "{f:?}: the table can follow"
        );
    }
}
