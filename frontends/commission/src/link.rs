//! What every procedure does with the loop and the machine file alike: reaching `hob-rt`,
//! asking it a command and taking its answer, reading its state stream until an alarm, and
//! the proposed change of the machine file, written only as it was shown.

use crate::Stop;
use hob_ipc::codec;
use hob_ipc::{CommandRequest, Commands, Feed, StateSample};
use hob_store::machine_edit;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// How long a command may wait for the loop's answer.
pub(crate) const ANSWER: Duration = Duration::from_secs(3);
/// A held command (a continuous jog, the spindle's hold) is renewed this often (the machine
/// file's dead-man time is longer).
pub(crate) const RENEWAL: Duration = Duration::from_millis(100);

/// The loop's state stream and its command channel.
pub(crate) type Link = (Box<dyn Feed>, Box<dyn Commands>);

/// The loop's [`Link`], once it has been heard.
pub(crate) fn connect() -> Result<Link, Stop> {
    let me = format!("hob-commission-{}", std::process::id());
    let unreachable = |e: hob_ipc::IpcError| Stop::Failed(format!("hob-rt cannot be reached: {e}"));
    let mut feed = hob_ipc::follow(&me).map_err(unreachable)?;
    let client = hob_ipc::commands(&me).map_err(unreachable)?;
    if feed.wait_state(Duration::from_secs(2)).is_none() {
        return Err(Stop::Failed(format!(
            "no state from hob-rt (instance {}): is it running?",
            hob_ipc::instance()
        )));
    }
    Ok((feed, client))
}

/// Asks `req`; the loop's refusal stops the procedure in its words. `moving` names what
/// the dead-man stops if the loop does not answer ("the table", "the spindle").
pub(crate) fn ask(client: &mut dyn Commands, req: &CommandRequest, moving: &str) -> Result<(), Stop> {
    let answer = client.request(req, ANSWER).map_err(|e| {
        Stop::Failed(format!(
            "hob-rt did not answer: {e}; {moving} stops within the dead-man time"
        ))
    })?;
    if answer.accepted == 0 {
        return Err(Stop::Refused(format!(
            "{}; nothing measured, the machine file unchanged",
            answer.text()
        )));
    }
    Ok(())
}

/// Hands every waiting state sample to `take`; an alarm stops the procedure.
pub(crate) fn drain(feed: &mut dyn Feed, mut take: impl FnMut(&StateSample)) -> Result<(), Stop> {
    while let Some(s) = feed.next_state() {
        if s.alarm.code != 0 {
            return Err(Stop::Failed(format!(
                "stopped: {}; nothing written, the machine file unchanged",
                codec::alarm_text(&s.alarm)
            )));
        }
        take(&s);
    }
    Ok(())
}

/// Jogs `axis` (`"b"`, `"x"`, `"y"`) `direction` (`"+"`, `"-"`) at `speed_per_min` for
/// `seconds`, renewing the loop's continuous jog while `enabled` holds; released in every
/// case, then left [`REST`] to come to rest. Every state sample meanwhile goes to `take`.
/// Stops at the loop's refusal, an alarm or the enable let go.
pub(crate) fn held_jog(
    feed: &mut dyn Feed,
    client: &mut dyn Commands,
    (axis, direction, speed_per_min): (&str, &str, f64),
    seconds: f64,
    enabled: &dyn Fn() -> bool,
    take: &mut dyn FnMut(&StateSample),
) -> Result<(), Stop> {
    let moving = if axis == "b" { "the table" } else { "the axis" };
    let jog = hob_ipc::request::jog_continuous(axis, direction, speed_per_min)
        .map_err(|e| Stop::Refused(e.to_string()))?;
    let end = Instant::now() + Duration::from_secs_f64(seconds);
    let result = loop {
        if !enabled() {
            break Err(Stop::Failed(format!(
                "the enable was let go: {moving} stopped; nothing written, the machine file unchanged"
            )));
        }
        if let Err(e) = ask(client, &jog, moving) {
            break Err(e);
        }
        std::thread::sleep(RENEWAL);
        if let Err(e) = drain(feed, &mut *take) {
            break Err(e);
        }
        if Instant::now() >= end {
            break Ok(());
        }
    };
    // Released in every case; after a refusal or a fault its answer adds nothing.
    if let Err(e) = result {
        let _ = client.request(&hob_ipc::request::jog_release(), ANSWER);
        return Err(e);
    }
    ask(client, &hob_ipc::request::jog_release(), moving)?;
    // At rest before what follows: the drive's lag runs out.
    let rest = Instant::now() + REST;
    while Instant::now() < rest {
        std::thread::sleep(Duration::from_millis(20));
        drain(feed, &mut *take)?;
    }
    Ok(())
}

/// The machine file's text and its configuration, checked as hob-rt loads it; refused (before
/// anything moves) when it cannot be read or does not hold.
pub(crate) fn read_machine(file: &Path) -> Result<(String, hob_setup::config::machine::MachineConfig), Stop> {
    let text = hob_store::files::read_text(file).map_err(|e| Stop::Refused(e.to_string()))?;
    let machine = machine_edit::check(file, &text).map_err(|e| Stop::Refused(e.to_string()))?;
    Ok((text, machine))
}

/// A setting within its limits, or refused naming its option.
pub(crate) fn within(option: &str, value: f64, (lo, hi): (f64, f64), unit: &str) -> Result<(), Stop> {
    if value.is_finite() && (lo..=hi).contains(&value) {
        return Ok(());
    }
    Err(Stop::Refused(format!(
        "{option} must be within {lo} .. {hi} {unit} (is {value})"
    )))
}

/// How long a released jog is left to come to rest.
pub(crate) const REST: Duration = Duration::from_millis(600);

/// A change of the machine file as it was read and as it is proposed.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Edit {
    pub read_text: String,
    pub new_text: String,
}

impl Edit {
    /// Writes the proposal into `file` (which must still be as it was read), the old file
    /// kept under `utc`'s stamp; returns the kept file.
    pub fn commit(&self, file: &Path, utc: &str) -> Result<PathBuf, Stop> {
        machine_edit::commit(
            file,
            &self.read_text,
            &self.new_text,
            &machine_edit::file_stamp(utc),
        )
        .map_err(|e| Stop::Failed(format!("{e}")))
    }
}
