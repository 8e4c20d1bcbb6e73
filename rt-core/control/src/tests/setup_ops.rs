//! The operator's set-up commands against a small model of CiA 402 drives: referencing
//! (homing mode, confirmed by the mode display), the dead-man of the continuous jog,
//! overrides, touch-off and position loss. The full physics and the virtual drives are
//! in `bench/` (hob-plant, hob-virtual-machine); this model only does what a drive's
//! interface promises, so the core's side of the protocol is tested alone.

use super::super::io::Inputs;
use super::super::*;
use fault::{Axis, Fault, HomingFailure, Refusal};

/// One drive as its master sees it: CSP follows the target; homing runs to a home
/// `travel` away and then reports the home offset as its position.
#[derive(Debug, Clone, Copy)]
struct Drive {
    counts: i64,
    mode: i8,
    /// Cycles before a written mode shows in the mode display.
    mode_lag: u32,
    pending: Option<(i8, u32)>,
    homing: Option<i64>,
    homed: bool,
    home_offset_counts: i64,
    homing_speed_counts: i64,
    /// Report a homing error instead of finishing.
    fail_homing: bool,
    last_start: bool,
    /// Added to the reported position (a drive whose counter restarted).
    counter_shift: i64,
}

impl Drive {
    fn new(counts: i64) -> Self {
        Drive {
            counts,
            mode: 8,
            mode_lag: 3,
            pending: None,
            homing: None,
            homed: false,
            home_offset_counts: 0,
            homing_speed_counts: 30,
            fail_homing: false,
            last_start: false,
            counter_shift: 0,
        }
    }

    fn apply(&mut self, target: i32, mode: DriveMode, start: bool, enabled: bool) {
        let m = mode.code();
        match self.pending {
            Some((pm, n)) if pm == m => {
                if n == 0 {
                    self.mode = m;
                    self.pending = None;
                } else {
                    self.pending = Some((pm, n - 1));
                }
            }
            _ if m != self.mode => self.pending = Some((m, self.mode_lag)),
            _ => self.pending = None,
        }
        if self.mode == 8 {
            self.homing = None;
            if enabled {
                self.counts = i64::from(target);
            }
        } else if self.mode == 6 && enabled {
            if start && !self.last_start {
                // Home 20 000 counts below (from wherever it stands).
                self.homing = Some(self.counts - 20_000);
                self.homed = false;
            }
            if let Some(home) = self.homing
                && !self.fail_homing
            {
                let step = (home - self.counts).clamp(-self.homing_speed_counts, self.homing_speed_counts);
                self.counts += step;
                if self.counts == home {
                    self.counts = self.home_offset_counts;
                    self.homing = None;
                    self.homed = true;
                }
            }
        }
        self.last_start = start;
    }

    fn feedback(&self) -> AxisFeedback {
        let homing = if self.mode != 6 {
            HomingBits::default()
        } else if self.fail_homing && self.last_start {
            HomingBits {
                error: true,
                target_reached: true,
                ..HomingBits::default()
            }
        } else if self.homing.is_some() {
            HomingBits::default()
        } else {
            HomingBits {
                attained: self.homed,
                target_reached: true,
                error: false,
            }
        };
        AxisFeedback {
            position_counts: (self.counts + self.counter_shift) as i32,
            enabled: true,
            fault: false,
            fresh: true,
            mode_display: self.mode,
            homing,
        }
    }
}

struct Rig {
    c: Controller,
    drives: [Drive; 3],
    inputs: u32,
    out: CycleOutputs,
}

impl Rig {
    fn new() -> Self {
        let p = ControlParams::from_machine(&hob_setup::config::machine::shipped_for_tests());
        let inputs = p.io.encode_inputs(&Inputs {
            safety_chain_closed: true,
            lube_pressure_ok: true,
            vfd_ready: true,
            ..Inputs::default()
        });
        // X and Y stand somewhere unknown: 40 and 70 mm of counter from power-on.
        let mut drives = [Drive::new(0), Drive::new(120_000), Drive::new(210_000)];
        drives[1].home_offset_counts = p.x.to_counts(240.0) as i64;
        drives[2].home_offset_counts = p.y.to_counts(440.0) as i64;
        let mut rig = Rig {
            c: Controller::new(p),
            drives,
            inputs,
            out: CycleOutputs::default(),
        };
        rig.run_until(20.0, |c| c.status().state == State::Idle);
        rig
    }

    fn step(&mut self) {
        let o = self.out;
        let targets = [o.table_target_counts, o.x_target_counts, o.y_target_counts];
        for (k, (drive, target)) in self.drives.iter_mut().zip(targets).enumerate() {
            drive.apply(target, o.drive_modes[k], o.homing_start[k], o.drives_enabled);
        }
        let input = CycleInputs {
            spindle_counts: 0,
            table: self.drives[0].feedback(),
            x: self.drives[1].feedback(),
            y: self.drives[2].feedback(),
            digital_inputs: self.inputs,
            io_valid: true,
            ..CycleInputs::default()
        };
        self.out = self.c.step(&input);
    }

    /// Steps until `done` (true) or `max_s` of machine time (false).
    fn run_until(&mut self, max_s: f64, done: impl Fn(&Controller) -> bool) -> bool {
        let n = (max_s / self.c.params().period_s) as usize;
        for _ in 0..n {
            self.step();
            if done(&self.c) {
                return true;
            }
        }
        false
    }

    fn referenced(mut self) -> Self {
        assert_eq!(self.c.command(Command::Home { axes: HomeAxes::Both }), Ok(()));
        assert!(self.run_until(60.0, |c| c.status().state == State::Idle));
        assert_eq!(self.c.status().fault, None);
        self
    }
}

#[test]
fn nothing_but_referencing_and_slow_jogs_before_the_reference() {
    let mut r = Rig::new();
    assert_eq!(r.c.status().referenced, [false, false]);
    // X reads 40 mm from the counter: outside the soft limits (25 .. 250 mm from the
    // reference), yet no soft-limit fault: nothing knows where X is.
    assert!(r.c.status().x_mm < 50.0);
    assert_eq!(r.c.status().fault, None);
    assert_eq!(
        r.c.command(Command::Start { single: false }),
        Err(Refusal::NoProgram)
    );
    assert_eq!(
        r.c.command(Command::TouchOff {
            axis: Axis::X,
            value_mm: 100.0,
            confirmed: true,
        }),
        Err(Refusal::NotReferenced)
    );
    // A jog beyond the soft limits is allowed, and slow.
    assert_eq!(
        r.c.command(Command::Jog {
            axis: Axis::X,
            distance: -30.0
        }),
        Ok(())
    );
    let mut fastest = 0.0f64;
    let mut last = r.c.status().x_cmd_mm;
    while r.c.status().state == State::Jog {
        r.step();
        let x = r.c.status().x_cmd_mm;
        fastest = fastest.max((x - last).abs() / r.c.params().period_s);
        last = x;
    }
    let slow = r.c.params().unreferenced_jog_mm_s;
    assert!(
        fastest <= slow + 1e-9,
        "{fastest} mm/s, unreferenced jogs at most {slow}"
    );
    assert!(fastest > 0.9 * slow);
    assert_eq!(r.c.status().fault, None);
}

#[test]
fn homing_references_x_then_y_and_the_position_jump_is_no_fault() {
    let mut r = Rig::new();
    assert_eq!(r.c.command(Command::Home { axes: HomeAxes::Both }), Ok(()));
    assert_eq!(r.c.status().state, State::Referencing);
    // Refused while referencing.
    assert_eq!(
        r.c.command(Command::Jog {
            axis: Axis::Y,
            distance: 1.0
        }),
        Err(Refusal::CycleRunning)
    );
    let mut order = Vec::new();
    let mut modes_seen = Vec::new();
    for _ in 0..60_000 {
        r.step();
        while let Some(e) = r.c.events().pop() {
            if let events::EventKind::Referenced { axis } = e.kind {
                order.push(axis);
            }
        }
        if r.out.drive_modes != [DriveMode::CyclicPosition; 3] {
            modes_seen.push(r.out.drive_modes);
        }
        if r.c.status().state == State::Idle {
            break;
        }
    }
    assert_eq!(order, vec![Axis::X, Axis::Y]);
    assert_eq!(
        r.c.status().fault,
        None,
        "the home offset jump is not a following error"
    );
    assert_eq!(r.c.status().referenced, [true, true]);
    assert!(
        modes_seen.iter().all(|m| m[0] == DriveMode::CyclicPosition),
        "the table stays in CSP"
    );
    assert!(
        modes_seen
            .iter()
            .all(|m| !(m[1] == DriveMode::Homing && m[2] == DriveMode::Homing))
    );
    assert_eq!(r.out.drive_modes, [DriveMode::CyclicPosition; 3]);
    // X is where the drive said: at the home position.
    assert!((r.c.status().x_mm - 240.0).abs() < 1e-3, "{}", r.c.status().x_mm);
    assert!((r.c.status().y_mm - 440.0).abs() < 1e-3);
    // From now on the soft limits hold: a jog past them is refused.
    assert_eq!(
        r.c.command(Command::Jog {
            axis: Axis::X,
            distance: 20.0
        }),
        Err(Refusal::OutsideSoftLimits)
    );
}

#[test]
fn a_drive_that_does_not_confirm_homing_mode_or_reports_an_error_is_a_fault() {
    let mut r = Rig::new();
    r.drives[1].mode_lag = 5_000;
    assert_eq!(r.c.command(Command::Home { axes: HomeAxes::X }), Ok(()));
    assert!(r.run_until(3.0, |c| c.status().fault.is_some()));
    assert_eq!(
        r.c.status().fault,
        Some(Fault::HomingFailed {
            axis: Axis::X,
            why: HomingFailure::ModeNotConfirmed
        })
    );
    assert_eq!(r.out.drive_modes, [DriveMode::CyclicPosition; 3], "back to CSP");

    let mut r = Rig::new();
    r.drives[2].fail_homing = true;
    assert_eq!(r.c.command(Command::Home { axes: HomeAxes::Y }), Ok(()));
    assert!(r.run_until(5.0, |c| c.status().fault.is_some()));
    assert!(matches!(
        r.c.status().fault,
        Some(Fault::HomingFailed { axis: Axis::Y, .. })
    ));
    assert_eq!(r.c.status().referenced, [false, false]);
}

#[test]
fn a_continuous_jog_runs_while_renewed_and_the_dead_man_stops_it() {
    let mut r = Rig::new().referenced();
    let jog = Command::JogContinuous {
        axis: Axis::Y,
        direction: Direction::Negative,
        speed_per_min: 600.0,
    };
    let dt = r.c.params().period_s;
    let deadman_s = r.c.params().deadman_s;
    assert_eq!(r.c.command(jog), Ok(()));
    // Renewed every 100 ms for 2 s: it keeps running.
    for _ in 0..20 {
        for _ in 0..100 {
            r.step();
        }
        assert_eq!(r.c.status().state, State::Jog);
        assert_eq!(r.c.command(jog), Ok(()));
    }
    // Another jog while this one runs is refused.
    assert_eq!(
        r.c.command(Command::Jog {
            axis: Axis::X,
            distance: -1.0
        }),
        Err(Refusal::JogActive)
    );
    // The renewals stop: it stops within the dead-man time plus the braking time.
    let v = 600.0 / 60.0;
    let brake_s = v / r.c.params().y_limits.accel_mm_s2;
    let mut stopped_after_s = None;
    for k in 1..=((deadman_s + brake_s + 0.5) / dt) as usize {
        r.step();
        if r.c.status().state == State::Idle {
            stopped_after_s = Some(k as f64 * dt);
            break;
        }
    }
    let t = stopped_after_s.expect("the dead-man did not stop the jog");
    assert!(
        t > deadman_s,
        "stopped after {t} s, before the dead-man time {deadman_s} s"
    );
    assert!(t <= deadman_s + brake_s + 0.01, "stopped after {t} s");
    assert_eq!(r.c.status().fault, None);
}

#[test]
fn overrides_are_checked_and_a_touch_off_moves_nothing() {
    let mut r = Rig::new().referenced();
    assert_eq!(
        r.c.command(Command::FeedOverride { percent: 121.0 }),
        Err(Refusal::BadValue)
    );
    assert_eq!(
        r.c.command(Command::SpindleOverride { percent: 40.0 }),
        Err(Refusal::BadValue)
    );
    assert_eq!(r.c.command(Command::FeedOverride { percent: 80.0 }), Ok(()));
    assert_eq!(r.c.status().feed_override_percent, 80.0);
    // A touch-off needs the hob's diameter: the loaded program's.
    assert_eq!(
        r.c.command(Command::TouchOff {
            axis: Axis::X,
            value_mm: 400.0,
            confirmed: false,
        }),
        Err(Refusal::NoProgram)
    );
    let targets_before = (r.out.x_target_counts, r.out.y_target_counts);
    let x_before = r.c.status().x_mm;
    r.c.set_offsets(Offsets {
        x_mm: 0.25,
        y_mm: -0.5,
    });
    r.step();
    r.step();
    assert_eq!(
        (r.out.x_target_counts, r.out.y_target_counts),
        targets_before,
        "no axis moves"
    );
    assert!((r.c.status().x_mm - (x_before + 0.25)).abs() < 1e-9);
    assert_eq!(r.c.status().fault, None);
}

#[test]
fn a_position_jump_loses_the_reference() {
    let mut r = Rig::new().referenced();
    // The X drive reboots: its counter starts again at 0.
    r.drives[1].counter_shift = -r.drives[1].counts;
    r.step();
    assert_eq!(r.c.status().fault, Some(Fault::PositionLost { axis: Axis::X }));
    assert_eq!(r.c.status().referenced, [false, true]);
}
