//! What every procedure does with the loop and the machine file alike: reaching `hob-rt`,
//! asking it a command and taking its answer, reading its state stream until an alarm, and
//! the proposed change of the machine file, written only as it was shown.

use crate::Stop;
use hob_ipc::codec;
use hob_ipc::nodes::DriveIdentity;
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
    let held = Held {
        request: &jog,
        moving,
        rest: REST,
    };
    hold(feed, client, &held, enabled, take, &mut || {
        Ok(Instant::now() >= end)
    })
}

/// A command held by renewals (a continuous jog, the table's swing) and released by
/// JOG_RELEASE.
pub(crate) struct Held<'a> {
    pub request: &'a CommandRequest,
    /// What the loop's dead-man stops, in words ("the table").
    pub moving: &'a str,
    /// How long it is left after its release, its state samples still read.
    pub rest: Duration,
}

/// Holds `held` until `done` says so, renewing it every [`RENEWAL`] from its last sending
/// (however long the loop's answer took) while `enabled` holds; released in every case,
/// then left its rest. Every state sample meanwhile goes to `take`. Stops at the loop's
/// refusal (one after it was accepted is its dead-man: the renewals came late), an alarm,
/// the enable let go, or `done`'s error.
pub(crate) fn hold(
    feed: &mut dyn Feed,
    client: &mut dyn Commands,
    held: &Held,
    enabled: &dyn Fn() -> bool,
    take: &mut dyn FnMut(&StateSample),
    done: &mut dyn FnMut() -> Result<bool, Stop>,
) -> Result<(), Stop> {
    let moving = held.moving;
    let mut renewed = 0usize;
    let result = loop {
        if !enabled() {
            break Err(Stop::Failed(format!(
                "the enable was let go: {moving} stopped; nothing written, the machine file unchanged"
            )));
        }
        let sent = Instant::now();
        if let Err(e) = ask(client, held.request, moving) {
            break Err(late_renewal(e, renewed, moving));
        }
        renewed += 1;
        let next = sent + RENEWAL;
        while Instant::now() < next {
            std::thread::sleep(Duration::from_millis(10));
        }
        if let Err(e) = drain(feed, &mut *take) {
            break Err(e);
        }
        match done() {
            Ok(false) => {}
            other => break other.map(|_| ()),
        }
    };
    // Released in every case; after a refusal or a fault its answer adds nothing.
    if let Err(e) = result {
        let _ = client.request(&hob_ipc::request::jog_release(), ANSWER);
        return Err(e);
    }
    ask(client, &hob_ipc::request::jog_release(), moving)?;
    // At rest before what follows: the drive's lag runs out.
    listen(feed, held.rest, take)
}

/// A refusal of a renewal after the command was accepted (`renewed` times): something
/// moved, so it is a stop, not a refusal; most likely the loop's dead-man (the renewals
/// came later than the machine file's `jog.deadman_timeout_ms`).
fn late_renewal(e: Stop, renewed: usize, moving: &str) -> Stop {
    match e {
        Stop::Refused(why) if renewed > 0 => Stop::Failed(format!(
            "{moving} stopped after {renewed} renewals, the loop refused the next: {why} (a jog \
             said to be running is the loop's dead-man: the renewals came later than \
             jog.deadman_timeout_ms, this computer too slow or too loaded?)"
        )),
        other => other,
    }
}

/// Hands every state sample for `time` to `take`; an alarm stops it.
pub(crate) fn listen(
    feed: &mut dyn Feed,
    time: Duration,
    take: &mut dyn FnMut(&StateSample),
) -> Result<(), Stop> {
    let end = Instant::now() + time;
    while Instant::now() < end {
        std::thread::sleep(Duration::from_millis(20));
        drain(feed, &mut *take)?;
    }
    Ok(())
}

/// hob-rt's answer to NODES and the table drive's identity in it ([`hob_ipc::nodes`]).
pub(crate) fn table_drive(client: &mut dyn Commands) -> Result<(DriveIdentity, String), Stop> {
    let answer = client
        .request(&hob_ipc::request::nodes(), ANSWER)
        .map_err(|e| Stop::Failed(format!("hob-rt did not answer: {e}")))?;
    let text = answer.text();
    match hob_ipc::nodes::table_drive(&text) {
        Some(drive) => Ok((drive, text)),
        None => Err(Stop::Failed(format!(
            "hob-rt named no table drive among the nodes on the bus:\n{text}"
        ))),
    }
}

/// A record's three keys of the drive it was measured on (its CiA 301 0x1018).
pub(crate) fn identity_lines((vendor, product, serial): DriveIdentity) -> String {
    format!(
        "table_drive_vendor_id = 0x{vendor:08X}\ntable_drive_product_code = 0x{product:08X}\n\
         table_drive_serial = 0x{serial:08X}\n"
    )
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
