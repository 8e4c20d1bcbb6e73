//! The table drive's loops on the two-way worm mechanism: a pure model of
//! `bench/plant/src/servo.rs`'s cascade on the linear two-mass drive, the Rust counterpart
//! of `bench/side-model/loop.py` (docs/mechanism.md, sections 1-2).
//!
//! What is modelled, per loop sample (period T, `loop_period_s`): the motor's angle is read
//! (no quantisation); speed = backward difference / T, then a first-order low-pass
//! discretised with the exponential (a = 1 - exp(-2 pi f_filter T)); a P position loop
//! (kv) with velocity feed-forward from the drive's own interpolation segment; a PI velocity
//! loop (the integral sums the past errors, as servo.rs updates it after use); the torque
//! held over the sample (zero-order hold, exact discretisation of the plant). Not modelled:
//! the torque limit and anti-windup (linear model), the encoder's quantisation, friction,
//! backlash, the coupling mode (motor against worm, about 1.5 kHz).
//!
//! The plant, in motor coordinates: the motor side J_m (rotor, coupling, worm) drives the
//! table J_t through the ratio i; the mesh's stiffness k and damping c act at the table,
//! i.e. k / i^2 and c / i^2 at the motor. Torque at the motor -> motor angle is
//! (J_t' s^2 + c' s + k') / (s^2 (J_m J_t' s^2 + c' (J_m + J_t') s + k' (J_m + J_t')))
//! with J_t' = J_t / i^2, c' = c / i^2, k' = k / i^2.
//!
//! Pure: no I/O, no clock. Everything here is deterministic.

use nalgebra::{Complex, DMatrix, Matrix4, Matrix5, SMatrix, SVector, Vector4};
use std::f64::consts::{PI, TAU};

#[cfg(test)]
mod tests;

/// The linear two-mass worm drive of the table (B) axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mechanism {
    /// Inertia on the motor's shaft: rotor, coupling and worm, kg m2.
    pub motor_inertia_kg_m2: f64,
    /// Table, fixture and blank, kg m2 (at the table).
    pub table_inertia_kg_m2: f64,
    /// Torsional stiffness of the mesh and all in series with it, Nm/rad at the table.
    pub mesh_stiffness_nm_per_rad: f64,
    /// Damping across the mesh, Nm s/rad at the table.
    pub mesh_damping_nm_s_per_rad: f64,
    /// Worm ratio: motor turns per table turn (75 on the thesis's machine).
    pub worm_ratio: f64,
}

impl Mechanism {
    /// The inertia the motor would see were the mesh rigid, J_m + J_t / i^2, kg m2 (what
    /// a drive's autotune reports, and what servo.rs's gains are tuned for).
    pub fn rigid_inertia_kg_m2(&self) -> f64 {
        self.motor_inertia_kg_m2 + self.table_inertia_kg_m2 / self.worm_ratio.powi(2)
    }

    /// The damping ratio of the coupled mode (motor against table), c / (2 sqrt(k J_red))
    /// with J_red = J_m' J_t / (J_m' + J_t), J_m' = J_m i^2 (docs/mechanism.md section 3,
    /// item 5).
    pub fn modal_damping_ratio(&self) -> f64 {
        self.mesh_damping_nm_s_per_rad
            / (2.0 * (self.mesh_stiffness_nm_per_rad * self.reduced_inertia_kg_m2()).sqrt())
    }

    /// The damping, Nm s/rad at the table, that gives the coupled mode the damping ratio
    /// `zeta` (dimensionless).
    pub fn damping_for_modal_ratio_nm_s_per_rad(&self, zeta: f64) -> f64 {
        2.0 * zeta * (self.mesh_stiffness_nm_per_rad * self.reduced_inertia_kg_m2()).sqrt()
    }

    /// J_m' J_t / (J_m' + J_t) at the table, kg m2.
    fn reduced_inertia_kg_m2(&self) -> f64 {
        let motor_at_table = self.motor_inertia_kg_m2 * self.worm_ratio.powi(2);
        motor_at_table * self.table_inertia_kg_m2 / (motor_at_table + self.table_inertia_kg_m2)
    }

    /// (J_t / i^2 kg m2, k / i^2 Nm/rad, c / i^2 Nm s/rad): the table's side at the motor.
    fn at_motor(&self) -> (f64, f64, f64) {
        let i2 = self.worm_ratio.powi(2);
        (
            self.table_inertia_kg_m2 / i2,
            self.mesh_stiffness_nm_per_rad / i2,
            self.mesh_damping_nm_s_per_rad / i2,
        )
    }
}

/// The table drive's loops as servo.rs implements them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriveLoops {
    /// Proportional gain of the velocity loop, Nm per rad/s (at the motor).
    pub velocity_kp_nm_s_per_rad: f64,
    /// The velocity loop's integral time kp / ki, s (infinite: no integral).
    pub velocity_integral_time_s: f64,
    /// The position loop's gain, rad/s of speed reference per rad of error (1/s).
    pub position_kv_per_s: f64,
    /// Velocity feed-forward from the interpolation segment (1.0 in servo.rs).
    pub velocity_feed_forward: f64,
    /// The loops' sample period, s (200 us: `drives.loop_us`).
    pub loop_period_s: f64,
    /// The speed estimate's first-order low-pass, Hz (1500 Hz in servo.rs).
    pub velocity_filter_hz: f64,
}

impl DriveLoops {
    /// servo.rs's formulas: kp = J w_v, ki = J w_v^2 / 4 (so the integral time is 4 / w_v),
    /// kv = 2 pi f_p, feed-forward 1.0; w_v = 2 pi `velocity_loop_hz`; J the inertia the
    /// drive is tuned for, kg m2 (its autotune's, i.e. [`Mechanism::rigid_inertia_kg_m2`]).
    /// A velocity loop of 0 Hz gives no loop at all (kp 0, no integral).
    pub fn from_bandwidths(
        tuned_inertia_kg_m2: f64,
        velocity_loop_hz: f64,
        position_loop_hz: f64,
        loop_period_s: f64,
        velocity_filter_hz: f64,
    ) -> Self {
        let w_v = TAU * velocity_loop_hz;
        Self {
            velocity_kp_nm_s_per_rad: tuned_inertia_kg_m2 * w_v,
            velocity_integral_time_s: if w_v > 0.0 { 4.0 / w_v } else { f64::INFINITY },
            position_kv_per_s: TAU * position_loop_hz,
            velocity_feed_forward: 1.0,
            loop_period_s,
            velocity_filter_hz,
        }
    }

    /// The velocity loop's integral gain ki = kp / integral time, Nm per rad (0 with an
    /// infinite integral time).
    pub fn velocity_ki_nm_per_rad(&self) -> f64 {
        if self.velocity_integral_time_s.is_finite() && self.velocity_integral_time_s > 0.0 {
            self.velocity_kp_nm_s_per_rad / self.velocity_integral_time_s
        } else {
            0.0
        }
    }

    /// The speed filter's weight per sample, a = 1 - exp(-2 pi f T).
    fn filter_weight(&self) -> f64 {
        1.0 - (-TAU * self.velocity_filter_hz * self.loop_period_s).exp()
    }
}

/// The continuous plant, torque at the motor -> motor angle, rad/Nm, at `f_hz`.
pub fn plant(m: &Mechanism, f_hz: f64) -> Complex<f64> {
    let (j_t, k, c) = m.at_motor();
    let j_m = m.motor_inertia_kg_m2;
    let s = Complex::new(0.0, TAU * f_hz);
    let num = s * s * j_t + s * c + k;
    let den = s * s * (s * s * (j_m * j_t) + s * (c * (j_m + j_t)) + k * (j_m + j_t));
    num / den
}

/// The mechanism's two frequencies seen at the motor, Hz: (anti-resonance sqrt(k / J_t),
/// the table ringing with the motor held; resonance sqrt(k (1/J_t + 1/(J_m i^2))), the
/// motor swinging against the table).
pub fn mesh_modes(m: &Mechanism) -> (f64, f64) {
    let k = m.mesh_stiffness_nm_per_rad;
    let j_t = m.table_inertia_kg_m2;
    let j_m_at_table = m.motor_inertia_kg_m2 * m.worm_ratio.powi(2);
    (
        (k / j_t).sqrt() / TAU,
        (k * (1.0 / j_t + 1.0 / j_m_at_table)).sqrt() / TAU,
    )
}

// State indices of the sampled cascade: the plant (motor angle, motor speed, twist = motor
// angle - table angle in motor units, table speed in motor units), then the loops (the
// motor angle's change since the last sample, the last speed estimate, the integral).
const ANGLE: usize = 0;
const TWIST_DIFF: usize = 4;
const ESTIMATE: usize = 5;
const INTEGRAL: usize = 6;

type Matrix7 = SMatrix<f64, 7, 7>;
type Vector7 = SVector<f64, 7>;

/// The plant sampled with a zero-order hold: x+ = phi x + gamma u, states as above.
#[derive(Debug, Clone, Copy)]
struct SampledPlant {
    phi: Matrix4<f64>,
    gamma: Vector4<f64>,
    period_s: f64,
}

impl SampledPlant {
    fn new(m: &Mechanism, period_s: f64) -> Self {
        let (j_t, k, c) = m.at_motor();
        let j_m = m.motor_inertia_kg_m2;
        // [angle, speed, twist, table speed]: d/dt, and the torque's column.
        #[rustfmt::skip]
        let a = Matrix4::new(
            0.0, 1.0, 0.0, 0.0,
            0.0, -c / j_m, -k / j_m, c / j_m,
            0.0, 1.0, 0.0, -1.0,
            0.0, c / j_t, k / j_t, -c / j_t,
        );
        let b = Vector4::new(0.0, 1.0 / j_m, 0.0, 0.0);
        let mut augmented = Matrix5::zeros();
        augmented.fixed_view_mut::<4, 4>(0, 0).copy_from(&(a * period_s));
        augmented.fixed_view_mut::<4, 1>(0, 4).copy_from(&(b * period_s));
        let e = augmented.exp();
        Self {
            phi: e.fixed_view::<4, 4>(0, 0).into_owned(),
            gamma: e.fixed_view::<4, 1>(0, 4).into_owned(),
            period_s,
        }
    }

    /// Torque held over the sample -> motor angle at the samples, rad/Nm, at z.
    fn response(&self, z: Complex<f64>) -> Complex<f64> {
        let m = Matrix4::<Complex<f64>>::identity() * z - self.phi.map(Complex::from);
        match m.lu().solve(&self.gamma.map(Complex::from)) {
            Some(x) => x[ANGLE],
            None => Complex::new(f64::INFINITY, 0.0),
        }
    }
}

/// The sampled cascade closed: X+ = a X + b_speed (kv r + ff_gain ff), with r the
/// reference (rad at the motor) and ff the interpolation segment's speed (rad/s), both at
/// the sample.
#[derive(Debug, Clone)]
pub struct LoopModel {
    a: Matrix7,
    b_speed: Vector7,
    loops: DriveLoops,
}

impl LoopModel {
    /// The loops `d` on the mechanism `m`, sampled at `d.loop_period_s`.
    pub fn new(m: &Mechanism, d: &DriveLoops) -> Self {
        Self::on(&SampledPlant::new(m, d.loop_period_s), d)
    }

    fn on(s: &SampledPlant, d: &DriveLoops) -> Self {
        let t = s.period_s;
        let a_f = d.filter_weight();
        let kp = d.velocity_kp_nm_s_per_rad;
        let ki_t = d.velocity_ki_nm_per_rad() * t;
        // Speed error e = e_row X + (kv r + ff_gain ff); torque u = kp e + integral.
        let mut e_row = Vector7::zeros();
        e_row[ANGLE] = -d.position_kv_per_s;
        e_row[TWIST_DIFF] = -a_f / t;
        e_row[ESTIMATE] = -(1.0 - a_f);
        let mut u_row = e_row * kp;
        u_row[INTEGRAL] += 1.0;
        let mut a = Matrix7::zeros();
        for i in 0..4 {
            for j in 0..4 {
                a[(i, j)] = s.phi[(i, j)];
            }
            for j in 0..7 {
                a[(i, j)] += s.gamma[i] * u_row[j];
            }
        }
        // The angle's change over the coming sample: angle+ - angle.
        for j in 0..7 {
            a[(TWIST_DIFF, j)] = a[(ANGLE, j)];
        }
        a[(TWIST_DIFF, ANGLE)] -= 1.0;
        a[(ESTIMATE, TWIST_DIFF)] = a_f / t;
        a[(ESTIMATE, ESTIMATE)] = 1.0 - a_f;
        for j in 0..7 {
            a[(INTEGRAL, j)] = ki_t * e_row[j];
        }
        a[(INTEGRAL, INTEGRAL)] += 1.0;
        let mut b_speed = Vector7::zeros();
        for i in 0..4 {
            b_speed[i] = s.gamma[i] * kp;
        }
        b_speed[TWIST_DIFF] = s.gamma[ANGLE] * kp;
        b_speed[INTEGRAL] = ki_t;
        Self {
            a,
            b_speed,
            loops: *d,
        }
    }

    /// The closed loop's poles (z plane). The motor's angle is left out when there is no
    /// position loop (kv 0: a pole at 1 the loops do not act on), the integral when there
    /// is no integral action.
    pub fn poles(&self) -> Vec<Complex<f64>> {
        let mut a = DMatrix::from_column_slice(7, 7, self.a.as_slice());
        if self.loops.velocity_ki_nm_per_rad() == 0.0 {
            a = a.remove_row(INTEGRAL).remove_column(INTEGRAL);
        }
        if self.loops.position_kv_per_s == 0.0 {
            a = a.remove_row(ANGLE).remove_column(ANGLE);
        }
        a.complex_eigenvalues().iter().copied().collect()
    }

    /// The largest pole's radius |z| and its frequency, |arg z| / (2 pi T), Hz.
    pub fn largest_pole(&self) -> (f64, f64) {
        let t = self.loops.loop_period_s;
        self.poles()
            .into_iter()
            .map(|p| (p.norm(), p.arg().abs() / (TAU * t)))
            .fold((0.0, 0.0), |best, p| if p.0 > best.0 { p } else { best })
    }

    /// (motor angle / reference, motor angle / segment speed in rad/s) at z: the loops'
    /// two inputs taken apart.
    fn responses(&self, z: Complex<f64>) -> (Complex<f64>, Complex<f64>) {
        let m = SMatrix::<Complex<f64>, 7, 7>::identity() * z - self.a.map(Complex::from);
        let x = match m.lu().solve(&self.b_speed.map(Complex::from)) {
            Some(x) => x[ANGLE],
            None => Complex::new(f64::NAN, f64::NAN),
        };
        (
            x * self.loops.position_kv_per_s,
            x * self.loops.velocity_feed_forward,
        )
    }

    /// The motor's angle over the drive's reference at the loop samples, at `f_hz`
    /// (dimensionless; the same in table units, both divided by the ratio). The reference
    /// is a sampled sine, the feed-forward its forward difference / T: exactly what the
    /// drive's linear interpolation between targets gives, where feed-forward is the
    /// segment's slope. Excludes the CSP interpolation itself: see
    /// [`LoopModel::target_response`].
    pub fn position_response(&self, f_hz: f64) -> Complex<f64> {
        let t = self.loops.loop_period_s;
        let z = Complex::from_polar(1.0, TAU * f_hz * t);
        let (r, ff) = self.responses(z);
        r + ff * (z - 1.0) / t
    }

    /// The motor's angle read at each SYNC over the CSP target sent for it, at `f_hz`:
    /// servo.rs's interpolation (the segment from the previous target to this SYNC's,
    /// reached one period plus `extra_delay_s` after it; extrapolated for a negative extra
    /// delay), its segment's speed as feed-forward, the loops, and the images of the
    /// interpolation at f + q / P folded back by reading once per SYNC. Assumes the loops
    /// sample at the SYNC and every T after it; the SYNC period is taken as the nearest
    /// whole number of loop periods. Valid for |extra delay| < one SYNC period.
    pub fn target_response(&self, csp: &CspTiming, f_hz: f64) -> Complex<f64> {
        let t = self.loops.loop_period_s;
        let n = (csp.sync_period_s / t).round().max(1.0) as usize;
        let period = n as f64 * t;
        let w = TAU * f_hz;
        // With target k = e^{j w k P}: the reference and the segment speed at sample
        // k n + m, over e^{j w (k n + m) T}.
        let target = |j: f64| Complex::from_polar(1.0, w * j * period);
        let (mut g, mut h) = (vec![Complex::default(); n], vec![Complex::default(); n]);
        for m in 0..n {
            let share = (m as f64 * t - csp.extra_delay_s) / period;
            let (from, f) = if share < 0.0 {
                (-2.0, (share + 1.0).max(0.0))
            } else {
                (-1.0, share.min(1.0 + (-csp.extra_delay_s / period).max(0.0)))
            };
            let back = Complex::from_polar(1.0, -w * m as f64 * t);
            g[m] = back * (target(from) * (1.0 - f) + target(from + 1.0) * f);
            h[m] = back * (target(from + 1.0) - target(from)) / period;
        }
        (0..n)
            .map(|q| {
                let dft = |v: &[Complex<f64>]| -> Complex<f64> {
                    v.iter()
                        .enumerate()
                        .map(|(m, x)| x * Complex::from_polar(1.0, -TAU * (q * m) as f64 / n as f64))
                        .sum::<Complex<f64>>()
                        / n as f64
                };
                let z = Complex::from_polar(1.0, (w + TAU * q as f64 / period) * t);
                let (r, ff) = self.responses(z);
                dft(&g) * r + dft(&h) * ff
            })
            .sum()
    }
}

/// How the CSP targets reach the drive: one per SYNC, interpolated linearly.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CspTiming {
    /// The SYNC period, s (1 ms on the machine).
    pub sync_period_s: f64,
    /// How much later than one period after its SYNC the reference reaches a target, s
    /// (servo.rs's `extra_delay_s`; negative: sooner, extrapolating).
    pub extra_delay_s: f64,
}

/// [`LoopModel::position_response`] of the loops `d` on `m`.
pub fn position_response(m: &Mechanism, d: &DriveLoops, f_hz: f64) -> Complex<f64> {
    LoopModel::new(m, d).position_response(f_hz)
}

/// [`LoopModel::target_response`] of the loops `d` on `m`.
pub fn target_response(m: &Mechanism, d: &DriveLoops, csp: &CspTiming, f_hz: f64) -> Complex<f64> {
    LoopModel::new(m, d).target_response(csp, f_hz)
}

/// Stability margins of an open loop (broken at the torque), as loop.py's `gm_pm`: the
/// smallest upper gain margin at a -180 deg crossing where |L| < 1, and the smallest phase
/// margin 180 - |phase| at any 0 dB crossing, on a grid of 3000 log-spaced frequencies from
/// 1 rad/s to 0.999 of Nyquist, each crossing interpolated between its grid points. Without
/// such a crossing the margin and its frequency are infinite.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Margins {
    pub gain_margin_db: f64,
    /// Where the phase crosses -180 deg, Hz.
    pub phase_crossover_hz: f64,
    pub phase_margin_deg: f64,
    /// Where the gain crosses 0 dB, Hz.
    pub gain_crossover_hz: f64,
}

impl Margins {
    /// At least `gain_db` and `phase_deg`.
    pub fn at_least(&self, gain_db: f64, phase_deg: f64) -> bool {
        self.gain_margin_db >= gain_db && self.phase_margin_deg >= phase_deg
    }
}

/// The drive's loops on the mechanism: stable, with the margins of the velocity loop alone
/// (L_v = C F D G) and of the cascade (L = C (F D + kv) G), both broken at the torque; or
/// unstable, with the largest closed-loop pole.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Stability {
    Stable {
        velocity: Margins,
        cascade: Margins,
    },
    /// `largest_pole_radius` |z| >= 1, `near_hz` its frequency, |arg z| / (2 pi T).
    Unstable {
        largest_pole_radius: f64,
        near_hz: f64,
    },
}

/// The open loops on the margins' grid for one mechanism, loop period and filter: the parts
/// that do not depend on the gains, so a gain search costs only products.
#[derive(Debug, Clone)]
struct OpenLoopGrid {
    w_rad_s: Vec<f64>,
    /// T z^-1 / (1 - z^-1): the integral's sum, so that C = kp + ki this.
    integral_s: Vec<Complex<f64>>,
    /// G: the sampled plant.
    plant: Vec<Complex<f64>>,
    /// F D G: the speed estimate (filter and difference) of the plant's response.
    speed: Vec<Complex<f64>>,
}

const GRID_POINTS: usize = 3000;

impl OpenLoopGrid {
    fn new(s: &SampledPlant, filter_hz: f64) -> Self {
        let t = s.period_s;
        let top = (PI / t * 0.999).log10();
        let w_rad_s: Vec<f64> = (0..GRID_POINTS)
            .map(|k| 10f64.powf(top * k as f64 / (GRID_POINTS - 1) as f64))
            .collect();
        let a = 1.0 - (-TAU * filter_hz * t).exp();
        let zi: Vec<_> = w_rad_s.iter().map(|w| Complex::from_polar(1.0, -w * t)).collect();
        let plant: Vec<_> = zi.iter().map(|&zi| s.response(zi.inv())).collect();
        let speed = zi
            .iter()
            .zip(&plant)
            .map(|(&zi, g)| a / (1.0 - zi * (1.0 - a)) * (1.0 - zi) / t * g)
            .collect();
        let integral_s = zi.iter().map(|&zi| zi * t / (1.0 - zi)).collect();
        Self {
            w_rad_s,
            integral_s,
            plant,
            speed,
        }
    }

    fn velocity_margins(&self, d: &DriveLoops) -> Margins {
        let (kp, ki) = (d.velocity_kp_nm_s_per_rad, d.velocity_ki_nm_per_rad());
        margins_on(&self.w_rad_s, |k| (self.integral_s[k] * ki + kp) * self.speed[k])
    }

    fn cascade_margins(&self, d: &DriveLoops) -> Margins {
        let (kp, ki, kv) = (
            d.velocity_kp_nm_s_per_rad,
            d.velocity_ki_nm_per_rad(),
            d.position_kv_per_s,
        );
        margins_on(&self.w_rad_s, |k| {
            (self.integral_s[k] * ki + kp) * (self.speed[k] + self.plant[k] * kv)
        })
    }
}

/// The margins of the open loop `l(k)` at the grid's frequencies `w_rad_s` (ascending).
/// Crossings are found by signs (|L| against 1; Im L with Re L < 0), and interpolated in
/// log frequency, dB and phase.
fn margins_on(w_rad_s: &[f64], l: impl Fn(usize) -> Complex<f64>) -> Margins {
    let mut out = Margins {
        gain_margin_db: f64::INFINITY,
        phase_crossover_hz: f64::INFINITY,
        phase_margin_deg: f64::INFINITY,
        gain_crossover_hz: f64::INFINITY,
    };
    let mut b = l(0);
    for k in 0..w_rad_s.len().saturating_sub(1) {
        let a = b;
        b = l(k + 1);
        let phase_crossing = a.re < 0.0 && (a.im < 0.0) != (b.im < 0.0);
        let gain_crossing = (a.norm_sqr() < 1.0) != (b.norm_sqr() < 1.0);
        if !phase_crossing && !gain_crossing {
            continue;
        }
        let (db_a, db_b) = (10.0 * a.norm_sqr().log10(), 10.0 * b.norm_sqr().log10());
        let ph_a = a.arg();
        let step = (b / a).arg();
        let hz_at = |t: f64| (w_rad_s[k].ln() * (1.0 - t) + w_rad_s[k + 1].ln() * t).exp() / TAU;
        if phase_crossing {
            let target = if ph_a > 0.0 { PI } else { -PI };
            let t = ((target - ph_a) / step).clamp(0.0, 1.0);
            let db = db_a + t * (db_b - db_a);
            if db < 0.0 && -db < out.gain_margin_db {
                out.gain_margin_db = -db;
                out.phase_crossover_hz = hz_at(t);
            }
        }
        if gain_crossing {
            let t = db_a / (db_a - db_b);
            let phase = Complex::from_polar(1.0, ph_a + t * step).arg();
            let pm = 180.0 - phase.to_degrees().abs();
            if pm < out.phase_margin_deg {
                out.phase_margin_deg = pm;
                out.gain_crossover_hz = hz_at(t);
            }
        }
    }
    out
}

/// The velocity loop's margins (position loop open), whatever the stability.
pub fn velocity_margins(m: &Mechanism, d: &DriveLoops) -> Margins {
    OpenLoopGrid::new(&SampledPlant::new(m, d.loop_period_s), d.velocity_filter_hz).velocity_margins(d)
}

/// The cascade's margins (broken at the torque), whatever the stability.
pub fn cascade_margins(m: &Mechanism, d: &DriveLoops) -> Margins {
    OpenLoopGrid::new(&SampledPlant::new(m, d.loop_period_s), d.velocity_filter_hz).cascade_margins(d)
}

/// Stable or not from the sampled cascade's closed-loop poles (as loop.py's
/// `closed_loop_poles`); if stable, the margins of the velocity loop and of the cascade.
pub fn stability(m: &Mechanism, d: &DriveLoops) -> Stability {
    let s = SampledPlant::new(m, d.loop_period_s);
    let (radius, hz) = LoopModel::on(&s, d).largest_pole();
    if radius >= 1.0 {
        return Stability::Unstable {
            largest_pole_radius: radius,
            near_hz: hz,
        };
    }
    let grid = OpenLoopGrid::new(&s, d.velocity_filter_hz);
    Stability::Stable {
        velocity: grid.velocity_margins(d),
        cascade: grid.cascade_margins(d),
    }
}

/// The search's requirements (docs/mechanism.md section 2 (b)).
pub const VELOCITY_GAIN_MARGIN_DB: f64 = 6.0;
pub const VELOCITY_PHASE_MARGIN_DEG: f64 = 45.0;
pub const CASCADE_GAIN_MARGIN_DB: f64 = 6.0;
pub const CASCADE_PHASE_MARGIN_DEG: f64 = 40.0;
/// The searches' ranges and steps, Hz (then bisected to 1/1024 of a step).
const VELOCITY_SCAN_HZ: (f64, f64) = (400.0, 1.0);
const POSITION_SCAN_HZ: (f64, f64) = (100.0, 0.5);

/// Gains proposed by [`propose`], with their margins.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Proposal {
    pub loops: DriveLoops,
    /// The parameters in servo.rs's terms (the rigid formula on the tuned inertia), Hz.
    pub velocity_loop_hz: f64,
    pub position_loop_hz: f64,
    pub velocity: Margins,
    pub cascade: Margins,
}

/// As loop.py's search: the largest `velocity_loop_hz` (servo.rs's formula on
/// `tuned_inertia_kg_m2`, the rigid inertia if None) up to 400 Hz whose velocity loop is
/// stable with GM >= 6 dB and PM >= 45 deg, then the largest `position_loop_hz` up to 100 Hz
/// whose cascade is stable with GM >= 6 dB and PM >= 40 deg. Scans in steps of 1 Hz and
/// 0.5 Hz, the largest passing step then bisected against the next (10 halvings).
/// Deterministic; about 10 ms in a release build. None if no velocity or no position loop
/// qualifies.
pub fn propose(
    m: &Mechanism,
    loop_period_s: f64,
    filter_hz: f64,
    tuned_inertia_kg_m2: Option<f64>,
) -> Option<Proposal> {
    let s = SampledPlant::new(m, loop_period_s);
    let grid = OpenLoopGrid::new(&s, filter_hz);
    let j = tuned_inertia_kg_m2.unwrap_or_else(|| m.rigid_inertia_kg_m2());
    let loops = |v_hz, p_hz| DriveLoops::from_bandwidths(j, v_hz, p_hz, loop_period_s, filter_hz);
    let velocity_ok = |v_hz| {
        let d = loops(v_hz, 0.0);
        grid.velocity_margins(&d)
            .at_least(VELOCITY_GAIN_MARGIN_DB, VELOCITY_PHASE_MARGIN_DEG)
            && LoopModel::on(&s, &d).largest_pole().0 < 1.0
    };
    let velocity_loop_hz = largest_passing(VELOCITY_SCAN_HZ, velocity_ok)?;
    let cascade_ok = |p_hz| {
        let d = loops(velocity_loop_hz, p_hz);
        grid.cascade_margins(&d)
            .at_least(CASCADE_GAIN_MARGIN_DB, CASCADE_PHASE_MARGIN_DEG)
            && LoopModel::on(&s, &d).largest_pole().0 < 1.0
    };
    let position_loop_hz = largest_passing(POSITION_SCAN_HZ, cascade_ok)?;
    let d = loops(velocity_loop_hz, position_loop_hz);
    Some(Proposal {
        loops: d,
        velocity_loop_hz,
        position_loop_hz,
        velocity: grid.velocity_margins(&d),
        cascade: grid.cascade_margins(&d),
    })
}

/// The largest of step, 2 step, ... up to `top` that passes, refined against the next
/// step by bisection (the lower end always passing); None if none passes.
fn largest_passing((top, step): (f64, f64), ok: impl Fn(f64) -> bool) -> Option<f64> {
    let steps = (top / step).round() as usize;
    let best = (1..=steps).rev().map(|k| k as f64 * step).find(|&f| ok(f))?;
    if best + step > top + 1e-9 {
        return Some(best);
    }
    let (mut lo, mut hi) = (best, best + step);
    for _ in 0..10 {
        let mid = 0.5 * (lo + hi);
        if ok(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(lo)
}
