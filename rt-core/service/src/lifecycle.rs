//! The life of `hob-rt`, in the order the types allow and no other:
//!
//! 1. [`configure`] -> [`Configured`]: the machine file (validated), the loop's
//!    shared-memory publishers (the loop's alone: a second hob-rt is refused before it
//!    touches the bus), the CAN bus opened and booted (may block and fail; nothing
//!    real-time yet);
//! 2. [`Configured::activate`] -> [`Active`]: the helper
//!    threads (commands, stats) with their own ports, then the real-time set-up of this
//!    thread ([`RealTime::enter`] takes the ports and the started helpers as proof: memory
//!    is locked only after every mapping exists, and the helpers never inherit the loop's
//!    core and priority);
//! 3. [`Active::run`] -> [`Stopped`]: the loop, until a termination signal or N cycles;
//! 4. [`Stopped::finish`]: the helpers joined, the summary printed, the histograms written.

use crate::commands::{self, ThreadMailbox};
use crate::cycle::{LoopCounters, RtLoop};
use crate::recorder;
use crate::stats::{self, LoopTiming, StatsTiming, Timing};
use hob_can_transport::SystemClock;
use hob_can_transport::shm::open_bus;
use hob_canopen::bus::CanBus;
use hob_control::pitch_comp::PitchCompensation;
use hob_control::{ControlParams, Controller, Status};
use hob_ipc::iceoryx2;
use hob_ipc::{EventSample, StateSample, StatsSample, Svc};
use hob_master::{BootError, Booted, boot};
use hob_process_image::plan::BusPlan;
use hob_rt_os::alloc_guard;
use hob_rt_os::{IdleLatencyRequest, RtReport};
use hob_setup::config::machine::MachineConfig;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};
use std::thread::JoinHandle;
use std::time::Duration;

/// Why `hob-rt` could not start or stop cleanly: each with its exit status
/// ([`Failure::exit_code`]) and the words it prints.
#[derive(Debug)]
pub enum Failure {
    /// The machine state file (work offsets) is broken: never cut with offsets half read.
    StateFile(hob_setup::config::LoadError),
    /// The worm set's pitch compensation is broken or another set's: never apply one half
    /// read.
    Compensation(String),
    /// The loop's publishers could not be opened (another hob-rt on this instance?).
    Ports {
        error: hob_ipc::IpcError,
        instance: String,
    },
    /// The iceoryx2 node of the loop could not be made.
    Node(hob_ipc::IpcError),
    /// The CAN bus could not be opened.
    BusOpen(String),
    /// The bus did not come up.
    BusBoot { iface: String, error: BootError },
    /// A helper thread could not be started.
    Thread {
        which: &'static str,
        error: std::io::Error,
    },
    /// The command and stats threads did not report ready.
    HelpersNotReady,
    /// `--require-rt` and the real-time set-up is not complete (exit status 3).
    Degraded,
    /// The stats thread panicked: its figures are lost.
    StatsPanicked,
    /// The run's summary could not be written.
    Summary(serde_json::Error),
    /// A figure's file could not be written.
    Write { path: PathBuf, error: std::io::Error },
}

impl Failure {
    /// The process's exit status for it: 3 for a refused degraded start, else 1.
    pub fn exit_code(&self) -> u8 {
        match self {
            Failure::Degraded => 3,
            _ => 1,
        }
    }
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Failure::StateFile(e) => write!(f, "{e}"),
            Failure::Ports { error, instance } => {
                write!(f, "{error} (is another hob-rt running on instance {instance}?)")
            }
            Failure::Node(e) => write!(f, "{e}"),
            Failure::BusOpen(e) => f.write_str(e),
            Failure::BusBoot { iface, error } => write!(f, "bus boot on {iface}: {error}"),
            Failure::Compensation(e) => write!(f, "pitch compensation: {e}"),
            Failure::Thread { which, error } => write!(f, "{which} thread: {error}"),
            Failure::HelpersNotReady => f.write_str("the command and stats threads did not start"),
            Failure::Degraded => f.write_str("--require-rt: refusing to run degraded"),
            Failure::StatsPanicked => f.write_str("stats thread panicked"),
            Failure::Summary(e) => write!(f, "hob-rt.json: {e}"),
            Failure::Write { path, error } => write!(f, "{}: {error}", path.display()),
        }
    }
}

impl std::error::Error for Failure {}

/// What the command line chose.
#[derive(Debug, Clone, Default)]
pub struct Settings {
    /// CAN interface (`can0`, `vcan0`, `shm`); `None`: the machine file's.
    pub iface: Option<String>,
    /// Refuse to run without the full real-time set-up (exit status 3).
    pub require_rt: bool,
    /// The machine state file (work offsets); `None`: the machine file's `state.file`.
    pub state_file: Option<std::path::PathBuf>,
    /// Where flight records go; `None`: `flight/` beside the state file.
    pub flight_dir: Option<std::path::PathBuf>,
}

/// Stage 1: the machine is known and its bus is up.
pub struct Configured {
    machine: MachineConfig,
    iface: String,
    ports: LoopPorts,
    bus: Box<dyn CanBus>,
    booted: Booted,
    require_rt: bool,
    state_file: std::path::PathBuf,
    flight_dir: std::path::PathBuf,
    offsets: hob_control::Offsets,
    compensation: Option<PitchCompensation>,
}

/// Opens the bus the machine file (or `settings`) names and boots every node on it.
pub fn configure(machine: MachineConfig, settings: &Settings) -> Result<Configured, Failure> {
    let state_file = settings
        .state_file
        .clone()
        .unwrap_or_else(|| machine.state.file.clone().into());
    // The work offsets of the last touch-off: a broken file stops the start, as a broken
    // machine file does (never cut with offsets half read).
    let offsets = match hob_store::machine_state::load(&state_file).map_err(Failure::StateFile)? {
        hob_store::machine_state::Loaded::NotCalibrated => {
            eprintln!(
                "hob-rt: {}: no touch-off yet: work offsets 0 (touch off X and Y before cutting)",
                state_file.display()
            );
            hob_control::Offsets::default()
        }
        hob_store::machine_state::Loaded::Calibrated(s) => {
            eprintln!(
                "hob-rt: {}: work offsets X {:+.4} mm, Y {:+.4} mm (set {})",
                state_file.display(),
                s.x_offset_mm,
                s.y_offset_mm,
                s.set_at_utc
            );
            hob_control::Offsets {
                x_mm: s.x_offset_mm,
                y_mm: s.y_offset_mm,
            }
        }
    };
    let compensation = pitch_compensation(&machine, &state_file)?;
    let flight_dir = settings.flight_dir.clone().unwrap_or_else(|| {
        state_file
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."))
            .join("flight")
    });
    if let Err(e) = std::fs::create_dir_all(&flight_dir) {
        eprintln!(
            "hob-rt: WARNING: {}: {e}: flight records cannot be written",
            flight_dir.display()
        );
    }
    // The loop's publishers first, before the bus is touched: they are the loop's alone
    // (`hob_ipc::LOOP_ONLY`), so a second hob-rt on this instance is refused here, before
    // it could reset the nodes of the loop that runs.
    let ports = LoopPorts::open()?;
    let iface = settings
        .iface
        .clone()
        .unwrap_or_else(|| machine.can.interface.clone());
    let mut bus = open_bus(&iface, "hob-rt-can").map_err(Failure::BusOpen)?;
    let plan = BusPlan::from_machine(&machine);
    let booted = boot(
        &plan,
        &mut *bus,
        &mut SystemClock::new(),
        Duration::from_millis(500),
    )
    .map_err(|error| Failure::BusBoot {
        iface: iface.clone(),
        error,
    })?;
    for i in &booted.nodes {
        eprintln!(
            "hob-rt: node {} \"{}\" operational{}",
            i.node,
            i.name,
            if i.csp() { ", CSP" } else { "" }
        );
    }
    Ok(Configured {
        machine,
        iface,
        ports,
        bus,
        booted,
        require_rt: settings.require_rt,
        state_file,
        flight_dir,
        offsets,
        compensation,
    })
}

/// The pitch compensation `hob compensate` stored for the machine's worm set
/// (`table.worm_set`), checked as the control core will apply it: none without a worm set
/// or a file; a broken file, another set's, or values the control core refuses stop the
/// start, as a broken state file does. Loaded switched off: the operator switches it on.
fn pitch_compensation(
    machine: &MachineConfig,
    state_file: &Path,
) -> Result<Option<PitchCompensation>, Failure> {
    let Some(worm_set) = machine.table.worm_set.as_deref() else {
        eprintln!("hob-rt: no table.worm_set in the machine file: no pitch compensation");
        return Ok(None);
    };
    let stored = hob_store::pitch_compensation::load_for(state_file, worm_set)
        .map_err(|e| Failure::Compensation(e.to_string()))?;
    let Some(c) = stored else {
        eprintln!("hob-rt: no pitch compensation stored for worm set {worm_set:?}");
        return Ok(None);
    };
    let comp = PitchCompensation::from_arcsec(
        c.first_table_deg,
        &c.table_offsets_arcsec,
        c.hob_cos_arcsec,
        c.hob_sin_arcsec,
        c.tooth_phase_deg,
    )
    .map_err(|e| Failure::Compensation(format!("worm set {worm_set:?}: {}", e.text())))?;
    eprintln!(
        "hob-rt: pitch compensation for worm set {worm_set:?} loaded, switched off: {} points from \
         {:?} measured {} (computed {})",
        c.table_offsets_arcsec.len(),
        c.gear,
        c.measured_at,
        c.computed_at_utc
    );
    Ok(Some(comp))
}

/// Whether the machine file's drive delay was measured on the table drive on the bus
/// (`[commissioning.drive_delay]` naming the drive that answered at boot); says why not.
fn delay_commissioned(machine: &MachineConfig, nodes: &[hob_master::NodeInfo]) -> bool {
    use hob_setup::config::machine::commissioning::identity_text;
    let table = nodes.iter().find(|n| n.node == machine.table.can_node_id);
    let record = machine
        .commissioning
        .as_ref()
        .and_then(|c| c.drive_delay.as_ref());
    let why_not = match (record, table) {
        (None, _) => "the machine file has no [commissioning.drive_delay]".to_string(),
        (Some(_), None) => "the table drive did not answer at boot".to_string(),
        (Some(r), Some(t)) if !r.is_of(t.vendor_id, t.product_code, t.serial) => format!(
            "it was measured on another drive ({}); the table drive on the bus is {}",
            identity_text(
                r.table_drive_vendor_id,
                r.table_drive_product_code,
                r.table_drive_serial
            ),
            identity_text(t.vendor_id, t.product_code, t.serial)
        ),
        (Some(r), Some(_)) => {
            eprintln!(
                "hob-rt: the table drive's delay ({} us) was measured on this drive at {}",
                machine.control.drive_delay_us, r.utc
            );
            return true;
        }
    };
    eprintln!(
        "hob-rt: the table drive's delay is not commissioned: {why_not}; START and CONTINUE \
         are refused until `hob commission delay` has measured it (then restart hob-rt)"
    );
    false
}

/// What the loop will do with the spindle encoder's once-per-turn sine it identifies.
fn say_spindle_encoder(machine: &MachineConfig) {
    let record = machine
        .commissioning
        .as_ref()
        .and_then(|c| c.spindle_encoder.as_ref());
    match record {
        Some(r) => eprintln!(
            "hob-rt: the spindle encoder's error ({:.1} arcsec once per turn) was told apart from \
             the spindle's true swing ({:.1} arcsec at {:.0} rpm) at {}: the loop corrects only \
             the encoder's share of what it identifies",
            r.error_arcsec, r.swing_arcsec, r.reference_rpm, r.utc
        ),
        None if machine.control.spindle_encoder_identification_s > 0.0 => eprintln!(
            "hob-rt: the spindle encoder is not commissioned ([commissioning.spindle_encoder]): \
             the loop takes all of the once-per-turn sine it identifies for the encoder's error \
             (a true swing of the spindle too); `hob commission encoder` tells them apart"
        ),
        None => {}
    }
}

/// The answer to [`hob_ipc::command::NODES`]: one line per node that answered at boot,
/// with the gains read from the table drive ([`hob_ipc::nodes`] writes and reads it).
fn nodes_text(machine: &MachineConfig, nodes: &[hob_master::NodeInfo]) -> String {
    use hob_ipc::nodes::{DriveGains, NodeLine, write};
    let role = |id: u8| match id {
        _ if id == machine.table.can_node_id => "B",
        _ if id == machine.x.can_node_id => "X",
        _ if id == machine.y.can_node_id => "Y",
        _ if id == machine.io.can_node_id => "IO",
        _ => "?",
    };
    let lines: Vec<NodeLine> = nodes
        .iter()
        .map(|n| NodeLine {
            axis: role(n.node).to_string(),
            node: n.node,
            vendor_id: n.vendor_id,
            product_code: n.product_code,
            revision: n.revision,
            serial: n.serial,
            gains: n.gains.map(|g| DriveGains {
                velocity_kp_nm_s_per_rad: g.velocity_kp_nm_s_per_rad(),
                velocity_integral_time_ms: g.velocity_integral_time_ms(),
                position_kv_per_s: g.position_kv_per_s(),
            }),
        })
        .collect();
    write(&lines)
}

/// What became of the machine file's commissioned gains of the table drive
/// (`[commissioning.table_drive_gains]`): the boot wrote them when they name the table drive
/// on the bus; a record of another drive was not written, and the drive runs on its own.
fn say_table_drive_gains(machine: &MachineConfig, nodes: &[hob_master::NodeInfo]) {
    use hob_setup::config::machine::commissioning::identity_text;
    let table = nodes.iter().find(|n| n.node == machine.table.can_node_id);
    let record = machine
        .commissioning
        .as_ref()
        .and_then(|c| c.table_drive_gains.as_ref());
    let held = table.and_then(|t| t.gains).map_or_else(
        || "unknown (the drive serves no 0x60F9/0x60FB)".to_string(),
        |g| {
            format!(
                "velocity gain {:.4} N m s/rad, integral time {:.3} ms, position gain {:.2} 1/s",
                g.velocity_kp_nm_s_per_rad(),
                g.velocity_integral_time_ms(),
                g.position_kv_per_s()
            )
        },
    );
    match (record, table) {
        (None, _) | (Some(_), None) => eprintln!("hob-rt: the table drive's own gains: {held}"),
        (Some(r), Some(t)) if !r.is_of(t.vendor_id, t.product_code, t.serial) => eprintln!(
            "hob-rt: the commissioned table drive gains ([commissioning.table_drive_gains], {}) \
             were NOT written: they were measured on another drive ({}); the table drive on the \
             bus is {}; it runs on its own gains ({held}) until `hob commission response` has measured it",
            r.utc,
            identity_text(
                r.table_drive_vendor_id,
                r.table_drive_product_code,
                r.table_drive_serial
            ),
            identity_text(t.vendor_id, t.product_code, t.serial)
        ),
        (Some(r), Some(_)) => eprintln!(
            "hob-rt: the table drive runs on the gains commissioned at {} ({held}); its own were \
             {:.4} N m s/rad, {:.3} ms, {:.2} 1/s",
            r.utc,
            r.previous_velocity_kp_nm_s_per_rad,
            r.previous_velocity_integral_time_ms,
            r.previous_position_kv_per_s
        ),
    }
}

/// The loop's shared-memory ports (made before the memory lock: with `MCL_FUTURE` and a
/// small `RLIMIT_MEMLOCK` later mappings would fail).
pub struct LoopPorts {
    _node: iceoryx2::node::Node<Svc>,
    state: iceoryx2::port::publisher::Publisher<Svc, StateSample, ()>,
    events: iceoryx2::port::publisher::Publisher<Svc, EventSample, ()>,
}

impl LoopPorts {
    fn open() -> Result<Self, Failure> {
        let refused = |error: hob_ipc::IpcError| Failure::Ports {
            error,
            instance: hob_ipc::instance(),
        };
        let node = hob_ipc::node("hob-rt").map_err(Failure::Node)?;
        let state = hob_ipc::open_state(&node)
            .and_then(|s| hob_ipc::publisher(&s, "state publisher"))
            .map_err(refused)?;
        let events = hob_ipc::open_events(&node)
            .and_then(|s| hob_ipc::publisher(&s, "events publisher"))
            .map_err(refused)?;
        Ok(Self {
            _node: node,
            state,
            events,
        })
    }
}

/// The command and stats threads, started and ready (their ports open, off the loop's core).
#[derive(Debug)]
pub struct Helpers {
    stop: Arc<AtomicBool>,
    commands: JoinHandle<()>,
    stats: JoinHandle<Timing>,
    /// The flight records' writer: ends when the loop (its recorder) is gone.
    flight: JoinHandle<()>,
    rt_report: Arc<OnceLock<RtReport>>,
}

impl Helpers {
    #[allow(clippy::too_many_arguments)]
    fn start(
        machine: &MachineConfig,
        nodes_text: &str,
        iface: &str,
        state_file: &std::path::Path,
        flight_dir: &std::path::Path,
        flight_writer: recorder::Writer,
        thread_box: ThreadMailbox,
        stats_timing: StatsTiming,
        counters: &Arc<LoopCounters>,
    ) -> Result<Self, Failure> {
        let stop = Arc::new(AtomicBool::new(false));
        let rt_report: Arc<OnceLock<RtReport>> = Arc::new(OnceLock::new());
        let (ready_tx, ready_rx) = std::sync::mpsc::channel::<()>();
        let commands = {
            let stop = Arc::clone(&stop);
            let (machine, nodes_text) = (machine.clone(), nodes_text.to_string());
            let state_file = state_file.to_path_buf();
            let flight_dir = flight_dir.to_path_buf();
            let ready_tx = ready_tx.clone();
            std::thread::Builder::new()
                .name("hob-rt-commands".into())
                .spawn(move || {
                    let ready = || {
                        let _ = ready_tx.send(());
                    };
                    hob_rt_os::keep_off_core(machine.service.loop_core);
                    if let Err(e) = commands::serve(
                        &machine,
                        &nodes_text,
                        &state_file,
                        &flight_dir,
                        &thread_box,
                        &stop,
                        ready,
                    ) {
                        eprintln!("hob-rt: {e}");
                    }
                })
                .map_err(|error| Failure::Thread {
                    which: "command",
                    error,
                })?
        };
        let stats = {
            let stop = Arc::clone(&stop);
            let counters = Arc::clone(counters);
            let period_ns = u64::from(machine.control.cycle_period_us) * 1000;
            let rt_report = Arc::clone(&rt_report);
            let bus_kind = if iface == "shm" {
                hob_ipc::bus_kind::SHARED_MEMORY
            } else {
                hob_ipc::bus_kind::SOCKETCAN
            };
            let loop_core = machine.service.loop_core;
            std::thread::Builder::new()
                .name("hob-rt-stats".into())
                .spawn(move || {
                    hob_rt_os::keep_off_core(loop_core);
                    stats_loop(
                        stats_timing,
                        &counters,
                        &stop,
                        period_ns,
                        &rt_report,
                        bus_kind,
                        &ready_tx,
                    )
                })
                .map_err(|error| Failure::Thread {
                    which: "stats",
                    error,
                })?
        };
        let flight = {
            let dir = flight_dir.to_path_buf();
            let loop_core = machine.service.loop_core;
            std::thread::Builder::new()
                .name("hob-rt-flight".into())
                .spawn(move || {
                    hob_rt_os::keep_off_core(loop_core);
                    flight_writer.serve(&dir);
                })
                .map_err(|error| Failure::Thread {
                    which: "flight record",
                    error,
                })?
        };
        let ready = (0..2).all(|_| ready_rx.recv_timeout(Duration::from_secs(10)).is_ok());
        if !ready {
            return Err(Failure::HelpersNotReady);
        }
        Ok(Self {
            stop,
            commands,
            stats,
            flight,
            rt_report,
        })
    }
}

/// The real-time set-up of the loop's thread, held while the loop runs.
#[derive(Debug)]
pub struct RealTime {
    pub report: RtReport,
    pub kernel_preempt_rt: bool,
    _idle_request: Option<IdleLatencyRequest>,
}

impl RealTime {
    /// Locks memory, pre-faults the stack, pins this thread and makes it SCHED_FIFO, and
    /// holds the idle-state request. Needs the ports and the started helpers: what must
    /// exist before the memory is locked and the thread becomes real-time.
    pub fn enter(_ports: &LoopPorts, _helpers: &Helpers, machine: &MachineConfig) -> Self {
        let mut report = RtReport::default();
        alloc_guard::prepare_pool();
        hob_rt_os::lock_memory(&mut report);
        hob_rt_os::prefault_stack(512 * 1024);
        hob_rt_os::pin(machine.service.loop_core, &mut report);
        hob_rt_os::set_fifo(machine.service.loop_priority, &mut report);
        let idle = hob_rt_os::hold_cpu_dma_latency(machine.service.cpu_dma_latency_us, &mut report);
        Self {
            report,
            kernel_preempt_rt: hob_rt_os::kernel_is_preempt_rt(),
            _idle_request: idle,
        }
    }

    fn announce(&self) {
        if !self.report.is_complete() {
            eprintln!("hob-rt: ************************************************************");
            eprintln!("hob-rt: DEGRADED: the loop runs without full real-time set-up:");
            for p in &self.report.problems {
                eprintln!("hob-rt:   - {p}");
            }
            eprintln!("hob-rt: ************************************************************");
        }
        if !self.kernel_preempt_rt {
            eprintln!(
                "hob-rt: note: the kernel is not PREEMPT_RT (/sys/kernel/realtime): latencies are not bounded"
            );
        }
    }

    fn summary(&self, iface: &str) -> String {
        let r = &self.report;
        format!(
            "hob-rt started on {iface}: {}, {}, {}{}{}",
            r.fifo_priority
                .map_or("no SCHED_FIFO".into(), |p| format!("SCHED_FIFO {p}")),
            r.core.map_or("not pinned".into(), |c| format!("core {c}")),
            if r.memory_locked {
                "memory locked"
            } else {
                "memory not locked"
            },
            r.cpu_dma_latency_us
                .map_or(", idle states not limited".into(), |us| format!(
                    ", idle exit latency <= {us} us"
                )),
            if self.kernel_preempt_rt {
                ", PREEMPT_RT"
            } else {
                ""
            }
        )
    }
}

/// Stage 2: everything set up, the loop about to run.
pub struct Active {
    /// The loop's iceoryx2 node: outlives its publishers (dropped with [`Stopped`]).
    _node: iceoryx2::node::Node<Svc>,
    machine: MachineConfig,
    iface: String,
    flight_dir: std::path::PathBuf,
    helpers: Helpers,
    realtime: RealTime,
    counters: Arc<LoopCounters>,
    rt_loop: RtLoop<Box<dyn CanBus>>,
}

impl Configured {
    /// Ports, helper threads, then the real-time set-up (exit status 3 with
    /// `--require-rt` when it is incomplete).
    pub fn activate(self) -> Result<Active, Failure> {
        let Configured {
            machine,
            iface,
            ports,
            mut bus,
            booted,
            require_rt,
            state_file,
            flight_dir,
            offsets,
            compensation,
        } = self;
        let (thread_box, loop_box) = commands::mailboxes();
        let (loop_timing, stats_timing): (LoopTiming, StatsTiming) = stats::circulation();
        let counters = Arc::new(LoopCounters::default());
        let mut params = ControlParams::from_machine(&machine);
        params.delay_commissioned = delay_commissioned(&machine, &booted.nodes);
        say_spindle_encoder(&machine);
        say_table_drive_gains(&machine, &booted.nodes);
        let nodes_text = nodes_text(&machine, &booted.nodes);
        let mut controller = Controller::new(params);
        controller.set_offsets(offsets);
        // Before the first cycle: the gearbox is out.
        controller.load_pitch_compensation(compensation);
        // The flight recorder's rings, before the memory lock.
        let (flight, flight_writer) = recorder::recorder(&controller, recorder::SEGMENT_CYCLES);
        let helpers = Helpers::start(
            &machine,
            &nodes_text,
            &iface,
            &state_file,
            &flight_dir,
            flight_writer,
            thread_box,
            stats_timing,
            &counters,
        )?;
        let realtime = RealTime::enter(&ports, &helpers, &machine);
        realtime.announce();
        if require_rt && !realtime.report.is_complete() {
            helpers.stop.store(true, Ordering::Relaxed);
            return Err(Failure::Degraded);
        }
        let _ = helpers.rt_report.set(realtime.report.clone());
        let mut cyclic = booted.cyclic;
        if cyclic.hear_own_sync(&mut *bus) {
            eprintln!(
                "hob-rt: {iface} echoes our SYNCs in bus order: each TPDO is matched to the SYNC it answers"
            );
        } else {
            eprintln!(
                "hob-rt: {iface} cannot echo our SYNCs in order: TPDOs are matched by counting the SYNCs each drive owes"
            );
        }
        let LoopPorts {
            _node: node,
            state,
            events,
        } = ports;
        let rt_loop = RtLoop::new(
            controller,
            cyclic,
            bus,
            state,
            events,
            loop_box,
            loop_timing,
            Arc::clone(&counters),
            flight,
        );
        Ok(Active {
            _node: node,
            machine,
            iface,
            flight_dir,
            helpers,
            realtime,
            counters,
            rt_loop,
        })
    }
}

/// Stage 3: the loop has stopped.
pub struct Stopped {
    _node: iceoryx2::node::Node<Svc>,
    machine: MachineConfig,
    iface: String,
    helpers: Helpers,
    realtime: RealTime,
    counters: Arc<LoopCounters>,
    status: Status,
}

impl Active {
    /// Runs the loop until `stop` is set (a termination signal) or `max_cycles` have run.
    pub fn run(mut self, stop: &AtomicBool, max_cycles: Option<u64>) -> Stopped {
        let summary = self.realtime.summary(&self.iface);
        eprintln!("hob-rt: {summary}");
        self.rt_loop.message(&summary);
        self.rt_loop.run(stop, max_cycles);
        self.rt_loop.message("hob-rt stopped");
        let status = self.rt_loop.controller.status();
        // The stop's flight record: the last seconds up to here (the loop has ended).
        match recorder::write(
            &self.flight_dir,
            self.rt_loop.recorder.live(),
            &recorder::Reason::Stop,
        ) {
            Ok(p) => eprintln!("hob-rt: flight record (stop) written: {}", p.display()),
            Err(e) => eprintln!("hob-rt: flight record (stop) NOT written: {e}"),
        }
        let dumps = (self.rt_loop.recorder.dumps, self.rt_loop.recorder.missed);
        if dumps.1 > 0 {
            eprintln!(
                "hob-rt: flight records: {} written, {} missed (the writer was busy)",
                dumps.0, dumps.1
            );
        }
        Stopped {
            _node: self._node,
            machine: self.machine,
            iface: self.iface,
            helpers: self.helpers,
            realtime: self.realtime,
            counters: self.counters,
            status,
        }
    }
}

/// `hob-rt.json`: what a run did, for the benchmarks and the gate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunSummary {
    pub cycles: u64,
    pub overruns: u64,
    pub period_ns: u64,
    pub fifo_priority: u32,
    pub core: i64,
    pub memory_locked: bool,
    pub cpu_dma_latency_us: Option<u32>,
    pub preempt_rt: bool,
    pub iface: String,
    pub system_allocations_in_cycles: u64,
    pub pool_blocks_in_cycles: u64,
    pub final_state: String,
}

impl Stopped {
    /// Joins the helpers, prints the run's figures and, given `hgrm`, writes the histograms
    /// and `hob-rt.json` there.
    pub fn finish(self, hgrm: Option<&Path>) -> Result<(), Failure> {
        self.helpers.stop.store(true, Ordering::Relaxed);
        let _ = self.helpers.commands.join();
        let _ = self.helpers.flight.join();
        let total = self.helpers.stats.join().map_err(|_| Failure::StatsPanicked)?;
        let overruns = self.counters.overruns.load(Ordering::Relaxed);
        let unpublished = self.counters.state_unpublished.load(Ordering::Relaxed);
        let (allocations, pool_blocks) = alloc_guard::counts().unwrap_or((0, 0));
        eprintln!(
            "hob-rt: stopped in state {} after {} cycles, {overruns} overruns, {unpublished} state samples not published; in cycles: {allocations} system heap allocations, {pool_blocks} pool blocks",
            self.status.state.name(),
            self.status.cycle,
        );
        let w = stats::percentiles(&total.wake_ns);
        let c = stats::percentiles(&total.compute_ns);
        eprintln!(
            "hob-rt: wake latency us: p50 {:.1} p99 {:.1} p99.9 {:.1} max {:.1}; compute us: p50 {:.1} p99.99 {:.1} max {:.1}",
            w.p50_ns as f64 / 1e3,
            w.p99_ns as f64 / 1e3,
            w.p999_ns as f64 / 1e3,
            w.max_ns as f64 / 1e3,
            c.p50_ns as f64 / 1e3,
            c.p9999_ns as f64 / 1e3,
            c.max_ns as f64 / 1e3
        );
        let Some(dir) = hgrm else { return Ok(()) };
        let r = &self.realtime.report;
        let summary = RunSummary {
            cycles: total.wake_ns.len(),
            overruns,
            period_ns: u64::from(self.machine.control.cycle_period_us) * 1000,
            fifo_priority: r.fifo_priority.unwrap_or(0),
            core: r.core.map_or(-1, i64::from),
            memory_locked: r.memory_locked,
            cpu_dma_latency_us: r.cpu_dma_latency_us,
            preempt_rt: self.realtime.kernel_preempt_rt,
            iface: self.iface.clone(),
            system_allocations_in_cycles: allocations,
            pool_blocks_in_cycles: pool_blocks,
            final_state: self.status.state.name().to_string(),
        };
        let json = serde_json::to_string(&summary).map_err(Failure::Summary)? + "\n";
        std::fs::create_dir_all(dir).map_err(|error| Failure::Write {
            path: dir.to_path_buf(),
            error,
        })?;
        let files = [
            ("wake.hgrm", stats::hgrm(&total.wake_ns)),
            ("compute.hgrm", stats::hgrm(&total.compute_ns)),
            ("wake.hist", stats::counts_text(&total.wake_ns)),
            ("compute.hist", stats::counts_text(&total.compute_ns)),
            ("hob-rt.json", json),
        ];
        for (name, text) in files {
            let p = dir.join(name);
            std::fs::write(&p, text).map_err(|error| Failure::Write {
                path: p.clone(),
                error,
            })?;
        }
        Ok(())
    }
}

fn stats_loop(
    mut timing: StatsTiming,
    counters: &LoopCounters,
    stop: &AtomicBool,
    period_ns: u64,
    report: &OnceLock<RtReport>,
    bus_kind: u8,
    ready: &std::sync::mpsc::Sender<()>,
) -> Timing {
    let publisher = hob_ipc::node("hob-rt-stats")
        .and_then(|n| {
            let p = hob_ipc::publisher(&hob_ipc::open_stats(&n)?, "stats publisher")?;
            Ok((n, p))
        })
        .map_err(|e| eprintln!("hob-rt: stats publisher: {e}"))
        .ok();
    let _ = ready.send(());
    let empty = RtReport::default();
    while !stop.load(Ordering::Relaxed) {
        timing.wait(Duration::from_millis(500));
        if let Some((_, p)) = &publisher {
            let report = report.get().unwrap_or(&empty);
            let s = StatsSample {
                cycle: counters.cycle.load(Ordering::Relaxed),
                period_ns,
                overruns: counters.overruns.load(Ordering::Relaxed),
                tx_errors: counters.tx_errors.load(Ordering::Relaxed),
                system_allocations_in_cycle: alloc_guard::counts().map_or(u64::MAX, |c| c.0),
                pool_allocations_in_cycle: alloc_guard::counts().map_or(0, |c| c.1),
                fifo_priority: report.fifo_priority.map_or(0, |p| p as i32),
                core: report.core.map_or(-1, |c| c as i32),
                memory_locked: u8::from(report.memory_locked),
                cpu_dma_latency_us: report.cpu_dma_latency_us.map_or(-1, |us| us as i32),
                bus_kind,
                ..timing.sample()
            };
            let _ = p.send_copy(s);
        }
    }
    timing.collect();
    timing.total
}

impl std::fmt::Debug for Configured {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Configured")
            .field("iface", &self.iface)
            .finish_non_exhaustive()
    }
}

impl std::fmt::Debug for LoopPorts {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LoopPorts").finish_non_exhaustive()
    }
}

impl std::fmt::Debug for Active {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Active").finish_non_exhaustive()
    }
}

impl std::fmt::Debug for Stopped {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Stopped").finish_non_exhaustive()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_run_summary_is_json_with_any_interface_name() {
        // The old hand-written JSON used Rust's escape_default, which is not JSON: a quote
        // or a non-ASCII character in the interface name broke the file.
        let s = RunSummary {
            cycles: 3,
            overruns: 0,
            period_ns: 1_000_000,
            fifo_priority: 80,
            core: -1,
            memory_locked: true,
            cpu_dma_latency_us: None,
            preempt_rt: false,
            iface: "can\"0\\é\u{1}".into(),
            system_allocations_in_cycles: 0,
            pool_blocks_in_cycles: 0,
            final_state: "idle".into(),
        };
        let text = serde_json::to_string(&s).unwrap_or_default();
        let v: serde_json::Value = serde_json::from_str(&text).unwrap_or_default();
        assert_eq!(v["iface"], "can\"0\\é\u{1}");
        assert_eq!(v["cpu_dma_latency_us"], serde_json::Value::Null);
        assert_eq!(v["core"], -1);
        let old = format!("{{\"iface\": \"{}\"}}", "can\"0\\é\u{1}".escape_default());
        assert!(
            serde_json::from_str::<serde_json::Value>(&old).map_or(true, |v| v["iface"] != "can\"0\\é\u{1}"),
            "escape_default happened to be JSON for this name"
        );
    }
}
