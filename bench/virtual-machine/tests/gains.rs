//! The drives' loop gains over the CAN bus (an in-memory bus, the virtual machine in a
//! thread): hob-sim serves 0x60F9 / 0x60FB, an SDO write reaches the running servo and reads
//! back, a value out of range is aborted, and the master's boot writes the machine file's
//! commissioned set to the table drive it names (and to no other).
#![allow(clippy::unwrap_used)]

use hob_can_transport::{MemoryBus, SystemClock};
use hob_canopen::sdo::{AbortCode, SdoError};
use hob_master::{boot, sdo_read, sdo_write};
use hob_plant::config::PlantConfig;
use hob_plant::plant::Start;
use hob_plant::servo::ServoGains;
use hob_process_image::gains::DriveGains;
use hob_process_image::plan::BusPlan;
use hob_setup::config::machine::MachineConfig;
use hob_setup::config::machine::commissioning::TableDriveGainsRecord;
use hob_virtual_machine::runner::VmThread;
use hob_virtual_machine::virtual_machine::VirtualMachine;
use std::path::{Path, PathBuf};
use std::time::Duration;

const TIMEOUT: Duration = Duration::from_millis(500);

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn machine() -> MachineConfig {
    hob_store::files::load_machine(&root().join("config/machine.toml")).unwrap()
}

/// The virtual machine of `m` on a fresh bus, booted by the master: the bus, the thread,
/// the boot's answer.
fn booted(m: &MachineConfig) -> (MemoryBus, VmThread, hob_master::Booted) {
    let plant = PlantConfig::load(&root().join("config/plant.toml")).unwrap();
    let start = Start {
        table_deg: 0.0,
        x_mm: m.x.homing.home_position_mm,
        y_mm: m.y.homing.home_position_mm,
    };
    let vm = VirtualMachine::new(m, &plant, start, 10);
    let mut bus = MemoryBus::new(4096);
    let vm = VmThread::spawn(vm, bus.endpoint());
    let booted = boot(
        &BusPlan::from_machine(m),
        &mut bus,
        &mut SystemClock::new(),
        TIMEOUT,
    )
    .unwrap();
    (bus, vm, booted)
}

/// The example record, for the drive that names itself `serial` (hob-sim's drives
/// are vendor 0x0B0B, product 0x00020192, serial 0x1000 + node-ID).
fn record(serial: u32) -> TableDriveGainsRecord {
    TableDriveGainsRecord {
        utc: "2026-11-29T09:10:05Z".parse().unwrap(),
        velocity_kp_nm_s_per_rad: 1.91,
        velocity_integral_time_ms: 8.6,
        position_kv_per_s: 100.5,
        previous_velocity_kp_nm_s_per_rad: 7.5,
        previous_velocity_integral_time_ms: 1.6,
        previous_position_kv_per_s: 377.0,
        velocity_gain_margin_db: 9.1,
        velocity_phase_margin_deg: 45.0,
        position_gain_margin_db: 8.9,
        position_phase_margin_deg: 41.0,
        mesh_antiresonance_hz: 50.3,
        mesh_resonance_hz: 137.0,
        table_drive_vendor_id: 0x0B0B,
        table_drive_product_code: 0x0002_0192,
        table_drive_serial: serial,
    }
}

fn with_record(serial: u32) -> MachineConfig {
    let mut m = machine();
    m.commissioning
        .get_or_insert_with(Default::default)
        .table_drive_gains = Some(record(serial));
    m
}

fn close(a: ServoGains, b: ServoGains) -> bool {
    let near = |x: f64, y: f64| (x - y).abs() <= 1e-9 * y.abs();
    near(a.velocity_kp_nm_s_per_rad, b.velocity_kp_nm_s_per_rad)
        && near(a.velocity_integral_time_s, b.velocity_integral_time_s)
        && near(a.position_kv_per_s, b.position_kv_per_s)
}

fn u32_of(b: &[u8]) -> u32 {
    u32::from_le_bytes(b.try_into().unwrap())
}

#[test]
fn a_gain_written_by_sdo_reaches_the_servo_and_reads_back() {
    let m = machine();
    let (mut bus, vm, booted) = booted(&m);
    let b = m.table.can_node_id;
    // The boot read the drive's own (the shipped B tuning, in the objects' units).
    let own = booted.nodes[0].gains.unwrap();
    assert!(booted.nodes[1..].iter().all(|n| n.gains.is_none()));
    let clock = &mut SystemClock::new();
    sdo_write(&mut bus, clock, b, 0x60FB, 1, &100_500u32.to_le_bytes(), TIMEOUT).unwrap();
    sdo_write(&mut bus, clock, b, 0x60F9, 2, &8_600u32.to_le_bytes(), TIMEOUT).unwrap();
    assert_eq!(
        u32_of(&sdo_read(&mut bus, clock, b, 0x60FB, 1, TIMEOUT).unwrap()),
        100_500
    );
    assert_eq!(
        u32_of(&sdo_read(&mut bus, clock, b, 0x60F9, 2, TIMEOUT).unwrap()),
        8_600
    );
    // Zero and absurd values are refused, the value held unchanged.
    for (index, sub, bad) in [(0x60F9, 1, 0u32), (0x60F9, 2, 5), (0x60FB, 1, u32::MAX)] {
        let e = sdo_write(&mut bus, clock, b, index, sub, &bad.to_le_bytes(), TIMEOUT).unwrap_err();
        assert_eq!(
            e,
            SdoError::Aborted {
                index,
                sub,
                code: AbortCode(0x0609_0030)
            }
        );
    }
    assert_eq!(
        u32_of(&sdo_read(&mut bus, clock, b, 0x60F9, 1, TIMEOUT).unwrap()),
        own.values[0]
    );
    let vm = vm.stop().unwrap();
    let want = ServoGains {
        velocity_kp_nm_s_per_rad: own.velocity_kp_nm_s_per_rad(),
        velocity_integral_time_s: 8.6e-3,
        position_kv_per_s: 100.5,
    };
    let got = vm.servo_gains(0);
    // The velocity gain keeps the servo's own (the object's rounding is not applied to it).
    assert!((got.velocity_kp_nm_s_per_rad - want.velocity_kp_nm_s_per_rad).abs() < 1e-4);
    assert_eq!(
        (got.velocity_integral_time_s, got.position_kv_per_s),
        (8.6e-3, 100.5)
    );
    // X was not touched.
    let x = vm.servo_gains(1);
    assert!(x.position_kv_per_s != 100.5, "{x:?}");
}

#[test]
fn the_boot_writes_a_commissioned_set_to_the_table_drive_it_names() {
    let m = with_record(0x1000 + u32::from(machine().table.can_node_id));
    let (_bus, vm, booted) = booted(&m);
    assert_eq!(
        booted.nodes[0].gains,
        Some(DriveGains {
            values: [19_100, 8_600, 100_500]
        })
    );
    let vm = vm.stop().unwrap();
    let want = ServoGains {
        velocity_kp_nm_s_per_rad: 1.91,
        velocity_integral_time_s: 8.6e-3,
        position_kv_per_s: 100.5,
    };
    assert!(close(vm.servo_gains(0), want), "{:?}", vm.servo_gains(0));
}

#[test]
fn a_set_measured_on_another_drive_is_not_written() {
    let m = with_record(0x0000_7777);
    let (_bus, vm, booted) = booted(&m);
    let own = booted.nodes[0].gains.unwrap();
    assert_ne!(own.values, [19_100, 8_600, 100_500]);
    let vm = vm.stop().unwrap();
    assert!(vm.servo_gains(0).position_kv_per_s != 100.5);
    // The drive's own, as the servo's start-up bandwidths make them.
    assert!((vm.servo_gains(0).position_kv_per_s - own.position_kv_per_s()).abs() < 1e-3);
}
