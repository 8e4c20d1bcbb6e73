//! The master and the virtual machine on an in-memory CAN bus, in one process: boot
//! through NMT, SDO and CiA 402, jog every axis, cut a short program and check from the
//! frames that the table targets follow the gearbox law for the spindle angles received,
//! and every fault injection ends in the documented reaction with nothing left enabled.
//! The same scenarios run as separate processes on vcan in the PREEMPT_RT guest.
#![allow(clippy::unwrap_used)]

use hob_can_transport::{MemoryBus, SystemClock};
use hob_canopen::cia402::PowerState;
use hob_canopen::frame::{Cob, Frame};
use hob_control::fault::{Axis, Fault};
use hob_control::program::CycleProgram;
use hob_control::{Command, ControlParams, Controller, HomeAxes, State};
use hob_master::boot;
use hob_plant::config::PlantConfig;
use hob_plant::sim::start_for;
use hob_process_image::plan::BusPlan;
use hob_setup::config::Problems;
use hob_setup::config::machine::MachineConfig;
use hob_setup::job::Program;
use hob_setup::planner;
use hob_virtual_machine::runner::{MasterLoop, VmThread};
use hob_virtual_machine::virtual_machine::{VirtualMachine, VmFault};
use std::path::{Path, PathBuf};
use std::time::Duration;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn machine() -> MachineConfig {
    hob_store::files::load_machine(&root().join("config/machine.toml")).unwrap()
}

fn short_program(m: &MachineConfig) -> (Program, CycleProgram, planner::Plan) {
    // The thesis gear made shallow and narrow: typed edits of the parsed file, each key
    // checked to exist (a text replacement does nothing, silently, when the file changes).
    let mut t: toml::Table = std::fs::read_to_string(root().join("config/programs/spur-z17-m5.toml"))
        .unwrap()
        .parse()
        .unwrap();
    let edits: [(&str, Option<toml::Value>); 9] = [
        ("workpiece.face_width_mm", Some(4.0.into())),
        ("workpiece.allowance_mm", Some(0.5.into())),
        ("strategy.total_depth_mm", Some(2.0.into())),
        ("strategy.finish_allowance_mm", Some(0.2.into())),
        ("strategy.rough_depths_mm", None),
        ("strategy.rough_passes", Some(1.into())),
        ("strategy.rough.feed_mm_per_rev", Some(8.0.into())),
        ("strategy.finish.feed_mm_per_rev", Some(6.0.into())),
        ("cycle.single_depth_mm", Some(1.0.into())),
    ];
    for (key, value) in edits {
        let (path, last) = key.rsplit_once('.').unwrap();
        let table = path.split('.').fold(&mut t, |t, part| {
            t.get_mut(part)
                .and_then(toml::Value::as_table_mut)
                .unwrap_or_else(|| panic!("{key}: no table {part}"))
        });
        let old = table.remove(last).unwrap_or_else(|| panic!("{key}: no such key"));
        if let Some(v) = value {
            assert_eq!(old.type_str(), v.type_str(), "{key}");
            table.insert(last.to_string(), v);
        }
    }
    let src = toml::to_string(&t).unwrap();
    let job: Program = toml::from_str(&src).unwrap();
    let mut p = Problems::new();
    let cycle = CycleProgram::build(&job, m, &mut p).unwrap();
    let plan = planner::plan(&job, m, &mut p).unwrap();
    (job, cycle, plan)
}

/// The controller's bound on the synchronisation error, arcsec of table: a quarter of the
/// gear's ISO 1328-1 grade-5 single pitch tolerance at its pitch circle.
fn bound_arcsec(cycle: &CycleProgram) -> f64 {
    let bound_um =
        hob_gearing::iso1328::single_pitch_tolerance_um(cycle.pitch_diameter_mm, cycle.normal_module_mm, 5)
            / 4.0;
    hob_gearing::units::um_to_arcsec_at_radius(bound_um, cycle.pitch_diameter_mm / 2.0)
}

struct Bed {
    master: MasterLoop<MemoryBus>,
    vm: VmThread,
    capture: MemoryBus,
    cycle: CycleProgram,
    plan: BusPlan,
}

/// Boots the bus and brings the controller to idle with the drives enabled.
fn bed() -> Bed {
    let m = machine();
    let (job, cycle, pplan) = short_program(&m);
    let plant = PlantConfig::load(&root().join("config/plant.toml")).unwrap();
    let mut vm = VirtualMachine::new(&m, &plant, start_for(&cycle), job.tool.gashes as u32);
    vm.plant.set_workpiece(hob_plant::sim::workpiece_for(
        &cycle,
        &pplan,
        job.workpiece.face_width_mm,
        job.tool.outside_diameter_mm,
    ));
    vm.set_law(cycle.ratio_signed, cycle.differential_signed_deg_per_mm);
    let mut bus = MemoryBus::new(4096);
    bus.capture();
    let vm_bus = bus.endpoint();
    let vm = VmThread::spawn(vm, vm_bus);
    let plan = BusPlan::from_machine(&m);
    let booted = boot(
        &plan,
        &mut bus,
        &mut SystemClock::new(),
        Duration::from_millis(500),
    )
    .unwrap();
    let infos = &booted.nodes;
    assert_eq!(infos.len(), 4);
    assert!(
        infos[..3].iter().all(|i| i.csp() && i.profile() == 402),
        "{infos:?}"
    );
    assert_eq!(infos[3].profile(), 401);
    assert_eq!(infos[0].name, "hob-sim drive B (table)");
    let controller = Controller::new(ControlParams::from_machine(&m));
    let mut master = MasterLoop::new(controller, booted.cyclic, bus.clone());
    for _ in 0..20_000 {
        master.cycle();
        if master.controller.status().state == State::Idle {
            break;
        }
    }
    assert_eq!(
        master.controller.status().state,
        State::Idle,
        "{:?}",
        master.controller.status().fault
    );
    // The drives follow the enable within a few event-spaced controlwords.
    for _ in 0..2000 {
        master.cycle();
    }
    // The drives count from wherever they powered up: X and Y reference by their own
    // homing (CiA 402 mode 6, over the bus) before anything but a slow jog is accepted.
    master
        .controller
        .command(Command::Home { axes: HomeAxes::Both })
        .unwrap();
    for _ in 0..120_000 {
        master.cycle();
        let s = master.controller.status();
        if s.state != State::Referencing {
            break;
        }
    }
    let s = master.controller.status();
    assert_eq!(
        (s.state, s.referenced),
        (State::Idle, [true, true]),
        "{:?}",
        s.fault
    );
    Bed {
        master,
        vm,
        capture: bus,
        cycle,
        plan,
    }
}

fn run_until(bed: &mut Bed, max_cycles: u32, mut done: impl FnMut(State) -> bool) {
    for _ in 0..max_cycles {
        bed.master.cycle();
        if done(bed.master.controller.status().state) {
            return;
        }
    }
}

fn drive_states(bed: Bed) -> [PowerState; 3] {
    let vm = bed.vm.stop().unwrap();
    [
        vm.drive_state(Axis::B),
        vm.drive_state(Axis::X),
        vm.drive_state(Axis::Y),
    ]
}

#[test]
fn boots_to_operation_enabled_and_jogs_every_axis() {
    let mut bed = bed();
    let s = bed.master.controller.status();
    assert!(s.inputs.safety_chain_closed);
    let before = (s.x_mm, s.y_mm, s.table_deg);
    for (axis, d) in [(Axis::X, 5.0), (Axis::Y, -3.0), (Axis::B, 10.0)] {
        bed.master
            .controller
            .command(Command::Jog { axis, distance: d })
            .unwrap();
        run_until(&mut bed, 20_000, |s| s == State::Idle);
    }
    run_until(&mut bed, 500, |_| false);
    let s = bed.master.controller.status();
    assert!(
        (s.x_mm - before.0 - 5.0).abs() < 0.01,
        "X reported by its drive: {} -> {}",
        before.0,
        s.x_mm
    );
    assert!(
        (s.y_mm - before.1 + 3.0).abs() < 0.01,
        "Y: {} -> {}",
        before.1,
        s.y_mm
    );
    assert!(
        (s.table_deg - before.2 - 10.0).abs() < 0.01,
        "B: {} -> {}",
        before.2,
        s.table_deg
    );
    let states = drive_states(bed);
    assert!(
        states.iter().all(|s| *s == PowerState::OperationEnabled),
        "{states:?}"
    );
}

#[test]
fn a_short_cut_over_the_bus_follows_the_gearbox_law() {
    let mut bed = bed();
    bed.master.controller.load(bed.cycle).unwrap();
    let from = bed.capture.captured().len();
    bed.master
        .controller
        .command(Command::Start { single: false })
        .unwrap();
    // The state after each cycle: cycle k sent the k-th table RPDO1 of the capture.
    let mut states = Vec::new();
    run_until(&mut bed, 400_000, |s| {
        states.push(s);
        s == State::Idle || s == State::Faulted
    });
    let cut_cycles = states.iter().filter(|s| **s == State::Cut).count();
    assert_eq!(
        bed.master.controller.status().state,
        State::Idle,
        "{:?}",
        bed.master.controller.status().fault
    );
    assert!(cut_cycles > 5000);
    // From the frames: per SYNC, the spindle counts the master received (table drive's
    // TPDO1) and the table target it sent next (RPDO1). In the cut the table targets must
    // advance by z0/z of the spindle's advance.
    let frames = bed.capture.captured()[from..].to_vec();
    let table = bed.plan.drives[0];
    let mut pairs: Vec<(f64, f64)> = Vec::new();
    let mut rpdos = 0usize;
    let mut in_cut = Vec::new();
    let mut spindle = None;
    // The machine file's units; the table's targets wrap at 32 bits (every 27 table turns in
    // its 2^20 counts per motor turn): followed continuously.
    let m = machine();
    let spindle_counts_per_deg = f64::from(m.spindle.encoder_counts_per_rev) / 360.0;
    let mut target_counts = hob_control::observer::Unwrapper::default();
    for f in &frames {
        match Cob::of(f.id) {
            Cob::Tpdo(1, n) if n == table.node => {
                let v = table.actual.unpack(f).unwrap();
                spindle = Some(f64::from(v[1] as u32 as i32) / spindle_counts_per_deg);
            }
            Cob::Rpdo(1, n) if n == table.node => {
                let state = states.get(rpdos).copied();
                rpdos += 1;
                if let Some(s) = spindle.take() {
                    let total = target_counts.update(table.target.unpack(f).unwrap()[0] as u32 as i32);
                    let target = total as f64 / m.table.counts_per_deg();
                    pairs.push((s, target));
                    in_cut.push(state == Some(State::Cut));
                }
            }
            _ => {}
        }
    }
    assert!(pairs.len() > 10_000, "{}", pairs.len());
    let ratio = bed.cycle.ratio_signed;
    // In the cut, over stretches of 2000 cycles: the table target advances by z0/z of the
    // spindle's advance, to the cross-coupling's small correction.
    let mut checked = 0;
    for (i, w) in pairs.windows(2001).enumerate().step_by(500) {
        if !in_cut[i..=i + 2000].iter().all(|c| *c) {
            continue;
        }
        let (s0, t0) = w[0];
        let (s1, t1) = w[2000];
        let slope = (t1 - t0) / (s1 - s0);
        checked += 1;
        assert!(
            (slope - ratio).abs() < 1e-4 * ratio.abs(),
            "slope {slope} vs ratio {ratio}"
        );
    }
    assert!(checked >= 10, "stretches of the cut checked: {checked}");
    // The phase, not only the slope: the table drive's true error against the law over the
    // whole cut, both passes (one engagement, one phase), within the controller's bound
    // either side of its centre. A table late by a constant time keeps the slope; its
    // offset, the table's speed times the delay, moves with the passes' speeds: 119.4 and
    // 139.3 spindle rpm here, 7.0 deg/s of table apart, so 1 ms late moves it by 25 arcsec
    // between them, beyond the spread allowed (2 x 8.6 arcsec; measured 6.7).
    let vm = bed.vm.stop().unwrap();
    let bound_arcsec = bound_arcsec(&bed.cycle);
    let spread = vm.cut_error_spread_arcsec().expect("the tool never cut");
    eprintln!("true error spread over the cut {spread:.2} arcsec, bound +-{bound_arcsec:.2} arcsec");
    assert!(
        spread / 2.0 <= bound_arcsec,
        "true error spread {spread:.2} arcsec over the cut: over +-{bound_arcsec:.2} arcsec"
    );
}

fn fault_in_cut(fault: VmFault) -> (Bed, Vec<State>) {
    let mut bed = bed();
    bed.master.controller.load(bed.cycle).unwrap();
    bed.master
        .controller
        .command(Command::Start { single: false })
        .unwrap();
    let mut cut = 0;
    run_until(&mut bed, 400_000, |s| {
        cut += u32::from(s == State::Cut);
        cut > 3000
    });
    assert_eq!(bed.master.controller.status().state, State::Cut);
    bed.vm.inject(fault);
    let mut states = vec![State::Cut];
    run_until(&mut bed, 60_000, |s| {
        if states.last() != Some(&s) {
            states.push(s);
        }
        s == State::Faulted
    });
    // Let the controlwords reach the drives.
    run_until(&mut bed, 1000, |_| false);
    (bed, states)
}

fn assert_nothing_enabled(bed: Bed) {
    let s = bed.master.controller.status();
    assert!(!s.outputs.spindle_run_forward && !s.outputs.spindle_run_reverse && !s.outputs.coolant_pump);
    assert!(!s.outputs.pc_ok_relay);
    let states = drive_states(bed);
    assert!(
        states.iter().all(|s| *s != PowerState::OperationEnabled),
        "{states:?}"
    );
}

#[test]
fn drive_fault_on_y_in_the_cut_retracts_first_then_stops() {
    let (bed, states) = fault_in_cut(VmFault::Plant(hob_plant::plant::Injection::DriveFault(Axis::Y)));
    assert_eq!(
        states,
        vec![State::Cut, State::FaultRetract, State::FaultStop, State::Faulted]
    );
    assert_eq!(
        bed.master.controller.status().fault,
        Some(Fault::DriveFault { axis: Axis::Y })
    );
    assert_nothing_enabled(bed);
}

#[test]
fn a_repaired_drive_is_reset_over_the_bus_and_the_interrupted_pass_continues() {
    let (mut bed, _) = fault_in_cut(VmFault::Plant(hob_plant::plant::Injection::DriveFault(Axis::Y)));
    // The cut was in pass 1 (of the short program's rough and finish passes).
    let pass = bed.master.controller.status().continue_pass;
    assert_eq!(pass, 1);
    run_until(&mut bed, 1000, |_| false);
    // Not repaired: the reset's fault reset does not take, the drive's fault is back.
    bed.master.controller.command(Command::Reset).unwrap();
    run_until(&mut bed, 10_000, |s| s == State::Faulted);
    assert_eq!(
        bed.master.controller.status().fault,
        Some(Fault::DriveFault { axis: Axis::Y })
    );
    // Repaired (a second later, the safety chain dropped out by then): the master's
    // fault reset clears it, the drives come up, the pass goes on.
    run_until(&mut bed, 1000, |_| false);
    bed.vm.inject(VmFault::Clear);
    bed.master.controller.command(Command::Reset).unwrap();
    run_until(&mut bed, 20_000, |s| s == State::Idle || s == State::Faulted);
    let s = bed.master.controller.status();
    assert_eq!((s.state, s.fault), (State::Idle, None));
    assert!(s.table_position_whole, "{s:?}");
    bed.master.controller.command(Command::Continue).unwrap();
    run_until(&mut bed, 400_000, |s| s == State::Cut || s == State::Faulted);
    let s = bed.master.controller.status();
    assert_eq!((s.state, s.pass, s.fault), (State::Cut, pass, None));
    let _ = drive_states(bed);
}

#[test]
fn a_silent_table_drive_is_noticed_and_the_machine_stops() {
    let (bed, states) = fault_in_cut(VmFault::Silent(2));
    assert!(states.contains(&State::Faulted), "{states:?}");
    assert_eq!(
        bed.master.controller.status().fault,
        Some(Fault::FeedbackLost { axis: Axis::B })
    );
    // The table cannot follow: X still retracts before the stop.
    assert!(states.contains(&State::FaultRetract), "{states:?}");
    let _ = drive_states(bed);
}

#[test]
fn emergency_stop_in_the_cut_retracts_within_the_stop_delay() {
    let (bed, states) = fault_in_cut(VmFault::Plant(hob_plant::plant::Injection::EmergencyStop));
    assert_eq!(
        states,
        vec![State::Cut, State::FaultRetract, State::FaultStop, State::Faulted]
    );
    assert_eq!(bed.master.controller.status().fault, Some(Fault::EmergencyStop));
    assert_nothing_enabled(bed);
}

#[test]
fn garbage_and_a_few_lost_frames_do_not_disturb_the_cut() {
    let mut bed = bed();
    let cycle = bed.cycle;
    bed.vm.inject(VmFault::Garbage(3));
    bed.vm.inject(VmFault::Drop(0.0005));
    bed.master.controller.load(bed.cycle).unwrap();
    bed.master
        .controller
        .command(Command::Start { single: true })
        .unwrap();
    run_until(&mut bed, 400_000, |s| s == State::Idle || s == State::Faulted);
    assert_eq!(
        bed.master.controller.status().state,
        State::Idle,
        "{:?}",
        bed.master.controller.status().fault
    );
    let vm = bed.vm.stop().unwrap();
    // What the faults did: frames taken away and added (at 0.05 % a few dozen PDOs over
    // the cut's tens of thousands; three garbage frames per SYNC).
    assert!(vm.pdos_dropped() >= 5, "PDOs dropped: {}", vm.pdos_dropped());
    assert!(
        vm.garbage_sent() >= 3 * vm.cutting_syncs(),
        "garbage frames: {}",
        vm.garbage_sent()
    );
    // And what they did not: the table drive's true error against the gearbox law over
    // the cut (the controller's share; the worm wheel's own errors are the machine's)
    // stays within the controller's bound (a quarter of the grade-5 single pitch
    // tolerance at the pitch circle) on either side of its centre. Without the faults the
    // spread was 6.9 arcsec (2026-11-26).
    let bound_arcsec = bound_arcsec(&cycle);
    let spread = vm.cut_error_spread_arcsec().expect("the tool never cut");
    eprintln!(
        "{} PDOs dropped, {} garbage frames over {} SYNCs ({} in the cut); true error spread {spread:.2} arcsec, bound +-{bound_arcsec:.2} arcsec",
        vm.pdos_dropped(),
        vm.garbage_sent(),
        vm.syncs(),
        vm.cutting_syncs()
    );
    assert!(
        spread / 2.0 <= bound_arcsec,
        "true error spread {spread:.2} arcsec: over +-{bound_arcsec:.2} arcsec"
    );
}

#[test]
fn frames_dropped_three_times_in_a_row_are_a_fault() {
    let (bed, states) = fault_in_cut(VmFault::Drop(1.0));
    assert!(states.contains(&State::Faulted), "{states:?}");
    assert!(matches!(
        bed.master.controller.status().fault,
        Some(Fault::FeedbackLost { .. })
    ));
    let _ = drive_states(bed);
}

#[test]
fn the_capture_shows_sync_every_cycle_and_only_the_schedule() {
    let mut bed = bed();
    let from = bed.capture.captured().len();
    run_until(&mut bed, 1000, |_| false);
    let frames: Vec<Frame> = bed.capture.captured()[from..].to_vec();
    let syncs = frames.iter().filter(|f| f.id == 0x080).count();
    assert!((999..=1001).contains(&syncs), "{syncs}");
    let allowed = |f: &Frame| match Cob::of(f.id) {
        Cob::Sync => true,
        Cob::Tpdo(1 | 2, n) | Cob::Rpdo(1 | 2, n) => bed.plan.nodes().contains(&n),
        Cob::Heartbeat(n) => n == 0x7F || bed.plan.nodes().contains(&n),
        _ => false,
    };
    assert!(
        frames.iter().all(allowed),
        "{:?}",
        frames.iter().find(|f| !allowed(f))
    );
    let _ = drive_states(bed);
}
