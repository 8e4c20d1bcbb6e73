//! The whole simulated machine: spindle, three servo axes, the I/O coupler's signals,
//! the safety chain, and fault injection. Exchanges with the controller exactly what the
//! bus carries: raw counts, drive status, raw I/O images, the analog voltage.

use crate::config::{DriveCounters, LinearPlant, PlantConfig, Side, WormCoupling};
use crate::drive::{Drive, DriveCommand, HomeGeometry, HomingParams, MODE_CSP};
use crate::servo::{Servo, ServoParams};
use crate::spindle::Spindle;
use crate::worklink::WorkLink;
use crate::worm::WormDrive;
use hob_control::fault::{Axis, End};
use hob_control::io::{Inputs, IoBits, Outputs};
use hob_control::{AxisFeedback, ControlParams, CycleInputs, CycleOutputs};
use hob_setup::config::machine::{LinearAxisConfig, MachineConfig};
use std::f64::consts::TAU;

const G: f64 = 9.81;
/// Lag of the cutting force behind the chip thickness (seed 003: T_P = 5.4e-4 s).
const CUT_FORCE_LAG_S: f64 = 5.4e-4;
/// Time the simulated operator takes to reset the safety relay once its causes are gone.
const SECONDS_FOR_OPERATOR_RESET: f64 = 0.5;

/// What the plant must know of the job to load the spindle and the table in the cut.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Workpiece {
    /// X with the tool tip on the blank's outside diameter.
    pub x_surface_mm: f64,
    pub face_bottom_mm: f64,
    pub face_top_mm: f64,
    pub tool_diameter_mm: f64,
    pub pitch_radius_mm: f64,
}

/// A fault to inject.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Injection {
    DriveFault(Axis),
    OpenSafetyChain,
    EmergencyStop,
    HardwareLimit(Axis, End),
    /// The lube pressure switch never closes.
    NoLubePressure,
    /// Something blocks the axis (a crash): a large opposing torque.
    Obstruct(Axis),
    VfdFault,
}

/// Initial positions: where the machine stands at power-on. What the drives' counters
/// read there is `simulation.drive_counters` ([`DriveCounters`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Start {
    pub x_mm: f64,
    pub y_mm: f64,
    pub table_deg: f64,
}

impl Start {
    /// X and Y at a random position within their soft limits (drawn from `seed`), the
    /// table at `table_deg`: where an unreferenced machine may stand at power-on.
    /// X and Y at a random position within `within_mm` of their home position (and within
    /// their soft limits), drawn from `seed`; the table at `table_deg`.
    pub fn random_near_home(machine: &MachineConfig, seed: u64, within_mm: f64, table_deg: f64) -> Self {
        let far = Self::random_within_travel(machine, seed, table_deg);
        let near = |a: &LinearAxisConfig, at: f64| {
            // The draw within the travel, mapped onto the home position's neighbourhood.
            let u = (at - a.soft_limit_min_mm) / (a.soft_limit_max_mm - a.soft_limit_min_mm);
            let lo = (a.homing.home_position_mm - within_mm).max(a.soft_limit_min_mm);
            let hi = (a.homing.home_position_mm + within_mm).min(a.soft_limit_max_mm);
            lo + u * (hi - lo)
        };
        Self {
            x_mm: near(&machine.x, far.x_mm),
            y_mm: near(&machine.y, far.y_mm),
            table_deg,
        }
    }

    pub fn random_within_travel(machine: &MachineConfig, seed: u64, table_deg: f64) -> Self {
        let mut rng = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        let mut uniform = || crate::rng::uniform(&mut rng);
        let within = |a: &LinearAxisConfig, u: f64| {
            a.soft_limit_min_mm + u * (a.soft_limit_max_mm - a.soft_limit_min_mm)
        };
        Self {
            x_mm: within(&machine.x, uniform()),
            y_mm: within(&machine.y, uniform()),
            table_deg,
        }
    }
}

/// The simulated machine.
#[derive(Debug, Clone)]
pub struct Plant {
    cfg: PlantConfig,
    params: ControlParams,
    io: IoBits,
    pub spindle: Spindle,
    pub table: Servo,
    pub x: Servo,
    pub y: Servo,
    /// The drives of B, X and Y (counters, modes, homing, hardware-limit faults).
    pub drives: [Drive; 3],
    /// Torsional deflection of the work on the table under the cut (seed 003).
    pub work: WorkLink,
    /// The worm drive between the B motor and the table.
    pub worm: WormDrive,
    worm_ratio: f64,
    spindle_counts_per_rad: f64,
    /// The spindle encoder's error: (amplitude rad, phase rad) once, twice, three times per turn.
    spindle_encoder_error: [(f64, f64); 3],
    /// The hob's axial runout: amplitude (mm) and phase (rad).
    hob_axial_runout: (f64, f64),
    table_motor_rad_per_deg: f64,
    x_rad_per_mm: f64,
    y_rad_per_mm: f64,
    hz_per_volt: f64,
    t_s: f64,
    /// The table's angle where the gauge reads 0 (where it stood at power-on), rad.
    gauge_zero_rad: f64,
    inner_s: f64,
    outputs: Outputs,
    analog_v: f64,
    /// Whether each drive's power stage drives its motor (B, X, Y), as of the last SYNC.
    drive_enable: [bool; 3],
    /// The enable of the last SYNC (a rising edge resets a drive's own fault).
    enable_before: [bool; 3],
    lube_on_since: Option<f64>,
    clamp_changed_at: f64,
    clamp_closed: bool,
    chain_closed: bool,
    chain_changed_at: f64,
    chain_cause_gone_at: Option<f64>,
    workpiece: Option<Workpiece>,
    /// A disk cutter's side deflection (tooth-by-tooth cycle with `[tool.disk]`).
    cutter: Option<crate::cutter::CutterLink>,
    estop: bool,
    chain_open_injected: bool,
    limit: Option<(Axis, End)>,
    no_lube_pressure: bool,
}

fn linear_servo(
    m: &hob_setup::config::machine::LinearAxisConfig,
    p: &crate::config::LinearPlant,
    drives: &crate::config::DrivesPlant,
    vertical: bool,
    period_s: f64,
    start_mm: f64,
) -> (Servo, f64) {
    let counts_per_rad = f64::from(m.encoder_counts_per_motor_rev) / TAU;
    let rad_per_mm = m.counts_per_mm() / counts_per_rad;
    let m_per_rad = 0.001 / rad_per_mm;
    let weight_n = p.moving_mass_kg * G;
    let params = ServoParams {
        inertia_kg_m2: p.motor_inertia_kg_m2 + p.moving_mass_kg * m_per_rad * m_per_rad,
        tuned_inertia_kg_m2: p.motor_inertia_kg_m2 + p.moving_mass_kg * m_per_rad * m_per_rad,
        counts_per_rad,
        peak_torque_nm: p.peak_motor_torque_nm,
        velocity_loop_hz: p.velocity_loop_hz,
        position_loop_hz: p.position_loop_hz,
        velocity_feed_forward: p.velocity_feed_forward,
        friction_nm: p.friction_coefficient * weight_n * m_per_rad,
        static_friction_nm: p.static_friction_ratio * p.friction_coefficient * weight_n * m_per_rad,
        stribeck_rad_s: p.stribeck_speed_mm_s * rad_per_mm,
        constant_load_nm: if vertical { weight_n * m_per_rad } else { 0.0 },
        brake: vertical,
        loop_period_s: f64::from(drives.loop_us) * 1e-6,
        feedback_counts_per_rad: drives.feedback_counts_per_rad(),
        velocity_filter_hz: drives.velocity_filter_hz,
        extra_delay_s: drives.extra_delay_s(period_s),
    };
    (Servo::new(params, start_mm * rad_per_mm, period_s), rad_per_mm)
}

/// The drive of a linear axis: home switch, index pulse, hardware limits and homing
/// parameters (as the master configures them from `[x|y.homing]`) in motor counts.
fn linear_drive(m: &LinearAxisConfig, p: &LinearPlant, servo: &Servo, counters: DriveCounters) -> Drive {
    let sign = m.polarity.sign();
    let counts = |mm: f64| mm * m.counts_per_mm() * sign;
    let pitch = i64::from(m.encoder_counts_per_motor_rev);
    let geometry = HomeGeometry {
        switch_edge_counts: counts(p.home_switch_edge_mm),
        switch_active_positive: (p.home_switch_active_side == Side::Positive) == (sign > 0.0),
        index_pitch_counts: pitch,
        index_phase_counts: (counts(p.index_pulse_at_mm).round() as i64).rem_euclid(pitch),
        timeout_s: p.homing_timeout_s,
    };
    let (a, b) = (
        counts(m.soft_limit_min_mm - p.hardware_limit_margin_mm),
        counts(m.soft_limit_max_mm + p.hardware_limit_margin_mm),
    );
    let h = &m.homing;
    let per_s = |mm_min: f64| (mm_min / 60.0 * m.counts_per_mm()).round() as u32;
    let homing = HomingParams {
        method: h.method,
        home_offset_counts: counts(h.home_position_mm).round() as i32,
        switch_speed_counts_s: per_s(h.switch_search_mm_min),
        zero_speed_counts_s: per_s(h.zero_search_mm_min),
        accel_counts_s2: (h.accel_mm_s2 * m.counts_per_mm()).round() as u32,
    };
    let physical = servo.position_counts();
    Drive::new(
        physical,
        power_on_counter(physical, counters),
        Some(geometry),
        Some((a.min(b), a.max(b))),
        homing,
    )
}

fn power_on_counter(physical: i64, counters: DriveCounters) -> i64 {
    match counters {
        DriveCounters::Referenced => physical,
        DriveCounters::Incremental => 0,
    }
}

impl Plant {
    pub fn new(cfg: &PlantConfig, machine: &MachineConfig, start: Start, gashes: u32) -> Self {
        let params = ControlParams::from_machine(machine);
        // The phases of the spindle encoder's and the hob's once-per-turn errors.
        let mut rng = cfg.simulation.seed.wrapping_mul(0xD1B5_4A32_D192_ED03) | 1;
        let phases = [crate::rng::uniform(&mut rng), crate::rng::uniform(&mut rng)];
        // Drawn after those two, so that a plant without them is as it was.
        let hidden_phases = [
            crate::rng::uniform(&mut rng),
            crate::rng::uniform(&mut rng),
            crate::rng::uniform(&mut rng),
        ];
        let period_s = params.period_s;
        let t = &cfg.table;
        let table_counts_per_rad = f64::from(machine.table.encoder_counts_per_motor_rev) / TAU;
        let ratio = machine.table.worm_ratio;
        // What the motor carries besides itself, the worm's inertia, and the inertia at the
        // table of the mesh's mode. One-way: the table rigidly reflected on the motor, which
        // holds the worm rigidly against the table's mode (the worm's own inertia belongs
        // to the two-way model: the one-way plant is kept as it was, to compare). Two-way:
        // the motor and the worm alone, the table reaching them through the mesh's torque;
        // the mode is the two sides in series.
        let (carried_kg_m2, worm_kg_m2, modal_kg_m2) = match t.coupling {
            WormCoupling::OneWay => (
                t.table_inertia_kg_m2 / (ratio * ratio),
                0.0,
                t.table_inertia_kg_m2,
            ),
            WormCoupling::TwoWay => {
                let motor_side = (t.motor_inertia_kg_m2 + t.worm_inertia_kg_m2) * ratio * ratio;
                let modal = motor_side * t.table_inertia_kg_m2 / (motor_side + t.table_inertia_kg_m2);
                (t.worm_inertia_kg_m2, t.worm_inertia_kg_m2, modal)
            }
        };
        let table_params = ServoParams {
            inertia_kg_m2: t.motor_inertia_kg_m2 + carried_kg_m2,
            // The autotune's estimate: everything the motor turns, the table rigidly reflected.
            tuned_inertia_kg_m2: t.motor_inertia_kg_m2
                + worm_kg_m2
                + t.tuned_table_inertia_kg_m2.unwrap_or(t.table_inertia_kg_m2) / (ratio * ratio),
            counts_per_rad: table_counts_per_rad,
            peak_torque_nm: t.peak_motor_torque_nm,
            velocity_loop_hz: t.velocity_loop_hz,
            position_loop_hz: t.position_loop_hz,
            velocity_feed_forward: t.velocity_feed_forward,
            friction_nm: t.friction_motor_nm,
            static_friction_nm: t.friction_motor_nm,
            stribeck_rad_s: 1.0,
            constant_load_nm: 0.0,
            brake: false,
            loop_period_s: f64::from(cfg.drives.loop_us) * 1e-6,
            feedback_counts_per_rad: cfg.drives.feedback_counts_per_rad(),
            velocity_filter_hz: cfg.drives.velocity_filter_hz,
            extra_delay_s: cfg.drives.extra_delay_s(period_s),
        };
        let table_motor_rad_per_deg = ratio * TAU / 360.0;
        let table = Servo::new(table_params, start.table_deg * table_motor_rad_per_deg, period_s);
        let (x, x_rad_per_mm) = linear_servo(&machine.x, &cfg.x, &cfg.drives, false, period_s, start.x_mm);
        let (y, y_rad_per_mm) = linear_servo(&machine.y, &cfg.y, &cfg.drives, true, period_s, start.y_mm);
        let counters = cfg.simulation.drive_counters;
        let table_physical = table.position_counts();
        let drives = [
            Drive::without_homing(table_physical, power_on_counter(table_physical, counters)),
            linear_drive(&machine.x, &cfg.x, &x, counters),
            linear_drive(&machine.y, &cfg.y, &y, counters),
        ];
        let s = &machine.spindle;
        Self {
            cfg: cfg.clone(),
            params,
            io: params.io,
            spindle: Spindle::new(
                &cfg.spindle,
                s.motor_to_spindle_ratio,
                s.vfd_hz_at_full_scale / s.vfd_ramp_s,
                gashes,
                TAU * hidden_phases[2],
            ),
            table,
            x,
            y,
            drives,
            work: WorkLink::new(t.work_link_t1_s, t.work_link_t2_s, t.work_link_stiffness_nm_rad),
            worm: WormDrive::new(
                &t.worm,
                ratio,
                t.table_inertia_kg_m2,
                modal_kg_m2,
                cfg.simulation.seed,
                start.table_deg * table_motor_rad_per_deg / ratio,
            ),
            worm_ratio: ratio,
            spindle_counts_per_rad: f64::from(s.encoder_counts_per_rev) / TAU,
            spindle_encoder_error: [
                (
                    (cfg.spindle.encoder_error_arcsec / 3600.0).to_radians(),
                    TAU * phases[0],
                ),
                (
                    (cfg.spindle.encoder_error_2_arcsec / 3600.0).to_radians(),
                    TAU * hidden_phases[0],
                ),
                (
                    (cfg.spindle.encoder_error_3_arcsec / 3600.0).to_radians(),
                    TAU * hidden_phases[1],
                ),
            ],
            hob_axial_runout: (cfg.spindle.hob_axial_runout_um * 1e-3, TAU * phases[1]),
            table_motor_rad_per_deg,
            x_rad_per_mm,
            y_rad_per_mm,
            hz_per_volt: s.vfd_hz_at_full_scale / s.analog_full_scale_v,
            t_s: 0.0,
            inner_s: f64::from(cfg.simulation.inner_step_us) * 1e-6,
            outputs: Outputs::default(),
            analog_v: 0.0,
            drive_enable: [false; 3],
            enable_before: [false; 3],
            lube_on_since: None,
            clamp_changed_at: 0.0,
            clamp_closed: false,
            chain_closed: false,
            chain_changed_at: 0.0,
            chain_cause_gone_at: None,
            workpiece: None,
            cutter: None,
            estop: false,
            chain_open_injected: false,
            limit: None,
            no_lube_pressure: false,
            gauge_zero_rad: start.table_deg * table_motor_rad_per_deg / ratio,
        }
    }

    pub fn set_workpiece(&mut self, w: Workpiece) {
        self.workpiece = Some(w);
    }

    /// The tool is this disk cutter: its side deflection is integrated while it cuts.
    pub fn set_disk_cutter(&mut self, c: crate::cutter::DiskCutter) {
        self.cutter = Some(crate::cutter::CutterLink::new(c));
    }

    /// The disk cutter's largest side deflection since the last call, um (None: no disk
    /// cutter).
    pub fn take_cutter_peak_um(&mut self) -> Option<f64> {
        self.cutter.as_mut().map(crate::cutter::CutterLink::take_peak_um)
    }

    pub fn time_s(&self) -> f64 {
        self.t_s
    }

    pub fn inject(&mut self, i: Injection) {
        match i {
            Injection::DriveFault(a) => self.servo_mut(a).fault = true,
            Injection::OpenSafetyChain => self.chain_open_injected = true,
            Injection::EmergencyStop => self.estop = true,
            Injection::HardwareLimit(a, e) => self.limit = Some((a, e)),
            Injection::NoLubePressure => self.no_lube_pressure = true,
            Injection::Obstruct(a) => self.servo_mut(a).disturbance_nm = 1e3,
            Injection::VfdFault => self.spindle.vfd_fault = true,
        }
    }

    /// Every injected fault repaired, as a technician would (a drive's fault cleared, the
    /// chain or the emergency stop released, the lube restored, the obstacle removed): the
    /// drives' own fault state stays until the master's fault reset.
    pub fn clear_injections(&mut self) {
        for a in [Axis::B, Axis::X, Axis::Y] {
            let s = self.servo_mut(a);
            s.fault = false;
            s.disturbance_nm = 0.0;
        }
        self.chain_open_injected = false;
        self.estop = false;
        self.limit = None;
        self.no_lube_pressure = false;
        self.spindle.vfd_fault = false;
    }

    fn servo_mut(&mut self, a: Axis) -> &mut Servo {
        match a {
            Axis::B => &mut self.table,
            Axis::X => &mut self.x,
            Axis::Y => &mut self.y,
        }
    }

    /// True spindle angle in the frame (deg, continuous).
    pub fn spindle_deg(&self) -> f64 {
        self.spindle.angle_rad.to_degrees()
    }

    /// The table angle the B motor commands through an ideal worm (deg, continuous): the
    /// motor's true angle over the ratio. What the controller's share of the error is
    /// measured on (the drive's motion, before the worm's errors).
    pub fn table_drive_deg(&self) -> f64 {
        self.table.motor_rad / self.table_motor_rad_per_deg * self.params.table.sign
    }

    /// The B motor's torque as its drive's loops command it, Nm (the peak is the drive's
    /// limit: a loop that saturates there is not in control).
    pub fn table_motor_torque_nm(&self) -> f64 {
        self.table.torque_nm()
    }

    /// True table angle (deg, continuous): the table on its worm wheel, after the worm's
    /// pitch errors, its play and its deflection under load ([`crate::worm`]). The work's own
    /// elastic twist on the table is [`Self::work_twist_arcsec`].
    pub fn table_deg(&self) -> f64 {
        self.worm.table_rad.to_degrees() * self.params.table.sign
    }

    /// The blank's true angle (deg, continuous): the table plus the work's twist on it. What
    /// the gear gets.
    pub fn blank_deg(&self) -> f64 {
        self.table_deg() + self.work_twist_arcsec() / 3600.0 + self.hob_runout_deg()
    }

    /// The hob's axial runout as a turn of the blank: the generating rack's shift along the
    /// hob axis (nearly the gear's tangent) over the pitch radius; 0 without a workpiece.
    fn hob_runout_deg(&self) -> f64 {
        let (amplitude_mm, phase) = self.hob_axial_runout;
        self.workpiece.as_ref().map_or(0.0, |w| {
            (amplitude_mm * (self.spindle.angle_rad + phase).sin() / w.pitch_radius_mm).to_degrees()
        })
    }

    /// Torsional deflection of the work relative to the table under the cut (seed 003's
    /// work link): a property of the machine that no drive encoder sees.
    pub fn work_twist_arcsec(&self) -> f64 {
        self.work.angle_rad.to_degrees() * 3600.0 * self.params.table.sign
    }

    pub fn x_mm(&self) -> f64 {
        self.x.motor_rad / self.x_rad_per_mm * self.params.x.sign
    }

    pub fn y_mm(&self) -> f64 {
        self.y.motor_rad / self.y_rad_per_mm * self.params.y.sign
    }

    pub fn outputs(&self) -> Outputs {
        self.outputs
    }

    pub fn safety_chain_closed(&self) -> bool {
        self.chain_closed
    }

    /// Whether the drives have power (chain closed, or within the stop-category-1 delay).
    fn drives_powered(&self) -> bool {
        self.chain_closed || self.t_s - self.chain_changed_at < self.cfg.simulation.safety_stop_delay_s
    }

    /// At SYNC: the drives and the I/O coupler take the controller's outputs (targets,
    /// enable, each drive's mode of operation and controlword bit 4 for homing).
    pub fn apply(&mut self, o: &CycleOutputs) {
        self.apply_io(o.digital_outputs, o.spindle_analog_v);
        let targets = [o.table_target_counts, o.x_target_counts, o.y_target_counts];
        self.apply_drive_commands(&std::array::from_fn(|i| DriveCommand {
            target_counts: targets[i],
            enable: o.drives_enabled,
            mode: o.drive_modes[i].code(),
            homing_start: o.homing_start[i],
            halt: false,
        }));
    }

    /// At SYNC, cyclic synchronous position only: each drive's target (its own counts,
    /// wrapping) and enable (B, X, Y).
    pub fn apply_drives(&mut self, targets: [i32; 3], enable: [bool; 3]) {
        self.apply_drive_commands(&std::array::from_fn(|i| DriveCommand {
            target_counts: targets[i],
            enable: enable[i],
            mode: MODE_CSP,
            homing_start: false,
            halt: false,
        }));
    }

    /// At SYNC: what each drive (B, X, Y) takes from the bus. Targets are in each drive's
    /// own counts (the controller applied the polarity). A rising edge of `enable` (the
    /// master's fault reset and enable) resets a drive's own fault (a hardware limit).
    pub fn apply_drive_commands(&mut self, c: &[DriveCommand; 3]) {
        let powered = self.drives_powered();
        let period_s = self.params.period_s;
        for (i, (s, d)) in [&mut self.table, &mut self.x, &mut self.y]
            .into_iter()
            .zip(self.drives.iter_mut())
            .enumerate()
        {
            if c[i].enable && !self.enable_before[i] {
                d.reset_fault();
            }
            self.enable_before[i] = c[i].enable;
            d.at_sync(s, &c[i], powered, period_s);
            self.drive_enable[i] = d.active();
        }
    }

    /// Drive `i` (0 B, 1 X, 2 Y) asks for `mode` (0x6060 written): it takes effect at
    /// once if the drive implements it (returns whether).
    pub fn set_drive_mode(&mut self, i: usize, mode: i8) -> bool {
        let s = match i {
            0 => &self.table,
            1 => &self.x,
            _ => &self.y,
        };
        self.drives[i].set_mode(mode, s)
    }

    /// The counter (0x6064) of drive `i` (0 B, 1 X, 2 Y).
    pub fn drive_counter(&self, i: usize) -> i64 {
        let s = match i {
            0 => &self.table,
            1 => &self.x,
            _ => &self.y,
        };
        self.drives[i].counter(s.position_counts())
    }

    /// The I/O coupler's outputs: raw digital image and the spindle's analog voltage.
    pub fn apply_io(&mut self, digital_outputs: u32, spindle_analog_v: f64) {
        self.outputs = self.io.decode_outputs(digital_outputs);
        self.analog_v = spindle_analog_v;
    }

    /// The raw digital input image (what the I/O coupler reports).
    pub fn input_image(&self) -> u32 {
        self.io.encode_inputs(&self.inputs())
    }

    /// The spindle encoder reading (counts, wrapping; B drive's auxiliary input).
    pub fn spindle_counts(&self) -> i32 {
        let a = self.spindle.angle_rad;
        let [(a1, p1), (a2, p2), (a3, p3)] = self.spindle_encoder_error;
        // The first term alone as before (a plant without harmonics reads bit for bit the same).
        let mut read_rad = a + a1 * (a + p1).sin();
        if a2 != 0.0 || a3 != 0.0 {
            read_rad += a2 * (2.0 * a + p2).sin() + a3 * (3.0 * a + p3).sin();
        }
        let c = (read_rad * self.spindle_counts_per_rad).floor() as i64;
        (c * self.params.spindle.sign as i64) as i32
    }

    /// Whether the drives have power now.
    pub fn drives_have_power(&self) -> bool {
        self.drives_powered()
    }

    /// At SYNC: what the drives and the coupler report.
    pub fn latch(&self) -> CycleInputs {
        let fb = |s: &Servo, d: &Drive| AxisFeedback {
            position_counts: d.counter(s.position_counts()) as i32,
            enabled: s.enabled && !s.fault,
            fault: s.fault || d.fault().is_some(),
            fresh: true,
            mode_display: d.mode_display(),
            homing: d.homing_bits(),
        };
        CycleInputs {
            spindle_counts: self.spindle_counts(),
            table: fb(&self.table, &self.drives[0]),
            x: fb(&self.x, &self.drives[1]),
            y: fb(&self.y, &self.drives[2]),
            digital_inputs: self.io.encode_inputs(&self.inputs()),
            io_valid: true,
            table_gauge_counts: self.table_gauge_counts(),
        }
    }

    /// The table gauge, when one is mounted.
    pub fn table_gauge(&self) -> Option<crate::config::TableGaugePlant> {
        self.cfg.peripherals.table_gauge
    }

    /// The table gauge's reading now, when one is mounted
    /// ([`crate::config::TableGaugePlant`]): the table's true angle since power-on as a
    /// displacement at the gauge's radius, with its noise (drawn from the time, so a run
    /// repeats), in the coupler's counts.
    pub fn table_gauge_counts(&self) -> Option<i16> {
        let g = self.cfg.peripherals.table_gauge?;
        let mut state = self.t_s.to_bits() ^ self.cfg.simulation.seed.rotate_left(17) | 1;
        // The sum of four uniforms: near-normal, variance 1/3.
        let normal = ((0..4).map(|_| crate::rng::uniform(&mut state)).sum::<f64>() - 2.0) * 3f64.sqrt();
        let um = (self.worm.table_rad - self.gauge_zero_rad) * g.radius_mm * 1000.0 + normal * g.noise_um;
        Some((um / g.um_per_count).round().clamp(-32768.0, 32767.0) as i16)
    }

    fn inputs(&self) -> Inputs {
        let (x, y) = (self.x_mm(), self.y_mm());
        let (xl, yl) = (self.params.x_limits, self.params.y_limits);
        let limit = |a: Axis, e: End| self.limit == Some((a, e));
        let lube_ok = !self.no_lube_pressure
            && self
                .lube_on_since
                .is_some_and(|t0| self.t_s - t0 >= self.cfg.peripherals.lube_pressure_delay_s);
        Inputs {
            safety_chain_closed: self.chain_closed,
            estop_pressed: self.estop,
            x_limit_min: limit(Axis::X, End::Min) || x < xl.soft_min_mm - self.cfg.x.hardware_limit_margin_mm,
            x_limit_max: limit(Axis::X, End::Max) || x > xl.soft_max_mm + self.cfg.x.hardware_limit_margin_mm,
            y_limit_min: limit(Axis::Y, End::Min) || y < yl.soft_min_mm - self.cfg.y.hardware_limit_margin_mm,
            y_limit_max: limit(Axis::Y, End::Max) || y > yl.soft_max_mm + self.cfg.y.hardware_limit_margin_mm,
            vfd_fault: self.spindle.vfd_fault,
            vfd_ready: !self.spindle.vfd_fault,
            lube_pressure_ok: lube_ok,
            coolant_running: self.outputs.coolant_pump,
            x_clamp_closed: self.clamp_closed,
            reset_button: false,
            cycle_start_button: false,
            cycle_stop_button: false,
            feed_hold_button: false,
        }
    }

    /// Advances the physics to `t_s` in inner steps.
    pub fn advance_to(&mut self, t_s: f64) {
        while self.t_s < t_s - 1e-12 {
            let dt = self.inner_s.min(t_s - self.t_s);
            self.advance(dt);
        }
    }

    fn advance(&mut self, dt: f64) {
        let t = self.t_s;
        // The safety relay: opens on e-stop, hardware limits, the VFD fault relay and the
        // PC fault relay; the operator resets it once every cause is gone.
        let i = self.inputs();
        let cause = self.estop
            || self.chain_open_injected
            || i.x_limit_min
            || i.x_limit_max
            || i.y_limit_min
            || i.y_limit_max
            || self.spindle.vfd_fault
            || !self.outputs.pc_ok_relay;
        if cause {
            self.chain_cause_gone_at = None;
        } else if self.chain_cause_gone_at.is_none() {
            self.chain_cause_gone_at = Some(t);
        }
        if self.chain_closed && cause {
            self.chain_closed = false;
            self.chain_changed_at = t;
        } else if !self.chain_closed
            && self
                .chain_cause_gone_at
                .is_some_and(|t0| t - t0 >= SECONDS_FOR_OPERATOR_RESET)
        {
            self.chain_closed = true;
            self.chain_changed_at = t;
        }
        let powered = self.drives_powered();
        for (i, s) in [&mut self.table, &mut self.x, &mut self.y]
            .into_iter()
            .enumerate()
        {
            s.enabled_power = powered;
            s.enabled = self.drive_enable[i] && powered;
        }
        // Lube pump and pressure switch.
        match (self.outputs.lube_pump, self.lube_on_since) {
            (true, None) => self.lube_on_since = Some(t),
            (false, Some(_)) => self.lube_on_since = None,
            _ => {}
        }
        // X clamp.
        if self.outputs.x_clamp != self.clamp_closed {
            if t - self.clamp_changed_at >= self.cfg.x.clamp_delay_s {
                self.clamp_closed = self.outputs.x_clamp;
                self.clamp_changed_at = t;
            }
        } else {
            self.clamp_changed_at = t;
        }
        self.x.locked = self.clamp_closed;
        // Spindle: the VFD runs when commanded and powered.
        let run = if self.outputs.spindle_run_forward {
            1.0
        } else if self.outputs.spindle_run_reverse {
            -1.0
        } else {
            0.0
        };
        let set_hz = if powered {
            run * self.analog_v * self.hz_per_volt
        } else {
            0.0
        };
        // Cutting force follows the chip with the first-order lag of seed 003.
        let share = self.cut_share();
        self.spindle.load_share += (share - self.spindle.load_share) * (dt / CUT_FORCE_LAG_S).min(1.0);
        self.spindle.advance(set_hz, dt);
        // The cut's tangential force on the gear, resisting the table's motion.
        let mut resisting = 0.0;
        self.y.process_load_nm = 0.0;
        if let Some(w) = self.workpiece {
            let force_n = self.spindle.cutting_torque_nm / (w.tool_diameter_mm / 2000.0);
            // Along the gear's axis: a positive spindle moves the teeth up at the cut
            // (hob_gearing::signs), pushing the work up and the hob, on the Y slide, down.
            let on_hob_up_n = -self.cfg.y.cut_force_share * force_n;
            self.y.process_load_nm = -on_hob_up_n * 0.001 / self.y_rad_per_mm;
            let torque = self.cfg.table.cut_force_share * force_n * w.pitch_radius_mm / 1000.0;
            // Resists the table's turning: on the drive through the worm, and on the work
            // link, which deflects back against the turning.
            resisting = torque * (self.table.motor_rad_s / 1.0).tanh();
            self.work.advance(-resisting, dt);
        }
        // The table's bearings resist its turning too; the worm carries both to the motor
        // (rigidly reflected there), and the table body hangs on the mesh.
        if self.cutter.is_some() {
            // The flank engaged: the depth, as much of it as has entered the face.
            let depth = match self.workpiece {
                Some(w) => (w.x_surface_mm - self.x_mm()).max(0.0) * self.entered_share(),
                None => 0.0,
            };
            let feed_mm_s = self.y.motor_rad_s / self.y_rad_per_mm;
            let rev_s = self.spindle.speed_rad_s / std::f64::consts::TAU;
            if let Some(c) = self.cutter.as_mut() {
                c.advance(dt, depth, feed_mm_s, rev_s);
            }
        }
        let drag = self.cfg.table.bearing_friction_nm * (self.worm.table_rad_s / 0.01).tanh();
        let load_at_table_nm = resisting + drag;
        // Both sides of the mesh at the start of the step (the worm as the motor stands
        // before its own step): a relative angle taken across different instants would
        // swing with the step's length.
        self.worm.advance(
            self.table.motor_rad / self.worm_ratio,
            self.table.motor_rad_s / self.worm_ratio,
            load_at_table_nm,
            dt,
        );
        self.table.disturbance_nm = match self.cfg.table.coupling {
            // The load reflected as if the table were rigid on the worm.
            WormCoupling::OneWay => load_at_table_nm / self.worm_ratio,
            // What the mesh transmits, from the same instant the table felt it: nothing
            // inside the play, the mesh's spring and damper on its flanks.
            WormCoupling::TwoWay => self.worm.transmitted_nm / self.worm_ratio,
        };
        self.table.advance(dt);
        self.x.advance(dt);
        self.y.advance(dt);
        self.t_s += dt;
    }

    /// Share of the full cutting load: the depth of the tool in the blank times how far
    /// the hob has entered the face (the engaged length grows from zero at the reach of
    /// the hob's tip circle to full with its centre at the face).
    fn cut_share(&self) -> f64 {
        let Some(w) = self.workpiece else { return 0.0 };
        let depth = w.x_surface_mm - self.x_mm();
        (depth / self.cfg.spindle.full_depth_mm).min(1.0) * self.entered_share()
    }

    /// How far the tool has entered the face: from zero at the reach of its tip circle to
    /// one with its centre at the face (0 out of the blank).
    fn entered_share(&self) -> f64 {
        let Some(w) = self.workpiece else { return 0.0 };
        let depth = w.x_surface_mm - self.x_mm();
        if depth <= 0.0 {
            return 0.0;
        }
        let d = w.tool_diameter_mm;
        let h = depth.min(d / 2.0);
        let reach = (h * (d - h)).sqrt();
        let y = self.y_mm();
        let outside = (w.face_bottom_mm - y).max(y - w.face_top_mm).max(0.0);
        if reach > 0.0 {
            (1.0 - outside / reach).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// Whether the tool is in the work (cutting load on the spindle).
    pub fn cutting(&self) -> bool {
        self.cut_share() > 0.0
    }

    /// Motor radians of the table per table degree (for diagnostics).
    pub fn table_motor_rad_per_deg(&self) -> f64 {
        self.table_motor_rad_per_deg
    }
}
