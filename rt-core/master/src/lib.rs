//! # hob-master: the CANopen master of the machine
//!
//! Pure: frames in, frames out. Where start-up waits (for a node's answer, for a drive to
//! change modes), it waits on the [`Clock`] and the [`CanBus`] it is given: the real ones
//! are the I/O edge's (`hob_can_transport::SystemClock` and the transports), a test's
//! are its own, so no wall clock is read here.
//!
//! - Start-up ([`boot`], may block on the clock): NMT reset, wait for every node's boot-up, read
//!   device type and identity, refuse a drive without cyclic synchronous position (0x6502)
//!   and X or Y without homing, read the table drive's loop gains (0x60F9, 0x60FB; first
//!   writing the machine file's commissioned set when it names that drive), configure heartbeats, modes, the homing parameters of X
//!   and Y, and PDOs by SDO, confirm each drive displays cyclic synchronous position
//!   (0x6061), start the network.
//! - The cycle ([`Cyclic`], no allocation, never blocks): take in the frames received
//!   since the last cycle, build the control core's inputs (what was latched at this
//!   cycle's SYNC, the drives' mode display and homing bits), send the targets for the
//!   next SYNC, event-driven modes with controlwords and outputs, then the SYNC itself;
//!   count TPDOs that did not arrive and hold their last value; watch heartbeats and
//!   EMCYs.

use hob_canopen::bus::{BusError, CanBus, Clock};
use hob_canopen::cia402::{self, PowerState, object};
use hob_canopen::emcy::Emcy;
use hob_canopen::frame::{Cob, Frame, SYNC, heartbeat_id};
use hob_canopen::nmt::{NmtCommand, NmtState};
use hob_canopen::pdo::as_i32;
use hob_canopen::sdo::{AbortCode, Progress, SdoClient, SdoError};
use hob_control::{AxisFeedback, CycleInputs, CycleOutputs};
use hob_process_image::gains::{self, DriveGains};
use hob_process_image::plan::{BusPlan, MASTER_NODE, PROFILE_DRIVE, PROFILE_IO};
use std::time::Duration;

/// What a node told about itself at boot.
#[derive(Debug, Clone, PartialEq)]
pub struct NodeInfo {
    pub node: u8,
    pub device_type: u32,
    pub name: String,
    pub vendor_id: u32,
    pub product_code: u32,
    pub revision: u32,
    pub serial: u32,
    /// 0x6502 for drives.
    pub supported_modes: Option<u32>,
    /// The table drive's loop gains (0x60F9:01, 0x60F9:02, 0x60FB:01, in the units of
    /// [`hob_process_image::gains`]) as read at boot, after a commissioned set was written;
    /// None on the other nodes and from a drive that aborts their upload (it has no such
    /// objects).
    pub gains: Option<DriveGains>,
}

impl NodeInfo {
    pub fn profile(&self) -> u32 {
        self.device_type & 0xFFFF
    }

    pub fn csp(&self) -> bool {
        self.supports(cia402::MODE_CSP)
    }

    /// Whether 0x6502 announces `mode` (false for a node that is no drive).
    pub fn supports(&self, mode: i8) -> bool {
        self.supported_modes
            .is_some_and(|m| cia402::supports_mode(m, mode))
    }
}

/// Why the bus could not be brought up.
#[derive(Debug, Clone, PartialEq)]
pub enum BootError {
    Bus(BusError),
    /// A node did not announce itself.
    NoBootUp {
        node: u8,
    },
    Sdo {
        node: u8,
        error: SdoError,
    },
    /// A node is not the device the configuration expects.
    WrongDevice {
        node: u8,
        expected_profile: u32,
        device_type: u32,
    },
    /// A drive without cyclic synchronous position mode.
    NoCsp {
        node: u8,
        supported_modes: u32,
    },
    /// A drive of X or Y without homing mode (6): the axis could not be referenced.
    NoHoming {
        node: u8,
        supported_modes: u32,
    },
    /// A drive that, after 0x6060 = 8 was written, does not display cyclic synchronous
    /// position in 0x6061.
    ModeNotTaken {
        node: u8,
        display: i8,
    },
    /// A node did not report operational after the start.
    NotOperational {
        node: u8,
    },
    /// The table drive does not hold a commissioned gain that was written to it.
    GainNotTaken {
        node: u8,
        index: u16,
        sub: u8,
        name: &'static str,
        written: u32,
        /// None: the drive aborted its upload.
        read: Option<u32>,
    },
}

impl std::fmt::Display for BootError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BootError::Bus(e) => write!(f, "bus: {e}"),
            BootError::NoBootUp { node } => write!(
                f,
                "node {node} did not boot (no boot-up message): powered, wired, node-ID set?"
            ),
            BootError::Sdo { node, error } => write!(f, "node {node}: {error}"),
            BootError::WrongDevice {
                node,
                expected_profile,
                device_type,
            } => write!(
                f,
                "node {node} is a CiA {} device (0x1000 = 0x{device_type:08X}), the configuration expects CiA {expected_profile}",
                device_type & 0xFFFF
            ),
            BootError::NoCsp {
                node,
                supported_modes,
            } => write!(
                f,
                "drive {node} does not support cyclic synchronous position mode (0x6502 = 0x{supported_modes:08X}, bit 7 clear): \
                 it cannot follow the electronic gearbox; use a drive with CSP"
            ),
            BootError::NoHoming {
                node,
                supported_modes,
            } => write!(
                f,
                "drive {node} does not support homing mode (6) (0x6502 = 0x{supported_modes:08X}, bit 5 clear): \
                 X and Y are referenced by the drive's homing; use a drive with homing"
            ),
            BootError::ModeNotTaken { node, display } => write!(
                f,
                "drive {node} did not take cyclic synchronous position: 0x6060 = 8 was written, 0x6061 displays {display}"
            ),
            BootError::NotOperational { node } => write!(f, "node {node} did not enter operational"),
            BootError::GainNotTaken {
                node,
                index,
                sub,
                name,
                written,
                read,
            } => write!(
                f,
                "drive {node} did not take the commissioned {name} ([commissioning.table_drive_gains]): \
                 {index:04X}:{sub:02X} = {written} was written, {} read back",
                read.map_or("nothing (upload aborted)".to_string(), |v| v.to_string())
            ),
        }
    }
}

impl std::error::Error for BootError {}

/// Waits for the next frame until `deadline` (start-up only).
fn recv_until(
    bus: &mut dyn CanBus,
    clock: &mut dyn Clock,
    deadline: Duration,
) -> Result<Option<Frame>, BootError> {
    loop {
        if let Some(f) = bus.try_recv().map_err(BootError::Bus)? {
            return Ok(Some(f));
        }
        if clock.now() >= deadline {
            return Ok(None);
        }
        clock.pause(Duration::from_micros(100));
    }
}

/// Runs one SDO transfer to the end (start-up and commissioning tools: blocks).
fn transfer(
    bus: &mut dyn CanBus,
    clock: &mut dyn Clock,
    client: &mut SdoClient,
    first: Frame,
    timeout: Duration,
) -> Result<(), SdoError> {
    // The object of the transfer, from its initiate request.
    let (index, sub) = (u16::from_le_bytes([first.data[1], first.data[2]]), first.data[3]);
    let not_sent = |error| SdoError::Send { index, sub, error };
    bus.send(&first).map_err(not_sent)?;
    let mut deadline = clock.now() + timeout;
    loop {
        let f = match recv_until(bus, clock, deadline) {
            Ok(Some(f)) => f,
            _ => {
                let abort = client.abort(AbortCode::TIMEOUT);
                let _ = bus.send(&abort);
                return Err(SdoError::Timeout { index, sub });
            }
        };
        match client.on_frame(&f) {
            Progress::Ignored => {}
            Progress::Send(next) => {
                bus.send(&next).map_err(not_sent)?;
                deadline = clock.now() + timeout;
            }
            Progress::Uploaded | Progress::Downloaded => return Ok(()),
            Progress::Failed(e, abort) => {
                if let Some(a) = abort {
                    let _ = bus.send(&a);
                }
                return Err(e);
            }
        }
    }
}

/// Reads `index:sub` of `node` (blocks up to `timeout` per frame).
pub fn sdo_read(
    bus: &mut dyn CanBus,
    clock: &mut dyn Clock,
    node: u8,
    index: u16,
    sub: u8,
    timeout: Duration,
) -> Result<Vec<u8>, SdoError> {
    let mut c = SdoClient::new(node);
    let first = c.upload(index, sub);
    transfer(bus, clock, &mut c, first, timeout)?;
    Ok(c.data().to_vec())
}

/// Writes `data` to `index:sub` of `node`.
pub fn sdo_write(
    bus: &mut dyn CanBus,
    clock: &mut dyn Clock,
    node: u8,
    index: u16,
    sub: u8,
    data: &[u8],
    timeout: Duration,
) -> Result<(), SdoError> {
    let mut c = SdoClient::new(node);
    let first = c.download(index, sub, data)?;
    transfer(bus, clock, &mut c, first, timeout)
}

fn u32_of(b: &[u8]) -> u32 {
    let mut v = [0u8; 4];
    let n = b.len().min(4);
    v[..n].copy_from_slice(&b[..n]);
    u32::from_le_bytes(v)
}

/// Reads what a node says about itself (0x1000, 0x1008, 0x1018, and 0x6502 on drives).
pub fn identify(
    bus: &mut dyn CanBus,
    clock: &mut dyn Clock,
    node: u8,
    timeout: Duration,
) -> Result<NodeInfo, SdoError> {
    let device_type = u32_of(&sdo_read(bus, clock, node, 0x1000, 0, timeout)?);
    let name = sdo_read(bus, clock, node, 0x1008, 0, timeout)
        .map(|b| String::from_utf8_lossy(&b).trim_end_matches('\0').to_string())
        .unwrap_or_default();
    let mut id = |sub| {
        sdo_read(bus, clock, node, 0x1018, sub, timeout)
            .map(|b| u32_of(&b))
            .unwrap_or(0)
    };
    let (vendor_id, product_code, revision, serial) = (id(1), id(2), id(3), id(4));
    let supported_modes = if device_type & 0xFFFF == PROFILE_DRIVE {
        Some(u32_of(&sdo_read(
            bus,
            clock,
            node,
            object::SUPPORTED_MODES,
            0,
            timeout,
        )?))
    } else {
        None
    };
    Ok(NodeInfo {
        node,
        device_type,
        name,
        vendor_id,
        product_code,
        revision,
        serial,
        supported_modes,
        gains: None,
    })
}

/// Reads a drive's loop gains; None when it aborts an upload (a drive without the objects,
/// or with other sub-indices), an error only when it does not answer.
pub fn read_gains(
    bus: &mut dyn CanBus,
    clock: &mut dyn Clock,
    node: u8,
    timeout: Duration,
) -> Result<Option<DriveGains>, SdoError> {
    let mut values = [0u32; 3];
    for (v, (index, sub, _)) in values.iter_mut().zip(gains::OBJECTS) {
        match sdo_read(bus, clock, node, index, sub, timeout) {
            Ok(b) => *v = u32_of(&b),
            Err(SdoError::Aborted { .. }) => return Ok(None),
            Err(e) => return Err(e),
        }
    }
    Ok(Some(DriveGains { values }))
}

/// The table drive's gains at boot: the machine file's commissioned set written first when
/// it names this drive (`info`'s identity), and read back (a value that differs is a boot
/// failure naming its object); then what the drive holds ([`read_gains`]). A set measured on
/// another drive is not written (`hob-rt` says so).
fn table_drive_gains(
    plan: &BusPlan,
    bus: &mut dyn CanBus,
    clock: &mut dyn Clock,
    info: &NodeInfo,
    timeout: Duration,
) -> Result<Option<DriveGains>, BootError> {
    let node = info.node;
    let sdo = |error| BootError::Sdo { node, error };
    let commissioned = plan
        .table_drive_gains
        .filter(|c| c.is_of(info.vendor_id, info.product_code, info.serial));
    if let Some(c) = commissioned {
        for w in c.gains.writes() {
            sdo_write(bus, clock, node, w.index, w.sub, &w.bytes(), timeout).map_err(sdo)?;
        }
    }
    let read = read_gains(bus, clock, node, timeout).map_err(sdo)?;
    if let Some(c) = commissioned {
        for (i, (index, sub, name)) in gains::OBJECTS.into_iter().enumerate() {
            let got = read.map(|g| g.values[i]);
            if got != Some(c.gains.values[i]) {
                return Err(BootError::GainNotTaken {
                    node,
                    index,
                    sub,
                    name,
                    written: c.gains.values[i],
                    read: got,
                });
            }
        }
    }
    Ok(read)
}

/// Reads 0x6061 until the drive displays cyclic synchronous position (the configuration
/// wrote 0x6060 = 8; a drive may take a moment to change modes), for up to `timeout`.
fn confirm_csp(
    bus: &mut dyn CanBus,
    clock: &mut dyn Clock,
    node: u8,
    timeout: Duration,
) -> Result<(), BootError> {
    let deadline = clock.now() + timeout;
    loop {
        let display = sdo_read(bus, clock, node, object::MODES_DISPLAY, 0, timeout)
            .map_err(|error| BootError::Sdo { node, error })?
            .first()
            .map_or(0, |b| *b as i8);
        if display == cia402::MODE_CSP {
            return Ok(());
        }
        if clock.now() >= deadline {
            return Err(BootError::ModeNotTaken { node, display });
        }
        clock.pause(Duration::from_millis(1));
    }
}

/// A bus that [`boot`] brought up: what each node said it is, and the cyclic exchange.
/// Only `boot` makes one, so the cyclic exchange cannot start on a bus that was not
/// configured (the order boot -> cycle is in the types, not in a comment).
#[derive(Debug)]
pub struct Booted {
    /// The nodes in the plan's order, as identified.
    pub nodes: Vec<NodeInfo>,
    /// The loop's part of the master, for this plan.
    pub cyclic: Cyclic,
}

/// Brings every node of `plan` from power-up to operational (start-up: blocks).
pub fn boot(
    plan: &BusPlan,
    bus: &mut dyn CanBus,
    clock: &mut dyn Clock,
    timeout: Duration,
) -> Result<Booted, BootError> {
    let nodes = plan.nodes();
    bus.send(&NmtCommand::ResetCommunication.frame(0))
        .map_err(BootError::Bus)?;
    let mut booted = [false; 4];
    let deadline = clock.now() + timeout * 4;
    while !booted.iter().all(|b| *b) {
        let Some(f) = recv_until(bus, clock, deadline)? else {
            let missing = nodes[booted.iter().position(|b| !b).unwrap_or(0)];
            return Err(BootError::NoBootUp { node: missing });
        };
        if let Some((node, NmtState::BootUp)) = NmtState::parse_heartbeat(&f)
            && let Some(i) = nodes.iter().position(|n| *n == node)
        {
            booted[i] = true;
        }
    }
    let mut infos = Vec::new();
    for node in nodes {
        let mut info = identify(bus, clock, node, timeout).map_err(|error| BootError::Sdo { node, error })?;
        let expected = if plan.drive(node).is_some() {
            PROFILE_DRIVE
        } else {
            PROFILE_IO
        };
        if info.profile() != expected {
            return Err(BootError::WrongDevice {
                node,
                expected_profile: expected,
                device_type: info.device_type,
            });
        }
        let drive = plan.drive(node);
        let supported_modes = info.supported_modes.unwrap_or(0);
        if drive.is_some() && !info.csp() {
            return Err(BootError::NoCsp {
                node,
                supported_modes,
            });
        }
        // X and Y switch to homing while the loop runs; the table never does.
        if drive.is_some_and(|d| d.homing.is_some()) && !info.supports(cia402::MODE_HOMING) {
            return Err(BootError::NoHoming {
                node,
                supported_modes,
            });
        }
        if node == plan.drives[0].node {
            info.gains = table_drive_gains(plan, bus, clock, &info, timeout)?;
        }
        for w in plan.node_configuration(node) {
            sdo_write(
                bus,
                clock,
                node,
                w.index,
                w.sub,
                &w.bytes()[..usize::from(w.size)],
                timeout,
            )
            .map_err(|error| BootError::Sdo { node, error })?;
        }
        if drive.is_some() {
            confirm_csp(bus, clock, node, timeout)?;
        }
        infos.push(info);
    }
    bus.send(&NmtCommand::Start.frame(0)).map_err(BootError::Bus)?;
    let mut operational = [false; 4];
    let deadline = clock.now() + timeout * 4;
    while !operational.iter().all(|b| *b) {
        let Some(f) = recv_until(bus, clock, deadline)? else {
            let missing = nodes[operational.iter().position(|b| !b).unwrap_or(0)];
            return Err(BootError::NotOperational { node: missing });
        };
        if let Some((node, NmtState::Operational)) = NmtState::parse_heartbeat(&f)
            && let Some(i) = nodes.iter().position(|n| *n == node)
        {
            operational[i] = true;
        }
    }
    Ok(Booted {
        nodes: infos,
        cyclic: Cyclic::new(*plan),
    })
}

/// The cycles of silence that reach `plan`'s heartbeat timeout: ceil(timeout / period), in
/// integers (the period in whole nanoseconds, at least 1), so that every period counts the
/// timeout, also one that does not divide it.
fn heartbeat_cycles(plan: &BusPlan) -> u32 {
    let period_ns = ((plan.cycle_s * 1e9).round() as u64).max(1);
    let timeout_ns = u64::from(plan.heartbeat_timeout_ms) * 1_000_000;
    u32::try_from(timeout_ns.div_ceil(period_ns)).unwrap_or(u32::MAX)
}

/// A node's liveness as the master sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Liveness {
    pub cycles_since_heartbeat: u32,
    pub state: Option<NmtState>,
}

/// Something the bus reported that the operator must see.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BusEvent {
    Emcy(Emcy),
    HeartbeatLost {
        node: u8,
    },
    /// A drive's synchronous TPDO late or lost: in `missed` cycles since its last such
    /// report, at most `longest_in_a_row` of them in a row. Reported at the first miss after
    /// a quiet second ([`TPDO_REPORT_S`]), at the miss that reaches the fault count, and for
    /// the misses in between at most once a second (a burst of late frames is a few counted
    /// reports, not an event per cycle); a silent drive's misses past the fault count are
    /// reported once its TPDOs come back. A report the event ring has no room for is kept
    /// and sent later: no miss goes uncounted.
    TpdoMissing {
        node: u8,
        missed: u32,
        longest_in_a_row: u32,
    },
    SendFailed(BusError),
}

/// Capacity of the bus event ring.
pub const BUS_EVENTS: usize = 64;

/// Time between two reports of a drive's missing TPDOs, s.
pub const TPDO_REPORT_S: f64 = 1.0;

/// One drive's missing TPDOs not reported yet.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
struct MissReport {
    unreported: u32,
    longest_in_a_row: u32,
    /// The cycle of the last report (None: never).
    last_cycle: Option<u64>,
}

/// The cyclic part of the master: no allocation, never blocks.
#[derive(Debug, Clone)]
pub struct Cyclic {
    plan: BusPlan,
    /// Per drive: raw position, spindle, statusword, mode display (0x6061); fresh this
    /// cycle.
    position: [i32; 3],
    spindle: i32,
    statusword: [u16; 3],
    mode_display: [i8; 3],
    fresh: [bool; 3],
    /// Per drive: SYNCs sent whose synchronous TPDO has not arrived yet, TPDOs drained
    /// this cycle, and whether the last cycle got one TPDO while still one behind.
    owed: [u32; 3],
    got: [u32; 3],
    one_behind: [bool; 3],
    /// Where the bus echoes our own SYNCs in bus order ([`Cyclic::hear_own_sync`]): SYNCs
    /// sent and heard, and per drive the SYNC its newest TPDO answers. No guessing then.
    own_sync_heard: bool,
    syncs_sent: u64,
    syncs_heard: u64,
    answers_sync: [u64; 3],
    misses: [u32; 3],
    miss_reports: [MissReport; 3],
    /// [`TPDO_REPORT_S`] in cycles (computed once).
    miss_report_cycles: u64,
    inputs: [u8; 3],
    inputs_seen: bool,
    /// The table gauge's reading received since the last cycle's inputs.
    gauge: Option<i16>,
    /// Per drive: the last RPDO2 sent (mode of operation, controlword) and the cycles since.
    last_control: [Option<(i8, u16)>; 3],
    controlword_age: [u32; 3],
    last_outputs: Option<[u8; 2]>,
    last_analog: Option<i16>,
    outputs_age: u32,
    analog_age: u32,
    liveness: [Liveness; 4],
    /// Each node's last EMCY error code (its `nodes()` order; 0x0000: none, or its
    /// "error reset" after the drive cleared its error).
    last_emcy: [u16; 4],
    /// Cycles of silence that reach the heartbeat timeout: ceil(timeout / period), in
    /// whole nanoseconds, computed once ([`heartbeat_cycles`]).
    heartbeat_cycles: u32,
    cycle: u64,
    events: [Option<BusEvent>; BUS_EVENTS],
    event_count: usize,
    lost_events: u64,
    /// Quick stop requested (by a watchdog or the operator): drives go to quick stop.
    quick_stop: bool,
}

impl Cyclic {
    /// Only [`boot`] (and this module's tests) make one.
    fn new(plan: BusPlan) -> Self {
        Self {
            plan,
            position: [0; 3],
            spindle: 0,
            statusword: [PowerState::SwitchOnDisabled.statusword(); 3],
            // What the boot read back from 0x6061 before the start; TPDO2 tells from then on.
            mode_display: [cia402::MODE_CSP; 3],
            fresh: [false; 3],
            owed: [0; 3],
            got: [0; 3],
            one_behind: [false; 3],
            own_sync_heard: false,
            syncs_sent: 0,
            syncs_heard: 0,
            answers_sync: [0; 3],
            misses: [0; 3],
            miss_reports: [MissReport::default(); 3],
            miss_report_cycles: (TPDO_REPORT_S / plan.cycle_s).ceil().max(1.0) as u64,
            inputs: [0; 3],
            inputs_seen: false,
            gauge: None,
            last_control: [None; 3],
            controlword_age: [u32::MAX; 3],
            last_outputs: None,
            last_analog: None,
            outputs_age: u32::MAX,
            analog_age: u32::MAX,
            liveness: [Liveness::default(); 4],
            last_emcy: [0; 4],
            heartbeat_cycles: heartbeat_cycles(&plan),
            cycle: 0,
            events: [None; BUS_EVENTS],
            event_count: 0,
            lost_events: 0,
            quick_stop: false,
        }
    }

    /// The cyclic exchange as [`boot`] leaves it, without a bus: for the fuzz harness
    /// (`bench/fuzz-harness`), which feeds it arbitrary frames.
    pub fn unbooted(plan: BusPlan) -> Self {
        Self::new(plan)
    }

    pub fn plan(&self) -> &BusPlan {
        &self.plan
    }

    /// Queues `e`; false (and counted lost) when the ring is full.
    fn event(&mut self, e: BusEvent) -> bool {
        if self.event_count < BUS_EVENTS {
            self.events[self.event_count] = Some(e);
            self.event_count += 1;
            true
        } else {
            self.lost_events += 1;
            false
        }
    }

    /// Counts drive `i`'s miss this cycle (if `missed`) and reports what is unreported when
    /// it is time ([`BusEvent::TpdoMissing`]).
    fn report_misses(&mut self, i: usize, missed: bool) {
        let cycle = self.cycle;
        let in_a_row = self.misses[i];
        let to_fault = self.plan.tpdo_misses_to_fault;
        let every = self.miss_report_cycles;
        let r = &mut self.miss_reports[i];
        let quiet = r.last_cycle.is_none_or(|c| cycle.saturating_sub(c) >= every);
        if missed {
            r.unreported = r.unreported.saturating_add(1);
            r.longest_in_a_row = r.longest_in_a_row.max(in_a_row);
        }
        let at_fault = missed && in_a_row == to_fault;
        // A drive silent past the fault count: its run is counted and reported when it ends.
        let silent = missed && in_a_row > to_fault;
        if r.unreported > 0 && !silent && (quiet || at_fault) {
            let e = BusEvent::TpdoMissing {
                node: self.plan.drives[i].node,
                missed: r.unreported,
                longest_in_a_row: r.longest_in_a_row,
            };
            if self.event(e) {
                self.miss_reports[i] = MissReport {
                    last_cycle: Some(cycle),
                    ..MissReport::default()
                };
            }
        }
    }

    /// Events since the last call (fixed storage; the caller copies them out).
    pub fn take_events(&mut self, out: &mut [Option<BusEvent>; BUS_EVENTS]) -> usize {
        let n = self.event_count;
        out[..n].copy_from_slice(&self.events[..n]);
        self.event_count = 0;
        n
    }

    pub fn liveness(&self) -> [Liveness; 4] {
        self.liveness
    }

    /// Each node's last EMCY error code (B, X, Y, the I/O coupler; 0: none or reset).
    pub fn last_emcy(&self) -> [u16; 4] {
        self.last_emcy
    }

    /// Each drive's statusword (0x6041) as last received (B, X, Y).
    pub fn statuswords(&self) -> [u16; 3] {
        self.statusword
    }

    /// Whether every drive whose synchronous TPDO came in the last cycle has sent it
    /// again since the last [`Self::inputs`] (a lockstep runner waits for this; a drive
    /// that went silent is not waited for).
    pub fn all_fresh(&self) -> bool {
        let silent = self.plan.tpdo_misses_to_fault;
        self.fresh
            .iter()
            .zip(&self.misses)
            .all(|(f, m)| *f || *m >= silent)
    }

    /// Asks `bus` to deliver our own SYNCs among the received frames, in bus order
    /// ([`CanBus::echo_own_sync`]; start-up only). Where it can, a TPDO answers the SYNC
    /// heard last before it, so a late answer is never taken for this cycle's; where it
    /// cannot (the shared-memory virtual CAN), the count of SYNCs owed decides. Returns which.
    pub fn hear_own_sync(&mut self, bus: &mut dyn CanBus) -> bool {
        self.own_sync_heard = bus.echo_own_sync();
        self.own_sync_heard
    }

    /// Without the echo: whether drive `i`'s newest TPDO answers the last SYNC, by
    /// counting. A synchronous TPDO answers exactly one SYNC, in order. A node that fell
    /// behind (its answers arrive late, then in a burst) sends values of an older SYNC:
    /// they are the newest known but not this cycle's measurement. One behind two cycles
    /// running with one answer each is a lost frame, not lag: forgiven.
    fn counted_current(&mut self, i: usize) -> bool {
        let mut owed = self.owed[i].saturating_sub(self.got[i]);
        if self.got[i] == 1 && owed >= 1 {
            if self.one_behind[i] {
                owed = 0;
            }
            self.one_behind[i] = true;
        } else {
            self.one_behind[i] = false;
        }
        self.owed[i] = owed;
        self.got[i] > 0 && owed == 0
    }

    /// Requests quick stop of every drive (kept until cleared).
    pub fn set_quick_stop(&mut self, on: bool) {
        self.quick_stop = on;
    }

    /// Takes in one received frame.
    pub fn receive(&mut self, f: &Frame) {
        match Cob::of(f.id) {
            Cob::Sync if self.own_sync_heard => self.syncs_heard += 1,
            Cob::Tpdo(n, node) => {
                if let Some(i) = self.plan.drives.iter().position(|d| d.node == node) {
                    let d = self.plan.drives[i];
                    if n == 1 {
                        if let Some(v) = d.actual.unpack(f) {
                            self.position[i] = as_i32(v[0]);
                            if d.actual.entries().len() > 1 {
                                self.spindle = as_i32(v[1]);
                            }
                            self.fresh[i] = true;
                            self.got[i] = self.got[i].saturating_add(1);
                            self.answers_sync[i] = self.syncs_heard;
                        }
                    } else if n == 2
                        && let Some(v) = d.status.unpack(f)
                    {
                        self.statusword[i] = v[0] as u16;
                        self.mode_display[i] = v[1] as u8 as i8;
                    }
                } else if node == self.plan.io.node
                    && n == 1
                    && let Some(v) = self.plan.io.inputs.unpack(f)
                {
                    self.inputs = [v[0] as u8, v[1] as u8, v[2] as u8];
                    self.inputs_seen = true;
                } else if node == self.plan.io.node
                    && n == 2
                    && let Some(v) = self.plan.io.gauge.and_then(|g| g.unpack(f))
                {
                    self.gauge = Some(v[0] as u16 as i16);
                }
            }
            Cob::Emcy(_) => {
                if let Some(e) = Emcy::parse(f) {
                    if let Some(i) = self.plan.nodes().iter().position(|n| *n == e.node) {
                        self.last_emcy[i] = e.code;
                    }
                    self.event(BusEvent::Emcy(e));
                }
            }
            Cob::Heartbeat(node) => {
                if let Some((node, state)) =
                    NmtState::parse_heartbeat(&Frame::new(heartbeat_id(node), f.payload()))
                    && let Some(i) = self.plan.nodes().iter().position(|n| *n == node)
                {
                    self.liveness[i] = Liveness {
                        cycles_since_heartbeat: 0,
                        state: Some(state),
                    };
                }
            }
            _ => {}
        }
    }

    /// The control core's inputs for this cycle (latched at this cycle's SYNC). A drive
    /// whose TPDO did not arrive keeps its last value and is marked not fresh.
    pub fn inputs(&mut self) -> CycleInputs {
        self.cycle += 1;
        // A node is lost at the first cycle whose silence (the cycles since its heartbeat's
        // own cycle, which counts 1) reaches the timeout: once, when the count passes it.
        let lost_at = self.heartbeat_cycles.saturating_add(1);
        for i in 0..4 {
            let l = &mut self.liveness[i];
            l.cycles_since_heartbeat = l.cycles_since_heartbeat.saturating_add(1);
            if l.cycles_since_heartbeat == lost_at {
                let node = self.plan.nodes()[i];
                self.event(BusEvent::HeartbeatLost { node });
            }
        }
        let mut fb = [AxisFeedback::default(); 3];
        #[allow(clippy::needless_range_loop)] // five arrays indexed by drive
        for i in 0..3 {
            let current = if self.own_sync_heard {
                // Exact: the newest TPDO answers the last SYNC sent.
                self.got[i] > 0
                    && self.answers_sync[i] == self.syncs_sent
                    && self.syncs_heard == self.syncs_sent
            } else {
                self.counted_current(i)
            };
            self.got[i] = 0;
            if current {
                self.misses[i] = 0;
            } else {
                self.misses[i] = self.misses[i].saturating_add(1);
            }
            self.report_misses(i, !current);
            let state = PowerState::from_statusword(self.statusword[i]);
            let sw = self.statusword[i];
            fb[i] = AxisFeedback {
                position_counts: self.position[i],
                enabled: state == PowerState::OperationEnabled,
                fault: matches!(state, PowerState::Fault | PowerState::FaultReactionActive),
                // The control core counts the misses and faults after the configured number.
                fresh: current,
                // As received in TPDO2 (the boot's reading until the first one): the loop
                // relies on a mode only once the drive displays it.
                mode_display: self.mode_display[i],
                // Meaningful in homing mode only; the control core looks at them there.
                homing: hob_control::HomingBits {
                    attained: sw & cia402::SW_HOMING_ATTAINED != 0,
                    error: sw & cia402::SW_HOMING_ERROR != 0,
                    target_reached: sw & cia402::SW_TARGET_REACHED != 0,
                },
            };
            self.fresh[i] = false;
        }
        let io_alive = self.liveness[3].cycles_since_heartbeat < lost_at;
        // Synchronous like the table drive's position: a reading that came with the table's
        // current one was latched at the same SYNC (one without it is not paired).
        CycleInputs {
            table_gauge_counts: self.gauge.take().filter(|_| fb[0].fresh),
            io_valid: self.inputs_seen && io_alive,
            spindle_counts: self.spindle,
            table: fb[0],
            x: fb[1],
            y: fb[2],
            digital_inputs: u32::from(self.inputs[0])
                | u32::from(self.inputs[1]) << 8
                | u32::from(self.inputs[2]) << 16,
        }
    }

    /// Sends this cycle's targets, event-driven modes with controlwords (RPDO2) and
    /// outputs, the heartbeat when due, and the SYNC that applies them. Never blocks; a
    /// full queue is reported.
    ///
    /// RPDO2 carries the mode the loop asks for (`out.drive_modes`; the table always
    /// cyclic synchronous position) and the controlword of the power state machine, with
    /// bit 4 (homing start) set while that drive is asked for homing, `out.homing_start`
    /// holds it and the controlword is "enable operation" (homing runs only in operation
    /// enabled; the stopping commands stay as they are). It goes out when the mode or the
    /// controlword changed, at most once per `can.event_rpdo_spacing_ms` (disabling and
    /// quick stop at once): the loop holds bit 4 until the drive reports progress, since a
    /// one-cycle pulse can fall inside the spacing.
    pub fn transmit(&mut self, out: &CycleOutputs, bus: &mut dyn CanBus) -> Result<(), BusError> {
        let spacing = (f64::from(self.plan.event_rpdo_spacing_ms) / 1000.0 / self.plan.cycle_s).ceil() as u32;
        let mut first_error = None;
        let targets = [
            (out.table_target_counts, out.table_velocity_counts_s),
            (out.x_target_counts, out.x_velocity_counts_s),
            (out.y_target_counts, out.y_velocity_counts_s),
        ];
        for (i, target) in targets.into_iter().enumerate() {
            self.transmit_drive(i, target, out, spacing, bus, &mut first_error);
        }
        self.transmit_outputs(out, spacing, bus, &mut first_error);
        self.transmit_analog(out, spacing, bus, &mut first_error);
        self.transmit_heartbeat(bus, &mut first_error);
        self.transmit_sync(bus, &mut first_error);
        match first_error {
            Some(e) => {
                self.event(BusEvent::SendFailed(e));
                Err(e)
            }
            None => Ok(()),
        }
    }

    /// Drive `i`'s target and velocity (RPDO1), and its mode with the controlword (RPDO2)
    /// when due.
    fn transmit_drive(
        &mut self,
        i: usize,
        (target, velocity): (i32, f64),
        out: &CycleOutputs,
        spacing: u32,
        bus: &mut dyn CanBus,
        first_error: &mut Option<BusError>,
    ) {
        let d = self.plan.drives[i];
        let f = d
            .target
            .pack(&[target as u32 as u64, velocity.round() as i32 as u32 as u64]);
        send_noting(bus, &f, first_error);
        let state = PowerState::from_statusword(self.statusword[i]);
        let base = if self.quick_stop && state == PowerState::OperationEnabled {
            cia402::command::QUICK_STOP
        } else {
            cia402::next_controlword(state, out.drives_enabled && !self.quick_stop)
        };
        let mode = if d.homing.is_some() {
            out.drive_modes[i].code()
        } else {
            cia402::MODE_CSP
        };
        let homing_start =
            mode == cia402::MODE_HOMING && out.homing_start[i] && base == cia402::command::ENABLE_OPERATION;
        let cw = if homing_start {
            base | cia402::CW_HOMING_START
        } else {
            base
        };
        self.controlword_age[i] = self.controlword_age[i].saturating_add(1);
        let changed = self.last_control[i] != Some((mode, cw));
        // Steps towards "enabled" and mode changes at most once per spacing (the
        // bus-load figure counts on it); disabling and quick stop go at once. An
        // unanswered step is repeated.
        let stopping = base == cia402::command::DISABLE_VOLTAGE || base == cia402::command::QUICK_STOP;
        let due = self.controlword_age[i] >= spacing;
        if (changed && (due || stopping)) || self.controlword_age[i] >= spacing * 4 {
            send_noting(
                bus,
                &d.control.pack(&[u64::from(mode as u8), u64::from(cw)]),
                first_error,
            );
            self.last_control[i] = Some((mode, cw));
            self.controlword_age[i] = 0;
        }
    }

    /// The I/O coupler's digital outputs: switching on waits for the spacing; switching
    /// off (PC-OK, spindle, coolant) goes at once.
    fn transmit_outputs(
        &mut self,
        out: &CycleOutputs,
        spacing: u32,
        bus: &mut dyn CanBus,
        first_error: &mut Option<BusError>,
    ) {
        let io = self.plan.io;
        let dout = [out.digital_outputs as u8, (out.digital_outputs >> 8) as u8];
        self.outputs_age = self.outputs_age.saturating_add(1);
        let only_off = self
            .last_outputs
            .is_some_and(|old| (dout[0] & !old[0]) | (dout[1] & !old[1]) == 0);
        if self.last_outputs != Some(dout) && (self.outputs_age >= spacing || only_off) {
            send_noting(
                bus,
                &io.outputs.pack(&[u64::from(dout[0]), u64::from(dout[1])]),
                first_error,
            );
            self.last_outputs = Some(dout);
            self.outputs_age = 0;
        }
    }

    /// The spindle's speed reference on the coupler's analog output, when it changed.
    fn transmit_analog(
        &mut self,
        out: &CycleOutputs,
        spacing: u32,
        bus: &mut dyn CanBus,
        first_error: &mut Option<BusError>,
    ) {
        let analog = self.plan.analog_counts(out.spindle_analog_v);
        self.analog_age = self.analog_age.saturating_add(1);
        if self.last_analog != Some(analog) && self.analog_age >= spacing {
            let mut values = [0u64; 2];
            values[usize::from(self.plan.spindle_analog_channel.min(1))] = analog as u16 as u64;
            send_noting(bus, &self.plan.io.analog.pack(&values), first_error);
            self.last_analog = Some(analog);
            self.analog_age = 0;
        }
    }

    /// The master's own heartbeat, when due.
    fn transmit_heartbeat(&mut self, bus: &mut dyn CanBus, first_error: &mut Option<BusError>) {
        let hb_cycles = (f64::from(self.plan.heartbeat_ms) / 1000.0 / self.plan.cycle_s)
            .round()
            .max(1.0) as u64;
        if self.cycle.is_multiple_of(hb_cycles) {
            send_noting(bus, &NmtState::Operational.heartbeat(MASTER_NODE), first_error);
        }
    }

    /// The SYNC that applies this cycle's frames: each drive owes its TPDO from then on.
    fn transmit_sync(&mut self, bus: &mut dyn CanBus, first_error: &mut Option<BusError>) {
        let sync = bus.send(&Frame::new(SYNC, &[]));
        if sync.is_ok() {
            self.syncs_sent += 1;
            // Each drive owes this SYNC's TPDO (bounded: a silent node is a fault long before).
            for o in &mut self.owed {
                *o = (*o + 1).min(1_000);
            }
        } else if let Err(e) = sync
            && first_error.is_none()
        {
            *first_error = Some(e);
        }
    }
}

/// Sends `f`, keeping the first error of the cycle (the rest of the cycle's frames still
/// go out).
fn send_noting(bus: &mut dyn CanBus, f: &Frame, first_error: &mut Option<BusError>) {
    if let Err(e) = bus.send(f)
        && first_error.is_none()
    {
        *first_error = Some(e);
    }
}

#[cfg(test)]
mod tests;
