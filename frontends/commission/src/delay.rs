//! The table drive's delay, the figure the gearbox's predictor uses
//! (`control.drive_delay_us`): wrong by 250 us, the first cut faults at engagement
//! (docs/accuracy.md, "Hidden plants").
//!
//! The table is jogged at a constant speed one way and then the other (the loop's own
//! continuous jog with its dead-man, renewed every 100 ms while the frontend's enable is
//! held: the loop checks each renewal as it checks the operator's; a killed frontend stops
//! the table within the dead-man time), the loop's state stream read cycle by cycle, and the
//! drive's position fitted against the command shifted in time (`hob_logger::delay`, as
//! `hob log delay` fits a recorded cut), over the cycles where the command had run at a
//! constant speed for a second (the drive's transient left out). Two directions: a drive
//! whose lag differs with the direction shows as a residual, not as a wrong delay.
//!
//! Nothing is proposed unless the measurement is whole (both jogs ran, no alarm, enough
//! steady cycles, a residual that says the fit holds); the proposal (the found delay and
//! its record, `[commissioning.drive_delay]`, naming the table drive that answered at boot)
//! is checked as `hob-rt` will load it and shown as a diff; [`Proposal::write`] writes it
//! only when the frontend's builder confirms, with the old file kept. `hob-rt` reads the
//! machine file at its start: the new delay takes effect when it is restarted.

use crate::Stop;
use crate::link::{self, connect};
use hob_ipc::StateSample;
use hob_ipc::codec;
use hob_logger::delay::{DriveDelay, TableSample};
use hob_store::machine_edit;
use std::path::Path;

/// The command must have run at one speed this long before a cycle counts: the drive's
/// velocity loop settles within it (a 16 Hz position loop: 5 time constants in 0.05 s;
/// a second leaves room for a slower drive).
const SETTLE_S: f64 = 1.0;
/// The fit must use at least this much steady jog, s, in each direction.
const MIN_STEADY_S: f64 = 1.0;
/// Above this RMS residual the drive does not follow its command as a pure delay (a
/// position-dependent error, a lag that differs with the direction, a stick-slip): the
/// figure is not written.
const MAX_RESIDUAL_ARCSEC: f64 = 5.0;
/// The measurement's settings' limits.
const SPEED_DEG_MIN: (f64, f64) = (30.0, 1200.0);
const SECONDS: (f64, f64) = (2.0, 20.0);

/// The measurement's settings.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DelayOptions {
    /// The table's jog speed, deg/min.
    pub speed_deg_min: f64,
    /// How long each direction is jogged, s.
    pub seconds: f64,
}

impl Default for DelayOptions {
    fn default() -> Self {
        Self {
            speed_deg_min: 240.0,
            seconds: 3.0,
        }
    }
}

impl DelayOptions {
    /// What the table will do, for the person beside it.
    pub fn announcement(&self) -> String {
        format!(
            "the table turns + at {:.0} deg/min for {:.0} s, then - as long ({:.1} deg each way, \
             back to where it stands); keep the table clear. hob-rt checks each step as it \
             checks a jog; letting go stops the table.",
            self.speed_deg_min,
            self.seconds,
            self.speed_deg_min / 60.0 * self.seconds
        )
    }
}

/// The delay found, us, and the one the machine file has.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DelayFound {
    pub found_us: f64,
    pub assumed_us: u32,
}

/// What a whole measurement proposes for the machine file.
pub type Proposal = crate::Proposal<DelayFound>;

/// Measures the delay on the running machine and proposes the machine file's change;
/// `enabled` is asked before every renewal of a jog (a frontend's dead-man: false stops
/// the measurement and the table), `say` is told each step.
pub fn run(
    machine_file: &Path,
    o: &DelayOptions,
    enabled: &dyn Fn() -> bool,
    say: &mut dyn FnMut(&str),
) -> Result<Proposal, Stop> {
    let (text, machine) = link::read_machine(machine_file)?;
    check_options(o)?;
    let period_s = f64::from(machine.control.cycle_period_us) * 1e-6;
    let assumed_us = machine.control.drive_delay_us;
    say(&o.announcement());
    let (states, drive) = jog_both_ways(o, enabled, say)?;
    say("fitting the delay to the jogs");
    let m = measure(&states, period_s, f64::from(assumed_us) * 1e-6)?;
    let utc = hob_store::utc::now();
    let new_text = proposal(&text, &m.delay, &utc, drive)?;
    // The proposal is checked as hob-rt will load it before it is shown.
    machine_edit::check(machine_file, &new_text).map_err(|e| Stop::Failed(e.to_string()))?;
    let found_us = m.delay.drive_delay_s * 1e6;
    let report = format!(
        "{}  steady cycles: + {}, - {}\nfound {found_us:.1} us; the machine file has {assumed_us} us.\n",
        hob_logger::delay::text(&m.delay, f64::from(assumed_us) * 1e-6)
            .replace("synchronised cut", "steady jog"),
        m.steady_positive,
        m.steady_negative,
    );
    Ok(Proposal::new(
        machine_file,
        DelayFound { found_us, assumed_us },
        report,
        text,
        new_text,
        utc,
    ))
}

/// Refuses settings outside their limits, before anything moves.
pub fn check_options(o: &DelayOptions) -> Result<(), Stop> {
    link::within("--speed", o.speed_deg_min, SPEED_DEG_MIN, "deg/min")?;
    link::within("--seconds", o.seconds, SECONDS, "s")?;
    Ok(())
}

/// A drive as it names itself: vendor id, product code, serial number (CiA 301 0x1018).
pub use hob_ipc::nodes::DriveIdentity;

/// Jogs the table + then - (each released and left to come to rest), reading every state
/// sample meanwhile; with the table drive's identity (the one measured). Stops at the
/// loop's refusal, an alarm or the enable let go.
fn jog_both_ways(
    o: &DelayOptions,
    enabled: &dyn Fn() -> bool,
    say: &mut dyn FnMut(&str),
) -> Result<(Vec<StateSample>, DriveIdentity), Stop> {
    let (mut feed, mut client) = connect()?;
    let (drive, _) = link::table_drive(client.as_mut())?;
    let mut states = Vec::new();
    for direction in ["+", "-"] {
        say(&format!("jogging the table {direction}"));
        link::held_jog(
            feed.as_mut(),
            client.as_mut(),
            ("b", direction, o.speed_deg_min),
            o.seconds,
            enabled,
            &mut |s| states.push(*s),
        )?;
    }
    Ok((states, drive))
}

/// A measurement from the jogs.
#[derive(Debug, Clone, Copy)]
pub struct Measured {
    pub delay: DriveDelay,
    pub steady_positive: usize,
    pub steady_negative: usize,
}

/// The delay from the recorded jogs: only cycles where the table jogged (`moving_axis` B)
/// with its command at one constant speed for [`SETTLE_S`]; refused when either direction
/// had less than [`MIN_STEADY_S`] of it, or the fit does not hold.
pub fn measure(states: &[StateSample], period_s: f64, assumed_s: f64) -> Result<Measured, Stop> {
    let jogging_b = codec::Axis::B.code();
    let mut samples = hob_logger::delay::from_states(states, |s| s.moving_axis == jogging_b);
    let (pos, neg) = keep_steady(&mut samples, period_s);
    let need = (MIN_STEADY_S / period_s) as usize;
    if pos < need || neg < need {
        return Err(Stop::Failed(format!(
            "too little steady jog to measure from (+ {pos}, - {neg} cycles, {need} needed each way): \
             a lost state stream, or a jog speed the loop limited; nothing written"
        )));
    }
    let delay = hob_logger::delay::identify(&samples, period_s, assumed_s)
        .ok_or_else(|| Stop::Failed("no delay could be fitted to the jogs; nothing written".into()))?;
    if delay.residual_rms_arcsec > MAX_RESIDUAL_ARCSEC || delay.drive_delay_s < 0.0 {
        return Err(Stop::Failed(format!(
            "the table does not follow its command as a delay (RMS {:.2} arcsec left at {:.0} us, \
             {MAX_RESIDUAL_ARCSEC} allowed): check the drive's tuning and the mechanism; nothing written",
            delay.residual_rms_arcsec,
            delay.drive_delay_s * 1e6
        )));
    }
    Ok(Measured {
        delay,
        steady_positive: pos,
        steady_negative: neg,
    })
}

/// Keeps `in_cut` only where the command has moved by the same step every cycle for
/// [`SETTLE_S`] (a few lost cycles between, filled as NaN, neither count nor break the
/// run); returns the steady cycles moving + and -.
fn keep_steady(samples: &mut [TableSample], period_s: f64) -> (usize, usize) {
    let settle = (SETTLE_S / period_s) as usize;
    let mut run = 0usize;
    let (mut pos, mut neg) = (0, 0);
    // The last sample with a command, and the step per cycle that led to it.
    let mut last: Option<(usize, f64)> = None;
    for i in 0..samples.len() {
        let c = samples[i].command_deg;
        if !c.is_finite() {
            samples[i].in_cut = false;
            continue;
        }
        let step = last.map(|(j, _)| (c - samples[j].command_deg) / (i - j) as f64);
        let previous = last.map(|(_, p)| p);
        let same = match (step, previous) {
            (Some(s), Some(p)) => s != 0.0 && (s - p).abs() <= 1e-9 * s.abs().max(1e-6),
            _ => false,
        };
        run = if same && samples[i].in_cut { run + 1 } else { 0 };
        samples[i].in_cut = run >= settle;
        if samples[i].in_cut {
            if step.unwrap_or(0.0) > 0.0 {
                pos += 1;
            } else {
                neg += 1;
            }
        }
        last = Some((i, step.unwrap_or(f64::NAN)));
    }
    (pos, neg)
}

/// The machine file's text with the found delay and its record (on `drive`).
pub fn proposal(text: &str, d: &DriveDelay, utc: &str, drive: DriveIdentity) -> Result<String, Stop> {
    let found_us = d.drive_delay_s * 1e6;
    let text = machine_edit::set_value(
        text,
        "control",
        "drive_delay_us",
        &format!("{}", found_us.round() as u32),
    )
    .map_err(|e| Stop::Failed(e.to_string()))?;
    let block = format!(
        "[commissioning.drive_delay]\n\
         # Written by `hob commission delay` (the file before it kept beside it as .bak).\n\
         utc = {utc}\n\
         found_us = {found_us:.1}\n\
         residual_arcsec = {:.2}\n\
         samples = {}\n\
         {}",
        d.residual_rms_arcsec,
        d.samples,
        link::identity_lines(drive)
    );
    Ok(machine_edit::replace_table(
        &text,
        "commissioning.drive_delay",
        &block,
    ))
}

#[cfg(test)]
mod tests;
