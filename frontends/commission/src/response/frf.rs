//! One point of a frequency response from the loop's state stream: the table drive's motor
//! (as table angle) against the table's target, both read each cycle while the target
//! swings at a known frequency. Each is fitted with that frequency's sine and cosine over
//! whole periods, together with a mean and a drift; the ratio of the two is the response. The run is cut into blocks of whole
//! periods, and the blocks' spread says how well the point is known.

use nalgebra::{Complex, Matrix4, Vector4};

/// One cycle's reading: the target the loop sent and the drive's position, deg of the table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    pub command_deg: f64,
    pub table_deg: f64,
}

/// The response at one frequency.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Point {
    pub frequency_hz: f64,
    /// The motor's position over the target's (1 at low frequency).
    #[serde(serialize_with = "complex_pair")]
    pub response: Complex<f64>,
    /// The standard error of `response` (the blocks' spread over the square root of their
    /// number).
    pub uncertainty: f64,
    /// The target's swing, deg (half peak-to-peak).
    pub amplitude_deg: f64,
}

fn complex_pair<S: serde::Serializer>(c: &Complex<f64>, s: S) -> Result<S::Ok, S::Error> {
    use serde::Serialize;
    [c.re, c.im].serialize(s)
}

impl Point {
    pub fn magnitude_db(&self) -> f64 {
        20.0 * self.response.norm().log10()
    }

    pub fn phase_deg(&self) -> f64 {
        self.response.arg().to_degrees()
    }
}

/// The index of the point whose response is smallest (the deepest dip), if any.
pub fn deepest(points: &[Point]) -> Option<usize> {
    (0..points.len()).min_by(|&a, &b| points[a].response.norm().total_cmp(&points[b].response.norm()))
}

/// Why a point could not be had.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NoPoint {
    /// Fewer whole periods than [`BLOCKS`] in the readings.
    TooShort,
    /// The target did not swing (the loop refused, or a reading went missing).
    NoSwing,
}

/// Blocks the readings are cut into.
pub const BLOCKS: usize = 4;

/// The response at `frequency_hz` from `readings` taken every `period_s`.
pub fn point(frequency_hz: f64, period_s: f64, readings: &[Reading]) -> Result<Point, NoPoint> {
    let per_period = 1.0 / (frequency_hz * period_s);
    let periods = (readings.len() as f64 / per_period).floor() as usize;
    let per_block = periods / BLOCKS;
    if per_block == 0 {
        return Err(NoPoint::TooShort);
    }
    // Whole periods a block, rounded to readings: never past the readings' own quarter
    // (1099 readings at 112.9 Hz: 31 periods are 274.6 readings, rounded 275, four of them
    // one more than there are).
    let block_len = ((per_block as f64 * per_period).round() as usize).min(readings.len() / BLOCKS);
    let w = std::f64::consts::TAU * frequency_hz * period_s;
    let mut ratios = [Complex::new(0.0, 0.0); BLOCKS];
    let mut swing = 0.0;
    for (b, ratio) in ratios.iter_mut().enumerate() {
        let block = &readings[b * block_len..(b + 1) * block_len];
        let start = b * block_len;
        let cmd = coefficient(block, w, start, |r| r.command_deg);
        let act = coefficient(block, w, start, |r| r.table_deg);
        if cmd.norm().partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return Err(NoPoint::NoSwing);
        }
        swing += cmd.norm() / BLOCKS as f64;
        *ratio = act / cmd;
    }
    let mean = ratios.iter().sum::<Complex<f64>>() / BLOCKS as f64;
    let var = ratios.iter().map(|r| (r - mean).norm_sqr()).sum::<f64>() / (BLOCKS - 1) as f64;
    Ok(Point {
        frequency_hz,
        response: mean,
        uncertainty: (var / BLOCKS as f64).sqrt(),
        amplitude_deg: swing,
    })
}

/// The complex amplitude of `value` at `w` rad per sample over `block` (whose first
/// reading is sample `start`): a least-squares fit of a mean, a straight-line drift and the
/// sine and cosine together (a drift taken out first would take part of a sine over few
/// periods with it).
fn coefficient(block: &[Reading], w: f64, start: usize, value: impl Fn(&Reading) -> f64) -> Complex<f64> {
    let mid = (block.len() as f64 - 1.0) / 2.0;
    let mut ata = Matrix4::<f64>::zeros();
    let mut atb = Vector4::<f64>::zeros();
    for (i, r) in block.iter().enumerate() {
        let phase = w * (start + i) as f64;
        let row = Vector4::new(1.0, (i as f64 - mid) / mid.max(1.0), phase.cos(), phase.sin());
        ata += row * row.transpose();
        atb += row * value(r);
    }
    match ata.cholesky() {
        Some(c) => {
            let x = c.solve(&atb);
            Complex::new(x[2], -x[3])
        }
        None => Complex::new(0.0, 0.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn readings(f_hz: f64, gain: f64, lag_rad: f64, n: usize, drift: f64) -> Vec<Reading> {
        (0..n)
            .map(|k| {
                let t = k as f64 * 1e-3;
                let a = std::f64::consts::TAU * f_hz * t;
                Reading {
                    command_deg: 10.0 + 0.01 * a.sin(),
                    table_deg: 10.0 + drift * t + 0.01 * gain * (a - lag_rad).sin(),
                }
            })
            .collect()
    }

    #[test]
    fn a_known_gain_and_lag_are_found_through_a_drift() {
        for f in [2.0, 13.7, 50.0, 240.0] {
            let p = point(f, 1e-3, &readings(f, 0.7, 0.9, 2000, 0.3)).unwrap();
            assert!((p.response.norm() - 0.7).abs() < 2e-3, "{f}: {p:?}");
            assert!((p.response.arg() + 0.9).abs() < 3e-3, "{f}: {p:?}");
            assert!((p.amplitude_deg - 0.01).abs() < 1e-4, "{f}: {p:?}");
            assert!(p.uncertainty < 2e-3, "{f}: {p:?}");
        }
    }

    #[test]
    fn blocks_rounded_up_never_run_past_the_readings() {
        // The count a run over the bus left (frequency and readings as in the service test
        // that panicked): four blocks of 275 readings asked of 1099.
        for (f, n) in [(112.9, 1099), (112.9, 1100), (71.6, 1097), (250.0, 1001)] {
            let p = point(f, 1e-3, &readings(f, 0.7, 0.9, n, 0.3)).unwrap();
            assert!((p.response.norm() - 0.7).abs() < 5e-3, "{f} {n}: {p:?}");
        }
    }

    #[test]
    fn too_few_periods_or_no_swing_give_no_point() {
        assert_eq!(
            point(1.0, 1e-3, &readings(1.0, 1.0, 0.0, 3000, 0.0)),
            Err(NoPoint::TooShort)
        );
        let still: Vec<Reading> = (0..1000)
            .map(|_| Reading {
                command_deg: 1.0,
                table_deg: 1.0,
            })
            .collect();
        assert_eq!(point(20.0, 1e-3, &still), Err(NoPoint::NoSwing));
    }
}
