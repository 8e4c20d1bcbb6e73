//! The hob spindle: a VFD with a frequency ramp feeding an induction motor (slip: the
//! speed sags with load), through i = 6 to the spindle, with a cutting torque that
//! fluctuates at the hob's gash frequency.

use crate::config::SpindlePlant;
use std::f64::consts::TAU;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spindle {
    p: SpindleLaw,
    /// Spindle angle and speed (rad, rad/s).
    pub angle_rad: f64,
    pub speed_rad_s: f64,
    /// VFD output frequency, signed (Hz).
    pub vfd_hz: f64,
    /// Cutting load share 0..1 set by the machine model.
    pub load_share: f64,
    /// Cutting torque at the spindle this instant (Nm), for the table's disturbance.
    pub cutting_torque_nm: f64,
    pub vfd_fault: bool,
}

/// Derived constants.
#[derive(Debug, Clone, Copy, PartialEq)]
struct SpindleLaw {
    pole_pairs: f64,
    ratio: f64,
    slip_gain_nm_per_rad_s: f64,
    breakdown_nm: f64,
    inertia: f64,
    friction: f64,
    cutting_nm: f64,
    ripple: f64,
    gashes: f64,
    ramp_hz_per_s: f64,
    /// A true once-per-turn torque, Nm, and its phase, rad.
    turn_nm: f64,
    turn_phase_rad: f64,
}

impl Spindle {
    /// `ratio`: motor turns per spindle turn; `ramp_hz_per_s`: VFD ramp; `gashes` of the hob;
    /// `turn_phase_rad`: the phase of the true once-per-turn torque.
    pub fn new(p: &SpindlePlant, ratio: f64, ramp_hz_per_s: f64, gashes: u32, turn_phase_rad: f64) -> Self {
        Self {
            p: SpindleLaw {
                pole_pairs: f64::from(p.motor_pole_pairs),
                ratio,
                slip_gain_nm_per_rad_s: p.rated_torque_nm / (p.rated_slip_rpm * TAU / 60.0),
                breakdown_nm: p.breakdown_torque_nm,
                inertia: p.inertia_at_spindle_kg_m2,
                friction: p.friction_at_spindle_nm,
                cutting_nm: p.cutting_torque_nm,
                ripple: p.cutting_ripple,
                gashes: f64::from(gashes),
                ramp_hz_per_s,
                turn_nm: p.once_per_turn_torque_nm,
                turn_phase_rad,
            },
            angle_rad: 0.0,
            speed_rad_s: 0.0,
            vfd_hz: 0.0,
            load_share: 0.0,
            cutting_torque_nm: 0.0,
            vfd_fault: false,
        }
    }

    /// Advances by `dt_s` with the VFD set to `set_hz` (signed; 0 = stop).
    pub fn advance(&mut self, set_hz: f64, dt_s: f64) {
        let p = self.p;
        let set_hz = if self.vfd_fault { 0.0 } else { set_hz };
        let step = p.ramp_hz_per_s * dt_s;
        self.vfd_hz += (set_hz - self.vfd_hz).clamp(-step, step);
        let motor_rad_s = self.speed_rad_s * p.ratio;
        let sync_rad_s = TAU * self.vfd_hz / p.pole_pairs;
        // A tripped VFD coasts: no motor torque.
        let motor_nm = if self.vfd_fault {
            0.0
        } else {
            (p.slip_gain_nm_per_rad_s * (sync_rad_s - motor_rad_s)).clamp(-p.breakdown_nm, p.breakdown_nm)
        };
        let ripple = 1.0 + p.ripple * (p.gashes * self.angle_rad).sin();
        self.cutting_torque_nm = p.cutting_nm * self.load_share * ripple * (self.speed_rad_s / 0.05).tanh();
        let friction = p.friction * (self.speed_rad_s / 0.05).tanh();
        let turn = p.turn_nm * (self.angle_rad + p.turn_phase_rad).sin();
        let acc = (motor_nm * p.ratio - friction - self.cutting_torque_nm + turn) / p.inertia;
        self.speed_rad_s += acc * dt_s;
        self.angle_rad += self.speed_rad_s * dt_s;
    }
}
