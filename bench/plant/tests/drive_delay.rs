//! The table drive's delay identified from a run (`hob log delay` on a recording), against
//! the simulated machine: with the shipped drives it is the period of interpolation the
//! machine file assumes; a drive with less velocity feed-forward lags by a share of its
//! position loop's time constant on top, and the identification sees it.
#![allow(clippy::unwrap_used)]

mod common;

use hob_ipc::codec::State;
use hob_logger::delay::{TableSample, identify};
use hob_plant::sim::{SimOptions, run_program};

fn identified_drive_delay_us(plant: &hob_plant::config::PlantConfig) -> f64 {
    let (job, cycle, plan) = common::program("demo-short-spur-z17-m5.toml", &[]);
    let machine = common::machine();
    // A trace row carries the command applied at its SYNC, computed the cycle before; a
    // recording carries each cycle's own command: shifted by one row to read as a log.
    let mut rows: Vec<(f64, f64, bool)> = Vec::new();
    let s = run_program(
        &machine,
        plant,
        &cycle,
        &plan,
        &job,
        &SimOptions::default(),
        &mut |row| {
            rows.push((
                row.table_cmd_deg,
                row.table_deg,
                row.state == State::Cut && row.sync_err_arcsec.is_some(),
            ));
        },
    )
    .unwrap();
    let samples: Vec<TableSample> = rows
        .windows(2)
        .map(|w| TableSample {
            command_deg: w[1].0,
            actual_deg: w[0].1,
            in_cut: w[0].2 && w[1].2,
        })
        .collect();
    assert!(s.completed, "{:?}", s.fault);
    let assumed_s = f64::from(machine.control.drive_delay_us) * 1e-6;
    let d = identify(&samples, 1e-3, assumed_s).expect("a cut to identify from");
    println!("{}", hob_logger::delay::text(&d, assumed_s));
    d.drive_delay_s * 1e6
}

#[test]
fn the_shipped_drives_delay_is_the_one_the_machine_file_assumes() {
    let us = identified_drive_delay_us(&common::plant());
    assert!((us - 1000.0).abs() < 50.0, "{us} us");
}

#[test]
fn a_drive_with_less_feed_forward_is_seen_to_lag() {
    // With 90 % velocity feed-forward the position loop (60 Hz) lags at a steady speed by
    // the rest over its gain, 0.1 / (2 pi 60 Hz) = 265 us, on top of the interpolation.
    // (Without feed-forward the lag, 2.65 ms, is a following-error fault in the cut.)
    let mut plant = common::plant();
    plant.table.velocity_feed_forward = 0.9;
    let us = identified_drive_delay_us(&plant);
    assert!((us - 1265.0).abs() < 60.0, "{us} us");
}
