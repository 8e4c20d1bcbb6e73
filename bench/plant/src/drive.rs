//! What a CiA 402 drive does around its servo axis, beyond the position loop of
//! [`crate::servo`]: its position counter from an incremental encoder, its modes of
//! operation (cyclic synchronous position 8, homing 6), homing with a home switch and the
//! motor encoder's index pulse (methods 3 to 6), and the fault when its axis runs into a
//! hardware limit. Shared by the in-process simulation ([`crate::plant::Plant::apply`],
//! [`crate::plant::Plant::latch`]) and the drives of the virtual machine on the bus
//! (`hob-virtual-machine`), which add the power state machine and the object dictionary.
//!
//! Positions here are the motor encoder's *physical* counts (the servo's), fixed to the
//! machine; the drive's counter (0x6064) is the physical count plus an offset that
//! power-on and homing set.
//!
//! Home offset (0x607C): at the home position the counter reads the home offset, so
//! `0x6064 = 0x607C` there (the reading of many drives and of `config/machine.toml`'s
//! `home_position_mm`). CiA 402-2's figure states it the other way round (the zero
//! position lies at home position + home offset, so the home position would read
//! -0x607C); a drive of that reading needs the offset negated.
//!
//! Homing methods 3 to 6 (CiA 402-2, homing on the home switch and the index pulse): the
//! home switch is active on one side of its edge (3 and 4: the positive side, 5 and 6: the
//! negative side, as the method *assumes*; the plant's switch is where the machine has it,
//! `home_switch_active_side`). The home position is the first index pulse beyond the edge
//! on the switch's inactive side (3, 5) or its active side (4, 6). The first move depends
//! on the switch's state at the start: from the side opposite the home position the
//! drive moves towards the edge at the switch search speed (0x6099:1) and, once the switch
//! changes state, on at the zero search speed (0x6099:2) to the next index pulse; from
//! the home side it moves away towards the edge at the switch search speed, stops once
//! the switch changes state, reverses and crosses the edge again at the zero search speed,
//! then takes the next index pulse. Acceleration and deceleration are 0x609A. The index
//! pulse is latched in hardware (its exact position); at it the counter is set so that it
//! reads the home offset, and the drive then stops and positions back onto it (within
//! [`HOME_WINDOW_COUNTS`]) before it reports homing completed.

use crate::servo::Servo;
use hob_control::HomingBits;

/// Mode of operation: homing (0x6060 = 6).
pub const MODE_HOMING: i8 = 6;
/// Mode of operation: cyclic synchronous position (0x6060 = 8).
pub const MODE_CSP: i8 = 8;
/// Homing methods implemented (home switch and index pulse).
pub const HOMING_METHODS: [i8; 4] = [3, 4, 5, 6];
/// Homing is completed once the axis stands this close to the home position (counts).
pub const HOME_WINDOW_COUNTS: f64 = 2.0;
/// EMCY error code of a drive that ran into a hardware limit: CiA 402's "reference limit"
/// (0x8612, in the positioning controller's group 0x86xx next to the following error
/// 0x8611): the position left the range the drive may travel.
pub const EMCY_HARDWARE_LIMIT: u16 = 0x8612;
/// Below this speed (counts/s) an axis beyond a hardware limit counts as standing, not
/// as running into it (a drive may be reset there and moved back).
const LIMIT_SPEED_COUNTS_S: f64 = 50.0;

/// The homing parameters (0x6098, 0x607C, 0x6099:1/2, 0x609A), in the drive's counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct HomingParams {
    pub method: i8,
    pub home_offset_counts: i32,
    pub switch_speed_counts_s: u32,
    pub zero_speed_counts_s: u32,
    pub accel_counts_s2: u32,
}

/// Where the machine has the home switch and the index pulses, in physical motor counts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HomeGeometry {
    pub switch_edge_counts: f64,
    /// The switch is active on the positive side (in motor counts) of its edge.
    pub switch_active_positive: bool,
    /// One index pulse per motor revolution: at `index_phase_counts + k * index_pitch_counts`.
    pub index_pitch_counts: i64,
    pub index_phase_counts: i64,
    pub timeout_s: f64,
}

impl HomeGeometry {
    /// The home switch's state with the motor at `counts`.
    pub fn switch_active(&self, counts: f64) -> bool {
        if self.switch_active_positive {
            counts > self.switch_edge_counts
        } else {
            counts < self.switch_edge_counts
        }
    }

    /// The first index pulse strictly beyond `counts` in direction `dir` (+1 or -1).
    pub fn next_index(&self, counts: f64, dir: f64) -> f64 {
        let pitch = self.index_pitch_counts as f64;
        let phase = self.index_phase_counts as f64;
        let k = (counts - phase) / pitch;
        let k = if dir > 0.0 {
            k.floor() + 1.0
        } else {
            k.ceil() - 1.0
        };
        phase + k * pitch
    }
}

/// What a drive takes at SYNC (from the controlword, 0x6060 and 0x607A).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DriveCommand {
    /// 0x607A in the drive's counts (wrapping); ignored outside cyclic synchronous position.
    pub target_counts: i32,
    /// The power state is "operation enabled".
    pub enable: bool,
    /// The mode asked for (0x6060); a mode the drive does not implement is ignored.
    pub mode: i8,
    /// Controlword bit 4: its rising edge starts homing in homing mode.
    pub homing_start: bool,
    /// Controlword bit 8: halt.
    pub halt: bool,
}

/// A trapezoidal motion generator (physical counts, counts/s).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Profile {
    pos: f64,
    vel: f64,
}

impl Profile {
    /// Towards `v_target` at `accel`.
    fn run(&mut self, v_target: f64, accel: f64, dt: f64) {
        let dv = accel * dt;
        self.vel += (v_target - self.vel).clamp(-dv, dv);
        self.pos += self.vel * dt;
    }

    /// Towards `target` at up to `v_max`, stopping there; true once there.
    fn position(&mut self, target: f64, v_max: f64, accel: f64, dt: f64) -> bool {
        let d = target - self.pos;
        let dv = accel * dt;
        let v_des = d.signum() * v_max.min((2.0 * accel * d.abs()).sqrt());
        self.vel += (v_des - self.vel).clamp(-dv, dv);
        let step = self.vel * dt;
        if (step * d > 0.0 && step.abs() >= d.abs()) || (d.abs() < 0.5 && self.vel.abs() <= dv) {
            self.pos = target;
            self.vel = 0.0;
            return true;
        }
        self.pos += step;
        false
    }
}

/// Where homing is.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Homing {
    Idle,
    /// Towards the edge at the switch search speed, until the switch changes state.
    Seek {
        dir: f64,
        active_at_start: bool,
    },
    /// Stopping after the edge was crossed away from the home side.
    Reverse,
    /// Back across the edge at the zero search speed.
    Approach {
        active_at_start: bool,
    },
    /// On at the zero search speed to the index pulse at `at`.
    Index {
        at: f64,
    },
    /// Positioning onto the home position `at`.
    Return {
        at: f64,
    },
    /// Stopping (halt, error, interruption); then `then` is reported.
    Stop {
        then: HomingBits,
    },
}

const NOT_STARTED: HomingBits = HomingBits {
    attained: false,
    error: false,
    target_reached: true,
};
const IN_PROGRESS: HomingBits = HomingBits {
    attained: false,
    error: false,
    target_reached: false,
};

/// One drive.
#[derive(Debug, Clone, PartialEq)]
pub struct Drive {
    supported_modes: &'static [i8],
    mode: i8,
    /// The counter (0x6064) = physical counts + this.
    counter_offset: i64,
    geometry: Option<HomeGeometry>,
    /// Hardware limit positions (physical counts, low and high).
    limits_counts: Option<(f64, f64)>,
    pub homing: HomingParams,
    state: Homing,
    progress: HomingBits,
    start_before: bool,
    profile: Profile,
    elapsed_s: f64,
    fault: Option<u16>,
    /// The power stage drives the motor (operation enabled in a mode with motion).
    active: bool,
}

impl Drive {
    /// A drive without homing or hardware limits (the table's): cyclic synchronous
    /// position only, its counter reading `counter_at_power_on` at `physical_counts`.
    pub fn without_homing(physical_counts: i64, counter_at_power_on: i64) -> Self {
        Self::new(
            physical_counts,
            counter_at_power_on,
            None,
            None,
            HomingParams::default(),
        )
    }

    /// A drive whose counter reads `counter_at_power_on` with the motor at
    /// `physical_counts`. `geometry` `None`: no homing (cyclic synchronous position only).
    pub fn new(
        physical_counts: i64,
        counter_at_power_on: i64,
        geometry: Option<HomeGeometry>,
        limits_counts: Option<(f64, f64)>,
        homing: HomingParams,
    ) -> Self {
        Self {
            supported_modes: if geometry.is_some() {
                &[MODE_HOMING, MODE_CSP]
            } else {
                &[MODE_CSP]
            },
            mode: 0,
            counter_offset: counter_at_power_on - physical_counts,
            geometry,
            limits_counts,
            homing,
            state: Homing::Idle,
            progress: NOT_STARTED,
            start_before: false,
            profile: Profile {
                pos: physical_counts as f64,
                vel: 0.0,
            },
            elapsed_s: 0.0,
            fault: None,
            active: false,
        }
    }

    /// The modes this drive implements (0x6502).
    pub fn supported_modes(&self) -> &'static [i8] {
        self.supported_modes
    }

    /// 0x6502: bit `mode - 1` for each mode implemented.
    pub fn supported_modes_bits(&self) -> u32 {
        self.supported_modes.iter().fold(0, |b, m| b | 1 << (m - 1))
    }

    /// The mode in effect (0x6061); 0 until a mode was asked for.
    pub fn mode_display(&self) -> i8 {
        self.mode
    }

    /// Asks for a mode; it takes effect at once if implemented (returns whether).
    /// Leaving homing mode interrupts a homing in progress.
    pub fn set_mode(&mut self, mode: i8, servo: &Servo) -> bool {
        if !self.supported_modes.contains(&mode) {
            return false;
        }
        if mode != self.mode {
            if self.running() {
                self.state = Homing::Idle;
                self.progress = NOT_STARTED;
            }
            self.mode = mode;
            self.hold(servo);
        }
        true
    }

    /// The counter (0x6064) with the motor at `physical_counts`.
    pub fn counter(&self, physical_counts: i64) -> i64 {
        physical_counts + self.counter_offset
    }

    /// Homing progress (statusword bits 13, 12, 10 in homing mode).
    pub fn homing_bits(&self) -> HomingBits {
        self.progress
    }

    /// Controlword bit 4 rose since the last SYNC (the bus delivers every controlword, a
    /// level sampled at SYNC could miss a fall and rise within one period): the next
    /// command with bit 4 set is a rising edge.
    pub fn homing_start_rose(&mut self) {
        self.start_before = false;
    }

    /// The drive's own fault (EMCY code), if any.
    pub fn fault(&self) -> Option<u16> {
        self.fault
    }

    /// Fault reset: the drive's own fault clears (a drive beyond a hardware limit may be
    /// moved back; moving on outwards faults it again).
    pub fn reset_fault(&mut self) {
        self.fault = None;
    }

    /// Whether the power stage drives the motor.
    pub fn active(&self) -> bool {
        self.active
    }

    fn running(&self) -> bool {
        !matches!(self.state, Homing::Idle | Homing::Stop { .. })
    }

    fn hold(&mut self, servo: &Servo) {
        self.profile = Profile {
            pos: servo.position_counts() as f64,
            vel: 0.0,
        };
    }

    /// At SYNC: takes the command, sets the servo's target and enable for the coming
    /// period (`period_s`); `powered`: the power stage has power.
    pub fn at_sync(&mut self, servo: &mut Servo, c: &DriveCommand, powered: bool, period_s: f64) {
        self.set_mode(c.mode, servo);
        let physical = servo.position_counts();
        // A hardware limit: faults in any mode.
        if let Some((lo, hi)) = self.limits_counts {
            let v = servo.velocity_counts_s();
            let p = physical as f64;
            if self.fault.is_none()
                && ((p < lo && v < -LIMIT_SPEED_COUNTS_S) || (p > hi && v > LIMIT_SPEED_COUNTS_S))
            {
                self.fault = Some(EMCY_HARDWARE_LIMIT);
                if self.running() || matches!(self.state, Homing::Stop { .. }) {
                    self.progress = HomingBits {
                        attained: false,
                        error: true,
                        target_reached: true,
                    };
                    self.state = Homing::Idle;
                }
            }
        }
        let moving_mode = self.mode == MODE_CSP || self.mode == MODE_HOMING;
        let enabled = c.enable && powered && self.fault.is_none() && !servo.fault && moving_mode;
        let rising = c.homing_start && !self.start_before;
        self.start_before = c.homing_start;
        self.active = enabled;
        servo.enabled = enabled && servo.enabled_power;
        if !enabled {
            if self.running() || matches!(self.state, Homing::Stop { .. }) {
                // Interrupted by leaving "operation enabled".
                self.state = Homing::Idle;
                self.progress = NOT_STARTED;
            }
            self.hold(servo);
            servo.apply_target(physical);
            return;
        }
        if self.mode == MODE_CSP {
            let target = unwrap_near(c.target_counts, self.counter(physical));
            servo.apply_target(target - self.counter_offset);
            self.hold(servo);
            return;
        }
        // Homing mode: the drive's own profile; 0x607A is ignored.
        if let Some(g) = self.geometry {
            if rising && !c.halt && !self.running() {
                self.start(&g, physical as f64);
            } else if c.halt && self.running() {
                self.state = Homing::Stop { then: NOT_STARTED };
                self.progress = IN_PROGRESS;
            }
            self.step(&g, physical as f64, period_s);
        }
        servo.apply_target(self.profile.pos.round() as i64);
    }

    fn directions(&self) -> (f64, bool) {
        // The side the method assumes the switch active on, and whether home lies on it.
        let assumed_positive = matches!(self.homing.method, 3 | 4);
        let home_on_active_side = self.homing.method % 2 == 0;
        let active_dir = if assumed_positive { 1.0 } else { -1.0 };
        let final_dir = if home_on_active_side {
            active_dir
        } else {
            -active_dir
        };
        (final_dir, home_on_active_side)
    }

    fn start(&mut self, g: &HomeGeometry, physical: f64) {
        if !HOMING_METHODS.contains(&self.homing.method) {
            self.progress = HomingBits {
                attained: false,
                error: true,
                target_reached: true,
            };
            return;
        }
        let (final_dir, home_on_active_side) = self.directions();
        let active = g.switch_active(physical);
        let on_home_side = active == home_on_active_side;
        self.state = Homing::Seek {
            dir: if on_home_side { -final_dir } else { final_dir },
            active_at_start: active,
        };
        self.progress = IN_PROGRESS;
        self.elapsed_s = 0.0;
        self.profile = Profile {
            pos: physical,
            vel: 0.0,
        };
    }

    fn step(&mut self, g: &HomeGeometry, physical: f64, dt: f64) {
        let h = self.homing;
        let (fast, slow) = (
            f64::from(h.switch_speed_counts_s),
            f64::from(h.zero_speed_counts_s),
        );
        let accel = f64::from(h.accel_counts_s2.max(1));
        let (final_dir, _) = self.directions();
        if self.running() {
            self.elapsed_s += dt;
            if self.elapsed_s > g.timeout_s {
                self.state = Homing::Stop {
                    then: HomingBits {
                        attained: false,
                        error: true,
                        target_reached: true,
                    },
                };
                self.progress = HomingBits {
                    attained: false,
                    error: true,
                    target_reached: false,
                };
            }
        }
        let active = g.switch_active(physical);
        match self.state {
            Homing::Idle => {}
            Homing::Seek { dir, active_at_start } => {
                self.profile.run(dir * fast, accel, dt);
                if active != active_at_start {
                    self.state = if dir == final_dir {
                        Homing::Index {
                            at: g.next_index(physical, final_dir),
                        }
                    } else {
                        Homing::Reverse
                    };
                }
            }
            Homing::Reverse => {
                self.profile.run(0.0, accel, dt);
                if self.profile.vel == 0.0 {
                    self.state = Homing::Approach {
                        active_at_start: active,
                    };
                }
            }
            Homing::Approach { active_at_start } => {
                self.profile.run(final_dir * slow, accel, dt);
                if active != active_at_start {
                    self.state = Homing::Index {
                        at: g.next_index(physical, final_dir),
                    };
                }
            }
            Homing::Index { at } => {
                self.profile.run(final_dir * slow, accel, dt);
                if (physical - at) * final_dir >= 0.0 {
                    // The index pulse, latched: here the counter reads the home offset.
                    self.counter_offset = i64::from(h.home_offset_counts) - at as i64;
                    self.progress = HomingBits {
                        attained: true,
                        error: false,
                        target_reached: false,
                    };
                    self.state = Homing::Return { at };
                }
            }
            Homing::Return { at } => {
                let there = self.profile.position(at, slow, accel, dt);
                if there && (physical - at).abs() <= HOME_WINDOW_COUNTS {
                    self.progress = HomingBits {
                        attained: true,
                        error: false,
                        target_reached: true,
                    };
                    self.state = Homing::Idle;
                }
            }
            Homing::Stop { then } => {
                self.profile.run(0.0, accel, dt);
                if self.profile.vel == 0.0 {
                    self.progress = then;
                    self.state = Homing::Idle;
                }
            }
        }
    }
}

/// The 64-bit count nearest to `reference` whose low 32 bits are `wrapped`'s.
pub fn unwrap_near(wrapped: i32, reference: i64) -> i64 {
    reference + i64::from(wrapped.wrapping_sub(reference as i32))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geometry() -> HomeGeometry {
        HomeGeometry {
            switch_edge_counts: 725_000.0,
            switch_active_positive: true,
            index_pitch_counts: 10_000,
            index_phase_counts: 0,
            timeout_s: 60.0,
        }
    }

    #[test]
    fn the_next_index_pulse_lies_strictly_beyond_in_the_direction() {
        let g = geometry();
        assert_eq!(g.next_index(725_000.0, 1.0), 730_000.0);
        assert_eq!(g.next_index(725_000.0, -1.0), 720_000.0);
        assert_eq!(g.next_index(720_000.0, 1.0), 730_000.0);
        assert_eq!(g.next_index(720_000.0, -1.0), 710_000.0);
        assert_eq!(g.next_index(-5.0, 1.0), 0.0);
        assert!(g.switch_active(725_001.0) && !g.switch_active(724_999.0));
    }

    #[test]
    fn a_position_profile_stops_on_its_target() {
        let mut p = Profile::default();
        let mut t = 0;
        while !p.position(12_345.0, 3000.0, 150_000.0, 0.001) {
            t += 1;
            assert!(t < 10_000, "never arrived: {p:?}");
        }
        assert_eq!(p.pos, 12_345.0);
        assert_eq!(p.vel, 0.0);
    }
}
