//! The machine configuration (`config/machine.toml`): what the machine is, set once by the
//! machine builder at commissioning. Loaded with serde (unknown keys refused) and validated
//! completely before anything runs.

use crate::{LoadError, Problems, parse_toml};
use hob_gearing::cutting::SpindleDrive;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Counting direction of a drive or encoder relative to the frame of
/// [`hob_gearing::signs`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Polarity {
    Normal,
    Inverted,
}

impl Polarity {
    pub fn sign(self) -> f64 {
        match self {
            Polarity::Normal => 1.0,
            Polarity::Inverted => -1.0,
        }
    }
}

/// Electrical level at which a digital signal is active.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Active {
    High,
    Low,
}

/// The whole machine.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MachineConfig {
    pub machine: Identity,
    pub control: ControlConfig,
    pub gearbox: GearboxConfig,
    pub can: CanConfig,
    pub service: ServiceConfig,
    pub spindle: SpindleConfig,
    pub table: TableConfig,
    pub x: LinearAxisConfig,
    pub y: LinearAxisConfig,
    pub process: ProcessLimits,
    pub lube: LubeConfig,
    pub jog: JogConfig,
    pub overrides: OverrideConfig,
    pub io: IoMap,
    pub library: LibraryConfig,
    pub state: StateConfig,
    pub setup: SetupConfig,
    /// What `hob commission` measured (absent until it ran).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub commissioning: Option<commissioning::Commissioning>,
}

/// The operator's program and tool library (`hob lib`, later the HMI): a directory with
/// `programs/` and `tools/` (crate `hob-store`).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct LibraryConfig {
    /// Absolute path of the library directory; `hob --library DIR` or `HOB_LIBRARY`
    /// override it.
    pub dir: String,
}

/// The machine state file of `hob-rt` (work offsets from touch-off; crate `hob-store`).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct StateConfig {
    /// Absolute path of the state file, written atomically.
    pub file: String,
}

/// Setting up the part: how far the operator's set-up input may move the work before the
/// loop asks for a confirmation.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SetupConfig {
    /// A touch-off is refused as needing the operator's confirmation when it would move
    /// the work offset by more than this, put the hob's tip this far off the loaded
    /// blank's outside diameter (X), or this far into the blank's root cylinder (mm;
    /// `hob_control::setup_math::check_touch_off`).
    pub touch_off_confirm_mm: f64,
}

/// Jogging: before X and Y are referenced, and the dead-man of the continuous jog.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct JogConfig {
    /// The speed of every X and Y jog until the axis is referenced (no soft limits yet:
    /// the hardware limit switches are the only protection).
    pub unreferenced_mm_min: f64,
    /// A continuous jog runs only while its frontend renews it: after this long without a
    /// renewal the axis is stopped.
    pub deadman_timeout_ms: u32,
}

/// The operator's overrides of the programmed feed and spindle speed, in percent.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct OverrideConfig {
    pub feed_min_percent: f64,
    pub feed_max_percent: f64,
    pub spindle_min_percent: f64,
    pub spindle_max_percent: f64,
}

/// CiA 402 homing of a linear axis: the drive finds its home switch and the index pulse
/// by itself (0x6060 = 6); the position there becomes `home_position_mm` (0x607C).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct HomingConfig {
    /// 0x6098: 3 or 4 (home switch active on its positive side: the index pulse before
    /// or after its edge), 5 or 6 (active on its negative side).
    pub method: i8,
    /// The axis position at the home position (mm).
    pub home_position_mm: f64,
    /// 0x6099 sub 1 and 2: towards the switch, then slowly to the index pulse.
    pub switch_search_mm_min: f64,
    pub zero_search_mm_min: f64,
    /// 0x609A.
    pub accel_mm_s2: f64,
    /// Referencing that takes longer is a fault.
    pub timeout_s: f64,
}

impl HomingConfig {
    fn validate(&self, key: &str, axis: &LinearAxisConfig, p: &mut Problems) {
        let k = |name: &str| format!("{key}.{name}");
        p.require(
            HOMING_METHODS.contains(&self.method),
            &k("method"),
            || {
                format!(
                    "must be a CiA 402 homing method with a home switch and the index pulse: 3, 4, 5 or 6 (is {})",
                    self.method
                )
            },
        );
        p.require(
            self.home_position_mm.is_finite()
                && (axis.soft_limit_min_mm..=axis.soft_limit_max_mm).contains(&self.home_position_mm),
            &k("home_position_mm"),
            || {
                format!(
                    "must be within the soft limits {} .. {} mm (is {})",
                    axis.soft_limit_min_mm, axis.soft_limit_max_mm, self.home_position_mm
                )
            },
        );
        p.positive(&k("switch_search_mm_min"), self.switch_search_mm_min);
        p.positive(&k("zero_search_mm_min"), self.zero_search_mm_min);
        p.positive(&k("accel_mm_s2"), self.accel_mm_s2);
        p.positive(&k("timeout_s"), self.timeout_s);
        p.require(
            self.switch_search_mm_min <= axis.rapid_mm_min,
            &k("switch_search_mm_min"),
            || {
                format!(
                    "must not exceed rapid_mm_min {} (is {})",
                    axis.rapid_mm_min, self.switch_search_mm_min
                )
            },
        );
        p.require(
            self.zero_search_mm_min <= self.switch_search_mm_min,
            &k("zero_search_mm_min"),
            || {
                format!(
                    "must not exceed switch_search_mm_min {} (the index pulse is found slowly) (is {})",
                    self.switch_search_mm_min, self.zero_search_mm_min
                )
            },
        );
        p.require(
            self.accel_mm_s2 <= axis.max_accel_mm_s2,
            &k("accel_mm_s2"),
            || {
                format!(
                    "must not exceed max_accel_mm_s2 {} (is {})",
                    axis.max_accel_mm_s2, self.accel_mm_s2
                )
            },
        );
    }
}

/// The homing methods the controller can use (home switch and index pulse); the same
/// list as `hob_canopen::cia402::HOMING_METHODS_SWITCH_AND_INDEX` (hob-setup depends on
/// no protocol crate; a test in hob-process-image compares them).
pub const HOMING_METHODS: [i8; 4] = [3, 4, 5, 6];

/// The real-time service `hob-rt` and its safety watchdog on the machine PC.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ServiceConfig {
    /// CPU core the 1 kHz loop is pinned to (isolate it: `isolcpus`, `nohz_full`).
    pub loop_core: u32,
    /// SCHED_FIFO priority of the loop (1 .. 98; the kernel's IRQ threads run at 50).
    pub loop_priority: u32,
    /// SCHED_FIFO priority of the safety watchdog (below the loop's).
    pub watchdog_priority: u32,
    /// The watchdog acts when the loop's state stream is missing for this long.
    pub watchdog_deadline_ms: u32,
    /// Longest idle-state exit latency the CPUs may have while `hob-rt` runs (a PM QoS
    /// request on `/dev/cpu_dma_latency`, as cyclictest makes); 0: no idle state but polling.
    pub cpu_dma_latency_us: u32,
}

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Identity {
    /// Shown to the operator.
    pub name: String,
}

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ControlConfig {
    /// Control cycle and CANopen SYNC period.
    pub cycle_period_us: u32,
    /// From the SYNC at which a target is applied to the instant the drive's position
    /// follows it (CSP interpolation over one period plus the servo's own lag). The
    /// spindle angle is predicted one cycle plus this far ahead.
    pub drive_delay_us: u32,
    /// Bandwidth of the spindle angle/speed/acceleration observer.
    pub spindle_observer_bandwidth_hz: f64,
    /// Time constant of the identification of the spindle encoder's once-per-turn error
    /// (its code disc's eccentricity), taken out of the reading while the spindle turns
    /// above 60 rpm; 0: off.
    pub spindle_encoder_identification_s: f64,
    /// Spindle speed within this share of the set speed counts as reached.
    pub spindle_speed_tolerance: f64,
    /// Time the spindle may take to reach its speed before it is a fault.
    pub spindle_start_timeout_s: f64,
    /// The X clamp must report closed (or open) within this time.
    pub x_clamp_timeout_s: f64,
    /// "Continue" after a pass was interrupted in its cut re-enters it at the Y where it
    /// stopped, less the pass's feed per table revolution (every tooth gap was cut by the
    /// hob within that distance behind the stop) and less this overlap.
    pub resume_overlap_mm: f64,
}

/// The electronic gearbox: engagement, synchronism windows, cross-coupling.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct GearboxConfig {
    /// Time to ramp the coupling in (or out) while the spindle runs.
    pub engage_time_s: f64,
    /// The feed into the cut waits until the synchronisation error is inside this window.
    pub fine_window_arcsec: f64,
    /// Leaving this window in the cut is a fault.
    pub coarse_window_arcsec: f64,
    /// Cross-coupling compensation of the synchronisation error on the table command.
    pub ccc_enabled: bool,
    /// Proportional gain (table correction per arcsec of error).
    pub ccc_kp: f64,
    /// Integral gain, 1/s.
    pub ccc_ki_per_s: f64,
    /// Bound of the correction.
    pub ccc_limit_arcsec: f64,
    /// Table speed of the phase correction that brings the table onto the recorded tooth gap.
    pub phase_sync_speed_deg_s: f64,
}

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CanConfig {
    /// SocketCAN interface, e.g. `can0`.
    pub interface: String,
    pub bitrate_bit_s: u32,
    /// Heartbeat period of the master and of every node.
    pub heartbeat_ms: u16,
    /// A node whose heartbeat is missing this long is lost.
    pub heartbeat_timeout_ms: u16,
    /// Synchronous TPDOs missing this many cycles in a row is a fault (the last value is
    /// held meanwhile).
    pub tpdo_misses_to_fault: u32,
    /// Map the velocity offset 0x60B1 into the target RPDO (8 instead of 4 bytes per
    /// drive and cycle). Off: the drives take the velocity from their CSP interpolation.
    pub velocity_feed_forward_in_pdo: bool,
    /// The B drive's object carrying the spindle encoder (auxiliary encoder input,
    /// vendor-specific: take it from the drive's object dictionary at commissioning).
    pub spindle_encoder_index: u16,
    pub spindle_encoder_subindex: u8,
    /// Inhibit time of the drives' statusword TPDO.
    pub statusword_inhibit_ms: u16,
    /// Inhibit time of the I/O coupler's input TPDO.
    pub inputs_inhibit_ms: u16,
    /// Least time between two event-driven RPDOs of one kind (controlword, outputs).
    pub event_rpdo_spacing_ms: u16,
    /// `hob bus-load` refuses a configuration whose worst case exceeds this share.
    pub bus_load_limit: f64,
}

/// Axis C: hob spindle, induction motor on a VFD, encoder on the spindle.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SpindleConfig {
    pub encoder_counts_per_rev: u32,
    pub encoder_polarity: Polarity,
    pub motor_to_spindle_ratio: f64,
    pub motor_rated_rpm: f64,
    pub vfd_hz_at_full_scale: f64,
    pub motor_rpm_at_full_scale: f64,
    pub analog_full_scale_v: f64,
    pub max_spindle_rpm: f64,
    /// VFD ramp time from 0 to full scale.
    pub vfd_ramp_s: f64,
}

impl SpindleConfig {
    pub fn drive(&self) -> SpindleDrive {
        SpindleDrive {
            motor_to_spindle_ratio: self.motor_to_spindle_ratio,
            vfd_hz_at_full_scale: self.vfd_hz_at_full_scale,
            motor_rpm_at_full_scale: self.motor_rpm_at_full_scale,
            analog_full_scale_v: self.analog_full_scale_v,
        }
    }
}

/// Axis B: work table, AC servo through a worm gear.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct TableConfig {
    pub can_node_id: u8,
    pub polarity: Polarity,
    pub encoder_counts_per_motor_rev: u32,
    pub worm_ratio: f64,
    pub motor_max_rpm: f64,
    pub max_table_rpm: f64,
    pub max_accel_deg_s2: f64,
    pub max_following_error_deg: f64,
    /// What the motor's and the drive's data sheets say of the table drive, for
    /// `hob commission response` (absent: that measurement is refused).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drive_model: Option<TableDriveModel>,
    /// The table's worm and wheel set as the builder names it (e.g. `B-2019-07`): a gear's
    /// pitch compensation is measured on, and kept for, one set (`hob compensate`); absent,
    /// a compensation is refused. Non-empty, at most [`WORM_SET_MAX_CHARS`] printable ASCII
    /// characters.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub worm_set: Option<String>,
}

/// The longest name `table.worm_set` may have.
pub const WORM_SET_MAX_CHARS: usize = 64;

/// Whether `name` is a valid `table.worm_set`: non-empty, at most [`WORM_SET_MAX_CHARS`]
/// printable ASCII characters (a space is printable).
pub fn is_worm_set_name(name: &str) -> bool {
    !name.trim().is_empty()
        && name.len() <= WORM_SET_MAX_CHARS
        && name.chars().all(|c| c.is_ascii_graphic() || c == ' ')
}

/// The table drive as its data sheets describe it: what a measurement at the loop's 1 kHz
/// cannot see (it acts above a quarter of that rate), which `hob commission response`'s
/// model of the drive's loops needs.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct TableDriveModel {
    /// Everything on the motor's shaft: rotor, coupling and worm, kg m2.
    pub motor_side_inertia_kg_m2: f64,
    /// The drive's velocity loop's sample period, us.
    pub loop_us: u32,
    /// The drive's low-pass on its speed estimate, Hz.
    pub speed_filter_hz: f64,
}

impl TableConfig {
    pub fn counts_per_deg(&self) -> f64 {
        f64::from(self.encoder_counts_per_motor_rev) * self.worm_ratio / 360.0
    }
}

/// Axes X and Y: AC servo through a ball screw.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct LinearAxisConfig {
    pub can_node_id: u8,
    pub polarity: Polarity,
    pub encoder_counts_per_motor_rev: u32,
    pub motor_to_screw_ratio: f64,
    pub screw_lead_mm: f64,
    pub motor_max_rpm: f64,
    pub soft_limit_min_mm: f64,
    pub soft_limit_max_mm: f64,
    pub rapid_mm_min: f64,
    pub max_feed_mm_min: f64,
    pub max_accel_mm_s2: f64,
    pub max_following_error_mm: f64,
    pub homing: HomingConfig,
}

impl LinearAxisConfig {
    pub fn counts_per_mm(&self) -> f64 {
        f64::from(self.encoder_counts_per_motor_rev) * self.motor_to_screw_ratio / self.screw_lead_mm
    }

    /// Motor speed for an axis speed.
    pub fn motor_rpm(&self, speed_mm_min: f64) -> f64 {
        speed_mm_min / self.screw_lead_mm * self.motor_to_screw_ratio
    }

    fn validate(&self, axis: &str, p: &mut Problems) {
        let k = |name: &str| format!("{axis}.{name}");
        velocity_fits_the_pdo(
            p,
            &k("encoder_counts_per_motor_rev"),
            self.encoder_counts_per_motor_rev,
            self.motor_max_rpm,
        );
        p.require((1..=127).contains(&self.can_node_id), &k("can_node_id"), || {
            format!("must be a CANopen node id 1 .. 127 (is {})", self.can_node_id)
        });
        p.require(
            self.encoder_counts_per_motor_rev > 0,
            &k("encoder_counts_per_motor_rev"),
            || "must be greater than 0".into(),
        );
        for (name, v) in [
            ("motor_to_screw_ratio", self.motor_to_screw_ratio),
            ("screw_lead_mm", self.screw_lead_mm),
            ("motor_max_rpm", self.motor_max_rpm),
            ("rapid_mm_min", self.rapid_mm_min),
            ("max_feed_mm_min", self.max_feed_mm_min),
            ("max_accel_mm_s2", self.max_accel_mm_s2),
            ("max_following_error_mm", self.max_following_error_mm),
        ] {
            p.positive(&k(name), v);
        }
        p.require(
            self.soft_limit_min_mm.is_finite()
                && self.soft_limit_max_mm.is_finite()
                && self.soft_limit_min_mm < self.soft_limit_max_mm,
            &k("soft_limit_max_mm"),
            || {
                format!(
                    "must be above soft_limit_min_mm ({} .. {})",
                    self.soft_limit_min_mm, self.soft_limit_max_mm
                )
            },
        );
        p.require(
            self.max_feed_mm_min <= self.rapid_mm_min,
            &k("max_feed_mm_min"),
            || {
                format!(
                    "must not exceed rapid_mm_min {} (is {})",
                    self.rapid_mm_min, self.max_feed_mm_min
                )
            },
        );
        let motor = self.motor_rpm(self.rapid_mm_min);
        p.require(motor <= self.motor_max_rpm, &k("rapid_mm_min"), || {
            format!(
                "needs {motor:.1} motor rpm, above motor_max_rpm {}",
                self.motor_max_rpm
            )
        });
        self.homing.validate(&k("homing"), self, p);
    }
}

/// What the machine can cut (thesis: v_c up to 40 m/min, hob diameters 60-80 mm).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ProcessLimits {
    pub max_cutting_speed_m_min: f64,
    pub min_tool_diameter_mm: f64,
    pub max_tool_diameter_mm: f64,
    pub max_helix_deg: f64,
    pub max_hob_starts: u32,
}

/// Slideway lubrication: at power-up and after every `interval_travel_m` of an axis.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct LubeConfig {
    pub interval_travel_m: f64,
    /// The pressure switch must confirm within this time after the pump starts.
    pub pressure_timeout_s: f64,
    pub pump_run_s: f64,
}

/// A digital input or output bit of the I/O coupler.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct DigitalBinding {
    /// Bit number across the coupler's modules (module * 8 + bit).
    pub bit: u8,
    pub active: Active,
}

impl DigitalBinding {
    /// Whether this signal is active in a raw process image (its polarity applied): the
    /// one place that reads a named signal, for the loop and every frontend alike.
    pub fn is_active(self, raw: u32) -> bool {
        let level = raw.checked_shr(u32::from(self.bit)).is_some_and(|r| r & 1 == 1);
        match self.active {
            Active::High => level,
            Active::Low => !level,
        }
    }

    /// The raw image with this signal set active or not.
    pub fn set(self, raw: &mut u32, on: bool) {
        let level = match self.active {
            Active::High => on,
            Active::Low => !on,
        };
        let Some(mask) = 1u32.checked_shl(u32::from(self.bit)) else {
            return;
        };
        if level {
            *raw |= mask;
        } else {
            *raw &= !mask;
        }
    }
}

/// An analog channel of the I/O coupler (0-based; the coupler's sub-index is one more).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct AnalogBinding {
    pub channel: u8,
}

/// The CANopen I/O coupler (CiA 401) and every signal of the machine on it
/// (docs/domain.md section 6).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct IoMap {
    pub can_node_id: u8,
    pub digital_input_count: u8,
    pub digital_output_count: u8,
    pub analog_output_count: u8,
    pub inputs: DigitalInputs,
    pub outputs: DigitalOutputs,
    pub analog_outputs: AnalogOutputs,
    /// What is wired to the coupler's analog inputs (none on a machine in production).
    #[serde(default)]
    pub analog_inputs: AnalogInputs,
}

/// Digital inputs.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct DigitalInputs {
    /// Safety relay output: the monitoring circuit is closed (drives and VFD may run).
    pub safety_chain_closed: DigitalBinding,
    /// E-stop buttons (diagnostic copy of the safety circuit).
    pub estop_pressed: DigitalBinding,
    pub x_limit_min: DigitalBinding,
    pub x_limit_max: DigitalBinding,
    pub y_limit_min: DigitalBinding,
    pub y_limit_max: DigitalBinding,
    pub vfd_fault: DigitalBinding,
    pub vfd_ready: DigitalBinding,
    pub lube_pressure_ok: DigitalBinding,
    pub coolant_running: DigitalBinding,
    pub x_clamp_closed: DigitalBinding,
    pub reset_button: DigitalBinding,
    pub cycle_start_button: DigitalBinding,
    pub cycle_stop_button: DigitalBinding,
    pub feed_hold_button: DigitalBinding,
}

impl DigitalInputs {
    pub fn bindings(&self) -> [(&'static str, DigitalBinding); 15] {
        [
            ("safety_chain_closed", self.safety_chain_closed),
            ("estop_pressed", self.estop_pressed),
            ("x_limit_min", self.x_limit_min),
            ("x_limit_max", self.x_limit_max),
            ("y_limit_min", self.y_limit_min),
            ("y_limit_max", self.y_limit_max),
            ("vfd_fault", self.vfd_fault),
            ("vfd_ready", self.vfd_ready),
            ("lube_pressure_ok", self.lube_pressure_ok),
            ("coolant_running", self.coolant_running),
            ("x_clamp_closed", self.x_clamp_closed),
            ("reset_button", self.reset_button),
            ("cycle_start_button", self.cycle_start_button),
            ("cycle_stop_button", self.cycle_stop_button),
            ("feed_hold_button", self.feed_hold_button),
        ]
    }
}

/// Digital outputs.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct DigitalOutputs {
    /// The PC fault relay of the safety circuit: energised while the controller is healthy;
    /// dropping it opens the safety chain.
    pub pc_ok_relay: DigitalBinding,
    /// The PC's part of the safety relay's reset condition.
    pub pc_reset_relay: DigitalBinding,
    pub lube_pump: DigitalBinding,
    pub coolant_pump: DigitalBinding,
    pub x_clamp: DigitalBinding,
    /// VFD run command, forward.
    pub spindle_run_forward: DigitalBinding,
    /// VFD run command, reverse.
    pub spindle_run_reverse: DigitalBinding,
    pub fault_lamp: DigitalBinding,
}

impl DigitalOutputs {
    pub fn bindings(&self) -> [(&'static str, DigitalBinding); 8] {
        [
            ("pc_ok_relay", self.pc_ok_relay),
            ("pc_reset_relay", self.pc_reset_relay),
            ("lube_pump", self.lube_pump),
            ("coolant_pump", self.coolant_pump),
            ("x_clamp", self.x_clamp),
            ("spindle_run_forward", self.spindle_run_forward),
            ("spindle_run_reverse", self.spindle_run_reverse),
            ("fault_lamp", self.fault_lamp),
        ]
    }
}

/// Analog outputs.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct AnalogOutputs {
    /// VFD speed reference, 0 .. full scale.
    pub spindle_speed: AnalogBinding,
}

/// Analog inputs (CiA 401 0x6401, 16-bit).
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct AnalogInputs {
    /// A displacement gauge (an LVDT and its conditioner, or a digital indicator with an
    /// analog output) touching the table's rim, mounted for `hob commission backlash`. Its
    /// scale and radius need not be known: the procedure compares the gauge with the table
    /// drive's own travel. While it is named the coupler sends it every
    /// [`TABLE_GAUGE_EVERY_SYNCS`] SYNCs.
    pub table_gauge: Option<AnalogBinding>,
}

/// The table gauge's transmission (CiA 301 synchronous, every n-th SYNC): latched at a
/// SYNC like the drives' positions, so a reading pairs with the motor's of the same SYNC;
/// rare enough (20 Hz at 1 ms) that the shipped schedule stays under its load limit.
pub const TABLE_GAUGE_EVERY_SYNCS: u8 = 50;
/// Analog input channels a gauge may name.
pub const ANALOG_INPUT_CHANNELS: u8 = 8;

impl MachineConfig {
    /// Parses and validates `src`, a machine file's text (`origin` names it in errors).
    pub fn parse(origin: &Path, src: &str) -> Result<Self, LoadError> {
        Self::validated(parse_toml(origin, src)?, origin, src)
    }

    fn validated(config: Self, file: &Path, src: &str) -> Result<Self, LoadError> {
        let mut problems = Problems::new();
        config.validate(&mut problems);
        problems.into_result(file, src)?;
        Ok(config)
    }

    /// Checks every value; problems are named by their key.
    pub fn validate(&self, p: &mut Problems) {
        p.require(!self.machine.name.trim().is_empty(), "machine.name", || {
            "must not be empty".into()
        });
        self.validate_control(p);
        self.validate_gearbox(p);
        self.validate_can(p);
        self.validate_service(p);
        self.validate_spindle(p);
        self.validate_table(p);
        self.x.validate("x", p);
        self.y.validate("y", p);
        self.validate_process(p);
        self.validate_jog_and_overrides(p);
        p.positive("lube.interval_travel_m", self.lube.interval_travel_m);
        p.positive("lube.pressure_timeout_s", self.lube.pressure_timeout_s);
        p.positive("lube.pump_run_s", self.lube.pump_run_s);
        self.validate_io(p);
        self.validate_node_ids(p);
        if let Some(c) = &self.commissioning {
            c.validate(
                self.control.drive_delay_us,
                10 * self.control.cycle_period_us,
                self.spindle.max_spindle_rpm,
                p,
            );
        }
        absolute_path(p, "library.dir", &self.library.dir);
        absolute_path(p, "state.file", &self.state.file);
        // Below 0.01 mm every re-touch would ask (a touch scatters by a few um and the
        // ways grow with warmth); above 5 mm a wrong tens digit of a diameter (10 mm: 5 mm
        // on X) would pass unasked.
        p.within(
            "setup.touch_off_confirm_mm",
            self.setup.touch_off_confirm_mm,
            0.01,
            5.0,
            "mm",
        );
    }

    /// `[control]`: the cycle, the drive delay, the spindle observer and the timeouts.
    fn validate_control(&self, p: &mut Problems) {
        p.require(
            (250..=100_000).contains(&self.control.cycle_period_us),
            "control.cycle_period_us",
            || {
                format!(
                    "must be within 250 .. 100000 us (is {})",
                    self.control.cycle_period_us
                )
            },
        );
        let c = &self.control;
        p.require(
            c.drive_delay_us <= 10 * c.cycle_period_us,
            "control.drive_delay_us",
            || {
                format!(
                    "must be at most 10 cycles ({} us) (is {})",
                    10 * c.cycle_period_us,
                    c.drive_delay_us
                )
            },
        );
        let nyquist_hz = 1e6 / f64::from(c.cycle_period_us.max(1)) / 2.0;
        p.within(
            "control.spindle_observer_bandwidth_hz",
            c.spindle_observer_bandwidth_hz,
            0.1,
            nyquist_hz / 2.0,
            "Hz",
        );
        if c.spindle_encoder_identification_s != 0.0 {
            p.within(
                "control.spindle_encoder_identification_s",
                c.spindle_encoder_identification_s,
                0.2,
                30.0,
                "s (or 0: off)",
            );
        }
        p.within(
            "control.spindle_speed_tolerance",
            c.spindle_speed_tolerance,
            0.001,
            0.5,
            "",
        );
        p.positive("control.spindle_start_timeout_s", c.spindle_start_timeout_s);
        p.positive("control.x_clamp_timeout_s", c.x_clamp_timeout_s);
        p.within("control.resume_overlap_mm", c.resume_overlap_mm, 0.0, 50.0, "mm");
    }

    /// `[gearbox]`: the engagement, its windows and the cross-coupling correction.
    fn validate_gearbox(&self, p: &mut Problems) {
        let g = &self.gearbox;
        p.positive("gearbox.engage_time_s", g.engage_time_s);
        p.positive("gearbox.fine_window_arcsec", g.fine_window_arcsec);
        p.require(
            g.coarse_window_arcsec > g.fine_window_arcsec,
            "gearbox.coarse_window_arcsec",
            || {
                format!(
                    "must be wider than gearbox.fine_window_arcsec = {} (is {})",
                    g.fine_window_arcsec, g.coarse_window_arcsec
                )
            },
        );
        p.non_negative("gearbox.ccc_kp", g.ccc_kp);
        p.require(g.ccc_kp < 1.0, "gearbox.ccc_kp", || {
            format!("must be below 1 for a stable correction (is {})", g.ccc_kp)
        });
        p.non_negative("gearbox.ccc_ki_per_s", g.ccc_ki_per_s);
        p.non_negative("gearbox.ccc_limit_arcsec", g.ccc_limit_arcsec);
        p.positive("gearbox.phase_sync_speed_deg_s", g.phase_sync_speed_deg_s);
    }

    /// `[can]`: the interface, heartbeats, the encoder object, bus load and bit rate.
    fn validate_can(&self, p: &mut Problems) {
        p.require(!self.can.interface.trim().is_empty(), "can.interface", || {
            "must not be empty".into()
        });
        let can = &self.can;
        p.require(
            (10..=10_000).contains(&can.heartbeat_ms),
            "can.heartbeat_ms",
            || format!("must be within 10 .. 10000 ms (is {})", can.heartbeat_ms),
        );
        p.require(
            can.heartbeat_timeout_ms > can.heartbeat_ms,
            "can.heartbeat_timeout_ms",
            || {
                format!(
                    "must be longer than can.heartbeat_ms = {} (is {})",
                    can.heartbeat_ms, can.heartbeat_timeout_ms
                )
            },
        );
        p.require(
            (1..=100).contains(&can.tpdo_misses_to_fault),
            "can.tpdo_misses_to_fault",
            || format!("must be within 1 .. 100 (is {})", can.tpdo_misses_to_fault),
        );
        p.require(
            (0x2000..=0x5FFF).contains(&can.spindle_encoder_index)
                || (0x6000..=0x9FFF).contains(&can.spindle_encoder_index),
            "can.spindle_encoder_index",
            || {
                format!(
                    "must be an application object 0x2000 .. 0x9FFF (is 0x{:04X})",
                    can.spindle_encoder_index
                )
            },
        );
        p.within("can.bus_load_limit", can.bus_load_limit, 0.05, 1.0, "");
        p.require(
            [125_000, 250_000, 500_000, 800_000, 1_000_000].contains(&self.can.bitrate_bit_s),
            "can.bitrate_bit_s",
            || {
                format!(
                    "must be a CiA 301 bit rate of 125000 .. 1000000 (is {})",
                    self.can.bitrate_bit_s
                )
            },
        );
    }

    /// `[service]`: priorities, the loop's core, the watchdog deadline and DMA latency.
    fn validate_service(&self, p: &mut Problems) {
        let sv = &self.service;
        p.require(
            (1..=98).contains(&sv.loop_priority),
            "service.loop_priority",
            || format!("must be a SCHED_FIFO priority 1 .. 98 (is {})", sv.loop_priority),
        );
        p.require(
            (1..=98).contains(&sv.watchdog_priority) && sv.watchdog_priority < sv.loop_priority,
            "service.watchdog_priority",
            || {
                format!(
                    "must be 1 .. 98 and below service.loop_priority {} (is {})",
                    sv.loop_priority, sv.watchdog_priority
                )
            },
        );
        p.require(sv.loop_core < 1024, "service.loop_core", || {
            format!("must be a CPU number (is {})", sv.loop_core)
        });
        let period_ms = self.control.cycle_period_us.div_ceil(1000);
        p.require(
            (2 * period_ms..=1000).contains(&sv.watchdog_deadline_ms),
            "service.watchdog_deadline_ms",
            || {
                format!(
                    "must be 2 cycles .. 1000 ms ({} .. 1000, is {})",
                    2 * period_ms,
                    sv.watchdog_deadline_ms
                )
            },
        );
        let quarter_cycle_us = self.control.cycle_period_us / 4;
        p.require(
            sv.cpu_dma_latency_us <= quarter_cycle_us,
            "service.cpu_dma_latency_us",
            || {
                format!(
                    "must be 0 .. a quarter of control.cycle_period_us ({quarter_cycle_us}), is {}",
                    sv.cpu_dma_latency_us
                )
            },
        );
    }

    fn validate_spindle(&self, p: &mut Problems) {
        let s = &self.spindle;
        p.require(
            s.encoder_counts_per_rev >= 4,
            "spindle.encoder_counts_per_rev",
            || format!("must be at least 4 (is {})", s.encoder_counts_per_rev),
        );
        for (key, v) in [
            ("spindle.motor_to_spindle_ratio", s.motor_to_spindle_ratio),
            ("spindle.motor_rated_rpm", s.motor_rated_rpm),
            ("spindle.vfd_hz_at_full_scale", s.vfd_hz_at_full_scale),
            ("spindle.motor_rpm_at_full_scale", s.motor_rpm_at_full_scale),
            ("spindle.analog_full_scale_v", s.analog_full_scale_v),
            ("spindle.max_spindle_rpm", s.max_spindle_rpm),
            ("spindle.vfd_ramp_s", s.vfd_ramp_s),
        ] {
            p.positive(key, v);
        }
        let reachable = s.motor_rpm_at_full_scale / s.motor_to_spindle_ratio;
        p.require(s.max_spindle_rpm <= reachable, "spindle.max_spindle_rpm", || {
            format!(
                "{} rpm cannot be reached: full-scale analog output gives {reachable:.1} spindle rpm",
                s.max_spindle_rpm
            )
        });
    }

    fn validate_table(&self, p: &mut Problems) {
        let t = &self.table;
        velocity_fits_the_pdo(
            p,
            "table.encoder_counts_per_motor_rev",
            t.encoder_counts_per_motor_rev,
            t.motor_max_rpm,
        );
        p.require((1..=127).contains(&t.can_node_id), "table.can_node_id", || {
            format!("must be a CANopen node id 1 .. 127 (is {})", t.can_node_id)
        });
        p.require(
            t.encoder_counts_per_motor_rev > 0,
            "table.encoder_counts_per_motor_rev",
            || "must be greater than 0".into(),
        );
        for (key, v) in [
            ("table.worm_ratio", t.worm_ratio),
            ("table.motor_max_rpm", t.motor_max_rpm),
            ("table.max_table_rpm", t.max_table_rpm),
            ("table.max_accel_deg_s2", t.max_accel_deg_s2),
            ("table.max_following_error_deg", t.max_following_error_deg),
        ] {
            p.positive(key, v);
        }
        if let Some(w) = &t.worm_set {
            p.require(is_worm_set_name(w), "table.worm_set", || {
                format!(
                    "must name the worm set in 1 to {WORM_SET_MAX_CHARS} printable ASCII characters (is {w:?})"
                )
            });
        }
        if let Some(d) = &t.drive_model {
            p.within(
                "table.drive_model.motor_side_inertia_kg_m2",
                d.motor_side_inertia_kg_m2,
                1e-6,
                1.0,
                "kg m2",
            );
            p.require(
                (31..=2000).contains(&d.loop_us),
                "table.drive_model.loop_us",
                || format!("must be within 31 .. 2000 us (is {})", d.loop_us),
            );
            p.within(
                "table.drive_model.speed_filter_hz",
                d.speed_filter_hz,
                10.0,
                0.5e6 / f64::from(d.loop_us.max(1)),
                "Hz (at most half the loop's rate)",
            );
        }
        let motor = t.max_table_rpm * t.worm_ratio;
        p.require(motor <= t.motor_max_rpm, "table.max_table_rpm", || {
            format!(
                "needs {motor:.1} motor rpm through the worm, above table.motor_max_rpm {}",
                t.motor_max_rpm
            )
        });
    }

    fn validate_jog_and_overrides(&self, p: &mut Problems) {
        let j = &self.jog;
        p.positive("jog.unreferenced_mm_min", j.unreferenced_mm_min);
        let slowest_rapid = self.x.rapid_mm_min.min(self.y.rapid_mm_min);
        p.require(
            j.unreferenced_mm_min <= 0.25 * slowest_rapid,
            "jog.unreferenced_mm_min",
            || {
                format!(
                    "must be a slow jog, at most a quarter of the slowest rapid ({} mm/min) (is {})",
                    0.25 * slowest_rapid,
                    j.unreferenced_mm_min
                )
            },
        );
        let period_ms = self.control.cycle_period_us / 1000;
        p.require(
            (20..=2000).contains(&j.deadman_timeout_ms) && j.deadman_timeout_ms > 2 * period_ms,
            "jog.deadman_timeout_ms",
            || {
                format!(
                    "must be within 20 .. 2000 ms (a frontend renews the jog every 100 ms) (is {})",
                    j.deadman_timeout_ms
                )
            },
        );
        let o = &self.overrides;
        p.within("overrides.feed_min_percent", o.feed_min_percent, 0.0, 100.0, "%");
        p.within(
            "overrides.feed_max_percent",
            o.feed_max_percent,
            100.0,
            200.0,
            "%",
        );
        p.within(
            "overrides.spindle_min_percent",
            o.spindle_min_percent,
            10.0,
            100.0,
            "%",
        );
        p.within(
            "overrides.spindle_max_percent",
            o.spindle_max_percent,
            100.0,
            200.0,
            "%",
        );
    }

    fn validate_process(&self, p: &mut Problems) {
        let l = &self.process;
        p.positive("process.max_cutting_speed_m_min", l.max_cutting_speed_m_min);
        p.positive("process.min_tool_diameter_mm", l.min_tool_diameter_mm);
        p.require(
            l.max_tool_diameter_mm >= l.min_tool_diameter_mm,
            "process.max_tool_diameter_mm",
            || {
                format!(
                    "must not be below min_tool_diameter_mm {}",
                    l.min_tool_diameter_mm
                )
            },
        );
        p.within("process.max_helix_deg", l.max_helix_deg, 0.0, 60.0, "deg");
        p.require(
            (1..=10).contains(&l.max_hob_starts),
            "process.max_hob_starts",
            || format!("must be within 1 .. 10 (is {})", l.max_hob_starts),
        );
    }

    fn validate_io(&self, p: &mut Problems) {
        let io = &self.io;
        p.require((1..=127).contains(&io.can_node_id), "io.can_node_id", || {
            format!("must be a CANopen node id 1 .. 127 (is {})", io.can_node_id)
        });
        check_bits(p, "io.inputs", &io.inputs.bindings(), io.digital_input_count);
        check_bits(p, "io.outputs", &io.outputs.bindings(), io.digital_output_count);
        let ch = io.analog_outputs.spindle_speed.channel;
        p.require(
            ch < io.analog_output_count,
            "io.analog_outputs.spindle_speed.channel",
            || {
                format!(
                    "must be below io.analog_output_count {} (is {ch})",
                    io.analog_output_count
                )
            },
        );
        if let Some(g) = io.analog_inputs.table_gauge {
            p.require(
                g.channel < ANALOG_INPUT_CHANNELS,
                "io.analog_inputs.table_gauge.channel",
                || format!("must be 0 .. {} (is {})", ANALOG_INPUT_CHANNELS - 1, g.channel),
            );
        }
    }

    fn validate_node_ids(&self, p: &mut Problems) {
        let ids = [
            ("table.can_node_id", self.table.can_node_id),
            ("x.can_node_id", self.x.can_node_id),
            ("y.can_node_id", self.y.can_node_id),
            ("io.can_node_id", self.io.can_node_id),
        ];
        for (i, (key, id)) in ids.iter().enumerate() {
            if let Some((other, _)) = ids[..i].iter().find(|(_, o)| o == id) {
                p.push(*key, format!("node id {id} is already used by {other}"));
            }
        }
    }
}

/// A path the services and frontends agree on: written out in full, whatever their
/// working directory.
fn absolute_path(p: &mut Problems, key: &str, value: &str) {
    if value.trim().is_empty() {
        p.push(key, "must not be empty");
    } else {
        p.require(Path::new(value).is_absolute(), key, || {
            format!("must be an absolute path, starting with / (is {value:?})")
        });
    }
}

/// A drive's velocity (counts/s, the target PDO's 32-bit velocity offset 0x60B1) at the
/// motor's top speed must fit in an i32: a position unit that fine is refused by its key.
fn velocity_fits_the_pdo(p: &mut Problems, key: &str, counts_per_rev: u32, motor_max_rpm: f64) {
    let counts_s = f64::from(counts_per_rev) * motor_max_rpm / 60.0;
    p.require(counts_s <= f64::from(i32::MAX), key, || {
        format!(
            "{counts_per_rev} counts per motor turn at {motor_max_rpm} rpm is {counts_s:.0} counts/s, beyond the drive's 32-bit velocity ({})",
            i32::MAX
        )
    });
}

fn check_bits(p: &mut Problems, table: &str, bindings: &[(&str, DigitalBinding)], count: u8) {
    for (i, (name, b)) in bindings.iter().enumerate() {
        let key = format!("{table}.{name}.bit");
        p.require(b.bit < count, &key, || {
            format!("must be below the coupler's {count} bits (is {})", b.bit)
        });
        if let Some((other, _)) = bindings[..i].iter().find(|(_, o)| o.bit == b.bit) {
            p.push(key, format!("bit {} is already used by {table}.{other}", b.bit));
        }
    }
}

/// The shipped `config/machine.toml`, for the tests of this crate and the crates above it
/// (feature `test-support`, enabled only by dev-dependencies). Its text is compiled in: no
/// file is read here.
#[cfg(any(test, feature = "test-support"))]
pub fn shipped_for_tests() -> MachineConfig {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/machine.toml");
    let src = include_str!("../../../config/machine.toml");
    MachineConfig::parse(&path, src).unwrap_or_else(|e| panic!("{e}"))
}

pub mod commissioning;
#[cfg(test)]
mod tests;
