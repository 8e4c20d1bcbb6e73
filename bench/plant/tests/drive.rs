//! The in-process simulation's drives through `Plant::apply` and `Plant::latch`, as the
//! control core sees them: counters, modes of operation, homing with the machine file's
//! parameters, the hardware-limit fault.
#![allow(clippy::unwrap_used)]

mod common;

use common::{holding as outputs, machine, plant};
use hob_control::{CycleOutputs, DriveMode, HomingBits};
use hob_plant::config::DriveCounters;
use hob_plant::plant::{Plant, Start};

const START: Start = Start {
    x_mm: 120.0,
    y_mm: 200.0,
    table_deg: 30.0,
};

fn period(p: &mut Plant, o: &CycleOutputs) {
    let t = p.time_s() + 0.001;
    p.apply(o);
    p.advance_to(t);
}

#[test]
fn referenced_counters_read_the_machine_position_and_incremental_ones_start_at_zero() {
    let m = machine();
    let mut cfg = plant();
    assert_eq!(
        cfg.simulation.drive_counters,
        DriveCounters::Incremental,
        "the shipped file: counters know nothing at power-on, as the machine's 2500-line encoders"
    );
    cfg.simulation.drive_counters = DriveCounters::Referenced;
    let p = Plant::new(&cfg, &m, START, 10);
    let i = p.latch();
    assert_eq!(i.x.position_counts, 360_000, "120 mm");
    assert_eq!(i.y.position_counts, 600_000, "200 mm");
    cfg.simulation.drive_counters = DriveCounters::Incremental;
    let p = Plant::new(&cfg, &m, START, 10);
    let i = p.latch();
    assert_eq!(
        (i.table.position_counts, i.x.position_counts, i.y.position_counts),
        (0, 0, 0)
    );
    assert!(
        (p.x_mm() - 120.0).abs() < 1e-9,
        "the machine stands where it stood"
    );
}

#[test]
fn x_and_y_home_in_process_with_the_machine_files_parameters() {
    let m = machine();
    let mut cfg = plant();
    cfg.simulation.drive_counters = DriveCounters::Incremental;
    let mut p = Plant::new(&cfg, &m, START, 10);
    let mut o = outputs(&p);
    for _ in 0..700 {
        period(&mut p, &o);
    }
    assert_eq!(p.latch().x.mode_display, 8, "CSP by default");
    o.drive_modes = [DriveMode::CyclicPosition, DriveMode::Homing, DriveMode::Homing];
    period(&mut p, &o);
    let i = p.latch();
    assert_eq!(
        (i.table.mode_display, i.x.mode_display, i.y.mode_display),
        (8, 6, 6)
    );
    assert_eq!(
        i.x.homing,
        HomingBits {
            attained: false,
            error: false,
            target_reached: true
        },
        "not started"
    );
    o.homing_start = [false, true, true];
    let done = HomingBits {
        attained: true,
        error: false,
        target_reached: true,
    };
    let mut cycles = 0;
    while (p.latch().x.homing != done || p.latch().y.homing != done) && cycles < 60_000 {
        period(&mut p, &o);
        cycles += 1;
    }
    let i = p.latch();
    assert_eq!((i.x.homing, i.y.homing), (done, done), "after {cycles} cycles");
    assert!(i.x.enabled && !i.x.fault && i.y.enabled && !i.y.fault);
    assert!((p.x_mm() - 240.0).abs() < 0.002 && (p.y_mm() - 440.0).abs() < 0.002);
    assert!(
        (i.x.position_counts - 720_000).abs() <= 2,
        "{}",
        i.x.position_counts
    );
    assert!(
        (i.y.position_counts - 1_320_000).abs() <= 2,
        "{}",
        i.y.position_counts
    );
}

#[test]
fn a_drive_running_into_a_hardware_limit_faults_until_reset_by_a_new_enable() {
    let m = machine();
    let mut p = Plant::new(&plant(), &m, Start { x_mm: 245.0, ..START }, 10);
    let mut o = outputs(&p);
    let mut faulted_at = None;
    for _ in 0..1500 {
        o.x_target_counts += 30; // 10 mm/s towards 252 mm
        period(&mut p, &o);
        if faulted_at.is_none() && p.latch().x.fault {
            faulted_at = Some(p.x_mm());
        }
    }
    let at = faulted_at.expect("X faulted");
    assert!((252.0..252.1).contains(&at), "{at}");
    assert!(!p.latch().x.enabled);
    // The master's fault reset and enable: the fault clears; the axis may move back.
    o.drives_enabled = false;
    period(&mut p, &o);
    o = CycleOutputs {
        drives_enabled: true,
        ..outputs(&p)
    };
    period(&mut p, &o);
    assert!(!p.latch().x.fault);
}
