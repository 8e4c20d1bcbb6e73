//! `hob-rt`'s command thread: the server of the `command` service. It does the work that
//! may allocate (parsing and checking a program file against this machine's
//! configuration), then hands the typed command to the loop through a bounded mailbox and
//! answers with the loop's verdict. The loop checks every command against the machine
//! state; a refusal changes nothing.
//!
//! The mailboxes are std's bounded channels used with `try_send`/`try_recv` only on the
//! loop's side, and this thread polls instead of parking: no thread ever waits on them,
//! so the loop's calls never lock nor wake anybody (no syscall).

use crate::encode;
use hob_control::Command;
use hob_control::fault::Refusal;
use hob_control::program::CycleProgram;
use hob_control::setup_math::TouchOff;
use hob_ipc::codec;
use hob_ipc::{CommandRequest, CommandResponse, command};
use hob_setup::config::Problems;
use hob_setup::config::machine::MachineConfig;
use hob_setup::job::Program;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TryRecvError};
use std::time::{Duration, Instant};

/// What the command thread hands to the loop. Not boxed: the loop would free the box,
/// a heap operation inside the cycle; the channel's slot holds it inline instead.
#[derive(Debug, Clone, Copy)]
#[allow(clippy::large_enum_variant)]
pub enum Mail {
    /// A program, and what names it (the hash of the text it was built from, its file
    /// and part).
    Load(CycleProgram, LoadedAs),
    Command(Command),
    /// A command for the program of this [`hob_ipc::program_hash`] only (START, CONTINUE
    /// from a frontend that knows the program's text as it is now): refused
    /// (`program-changed`) when the loaded program is another.
    CommandFor(Command, u64),
    /// Write the flight recorder's last seconds (`hob record`): not the control core's.
    Record,
}

/// What names a program handed to the loop: the [`hob_ipc::program_hash`] of its text
/// (the state sample's `program_hash` while it is loaded) and the text of its
/// [`hob_ipc::event_kind::PROGRAM_LOADED`] event ([`hob_ipc::codec::program_loaded_text`]:
/// its file name and part), in a fixed buffer: the loop copies it, never allocates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoadedAs {
    pub hash: u64,
    text: [u8; hob_ipc::EVENT_TEXT_BYTES],
    text_len: u32,
}

impl LoadedAs {
    /// A program file's text `text` sent under `name`, its workpiece named `part`.
    pub fn new(name: &str, part: Option<&str>, text: &str) -> Self {
        let mut t = [0; hob_ipc::EVENT_TEXT_BYTES];
        let text_len = hob_ipc::write_text(&mut t, &codec::program_loaded_text(name, part));
        Self {
            hash: hob_ipc::program_hash(text),
            text: t,
            text_len,
        }
    }

    /// Names the program in its PROGRAM_LOADED event (any other event is left as it is).
    pub fn name_event(&self, e: &mut hob_ipc::EventSample) {
        if e.kind == hob_ipc::event_kind::PROGRAM_LOADED {
            e.text = self.text;
            e.text_len = self.text_len;
        }
    }
}

/// The loop's verdict: accepted with the work offsets after the command, or refused; for a
/// touch-off the figures the loop judged it by (`Controller::last_touch_off`): the offset
/// it applied, or the one it asks the operator to confirm. Copied, never boxed: the loop
/// sends it from the cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Verdict {
    pub result: Result<hob_control::Offsets, Refusal>,
    pub touch_off: Option<TouchOff>,
}

/// How long a request may wait for the loop (it takes one per cycle).
const LOOP_ANSWER: Duration = Duration::from_millis(500);

/// Checks a program file's text on this machine: the cycle program, or the problems
/// (file, line, key, limit) as text.
pub fn build_program(name: &str, text: &str, machine: &MachineConfig) -> Result<CycleProgram, String> {
    checked_program(name, text, machine).map(|(c, _)| c)
}

/// [`build_program`], with the program as parsed (its workpiece's name among it).
fn checked_program(
    name: &str,
    text: &str,
    machine: &MachineConfig,
) -> Result<(CycleProgram, Program), String> {
    let path = Path::new(name);
    let program = Program::parse(path, text).map_err(|e| e.to_string())?;
    let mut problems = Problems::new();
    match CycleProgram::build(&program, machine, &mut problems) {
        Some(c) => Ok((c, program)),
        None => Err(problems
            .into_result(path, text)
            .err()
            .map_or_else(|| "refused".into(), |e| e.to_string())),
    }
}

/// Turns a request into mail for the loop, or the reason it is malformed.
pub fn to_mail(req: &CommandRequest, machine: &MachineConfig) -> Result<Mail, String> {
    if req.command == command::LOAD_PROGRAM {
        let (text, name) = (req.text(), req.name());
        return checked_program(&name, &text, machine).map(|(c, p)| {
            let part = p.workpiece.name.as_deref();
            Mail::Load(c, LoadedAs::new(&name, part, &text))
        });
    }
    if req.command == command::FLIGHT_RECORD {
        return Ok(Mail::Record);
    }
    let for_program = matches!(req.command, command::START | command::CONTINUE) && req.program_hash != 0;
    encode::command_from_code(&encode::Args::from_request(req))
        .map(|c| {
            if for_program {
                Mail::CommandFor(c, req.program_hash)
            } else {
                Mail::Command(c)
            }
        })
        .ok_or_else(|| {
            format!(
                "unknown command {} (axis code {}, direction code {})",
                req.command, req.axis, req.direction
            )
        })
}

/// The loop's side of the mailboxes.
#[derive(Debug)]
pub struct LoopMailbox {
    pub requests: Receiver<Mail>,
    pub verdicts: SyncSender<Verdict>,
}

/// The command thread's side.
#[derive(Debug)]
pub struct ThreadMailbox {
    requests: SyncSender<Mail>,
    verdicts: Receiver<Verdict>,
}

pub fn mailboxes() -> (ThreadMailbox, LoopMailbox) {
    let (rq_tx, rq_rx) = std::sync::mpsc::sync_channel(1);
    let (v_tx, v_rx) = std::sync::mpsc::sync_channel(1);
    (
        ThreadMailbox {
            requests: rq_tx,
            verdicts: v_rx,
        },
        LoopMailbox {
            requests: rq_rx,
            verdicts: v_tx,
        },
    )
}

impl ThreadMailbox {
    /// Hands `mail` to the loop and polls for its verdict.
    pub fn ask(&self, mail: Mail) -> Result<Verdict, String> {
        // A verdict left over from a request that timed out.
        while self.verdicts.try_recv().is_ok() {}
        self.requests
            .try_send(mail)
            .map_err(|_| "the loop is not taking commands".to_string())?;
        let end = Instant::now() + LOOP_ANSWER;
        loop {
            match self.verdicts.try_recv() {
                Ok(v) => return Ok(v),
                Err(TryRecvError::Disconnected) => return Err("the loop has stopped".into()),
                Err(TryRecvError::Empty) if Instant::now() >= end => {
                    return Err("the loop did not answer in time".into());
                }
                Err(TryRecvError::Empty) => std::thread::sleep(Duration::from_micros(500)),
            }
        }
    }
}

/// A touch-off's figures as the operator reads them: the offset before and after, and the
/// change (the loop's numbers: the one a confirmation applies is the one shown).
pub fn touch_off_figures(t: &TouchOff) -> String {
    format!(
        "{} offset {:+.4} mm -> {:+.4} mm (change {:+.4} mm)",
        t.axis.name(),
        t.old_offset_mm,
        t.new_offset_mm,
        t.change_mm()
    )
}

/// Why the loop asks before applying a touch-off, one clause per check that failed.
pub fn touch_off_doubts(t: &TouchOff) -> String {
    let d = &t.doubts;
    let mut why = Vec::new();
    if let Some(off) = d.gauge_less_blank_mm {
        why.push(format!(
            "the gauge, {:.3} mm, is {:.3} mm {} than the loaded blank's outside diameter, {:.3} mm",
            t.gauge_mm,
            off.abs(),
            if off > 0.0 { "larger" } else { "smaller" },
            t.gauge_mm - off
        ));
    }
    if let Some(change) = d.change_mm {
        why.push(format!(
            "the offset would move by {change:+.4} mm, more than the {:.3} mm a touch-off may move it unasked",
            t.confirm_mm
        ));
    }
    if let Some(reach) = d.into_blank_mm {
        why.push(format!(
            "with it the hob would stand {reach:.3} mm inside the loaded blank (below its root diameter or under its top face) where the axes are now"
        ));
    }
    why.join("; ")
}

/// Keeps the offsets of an accepted touch-off in the machine state file (atomically: a
/// crash or a power loss while writing leaves the previous file whole). Returns the text
/// for the operator: the offset's change (`touch`, the loop's figures) and what was saved.
pub fn save_offsets(
    state_file: &Path,
    offsets: hob_control::Offsets,
    cmd: Command,
    touch: Option<TouchOff>,
) -> String {
    use hob_store::machine_state::{Loaded, MachineState, load};
    let previous = match load(state_file) {
        Ok(Loaded::Calibrated(s)) => Some(s),
        _ => None,
    };
    let (mut diameter, mut height) = previous
        .as_ref()
        .map_or((None, None), |s| (s.gauge_diameter_mm, s.gauge_height_mm));
    let axis = match cmd {
        Command::TouchOff { axis, value_mm, .. } => {
            if axis == hob_control::fault::Axis::X {
                diameter = Some(value_mm);
            } else {
                height = Some(value_mm);
            }
            axis.name()
        }
        _ => "?",
    };
    let change = touch.map_or_else(String::new, |t| format!(" {};", touch_off_figures(&t)));
    let state = MachineState::new(offsets.x_mm, offsets.y_mm, diameter, height);
    match state.save(state_file) {
        Ok(()) => format!(
            "touch-off {axis}: accepted;{change} offsets X {:+.4} mm, Y {:+.4} mm saved in {}",
            offsets.x_mm,
            offsets.y_mm,
            state_file.display()
        ),
        Err(e) => format!(
            "touch-off {axis}: accepted by the loop;{change} offsets X {:+.4} mm, Y {:+.4} mm, but NOT SAVED: {e}; touch off again once the state file can be written",
            offsets.x_mm, offsets.y_mm
        ),
    }
}

/// The text of a refusal: the loop's words, and for a touch-off it asks to confirm, on
/// lines of their own, the offset it would set and why it asks.
pub fn refusal_text(what: &str, r: Refusal, touch: Option<TouchOff>) -> String {
    match touch {
        Some(t) if r == Refusal::OffsetNeedsConfirmation => format!(
            "{what} refused: {}.\nConfirmed, it sets the {}.\nWhy: {}.",
            r.text(),
            touch_off_figures(&t),
            touch_off_doubts(&t)
        ),
        _ => format!("{what} refused: {}", r.text()),
    }
}

/// The answer to one request.
pub fn answer(
    req: &CommandRequest,
    machine: &MachineConfig,
    nodes_text: &str,
    state_file: &Path,
    flight_dir: &Path,
    mailbox: &ThreadMailbox,
) -> CommandResponse {
    let what = codec::command_name(req.command);
    // What the nodes said at boot: this thread knows it, the loop has nothing to decide.
    if req.command == command::NODES {
        return CommandResponse::new(true, 0, nodes_text);
    }
    let mail = match to_mail(req, machine) {
        Ok(m) => m,
        Err(text) => return CommandResponse::new(false, 0, &format!("{what} refused: {text}")),
    };
    match mailbox.ask(mail) {
        Ok(Verdict {
            result: Ok(offsets),
            touch_off,
        }) => {
            let text = match mail {
                Mail::Load(p, _) => format!("loaded {} ({} passes)", req.name(), p.passes().len()),
                Mail::Command(c @ Command::TouchOff { .. }) => {
                    save_offsets(state_file, offsets, c, touch_off)
                }
                Mail::Command(_) | Mail::CommandFor(..) => format!("{what}: accepted"),
                Mail::Record => format!(
                    "{what}: the flight recorder's last seconds go to {} (hob replay FILE)",
                    flight_dir.display()
                ),
            };
            CommandResponse::new(true, 0, &text)
        }
        Ok(Verdict {
            result: Err(r),
            touch_off,
        }) => CommandResponse::new(false, r.code(), &refusal_text(what, r, touch_off)),
        Err(text) => CommandResponse::new(false, 0, &format!("{what} not done: {text}")),
    }
}

/// Serves the `command` service until `stop`; `ready` is called once the server exists.
pub fn serve(
    machine: &MachineConfig,
    nodes_text: &str,
    state_file: &Path,
    flight_dir: &Path,
    mailbox: &ThreadMailbox,
    stop: &AtomicBool,
    ready: impl FnOnce(),
) -> Result<(), hob_ipc::IpcError> {
    let node = hob_ipc::node("hob-rt-commands")?;
    let server = hob_ipc::command_server(&node)?;
    ready();
    while !stop.load(Ordering::Relaxed) {
        match server.receive() {
            Ok(Some(active)) => {
                let response = answer(
                    active.payload(),
                    machine,
                    nodes_text,
                    state_file,
                    flight_dir,
                    mailbox,
                );
                let _ = active.send_copy(response);
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(2)),
            Err(e) => return Err(hob_ipc::IpcError(format!("command server: {e:?}"))),
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use hob_setup::config::machine::shipped_for_tests;

    #[test]
    fn a_program_that_fails_its_check_is_refused_with_the_key() {
        let m = shipped_for_tests();
        let text = std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/programs/spur-z17-m5.toml"),
        )
        .unwrap();
        assert!(build_program("spur.toml", &text, &m).is_ok());
        let bad = text.replacen("teeth = 17", "teeth = 2", 1);
        assert_ne!(bad, text, "the sample program changed: adapt the test");
        let e = build_program("spur.toml", &bad, &m).unwrap_err();
        assert!(e.contains("teeth"), "{e}");
        let e = build_program("x.toml", "[nonsense]\n", &m).unwrap_err();
        assert!(e.contains("x.toml"), "{e}");
    }

    #[test]
    fn the_first_touch_off_of_a_set_up_is_saved_and_the_second_keeps_it() {
        use hob_control::fault::Axis;
        use hob_store::machine_state::{Loaded, load};
        let dir = std::env::temp_dir().join(format!("hob-service-touch-off-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("machine-state.toml");
        let x = Command::TouchOff {
            axis: Axis::X,
            value_mm: 100.0,
            confirmed: false,
        };
        let text = save_offsets(&file, hob_control::Offsets { x_mm: 0.4, y_mm: 0.0 }, x, None);
        assert!(text.contains("saved in"), "{text}");
        let y = Command::TouchOff {
            axis: Axis::Y,
            value_mm: 0.0,
            confirmed: true,
        };
        let text = save_offsets(
            &file,
            hob_control::Offsets {
                x_mm: 0.4,
                y_mm: -1.5,
            },
            y,
            None,
        );
        assert!(text.contains("saved in"), "{text}");
        let Ok(Loaded::Calibrated(s)) = load(&file) else {
            panic!("{}: not loaded", file.display())
        };
        assert_eq!(
            (
                s.x_offset_mm,
                s.y_offset_mm,
                s.gauge_diameter_mm,
                s.gauge_height_mm
            ),
            (0.4, -1.5, Some(100.0), Some(0.0))
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// The typo as the loop judges it: the blank 95 mm, the hob 80 mm on it at X
    /// 87.475 mm (machine), the previous offset -0.005 mm, 194.94 typed for 94.94.
    fn typo() -> TouchOff {
        use hob_control::fault::Axis;
        use hob_control::setup_math::{Blank, TouchOffInput, check_touch_off};
        check_touch_off(&TouchOffInput {
            axis: Axis::X,
            gauge_mm: 194.94,
            machine_mm: 87.475,
            old_offset_mm: -0.005,
            other_work_mm: Some(70.0),
            tool_tip_diameter_mm: 80.0,
            blank: Blank {
                outside_diameter_mm: 95.0,
                total_depth_mm: 11.25,
                face_bottom_mm: 50.0,
                face_top_mm: 90.0,
            },
            confirm_mm: 0.3,
        })
        .unwrap()
    }

    #[test]
    fn a_touch_off_to_confirm_is_answered_with_the_offset_it_would_set_and_why() {
        let t = typo();
        let text = refusal_text("touch-off", Refusal::OffsetNeedsConfirmation, Some(t));
        for needle in [
            Refusal::OffsetNeedsConfirmation.text(),
            "\nConfirmed, it sets the X offset -0.0050 mm -> +49.9950 mm (change +50.0000 mm).\nWhy: ",
            "the gauge, 194.940 mm, is 99.940 mm larger than the loaded blank's outside diameter, 95.000 mm",
            "more than the 0.300 mm a touch-off may move it unasked",
        ] {
            assert!(text.contains(needle), "{needle:?} not in {text:?}");
        }
        assert!(!text.contains("inside the loaded blank"), "{text}");
        // Other refusals are the loop's words alone.
        assert_eq!(
            refusal_text("touch-off", Refusal::BadValue, Some(t)),
            format!("touch-off refused: {}", Refusal::BadValue.text())
        );
    }

    #[test]
    fn the_answer_carries_the_loops_figures_through_the_mailbox() {
        use hob_control::fault::Axis;
        let m = shipped_for_tests();
        let dir = std::env::temp_dir().join(format!("hob-service-touch-answer-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("machine-state.toml");
        let (thread, lp) = mailboxes();
        let t = typo();
        // The loop: refuses the first, applies the confirmed one (the offset it showed).
        let loop_side = std::thread::spawn(move || {
            let mut seen = Vec::new();
            for result in [
                Err(Refusal::OffsetNeedsConfirmation),
                Ok(hob_control::Offsets {
                    x_mm: t.new_offset_mm,
                    y_mm: 0.0,
                }),
            ] {
                let mail = loop {
                    if let Ok(mail) = lp.requests.try_recv() {
                        break mail;
                    }
                    std::thread::sleep(Duration::from_millis(1));
                };
                seen.push(mail);
                lp.verdicts
                    .try_send(Verdict {
                        result,
                        touch_off: Some(t),
                    })
                    .unwrap();
            }
            seen
        });
        let ask = |confirm| {
            let r = hob_ipc::request::touch_off_value("x", 194.94, confirm).unwrap();
            answer(&r, &m, "", &file, &dir, &thread)
        };
        let refused = ask(false);
        assert_eq!(
            (refused.accepted, refused.refusal),
            (0, Refusal::OffsetNeedsConfirmation.code())
        );
        assert!(refused.text().contains("-> +49.9950 mm"), "{}", refused.text());
        let accepted = ask(true);
        assert_eq!(accepted.accepted, 1, "{}", accepted.text());
        assert!(
            accepted
                .text()
                .contains("touch-off X: accepted; X offset -0.0050 mm -> +49.9950 mm (change +50.0000 mm); offsets X +49.9950 mm"),
            "{}",
            accepted.text()
        );
        let seen = loop_side.join().unwrap();
        let confirmed: Vec<bool> = seen
            .iter()
            .map(|m| match m {
                Mail::Command(Command::TouchOff {
                    axis: Axis::X,
                    confirmed,
                    ..
                }) => *confirmed,
                other => panic!("{other:?}"),
            })
            .collect();
        assert_eq!(confirmed, [false, true]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_loop_that_does_not_answer_is_reported() {
        let (thread, _loop) = mailboxes();
        let e = thread.ask(Mail::Command(Command::Stop)).unwrap_err();
        assert!(e.contains("did not answer"), "{e}");
    }

    #[test]
    fn a_start_for_a_program_is_checked_against_the_loaded_one_and_others_are_not() {
        let m = shipped_for_tests();
        let mut r = hob_ipc::request::start(false);
        assert!(matches!(
            to_mail(&r, &m),
            Ok(Mail::Command(Command::Start { single: false }))
        ));
        r.program_hash = 42;
        assert!(matches!(
            to_mail(&r, &m),
            Ok(Mail::CommandFor(Command::Start { single: false }, 42))
        ));
        let mut c = CommandRequest::new(command::CONTINUE);
        c.program_hash = 7;
        assert!(matches!(
            to_mail(&c, &m),
            Ok(Mail::CommandFor(Command::Continue, 7))
        ));
        // Only START and CONTINUE name a program.
        let mut hold = CommandRequest::new(command::FEED_HOLD);
        hold.program_hash = 7;
        assert!(matches!(to_mail(&hold, &m), Ok(Mail::Command(Command::FeedHold))));
    }

    #[test]
    fn a_loaded_program_is_named_in_its_event_by_its_file_and_part() {
        let m = shipped_for_tests();
        let text = std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/programs/spur-z17-m5.toml"),
        )
        .unwrap();
        let req = CommandRequest::load_program("config/programs/spur-z17-m5.toml", &text).unwrap();
        let Ok(Mail::Load(_, loaded)) = to_mail(&req, &m) else {
            panic!("not loaded")
        };
        assert_eq!(loaded.hash, hob_ipc::program_hash(&text));
        let mut e = hob_ipc::EventSample {
            kind: hob_ipc::event_kind::PROGRAM_LOADED,
            ..hob_ipc::EventSample::default()
        };
        loaded.name_event(&mut e);
        assert_eq!(
            codec::event_text(&e),
            "program loaded: spur-z17-m5.toml; part: Thesis worst case, spur z17 m5, 42CrMo4"
        );
        // Another event keeps its own words.
        let mut other = hob_ipc::EventSample {
            kind: hob_ipc::event_kind::CYCLE_DONE,
            ..hob_ipc::EventSample::default()
        };
        loaded.name_event(&mut other);
        assert_eq!(codec::event_text(&other), "cycle done");
    }

    #[test]
    fn unknown_commands_and_axes_are_malformed() {
        let m = shipped_for_tests();
        let mut r = CommandRequest::new(99);
        assert!(to_mail(&r, &m).is_err());
        r = CommandRequest::new(command::JOG);
        r.axis = 7;
        assert!(to_mail(&r, &m).unwrap_err().contains("axis"));
    }
}
