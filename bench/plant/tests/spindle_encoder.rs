//! The spindle encoder's error against the controller's identifier (issue 33): the plant's
//! encoder no longer errs by the identifier's own model only. Hidden in the plant: harmonics
//! of the error at two and three per turn, and a true once-per-turn speed variation of the
//! spindle (a torque: an unbalance, an eccentric pulley) that the encoder reads correctly.
//! The identifier (`hob_control::eccentricity`, a single-speed fit of a once-per-turn sine)
//! finds the once-per-turn error within 10 % with the harmonics beside it; a true speed
//! variation it takes for an encoder error. Commissioning tells them apart
//! (`hob_commission::encoder`, what `hob commission encoder` runs: the spindle held at four
//! speeds, each fitted, the once-per-turn parts split by how they go with speed), on three
//! plants whose hidden error, harmonics and swing differ; with its record the identifier
//! keeps only the encoder's share.
#![allow(clippy::unwrap_used)]

mod common;

use hob_commission::encoder::{self, fit};
use hob_control::eccentricity::EccentricityIdentifier;
use hob_control::{Command, ControlParams};
use hob_plant::config::PlantConfig;
use hob_setup::config::machine::commissioning::SpindleSwing;

/// The once-per-turn amplitude the identifier finds, arcsec, with the spindle at `rpm` for
/// 40 s on `plant` (fed the plant's readings as the loop reads them; the identifier works
/// from 130 rpm up, its fit spanning four turns).
fn identified_arcsec(plant: &PlantConfig, rpm: f64) -> f64 {
    identified_with(plant, rpm, None)
}

/// [`identified_arcsec`] by an identifier that knows the spindle's `swing`.
fn identified_with(plant: &PlantConfig, rpm: f64, swing: Option<SpindleSwing>) -> f64 {
    let (job, cycle, plan) = common::short_spur(&[]);
    let mut sim = common::powered_up_on(plant, &job, &cycle, &plan);
    let p = ControlParams::from_machine(&common::machine());
    let mut id = EccentricityIdentifier::new(
        p.period_s,
        p.encoder_identification_s,
        1.0 / p.spindle.counts_per_unit,
    )
    .with_swing(swing);
    sim.command(Command::SpindleOn { rpm }).unwrap();
    // Up to speed first (the VFD's ramp), then 40 s at it.
    for n in 0..45_000 {
        sim.step();
        if n >= 5_000 {
            let reading_deg = p.spindle.to_units(i64::from(sim.plant.spindle_counts()));
            id.update(reading_deg, true);
        }
    }
    id.amplitude_arcsec()
}

fn with(edit: impl Fn(&mut PlantConfig)) -> PlantConfig {
    let mut plant = common::plant();
    plant.spindle.encoder_error_arcsec = 0.0;
    edit(&mut plant);
    plant
}

#[test]
fn the_once_per_turn_error_is_found_within_10_percent_beside_its_harmonics() {
    let plant = with(|p| {
        p.spindle.encoder_error_arcsec = 26.0;
        p.spindle.encoder_error_2_arcsec = 6.0;
        p.spindle.encoder_error_3_arcsec = 3.0;
    });
    let found = identified_arcsec(&plant, 200.0);
    println!("26 arcsec once per turn, 6 and 3 at two and three: {found:.2} arcsec found");
    assert!((found - 26.0).abs() <= 2.6, "{found} arcsec");
}

#[test]
fn a_true_speed_variation_is_taken_for_an_encoder_error() {
    // A perfect encoder; the spindle truly swings once per turn (0.2 Nm: about 27 arcsec at
    // 200 rpm against the VFD's slip, 41 at 140 rpm; measured 2026-11-27).
    let plant = with(|p| p.spindle.once_per_turn_torque_nm = 0.2);
    let found = identified_arcsec(&plant, 200.0);
    println!("a perfect encoder, a true once-per-turn swing: {found:.2} arcsec found");
    assert!(
        found > 10.0,
        "{found} arcsec: the identifier told the swing from an encoder error"
    );
    let none = identified_arcsec(&with(|_| {}), 200.0);
    println!("a perfect encoder, no swing: {none:.2} arcsec found");
    assert!(none < 5.0, "{none} arcsec of nothing");
}

/// How long each speed is read, s (the CLI's default).
const SECONDS: f64 = 30.0;

/// Three plants whose hidden encoder error (once, twice, three times per turn, arcsec)
/// differs, none the shipped, and a spindle without a true swing: (error, 2nd, 3rd, torque
/// Nm).
const ENCODER_PLANTS: [(f64, f64, f64, f64); 3] =
    [(15.0, 4.0, 2.0, 0.0), (40.0, 8.0, 0.0, 0.0), (8.0, 3.0, 1.5, 0.0)];
/// Two with a true once-per-turn torque beside the error (an unbalance).
const SWING_PLANTS: [(f64, f64, f64, f64); 2] = [(15.0, 4.0, 2.0, 0.1), (12.0, 3.0, 1.5, 0.2)];

fn encoder_plant((e1, e2, e3, torque): (f64, f64, f64, f64)) -> PlantConfig {
    with(|p| {
        p.spindle.encoder_error_arcsec = e1;
        p.spindle.encoder_error_2_arcsec = e2;
        p.spindle.encoder_error_3_arcsec = e3;
        p.spindle.once_per_turn_torque_nm = torque;
    })
}

/// `hob commission encoder` on the simulated machine: the spindle at each of the default
/// speeds in turn, read from the cycle it settled ([`encoder::Settling`], as the procedure
/// waits it) for [`SECONDS`], the loop's raw readings (`Status::spindle_reading_deg`, what
/// the state stream carries) fitted and split by the product's own code.
fn commissioned(plant: &PlantConfig) -> fit::Separation {
    let (job, cycle, plan) = common::short_spur(&[]);
    let mut sim = common::powered_up_on(plant, &job, &cycle, &plan);
    let m = common::machine();
    let p = ControlParams::from_machine(&m);
    let speeds = encoder::default_speeds_rpm(m.spindle.max_spindle_rpm);
    let mut fits = Vec::new();
    let mut k = 0u64;
    for &rpm in &speeds {
        let mut settling = encoder::Settling::new(rpm);
        let mut readings = Vec::new();
        let mut end_s = f64::INFINITY;
        loop {
            // The loop's SPINDLE HOLD, renewed every 100 ms as the procedure renews it.
            if k.is_multiple_of(100) {
                sim.command(Command::SpindleHold { rpm }).unwrap();
            }
            sim.step();
            k += 1;
            let t_s = k as f64 * p.period_s;
            let reading_deg = sim.controller.status().spindle_reading_deg;
            if settling.steady(t_s, reading_deg) {
                end_s = end_s.min(t_s + encoder::read_s(SECONDS, rpm));
                encoder::take(&mut readings, t_s, reading_deg);
            }
            assert!(t_s < 900.0, "{rpm} rpm never settled ({} rpm)", settling.last_rpm);
            if t_s >= end_s {
                break;
            }
        }
        fits.push(fit::fit_speed(&readings, 1.0 / p.spindle.counts_per_unit).unwrap());
    }
    let top = speeds.iter().fold(0.0f64, |a, &r| a.max(r));
    let s = fit::separate(&fits, top).unwrap();
    println!("{}", encoder::report(&fits, &s));
    s
}

fn say(hidden: (f64, f64, f64, f64), s: &fit::Separation) {
    println!(
        "hidden {:.1} arcsec (2nd {:.1}, 3rd {:.1}), {:.2} Nm once per turn: found {:.2} +- {:.2} \
         (2nd {:.2}, 3rd {:.2}), a swing of {:.1} arcsec at {:.0} rpm",
        hidden.0,
        hidden.1,
        hidden.2,
        hidden.3,
        s.encoder[0].amplitude_arcsec(),
        s.error_uncertainty_arcsec,
        s.encoder[1].amplitude_arcsec(),
        s.encoder[2].amplitude_arcsec(),
        s.variation.amplitude_arcsec(),
        s.reference_rpm
    );
}

#[test]
fn commissioning_finds_the_encoders_error_on_three_plants_within_10_percent() {
    for hidden in ENCODER_PLANTS {
        let s = commissioned(&encoder_plant(hidden));
        say(hidden, &s);
        let found = s.encoder[0].amplitude_arcsec();
        assert!(
            (found - hidden.0).abs() <= 0.1 * hidden.0,
            "{} arcsec hidden, {found:.2} found",
            hidden.0
        );
        assert_eq!(encoder::precise_enough(&s), Ok(()), "not proposed");
        assert!(s.variation.amplitude_arcsec() < 1.0, "a swing of nothing claimed");
        for k in 1..3 {
            let h = [hidden.1, hidden.2][k - 1];
            let f = s.encoder[k].amplitude_arcsec();
            assert!(
                (f - h).abs() <= 1.5,
                "harmonic {}: {h} hidden, {f:.2} found",
                k + 1
            );
        }
    }
}

/// Beside a true swing the error is an extrapolation to infinite speed, and over this
/// machine's speeds (64-212 rpm) an inertia bends the swing's curve by less than the
/// speeds' noise: the procedure sees the swing, and either finds the error within 10 % or
/// says how far it is known and writes nothing. It is never confidently wrong.
#[test]
fn beside_a_true_swing_the_error_is_found_or_the_record_refused() {
    for hidden in SWING_PLANTS {
        let s = commissioned(&encoder_plant(hidden));
        say(hidden, &s);
        let found = s.encoder[0].amplitude_arcsec();
        assert!(s.variation.amplitude_arcsec() > 5.0, "the swing was not seen");
        match encoder::precise_enough(&s) {
            Ok(()) => assert!(
                (found - hidden.0).abs() <= 0.1 * hidden.0,
                "proposed {found:.2} +- {:.2} for {} hidden",
                s.error_uncertainty_arcsec,
                hidden.0
            ),
            Err(why) => {
                println!("refused: {why}");
                assert!(
                    (found - hidden.0).abs() <= s.error_uncertainty_arcsec,
                    "{found:.2} +- {:.2} does not hold the {} hidden",
                    s.error_uncertainty_arcsec,
                    hidden.0
                );
            }
        }
    }
}

/// The loop keeps a held spindle's trim once it has been at speed
/// `HELD_SPINDLE_TRIM_FREEZE_S`: from then on the VFD's reference stands still (the readings
/// of `hob commission encoder` see the spindle as its drive turns it, not the loop's
/// reaction through a coupler that updates the reference every 50 ms: docs/commands.md);
/// a spindle switched on by SPINDLE ON keeps being trimmed.
#[test]
fn a_held_spindle_keeps_its_trim_once_at_speed() {
    let plant = encoder_plant((15.0, 4.0, 2.0, 0.0));
    let (job, cycle, plan) = common::short_spur(&[]);
    let freeze_s = hob_setup::config::machine::commissioning::HELD_SPINDLE_TRIM_FREEZE_S;
    // (s, analog volts) over 25 s at 110 rpm, held or switched on.
    let run = |held: bool| {
        let mut sim = common::powered_up_on(&plant, &job, &cycle, &plan);
        if !held {
            sim.command(Command::SpindleOn { rpm: 110.0 }).unwrap();
        }
        (0..25_000u32)
            .map(|k| {
                if held && k.is_multiple_of(100) {
                    sim.command(Command::SpindleHold { rpm: 110.0 }).unwrap();
                }
                sim.step();
                (f64::from(k) * 1e-3, sim.last_outputs().spindle_analog_v)
            })
            .collect::<Vec<_>>()
    };
    let changes_after =
        |v: &[(f64, f64)], t0: f64| v.windows(2).filter(|w| w[0].0 >= t0 && w[1].1 != w[0].1).count();
    let held = run(true);
    let on = run(false);
    // The spindle is at speed within a few seconds; the trim stands from freeze_s after.
    let late = freeze_s + 8.0;
    assert_eq!(
        changes_after(&held, late),
        0,
        "the held spindle's reference changed after {late} s"
    );
    assert!(
        changes_after(&held, 0.0) > 0,
        "the held spindle was never trimmed"
    );
    assert!(
        changes_after(&on, late) > 100,
        "SPINDLE ON's reference stood still: {} changes",
        changes_after(&on, late)
    );
}
