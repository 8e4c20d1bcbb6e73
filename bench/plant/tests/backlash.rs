//! `hob commission backlash` on the simulated machine (issue 33's step 3): on three plants
//! whose hidden worm backlash differs (6, 25 and 50 arcsec, none the shipped 10), the table
//! jogged +, -, + at the procedure's default speed and time, the loop's state (the motor's
//! position as table angle, and the gauge on the table's rim as the bus delivers it: every
//! 50th cycle, `TABLE_GAUGE_EVERY_SYNCS`) fitted by the product's own code
//! (`hob_commission::backlash`). The lost motion it finds is the backlash plus the mesh's
//! wind-up under the table's bearing friction (2 T / k: at 3 deg/min a tenth of an arcsec
//! here); the issue asks for the backlash within 10 %.
#![allow(clippy::unwrap_used)]

mod common;

use common::{HIDDEN_PLANTS, hidden_plant};
use hob_commission::backlash::fit::{GaugeSample, Jog, Way};
use hob_commission::backlash::{self, BacklashOptions};
use hob_control::fault::Axis;
use hob_control::{Command, Direction};
use hob_plant::config::PlantConfig;
use hob_setup::config::machine::TABLE_GAUGE_EVERY_SYNCS;

fn jogs(plant: &PlantConfig, o: &BacklashOptions) -> Vec<Jog> {
    let (job, cycle, plan) = common::short_spur(&[]);
    let mut sim = common::powered_up_on(plant, &job, &cycle, &plan);
    let mut out = Vec::new();
    let mut k = 0u64;
    for (way, direction) in [
        (Way::Positive, Direction::Positive),
        (Way::Negative, Direction::Negative),
        (Way::Positive, Direction::Positive),
    ] {
        let jog = Command::JogContinuous {
            axis: Axis::B,
            direction,
            speed_per_min: o.speed_deg_min,
        };
        let mut samples = Vec::new();
        let renewals = (o.seconds / 0.1).round() as usize;
        for _ in 0..renewals {
            assert_eq!(sim.command(jog), Ok(()));
            for _ in 0..100 {
                sim.step();
                k += 1;
                let s = sim.controller.status();
                samples.push(GaugeSample {
                    table_deg: s.table_deg,
                    command_deg: s.table_cmd_deg,
                    gauge_counts: if k.is_multiple_of(u64::from(TABLE_GAUGE_EVERY_SYNCS)) {
                        s.table_gauge_counts
                    } else {
                        f64::NAN
                    },
                });
            }
        }
        assert_eq!(sim.command(Command::JogRelease), Ok(()));
        common::run(&mut sim, 0.6, |_| false);
        k += 600;
        out.push(Jog { way, samples });
    }
    out
}

#[test]
fn the_backlash_is_found_within_10_percent_on_three_plants() {
    let o = BacklashOptions::default();
    for (delay_us, backlash_arcsec, encoder_arcsec) in HIDDEN_PLANTS {
        let plant = hidden_plant(delay_us, backlash_arcsec, encoder_arcsec);
        let l = backlash::measure(&jogs(&plant, &o)).unwrap();
        println!(
            "hidden {backlash_arcsec} arcsec: {}",
            backlash::report(&l, &o).trim_end()
        );
        assert!(
            (l.arcsec - backlash_arcsec).abs() <= 0.1 * backlash_arcsec,
            "{backlash_arcsec} arcsec hidden: {l:?}"
        );
        assert!(backlash::precise_enough(&l), "{l:?}");
        // Its uncertainty holds the truth (the wind-up is a tenth of an arcsec).
        assert!(
            (l.arcsec - backlash_arcsec).abs() <= l.uncertainty_arcsec + 0.3,
            "{backlash_arcsec} arcsec hidden: {l:?}"
        );
    }
}

#[test]
fn without_a_gauge_the_state_carries_none() {
    let mut plant = common::plant();
    plant.peripherals.table_gauge = None;
    let e = backlash::measure(&jogs(&plant, &BacklashOptions::default())).unwrap_err();
    assert!(e.to_string().contains("steady readings of the gauge"), "{e}");
}
