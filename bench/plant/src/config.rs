//! The plant's parameters (`config/plant.toml`), validated like every configuration.

use hob_setup::config::{LoadError, Problems};
use hob_store::files::read_toml;
use serde::{Deserialize, Serialize};
use std::path::Path;

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct PlantConfig {
    pub simulation: SimulationConfig,
    pub drives: DrivesPlant,
    pub spindle: SpindlePlant,
    pub table: TablePlant,
    pub x: LinearPlant,
    pub y: LinearPlant,
    pub peripherals: PeripheralPlant,
}

/// How the servo drives (B, X, Y) close their loops: sampled on their own clock, on the
/// motor's own feedback, with the speed estimated from it (not the true speed).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct DrivesPlant {
    /// The position and velocity loops' sample period, us: a multiple of
    /// `simulation.inner_step_us` (the torque is held between samples).
    pub loop_us: u32,
    /// The motor feedback's resolution, bits per motor turn: what the drive's loops read.
    /// The position it reports (0x6064) is scaled to machine.toml's encoder counts.
    pub feedback_bits: u32,
    /// First-order low-pass on the speed estimate (the feedback's difference over a loop
    /// sample), Hz.
    pub velocity_filter_hz: f64,
    /// Hidden from the controller: the drives' true delay, us, from the SYNC that brings a
    /// target to where their interpolated reference reaches it (linear between the
    /// targets, extrapolated when shorter than a period). Absent: one control period, what
    /// the machine file's `control.drive_delay_us` says of the shipped drives. What a
    /// commissioning must find (issue 33): a controller told another delay predicts wrong.
    #[serde(default)]
    pub delay_us: Option<u32>,
}

impl DrivesPlant {
    pub fn feedback_counts_per_rad(&self) -> f64 {
        2f64.powi(self.feedback_bits as i32) / std::f64::consts::TAU
    }

    /// How much later than one control period of `period_s` the drives' reference reaches
    /// a target (`delay_us` less the period; 0 when absent), s.
    pub fn extra_delay_s(&self, period_s: f64) -> f64 {
        self.delay_us.map_or(0.0, |us| f64::from(us) * 1e-6 - period_s)
    }
}

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SimulationConfig {
    pub inner_step_us: u32,
    pub sync_jitter_us: f64,
    pub seed: u64,
    pub safety_stop_delay_s: f64,
    /// What the drives' position counters (0x6064) read at power-on (see [`DriveCounters`]).
    pub drive_counters: DriveCounters,
    /// With incremental counters: X and Y power up at a random position within this many
    /// mm of their home position instead of anywhere in their travel (referencing still
    /// runs, over a short way). For test runs whose clock is slow (the emulated guest);
    /// absent: anywhere in the travel.
    #[serde(default)]
    pub power_on_near_home_mm: Option<f64>,
    /// The SYNC's lateness as a measured distribution instead of the uniform
    /// `sync_jitter_us`: `[quantile, late_us]` pairs from 0 to 1 (a wake-up histogram of
    /// the loop, `hob-bench loop`, with its tail), drawn by inverse transform. The SYNC is
    /// only ever late (the loop wakes after its instant, never before). Empty: uniform.
    #[serde(default)]
    pub sync_late_quantiles_us: Vec<[f64; 2]>,
    /// The drives lock their cycle to the SYNC with a PLL that moves their clock's phase
    /// by at most this share of a period per SYNC (Kollmorgen AKD: 150 ns of each 62.5 us
    /// interrupt, 0.24 %). Absent: no PLL, each drive latches and restarts its interpolation
    /// when the SYNC arrives (see [`crate::sim::SyncTiming`]).
    #[serde(default)]
    pub drive_clock_slew_percent: Option<f64>,
    /// The share of each drive's position TPDOs (B's carries the spindle encoder) that
    /// miss their SYNC's exchange: the master has nothing new from that drive this cycle
    /// and the controller coasts on its last value. 0: none (the lockstep virtual machine
    /// on vcan: 0 of 72 077 cycles, `hob can check-capture`).
    #[serde(default)]
    pub tpdo_late_rate: f64,
    /// The share of the target RPDOs that reach their drive after the SYNC: the drive then
    /// keeps the target it has for that period (the object 0x607A still holds the last
    /// one; CiA 402 cyclic synchronous position defines no extrapolation) and takes the
    /// new one at the next SYNC.
    #[serde(default)]
    pub rpdo_late_rate: f64,
}

/// The loop's wake-up latency measured with `target/release/hob-bench loop --load hmi
/// --seconds 160 --block-s 5` on the 2-core development VM, 2026-11-24 (hob-rt while it cut
/// the demo job; docs/performance.md, "The touch HMI"): min 8.0, p50 15.0, p99 38.9,
/// p99.9 141.6, p99.99 407.3 us. Its maximum (45 ms, a hypervisor stall that skipped whole
/// periods) is left out: a stall longer than the period is a missed cycle, which the loop
/// handles as such, not a late SYNC. The last point carries the p99.99 value to 1.
pub const MEASURED_VM_SYNC_LATE_US: [[f64; 2]; 6] = [
    [0.0, 8.0],
    [0.5, 15.0],
    [0.99, 38.9],
    [0.999, 141.6],
    [0.9999, 407.3],
    [1.0, 407.3],
];

/// The value at quantile `u` (0..=1) of a `[quantile, value]` table, linear between points.
pub fn quantile_value(table: &[[f64; 2]], u: f64) -> f64 {
    let Some(first) = table.first() else {
        return 0.0;
    };
    if u <= first[0] {
        return first[1];
    }
    for w in table.windows(2) {
        let ([q0, v0], [q1, v1]) = (w[0], w[1]);
        if u <= q1 {
            return if q1 > q0 {
                v0 + (v1 - v0) * (u - q0) / (q1 - q0)
            } else {
                v1
            };
        }
    }
    table[table.len() - 1][1]
}

/// What the drives' position counters read at power-on. The encoders are incremental
/// (2500 lines, docs/domain.md section 2): a real drive's counter starts at an arbitrary
/// value, and only homing (CiA 402 mode 6) ties it to the machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum DriveCounters {
    /// The counters read the machine position in counts from power-on, as if the axes had
    /// been referenced before: what a controller that does not reference assumes.
    Referenced,
    /// Honest incremental encoders: every counter starts at 0 at power-on, wherever the
    /// axis stands; the bus simulator (`hob-sim`) also puts X and Y at a random position
    /// within their travel (drawn from `simulation.seed`). The controller must home X and Y.
    Incremental,
}

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SpindlePlant {
    pub motor_pole_pairs: u32,
    pub rated_torque_nm: f64,
    pub rated_slip_rpm: f64,
    pub breakdown_torque_nm: f64,
    pub inertia_at_spindle_kg_m2: f64,
    pub friction_at_spindle_nm: f64,
    pub cutting_torque_nm: f64,
    pub cutting_ripple: f64,
    pub full_depth_mm: f64,
    /// The spindle encoder's error, amplitude of a once-per-turn sine (the code disc's
    /// eccentricity), arcsec of the spindle: what the controller reads is off by it.
    pub encoder_error_arcsec: f64,
    /// Hidden: the encoder's error at twice and three times per turn, arcsec (the disc's
    /// graduation, its mounting), phases drawn from `simulation.seed`. Absent: 0.
    #[serde(default)]
    pub encoder_error_2_arcsec: f64,
    #[serde(default)]
    pub encoder_error_3_arcsec: f64,
    /// Hidden: a true once-per-turn torque on the spindle, Nm (an unbalance, an eccentric
    /// pulley): the spindle's speed truly varies once per turn, and its encoder reads that
    /// correctly. Absent: 0.
    #[serde(default)]
    pub once_per_turn_torque_nm: f64,
    /// The hob's axial runout on its arbor, amplitude of a once-per-turn sine, um: the
    /// generating rack moves along the hob axis, nearly the gear's tangent, so the blank
    /// is cut as if turned by it over the pitch radius. Nothing measures it.
    pub hob_axial_runout_um: f64,
}

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct TablePlant {
    pub motor_inertia_kg_m2: f64,
    pub table_inertia_kg_m2: f64,
    /// The table inertia the B drive's gains were tuned for (its autotune's estimate);
    /// absent: the true `table_inertia_kg_m2`.
    #[serde(default)]
    pub tuned_table_inertia_kg_m2: Option<f64>,
    pub work_link_t1_s: f64,
    pub work_link_t2_s: f64,
    pub work_link_stiffness_nm_rad: f64,
    pub peak_motor_torque_nm: f64,
    pub cut_force_share: f64,
    pub velocity_loop_hz: f64,
    pub position_loop_hz: f64,
    pub velocity_feed_forward: f64,
    pub friction_motor_nm: f64,
    /// Friction in the table's own bearings, Nm at the table: the load that keeps the
    /// worm's play on its driving flank while the table turns without a cut.
    pub bearing_friction_nm: f64,
    /// How the worm couples the B motor and the table (absent: `one-way`).
    #[serde(default)]
    pub coupling: WormCoupling,
    /// The worm shaft and its coupling to the motor, kg m2 at the motor: with a `two-way`
    /// coupling the motor carries them and the mesh, not the table (absent: 0).
    #[serde(default)]
    pub worm_inertia_kg_m2: f64,
    /// The worm drive between the motor and the table (`[table.worm]`).
    pub worm: WormPlant,
}

/// How the worm couples the B motor and the table ([`crate::worm`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum WormCoupling {
    /// The motor drives the table's inertia as if rigidly reflected through the worm; the
    /// table body hangs on the mesh behind it (the drive never feels the play or the mesh's
    /// mode): the simulated machine before issue 33, kept to compare.
    #[default]
    OneWay,
    /// The mesh's torque acts on both sides: the motor (with the worm) carries only its own
    /// inertia and the torque the mesh transmits, so the drive's loops see the play and the
    /// mesh's mode as a real drive does.
    TwoWay,
}

/// The table's worm drive ([`crate::worm`]): a single-start worm, the wheel with as many
/// teeth as `table.worm_ratio` of the machine file.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct WormPlant {
    /// The wheel's pitch diameter, mm (its module is this over its teeth).
    pub wheel_pitch_diameter_mm: f64,
    /// The wheel's accuracy as an ISO 1328-1 grade (1 ..= 11): its eccentricity has the
    /// range `F_p` and its teeth deviate by up to `f_pt` from their neighbours, the
    /// tolerances of that grade; 0: a perfect wheel.
    pub wheel_grade: u8,
    /// The worm's axial runout, um (once per worm revolution, at the wheel's pitch circle).
    pub worm_axial_runout_um: f64,
    /// The play between worm and wheel, arcsec of the table.
    pub backlash_arcsec: f64,
    /// The drive's torsional stiffness at the table (worm shaft, bearings, mesh), Nm/rad.
    pub stiffness_nm_rad: f64,
    /// The mesh's damping as a share of critical of its mode: with the table's inertia on
    /// it (one-way coupling), or the table's and the motor side's in series (two-way).
    pub damping_ratio: f64,
}

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct LinearPlant {
    pub motor_inertia_kg_m2: f64,
    pub moving_mass_kg: f64,
    /// Sliding (Coulomb) friction coefficient of the ways.
    pub friction_coefficient: f64,
    /// Breakaway over sliding friction at rest (stick-slip on the ways: Stribeck).
    pub static_friction_ratio: f64,
    /// The speed over which the friction falls from breakaway to sliding, mm/s.
    pub stribeck_speed_mm_s: f64,
    /// The share of the cut's force F_c that pushes the slide along its axis (Y: the
    /// hob's teeth move nearly along the gear's axis at the cut, so most of F_c does; X is
    /// clamped in the cut: 0). Its sense is the teeth's motion's opposite (the work is
    /// pushed along it, the hob back): against the feed in the project's climb hobbing,
    /// with it in conventional (`hob_gearing::signs`).
    #[serde(default)]
    pub cut_force_share: f64,
    pub peak_motor_torque_nm: f64,
    pub velocity_loop_hz: f64,
    pub position_loop_hz: f64,
    pub velocity_feed_forward: f64,
    pub hardware_limit_margin_mm: f64,
    pub clamp_delay_s: f64,
    /// The home switch's edge (axis position, mm): the switch is active beyond it on
    /// `home_switch_active_side`. Homing methods 3 and 4 expect it active on the positive
    /// side, 5 and 6 on the negative side.
    pub home_switch_edge_mm: f64,
    pub home_switch_active_side: Side,
    /// The motor encoder's index pulse, once per motor revolution (every screw lead /
    /// motor_to_screw_ratio mm): at this axis position and every revolution from it.
    pub index_pulse_at_mm: f64,
    /// The drive gives up homing after this long (homing error, statusword bit 13).
    pub homing_timeout_s: f64,
}

/// A side of a point on an axis, in the axis's positive direction (the machine frame).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Side {
    Positive,
    Negative,
}

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct PeripheralPlant {
    pub lube_pressure_delay_s: f64,
    /// A displacement gauge touching the table's rim, wired to one of the I/O coupler's
    /// analog inputs: what the machine builder mounts for `hob commission backlash`. The
    /// coupler serves it only when the machine file names that input.
    #[serde(default)]
    pub table_gauge: Option<TableGaugePlant>,
}

/// The table gauge: it reads the table's true angle as a displacement at its radius,
/// quantised by the coupler's 16-bit input, with a little noise; it reads 0 where the table
/// stood at power-on, and saturates at the input's ends (the gauge's stroke).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct TableGaugePlant {
    /// The coupler's analog input (0-based).
    pub channel: u8,
    /// Where the gauge touches the table, mm from its axis.
    pub radius_mm: f64,
    /// The displacement of one count of the coupler's input, um.
    pub um_per_count: f64,
    /// The reading's noise, um RMS.
    pub noise_um: f64,
}

impl PlantConfig {
    pub fn load(file: &Path) -> Result<Self, LoadError> {
        let (config, src): (Self, String) = read_toml(file)?;
        let mut p = Problems::new();
        config.validate(&mut p);
        p.into_result(file, &src)?;
        Ok(config)
    }

    pub fn validate(&self, p: &mut Problems) {
        let s = &self.simulation;
        p.require(
            (10..=1000).contains(&s.inner_step_us),
            "simulation.inner_step_us",
            || {
                format!(
                    "must be within 10 .. 1000 us (at least 1 kHz physics) (is {})",
                    s.inner_step_us
                )
            },
        );
        p.within("simulation.sync_jitter_us", s.sync_jitter_us, 0.0, 200.0, "us");
        p.non_negative("simulation.safety_stop_delay_s", s.safety_stop_delay_s);
        for (key, rate) in [
            ("simulation.tpdo_late_rate", s.tpdo_late_rate),
            ("simulation.rpdo_late_rate", s.rpdo_late_rate),
        ] {
            p.require((0.0..=0.1).contains(&rate), key, || {
                format!("must be a share of the frames from 0 to 0.1, more is a broken bus (is {rate})")
            });
        }
        if let Some(pc) = s.drive_clock_slew_percent {
            p.require(pc.is_finite() && pc > 0.0 && pc <= 5.0, "simulation.drive_clock_slew_percent", || {
                format!("{pc}: must be above 0 and at most 5 % of a period (leave it out for drives without a SYNC PLL)")
            });
        }
        if let Some(mm) = s.power_on_near_home_mm {
            p.positive("simulation.power_on_near_home_mm", mm);
        }
        let d = &self.drives;
        p.require(
            d.loop_us >= s.inner_step_us
                && s.inner_step_us > 0
                && d.loop_us.is_multiple_of(s.inner_step_us)
                && d.loop_us <= 1000,
            "drives.loop_us",
            || {
                format!(
                    "{}: must be a multiple of simulation.inner_step_us ({}) up to 1000 us",
                    d.loop_us, s.inner_step_us
                )
            },
        );
        if let Some(us) = d.delay_us {
            p.require((200..=5000).contains(&us), "drives.delay_us", || {
                format!("{us}: must be 200 to 5000 us (leave it out for one control period)")
            });
        }
        p.require(
            (12..=32).contains(&d.feedback_bits),
            "drives.feedback_bits",
            || format!("{}: must be 12 to 32 bits per turn", d.feedback_bits),
        );
        p.within(
            "drives.velocity_filter_hz",
            d.velocity_filter_hz,
            10.0,
            20_000.0,
            "Hz",
        );
        let q = &s.sync_late_quantiles_us;
        if !q.is_empty() {
            let ends = q.first().map(|x| x[0]) == Some(0.0) && q.last().map(|x| x[0]) == Some(1.0);
            let rising = q.windows(2).all(|w| w[1][0] > w[0][0] && w[1][1] >= w[0][1]);
            let in_range = q
                .iter()
                .all(|x| x.iter().all(|v| v.is_finite()) && (0.0..=500.0).contains(&x[1]));
            p.require(ends && rising && in_range, "simulation.sync_late_quantiles_us", || {
                "must be [quantile, late_us] pairs from quantile 0 to 1, quantiles rising, lateness not falling, within 0 .. 500 us".into()
            });
        }
        for (axis, l) in [("x", &self.x), ("y", &self.y)] {
            p.within(
                &format!("{axis}.static_friction_ratio"),
                l.static_friction_ratio,
                1.0,
                3.0,
                "",
            );
            p.within(
                &format!("{axis}.stribeck_speed_mm_s"),
                l.stribeck_speed_mm_s,
                0.001,
                100.0,
                "mm/s",
            );
            p.within(
                &format!("{axis}.cut_force_share"),
                l.cut_force_share,
                0.0,
                1.0,
                "",
            );
        }
        let sp = &self.spindle;
        for (k, v) in [
            ("spindle.encoder_error_arcsec", sp.encoder_error_arcsec),
            ("spindle.encoder_error_2_arcsec", sp.encoder_error_2_arcsec),
            ("spindle.encoder_error_3_arcsec", sp.encoder_error_3_arcsec),
        ] {
            p.within(k, v, 0.0, 600.0, "arcsec");
        }
        p.within(
            "spindle.once_per_turn_torque_nm",
            sp.once_per_turn_torque_nm,
            0.0,
            50.0,
            "Nm",
        );
        p.within(
            "spindle.hob_axial_runout_um",
            sp.hob_axial_runout_um,
            0.0,
            50.0,
            "um",
        );
        p.require(sp.motor_pole_pairs >= 1, "spindle.motor_pole_pairs", || {
            "must be at least 1".into()
        });
        for (k, v) in [
            ("spindle.rated_torque_nm", sp.rated_torque_nm),
            ("spindle.rated_slip_rpm", sp.rated_slip_rpm),
            ("spindle.breakdown_torque_nm", sp.breakdown_torque_nm),
            ("spindle.inertia_at_spindle_kg_m2", sp.inertia_at_spindle_kg_m2),
            ("spindle.full_depth_mm", sp.full_depth_mm),
        ] {
            p.positive(k, v);
        }
        p.non_negative("spindle.friction_at_spindle_nm", sp.friction_at_spindle_nm);
        p.non_negative("spindle.cutting_torque_nm", sp.cutting_torque_nm);
        p.within("spindle.cutting_ripple", sp.cutting_ripple, 0.0, 1.0, "");
        let t = &self.table;
        for (k, v) in [
            ("table.motor_inertia_kg_m2", t.motor_inertia_kg_m2),
            ("table.table_inertia_kg_m2", t.table_inertia_kg_m2),
            ("table.work_link_t1_s", t.work_link_t1_s),
            ("table.work_link_stiffness_nm_rad", t.work_link_stiffness_nm_rad),
            ("table.peak_motor_torque_nm", t.peak_motor_torque_nm),
            ("table.velocity_loop_hz", t.velocity_loop_hz),
            ("table.position_loop_hz", t.position_loop_hz),
        ] {
            p.positive(k, v);
        }
        p.non_negative("table.work_link_t2_s", t.work_link_t2_s);
        p.within("table.cut_force_share", t.cut_force_share, 0.0, 1.0, "");
        p.within(
            "table.velocity_feed_forward",
            t.velocity_feed_forward,
            0.0,
            1.0,
            "",
        );
        p.non_negative("table.friction_motor_nm", t.friction_motor_nm);
        p.non_negative("table.bearing_friction_nm", t.bearing_friction_nm);
        p.non_negative("table.worm_inertia_kg_m2", t.worm_inertia_kg_m2);
        if let Some(j) = t.tuned_table_inertia_kg_m2 {
            p.positive("table.tuned_table_inertia_kg_m2", j);
        }
        let w = &t.worm;
        p.positive("table.worm.wheel_pitch_diameter_mm", w.wheel_pitch_diameter_mm);
        p.require(w.wheel_grade <= 11, "table.worm.wheel_grade", || {
            format!(
                "must be an ISO 1328-1 grade 1 ..= 11, or 0 for a perfect wheel (is {})",
                w.wheel_grade
            )
        });
        p.within(
            "table.worm.worm_axial_runout_um",
            w.worm_axial_runout_um,
            0.0,
            100.0,
            "um",
        );
        p.within(
            "table.worm.backlash_arcsec",
            w.backlash_arcsec,
            0.0,
            600.0,
            "arcsec",
        );
        p.positive("table.worm.stiffness_nm_rad", w.stiffness_nm_rad);
        p.within("table.worm.damping_ratio", w.damping_ratio, 0.001, 1.0, "");
        // The table on the mesh rings at sqrt(k / J); the physics step must resolve it
        // (semi-implicit Euler: a tenth of a period per step at least, with margin).
        let ring_rad_s = (w.stiffness_nm_rad / t.table_inertia_kg_m2).sqrt();
        let step_s = f64::from(s.inner_step_us) * 1e-6;
        if t.table_inertia_kg_m2 > 0.0 && ring_rad_s * step_s > 0.5 {
            p.require(false, "table.worm.stiffness_nm_rad", || {
                format!(
                    "rings the table at {:.0} Hz, too fast for simulation.inner_step_us {} (at most {:.0} Nm/rad at this step)",
                    ring_rad_s / std::f64::consts::TAU,
                    s.inner_step_us,
                    (0.5 / step_s).powi(2) * t.table_inertia_kg_m2
                )
            });
        }
        for (axis, a) in [("x", &self.x), ("y", &self.y)] {
            let k = |n: &str| format!("{axis}.{n}");
            for (n, v) in [
                ("motor_inertia_kg_m2", a.motor_inertia_kg_m2),
                ("moving_mass_kg", a.moving_mass_kg),
                ("peak_motor_torque_nm", a.peak_motor_torque_nm),
                ("velocity_loop_hz", a.velocity_loop_hz),
                ("position_loop_hz", a.position_loop_hz),
                ("hardware_limit_margin_mm", a.hardware_limit_margin_mm),
            ] {
                p.positive(&k(n), v);
            }
            p.within(&k("friction_coefficient"), a.friction_coefficient, 0.0, 1.0, "");
            p.within(&k("velocity_feed_forward"), a.velocity_feed_forward, 0.0, 1.0, "");
            p.non_negative(&k("clamp_delay_s"), a.clamp_delay_s);
            p.positive(&k("homing_timeout_s"), a.homing_timeout_s);
            p.require(
                a.home_switch_edge_mm.is_finite(),
                &k("home_switch_edge_mm"),
                || "must be a number".into(),
            );
            p.require(a.index_pulse_at_mm.is_finite(), &k("index_pulse_at_mm"), || {
                "must be a number".into()
            });
        }
        p.non_negative(
            "peripherals.lube_pressure_delay_s",
            self.peripherals.lube_pressure_delay_s,
        );
        if let Some(g) = &self.peripherals.table_gauge {
            let k = |f: &str| format!("peripherals.table_gauge.{f}");
            p.require(g.channel < 8, &k("channel"), || {
                format!("must be 0 .. 7 (is {})", g.channel)
            });
            p.within(&k("radius_mm"), g.radius_mm, 10.0, 2000.0, "mm");
            p.within(&k("um_per_count"), g.um_per_count, 0.001, 10.0, "um");
            p.within(&k("noise_um"), g.noise_um, 0.0, 10.0, "um");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shipped() -> (PlantConfig, String) {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/plant.toml");
        let src = std::fs::read_to_string(&path).unwrap();
        (toml::from_str(&src).unwrap(), src)
    }

    #[test]
    fn a_pll_slew_out_of_range_is_refused_by_its_key() {
        let (mut c, _) = shipped();
        assert_eq!(c.simulation.drive_clock_slew_percent, Some(0.24));
        for bad in [0.0, -0.1, 6.0, f64::NAN] {
            c.simulation.drive_clock_slew_percent = Some(bad);
            let mut p = Problems::new();
            c.validate(&mut p);
            assert!(
                format!("{p:?}").contains("simulation.drive_clock_slew_percent"),
                "{bad}"
            );
        }
        c.simulation.drive_clock_slew_percent = None;
        let mut p = Problems::new();
        c.validate(&mut p);
        assert!(p.is_empty(), "{p:?}");
    }

    #[test]
    fn a_worm_the_physics_cannot_resolve_or_out_of_range_is_refused_by_its_key() {
        let (shipped, _) = shipped();
        let refused = |edit: &dyn Fn(&mut PlantConfig), key: &str| {
            let mut c = shipped.clone();
            edit(&mut c);
            let mut p = Problems::new();
            c.validate(&mut p);
            let text = format!("{p:?}");
            assert!(text.contains(key), "{key}: {text}");
        };
        // 20 kg m2 at 100 us: at most (0.5 / 1e-4)^2 * 20 = 5e8 Nm/rad.
        refused(
            &|c| c.table.worm.stiffness_nm_rad = 6e8,
            "table.worm.stiffness_nm_rad",
        );
        refused(
            &|c| c.table.worm.stiffness_nm_rad = 0.0,
            "table.worm.stiffness_nm_rad",
        );
        refused(&|c| c.table.worm.wheel_grade = 12, "table.worm.wheel_grade");
        refused(
            &|c| c.table.worm.backlash_arcsec = -1.0,
            "table.worm.backlash_arcsec",
        );
        refused(&|c| c.table.worm.damping_ratio = 0.0, "table.worm.damping_ratio");
        refused(
            &|c| c.table.worm.worm_axial_runout_um = f64::NAN,
            "table.worm.worm_axial_runout_um",
        );
        refused(
            &|c| c.table.bearing_friction_nm = -5.0,
            "table.bearing_friction_nm",
        );
        let mut ok = shipped.clone();
        ok.table.worm.stiffness_nm_rad = 4.9e8;
        let mut p = Problems::new();
        ok.validate(&mut p);
        assert!(p.is_empty(), "{p:?}");
    }

    #[test]
    fn a_quantile_table_is_read_linearly_between_its_points() {
        let t = MEASURED_VM_SYNC_LATE_US;
        assert_eq!(quantile_value(&t, 0.0), 8.0);
        assert_eq!(quantile_value(&t, 0.25), 11.5);
        assert_eq!(quantile_value(&t, 0.5), 15.0);
        // Between p99.9 and p99.99: 5/9 of the way.
        let want = 141.6 + (0.9995 - 0.999) / (0.9999 - 0.999) * (407.3 - 141.6);
        assert!((quantile_value(&t, 0.9995) - want).abs() < 1e-9);
        assert_eq!(quantile_value(&t, 1.0), 407.3);
        assert_eq!(quantile_value(&[], 0.3), 0.0);
    }

    #[test]
    fn the_measured_table_is_valid_and_a_broken_one_is_refused_by_its_key() {
        let (mut c, _) = shipped();
        c.simulation.sync_late_quantiles_us = MEASURED_VM_SYNC_LATE_US.to_vec();
        let mut p = Problems::new();
        c.validate(&mut p);
        assert!(p.is_empty(), "{p:?}");
        for bad in [
            vec![[0.0, 8.0], [0.5, 15.0]],                           // does not reach 1
            vec![[0.1, 8.0], [1.0, 15.0]],                           // does not start at 0
            vec![[0.0, 15.0], [0.5, 8.0], [1.0, 20.0]],              // lateness falls
            vec![[0.0, 8.0], [0.5, 15.0], [0.5, 20.0], [1.0, 30.0]], // quantile repeats
            vec![[0.0, -1.0], [1.0, 15.0]],                          // early
            vec![[0.0, 8.0], [1.0, 900.0]],                          // past half a period
            vec![[0.0, 8.0], [1.0, f64::NAN]],
        ] {
            c.simulation.sync_late_quantiles_us = bad.clone();
            let mut p = Problems::new();
            c.validate(&mut p);
            let text = format!("{p:?}");
            assert!(
                text.contains("simulation.sync_late_quantiles_us"),
                "{bad:?}: {text}"
            );
        }
    }
}
