//! The spindle encoder's error, told apart from a true once-per-turn swing of the spindle
//! (`[commissioning.spindle_encoder]`).
//!
//! The loop identifies the once-per-turn sine of the spindle's reading while it cuts and
//! takes it out (`hob_control::eccentricity`), but at one speed an error of the encoder's
//! disc and a true swing of the spindle (an unbalance, a pulley: a torque once per turn,
//! which the encoder reads correctly) look the same; taking a swing for an error makes the
//! table stop following a motion the spindle really makes. They differ in how they go with
//! speed: the error is fixed to the angle, the swing of a torque against the drive's slip
//! and the spindle's inertia shrinks as the speed rises (as 1/W to 1/W^2). So the spindle
//! is held at several speeds in turn (the loop's own SPINDLE HOLD with its dead-man,
//! renewed every 100 ms while the frontend's enable is held), the raw readings of each
//! speed fitted ([`fit::fit_speed`]: harmonics 1 to 3 per turn beside the motion) and the
//! once-per-turn parts over the speeds split into the error and the swing
//! ([`fit::separate`]).
//!
//! Nothing is proposed unless every speed was held and fitted; the record is checked as
//! `hob-rt` will load it and shown as a diff, and [`Proposal::write`] writes it only on the
//! builder's confirmation, the old file kept. With the record, the loop corrects only the
//! encoder's share of what it identifies; `hob-rt` reads it at its start.

pub mod fit;

use crate::Stop;
use crate::link::{self, ask, connect, drain};
use fit::{Reading, Separation, SpeedFit};
use hob_ipc::{Commands, Feed};
use hob_setup::config::machine::commissioning::HELD_SPINDLE_TRIM_FREEZE_S;
use hob_store::machine_edit;
use std::path::Path;
use std::time::{Duration, Instant};

/// A speed is read once the spindle's mean speed over one window of whole turns (at least
/// a second) differs from the window's before by at most [`SETTLED_SHARE`] of it (the
/// VFD's ramp, then the loop's slow trim of the slip: 5-7 s in the simulated machine at
/// 64 rpm; whole turns, so that a once-per-turn swing does not move the mean) and is
/// within [`NEAR_SHARE`] of the speed held ...
const SETTLED_SHARE: f64 = 0.0005;
const NEAR_SHARE: f64 = 0.02;
/// ... and refused when it has not within this after the VFD's ramp, s.
const SETTLE_TIMEOUT_S: f64 = 30.0;
/// The record is proposed only when the error is known to this share of itself, or to
/// [`MIN_UNCERTAINTY_ARCSEC`] (a small error: its share means little there).
const MAX_UNCERTAINTY_SHARE: f64 = 0.1;
const MIN_UNCERTAINTY_ARCSEC: f64 = 1.0;
/// The measurement's settings' limits.
const SECONDS: (f64, f64) = (4.0, 60.0);
/// The loop identifies the once-per-turn sine from 60 rpm (four turns within its fit's
/// 4 s), and while it does its slow trim of the VFD's reference no longer sees the sine:
/// the swing then answers the spindle's inertia and slip alone, as the loop's cut will
/// meet it. Below, the trim would move the swing (15 % at 32 rpm) and the identification
/// would not run at all.
const LOWEST_RPM: f64 = 60.0;
/// Each speed is read for at least this many turns (3 of the fit's blocks of 2 turns, and
/// a margin for lost samples).
const MIN_TURNS: f64 = 8.0;

/// The measurement's settings.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EncoderOptions {
    /// The speeds the spindle is held at, rpm (at least 3, spanning a factor 2; none: a
    /// spread up to the machine's `spindle.max_spindle_rpm`).
    pub speeds_rpm: Vec<f64>,
    /// How long each speed is read, s.
    pub seconds: f64,
}

impl Default for EncoderOptions {
    fn default() -> Self {
        Self {
            speeds_rpm: Vec::new(),
            seconds: 30.0,
        }
    }
}

/// The speeds held when none are asked for: six from 30 % of the machine's largest to it
/// (the top speed above all shows how a swing bends with speed).
pub fn default_speeds_rpm(max_spindle_rpm: f64) -> Vec<f64> {
    [0.30, 0.40, 0.52, 0.66, 0.83, 1.0]
        .iter()
        .map(|f| (f * max_spindle_rpm).round())
        .collect()
}

/// Before each speed is read, the VFD's ramp and the settling take about this long, s (5-15 s
/// measured on the simulated machine).
const SETTLING_ABOUT_S: f64 = 14.0;
/// No speed is read earlier than this after its hold began, s: the loop keeps its speed
/// trim from [`HELD_SPINDLE_TRIM_FREEZE_S`] at speed on (the ramp and a margin after it), so
/// the readings see a VFD whose reference stands still.
pub const SETTLE_MIN_S: f64 = HELD_SPINDLE_TRIM_FREEZE_S + 4.0;

impl EncoderOptions {
    /// The options as they run on a machine whose spindle's largest speed is `max_rpm`: the
    /// default speeds where none were asked for.
    pub fn on_machine(&self, max_rpm: f64) -> EncoderOptions {
        let mut o = self.clone();
        if o.speeds_rpm.is_empty() {
            o.speeds_rpm = default_speeds_rpm(max_rpm);
        }
        o
    }

    /// About how long the spindle is held, s: each speed read ([`read_s`]) after its ramp
    /// and settling.
    pub fn about_s(&self) -> f64 {
        self.speeds_rpm
            .iter()
            .map(|&r| read_s(self.seconds, r) + SETTLING_ABOUT_S)
            .sum()
    }

    /// What the spindle will do, for the person beside it.
    pub fn announcement(&self) -> String {
        let speeds: Vec<String> = self.speeds_rpm.iter().map(|r| format!("{r:.0}")).collect();
        format!(
            "the hob spindle turns at {} rpm in turn, {:.0} s each (about {:.0} s in all); the hob \
             must be clear of the work and guarded. hob-rt checks each step as it checks the \
             spindle's hold; letting go stops the spindle.",
            speeds.join(", "),
            self.seconds,
            self.about_s()
        )
    }
}

/// Refuses settings outside their limits (the speeds against the machine's largest), before
/// anything turns.
pub fn check_options(o: &EncoderOptions, max_spindle_rpm: f64) -> Result<(), Stop> {
    if !(o.seconds.is_finite() && (SECONDS.0..=SECONDS.1).contains(&o.seconds)) {
        return Err(Stop::Refused(format!(
            "--seconds must be within {} .. {} s (is {})",
            SECONDS.0, SECONDS.1, o.seconds
        )));
    }
    if o.speeds_rpm.len() < 3 {
        return Err(Stop::Refused(format!(
            "--speeds must name at least 3 speeds (names {}): the error and the swing are told \
             apart by how they go with speed",
            o.speeds_rpm.len()
        )));
    }
    for &r in &o.speeds_rpm {
        if !(r.is_finite() && (LOWEST_RPM..=max_spindle_rpm).contains(&r)) {
            return Err(Stop::Refused(format!(
                "--speeds: {r} rpm is outside {LOWEST_RPM} .. {max_spindle_rpm} rpm \
                 (spindle.max_spindle_rpm)"
            )));
        }
    }
    let (lo, hi) = o
        .speeds_rpm
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), &r| (lo.min(r), hi.max(r)));
    if hi < 2.0 * lo {
        return Err(Stop::Refused(format!(
            "--speeds must span at least a factor 2 (span {lo} .. {hi} rpm)"
        )));
    }
    Ok(())
}

/// What the speeds showed: each speed's fit and their separation into the encoder's error
/// and the spindle's swing.
#[derive(Debug, Clone, PartialEq)]
pub struct EncoderFound {
    pub separation: Separation,
    pub fits: Vec<SpeedFit>,
}

/// What a whole measurement proposes for the machine file.
pub type Proposal = crate::Proposal<EncoderFound>;

/// Measures on the running machine and proposes the machine file's record; `enabled` is
/// asked before every renewal of the hold (a frontend's dead-man: false stops the spindle
/// and the measurement), `say` is told each step.
pub fn run(
    machine_file: &Path,
    o: &EncoderOptions,
    enabled: &dyn Fn() -> bool,
    say: &mut dyn FnMut(&str),
) -> Result<Proposal, Stop> {
    let (text, machine) = link::read_machine(machine_file)?;
    let max_rpm = machine.spindle.max_spindle_rpm;
    let o = o.on_machine(max_rpm);
    check_options(&o, max_rpm)?;
    if machine.control.spindle_encoder_identification_s <= 0.0 {
        return Err(Stop::Refused(
            "control.spindle_encoder_identification_s is 0: the loop does not identify the \
             encoder's error, so there is nothing to tell apart for it"
                .into(),
        ));
    }
    let count_deg = 360.0 / f64::from(machine.spindle.encoder_counts_per_rev);
    let period_s = f64::from(machine.control.cycle_period_us) * 1e-6;
    if let Some(&r) = o
        .speeds_rpm
        .iter()
        .find(|&&r| locks_to_counts(r, count_deg, period_s))
    {
        return Err(Stop::Refused(format!(
            "--speeds: at {r} rpm the spindle turns a whole number of counts a cycle ({:.2}): \
             the reading's rounding would lock to the angle and bias the fit; take a speed \
             1 % away",
            r * 6.0 * period_s / count_deg
        )));
    }
    // Full scale of the VFD in spindle rpm: how long its ramp to each speed takes.
    let full_scale_rpm = machine.spindle.motor_rpm_at_full_scale / machine.spindle.motor_to_spindle_ratio;
    let ramp_s_per_rpm = machine.spindle.vfd_ramp_s / full_scale_rpm;
    say(&o.announcement());
    let pace = Pace {
        ramp_s_per_rpm,
        period_s,
    };
    let runs = hold_each_speed(&o, pace, enabled, say)?;
    say("fitting the encoder's error to each speed");
    let mut fits = Vec::with_capacity(runs.len());
    for (rpm, readings) in &runs {
        let f = fit::fit_speed(readings, count_deg).map_err(|e| {
            Stop::Failed(format!(
                "the {rpm:.0} rpm run does not fit: {e}; nothing written, the machine file unchanged"
            ))
        })?;
        fits.push(f);
    }
    // The top speed, in the direction the reading ran (the encoder's polarity decides it).
    let direction = fits.first().map_or(1.0, |f| f.rpm.signum());
    let reference_rpm = direction * o.speeds_rpm.iter().fold(0.0f64, |a, &r| a.max(r));
    let separation = fit::separate(&fits, reference_rpm).map_err(|e| {
        Stop::Failed(format!(
            "the error and the swing could not be told apart: {e}; nothing written, the machine \
             file unchanged"
        ))
    })?;
    if let Err(why) = precise_enough(&separation) {
        return Err(Stop::Failed(format!(
            "{}{why}; nothing written, the machine file unchanged (the loop goes on taking all \
             of the once-per-turn sine for the encoder's error)",
            report(&fits, &separation),
        )));
    }
    let utc = hob_store::utc::now();
    let new_text = proposal(&text, &separation, &o.speeds_rpm, &utc);
    // The proposal is checked as hob-rt will load it before it is shown.
    machine_edit::check(machine_file, &new_text).map_err(|e| Stop::Failed(e.to_string()))?;
    let words = report(&fits, &separation);
    Ok(Proposal::new(
        machine_file,
        EncoderFound { separation, fits },
        words,
        text,
        new_text,
        utc,
    ))
}

/// Whether the error is known well enough to be written: to [`MAX_UNCERTAINTY_SHARE`] of
/// itself or [`MIN_UNCERTAINTY_ARCSEC`]; otherwise why not, in words.
pub fn precise_enough(s: &Separation) -> Result<(), String> {
    let found = s.encoder[0].amplitude_arcsec();
    let allowed = (MAX_UNCERTAINTY_SHARE * found).max(MIN_UNCERTAINTY_ARCSEC);
    if s.error_uncertainty_arcsec <= allowed {
        return Ok(());
    }
    Err(format!(
        "the encoder's error is known only to +- {:.1} arcsec of its {found:.1} ({:.0} %; \
         {:.0} % or {MIN_UNCERTAINTY_ARCSEC} arcsec needed): the speeds do not tell it apart \
         from the spindle's swing well enough. Run it longer (--seconds) or over a wider span \
         of speeds (--speeds)",
        s.error_uncertainty_arcsec,
        100.0 * s.error_uncertainty_arcsec / found.max(1e-9),
        100.0 * MAX_UNCERTAINTY_SHARE
    ))
}

/// The fits and the separation in words.
pub fn report(fits: &[SpeedFit], s: &Separation) -> String {
    let mut t = String::from(
        "speed      once    twice    three times per turn (arcsec)  +- once  residual  blocks (left out)\n",
    );
    for f in fits {
        t.push_str(&format!(
            "{:>6.1} rpm {:>7.2}  {:>7.2}  {:>7.2}{:>29.2}  {:>6.1} arcsec  {} ({})\n",
            f.rpm,
            f.harmonics[0].amplitude_arcsec(),
            f.harmonics[1].amplitude_arcsec(),
            f.harmonics[2].amplitude_arcsec(),
            f.once_sigma_arcsec,
            f.residual_arcsec,
            f.blocks,
            f.dropped_blocks
        ));
    }
    t.push_str(&s.text());
    if !t.ends_with('\n') {
        t.push('\n');
    }
    t
}

/// Holds the spindle at each speed in turn, reading every state sample after it settled;
/// the spindle is stopped at the end and on every way out. Stops at the loop's refusal,
/// an alarm or the enable let go.
/// How fast the spindle's speed changes (the VFD's ramp, s per rpm) and the loop's period.
#[derive(Debug, Clone, Copy)]
struct Pace {
    ramp_s_per_rpm: f64,
    period_s: f64,
}

fn hold_each_speed(
    o: &EncoderOptions,
    pace: Pace,
    enabled: &dyn Fn() -> bool,
    say: &mut dyn FnMut(&str),
) -> Result<Vec<(f64, Vec<Reading>)>, Stop> {
    let (mut feed, mut client) = connect()?;
    let mut held = false;
    let result = each_speed(o, pace, enabled, say, client.as_mut(), feed.as_mut(), &mut held);
    if !held {
        // The loop refused the first hold: the spindle is as it was (turning, if the
        // operator had switched it on), and stays so.
        return result;
    }
    // Stopped in every case; after a refusal or a fault its answer adds nothing.
    let off = client.request(
        &hob_ipc::request::simple(hob_ipc::command::SPINDLE_OFF),
        link::ANSWER,
    );
    let runs = result?;
    off.map_err(|e| {
        Stop::Failed(format!(
            "hob-rt did not answer the spindle's stop: {e}; it stops within the dead-man time"
        ))
    })?;
    Ok(runs)
}

fn each_speed(
    o: &EncoderOptions,
    Pace {
        ramp_s_per_rpm,
        period_s,
    }: Pace,
    enabled: &dyn Fn() -> bool,
    say: &mut dyn FnMut(&str),
    client: &mut dyn Commands,
    feed: &mut dyn Feed,
    held: &mut bool,
) -> Result<Vec<(f64, Vec<Reading>)>, Stop> {
    let mut runs = Vec::with_capacity(o.speeds_rpm.len());
    let mut was_rpm = 0.0f64;
    for &rpm in &o.speeds_rpm {
        say(&format!(
            "holding the spindle at {rpm:.0} rpm (until it is steady, then {:.0} s read)",
            o.seconds
        ));
        let hold = hob_ipc::request::spindle_hold(rpm);
        let give_up = Instant::now()
            + Duration::from_secs_f64(ramp_s_per_rpm * (rpm - was_rpm).abs() + SETTLE_TIMEOUT_S);
        let mut settling = Settling::new(rpm);
        let mut readings = Vec::with_capacity((o.seconds * 1100.0) as usize);
        let mut end = None;
        loop {
            if !enabled() {
                return Err(Stop::Failed(
                    "the enable was let go: the spindle stopped; nothing written, the machine file unchanged"
                        .into(),
                ));
            }
            // A refusal because the machine faulted names the fault (the state stream has it).
            ask(client, &hold, "the spindle")
                .map_err(|refused| drain(feed, |_| {}).err().unwrap_or(refused))?;
            *held = true;
            std::thread::sleep(link::RENEWAL);
            drain(feed, |s| {
                // The drive latches the reading at each SYNC, a period apart: the cycle's
                // count is its time. (The SYNC's own jitter, tens of us on PREEMPT_RT, is
                // noise below the quantisation's at these speeds; the clock it was sent at
                // would carry the host's scheduling into the simulated machine, whose
                // physics advance a period per SYNC.)
                let t_s = s.cycle as f64 * period_s;
                if settling.steady(t_s, s.spindle_reading_deg) {
                    take(&mut readings, t_s, s.spindle_reading_deg);
                }
            })?;
            match end {
                None if settling.since_s().is_some() => {
                    end = Some(Instant::now() + Duration::from_secs_f64(read_s(o.seconds, rpm)));
                }
                None if Instant::now() >= give_up => {
                    return Err(Stop::Failed(format!(
                        "the spindle did not settle at {rpm:.0} rpm (last {:.1} rpm): check the \
                         VFD and the spindle's drive; nothing written, the machine file unchanged",
                        settling.last_rpm
                    )));
                }
                Some(at) if Instant::now() >= at => break,
                _ => {}
            }
        }
        runs.push((rpm, readings));
        was_rpm = rpm;
    }
    Ok(runs)
}

/// Whether at `rpm` the spindle turns within a twentieth of a whole number of counts a
/// cycle: every reading then rounds the same way at the same angle, and the rounding looks
/// like an error of the disc (three times the error itself in a test at 90 rpm on 10 000
/// counts, 15 a cycle). The loop's trim holds the set speed, so a real machine's slip does
/// not dither it away.
pub fn locks_to_counts(rpm: f64, count_deg: f64, period_s: f64) -> bool {
    let counts = rpm * 6.0 * period_s / count_deg;
    (counts - counts.round()).abs() < 0.05
}

/// How long a speed is read: `seconds`, and at least [`MIN_TURNS`] turns (the fit's blocks).
pub fn read_s(seconds: f64, rpm: f64) -> f64 {
    seconds.max(MIN_TURNS * 60.0 / rpm)
}

/// Whether the spindle has settled at its speed, from its readings: the mean speed over
/// windows of whole turns lasting at least a second, each against the one before (see
/// [`SETTLED_SHARE`]). Once settled it stays so: a speed that wanders afterwards is for the
/// fit to refuse ([`fit::FitError::NotSteady`]).
#[derive(Debug, Clone, Copy)]
pub struct Settling {
    rpm: f64,
    window_deg: f64,
    /// Where the current window began (s, deg), and the last window's mean speed, deg/s.
    window_start: Option<(f64, f64)>,
    last_deg_s: Option<f64>,
    settled_at_s: Option<f64>,
    /// The first reading's time: none is settled before [`SETTLE_MIN_S`] after it.
    first_s: Option<f64>,
    /// The last window's mean speed, rpm (0 before the first).
    pub last_rpm: f64,
}

impl Settling {
    pub fn new(rpm: f64) -> Self {
        Self {
            rpm,
            window_deg: 360.0 * (rpm.abs() / 60.0).ceil().max(1.0),
            window_start: None,
            last_deg_s: None,
            settled_at_s: None,
            first_s: None,
            last_rpm: 0.0,
        }
    }

    /// Takes the reading latched at `t_s`; true from the cycle the spindle has settled on.
    pub fn steady(&mut self, t_s: f64, reading_deg: f64) -> bool {
        if self.settled_at_s.is_some() {
            return true;
        }
        let first_s = *self.first_s.get_or_insert(t_s);
        let Some((t0, d0)) = self.window_start else {
            self.window_start = Some((t_s, reading_deg));
            return false;
        };
        if (reading_deg - d0).abs() < self.window_deg || t_s <= t0 {
            return false;
        }
        let deg_s = (reading_deg - d0) / (t_s - t0);
        self.last_rpm = deg_s / 6.0;
        let near = (deg_s.abs() / 6.0 - self.rpm).abs() <= NEAR_SHARE * self.rpm;
        if let Some(before) = self.last_deg_s
            && near
            && t_s - first_s >= SETTLE_MIN_S
            && (deg_s - before).abs() <= SETTLED_SHARE * deg_s.abs()
        {
            self.settled_at_s = Some(t_s);
        }
        self.last_deg_s = Some(deg_s);
        self.window_start = Some((t_s, reading_deg));
        self.settled_at_s.is_some()
    }

    /// When it settled (the loop's clock).
    pub fn since_s(&self) -> Option<f64> {
        self.settled_at_s
    }
}

/// Adds the reading latched at `t_s`, unless it is the last one again: the drive's TPDO
/// missed and the value held (at [`LOWEST_RPM`] and more the spindle turns several counts
/// a cycle, so a fresh reading always differs), which is not a measurement.
pub fn take(readings: &mut Vec<Reading>, t_s: f64, deg: f64) {
    if readings.last().is_some_and(|r| r.deg == deg) {
        return;
    }
    readings.push(Reading { t_s, deg });
}

/// The machine file's text with the record of `s`, measured at `speeds_rpm`.
///
/// The record is written for a reading that counts up: a spindle whose reading counted down
/// sees every once-per-turn sine mirrored (the conjugate), so the swing's phase against the
/// error is written mirrored back, and the loop mirrors it again where its reading counts
/// down (`hob_control::eccentricity`).
pub fn proposal(text: &str, s: &Separation, speeds_rpm: &[f64], utc: &str) -> String {
    let relative = if s.reference_rpm < 0.0 {
        s.variation_relative().conj()
    } else {
        s.variation_relative()
    };
    let speeds: Vec<String> = speeds_rpm.iter().map(|r| format!("{r:.1}")).collect();
    let block = format!(
        "[commissioning.spindle_encoder]\n\
         # Written by `hob commission encoder` (the file before it kept beside it as .bak).\n\
         # The encoder's error per turn (once, twice, three times), and the spindle's true\n\
         # swing once per turn at reference_rpm with its phase against the error's: the loop\n\
         # corrects only the error and lets the table follow the swing.\n\
         utc = {utc}\n\
         error_arcsec = {:.2}\n\
         error_2_arcsec = {:.2}\n\
         error_3_arcsec = {:.2}\n\
         swing_arcsec = {:.2}\n\
         swing_phase_deg = {:.1}\n\
         swing_tau_s = {:.4}\n\
         reference_rpm = {:.1}\n\
         speeds_rpm = [{}]\n\
         misfit_arcsec = {:.2}\n\
         error_uncertainty_arcsec = {:.2}\n",
        s.encoder[0].amplitude_arcsec(),
        s.encoder[1].amplitude_arcsec(),
        s.encoder[2].amplitude_arcsec(),
        relative.amplitude_arcsec(),
        relative.cos_arcsec.atan2(relative.sin_arcsec).to_degrees(),
        s.tau_s,
        s.reference_rpm.abs(),
        speeds.join(", "),
        s.misfit_arcsec,
        s.error_uncertainty_arcsec,
    );
    machine_edit::replace_table(text, "commissioning.spindle_encoder", &block)
}

#[cfg(test)]
mod tests {
    use super::*;

    const COUNT_DEG: f64 = 0.036;

    #[test]
    fn settings_outside_their_limits_are_refused_before_anything_turns() {
        let o = |speeds: &[f64], seconds: f64| EncoderOptions {
            speeds_rpm: speeds.to_vec(),
            seconds,
        };
        let refused = |o: &EncoderOptions, says: &str| match check_options(o, 212.2) {
            Err(Stop::Refused(t)) => assert!(t.contains(says), "{t}"),
            other => panic!("{other:?}"),
        };
        refused(&o(&[64.0, 130.0], 10.0), "at least 3");
        refused(&o(&[64.0, 130.0, 400.0], 10.0), "max_spindle_rpm");
        refused(&o(&[40.0, 130.0, 200.0], 10.0), "40 rpm is outside");
        refused(&o(&[100.0, 130.0, 190.0], 10.0), "factor 2");
        refused(&o(&[64.0, 130.0, 200.0], 2.0), "--seconds");
        let defaults = default_speeds_rpm(212.2);
        assert_eq!(check_options(&o(&defaults, 12.0), 212.2), Ok(()));
        assert!(
            !defaults.iter().any(|&r| locks_to_counts(r, COUNT_DEG, 0.001)),
            "{defaults:?}"
        );
    }

    #[test]
    fn a_speed_of_whole_counts_a_cycle_is_found() {
        // 10 000 counts a turn at 1 kHz: 6 rpm a count a cycle.
        assert!(locks_to_counts(90.0, COUNT_DEG, 0.001));
        assert!(locks_to_counts(210.1, COUNT_DEG, 0.001));
        assert!(!locks_to_counts(93.7, COUNT_DEG, 0.001));
    }

    #[test]
    fn a_held_reading_is_not_taken() {
        let mut r = Vec::new();
        for (t, d) in [(0.0, 1.0), (0.001, 1.5), (0.002, 1.5), (0.003, 2.0)] {
            take(&mut r, t, d);
        }
        assert_eq!(r.iter().map(|x| x.t_s).collect::<Vec<_>>(), [0.0, 0.001, 0.003]);
    }

    #[test]
    fn the_spindle_is_settled_once_its_mean_speed_holds_over_whole_turns() {
        // 100 rpm reached by an exponential from 110 with a 2 s time constant, and a 60
        // arcsec swing once per turn that the whole-turn windows do not see.
        let mut s = Settling::new(100.0);
        let mut angle = 0.0f64;
        let mut settled = None;
        for k in 1..60_000 {
            let t = f64::from(k) * 0.001;
            let rpm = 100.0 + 10.0 * (-t / 2.0).exp();
            angle += rpm * 6.0 * 0.001;
            let reading = angle + 60.0 / 3600.0 * angle.to_radians().sin();
            if s.steady(t, reading) && settled.is_none() {
                settled = Some(t);
            }
        }
        let at = settled.expect("settled");
        // Within 0.05 % a second: 10 % e^(-t/2) / 2 s < 0.0005 from t = 9.2 s; and not
        // before SETTLE_MIN_S (12 s) after the first reading, when the loop's trim stands.
        assert!(
            (SETTLE_MIN_S..SETTLE_MIN_S + 3.0).contains(&at),
            "settled at {at} s"
        );
        assert_eq!(s.since_s(), Some(at));
        // A speed that never comes near the one held never settles.
        let mut far = Settling::new(130.0);
        assert!(!(1..20_000).any(|k| far.steady(f64::from(k) * 0.001, f64::from(k) * 0.6)));
    }
}
