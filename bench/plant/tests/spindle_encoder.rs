//! The spindle encoder's error against the controller's identifier (issue 33): the plant's
//! encoder no longer errs by the identifier's own model only. Hidden in the plant: harmonics
//! of the error at two and three per turn, and a true once-per-turn speed variation of the
//! spindle (a torque: an unbalance, an eccentric pulley) that the encoder reads correctly.
//! The identifier (`hob_control::eccentricity`, a single-speed fit of a once-per-turn sine)
//! finds the once-per-turn error within 10 % with the harmonics beside it; a true speed
//! variation it takes for an encoder error (what issue 33's commissioning must tell apart,
//! by fits at several speeds: docs/mechanism.md, section 4; not built yet).
#![allow(clippy::unwrap_used)]

mod common;

use hob_control::eccentricity::EccentricityIdentifier;
use hob_control::{Command, ControlParams};
use hob_plant::config::PlantConfig;

/// The once-per-turn amplitude the identifier finds, arcsec, with the spindle at `rpm` for
/// 40 s on `plant` (fed the plant's readings as the loop reads them; the identifier works
/// from 130 rpm up, its fit spanning four turns).
fn identified_arcsec(plant: &PlantConfig, rpm: f64) -> f64 {
    let (job, cycle, plan) = common::short_spur(&[]);
    let mut sim = common::powered_up_on(plant, &job, &cycle, &plan);
    let p = ControlParams::from_machine(&common::machine());
    let mut id = EccentricityIdentifier::new(
        p.period_s,
        p.encoder_identification_s,
        1.0 / p.spindle.counts_per_unit,
    );
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
