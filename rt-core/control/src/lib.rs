//! # hob-control: the control core
//!
//! What the 1 kHz loop computes, as deterministic code with no I/O.
//!
//! [`Controller::step`] runs once per cycle. Its inputs were latched at this cycle's SYNC
//! (k); its outputs are applied by the drives at the next SYNC (k+1) and reached through
//! CSP interpolation over the following period, so the spindle angle is predicted one
//! period plus `control.drive_delay_us` ahead.
//!
//! Rules of this crate (checked by `bench/plant/tests/no_alloc.rs` with a counting allocator): no
//! heap allocation, no lock, no blocking call, no logging, bounded work per call, no
//! panic. Errors are `Copy` enums ([`fault::Fault`], [`fault::Refusal`]); events go into
//! a fixed ring ([`events::EventRing`]) that the caller drains.

mod align;
mod command;
mod commands;
mod cycle;
mod drive;
pub mod eccentricity;
pub mod egb;
pub mod events;
pub mod fault;
mod fault_reaction;
pub mod flight;
pub mod io;
pub mod jog;
pub mod lube;
pub mod observer;
pub mod pitch_comp;
pub mod profile;
pub mod program;
pub mod referencing;
mod sequencer;
mod sequencing;
pub mod setup_math;

pub use command::{Command, Direction, HomeAxes, State};
pub use drive::{AxisFeedback, DriveMode, HomingBits};
pub use setup_math::Offsets;

use eccentricity::EccentricityIdentifier;
use egb::{Coupling, Gearbox, GearboxParams};
use events::{Event, EventKind, EventRing};
use fault::{Axis, Fault};
use hob_gearing::cutting::SpindleDrive;
use hob_setup::config::machine::MachineConfig;
use io::{Inputs, IoBits, Outputs};
use lube::{Lube, LubeParams};
use observer::{SpindleObserver, Unwrapper};
use profile::Profile;
use program::CycleProgram;

/// Integral gain of the spindle speed trim, per second.
const SPINDLE_TRIM_PER_S: f64 = 0.5;
/// Bounds of the trim factor on the VFD reference.
const SPINDLE_TRIM_RANGE: (f64, f64) = (0.8, 1.25);
/// A held spindle keeps its trim once it has been at speed this long (the constant's
/// reasons are where it is shared with the commissioning).
const SPINDLE_HOLD_TRIM_S: f64 = hob_setup::config::machine::commissioning::HELD_SPINDLE_TRIM_FREEZE_S;
/// Time the drives may take to reach "operation enabled" once asked to.
pub const DRIVE_ENABLE_TIMEOUT_S: f64 = 2.0;
/// The spindle must hold its speed this long before the gearbox engages.
pub const SPINDLE_SETTLE_S: f64 = 0.5;

/// Everything latched at this cycle's SYNC.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct CycleInputs {
    /// Spindle encoder (B drive's auxiliary encoder), counts, wrapping.
    pub spindle_counts: i32,
    pub table: AxisFeedback,
    pub x: AxisFeedback,
    pub y: AxisFeedback,
    /// Raw digital input image of the I/O coupler.
    pub digital_inputs: u32,
    /// The input image is current: it arrived at least once and the coupler is alive.
    /// While false the inputs read as inactive with the safety chain open.
    pub io_valid: bool,
    /// The table gauge's analog input (CiA 401, 16-bit), when one was latched at this
    /// cycle's SYNC (a gauge is mounted for commissioning only).
    pub table_gauge_counts: Option<i16>,
}

/// Everything to send for the next SYNC.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CycleOutputs {
    /// Target positions (0x607A), counts, wrapping.
    pub table_target_counts: i32,
    pub x_target_counts: i32,
    pub y_target_counts: i32,
    /// Velocity feed-forward (0x60B1), counts/s.
    pub table_velocity_counts_s: f64,
    pub x_velocity_counts_s: f64,
    pub y_velocity_counts_s: f64,
    /// Drives in "operation enabled" (false: disable voltage).
    pub drives_enabled: bool,
    /// Each drive's mode of operation (B, X, Y); the table always stays in
    /// cyclic synchronous position.
    pub drive_modes: [DriveMode; 3],
    /// Controlword bit 4 (B, X, Y): in homing mode its rising edge starts homing.
    pub homing_start: [bool; 3],
    /// Raw digital output image of the I/O coupler.
    pub digital_outputs: u32,
    /// Spindle speed reference to the VFD.
    pub spindle_analog_v: f64,
}

fn input_mode(input: &CycleInputs, k: usize) -> i8 {
    [input.table, input.x, input.y][k].mode_display
}

/// Scaling of one axis between counts and units (a unit conversion: `hob_gearing::units`).
pub use hob_gearing::units::AxisScale;

/// Limits and timing of one linear axis (declared with the axis' motion profile).
pub use profile::LinearLimits;

/// Everything the loop needs from the machine configuration, copied at start-up.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ControlParams {
    pub period_s: f64,
    /// Prediction horizon: one period plus the drive delay.
    pub horizon_s: f64,
    pub spindle: AxisScale,
    pub table: AxisScale,
    pub x: AxisScale,
    pub y: AxisScale,
    pub x_limits: LinearLimits,
    pub y_limits: LinearLimits,
    pub table_max_deg_s: f64,
    pub table_accel_deg_s2: f64,
    pub table_max_following_error_deg: f64,
    pub spindle_drive: SpindleDrive,
    pub spindle_max_rpm: f64,
    pub spindle_tolerance: f64,
    pub spindle_start_timeout_s: f64,
    pub clamp_timeout_s: f64,
    /// "Continue" re-enters an interrupted cut this far (and a feed per table revolution)
    /// behind the Y where it stopped.
    pub resume_overlap_mm: f64,
    pub observer_bandwidth_hz: f64,
    /// Time constant of the spindle encoder's once-per-turn error identification (0: off).
    pub encoder_identification_s: f64,
    /// Consecutive cycles without fresh feedback from a drive before it is a fault.
    pub feedback_misses_to_fault: u32,
    pub gearbox: GearboxParams,
    pub lube: LubeParams,
    pub io: IoBits,
    /// Referencing that takes longer is a fault.
    pub x_homing_timeout_s: f64,
    pub y_homing_timeout_s: f64,
    /// X and Y jog speed until referenced.
    pub unreferenced_jog_mm_s: f64,
    /// A continuous jog not renewed for this long stops.
    pub deadman_s: f64,
    pub overrides: setup_math::OverrideLimits,
    /// A touch-off that moves the work more than this needs the operator's confirmation
    /// (`setup.touch_off_confirm_mm`, mm).
    pub touch_off_confirm_mm: f64,
    /// The drive delay (`horizon_s`) was measured on this machine's table drive
    /// (`[commissioning.drive_delay]`, its drive the one on the bus: `hob-rt` checks the
    /// identity at boot); until it is, START and CONTINUE are refused
    /// (`Refusal::DelayNotCommissioned`): a delay 250 us wrong faults the cut at engagement.
    pub delay_commissioned: bool,
    /// The spindle's true once-per-turn swing beside its encoder's error
    /// (`[commissioning.spindle_encoder]`): the encoder identifier then corrects only the
    /// encoder's share. None: all it identifies is taken for the encoder's error.
    pub spindle_swing: Option<hob_setup::config::machine::commissioning::SpindleSwing>,
}

impl ControlParams {
    /// Copies and converts the validated machine configuration.
    pub fn from_machine(m: &MachineConfig) -> Self {
        let period_s = f64::from(m.control.cycle_period_us) * 1e-6;
        let linear = |a: &hob_setup::config::machine::LinearAxisConfig| LinearLimits {
            soft_min_mm: a.soft_limit_min_mm,
            soft_max_mm: a.soft_limit_max_mm,
            rapid_mm_s: a.rapid_mm_min / 60.0,
            accel_mm_s2: a.max_accel_mm_s2,
            max_following_error_mm: a.max_following_error_mm,
        };
        let g = &m.gearbox;
        Self {
            period_s,
            horizon_s: period_s + f64::from(m.control.drive_delay_us) * 1e-6,
            spindle: AxisScale {
                counts_per_unit: f64::from(m.spindle.encoder_counts_per_rev) / 360.0,
                sign: m.spindle.encoder_polarity.sign(),
            },
            table: AxisScale {
                counts_per_unit: m.table.counts_per_deg(),
                sign: m.table.polarity.sign(),
            },
            x: AxisScale {
                counts_per_unit: m.x.counts_per_mm(),
                sign: m.x.polarity.sign(),
            },
            y: AxisScale {
                counts_per_unit: m.y.counts_per_mm(),
                sign: m.y.polarity.sign(),
            },
            x_limits: linear(&m.x),
            y_limits: linear(&m.y),
            table_max_deg_s: m.table.max_table_rpm * 6.0,
            table_accel_deg_s2: m.table.max_accel_deg_s2,
            table_max_following_error_deg: m.table.max_following_error_deg,
            spindle_drive: m.spindle.drive(),
            spindle_max_rpm: m.spindle.max_spindle_rpm,
            spindle_tolerance: m.control.spindle_speed_tolerance,
            spindle_start_timeout_s: m.control.spindle_start_timeout_s,
            clamp_timeout_s: m.control.x_clamp_timeout_s,
            resume_overlap_mm: m.control.resume_overlap_mm,
            observer_bandwidth_hz: m.control.spindle_observer_bandwidth_hz,
            encoder_identification_s: m.control.spindle_encoder_identification_s,
            feedback_misses_to_fault: m.can.tpdo_misses_to_fault,
            gearbox: GearboxParams {
                ratio_signed: 0.0,
                differential_signed_deg_per_mm: 0.0,
                pitch_deg: 360.0,
                engage_time_s: g.engage_time_s,
                fine_window_deg: g.fine_window_arcsec / 3600.0,
                coarse_window_deg: g.coarse_window_arcsec / 3600.0,
                ccc_enabled: g.ccc_enabled,
                ccc_kp: g.ccc_kp,
                ccc_ki_per_s: g.ccc_ki_per_s,
                ccc_limit_deg: g.ccc_limit_arcsec / 3600.0,
                phase_speed_deg_s: g.phase_sync_speed_deg_s,
                table_accel_deg_s2: m.table.max_accel_deg_s2,
            },
            lube: LubeParams {
                interval_mm: m.lube.interval_travel_m * 1000.0,
                pressure_timeout_s: m.lube.pressure_timeout_s,
                pump_run_s: m.lube.pump_run_s,
            },
            io: IoBits::new(&m.io),
            x_homing_timeout_s: m.x.homing.timeout_s,
            y_homing_timeout_s: m.y.homing.timeout_s,
            unreferenced_jog_mm_s: m.jog.unreferenced_mm_min / 60.0,
            deadman_s: f64::from(m.jog.deadman_timeout_ms) * 1e-3,
            overrides: setup_math::OverrideLimits {
                feed_min: m.overrides.feed_min_percent / 100.0,
                feed_max: m.overrides.feed_max_percent / 100.0,
                spindle_min: m.overrides.spindle_min_percent / 100.0,
                spindle_max: m.overrides.spindle_max_percent / 100.0,
            },
            touch_off_confirm_mm: m.setup.touch_off_confirm_mm,
            delay_commissioned: m.commissioning.as_ref().is_some_and(|c| c.drive_delay.is_some()),
            spindle_swing: m
                .commissioning
                .as_ref()
                .and_then(|c| c.spindle_encoder.as_ref())
                .map(|r| r.swing()),
        }
    }
}

/// How the spindle angle is taken for the gearbox.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum SpindleAngleSource {
    /// Observer estimate predicted to the instant the command takes effect (normal).
    Predicted,
    /// The last measured angle, unpredicted (to show what prediction is worth).
    LastMeasured,
}

/// What the loop publishes about itself each cycle.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Status {
    pub cycle: u64,
    pub state: State,
    /// Feed hold active.
    pub hold: bool,
    /// 1-based pass number, 0 outside a cycle.
    pub pass: u32,
    /// Tooth being cut (tooth-by-tooth), 0-based.
    pub tooth: u32,
    pub spindle_deg: f64,
    /// The spindle encoder's reading as latched, continuous, before the once-per-turn
    /// correction: what commissioning fits the encoder's error from (`hob commission
    /// encoder`).
    pub spindle_reading_deg: f64,
    /// The table gauge's reading latched with this cycle's `table_deg` (CiA 401 counts),
    /// NaN when none was (`hob commission backlash`).
    pub table_gauge_counts: f64,
    pub spindle_rpm: f64,
    pub spindle_set_rpm: f64,
    pub table_deg: f64,
    pub table_cmd_deg: f64,
    pub x_mm: f64,
    pub x_cmd_mm: f64,
    pub y_mm: f64,
    pub y_cmd_mm: f64,
    pub coupling: Coupling,
    pub sync_error_arcsec: f64,
    pub ccc_arcsec: f64,
    pub fault: Option<Fault>,
    /// The state the fault met: in the work, elsewhere in a cycle or outside one (its
    /// reaction differs).
    pub fault_met: State,
    pub inputs: Inputs,
    pub outputs: Outputs,
    /// Drives (B, X, Y) reporting "operation enabled".
    pub drives_enabled: [bool; 3],
    /// Drives whose feedback has been missing long enough to be a fault (their state is
    /// unknown).
    pub drives_silent: [bool; 3],
    /// X, Y referenced.
    pub referenced: [bool; 2],
    /// The table kept its position since the tooth phase of an interrupted part was
    /// recorded ("continue" can meet the same gaps).
    pub table_position_whole: bool,
    /// The axis being referenced or jogged.
    pub moving_axis: Option<Axis>,
    /// The 1-based pass "continue" would start from (0: nothing to continue).
    pub continue_pass: u32,
    /// The Y where "continue" would re-enter that pass's cut (none: at the pass's start).
    pub continue_from_y_mm: Option<f64>,
    pub feed_override_percent: f64,
    pub spindle_override_percent: f64,
    pub offsets: Offsets,
    /// The pitch compensation: a `hob_wire::vocab::pitch_compensation` code.
    pub pitch_compensation: u8,
}

/// Measured values of one cycle, in units.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
struct Measured {
    spindle_deg: f64,
    /// The encoder's reading, continuous, uncorrected.
    spindle_reading_deg: f64,
    table_gauge_counts: f64,
    spindle_speed_deg_s: f64,
    /// Angle the gearbox follows (predicted or last measured).
    spindle_for_gearbox_deg: f64,
    table_deg: f64,
    x_mm: f64,
    y_mm: f64,
    inputs: Inputs,
    drives_enabled: [bool; 3],
    /// The drives' feedback as latched (B, X, Y): mode display and homing bits.
    feedback: [AxisFeedback; 3],
    /// The drive's position jumped this cycle (B, X, Y): see [`POSITION_JUMP`].
    jumped: [bool; 3],
}

/// What is left of an excitation's offset one cycle after a fault cut it short: gone
/// within about 50 cycles (the swing is at most `EXCITE_MAX_DEG`, so it moves the table's
/// target by at most a tenth of that a cycle).
const EXCITATION_CUT_DECAY: f64 = 0.9;

/// A change of a drive's position in one cycle that no motion of this machine can make
/// (B deg, X mm, Y mm): the drive rebooted or its encoder failed, so the position is lost.
pub const POSITION_JUMP: [f64; 3] = [10.0, 5.0, 5.0];

/// The control core.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct Controller {
    params: ControlParams,
    angle_source: SpindleAngleSource,
    program: Option<CycleProgram>,
    unwrap: [Unwrapper; 4],
    observer: SpindleObserver,
    /// The spindle encoder's once-per-turn error, identified while it turns.
    eccentricity: EccentricityIdentifier,
    gearbox: Gearbox,
    x: Profile,
    y: Profile,
    table_cmd_deg: f64,
    /// The table's target swung from the gearbox's this far, deg (an excitation; faded
    /// back to 0 within a few cycles when a fault cut the excitation short).
    table_excitation_deg: f64,
    /// Targets (B, X, Y) of the last two cycles: the drive follows the older one at SYNC.
    history: [[f64; 3]; 2],
    misses: [u32; 3],
    measured: Measured,
    last_spindle_for_gearbox_deg: f64,
    sequencer: sequencer::Sequencer,
    fault: Option<Fault>,
    lube: Lube,
    outputs: Outputs,
    /// Slow trim of the open-loop VFD reference onto the measured spindle speed (slip).
    spindle_trim: f64,
    /// Time the spindle has been within tolerance of its set speed.
    spindle_at_speed_s: f64,
    /// Time the drives have been asked to be enabled.
    enable_age_s: f64,
    events: EventRing,
    cycle: u64,
    started: bool,
    referencing: referencing::Referencing,
    offsets: Offsets,
    /// The last touch-off judged and the one the operator was asked to confirm.
    touch_offs: setup_math::TouchOffs,
    /// Overrides as fractions (1.0 = 100 %).
    feed_override: f64,
    spindle_override: f64,
    /// The pitch compensation loaded at start-up (the machine's worm set's), and whether
    /// the operator switched it on: the gearbox applies it when both.
    pitch_compensation: Option<pitch_comp::PitchCompensation>,
    pitch_compensation_on: bool,
}

impl Controller {
    /// A controller for the machine; allocates nothing after this.
    pub fn new(p: ControlParams) -> Self {
        Self {
            params: p,
            angle_source: SpindleAngleSource::Predicted,
            program: None,
            unwrap: [Unwrapper::default(); 4],
            observer: SpindleObserver::new(p.period_s, p.observer_bandwidth_hz),
            eccentricity: EccentricityIdentifier::new(
                p.period_s,
                p.encoder_identification_s,
                1.0 / p.spindle.counts_per_unit,
            )
            .with_swing(p.spindle_swing),
            gearbox: Gearbox::new(p.gearbox, 0.0),
            x: Profile::default(),
            y: Profile::default(),
            table_cmd_deg: 0.0,
            table_excitation_deg: 0.0,
            history: [[0.0; 3]; 2],
            misses: [0; 3],
            measured: Measured::default(),
            last_spindle_for_gearbox_deg: 0.0,
            sequencer: sequencer::Sequencer::default(),
            fault: None,
            lube: Lube::new(p.lube),
            outputs: Outputs::default(),
            spindle_trim: 1.0,
            spindle_at_speed_s: 0.0,
            enable_age_s: 0.0,
            events: EventRing::new(),
            cycle: 0,
            started: false,
            referencing: referencing::Referencing::default(),
            offsets: Offsets::default(),
            touch_offs: setup_math::TouchOffs::default(),
            feed_override: 1.0,
            spindle_override: 1.0,
            pitch_compensation: None,
            pitch_compensation_on: false,
        }
    }

    /// The work offsets (from the machine state file at start-up, or a touch-off). The
    /// loop's positions shift with them, so a change never moves an axis.
    pub fn set_offsets(&mut self, offsets: Offsets) {
        self.apply_offsets(offsets);
    }

    /// The cycle counter (what `status().cycle` says, without building the status).
    pub fn cycle(&self) -> u64 {
        self.cycle
    }

    /// The spindle observer's bandwidth changed, its state kept: a replay's "what if"
    /// (`hob replay --observer-bandwidth-hz`), never the loop's.
    pub fn set_observer_bandwidth_hz(&mut self, hz: f64) {
        self.params.observer_bandwidth_hz = hz;
        self.observer = self.observer.with_bandwidth(hz);
    }

    pub fn offsets(&self) -> Offsets {
        self.offsets
    }

    /// The touch-off the last `TouchOff` command judged: applied (the command accepted) or
    /// asked about (refused as `OffsetNeedsConfirmation`), with the old and new offsets the
    /// answer names; `None` when it was refused before it was judged.
    pub fn last_touch_off(&self) -> Option<setup_math::TouchOff> {
        self.touch_offs.last
    }

    fn apply_offsets(&mut self, new: Offsets) {
        let (dx, dy) = (new.x_mm - self.offsets.x_mm, new.y_mm - self.offsets.y_mm);
        self.offsets = new;
        self.measured.x_mm += dx;
        self.measured.y_mm += dy;
        self.x.position += dx;
        self.y.position += dy;
        for h in &mut self.history {
            h[1] += dx;
            h[2] += dy;
        }
    }

    /// Whether X (Y) is referenced.
    pub fn referenced(&self, axis: Axis) -> bool {
        self.referencing.is_referenced(axis)
    }

    /// Chooses the spindle angle the gearbox follows (for comparisons; default predicted).
    pub fn set_angle_source(&mut self, source: SpindleAngleSource) {
        self.angle_source = source;
    }

    /// Turns cross-coupling on or off (before a cycle).
    pub fn set_cross_coupling(&mut self, on: bool) {
        self.params.gearbox.ccc_enabled = on;
        self.gearbox.set_cross_coupling(on);
    }

    pub fn params(&self) -> &ControlParams {
        &self.params
    }

    /// Loads a pitch compensation (start-up: the machine's worm set's), switched off;
    /// `None` unloads it. Refused (`false`, nothing changed) while the gearbox is coupled,
    /// where the change would step the table. Switched on (`Command::PitchCompensation`), it
    /// is applied to the table and a new blank is cut at its tooth phase.
    pub fn load_pitch_compensation(&mut self, compensation: Option<pitch_comp::PitchCompensation>) -> bool {
        if self.gearbox.coupling() != egb::Coupling::Disengaged {
            return false;
        }
        self.pitch_compensation = compensation;
        self.pitch_compensation_on = false;
        true
    }

    /// The pitch compensation the gearbox applies now (loaded and switched on).
    pub fn pitch_compensation(&self) -> Option<&pitch_comp::PitchCompensation> {
        self.pitch_compensation
            .as_ref()
            .filter(|_| self.pitch_compensation_on)
    }

    pub fn program(&self) -> Option<&CycleProgram> {
        self.program.as_ref()
    }

    /// Events since the last drain, oldest first.
    pub fn events(&mut self) -> &mut EventRing {
        &mut self.events
    }

    fn event(&mut self, kind: EventKind) {
        self.events.push(Event {
            cycle: self.cycle,
            kind,
        });
    }

    /// One control cycle.
    pub fn step(&mut self, input: &CycleInputs) -> CycleOutputs {
        self.cycle += 1;
        self.measure(input);
        if !self.started {
            self.started = true;
            self.x = Profile::at(self.measured.x_mm);
            self.y = Profile::at(self.measured.y_mm);
            self.gearbox = Gearbox::new(self.params.gearbox, self.measured.table_deg);
            self.table_cmd_deg = self.measured.table_deg;
            self.history = [[self.measured.table_deg, self.measured.x_mm, self.measured.y_mm]; 2];
            self.last_spindle_for_gearbox_deg = self.measured.spindle_for_gearbox_deg;
        }
        self.supervise(input);
        let (x_before, y_before) = (self.x.position, self.y.position);
        self.trim_spindle();
        self.sequence();
        // A drive homing by itself sets its position at the home: that step is no travel
        // (nor is the homing run, which the loop does not command).
        let travel = |own: bool, d: f64| if own { 0.0 } else { d };
        if let Err(f) = self.lube.step(
            self.params.period_s,
            travel(
                self.referencing.drive_on_its_own(Axis::X),
                self.x.position - x_before,
            ),
            travel(
                self.referencing.drive_on_its_own(Axis::Y),
                self.y.position - y_before,
            ),
            self.measured.inputs.lube_pressure_ok,
        ) {
            self.raise(f);
        }
        self.table_cmd_deg = self.gearbox.step(
            self.measured.spindle_for_gearbox_deg,
            self.y.position,
            self.measured.spindle_deg,
            self.measured.table_deg,
            self.measured.y_mm,
            self.params.period_s,
            self.pitch_compensation
                .as_ref()
                .filter(|_| self.pitch_compensation_on),
        );
        if self.sequencer.state != State::Jog {
            // An excitation cut short (a fault): its offset fades instead of jumping.
            self.table_excitation_deg *= EXCITATION_CUT_DECAY;
            if self.table_excitation_deg.abs() < 1e-9 {
                self.table_excitation_deg = 0.0;
            }
        }
        self.table_cmd_deg += self.table_excitation_deg;
        self.last_spindle_for_gearbox_deg = self.measured.spindle_for_gearbox_deg;
        self.check_soft_limits();
        self.history = [
            self.history[1],
            [self.table_cmd_deg, self.x.position, self.y.position],
        ];
        self.outputs()
    }

    fn measure(&mut self, input: &CycleInputs) {
        let prev = self.measured;
        let reading = self
            .params
            .spindle
            .to_units(self.unwrap[0].update(input.spindle_counts));
        // The spindle encoder rides on the B drive's TPDO: without it this cycle the
        // observer coasts instead of taking the held value as a measurement.
        let fresh = input.table.fresh || !self.started;
        // The reading without the encoder's once-per-turn error identified so far.
        let spindle = self.eccentricity.update(reading, fresh);
        let est = if fresh {
            self.observer.update(spindle)
        } else {
            self.observer.coast()
        };
        let for_gearbox = match self.angle_source {
            SpindleAngleSource::Predicted => est.predict_deg(self.params.horizon_s),
            SpindleAngleSource::LastMeasured => spindle,
        };
        self.measured = Measured {
            spindle_deg: est.angle_deg,
            spindle_reading_deg: reading,
            table_gauge_counts: input.table_gauge_counts.map_or(f64::NAN, f64::from),
            spindle_speed_deg_s: est.speed_deg_s,
            spindle_for_gearbox_deg: for_gearbox,
            table_deg: self
                .params
                .table
                .to_units(self.unwrap[1].update(input.table.position_counts)),
            x_mm: self
                .params
                .x
                .to_units(self.unwrap[2].update(input.x.position_counts))
                + self.offsets.x_mm,
            y_mm: self
                .params
                .y
                .to_units(self.unwrap[3].update(input.y.position_counts))
                + self.offsets.y_mm,
            drives_enabled: [input.table.enabled, input.x.enabled, input.y.enabled],
            feedback: [input.table, input.x, input.y],
            jumped: [false; 3],
            inputs: if input.io_valid {
                self.params.io.decode(input.digital_inputs)
            } else {
                Inputs::default()
            },
        };
        // A drive's feedback that did not arrive this cycle (a late frame, a bus hiccup)
        // is not a measurement: assume the axis moved as commanded, its following error
        // unchanged, until `feedback_misses_to_fault` cycles make it a fault.
        if self.started {
            let [h0, h1] = self.history;
            let moved = |k: usize| h1[k] - h0[k];
            if !input.table.fresh {
                self.measured.table_deg = prev.table_deg + moved(0);
            }
            if !input.x.fresh {
                self.measured.x_mm = prev.x_mm + moved(1);
            }
            if !input.y.fresh {
                self.measured.y_mm = prev.y_mm + moved(2);
            }
            let m = &self.measured;
            let steps = [
                (m.table_deg - prev.table_deg, input.table.fresh, Axis::B),
                (m.x_mm - prev.x_mm, input.x.fresh, Axis::X),
                (m.y_mm - prev.y_mm, input.y.fresh, Axis::Y),
            ];
            for (k, (step, fresh, axis)) in steps.into_iter().enumerate() {
                // A drive homing by itself sets its position at the home: not a jump.
                self.measured.jumped[k] = fresh
                    && step.abs() > POSITION_JUMP[k]
                    && !self.referencing.drive_on_its_own(axis)
                    && prev.feedback[k].mode_display == input_mode(input, k);
            }
        }
    }

    /// Supervision: safety chain, limits, drives, feedback, following errors. What is
    /// checked depends on whether the drives were to be enabled at the start of the cycle
    /// (`active`), whatever a fault raised on the way changes.
    fn supervise(&mut self, input: &CycleInputs) {
        let active = self.sequencer.drives_should_be_enabled();
        self.supervise_inputs(input, active);
        self.supervise_drives(input, active);
        if active && self.enable_age_s > DRIVE_ENABLE_TIMEOUT_S {
            self.supervise_enabled(input);
        }
        if active && self.cycle > 3 {
            self.supervise_following_errors();
        }
    }

    /// The I/O coupler and the inputs: e-stop, hardware limits, VFD, safety chain.
    fn supervise_inputs(&mut self, input: &CycleInputs, active: bool) {
        let i = self.measured.inputs;
        if !input.io_valid && active {
            self.raise(Fault::IoLost);
        }
        // The specific causes first, so that the root cause is the fault reported: each of
        // them also opens the safety chain.
        if i.estop_pressed {
            self.raise(Fault::EmergencyStop);
        }
        for (on, axis, end) in [
            (i.x_limit_min, Axis::X, fault::End::Min),
            (i.x_limit_max, Axis::X, fault::End::Max),
            (i.y_limit_min, Axis::Y, fault::End::Min),
            (i.y_limit_max, Axis::Y, fault::End::Max),
        ] {
            if on {
                self.raise(Fault::HardwareLimit { axis, end });
            }
        }
        if i.vfd_fault {
            self.raise(Fault::VfdFault);
        }
        if !i.safety_chain_closed && active {
            self.raise(Fault::SafetyChainOpen);
        }
    }

    /// Each drive: its position, its fault and its feedback; and the time the drives have
    /// been asked to be enabled.
    fn supervise_drives(&mut self, input: &CycleInputs, active: bool) {
        // After a reset (or at power-up) the drives are brought up from Init: a drive's
        // fault is cleared by the fault reset the master sends, a few cycles later. A drive
        // still in fault when the enable time is over has its fault again.
        let fault_resetting =
            self.sequencer.state == State::Init && self.enable_age_s <= DRIVE_ENABLE_TIMEOUT_S;
        let drives = [(input.table, Axis::B), (input.x, Axis::X), (input.y, Axis::Y)];
        for (k, (fb, axis)) in drives.into_iter().enumerate() {
            if self.measured.jumped[k] {
                if active {
                    self.raise(Fault::PositionLost { axis });
                }
                self.position_lost(axis);
            }
            if fb.fault && !fault_resetting {
                self.raise(Fault::DriveFault { axis });
            }
            self.misses[k] = if fb.fresh { 0 } else { self.misses[k] + 1 };
            if self.misses[k] >= self.params.feedback_misses_to_fault {
                self.raise(Fault::FeedbackLost { axis });
            }
        }
        self.enable_age_s = if active {
            self.enable_age_s + self.params.period_s
        } else {
            0.0
        };
    }

    /// The drives' enable time is over: each drive must be enabled.
    fn supervise_enabled(&mut self, input: &CycleInputs) {
        let faulted = [input.table.fault, input.x.fault, input.y.fault];
        for ((enabled, faulted), axis) in
            self.measured
                .drives_enabled
                .into_iter()
                .zip(faulted)
                .zip([Axis::B, Axis::X, Axis::Y])
        {
            // A drive whose fault the reset did not clear: its fault is the cause.
            if faulted {
                self.raise(Fault::DriveFault { axis });
            } else if !enabled {
                self.raise(Fault::DriveNotEnabled { axis });
            }
        }
    }

    /// The following error of each drive that follows the loop's targets.
    fn supervise_following_errors(&mut self) {
        let [b, x, y] = self.history[0];
        let errors = [
            (
                self.measured.table_deg - b,
                self.params.table_max_following_error_deg,
                Axis::B,
            ),
            (
                self.measured.x_mm - x,
                self.params.x_limits.max_following_error_mm,
                Axis::X,
            ),
            (
                self.measured.y_mm - y,
                self.params.y_limits.max_following_error_mm,
                Axis::Y,
            ),
        ];
        for (error, limit, axis) in errors {
            // A drive out of cyclic synchronous position follows no target of ours.
            let own = self.referencing.drive_on_its_own(axis)
                || self.measured.feedback[match axis {
                    Axis::B => 0,
                    Axis::X => 1,
                    Axis::Y => 2,
                }]
                .mode_display
                    != DriveMode::CyclicPosition.code();
            if error.abs() > limit && !own {
                self.raise(Fault::FollowingError { axis, error });
            }
        }
    }

    /// The VFD runs open loop and its motor slips under load: a slow integral trim keeps
    /// the measured speed on the set speed. Bounded; learned value kept between runs.
    fn trim_spindle(&mut self) {
        let set = self.sequencer.spindle_set_rpm;
        let sign = self.program.map_or(1.0, |p| p.spindle_sign);
        let actual = self.measured.spindle_speed_deg_s / 6.0 * sign;
        let held_steady = self.sequencer.jog.spindle_hold_renewed_s.is_some()
            && self.spindle_at_speed_s >= SPINDLE_HOLD_TRIM_S;
        if set > 0.0 && actual > 0.5 * set && !held_steady {
            let error = (set - actual) / set;
            self.spindle_trim = (self.spindle_trim + SPINDLE_TRIM_PER_S * self.params.period_s * error)
                .clamp(SPINDLE_TRIM_RANGE.0, SPINDLE_TRIM_RANGE.1);
        }
        let within = set > 0.0 && (actual - set).abs() <= self.params.spindle_tolerance * set;
        self.spindle_at_speed_s = if within {
            self.spindle_at_speed_s + self.params.period_s
        } else {
            0.0
        };
    }

    /// From the reference on: no command outside the soft limits (in the drive's
    /// referenced frame, the work offset taken off).
    fn check_soft_limits(&mut self) {
        for (axis, pos, offset, lim) in [
            (Axis::X, self.x.position, self.offsets.x_mm, self.params.x_limits),
            (Axis::Y, self.y.position, self.offsets.y_mm, self.params.y_limits),
        ] {
            let machine = pos - offset;
            if self.referencing.is_referenced(axis)
                && !(lim.soft_min_mm..=lim.soft_max_mm).contains(&machine)
                && self.sequencer.drives_should_be_enabled()
            {
                self.raise(Fault::SoftLimit { axis, position: pos });
                let clamped = machine.clamp(lim.soft_min_mm, lim.soft_max_mm) + offset;
                let p = if axis == Axis::X { &mut self.x } else { &mut self.y };
                p.position = clamped;
                p.velocity = 0.0;
            }
        }
    }

    fn outputs(&mut self) -> CycleOutputs {
        // An open chain disables the drives, except in the fault reaction: a stop of
        // category 1 retracts and stops under control while the drives still have power
        // (the safety relay takes it after its delay), so X leaves the work with the
        // gearbox engaged.
        let enabled = self.sequencer.drives_should_be_enabled()
            && (self.measured.inputs.safety_chain_closed || self.sequencer.in_fault_reaction());
        let spindle_rpm = self.sequencer.spindle_set_rpm;
        let program_sign = self.program.map_or(1.0, |p| p.spindle_sign);
        let running = spindle_rpm > 0.0;
        let forward = program_sign * self.params.spindle.sign > 0.0;
        self.outputs = Outputs {
            pc_ok_relay: self.sequencer.pc_ok(self.fault),
            pc_reset_relay: self.fault.is_none(),
            lube_pump: self.lube.pump_on(),
            coolant_pump: self.sequencer.coolant,
            x_clamp: self.sequencer.clamp,
            spindle_run_forward: running && forward,
            spindle_run_reverse: running && !forward,
            fault_lamp: self.fault.is_some(),
        };
        let v_table = (self.table_cmd_deg - self.history[0][0]) / (2.0 * self.params.period_s);
        CycleOutputs {
            table_target_counts: self.params.table.to_counts(self.table_cmd_deg),
            x_target_counts: self.params.x.to_counts(self.x.position - self.offsets.x_mm),
            y_target_counts: self.params.y.to_counts(self.y.position - self.offsets.y_mm),
            table_velocity_counts_s: v_table * self.params.table.counts_per_unit * self.params.table.sign,
            x_velocity_counts_s: self.x.velocity * self.params.x.counts_per_unit * self.params.x.sign,
            y_velocity_counts_s: self.y.velocity * self.params.y.counts_per_unit * self.params.y.sign,
            drives_enabled: enabled,
            drive_modes: self.referencing.modes,
            homing_start: self.referencing.start_bit,
            digital_outputs: self.params.io.encode(&self.outputs),
            spindle_analog_v: self
                .params
                .spindle_drive
                .analog_out_v(spindle_rpm * self.spindle_trim)
                .clamp(0.0, self.params.spindle_drive.analog_full_scale_v),
        }
    }

    /// What the loop publishes this cycle.
    pub fn status(&self) -> Status {
        let s = self.gearbox.status();
        Status {
            cycle: self.cycle,
            state: self.sequencer.state,
            hold: self.sequencer.hold,
            pass: self.sequencer.pass_number(),
            tooth: self.sequencer.tooth,
            spindle_deg: self.measured.spindle_deg,
            spindle_reading_deg: self.measured.spindle_reading_deg,
            table_gauge_counts: self.measured.table_gauge_counts,
            spindle_rpm: self.measured.spindle_speed_deg_s / 6.0,
            spindle_set_rpm: self.sequencer.spindle_set_rpm,
            table_deg: self.measured.table_deg,
            table_cmd_deg: self.table_cmd_deg,
            x_mm: self.measured.x_mm,
            x_cmd_mm: self.x.position,
            y_mm: self.measured.y_mm,
            y_cmd_mm: self.y.position,
            coupling: self.gearbox.coupling(),
            sync_error_arcsec: s.error_deg * 3600.0,
            ccc_arcsec: s.ccc_deg * 3600.0,
            fault: self.fault,
            fault_met: self.sequencer.fault_met,
            inputs: self.measured.inputs,
            outputs: self.outputs,
            drives_enabled: self.measured.drives_enabled,
            drives_silent: self.misses.map(|m| m >= self.params.feedback_misses_to_fault),
            referenced: self.referencing.referenced,
            table_position_whole: !self.sequencer.phase_lost,
            moving_axis: match self.sequencer.state {
                State::Referencing => self.referencing.current_axis(),
                State::Jog => self.sequencer.jog.axis(),
                _ => None,
            },
            continue_pass: self.sequencer.interrupted.map_or(0, |i| i.pass_index as u32 + 1),
            continue_from_y_mm: self.sequencer.interrupted.and_then(|i| i.from_y_mm),
            feed_override_percent: self.feed_override * 100.0,
            spindle_override_percent: self.spindle_override * 100.0,
            offsets: self.offsets,
            pitch_compensation: match (&self.pitch_compensation, self.pitch_compensation_on) {
                (None, _) => hob_wire::vocab::pitch_compensation::NONE,
                (Some(_), false) => hob_wire::vocab::pitch_compensation::OFF,
                (Some(_), true) => hob_wire::vocab::pitch_compensation::ON,
            },
        }
    }

    /// The gearbox (for its recorded phase and parameters).
    pub fn gearbox(&self) -> &Gearbox {
        &self.gearbox
    }

    /// Whether every drive reports "operation enabled".
    pub fn drives_ready(&self) -> bool {
        self.measured.drives_enabled.iter().all(|e| *e)
    }

    /// Lubrication cycles completed since power-up.
    pub fn lube_cycles(&self) -> u32 {
        self.lube.cycles_done()
    }
}

#[cfg(test)]
mod tests;
