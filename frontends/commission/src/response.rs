//! The table's frequency response through the worm (`hob commission response`, issue 33's
//! step 2): the loop swings the table's target (`EXCITE_TABLE`: a sine of about an arcsec,
//! less where the table's acceleration limit says, the table creeping 36 deg/min so that its
//! friction holds the worm on one flank) at stepped frequencies, then at as many again about
//! the deepest dip; each point is the drive's motor against the target from the loop's state
//! stream ([`frf`]). A model of the drive's loops ([`model`], with the gains the drive
//! reported at boot and its data sheet's loop period, speed filter and motor-side inertia
//! from the machine file's `[table.drive_model]`) is fitted to the points ([`fit`]): the
//! table's inertia, the mesh's stiffness and damping, the target's delay. From the fitted
//! mechanism: the mesh's anti-resonance and resonance, the present tuning's stability and
//! margins, and gains proposed with margins (GM 6 dB, PM 45 deg velocity / 40 deg cascade)
//! for the fitted mechanism with no more than 2 % of critical damping. The Bode plot
//! ([`bode`]) shows the points and the fitted model.
//!
//! The record `[commissioning.table_drive_gains]` is shown as a diff and written only on the
//! builder's confirmation, the old file kept; hob-rt's boot writes the gains to the drive
//! (0x60F9/0x60FB) when the record names the drive on the bus, and reads them back.

pub mod analysis;
pub mod bode;
pub mod fit;
pub mod frf;
pub mod model;

use crate::Stop;
use crate::link::{self, connect};
use analysis::Analysis;
use frf::{Point, Reading};
use hob_ipc::nodes::{DriveGains, DriveIdentity};
use hob_ipc::{Commands, Feed, StateSample};
use hob_store::machine_edit;
use std::path::Path;
use std::time::{Duration, Instant};

/// The sweep's settings.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ResponseOptions {
    /// The lowest and highest frequency, Hz (the highest at most a quarter of the loop's rate).
    pub from_hz: f64,
    pub to_hz: f64,
    /// Frequencies of the first sweep, spaced evenly on a log scale; as many again are
    /// added about the deepest dip (the mesh's anti-resonance).
    pub points: usize,
}

/// The settings' limits: frequencies, Hz, and points of the first sweep.
const FREQUENCIES_HZ: (f64, f64) = (0.5, 500.0);
const POINTS: (f64, f64) = (6.0, 40.0);
/// The most the table may wander at rest before the sweep, deg (an unstable or badly tuned
/// drive shows here before anything swings).
const REST_JITTER_DEG: f64 = 3e-4;

impl Default for ResponseOptions {
    fn default() -> Self {
        Self {
            from_hz: 2.0,
            to_hz: 250.0,
            points: 16,
        }
    }
}

/// How long the swing settles after its fade-in before it is read, s.
pub const SETTLE_S: f64 = 0.3;
/// Whole periods read at least at each frequency (and at least a second).
pub const PERIODS_READ: f64 = 8.0;

impl ResponseOptions {
    /// The first sweep's frequencies, Hz, lowest first.
    pub fn first_sweep(&self) -> Vec<f64> {
        let n = self.points.max(2);
        let ratio = (self.to_hz / self.from_hz).ln();
        (0..n)
            .map(|i| match i {
                _ if i == n - 1 => self.to_hz,
                _ => self.from_hz * (ratio * i as f64 / (n - 1) as f64).exp(),
            })
            .collect()
    }

    /// The frequencies added about the first sweep's deepest dip at `dip_hz` (between its
    /// neighbours `below_hz` and `above_hz`), Hz.
    pub fn refinement(&self, below_hz: f64, above_hz: f64) -> Vec<f64> {
        let n = self.points.max(2);
        let ratio = (above_hz / below_hz).ln();
        (1..=n)
            .map(|i| below_hz * (ratio * i as f64 / (n + 1) as f64).exp())
            .collect()
    }
}

/// How long the swing at `frequency_hz` is held and read, s (after its fade-in and settling).
pub fn read_s(frequency_hz: f64) -> f64 {
    (PERIODS_READ / frequency_hz).max(1.0)
}

impl ResponseOptions {
    /// About how long the table moves, s.
    pub fn about_s(&self) -> f64 {
        let fade = hob_ipc::vocab::excitation::FADE_S;
        let each = |f: f64| 2.0 * fade + SETTLE_S + read_s(f) + link::REST.as_secs_f64();
        2.0 * self.first_sweep().iter().map(|&f| each(f)).sum::<f64>()
    }

    /// About how far the table creeps meanwhile, deg (it creeps while it swings).
    pub fn creep_deg(&self) -> f64 {
        let fade = hob_ipc::vocab::excitation::FADE_S;
        let swinging = |f: f64| fade + SETTLE_S + read_s(f);
        2.0 * self.first_sweep().iter().map(|&f| swinging(f)).sum::<f64>()
            * hob_ipc::vocab::excitation::CREEP_DEG_S
    }

    /// The table's creep, deg/min.
    pub fn creep_deg_min(&self) -> f64 {
        hob_ipc::vocab::excitation::CREEP_DEG_S * 60.0
    }

    /// What the table will do, for the person beside it.
    pub fn announcement(&self) -> String {
        format!(
            "the table's target swings by about an arcsec at {} frequencies from {} to {} Hz, \
             then as many again about the deepest dip, the table creeping + at {:.0} deg/min \
             meanwhile (about {:.0} s, {:.0} deg of the table); keep the table clear and \
             unclamped. hob-rt checks each step as it checks a jog; letting go stops the swing.",
            self.points,
            self.from_hz,
            self.to_hz,
            self.creep_deg_min(),
            self.about_s(),
            self.creep_deg()
        )
    }
}

/// Refuses settings outside their limits (the highest frequency at most a quarter of the
/// loop's rate, `period_s`), before anything moves.
pub fn check_options(o: &ResponseOptions, period_s: f64) -> Result<(), Stop> {
    link::within("--from", o.from_hz, FREQUENCIES_HZ, "Hz")?;
    link::within(
        "--to",
        o.to_hz,
        (o.from_hz * 4.0, 0.25 / period_s),
        "Hz (at least 4 x --from, at most a quarter of the loop's rate)",
    )?;
    link::within("--points", o.points as f64, POINTS, "")?;
    Ok(())
}

/// What a whole measurement proposes (its figures in [`Analysis`]).
pub type Proposal = crate::Proposal<Analysis>;

/// Measures the table's frequency response on the running machine and proposes the drive's
/// gains; `enabled` is asked before every renewal (false stops the swing), `say` is told
/// each step.
pub fn run(
    machine_file: &Path,
    o: &ResponseOptions,
    enabled: &dyn Fn() -> bool,
    say: &mut dyn FnMut(&str),
) -> Result<Proposal, Stop> {
    let (text, machine) = link::read_machine(machine_file)?;
    let Some(drive_model) = machine.table.drive_model else {
        return Err(Stop::Refused(format!(
            "{} has no [table.drive_model] (the motor side's inertia, the drive's loop period \
             and speed filter from their data sheets): the model of the drive's loops needs \
             them; nothing measured",
            machine_file.display()
        )));
    };
    let (mut feed, mut client) = connect()?;
    let (identity, gains) = table_drive(client.as_mut())?;
    // The loop's own period (its time per cycle: a slow machine's late cycles do not
    // stretch it), as hob-rt reads it from the same file.
    let period_s = f64::from(machine.control.cycle_period_us) * 1e-6;
    check_options(o, period_s)?;
    say(&o.announcement());
    at_rest(feed.as_mut())?;
    let mut points = Vec::new();
    for f in o.first_sweep() {
        say(&format!("swinging the table at {f:.1} Hz"));
        points.push(swing(feed.as_mut(), client.as_mut(), f, period_s, enabled)?);
    }
    let (below, above) = about_the_dip(&points);
    for f in o.refinement(below, above) {
        say(&format!("swinging the table at {f:.1} Hz (about the dip)"));
        points.push(swing(feed.as_mut(), client.as_mut(), f, period_s, enabled)?);
    }
    points.sort_by(|a, b| a.frequency_hz.total_cmp(&b.frequency_hz));
    say("fitting the model of the drive's loops");
    let a = analysis::analyse(points, gains, &drive_model, machine.table.worm_ratio, period_s)?;
    let report = analysis::report(&a);
    let utc = hob_store::utc::now();
    let new_text = analysis::proposal(&text, &a, identity, &utc);
    machine_edit::check(machine_file, &new_text).map_err(|e| Stop::Failed(e.to_string()))?;
    Ok(Proposal::new(machine_file, a, report, text, new_text, utc))
}

/// The table drive's identity and its gains from hob-rt's answer to NODES.
fn table_drive(client: &mut dyn Commands) -> Result<(DriveIdentity, DriveGains), Stop> {
    let (identity, text) = link::table_drive(client)?;
    let gains = hob_ipc::nodes::table_drive_gains(&text).ok_or_else(|| {
        Stop::Refused(
            "the table drive did not report its gains at boot (0x60F9, 0x60FB): its tuning \
             cannot be checked nor written by hob; nothing measured"
                .into(),
        )
    })?;
    Ok((identity, gains))
}

/// Every state sample for `time`.
fn listen(feed: &mut dyn Feed, time: Duration) -> Result<Vec<StateSample>, Stop> {
    let mut states = Vec::new();
    link::listen(feed, time, &mut |s| states.push(*s))?;
    Ok(states)
}

/// Refuses a table that wanders at rest (its drive's tuning unstable or marginal).
fn at_rest(feed: &mut dyn Feed) -> Result<(), Stop> {
    let states = listen(feed, Duration::from_millis(500))?;
    let (lo, hi) = states
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), s| {
            (lo.min(s.table_deg.actual), hi.max(s.table_deg.actual))
        });
    if hi - lo > REST_JITTER_DEG {
        return Err(Stop::Refused(format!(
            "the table does not stand still ({:.1} arcsec peak to peak in 0.5 s): its drive \
             oscillates or something turns it; check the drive's tuning with its own tool \
             before this measurement; nothing measured",
            (hi - lo) * 3600.0
        )));
    }
    Ok(())
}

/// The first sweep's neighbours of its deepest point, Hz.
fn about_the_dip(points: &[Point]) -> (f64, f64) {
    let i = frf::deepest(points).unwrap_or(0);
    let below = points[i.saturating_sub(1)].frequency_hz;
    let above = points[(i + 1).min(points.len() - 1)].frequency_hz;
    (below, above)
}

/// Swings the table at `frequency_hz` (renewed while `enabled`), reads it once faded in and
/// settled, releases it and leaves it to rest; the point.
fn swing(
    feed: &mut dyn Feed,
    client: &mut dyn Commands,
    frequency_hz: f64,
    period_s: f64,
    enabled: &dyn Fn() -> bool,
) -> Result<Point, Stop> {
    let excite =
        hob_ipc::request::excite_table(frequency_hz, "+").map_err(|e| Stop::Refused(e.to_string()))?;
    let settle = hob_ipc::vocab::excitation::FADE_S + SETTLE_S;
    // Counted in the loop's cycles, not the wall's: a loop that falls behind its pace
    // (an emulated machine) still gives whole periods; one far behind is given up.
    let cycles = ((settle + read_s(frequency_hz)) / period_s).ceil() as usize;
    let give_up = Instant::now() + Duration::from_secs_f64(4.0 * (settle + read_s(frequency_hz)) + 2.0);
    let swinging_b = hob_ipc::codec::Axis::B.code();
    let swung = std::cell::Cell::new(0usize);
    let mut states: Vec<StateSample> = Vec::new();
    let held = link::Held {
        request: &excite,
        moving: "the table's swing",
        rest: link::REST + Duration::from_secs_f64(hob_ipc::vocab::excitation::FADE_S),
    };
    // Read until it is released: its fade-out and rest are no readings.
    let released = std::cell::Cell::new(false);
    let mut take = |s: &StateSample| {
        if released.get() {
            return;
        }
        if s.moving_axis == swinging_b {
            swung.set(swung.get() + 1);
        }
        states.push(*s);
    };
    let mut done = || match swung.get() {
        n if n >= cycles => {
            released.set(true);
            Ok(true)
        }
        n if Instant::now() >= give_up => Err(Stop::Failed(format!(
            "the loop ran {n} of the swing's {cycles} cycles in four times their time: it is \
             far behind its pace; nothing written"
        ))),
        _ => Ok(false),
    };
    link::hold(feed, client, &held, enabled, &mut take, &mut done)?;
    let readings = readings(&states, (settle / period_s).ceil() as usize)?;
    frf::point(frequency_hz, period_s, &readings).map_err(|e| {
        Stop::Failed(format!(
            "no response at {frequency_hz:.1} Hz ({e:?}): nothing written"
        ))
    })
}

/// The swing's readings after its first `skip` cycles, consecutive (a lost state sample
/// would shift every later one in time).
fn readings(states: &[StateSample], skip: usize) -> Result<Vec<Reading>, Stop> {
    let swinging_b = hob_ipc::codec::Axis::B.code();
    let swung: Vec<&StateSample> = states
        .iter()
        .filter(|s| s.moving_axis == swinging_b)
        .skip(skip)
        .collect();
    if swung.windows(2).any(|w| w[1].cycle != w[0].cycle + 1) {
        return Err(Stop::Failed(
            "state samples were lost during the swing (the reader fell behind): nothing written".into(),
        ));
    }
    Ok(swung
        .iter()
        .map(|s| Reading {
            command_deg: s.table_deg.command,
            table_deg: s.table_deg.actual,
        })
        .collect())
}
