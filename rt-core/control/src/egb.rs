//! The electronic gearbox: the table command from the predicted spindle angle and the
//! commanded Y, engaged and disengaged without a jump, kept on the blank's recorded tooth
//! phase, watched by synchronism windows and corrected by cross-coupling.
//!
//! Table command (deg), with `coupled(theta, Y) = s_i (z0/z) theta + s_d D Y`
//! (`D` = 360 sin(beta) / (pi m_n z)):
//!
//! ```text
//! base(k)  = base(k-1) + c(k) [coupled(theta_pred(k), Y_cmd(k)) - coupled(theta_pred(k-1), Y_cmd(k-1))]
//!            + phase move(k)
//! phase(k) = base(k) - coupled(theta_pred(k), Y_cmd(k))
//! cmd(k)   = base(k) - ccc(k)
//! ```
//!
//! The coupling `c` ramps 0 -> 1 (smoothstep) over the engage time, so the table
//! accelerates smoothly to the synchronous speed whatever the spindle does. At full
//! coupling the phase is recorded on the first engagement of a blank; every later
//! engagement moves the phase onto the nearest equivalent (`recorded + n 360/z`) of the
//! recorded one: the same tooth gap, never an arbitrary one.

use super::pitch_comp::PitchCompensation;
use super::profile::Profile;

/// The gearbox's fixed parameters (from the machine configuration and the job).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GearboxParams {
    /// `s_i z0 / z`: table deg per spindle deg, signed; 0 for tooth-by-tooth.
    pub ratio_signed: f64,
    /// `s_d 360 sin(beta)/(pi m_n z)`: table deg per mm of Y, signed.
    pub differential_signed_deg_per_mm: f64,
    /// Table pitch `360 / z`: equivalent tooth phases are this far apart.
    pub pitch_deg: f64,
    pub engage_time_s: f64,
    pub fine_window_deg: f64,
    pub coarse_window_deg: f64,
    pub ccc_enabled: bool,
    pub ccc_kp: f64,
    pub ccc_ki_per_s: f64,
    pub ccc_limit_deg: f64,
    pub phase_speed_deg_s: f64,
    pub table_accel_deg_s2: f64,
}

impl GearboxParams {
    /// The coupled table angle for a spindle angle and a Y position.
    pub fn coupled_deg(&self, spindle_deg: f64, y_mm: f64) -> f64 {
        self.ratio_signed * spindle_deg + self.differential_signed_deg_per_mm * y_mm
    }
}

/// Where the gearbox is (the wire's vocabulary).
pub use hob_wire::vocab::Coupling;

/// What the gearbox measured this cycle.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct SyncStatus {
    /// `table - coupled(spindle, Y) - phase target`, deg; 0 unless synchronised.
    pub error_deg: f64,
    pub in_fine_window: bool,
    pub in_coarse_window: bool,
    /// Cross-coupling correction applied, deg.
    pub ccc_deg: f64,
    /// The pitch compensation's offset on the table's target, deg (0 without one).
    pub compensation_deg: f64,
}

/// The electronic gearbox.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Gearbox {
    params: GearboxParams,
    coupling: Coupling,
    /// Linear ramp variable 0..1; the coupling factor is its smoothstep.
    ramp: f64,
    last_coupled_deg: Option<f64>,
    base_deg: f64,
    phase_move: Profile,
    phase_goal_deg: f64,
    /// The phase the table must hold (deg), once synchronised.
    phase_target_deg: Option<f64>,
    /// The blank's tooth phase, recorded at its first engagement.
    recorded_phase_deg: Option<f64>,
    ccc_integral_deg: f64,
    status: SyncStatus,
}

fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

impl Gearbox {
    /// A disengaged gearbox holding the table at `table_deg`.
    pub fn new(params: GearboxParams, table_deg: f64) -> Self {
        Self {
            params,
            coupling: Coupling::Disengaged,
            ramp: 0.0,
            last_coupled_deg: None,
            base_deg: table_deg,
            phase_move: Profile::default(),
            phase_goal_deg: 0.0,
            phase_target_deg: None,
            recorded_phase_deg: None,
            ccc_integral_deg: 0.0,
            status: SyncStatus::default(),
        }
    }

    /// Changes the law (a new program) keeping the table where it is. Clears the phase.
    pub fn set_params(&mut self, params: GearboxParams) {
        let table = self.base_deg;
        *self = Self::new(params, table);
    }

    /// Turns cross-coupling on or off, keeping everything else.
    pub fn set_cross_coupling(&mut self, on: bool) {
        self.params.ccc_enabled = on;
        self.ccc_integral_deg = 0.0;
    }

    pub fn params(&self) -> &GearboxParams {
        &self.params
    }

    pub fn coupling(&self) -> Coupling {
        self.coupling
    }

    pub fn status(&self) -> SyncStatus {
        self.status
    }

    /// The phase the table holds while synchronised (recorded + n pitches).
    pub fn phase_target_deg(&self) -> Option<f64> {
        self.phase_target_deg
    }

    pub fn recorded_phase_deg(&self) -> Option<f64> {
        self.recorded_phase_deg
    }

    /// Keeps a blank's recorded phase across a re-initialisation (drives re-enabled).
    pub fn restore_recorded_phase(&mut self, phase_deg: f64) {
        self.recorded_phase_deg = Some(phase_deg);
    }

    /// A new blank is on the table: forget its tooth phase (operator's confirmation).
    pub fn new_blank(&mut self) {
        self.recorded_phase_deg = None;
    }

    pub fn engage(&mut self) {
        if matches!(self.coupling, Coupling::Disengaged | Coupling::Disengaging) {
            self.coupling = Coupling::Engaging;
        }
    }

    pub fn disengage(&mut self) {
        if self.coupling != Coupling::Disengaged {
            self.coupling = Coupling::Disengaging;
            self.phase_target_deg = None;
            self.ccc_integral_deg = 0.0;
        }
    }

    /// Moves the table by `delta_deg` on top of whatever the coupling does (indexing,
    /// jog); when synchronised the phase target moves with it.
    pub fn move_table_by(&mut self, delta_deg: f64) {
        self.phase_goal_deg += delta_deg;
        if let Some(t) = self.phase_target_deg.as_mut() {
            *t += delta_deg;
        }
    }

    /// Whether a table move is still under way.
    pub fn table_moving(&self) -> bool {
        self.phase_move.position != self.phase_goal_deg || self.phase_move.velocity != 0.0
    }

    /// Ready for the cut: synchronised, no move left, error in the fine window.
    pub fn ready_to_cut(&self) -> bool {
        self.coupling == Coupling::Synchronised && !self.table_moving() && self.status.in_fine_window
    }

    /// One cycle. `spindle_pred_deg` and `y_cmd_mm` are for the instant the command takes
    /// effect; `spindle_now_deg`, `table_now_deg` and `y_now_mm` were measured at this
    /// cycle's sync. With a pitch compensation, a new blank takes the compensation's tooth
    /// phase (the nearest equivalent) and the table's target gets its offset, scaled by the
    /// coupling as it ramps; the synchronism error is measured against the compensated
    /// target. Returns the table command in deg.
    #[allow(clippy::too_many_arguments)]
    pub fn step(
        &mut self,
        spindle_pred_deg: f64,
        y_cmd_mm: f64,
        spindle_now_deg: f64,
        table_now_deg: f64,
        y_now_mm: f64,
        dt_s: f64,
        compensation: Option<&PitchCompensation>,
    ) -> f64 {
        let p = self.params;
        match self.coupling {
            Coupling::Engaging => {
                self.ramp = (self.ramp + dt_s / p.engage_time_s).min(1.0);
            }
            Coupling::Disengaging => {
                self.ramp = (self.ramp - dt_s / p.engage_time_s).max(0.0);
                if self.ramp == 0.0 {
                    self.coupling = Coupling::Disengaged;
                }
            }
            _ => {}
        }
        let c = smoothstep(self.ramp);
        let coupled = p.coupled_deg(spindle_pred_deg, y_cmd_mm);
        let delta = self.last_coupled_deg.map_or(0.0, |last| coupled - last);
        self.last_coupled_deg = Some(coupled);
        self.base_deg += c * delta;

        if self.coupling == Coupling::Engaging && self.ramp >= 1.0 {
            let phase = self.base_deg - coupled;
            let nearest = |rec: f64| rec + ((phase - rec) / p.pitch_deg).round() * p.pitch_deg;
            let target = match (self.recorded_phase_deg, compensation) {
                (None, None) => {
                    self.recorded_phase_deg = Some(phase);
                    phase
                }
                // A new blank cut where the compensation was measured.
                (None, Some(comp)) => {
                    let target = nearest(comp.phase_deg());
                    self.recorded_phase_deg = Some(target);
                    target
                }
                (Some(rec), _) => nearest(rec),
            };
            self.phase_target_deg = Some(target);
            self.phase_goal_deg += target - phase;
            self.coupling = Coupling::Phasing;
        }

        let before = self.phase_move.position;
        self.phase_move.step_towards(
            self.phase_goal_deg,
            p.phase_speed_deg_s,
            p.table_accel_deg_s2,
            dt_s,
        );
        self.base_deg += self.phase_move.position - before;
        if self.coupling == Coupling::Phasing && !self.table_moving() {
            self.coupling = Coupling::Synchronised;
        }

        self.status = match (self.coupling, self.phase_target_deg) {
            (Coupling::Phasing | Coupling::Synchronised, Some(target)) => {
                let error = table_now_deg - p.coupled_deg(spindle_now_deg, y_now_mm) - target;
                // The phase move is part of the command; measure against where it is.
                let error = error - (self.phase_move.position - self.phase_goal_deg);
                let error = match compensation {
                    Some(comp) => error - c * comp.offset_deg(table_now_deg, spindle_now_deg),
                    None => error,
                };
                let ccc = if p.ccc_enabled && self.coupling == Coupling::Synchronised {
                    self.ccc_integral_deg = (self.ccc_integral_deg + p.ccc_ki_per_s * dt_s * error)
                        .clamp(-p.ccc_limit_deg, p.ccc_limit_deg);
                    (p.ccc_kp * error + self.ccc_integral_deg).clamp(-p.ccc_limit_deg, p.ccc_limit_deg)
                } else {
                    0.0
                };
                SyncStatus {
                    error_deg: error,
                    in_fine_window: error.abs() <= p.fine_window_deg,
                    in_coarse_window: error.abs() <= p.coarse_window_deg,
                    ccc_deg: ccc,
                    compensation_deg: 0.0,
                }
            }
            _ => SyncStatus {
                in_fine_window: false,
                in_coarse_window: true,
                ..SyncStatus::default()
            },
        };
        match compensation {
            Some(comp) => {
                self.status.compensation_deg = c * comp.offset_deg(self.base_deg, spindle_pred_deg);
                self.base_deg - self.status.ccc_deg + self.status.compensation_deg
            }
            None => self.base_deg - self.status.ccc_deg,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> GearboxParams {
        GearboxParams {
            ratio_signed: 1.0 / 17.0,
            differential_signed_deg_per_mm: 0.0,
            pitch_deg: 360.0 / 17.0,
            engage_time_s: 0.5,
            fine_window_deg: 20.0 / 3600.0,
            coarse_window_deg: 200.0 / 3600.0,
            ccc_enabled: false,
            ccc_kp: 0.0,
            ccc_ki_per_s: 0.0,
            ccc_limit_deg: 0.0,
            phase_speed_deg_s: 5.0,
            table_accel_deg_s2: 200.0,
        }
    }

    /// Runs an ideal table (follows its command exactly) with the spindle at `rpm`.
    fn run(g: &mut Gearbox, spindle: &mut f64, table: &mut f64, rpm: f64, cycles: u32) -> f64 {
        // The command is for the next instant; the table reaches it there.
        let mut max_step = 0.0f64;
        for _ in 0..cycles {
            let next = *spindle + rpm * 6.0 * 0.001;
            let cmd = g.step(next, 0.0, *spindle, *table, 0.0, 0.001, None);
            max_step = max_step.max((cmd - *table).abs());
            *table = cmd;
            *spindle = next;
        }
        max_step
    }

    #[test]
    fn engages_without_a_jump_and_records_the_phase() {
        let mut g = Gearbox::new(params(), 10.0);
        let (mut spindle, mut table) = (1234.0, 10.0);
        g.engage();
        let max_step = run(&mut g, &mut spindle, &mut table, 200.0, 2000);
        // Synchronous table speed is 1200/17 = 70.6 deg/s = 0.0706 deg per cycle.
        assert!(max_step <= 1200.0 / 17.0 * 0.001 + 1e-9, "{max_step}");
        assert_eq!(g.coupling(), Coupling::Synchronised);
        assert!(g.ready_to_cut());
        let rec = g.recorded_phase_deg().unwrap();
        assert!((table - spindle / 17.0 - rec).abs() < 1e-9);
    }

    #[test]
    fn re_engagement_returns_to_the_same_tooth_gap() {
        let p = params();
        let mut g = Gearbox::new(p, 0.0);
        let (mut spindle, mut table) = (0.0, 0.0);
        g.engage();
        run(&mut g, &mut spindle, &mut table, 100.0, 2000);
        let rec = g.recorded_phase_deg().unwrap();
        g.disengage();
        run(&mut g, &mut spindle, &mut table, 100.0, 1000);
        assert_eq!(g.coupling(), Coupling::Disengaged);
        // The table is moved by hand (jog) by an odd amount while the spindle keeps running.
        g.move_table_by(7.3);
        run(&mut g, &mut spindle, &mut table, 100.0, 5000);
        g.engage();
        run(&mut g, &mut spindle, &mut table, 100.0, 5000);
        assert_eq!(g.coupling(), Coupling::Synchronised);
        let phase = table - spindle / 17.0;
        let gaps = (phase - rec) / p.pitch_deg;
        assert!(
            (gaps - gaps.round()).abs() < 1e-9,
            "phase {phase} vs recorded {rec}: {gaps} pitches"
        );
        assert_eq!(g.recorded_phase_deg(), Some(rec));
    }

    #[test]
    fn a_new_blank_takes_a_new_phase() {
        let mut g = Gearbox::new(params(), 0.0);
        let (mut spindle, mut table) = (0.0, 0.0);
        g.engage();
        run(&mut g, &mut spindle, &mut table, 100.0, 2000);
        g.disengage();
        run(&mut g, &mut spindle, &mut table, 100.0, 1000);
        g.new_blank();
        g.move_table_by(7.3);
        run(&mut g, &mut spindle, &mut table, 100.0, 5000);
        g.engage();
        run(&mut g, &mut spindle, &mut table, 100.0, 1000);
        let rec = g.recorded_phase_deg().unwrap();
        assert!((table - spindle / 17.0 - rec).abs() < 1e-9);
    }

    #[test]
    fn the_error_leaves_the_windows_when_the_table_lags() {
        let mut g = Gearbox::new(params(), 0.0);
        let (mut spindle, mut table) = (0.0, 0.0);
        g.engage();
        run(&mut g, &mut spindle, &mut table, 100.0, 2000);
        let cmd = g.step(spindle, 0.0, spindle, table - 0.1, 0.0, 0.001, None);
        let s = g.status();
        assert!((s.error_deg + 0.1).abs() < 1e-3, "{s:?} {cmd}");
        assert!(!s.in_fine_window && !s.in_coarse_window);
    }

    #[test]
    fn cross_coupling_pushes_against_the_error_within_its_bound() {
        let mut p = params();
        p.ccc_enabled = true;
        p.ccc_kp = 0.2;
        p.ccc_ki_per_s = 50.0;
        p.ccc_limit_deg = 60.0 / 3600.0;
        let mut g = Gearbox::new(p, 0.0);
        let (mut spindle, mut table) = (0.0, 0.0);
        g.engage();
        run(&mut g, &mut spindle, &mut table, 100.0, 2000);
        // The table stands 0.01 deg ahead of where the law puts it for a second.
        let rec = g.recorded_phase_deg().unwrap();
        let mut cmd = table;
        for _ in 0..1000 {
            let next = spindle + 0.6;
            cmd = g.step(next, 0.0, spindle, spindle / 17.0 + rec + 0.01, 0.0, 0.001, None);
            spindle = next;
        }
        let s = g.status();
        assert!((s.error_deg - 0.01).abs() < 1e-9, "{s:?}");
        assert!(s.ccc_deg > 0.0 && s.ccc_deg <= p.ccc_limit_deg + 1e-12, "{s:?}");
        assert!(
            (s.ccc_deg - p.ccc_limit_deg).abs() < 1e-12,
            "saturates at its bound: {s:?}"
        );
        let ideal = (spindle - 0.6 + 0.6) / 17.0 + rec;
        assert!(cmd < ideal, "the command is pulled back against the error");
    }
}
