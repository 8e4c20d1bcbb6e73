//! The lost motion of the table drive from a gauge on the table: pure, no bus.
//!
//! The table is jogged slowly one way, back, and the first way again. In a steady jog the
//! worm drives the wheel on one flank: the motor (its encoder, converted to the table's
//! angle by the drive's ratio) stands ahead of the table by half the lost motion `h` in
//! the jog's sense. The gauge reads the table: `g = G(table)`, with a scale and a radius
//! nobody needs to know, and a little curvature. Compared at the same gauge reading (the
//! same table position, so the wheel's pitch errors and the gauge's own nonlinearity cancel)
//! `motor = P(g) + h` moving + and `P(g) - h` moving -, `P` a cubic shared by all jogs: one
//! least-squares fit over the gauge range every jog covered gives `L = 2 h`.
//!
//! Each jog is used from where the gauge follows the motor steadily: after the reversal
//! the motor first crosses the play while the table stands, then takes the table along.
//! The steady part is found from the jog's end backwards (a line through its last half,
//! extended while the readings stay on it), so no play is assumed.

use nalgebra::{DMatrix, DVector};

/// One cycle of a jog: the motor's position as table angle, the command, and the gauge
/// when it was latched with it (NaN otherwise).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GaugeSample {
    pub table_deg: f64,
    pub command_deg: f64,
    pub gauge_counts: f64,
}

/// Which way a jog turns the table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Way {
    Positive,
    Negative,
}

impl Way {
    fn sign(self) -> f64 {
        match self {
            Way::Positive => 1.0,
            Way::Negative => -1.0,
        }
    }
}

/// The samples of one jog, in order.
#[derive(Debug, Clone, PartialEq)]
pub struct Jog {
    pub way: Way,
    pub samples: Vec<GaugeSample>,
}

/// Why no lost motion could be found.
#[derive(Debug, Clone, PartialEq)]
pub enum FitError {
    /// A jog had too few steady readings of the gauge (`jog` is 1-based).
    TooFewReadings {
        jog: usize,
        readings: usize,
        needed: usize,
    },
    /// The gauge did not move with the table (not touching, not wired, out of its range).
    GaugeStill { jog: usize },
    /// The gauge read the end of the coupler's input range: beyond its stroke, or not set
    /// to zero where the table stands.
    GaugeAtItsEnd { jog: usize },
    /// The jogs covered too little of the same gauge range.
    NoOverlap { readings: usize },
    /// Not a jog each way.
    OneWay,
    /// The fit is singular (the gauge constant).
    Singular,
}

impl std::fmt::Display for FitError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FitError::TooFewReadings {
                jog,
                readings,
                needed,
            } => write!(
                f,
                "jog {jog}: {readings} steady readings of the gauge, {needed} needed (a longer \
                 jog, or a gauge that is sent)"
            ),
            FitError::GaugeStill { jog } => write!(
                f,
                "jog {jog}: the gauge did not move with the table (is it touching the table, \
                 within its stroke, on the input the machine file names?)"
            ),
            FitError::NoOverlap { readings } => write!(
                f,
                "the jogs met on too little of the same table travel ({readings} readings): \
                 jog longer"
            ),
            FitError::GaugeAtItsEnd { jog } => write!(
                f,
                "jog {jog}: the gauge reads the end of its input range (beyond its stroke): set \
                 it to zero where the table stands, or jog less far"
            ),
            FitError::OneWay => write!(f, "a jog each way is needed"),
            FitError::Singular => write!(f, "the gauge's readings do not span a range to fit"),
        }
    }
}

/// The steady readings of one jog: (motor arcsec, gauge counts).
#[derive(Debug, Clone, PartialEq)]
pub struct Window {
    pub way: Way,
    pub points: Vec<(f64, f64)>,
}

/// A jog needs this many steady gauge readings.
pub const MIN_READINGS: usize = 12;
/// The coupler's 16-bit input's ends, counts (-32768 and 32767).
const INPUT_END: f64 = 32767.0;
/// Readings kept off the start of the steady part (the table's last settling).
const MARGIN: usize = 2;

/// The readings of `jog` (number `n`, 1-based) where the command ran at one speed and the
/// gauge followed the motor on a line.
pub fn window(jog: &Jog, n: usize) -> Result<Window, FitError> {
    // The command's steady run: every step the jog's (the last run of equal steps).
    let s = &jog.samples;
    let mut start = s.len();
    let step_of = |i: usize| s[i].command_deg - s[i - 1].command_deg;
    if s.len() >= 2 {
        let last = step_of(s.len() - 1);
        start = s.len() - 1;
        while start > 1 && last != 0.0 && (step_of(start - 1) - last).abs() <= 1e-9 * last.abs().max(1e-9) {
            start -= 1;
        }
    }
    let pts: Vec<(f64, f64)> = s[start.min(s.len())..]
        .iter()
        .filter(|p| p.gauge_counts.is_finite() && p.table_deg.is_finite())
        .map(|p| (p.table_deg * 3600.0, p.gauge_counts))
        .collect();
    let few = |readings| FitError::TooFewReadings {
        jog: n,
        readings,
        needed: MIN_READINGS,
    };
    if pts.len() < MIN_READINGS {
        return Err(few(pts.len()));
    }
    let at_end = pts
        .iter()
        .filter(|p| p.1 >= INPUT_END || p.1 <= -INPUT_END - 1.0)
        .count();
    if 2 * at_end > pts.len() {
        return Err(FitError::GaugeAtItsEnd { jog: n });
    }
    // A line through the last half, extended back while the readings stay on it.
    let half = &pts[pts.len() / 2..];
    let (a, b, rms) = line(half).ok_or(FitError::GaugeStill { jog: n })?;
    let span = half.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max)
        - half.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
    if (b * span).abs() < 10.0 * rms.max(1.0) {
        return Err(FitError::GaugeStill { jog: n });
    }
    let tol = (6.0 * rms).max(3.0);
    let mut first = pts.len() - half.len();
    while first > 0 && (pts[first - 1].1 - (a + b * pts[first - 1].0)).abs() <= tol {
        first -= 1;
    }
    let kept: Vec<(f64, f64)> = pts[(first + MARGIN).min(pts.len())..].to_vec();
    if kept.len() < MIN_READINGS {
        return Err(few(kept.len()));
    }
    Ok(Window {
        way: jog.way,
        points: kept,
    })
}

/// Least-squares line y = a + b x through (x, y), with the RMS residual.
fn line(p: &[(f64, f64)]) -> Option<(f64, f64, f64)> {
    let n = p.len() as f64;
    let (mx, my) = (
        p.iter().map(|q| q.0).sum::<f64>() / n,
        p.iter().map(|q| q.1).sum::<f64>() / n,
    );
    let sxx: f64 = p.iter().map(|q| (q.0 - mx).powi(2)).sum();
    let sxy: f64 = p.iter().map(|q| (q.0 - mx) * (q.1 - my)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let b = sxy / sxx;
    let a = my - b * mx;
    let rms = (p.iter().map(|q| (q.1 - a - b * q.0).powi(2)).sum::<f64>() / n).sqrt();
    Some((a, b, rms))
}

/// What the jogs say of the lost motion.
#[derive(Debug, Clone, PartialEq)]
pub struct LostMotion {
    /// Arcsec of the table.
    pub arcsec: f64,
    /// Its standard error from the fit's scatter, and half the spread between the
    /// reversals (each pair of jogs on its own), whichever is larger.
    pub uncertainty_arcsec: f64,
    /// Each reversal's own figure (jogs 1-2, 2-3, ...).
    pub per_reversal_arcsec: Vec<f64>,
    /// RMS of the motor against the fit, arcsec.
    pub residual_arcsec: f64,
    /// Readings the fit used.
    pub readings: usize,
    /// The gauge range every jog covered, counts.
    pub overlap_counts: (f64, f64),
}

/// The lost motion from the jogs' windows (at least one each way).
pub fn lost_motion(windows: &[Window]) -> Result<LostMotion, FitError> {
    if !windows.iter().any(|w| w.way == Way::Positive) || !windows.iter().any(|w| w.way == Way::Negative) {
        return Err(FitError::OneWay);
    }
    let whole = joint(windows)?;
    let per_reversal: Vec<f64> = windows
        .windows(2)
        .filter(|p| p[0].way != p[1].way)
        .filter_map(|p| joint(p).ok().map(|r| r.arcsec))
        .collect();
    let spread = per_reversal.iter().fold(f64::NEG_INFINITY, |a, &b| a.max(b))
        - per_reversal.iter().fold(f64::INFINITY, |a, &b| a.min(b));
    let spread = if per_reversal.len() >= 2 {
        spread / 2.0
    } else {
        0.0
    };
    Ok(LostMotion {
        uncertainty_arcsec: whole.uncertainty_arcsec.max(spread),
        per_reversal_arcsec: per_reversal,
        ..whole
    })
}

/// The joint fit over the common gauge range (its uncertainty the standard error alone,
/// no reversal apart).
fn joint(windows: &[Window]) -> Result<LostMotion, FitError> {
    let lo = windows
        .iter()
        .map(|w| w.points.iter().map(|p| p.1).fold(f64::INFINITY, f64::min))
        .fold(f64::NEG_INFINITY, f64::max);
    let hi = windows
        .iter()
        .map(|w| w.points.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max))
        .fold(f64::INFINITY, f64::min);
    let rows: Vec<(f64, f64, f64)> = windows
        .iter()
        .flat_map(|w| {
            w.points
                .iter()
                .filter(move |p| p.1 >= lo && p.1 <= hi)
                .map(move |p| (p.0, p.1, w.way.sign()))
        })
        .collect();
    let per_window = windows
        .iter()
        .map(|w| w.points.iter().filter(|p| p.1 >= lo && p.1 <= hi).count())
        .min()
        .unwrap_or(0);
    if hi <= lo || hi.is_nan() || lo.is_nan() || per_window < MIN_READINGS / 2 {
        return Err(FitError::NoOverlap { readings: per_window });
    }
    // motor = p0 + p1 u + p2 u^2 + p3 u^3 + sign h, u the gauge scaled onto -1 .. 1.
    let (mid, half) = ((lo + hi) / 2.0, (hi - lo) / 2.0);
    let n = rows.len();
    let a = DMatrix::from_fn(n, 5, |i, j| {
        let u = (rows[i].1 - mid) / half;
        if j < 4 { u.powi(j as i32) } else { rows[i].2 }
    });
    let y = DVector::from_iterator(n, rows.iter().map(|r| r.0));
    let ata = a.transpose() * &a;
    let inv = ata.try_inverse().ok_or(FitError::Singular)?;
    let x = &inv * (a.transpose() * &y);
    let r = &y - &a * &x;
    let dof = n.saturating_sub(5).max(1) as f64;
    let s2 = r.norm_squared() / dof;
    let h = x[4];
    let sd_h = (s2 * inv[(4, 4)]).sqrt();
    Ok(LostMotion {
        arcsec: 2.0 * h,
        uncertainty_arcsec: 2.0 * sd_h,
        per_reversal_arcsec: Vec::new(),
        residual_arcsec: (r.norm_squared() / n as f64).sqrt(),
        readings: n,
        overlap_counts: (lo, hi),
    })
}

#[cfg(test)]
mod tests;
