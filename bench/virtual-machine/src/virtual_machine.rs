//! The virtual machine on the bus: every node of the real machine (three CiA 402 drives,
//! the CiA 401 I/O coupler, the spindle encoder on the table drive's auxiliary input)
//! around the physics of `hob-plant`, with fault injection.
//!
//! Lockstep: the physics advance by one period per SYNC received, as real drives act on
//! SYNC, so a run over the bus is reproducible however the processes are scheduled.
//! As a real drive does, a SYNC is answered first (latch, TPDOs) and the period's
//! physics are computed afterwards ([`VirtualMachine::settle`]), before the next frame.

use crate::node::{Node, communication_objects};
use crate::od::{Access, Od};
use hob_canopen::cia402::{self, PowerState, object};
use hob_canopen::emcy::Emcy;
use hob_canopen::frame::Frame;
use hob_canopen::nmt::NmtState;
use hob_control::fault::Axis;
use hob_plant::config::{DriveCounters, PlantConfig};
use hob_plant::drive::{DriveCommand, HOMING_METHODS, HomingParams, MODE_HOMING};
use hob_plant::plant::{Injection, Plant, Start};
use hob_plant::servo::{Servo, ServoGains};
use hob_process_image::gains::{self, DriveGains};
use hob_process_image::plan::{ANALOG_INPUTS, ANALOG_OUTPUTS, BusPlan, DIGITAL_INPUTS, DIGITAL_OUTPUTS};
use hob_setup::config::machine::MachineConfig;
use std::collections::VecDeque;

/// A fault of the bus or of a node, injected from the command line or control channel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum VmFault {
    /// A physical fault of the machine.
    Plant(Injection),
    /// Drop each TPDO with this probability.
    Drop(f64),
    /// Hold every TPDO back by this many SYNCs.
    Delay(u32),
    /// The node sends and hears nothing any more.
    Silent(u8),
    /// Garbage frames per SYNC: unused identifiers, and used ones with wrong lengths.
    Garbage(u32),
    /// Every fault injected so far repaired (the bus healthy again, the plant's faults
    /// cleared; a drive's own fault stays until the master's fault reset).
    Clear,
}

impl VmFault {
    /// Parses `drive-fault x`, `estop`, `chain-open`, `limit y min`, `no-lube`,
    /// `obstruct y`, `vfd-fault`, `drop 0.2`, `delay 3`, `silent 2`, `garbage 4`, `clear`.
    pub fn parse(text: &str) -> Result<Self, String> {
        let words: Vec<&str> = text.split_whitespace().collect();
        let axis = |w: Option<&&str>| match w.map(|s| s.to_ascii_lowercase()).as_deref() {
            Some("b") | Some("table") => Ok(Axis::B),
            Some("x") => Ok(Axis::X),
            Some("y") => Ok(Axis::Y),
            other => Err(format!("axis must be b, x or y (got {other:?})")),
        };
        let num = |w: Option<&&str>| -> Result<f64, String> {
            w.ok_or("a number is missing")?
                .parse::<f64>()
                .map_err(|e| e.to_string())
        };
        Ok(match words.first().copied() {
            Some("drive-fault") => VmFault::Plant(Injection::DriveFault(axis(words.get(1))?)),
            Some("estop") => VmFault::Plant(Injection::EmergencyStop),
            Some("chain-open") => VmFault::Plant(Injection::OpenSafetyChain),
            Some("limit") => {
                let end = match words.get(2).copied() {
                    Some("min") => hob_control::fault::End::Min,
                    Some("max") => hob_control::fault::End::Max,
                    other => return Err(format!("limit end must be min or max (got {other:?})")),
                };
                VmFault::Plant(Injection::HardwareLimit(axis(words.get(1))?, end))
            }
            Some("no-lube") => VmFault::Plant(Injection::NoLubePressure),
            Some("obstruct") => VmFault::Plant(Injection::Obstruct(axis(words.get(1))?)),
            Some("vfd-fault") => VmFault::Plant(Injection::VfdFault),
            Some("drop") => VmFault::Drop(num(words.get(1))?.clamp(0.0, 1.0)),
            Some("delay") => VmFault::Delay(num(words.get(1))? as u32),
            Some("silent") => VmFault::Silent(num(words.get(1))? as u8),
            Some("garbage") => VmFault::Garbage(num(words.get(1))? as u32),
            Some("clear") => VmFault::Clear,
            other => return Err(format!("unknown fault {other:?}")),
        })
    }
}

const DRIVE_DEVICE_TYPE: u32 = 0x0002_0192; // CiA 402, servo
const IO_DEVICE_TYPE: u32 = 0x0003_0191; // CiA 401, digital in + out
/// Following error window of the simulated drives (0x6065) at power-on, motor turns (in
/// each drive's position unit: the machine file's counts per motor turn).
const FOLLOWING_WINDOW_MOTOR_TURNS: u32 = 2;
/// Controlword bit 8: halt.
const CW_HALT: u16 = 1 << 8;

/// TPDO1-4 and RPDO1-4 identifiers.
fn is_pdo(id: u16) -> bool {
    (0x180..0x580).contains(&id)
}

/// The servo of drive `i` (B, X, Y).
fn servo(plant: &Plant, i: usize) -> &Servo {
    [&plant.table, &plant.x, &plant.y][i]
}

fn servo_mut(plant: &mut Plant, i: usize) -> &mut Servo {
    match i {
        0 => &mut plant.table,
        1 => &mut plant.x,
        _ => &mut plant.y,
    }
}

/// The drive's loop gains as its objects hold them (0x60F9:01, 0x60F9:02, 0x60FB:01, in
/// the units of [`hob_process_image::gains`]), from the servo's.
fn gain_objects(g: ServoGains) -> DriveGains {
    DriveGains::from_si(
        g.velocity_kp_nm_s_per_rad,
        g.velocity_integral_time_s,
        g.position_kv_per_s,
    )
    .unwrap_or_else(|| panic!("the servo's gains {g:?} are outside the drive's objects' ranges"))
}

/// The drive's loop gains as objects, readable and writable by SDO (expedited), each
/// limited to its range ([`hob_process_image::gains`]); a write reaches the servo at once
/// ([`VirtualMachine::on_gains`]).
fn gain_entries(od: &mut Od, gains: DriveGains) {
    od.set(object::VELOCITY_CONTROL_PARAMETERS, 0, Access::Ro, &[2])
        .set(object::POSITION_CONTROL_PARAMETERS, 0, Access::Ro, &[1]);
    let ranges = gains::ranges();
    for (i, (index, sub, _)) in gains::OBJECTS.into_iter().enumerate() {
        od.set(index, sub, Access::Rw, &gains.values[i].to_le_bytes())
            .limit(index, sub, ranges[i].0, ranges[i].1);
    }
}

/// The object dictionary of a drive: `modes` are the modes it implements (0x6502, and the
/// only values 0x6060 takes); `homing` its homing objects' values at power-on (X and Y);
/// `gains` its loop gains' objects at power-on.
fn drive_od(
    node: u8,
    name: &str,
    spindle: Option<(u16, u8)>,
    modes: &[i8],
    homing: Option<HomingParams>,
    following_window_counts: u32,
    gains: DriveGains,
) -> Od {
    let supported: u32 = modes.iter().fold(0, |b, m| b | 1 << (m - 1));
    let mut od = Od::default();
    // Default mapping as many drives ship: RPDO1 controlword, TPDO1 statusword.
    let rpdo = [[0x6040_0010, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0]];
    let tpdo = [[0x6041_0010, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0]];
    communication_objects(&mut od, node, DRIVE_DEVICE_TYPE, name, &rpdo, &tpdo);
    od.set(object::CONTROLWORD, 0, Access::Rw, &0u16.to_le_bytes())
        .set(
            object::STATUSWORD,
            0,
            Access::Ro,
            &PowerState::SwitchOnDisabled.statusword().to_le_bytes(),
        )
        // Powered up with no mode (0): the display follows a mode written to 0x6060 as
        // soon as it takes effect, in any power state, and the master's boot reads it back.
        .set(object::MODES_OF_OPERATION, 0, Access::Rw, &[0])
        .set(object::MODES_DISPLAY, 0, Access::Ro, &[0])
        .set(object::POSITION_ACTUAL, 0, Access::Ro, &0i32.to_le_bytes())
        .set(0x6065, 0, Access::Rw, &following_window_counts.to_le_bytes())
        .set(object::TARGET_POSITION, 0, Access::Rw, &0i32.to_le_bytes())
        .set(object::VELOCITY_OFFSET, 0, Access::Rw, &0i32.to_le_bytes())
        .set(object::INTERPOLATION_PERIOD, 0, Access::Ro, &[2])
        .set(object::INTERPOLATION_PERIOD, 1, Access::Rw, &[1])
        .set(object::INTERPOLATION_PERIOD, 2, Access::Rw, &[(-3i8) as u8])
        .set(object::SUPPORTED_MODES, 0, Access::Ro, &supported.to_le_bytes())
        // A vendor-specific text the machine builder may write (axis label).
        .set_rw_str(0x2000, 0, "");
    od.allow_only(object::MODES_OF_OPERATION, 0, modes);
    gain_entries(&mut od, gains);
    // Homing parameters (CiA 402-2 section 12), written by the master at boot: only on a
    // drive that homes (the table has none, and says so with "object does not exist").
    if let Some(h) = homing {
        od.set(
            object::HOME_OFFSET,
            0,
            Access::Rw,
            &h.home_offset_counts.to_le_bytes(),
        )
        .set(object::HOMING_METHOD, 0, Access::Rw, &[h.method as u8])
        .set(object::HOMING_SPEEDS, 0, Access::Ro, &[2])
        .set(
            object::HOMING_SPEEDS,
            1,
            Access::Rw,
            &h.switch_speed_counts_s.to_le_bytes(),
        )
        .set(
            object::HOMING_SPEEDS,
            2,
            Access::Rw,
            &h.zero_speed_counts_s.to_le_bytes(),
        )
        .set(
            object::HOMING_ACCELERATION,
            0,
            Access::Rw,
            &h.accel_counts_s2.to_le_bytes(),
        )
        .allow_only(object::HOMING_METHOD, 0, &HOMING_METHODS);
    }
    if let Some((index, sub)) = spindle {
        od.set(index, sub, Access::Ro, &0i32.to_le_bytes());
    }
    od
}

fn io_od(node: u8) -> Od {
    let mut od = Od::default();
    let rpdo = [
        [0x6200_0108, 0x6200_0208, 0],
        [0x6411_0110, 0x6411_0210, 0],
        [0, 0, 0],
        [0, 0, 0],
    ];
    let tpdo = [
        [0x6000_0108, 0x6000_0208, 0x6000_0308],
        [0, 0, 0],
        [0, 0, 0],
        [0, 0, 0],
    ];
    communication_objects(&mut od, node, IO_DEVICE_TYPE, "hob-sim I/O coupler", &rpdo, &tpdo);
    od.set(DIGITAL_INPUTS, 0, Access::Ro, &[3]);
    for s in 1..=3 {
        od.set(DIGITAL_INPUTS, s, Access::Ro, &[0]);
    }
    od.set(DIGITAL_OUTPUTS, 0, Access::Ro, &[2]);
    for s in 1..=2 {
        od.set(DIGITAL_OUTPUTS, s, Access::Rw, &[0]);
    }
    od.set(ANALOG_OUTPUTS, 0, Access::Ro, &[2]);
    for s in 1..=2 {
        od.set(ANALOG_OUTPUTS, s, Access::Rw, &0i16.to_le_bytes());
    }
    // Two analog inputs (a table gauge on one of them, when the plant has one), sent only
    // when the master maps them (TPDO2 is disabled by default).
    od.set(ANALOG_INPUTS, 0, Access::Ro, &[ANALOG_INPUT_CHANNELS]);
    for s in 1..=ANALOG_INPUT_CHANNELS {
        od.set(ANALOG_INPUTS, s, Access::Ro, &0i16.to_le_bytes());
    }
    od
}

/// The virtual coupler's analog inputs.
const ANALOG_INPUT_CHANNELS: u8 = 2;

/// The virtual machine.
#[derive(Debug)]
pub struct VirtualMachine {
    pub plant: Plant,
    plan: BusPlan,
    drives: [Node; 3],
    io: Node,
    state: [PowerState; 3],
    /// A rising edge of controlword bit 4 since the last SYNC (homing start), so that a
    /// pulse shorter than a period is not lost.
    homing_start_seen: [bool; 3],
    controlword_before: [u16; 3],
    time_s: f64,
    /// The nominal instant of the next SYNC (one period per SYNC).
    nominal_s: f64,
    /// The SYNCs' timing disturbance ([`hob_plant::sim::SyncTiming`]).
    timing: hob_plant::sim::SyncTiming,
    period_s: f64,
    syncs: u64,
    drop: f64,
    delay: u32,
    garbage: u32,
    delayed: VecDeque<(u64, Frame)>,
    rng: u64,
    powered_before: bool,
    cutting_syncs: u64,
    /// The physics owe the period since the last SYNC (see [`VirtualMachine::settle`]).
    physics_owed: bool,
    /// The nodes' own clock (heartbeats, inhibit times): advances by one period per SYNC
    /// and by wall time while no SYNC runs, so both never mix.
    node_clock_s: f64,
    /// The SYNC being handled is already followed by another: its PDOs are not sent.
    superseded: bool,
    /// SYNCs whose PDOs were not sent because a later SYNC was already waiting.
    superseded_syncs: u64,
    /// The plant file's late frames (`simulation.tpdo_late_rate`, `rpdo_late_rate`), as
    /// in the in-process simulation ([`hob_plant::sim::FrameTiming`]): a drive's position
    /// TPDO not sent at its SYNC (the master then has nothing new from it, as when the
    /// frame comes after the next SYNC), a target RPDO taken a SYNC late (the drive keeps
    /// the target it applied last).
    late_rates: [f64; 2],
    late_rng: u64,
    applied_targets: Option<[i32; 3]>,
    /// The gearbox law the truth is graded against (ratio, differential deg/mm), and the
    /// least and greatest true error of the table drive against it while cutting, arcsec
    /// (the controller's share: the worm wheel's own errors are the machine's).
    law: Option<(f64, f64)>,
    cut_error_arcsec: Option<(f64, f64)>,
    /// Frames the injected faults took away or added: PDOs dropped, garbage frames sent.
    pdos_dropped: u64,
    garbage_sent: u64,
}

impl VirtualMachine {
    /// The virtual machine at power-on with the machine standing at `start`; with
    /// `simulation.drive_counters = "incremental"` X and Y stand at a random position
    /// within their travel instead (from `simulation.seed`; near their home position with
    /// `simulation.power_on_near_home_mm`) and every drive's counter starts at 0.
    pub fn new(machine: &MachineConfig, plant: &PlantConfig, start: Start, gashes: u32) -> Self {
        let plan = BusPlan::from_machine(machine);
        let spindle = (plan.spindle_encoder.index, plan.spindle_encoder.sub);
        let names = ["hob-sim drive B (table)", "hob-sim drive X", "hob-sim drive Y"];
        let start = match plant.simulation.drive_counters {
            DriveCounters::Referenced => start,
            DriveCounters::Incremental => match plant.simulation.power_on_near_home_mm {
                Some(mm) => Start::random_near_home(machine, plant.simulation.seed, mm, start.table_deg),
                None => Start::random_within_travel(machine, plant.simulation.seed, start.table_deg),
            },
        };
        let physics = Plant::new(plant, machine, start, gashes);
        let counts_per_turn = [
            machine.table.encoder_counts_per_motor_rev,
            machine.x.encoder_counts_per_motor_rev,
            machine.y.encoder_counts_per_motor_rev,
        ];
        let drives = std::array::from_fn(|i| {
            let node = plan.drives[i].node;
            let d = &physics.drives[i];
            let homing = d.supported_modes().contains(&MODE_HOMING).then_some(d.homing);
            Node::new(
                node,
                drive_od(
                    node,
                    names[i],
                    (i == 0).then_some(spindle),
                    d.supported_modes(),
                    homing,
                    counts_per_turn[i].saturating_mul(FOLLOWING_WINDOW_MOTOR_TURNS),
                    gain_objects(servo(&physics, i).gains()),
                ),
            )
        });
        Self {
            plant: physics,
            plan,
            drives,
            io: Node::new(plan.io.node, io_od(plan.io.node)),
            state: [PowerState::SwitchOnDisabled; 3],
            homing_start_seen: [false; 3],
            controlword_before: [0; 3],
            time_s: 0.0,
            nominal_s: 0.0,
            timing: hob_plant::sim::SyncTiming::new(plant, plan.cycle_s),
            period_s: plan.cycle_s,
            syncs: 0,
            drop: 0.0,
            delay: 0,
            garbage: 0,
            delayed: VecDeque::new(),
            rng: plant.simulation.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1,
            powered_before: false,
            cutting_syncs: 0,
            law: None,
            cut_error_arcsec: None,
            pdos_dropped: 0,
            garbage_sent: 0,
            physics_owed: false,
            node_clock_s: 0.0,
            superseded: false,
            superseded_syncs: 0,
            late_rates: [plant.simulation.tpdo_late_rate, plant.simulation.rpdo_late_rate],
            late_rng: plant.simulation.seed.wrapping_mul(0xD1B5_4A32_D192_ED03) | 1,
            applied_targets: None,
        }
    }

    /// Whether this frame is late, at the plant file's rate `k` (0 TPDO, 1 RPDO).
    fn late(&mut self, k: usize) -> bool {
        self.late_rates[k] > 0.0 && hob_plant::rng::uniform(&mut self.late_rng) < self.late_rates[k]
    }

    /// Every node sends its boot-up message (power-on).
    pub fn power_on(&mut self, out: &mut Vec<Frame>) {
        for n in self.nodes_mut() {
            n.power_on(out);
        }
    }

    fn nodes_mut(&mut self) -> impl Iterator<Item = &mut Node> {
        self.drives.iter_mut().chain(std::iter::once(&mut self.io))
    }

    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    /// SYNCs during which the tool was in the work.
    pub fn cutting_syncs(&self) -> u64 {
        self.cutting_syncs
    }

    pub fn syncs(&self) -> u64 {
        self.syncs
    }

    /// SYNCs left unanswered because the simulator read them late, together with a later
    /// one (see [`Self::on_frames`]).
    pub fn superseded_syncs(&self) -> u64 {
        self.superseded_syncs
    }

    pub fn drive_state(&self, axis: Axis) -> PowerState {
        self.state[match axis {
            Axis::B => 0,
            Axis::X => 1,
            Axis::Y => 2,
        }]
    }

    pub fn nmt_state(&self, node: u8) -> Option<NmtState> {
        self.drives
            .iter()
            .chain(std::iter::once(&self.io))
            .find(|n| n.id == node)
            .map(|n| n.nmt)
    }

    pub fn inject(&mut self, f: VmFault) {
        self.settle();
        match f {
            VmFault::Plant(i) => self.plant.inject(i),
            VmFault::Drop(p) => self.drop = p,
            VmFault::Delay(n) => self.delay = n,
            VmFault::Garbage(n) => self.garbage = n,
            VmFault::Clear => {
                self.plant.clear_injections();
                (self.drop, self.delay, self.garbage) = (0.0, 0, 0);
                for n in self.nodes_mut() {
                    n.silent = false;
                }
            }
            VmFault::Silent(node) => {
                for n in self.nodes_mut() {
                    if n.id == node {
                        n.silent = true;
                    }
                }
            }
        }
    }

    fn random(&mut self) -> u64 {
        self.rng ^= self.rng >> 12;
        self.rng ^= self.rng << 25;
        self.rng ^= self.rng >> 27;
        self.rng.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// Computes the physics of the period since the last SYNC if that is still owed. A
    /// SYNC's answer goes out before them (send `out`, then call this while the bus is
    /// quiet); every other entry point calls it first, so the order never matters.
    pub fn settle(&mut self) {
        if self.physics_owed {
            self.physics_owed = false;
            self.plant.advance_to(self.time_s);
            let cutting = self.plant.cutting();
            self.cutting_syncs += u64::from(cutting);
            if let (true, Some((ratio, differential))) = (cutting, self.law) {
                let p = &self.plant;
                let e = (p.table_drive_deg() - ratio * p.spindle_deg() - differential * p.y_mm()) * 3600.0;
                let (lo, hi) = self.cut_error_arcsec.unwrap_or((e, e));
                self.cut_error_arcsec = Some((lo.min(e), hi.max(e)));
            }
        }
    }

    /// Grades the truth against this gearbox law (the program's `ratio_signed` and
    /// `differential_signed_deg_per_mm`; its phase is whatever the engagement made).
    pub fn set_law(&mut self, ratio: f64, differential_deg_per_mm: f64) {
        self.law = Some((ratio, differential_deg_per_mm));
    }

    /// The spread (greatest minus least) of the table drive's true error against the law over
    /// every SYNC in the cut, arcsec: twice the deviation from its centre (one engagement,
    /// one phase). None before a cut.
    pub fn cut_error_spread_arcsec(&self) -> Option<f64> {
        self.cut_error_arcsec.map(|(lo, hi)| hi - lo)
    }

    /// PDOs the injected `drop` took away.
    pub fn pdos_dropped(&self) -> u64 {
        self.pdos_dropped
    }

    /// Garbage frames the injected `garbage` sent.
    pub fn garbage_sent(&self) -> u64 {
        self.garbage_sent
    }

    /// Handles one frame from the bus; frames to send are appended to `out`.
    pub fn on_frame(&mut self, f: &Frame, out: &mut Vec<Frame>) {
        self.settle();
        let now = self.node_clock_s;
        let mut sync = false;
        for i in 0..3 {
            let e = self.drives[i].handle(f, now, out);
            sync |= e.sync;
            if e.reset {
                self.state[i] = PowerState::SwitchOnDisabled;
            }
            // The mode first: a frame that brings a mode and the controlword (RPDO2 with
            // both) starts homing in the mode it brings.
            if e.wrote(object::MODES_OF_OPERATION) {
                self.on_mode(i);
            }
            if e.wrote(object::CONTROLWORD) {
                self.on_controlword(i, out);
            }
            if e.wrote(object::VELOCITY_CONTROL_PARAMETERS) || e.wrote(object::POSITION_CONTROL_PARAMETERS) {
                self.on_gains(i);
            }
        }
        let e = self.io.handle(f, now, out);
        sync |= e.sync;
        if f.id == hob_canopen::frame::SYNC && (sync || self.any_operational()) {
            self.on_sync(out);
        }
    }

    /// Handles the frames read from the bus in one go, in order. A process scheduled late
    /// reads several SYNCs at once; a drive latches each SYNC in hardware and answers it
    /// within the period, so an answer to any but the last would reach the master after
    /// the next SYNC and pass for that one's. Those SYNCs are latched and their periods
    /// computed, but their synchronous TPDOs are not sent: the master sees a missed frame,
    /// as from a drive whose answer is lost, never a stale one. Event-driven TPDOs (a
    /// changed statusword) still go out. Returns whether a SYNC was handled
    /// (its answer is in `out`).
    pub fn on_frames(&mut self, batch: &[Frame], out: &mut Vec<Frame>) -> bool {
        let sync = hob_canopen::frame::SYNC;
        let last_sync = batch.iter().rposition(|f| f.id == sync);
        for (i, f) in batch.iter().enumerate() {
            self.superseded = f.id == sync && last_sync.is_some_and(|l| i < l);
            self.on_frame(f, out);
        }
        self.superseded = false;
        last_sync.is_some()
    }

    /// The next SYNC arrived before the answer to the last one went out: the synchronous
    /// TPDOs in `out` are withdrawn (see [`Self::on_frames`]); everything else there is
    /// still sent. An event-driven TPDO (a statusword that changed) reports a change, not
    /// a measurement at a SYNC: withheld, the master would keep the old state until the
    /// next change.
    pub fn withdraw_answer(&mut self, out: &mut Vec<Frame>) {
        let before = out.len();
        out.retain(|f| !self.answers_sync(f.id));
        if out.len() < before {
            self.superseded_syncs += 1;
        }
    }

    /// Whether `id` is a synchronous TPDO of one of the nodes (an answer to a SYNC).
    fn answers_sync(&self, id: u16) -> bool {
        self.drives
            .iter()
            .chain(std::iter::once(&self.io))
            .any(|n| n.is_sync_tpdo(id))
    }

    fn any_operational(&self) -> bool {
        self.drives
            .iter()
            .chain(std::iter::once(&self.io))
            .any(|n| n.nmt == NmtState::Operational)
    }

    /// 0x6060 was written (its value is one the drive implements: the dictionary refuses
    /// others, by SDO with an abort, by RPDO by ignoring them): the mode takes effect at
    /// once, in any power state, and 0x6061 shows it.
    fn on_mode(&mut self, i: usize) {
        let mode = self.drives[i].od.u32(object::MODES_OF_OPERATION, 0) as u8 as i8;
        if self.plant.set_drive_mode(i, mode) {
            self.drives[i]
                .od
                .put(object::MODES_DISPLAY, 0, u64::from(mode as u8));
            self.put_statusword(i);
        }
    }

    /// 0x60F9 or 0x60FB was written (a value in its range: the dictionary refuses others):
    /// the servo's loops take the gains at once.
    fn on_gains(&mut self, i: usize) {
        let od = &self.drives[i].od;
        let g = DriveGains {
            values: gains::OBJECTS.map(|(index, sub, _)| od.u32(index, sub)),
        };
        servo_mut(&mut self.plant, i).set_gains(ServoGains {
            velocity_kp_nm_s_per_rad: g.velocity_kp_nm_s_per_rad(),
            velocity_integral_time_s: g.velocity_integral_time_s(),
            position_kv_per_s: g.position_kv_per_s(),
        });
    }

    /// The gains the drive's servo loops use (B, X, Y by `i`).
    pub fn servo_gains(&self, i: usize) -> ServoGains {
        servo(&self.plant, i).gains()
    }

    fn on_controlword(&mut self, i: usize, out: &mut Vec<Frame>) {
        let cw = self.drives[i].od.u32(object::CONTROLWORD, 0) as u16;
        if cw & cia402::CW_HOMING_START != 0 && self.controlword_before[i] & cia402::CW_HOMING_START == 0 {
            self.homing_start_seen[i] = true;
        }
        self.controlword_before[i] = cw;
        let before = self.state[i];
        let mut next = cia402::drive_transition(before, cw);
        // Without power at the stage the drive cannot switch on.
        if !self.plant.drives_have_power()
            && matches!(next, PowerState::SwitchedOn | PowerState::OperationEnabled)
        {
            next = PowerState::SwitchOnDisabled;
        }
        if before == PowerState::Fault && next != PowerState::Fault {
            // Fault reset: the drive clears the fault if its cause is gone.
            let servo = match i {
                0 => &self.plant.table,
                1 => &self.plant.x,
                _ => &self.plant.y,
            };
            if servo.fault {
                next = PowerState::Fault;
            } else {
                self.plant.drives[i].reset_fault();
                out.push(self.emcy(i, 0x0000, 0));
            }
        }
        self.set_state(i, next);
    }

    /// An EMCY of drive `i`.
    fn emcy(&self, i: usize, code: u16, register: u8) -> Frame {
        Emcy {
            node: self.drives[i].id,
            code,
            register,
            vendor: [0; 5],
        }
        .frame()
    }

    fn set_state(&mut self, i: usize, s: PowerState) {
        self.state[i] = s;
        self.put_statusword(i);
    }

    /// The statusword: the power state's bits, and in homing mode the homing progress in
    /// bits 13, 12, 10 (CiA 402-2; `hob_canopen::cia402::HomingProgress`).
    fn put_statusword(&mut self, i: usize) {
        let d = &self.plant.drives[i];
        let mut sw = self.state[i].statusword();
        if d.mode_display() == MODE_HOMING {
            let h = d.homing_bits();
            for (on, bit) in [
                (h.error, cia402::SW_HOMING_ERROR),
                (h.attained, cia402::SW_HOMING_ATTAINED),
                (h.target_reached, cia402::SW_TARGET_REACHED),
            ] {
                if on {
                    sw |= bit;
                }
            }
        }
        self.drives[i].od.put(object::STATUSWORD, 0, u64::from(sw));
    }

    fn fault(&mut self, i: usize, code: u16, out: &mut Vec<Frame>) {
        if self.state[i] != PowerState::Fault {
            self.set_state(i, PowerState::Fault);
            out.push(self.emcy(i, code, 0x01));
        }
    }

    /// A SYNC: apply the targets received since the last one, latch, send the TPDOs;
    /// the physics of the coming period are owed until [`Self::settle`].
    fn on_sync(&mut self, out: &mut Vec<Frame>) {
        self.syncs += 1;
        let mut targets = [0i32; 3];
        let mut enable = [false; 3];
        let mut commands = [DriveCommand {
            target_counts: 0,
            enable: false,
            mode: 0,
            homing_start: false,
            halt: false,
        }; 3];
        for i in 0..3 {
            let d = &self.drives[i];
            targets[i] = d.od.u32(object::TARGET_POSITION, 0) as i32;
            enable[i] = self.state[i] == PowerState::OperationEnabled && d.nmt == NmtState::Operational;
            let cw = d.od.u32(object::CONTROLWORD, 0) as u16;
            if let Some(h) = self.plant.drives[i]
                .supported_modes()
                .contains(&MODE_HOMING)
                .then(|| homing_params(&d.od))
            {
                self.plant.drives[i].homing = h;
            }
            commands[i] = DriveCommand {
                target_counts: targets[i],
                enable: enable[i],
                mode: self.plant.drives[i].mode_display(),
                // A rising edge since the last SYNC, even if bit 4 fell again.
                homing_start: cw & cia402::CW_HOMING_START != 0 || self.homing_start_seen[i],
                halt: cw & CW_HALT != 0,
            };
            if self.homing_start_seen[i] {
                self.plant.drives[i].homing_start_rose();
            }
        }
        if let Some(applied) = self.applied_targets {
            for i in 0..3 {
                if self.late(1) {
                    targets[i] = applied[i];
                    commands[i].target_counts = applied[i];
                }
            }
        }
        self.applied_targets = Some(targets);
        let io = &self.io.od;
        let dout = io.u32(DIGITAL_OUTPUTS, 1) | io.u32(DIGITAL_OUTPUTS, 2) << 8;
        let ch = 1 + self.plan.spindle_analog_channel;
        let analog = io.u32(ANALOG_OUTPUTS, ch) as u16 as i16;
        let volts = f64::from(analog.max(0)) / 32767.0 * self.plan.analog_full_scale_v;
        self.plant.apply_io(dout, volts);
        self.plant.apply_drive_commands(&commands);
        self.homing_start_seen = [false; 3];

        // Latch.
        let powered = self.plant.drives_have_power();
        let servos = [&self.plant.table, &self.plant.x, &self.plant.y];
        let faulted: [bool; 3] = std::array::from_fn(|i| servos[i].fault);
        let positions: [i64; 3] = std::array::from_fn(|i| self.plant.drive_counter(i));
        let csp: [bool; 3] = std::array::from_fn(|i| self.plant.drives[i].mode_display() == cia402::MODE_CSP);
        for i in 0..3 {
            self.drives[i]
                .od
                .put(object::POSITION_ACTUAL, 0, positions[i] as i32 as u32 as u64);
            if faulted[i] {
                self.fault(i, 0x2310, out);
            } else if let Some(code) = self.plant.drives[i].fault() {
                // The drive's own fault: a hardware limit.
                self.fault(i, code, out);
            } else if enable[i]
                && csp[i]
                // In the drive's 32-bit counts, as a drive compares them: the target and the
                // position both wrap (every 27 table turns in 2^20 counts per motor turn).
                && targets[i].wrapping_sub(positions[i] as i32).unsigned_abs()
                    > self.drives[i].od.u32(0x6065, 0)
            {
                self.fault(i, 0x8611, out);
            } else if !powered
                && self.powered_before
                && matches!(
                    self.state[i],
                    PowerState::OperationEnabled | PowerState::SwitchedOn | PowerState::ReadyToSwitchOn
                )
            {
                // Safe torque off by the safety relay.
                self.set_state(i, PowerState::SwitchOnDisabled);
                out.push(self.emcy(i, 0x5441, 0x01));
            }
            if self.drives[i].master_lost(self.node_clock_s) && self.state[i] == PowerState::OperationEnabled
            {
                // Communication error reaction: quick stop.
                self.set_state(i, PowerState::QuickStopActive);
                out.push(self.emcy(i, 0x8130, 0x11));
            }
        }
        self.powered_before = powered;
        for i in 0..3 {
            self.put_statusword(i);
        }
        let spindle = self.plant.spindle_counts();
        let enc = self.plan.spindle_encoder;
        self.drives[0].od.put(enc.index, enc.sub, spindle as u32 as u64);
        let din = self.plant.input_image();
        for s in 0..3u8 {
            self.io
                .od
                .put(DIGITAL_INPUTS, s + 1, u64::from((din >> (8 * s)) & 0xFF));
        }
        if let (Some(g), Some(counts)) = (self.plant.table_gauge(), self.plant.table_gauge_counts())
            && g.channel < ANALOG_INPUT_CHANNELS
        {
            self.io
                .od
                .put(ANALOG_INPUTS, g.channel + 1, u64::from(counts as u16));
        }

        // TPDOs, through the injected faults.
        self.node_clock_s += self.period_s;
        let now = self.node_clock_s;
        let mut tx = Vec::new();
        for n in self.drives.iter_mut().chain(std::iter::once(&mut self.io)) {
            n.transmit_pdos(true, now, &mut tx);
            n.heartbeat(now, &mut tx);
        }
        self.superseded_syncs += u64::from(self.superseded);
        for f in tx {
            let is_pdo = is_pdo(f.id);
            if self.superseded && self.answers_sync(f.id) {
                continue;
            }
            if is_pdo && self.drop > 0.0 && (self.random() >> 11) as f64 / (1u64 << 53) as f64 <= self.drop {
                self.pdos_dropped += 1;
                continue;
            }
            if self.drives.iter().any(|n| n.is_sync_tpdo(f.id)) && self.late(0) {
                continue;
            }
            if is_pdo && self.delay > 0 {
                self.delayed.push_back((self.syncs + u64::from(self.delay), f));
            } else {
                out.push(f);
            }
        }
        while self.delayed.front().is_some_and(|(due, _)| *due <= self.syncs) {
            if let Some((_, f)) = self.delayed.pop_front() {
                out.push(f);
            }
        }
        for _ in 0..self.garbage {
            let r = self.random();
            let f = if r & 1 == 0 {
                // An identifier nobody uses here (0x6E0..0x6FF: unassigned SDO range).
                Frame::new(
                    0x6E0 + ((r >> 8) & 0x1F) as u16,
                    &(r >> 16).to_le_bytes()[..((r >> 40) % 9) as usize],
                )
            } else {
                // A used TPDO identifier with a length no PDO of ours has (5 or 7 bytes).
                let d = &self.plan.drives[((r >> 8) % 3) as usize];
                Frame::new(
                    d.actual.cob_id,
                    &(r >> 16).to_le_bytes()[..if r & 2 == 0 { 5 } else { 7 }],
                )
            };
            self.garbage_sent += 1;
            out.push(f);
        }

        // The next SYNC's instant in the plant's time: nominal, plus its timing
        // disturbance (the plant file's jitter or measured lateness), as in the in-process
        // simulation: the drives latch and apply their targets when it comes.
        self.nominal_s += self.period_s;
        self.time_s = (self.nominal_s + self.timing.draw()).max(self.time_s);
        self.physics_owed = true;
    }

    /// Without SYNCs (boot, pre-operational, a dead master): the nodes' clock runs on
    /// wall time (`wall_dt_s` since the last call); heartbeats go on.
    pub fn idle(&mut self, wall_dt_s: f64, out: &mut Vec<Frame>) {
        self.settle();
        self.node_clock_s += wall_dt_s.max(0.0);
        let now = self.node_clock_s;
        for n in self.nodes_mut() {
            n.heartbeat(now, out);
        }
    }
}

/// The homing objects of a drive's dictionary.
fn homing_params(od: &Od) -> HomingParams {
    HomingParams {
        method: od.u32(object::HOMING_METHOD, 0) as u8 as i8,
        home_offset_counts: od.u32(object::HOME_OFFSET, 0) as i32,
        switch_speed_counts_s: od.u32(object::HOMING_SPEEDS, 1),
        zero_speed_counts_s: od.u32(object::HOMING_SPEEDS, 2),
        accel_counts_s2: od.u32(object::HOMING_ACCELERATION, 0),
    }
}

#[cfg(test)]
mod drive_tests;
#[cfg(test)]
mod tests;
