//! The table drive's lost motion at a reversal (the worm's backlash and the mesh's
//! wind-up), against a gauge on the table (issue 33's step 3).
//!
//! The motor's encoder cannot see the play: the drive turns the worm, the wheel waits. A
//! gauge touching the table's rim (an LVDT on one of the I/O coupler's analog inputs,
//! named by the machine file's `io.analog_inputs.table_gauge`) reads the table itself. The
//! table is jogged slowly + , - and + again (the loop's own continuous jog with its
//! dead-man, as `hob commission delay` jogs it), and the motor compared with the gauge at
//! the same readings ([`fit`]): the motor stands ahead of the table by half the lost motion
//! in the jog's sense. The gauge's scale and radius need not be known.
//!
//! Nothing is proposed unless the measurement is whole (every jog ran, no alarm, enough
//! readings on a line, a fit that holds) and known to 10 % (or 0.5 arcsec); the record
//! `[commissioning.table_backlash]` is shown as a diff and written only on the builder's
//! confirmation, the old file kept. The loop does not use the figure (a hobbing cut turns
//! the table one way): it is for the commissioning report and the builder's papers.

pub mod fit;

use crate::Stop;
use crate::link::{self, connect, drain};
use fit::{GaugeSample, Jog, LostMotion, Way};
use hob_ipc::StateSample;
use hob_ipc::codec;
use hob_store::machine_edit;
use std::path::Path;
use std::time::{Duration, Instant};

/// The measurement's settings' limits.
const SPEED_DEG_MIN: (f64, f64) = (0.5, 30.0);
const SECONDS: (f64, f64) = (2.0, 30.0);
/// The most the table may travel each way, deg (a gauge's stroke at a table's rim).
const MAX_TRAVEL_DEG: f64 = 1.0;
/// How long the gauge may stay silent before the jogs, s.
const GAUGE_WAIT_S: f64 = 2.0;
/// The uncertainty a written figure may have: a tenth of it, or this much.
const WRITABLE_ARCSEC: f64 = 0.5;

/// The measurement's settings.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BacklashOptions {
    /// The table's jog speed, deg/min.
    pub speed_deg_min: f64,
    /// How long each jog runs, s.
    pub seconds: f64,
}

impl Default for BacklashOptions {
    fn default() -> Self {
        Self {
            speed_deg_min: 3.0,
            seconds: 5.0,
        }
    }
}

impl BacklashOptions {
    /// The table's travel each way, deg.
    pub fn travel_deg(&self) -> f64 {
        self.speed_deg_min / 60.0 * self.seconds
    }

    /// About how long the table moves, s: three jogs, each left to rest.
    pub fn about_s(&self) -> f64 {
        3.0 * (self.seconds + link::REST.as_secs_f64())
    }

    /// What the table will do, for the person beside it.
    pub fn announcement(&self) -> String {
        format!(
            "the table turns + at {:.1} deg/min for {:.0} s, then - and + again as long ({:.3} deg \
             each way; the gauge must have that much stroke); keep the table clear. hob-rt checks \
             each step as it checks a jog; letting go stops the table.",
            self.speed_deg_min,
            self.seconds,
            self.travel_deg()
        )
    }
}

/// Refuses settings outside their limits, before anything moves.
pub fn check_options(o: &BacklashOptions) -> Result<(), Stop> {
    link::within("--speed", o.speed_deg_min, SPEED_DEG_MIN, "deg/min")?;
    link::within("--seconds", o.seconds, SECONDS, "s")?;
    if o.travel_deg() > MAX_TRAVEL_DEG {
        return Err(Stop::Refused(format!(
            "--speed x --seconds turns the table {:.2} deg each way, more than a gauge's stroke \
             ({MAX_TRAVEL_DEG} deg allowed)",
            o.travel_deg()
        )));
    }
    Ok(())
}

/// What a whole measurement proposes: the lost motion found (its figures in
/// [`LostMotion`]).
pub type Proposal = crate::Proposal<LostMotion>;

/// Measures the lost motion on the running machine and proposes the record; `enabled` is
/// asked before every renewal of a jog (false stops the table), `say` is told each step.
pub fn run(
    machine_file: &Path,
    o: &BacklashOptions,
    enabled: &dyn Fn() -> bool,
    say: &mut dyn FnMut(&str),
) -> Result<Proposal, Stop> {
    let (text, machine) = link::read_machine(machine_file)?;
    check_options(o)?;
    let Some(gauge) = machine.io.analog_inputs.table_gauge else {
        return Err(Stop::Refused(format!(
            "{} names no table gauge (io.analog_inputs.table_gauge): mount a gauge on the \
             table's rim, wire it to an analog input of the I/O coupler, name that input and \
             restart hob-rt; nothing measured",
            machine_file.display()
        )));
    };
    say(&o.announcement());
    let jogs = jog_three_times(o, gauge.channel, enabled, say)?;
    say("comparing the motor with the gauge");
    let l = measure(&jogs)?;
    let report = report(&l, o);
    if !precise_enough(&l) {
        return Err(Stop::Failed(format!(
            "{report}not known to 10 % (+- {:.2} arcsec): nothing written; check the gauge's \
             mounting (it must not slip nor wander) and measure again",
            l.uncertainty_arcsec
        )));
    }
    let utc = hob_store::utc::now();
    let new_text = proposal(&text, &l, o, &utc);
    machine_edit::check(machine_file, &new_text).map_err(|e| Stop::Failed(e.to_string()))?;
    Ok(Proposal::new(machine_file, l, report, text, new_text, utc))
}

/// Whether the figure may be written: known to 10 %, or to [`WRITABLE_ARCSEC`].
pub fn precise_enough(l: &LostMotion) -> bool {
    l.uncertainty_arcsec <= (0.1 * l.arcsec).max(WRITABLE_ARCSEC)
}

/// The lost motion from the recorded jogs.
pub fn measure(jogs: &[Jog]) -> Result<LostMotion, Stop> {
    let windows = jogs
        .iter()
        .enumerate()
        .map(|(i, j)| fit::window(j, i + 1))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| Stop::Failed(format!("{e}; nothing written")))?;
    let l = fit::lost_motion(&windows).map_err(|e| Stop::Failed(format!("{e}; nothing written")))?;
    if l.arcsec < 0.0 {
        return Err(Stop::Failed(format!(
            "the table led its motor ({:.2} arcsec): the gauge's reading is late or the table \
             is pushed; nothing written",
            l.arcsec
        )));
    }
    Ok(l)
}

/// The fit in words.
pub fn report(l: &LostMotion, o: &BacklashOptions) -> String {
    let each: Vec<String> = l.per_reversal_arcsec.iter().map(|v| format!("{v:.2}")).collect();
    format!(
        "lost motion of the table drive: {:.2} +- {:.2} arcsec (each reversal: {}), at {:.1} \
         deg/min; {} gauge readings, the motor {:.2} arcsec RMS off the fit\n\
         (the worm's backlash and the mesh's wind-up under the table's friction together)\n",
        l.arcsec,
        l.uncertainty_arcsec,
        each.join(", "),
        o.speed_deg_min,
        l.readings,
        l.residual_arcsec
    )
}

/// The machine file's text with the record.
pub fn proposal(text: &str, l: &LostMotion, o: &BacklashOptions, utc: &str) -> String {
    let block = format!(
        "[commissioning.table_backlash]\n\
         # Written by `hob commission backlash` (the file before it kept beside it as .bak).\n\
         utc = {utc}\n\
         lost_motion_arcsec = {:.2}\n\
         uncertainty_arcsec = {:.2}\n\
         speed_deg_min = {}\n\
         samples = {}\n",
        l.arcsec, l.uncertainty_arcsec, o.speed_deg_min, l.readings
    );
    machine_edit::replace_table(text, "commissioning.table_backlash", &block)
}

/// The jog's cycles as the fit reads them.
pub fn gauge_samples(states: &[StateSample]) -> Vec<GaugeSample> {
    let jogging_b = codec::Axis::B.code();
    states
        .iter()
        .filter(|s| s.moving_axis == jogging_b)
        .map(|s| GaugeSample {
            table_deg: s.table_deg.actual,
            command_deg: s.table_deg.command,
            gauge_counts: s.table_gauge_counts,
        })
        .collect()
}

/// Waits for the gauge, then jogs + , - , + , each released and left to rest, reading
/// every state sample meanwhile.
fn jog_three_times(
    o: &BacklashOptions,
    channel: u8,
    enabled: &dyn Fn() -> bool,
    say: &mut dyn FnMut(&str),
) -> Result<Vec<Jog>, Stop> {
    let (mut feed, mut client) = connect()?;
    let end = Instant::now() + Duration::from_secs_f64(GAUGE_WAIT_S);
    let mut heard = false;
    while !heard && Instant::now() < end {
        std::thread::sleep(Duration::from_millis(20));
        drain(feed.as_mut(), |s| heard |= s.table_gauge_counts.is_finite())?;
    }
    if !heard {
        return Err(Stop::Failed(format!(
            "no reading from the table gauge (the coupler's analog input {channel}) in {GAUGE_WAIT_S} s: \
             is hob-rt running with this machine file, the gauge wired and powered?"
        )));
    }
    let mut jogs = Vec::new();
    for (way, direction) in [(Way::Positive, "+"), (Way::Negative, "-"), (Way::Positive, "+")] {
        say(&format!("jogging the table {direction}"));
        let mut states = Vec::new();
        link::held_jog(
            feed.as_mut(),
            client.as_mut(),
            ("b", direction, o.speed_deg_min),
            o.seconds,
            enabled,
            &mut |s| states.push(*s),
        )?;
        jogs.push(Jog {
            way,
            samples: gauge_samples(&states),
        });
    }
    Ok(jogs)
}
