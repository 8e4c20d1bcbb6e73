//! The drives as CiA 402 drives towards any master, driven frame by frame (no CAN): modes
//! by SDO and RPDO, the mode display, homing methods 3 to 6 from either side of the home
//! switch, homing errors and the hardware-limit fault.
#![allow(clippy::unwrap_used)]

use super::*;
use hob_canopen::cia402::HomingProgress;
use hob_canopen::frame::{NMT, SYNC};
use hob_plant::config::Side;
use std::path::{Path, PathBuf};

const X: u8 = 3;
const Y: u8 = 4;
const TABLE: u8 = 2;
const IO: u8 = 5;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn machine() -> MachineConfig {
    hob_store::files::load_machine(&root().join("config/machine.toml")).unwrap()
}

fn plant_config() -> PlantConfig {
    PlantConfig::load(&root().join("config/plant.toml")).unwrap()
}

fn vm_with(plant: &PlantConfig, start: Start) -> VirtualMachine {
    VirtualMachine::new(&machine(), plant, start, 10)
}

fn at(x_mm: f64, y_mm: f64) -> Start {
    Start {
        x_mm,
        y_mm,
        table_deg: 0.0,
    }
}

/// The answer of `node`'s SDO server to one request.
fn sdo(vm: &mut VirtualMachine, node: u8, request: [u8; 8]) -> Frame {
    let mut out = Vec::new();
    vm.on_frame(&Frame::new(0x600 + u16::from(node), &request), &mut out);
    *out.iter()
        .find(|f| f.id == 0x580 + u16::from(node))
        .expect("an SDO answer")
}

/// An expedited download of `data` (1, 2 or 4 bytes): Ok, or the abort code.
fn write(vm: &mut VirtualMachine, node: u8, index: u16, sub: u8, data: &[u8]) -> Result<(), u32> {
    let cmd = match data.len() {
        1 => 0x2F,
        2 => 0x2B,
        _ => 0x23,
    };
    let i = index.to_le_bytes();
    let mut r = [cmd, i[0], i[1], sub, 0, 0, 0, 0];
    r[4..4 + data.len()].copy_from_slice(data);
    let a = sdo(vm, node, r);
    match a.data[0] {
        0x60 => Ok(()),
        0x80 => Err(u32::from_le_bytes(a.data[4..8].try_into().unwrap())),
        other => panic!("unexpected SDO answer {other:#x}"),
    }
}

fn read(vm: &mut VirtualMachine, node: u8, index: u16, sub: u8) -> u32 {
    let i = index.to_le_bytes();
    let a = sdo(vm, node, [0x40, i[0], i[1], sub, 0, 0, 0, 0]);
    assert_eq!(a.data[0] & 0xE0, 0x40, "read {index:#x}:{sub}: {:x?}", a.data);
    u32::from_le_bytes(a.data[4..8].try_into().unwrap())
}

fn statusword(vm: &mut VirtualMachine, node: u8) -> u16 {
    read(vm, node, object::STATUSWORD, 0) as u16
}

fn nmt_start(vm: &mut VirtualMachine) {
    vm.on_frame(&Frame::new(NMT, &[0x01, 0]), &mut Vec::new());
}

/// One SYNC and its period's physics; the frames the nodes sent.
fn sync(vm: &mut VirtualMachine) -> Vec<Frame> {
    let mut out = Vec::new();
    vm.on_frame(&Frame::new(SYNC, &[]), &mut out);
    vm.settle();
    out
}

/// Nodes operational, PC-OK on (the safety chain closes), `node` walked to operation
/// enabled by SDO in `mode`.
fn enabled(vm: &mut VirtualMachine, node: u8, mode: i8) {
    nmt_start(vm);
    write(vm, IO, DIGITAL_OUTPUTS, 1, &[0x01]).unwrap();
    for _ in 0..700 {
        sync(vm);
    }
    assert!(vm.plant.safety_chain_closed());
    write(vm, node, object::MODES_OF_OPERATION, 0, &[mode as u8]).unwrap();
    let actual = read(vm, node, object::POSITION_ACTUAL, 0);
    write(vm, node, object::TARGET_POSITION, 0, &actual.to_le_bytes()).unwrap();
    for cw in [0x06u16, 0x07, 0x0F] {
        write(vm, node, object::CONTROLWORD, 0, &cw.to_le_bytes()).unwrap();
    }
    assert_eq!(
        PowerState::from_statusword(statusword(vm, node)),
        PowerState::OperationEnabled
    );
}

#[test]
fn supported_modes_are_announced_and_only_they_are_accepted_by_sdo() {
    let mut vm = vm_with(&plant_config(), at(150.0, 150.0));
    assert_eq!(
        read(&mut vm, X, object::SUPPORTED_MODES, 0),
        0xA0,
        "homing and CSP"
    );
    assert_eq!(read(&mut vm, Y, object::SUPPORTED_MODES, 0), 0xA0);
    assert_eq!(read(&mut vm, TABLE, object::SUPPORTED_MODES, 0), 0x80, "CSP only");
    // Switch on disabled: the mode takes effect and shows at once.
    assert_eq!(
        PowerState::from_statusword(statusword(&mut vm, X)),
        PowerState::SwitchOnDisabled
    );
    write(&mut vm, X, object::MODES_OF_OPERATION, 0, &[6]).unwrap();
    assert_eq!(read(&mut vm, X, object::MODES_DISPLAY, 0), 6);
    // Profile position (1), interpolated position (7), "no mode" (0) are not implemented:
    // refused with "value range exceeded", nothing changes.
    for mode in [1u8, 7, 0, 0xFF] {
        assert_eq!(
            write(&mut vm, X, object::MODES_OF_OPERATION, 0, &[mode]),
            Err(0x0609_0030),
            "mode {mode}"
        );
        assert_eq!(read(&mut vm, X, object::MODES_OF_OPERATION, 0), 6);
        assert_eq!(read(&mut vm, X, object::MODES_DISPLAY, 0), 6);
    }
    write(&mut vm, X, object::MODES_OF_OPERATION, 0, &[8]).unwrap();
    assert_eq!(read(&mut vm, X, object::MODES_DISPLAY, 0), 8);
    assert_eq!(
        write(&mut vm, TABLE, object::MODES_OF_OPERATION, 0, &[6]),
        Err(0x0609_0030),
        "the table does not home"
    );
    assert_eq!(read(&mut vm, TABLE, object::MODES_DISPLAY, 0), 0);
    // The homing objects: X and Y only, writable; a method not implemented is refused.
    let h = machine().x.homing;
    assert_eq!(read(&mut vm, X, object::HOMING_METHOD, 0), h.method as u32);
    assert_eq!(read(&mut vm, X, object::HOME_OFFSET, 0) as i32, 720_000, "240 mm");
    assert_eq!(read(&mut vm, X, object::HOMING_SPEEDS, 1), 30_000, "600 mm/min");
    assert_eq!(read(&mut vm, X, object::HOMING_SPEEDS, 2), 3_000, "60 mm/min");
    assert_eq!(read(&mut vm, X, object::HOMING_ACCELERATION, 0), 150_000);
    for method in [3u8, 4, 5, 6] {
        write(&mut vm, Y, object::HOMING_METHOD, 0, &[method]).unwrap();
    }
    for method in [1u8, 2, 35, 0xFF] {
        assert_eq!(
            write(&mut vm, Y, object::HOMING_METHOD, 0, &[method]),
            Err(0x0609_0030)
        );
    }
    assert_eq!(read(&mut vm, Y, object::HOMING_METHOD, 0), 6);
    write(&mut vm, Y, object::HOME_OFFSET, 0, &(-1234i32).to_le_bytes()).unwrap();
    assert_eq!(read(&mut vm, Y, object::HOME_OFFSET, 0) as i32, -1234);
    write(&mut vm, Y, object::HOMING_SPEEDS, 1, &99u32.to_le_bytes()).unwrap();
    write(&mut vm, Y, object::HOMING_ACCELERATION, 0, &77u32.to_le_bytes()).unwrap();
    assert_eq!(read(&mut vm, Y, object::HOMING_SPEEDS, 1), 99);
    assert_eq!(read(&mut vm, Y, object::HOMING_ACCELERATION, 0), 77);
    assert_eq!(
        write(&mut vm, TABLE, object::HOMING_METHOD, 0, &[3]),
        Err(0x0602_0000),
        "no homing objects on the table"
    );
}

/// RPDO2 = controlword + 0x6060 and TPDO2 = statusword + 0x6061 (event-driven), as the
/// master maps them, configured by SDO on `node`.
fn map_mode_pdos(vm: &mut VirtualMachine, node: u8) {
    let n = u32::from(node);
    write(vm, node, 0x1401, 1, &(0x8000_0300 + n).to_le_bytes()).unwrap();
    write(vm, node, 0x1601, 0, &[0]).unwrap();
    write(vm, node, 0x1601, 1, &0x6040_0010u32.to_le_bytes()).unwrap();
    write(vm, node, 0x1601, 2, &0x6060_0008u32.to_le_bytes()).unwrap();
    write(vm, node, 0x1601, 0, &[2]).unwrap();
    write(vm, node, 0x1401, 1, &(0x300 + n).to_le_bytes()).unwrap();
    write(vm, node, 0x1801, 1, &(0x8000_0280 + n).to_le_bytes()).unwrap();
    write(vm, node, 0x1A01, 0, &[0]).unwrap();
    write(vm, node, 0x1A01, 1, &0x6041_0010u32.to_le_bytes()).unwrap();
    write(vm, node, 0x1A01, 2, &0x6061_0008u32.to_le_bytes()).unwrap();
    write(vm, node, 0x1A01, 0, &[2]).unwrap();
    write(vm, node, 0x1801, 2, &[255]).unwrap();
    write(vm, node, 0x1801, 1, &(0x280 + n).to_le_bytes()).unwrap();
}

fn rpdo2(vm: &mut VirtualMachine, node: u8, cw: u16, mode: i8) -> Vec<Frame> {
    let c = cw.to_le_bytes();
    let mut out = Vec::new();
    vm.on_frame(
        &Frame::new(0x300 + u16::from(node), &[c[0], c[1], mode as u8]),
        &mut out,
    );
    out
}

fn tpdo2(frames: &[Frame], node: u8) -> Option<(u16, i8)> {
    frames
        .iter()
        .rfind(|f| f.id == 0x280 + u16::from(node))
        .map(|f| (u16::from_le_bytes([f.data[0], f.data[1]]), f.data[2] as i8))
}

#[test]
fn the_mode_display_follows_a_mode_written_by_rpdo_in_any_power_state_and_is_sent_on_change() {
    let mut vm = vm_with(&plant_config(), at(150.0, 150.0));
    map_mode_pdos(&mut vm, Y);
    nmt_start(&mut vm);
    write(&mut vm, IO, DIGITAL_OUTPUTS, 1, &[0x01]).unwrap();
    let first = sync(&mut vm);
    assert_eq!(tpdo2(&first, Y).map(|t| t.1), Some(0), "no mode yet");
    // Switch on disabled: the mode by RPDO takes effect at once.
    rpdo2(&mut vm, Y, 0x0000, 6);
    assert_eq!(read(&mut vm, Y, object::MODES_DISPLAY, 0), 6);
    let (sw, mode) = tpdo2(&sync(&mut vm), Y).expect("the changed 0x6061 sends TPDO2");
    assert_eq!(mode, 6);
    assert_eq!(PowerState::from_statusword(sw), PowerState::SwitchOnDisabled);
    assert_eq!(tpdo2(&sync(&mut vm), Y), None, "nothing changed: nothing sent");
    for _ in 0..700 {
        sync(&mut vm);
    }
    // To operation enabled in CSP, then to homing there: the mode changes with the
    // power state unchanged.
    let actual = read(&mut vm, Y, object::POSITION_ACTUAL, 0);
    write(&mut vm, Y, object::TARGET_POSITION, 0, &actual.to_le_bytes()).unwrap();
    for cw in [0x06u16, 0x07, 0x0F] {
        rpdo2(&mut vm, Y, cw, 8);
    }
    let (sw, mode) = tpdo2(&sync(&mut vm), Y).unwrap();
    assert_eq!(
        (PowerState::from_statusword(sw), mode),
        (PowerState::OperationEnabled, 8)
    );
    rpdo2(&mut vm, Y, 0x0F, 6);
    assert_eq!(read(&mut vm, Y, object::MODES_DISPLAY, 0), 6);
    let (sw, mode) = tpdo2(&sync(&mut vm), Y).unwrap();
    assert_eq!(
        (PowerState::from_statusword(sw), mode),
        (PowerState::OperationEnabled, 6)
    );
    assert_eq!(
        HomingProgress::from_statusword(sw),
        HomingProgress::NotStarted,
        "homing mode, not started: bit 10 only"
    );
    // An unsupported mode by RPDO is ignored; the controlword next to it is applied.
    rpdo2(&mut vm, Y, 0x07, 1);
    assert_eq!(read(&mut vm, Y, object::MODES_OF_OPERATION, 0), 6);
    assert_eq!(read(&mut vm, Y, object::MODES_DISPLAY, 0), 6);
    let (sw, mode) = tpdo2(&sync(&mut vm), Y).unwrap();
    assert_eq!(
        (PowerState::from_statusword(sw), mode),
        (PowerState::SwitchedOn, 6)
    );
}

/// The X axis's drive with its switch active on `side` of 241.6 mm (index pulses at
/// 240.000 + k * 3.333 mm), counters incremental, standing at `x_mm`.
fn homing_vm(side: Side, x_mm: f64) -> VirtualMachine {
    let mut p = plant_config();
    p.simulation.drive_counters = DriveCounters::Incremental;
    p.x.home_switch_active_side = side;
    let mut vm = vm_with(&p, at(x_mm, 150.0));
    // Incremental: the machine stands at a random position; put it at `x_mm`.
    let mut r = Plant::new(&p, &machine(), at(x_mm, 150.0), 10);
    std::mem::swap(&mut vm.plant, &mut r);
    vm
}

/// Homing on `node` with `method`, faster than the machine file's speeds; returns the
/// progress reported after each SYNC (repeats removed) until it ends or `max_syncs`.
fn home(vm: &mut VirtualMachine, node: u8, method: u8, offset: i32, max_syncs: u32) -> Vec<HomingProgress> {
    write(vm, node, object::HOMING_METHOD, 0, &[method]).unwrap();
    write(vm, node, object::HOME_OFFSET, 0, &offset.to_le_bytes()).unwrap();
    write(vm, node, object::HOMING_SPEEDS, 1, &30_000u32.to_le_bytes()).unwrap();
    write(vm, node, object::HOMING_SPEEDS, 2, &6_000u32.to_le_bytes()).unwrap();
    write(
        vm,
        node,
        object::HOMING_ACCELERATION,
        0,
        &150_000u32.to_le_bytes(),
    )
    .unwrap();
    enabled(vm, node, 6);
    let mut seen = vec![HomingProgress::from_statusword(statusword(vm, node))];
    write(vm, node, object::CONTROLWORD, 0, &0x1Fu16.to_le_bytes()).unwrap();
    for _ in 0..max_syncs {
        sync(vm);
        let sw = statusword(vm, node);
        let p = HomingProgress::from_statusword(sw);
        if seen.last() != Some(&p) {
            seen.push(p);
        }
        if matches!(p, HomingProgress::Completed | HomingProgress::Error) && sw & 0x0400 != 0 {
            break;
        }
    }
    seen
}

#[test]
fn homing_ends_on_the_methods_index_pulse_from_either_side_of_the_switch() {
    // Method, the side the switch is active on, the home position (mm).
    let pitch = 10.0 / 3.0;
    let cases = [
        (3u8, Side::Positive, 240.0),
        (4, Side::Positive, 240.0 + pitch),
        (5, Side::Negative, 240.0 + pitch),
        (6, Side::Negative, 240.0),
    ];
    let m = machine();
    let mut rng = 0x2545_F491_4F6C_DD1Du64;
    for (method, side, home_mm) in cases {
        // Random starts within the travel, and at least one on each side of the edge.
        let mut starts = vec![100.0, 246.0];
        for _ in 0..2 {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            let u = (rng >> 11) as f64 / (1u64 << 53) as f64;
            starts.push(m.x.soft_limit_min_mm + u * (m.x.soft_limit_max_mm - m.x.soft_limit_min_mm));
        }
        for x0 in starts {
            let mut vm = homing_vm(side, x0);
            let offset = 717_000;
            let seen = home(&mut vm, X, method, offset, 60_000);
            let what = format!("method {method}, switch {side:?}, from {x0:.3} mm");
            assert_eq!(
                seen,
                [
                    HomingProgress::NotStarted,
                    HomingProgress::InProgress,
                    HomingProgress::AttainedMoving,
                    HomingProgress::Completed
                ],
                "{what}"
            );
            assert!(
                (vm.plant.x_mm() - home_mm).abs() < 0.002,
                "{what}: ends at {} mm, not on the index pulse at {home_mm:.3} mm",
                vm.plant.x_mm()
            );
            let actual = read(&mut vm, X, object::POSITION_ACTUAL, 0) as i32;
            assert!((actual - offset).abs() <= 2, "{what}: 0x6064 = {actual}");
            assert_eq!(
                PowerState::from_statusword(statusword(&mut vm, X)),
                PowerState::OperationEnabled
            );
        }
    }
}

#[test]
fn the_vertical_axis_homes_with_the_machine_files_parameters_and_keeps_its_reference_in_csp() {
    let mut p = plant_config();
    p.simulation.drive_counters = DriveCounters::Incremental;
    p.simulation.seed = 7;
    let mut vm = vm_with(&p, at(150.0, 150.0));
    assert_eq!(
        read(&mut vm, Y, object::POSITION_ACTUAL, 0),
        0,
        "counter 0 at power-on"
    );
    let y0 = vm.plant.y_mm();
    assert!(
        (0.0..=450.0).contains(&y0) && (y0 - 150.0).abs() > 1e-6,
        "random: {y0}"
    );
    enabled(&mut vm, Y, 6);
    write(&mut vm, Y, object::CONTROLWORD, 0, &0x1Fu16.to_le_bytes()).unwrap();
    let mut done = false;
    for _ in 0..200_000 {
        sync(&mut vm);
        if HomingProgress::from_statusword(statusword(&mut vm, Y)) == HomingProgress::Completed {
            done = true;
            break;
        }
    }
    assert!(done, "Y did not home from {y0} mm: at {} mm", vm.plant.y_mm());
    assert!((vm.plant.y_mm() - 440.0).abs() < 0.002, "{}", vm.plant.y_mm());
    let offset = read(&mut vm, Y, object::HOME_OFFSET, 0) as i32;
    assert_eq!(offset, 1_320_000);
    // In CSP the counter keeps the reference: 10 mm down by targets.
    write(&mut vm, Y, object::MODES_OF_OPERATION, 0, &[8]).unwrap();
    let mut target = read(&mut vm, Y, object::POSITION_ACTUAL, 0) as i32;
    for _ in 0..1000 {
        target -= 30;
        write(&mut vm, Y, object::TARGET_POSITION, 0, &target.to_le_bytes()).unwrap();
        sync(&mut vm);
    }
    for _ in 0..300 {
        sync(&mut vm);
    }
    assert!((vm.plant.y_mm() - 430.0).abs() < 0.01, "{}", vm.plant.y_mm());
    let actual = read(&mut vm, Y, object::POSITION_ACTUAL, 0) as i32;
    assert!((actual - 1_290_000).abs() <= 5, "{actual}");
}

#[test]
fn halt_interrupts_homing_and_a_new_start_completes_it() {
    let mut vm = homing_vm(Side::Positive, 100.0);
    let seen = home(&mut vm, X, 3, 0, 500);
    assert_eq!(seen.last(), Some(&HomingProgress::InProgress));
    write(&mut vm, X, object::CONTROLWORD, 0, &0x11Fu16.to_le_bytes()).unwrap();
    for _ in 0..2000 {
        sync(&mut vm);
    }
    assert_eq!(
        HomingProgress::from_statusword(statusword(&mut vm, X)),
        HomingProgress::NotStarted,
        "interrupted: bit 10 only"
    );
    let x = vm.plant.x_mm();
    sync(&mut vm);
    assert!((vm.plant.x_mm() - x).abs() < 1e-3, "standing");
    // Bit 4 falls and rises again without halt: homing starts over and completes.
    write(&mut vm, X, object::CONTROLWORD, 0, &0x0Fu16.to_le_bytes()).unwrap();
    write(&mut vm, X, object::CONTROLWORD, 0, &0x1Fu16.to_le_bytes()).unwrap();
    for _ in 0..60_000 {
        sync(&mut vm);
        if HomingProgress::from_statusword(statusword(&mut vm, X)) == HomingProgress::Completed {
            break;
        }
    }
    assert!((vm.plant.x_mm() - 240.0).abs() < 0.002, "{}", vm.plant.x_mm());
}

fn emcy_codes(frames: &[Frame], node: u8) -> Vec<u16> {
    frames
        .iter()
        .filter_map(hob_canopen::emcy::Emcy::parse)
        .filter(|e| e.node == node)
        .map(|e| e.code)
        .collect()
}

#[test]
fn a_switch_that_is_not_found_before_the_hardware_limit_is_a_homing_error_and_a_fault() {
    // Method 3 expects the switch active on the positive side; this machine has it on
    // the negative side: from below the edge the drive runs towards the lower limit.
    let mut vm = homing_vm(Side::Negative, 60.0);
    let seen = home(&mut vm, X, 3, 0, 60_000);
    assert_eq!(seen.last(), Some(&HomingProgress::Error), "{seen:?}");
    let sw = statusword(&mut vm, X);
    assert_eq!(PowerState::from_statusword(sw), PowerState::Fault);
    assert_ne!(sw & cia402::SW_HOMING_ERROR, 0);
    let limit = machine().x.soft_limit_min_mm - plant_config().x.hardware_limit_margin_mm;
    assert!(
        vm.plant.x_mm() < limit && vm.plant.x_mm() > limit - 1.0,
        "stopped just beyond the limit at {limit} mm: {}",
        vm.plant.x_mm()
    );
}

#[test]
fn homing_gives_up_after_its_timeout() {
    let mut p = plant_config();
    p.simulation.drive_counters = DriveCounters::Incremental;
    p.x.homing_timeout_s = 0.5;
    let mut vm = vm_with(&p, at(100.0, 150.0));
    let mut r = Plant::new(&p, &machine(), at(100.0, 150.0), 10);
    std::mem::swap(&mut vm.plant, &mut r);
    let seen = home(&mut vm, X, 3, 0, 5_000);
    assert_eq!(
        seen,
        [
            HomingProgress::NotStarted,
            HomingProgress::InProgress,
            HomingProgress::Error
        ]
    );
    let sw = statusword(&mut vm, X);
    assert_ne!(sw & cia402::SW_TARGET_REACHED, 0, "standing");
    assert_eq!(
        PowerState::from_statusword(sw),
        PowerState::OperationEnabled,
        "not a fault"
    );
}

#[test]
fn a_drive_running_into_a_hardware_limit_in_csp_faults_with_an_emcy() {
    // Placed near the limit: an incremental drive powers up wherever the machine stood,
    // which the plant draws at random; the referenced one starts where it is told.
    let mut cfg = plant_config();
    cfg.simulation.drive_counters = hob_plant::config::DriveCounters::Referenced;
    let mut vm = vm_with(&cfg, at(245.0, 150.0));
    enabled(&mut vm, X, 8);
    let mut target = read(&mut vm, X, object::POSITION_ACTUAL, 0) as i32;
    let mut emcys = Vec::new();
    let mut faulted_at_mm = None;
    for _ in 0..2000 {
        target += 30; // 10 mm/s towards the upper limit at 252 mm
        write(&mut vm, X, object::TARGET_POSITION, 0, &target.to_le_bytes()).unwrap();
        let out = sync(&mut vm);
        emcys.extend(emcy_codes(&out, X));
        if faulted_at_mm.is_none() && PowerState::from_statusword(statusword(&mut vm, X)) == PowerState::Fault
        {
            faulted_at_mm = Some(vm.plant.x_mm());
        }
    }
    let at_mm = faulted_at_mm.unwrap_or_else(|| panic!("no fault; X at {} mm", vm.plant.x_mm()));
    assert!((252.0..252.1).contains(&at_mm), "faulted at {at_mm} mm");
    assert_eq!(
        emcys.first(),
        Some(&hob_plant::drive::EMCY_HARDWARE_LIMIT),
        "{emcys:x?}"
    );
    assert!(vm.plant.x_mm() < 252.5, "stopped: {}", vm.plant.x_mm());
}

/// SYNCs until Y reports its homing completed (none: not within `max`).
fn syncs_to_home_y(vm: &mut VirtualMachine, max: u32) -> Option<u32> {
    enabled(vm, Y, 6);
    write(vm, Y, object::CONTROLWORD, 0, &0x1Fu16.to_le_bytes()).unwrap();
    (1..=max).find(|_| {
        sync(vm);
        HomingProgress::from_statusword(statusword(vm, Y)) == HomingProgress::Completed
    })
}

#[test]
fn powered_up_near_home_the_drives_still_home_over_a_short_way() {
    let m = machine();
    let mut p = plant_config();
    p.simulation.drive_counters = DriveCounters::Incremental;
    p.simulation.seed = 7;
    let mut far = vm_with(&p, at(150.0, 150.0));
    let far_y0 = far.plant.y_mm();
    let far_syncs = syncs_to_home_y(&mut far, 200_000).expect("homed from anywhere");
    for seed in 1..=8 {
        p.simulation.seed = seed;
        p.simulation.power_on_near_home_mm = Some(20.0);
        let mut vm = vm_with(&p, at(150.0, 150.0));
        let (x0, y0) = (vm.plant.x_mm(), vm.plant.y_mm());
        for (axis, at_mm) in [(&m.x, x0), (&m.y, y0)] {
            assert!(
                (at_mm - axis.homing.home_position_mm).abs() <= 20.0 + 1e-9,
                "seed {seed}: {at_mm} mm"
            );
            assert!(
                (axis.soft_limit_min_mm..=axis.soft_limit_max_mm).contains(&at_mm),
                "seed {seed}: {at_mm} mm"
            );
        }
        assert_eq!(
            read(&mut vm, Y, object::POSITION_ACTUAL, 0),
            0,
            "counter 0 at power-on"
        );
        let syncs = syncs_to_home_y(&mut vm, 200_000)
            .unwrap_or_else(|| panic!("seed {seed}: Y did not home from {y0} mm"));
        assert!(
            (vm.plant.y_mm() - 440.0).abs() < 0.002,
            "seed {seed}: {}",
            vm.plant.y_mm()
        );
        if seed == 7 {
            assert!(
                syncs * 3 < far_syncs,
                "near home ({y0:.1} mm) {syncs} SYNCs, from {far_y0:.1} mm {far_syncs}"
            );
        }
    }
    // A distance of 0 or less is refused by the plant file's check.
    p.simulation.power_on_near_home_mm = Some(0.0);
    let mut problems = hob_setup::config::Problems::new();
    p.validate(&mut problems);
    assert!(
        problems
            .as_slice()
            .iter()
            .any(|q| q.key == "simulation.power_on_near_home_mm")
    );
}

/// The table's position in 2^20 counts per motor turn wraps at 32 bits every 27 table turns:
/// a drive running through the wrap in CSP follows its target across it, reports the
/// wrapped position and does not fault (it compares target and position in its own 32-bit
/// counts, as a drive does).
#[test]
fn the_table_drive_runs_through_the_32_bit_wrap_without_a_fault() {
    let m = machine();
    let counts_per_deg = m.table.counts_per_deg();
    let mut cfg = plant_config();
    cfg.simulation.drive_counters = hob_plant::config::DriveCounters::Referenced;
    // 1.4 to 2.4 deg of table below the wrap.
    let start_deg = (f64::from(i32::MAX) / counts_per_deg - 1.4).floor();
    let mut vm = vm_with(
        &cfg,
        Start {
            x_mm: 150.0,
            y_mm: 150.0,
            table_deg: start_deg,
        },
    );
    enabled(&mut vm, TABLE, 8);
    let first = read(&mut vm, TABLE, object::POSITION_ACTUAL, 0) as i32;
    assert!(first > i32::MAX - 1_000_000, "{first}");
    let mut target = first;
    let mut wrapped = false;
    for _ in 0..3000 {
        target = target.wrapping_add(437); // 2 deg/s of table
        write(&mut vm, TABLE, object::TARGET_POSITION, 0, &target.to_le_bytes()).unwrap();
        sync(&mut vm);
        let sw = statusword(&mut vm, TABLE);
        assert_eq!(
            PowerState::from_statusword(sw),
            PowerState::OperationEnabled,
            "sw {sw:#06x}"
        );
        let actual = read(&mut vm, TABLE, object::POSITION_ACTUAL, 0) as i32;
        wrapped |= actual < 0;
        // Following within a tenth of a degree of table, across the wrap.
        assert!(
            f64::from(target.wrapping_sub(actual).unsigned_abs()) < 0.1 * counts_per_deg,
            "target {target}, actual {actual}"
        );
    }
    assert!(wrapped, "the position never wrapped");
}
