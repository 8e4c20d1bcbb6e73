//! The table's frequency response through the worm (`hob commission response`): a held
//! sine on the table's target at stepped frequencies, the response of the table drive's
//! motor from the loop's state stream, the mesh's mode found from it, and the drive's
//! tuning checked against a model of its loops on the mechanism fitted to it.

pub mod fit;
pub mod frf;
pub mod model;

/// The sweep's settings.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ResponseOptions {
    /// The lowest and highest frequency, Hz (the highest at most a quarter of the loop's rate).
    pub from_hz: f64,
    pub to_hz: f64,
    /// Frequencies of the first sweep, spaced evenly on a log scale; as many again are
    /// added about the deepest dip (the mesh's anti-resonance).
    pub points: usize,
}

impl Default for ResponseOptions {
    fn default() -> Self {
        Self {
            from_hz: 2.0,
            to_hz: 250.0,
            points: 16,
        }
    }
}

/// How long the swing settles after its fade-in before it is read, s.
pub const SETTLE_S: f64 = 0.3;
/// Whole periods read at least at each frequency (and at least a second).
pub const PERIODS_READ: f64 = 8.0;

impl ResponseOptions {
    /// The first sweep's frequencies, Hz, lowest first.
    pub fn first_sweep(&self) -> Vec<f64> {
        let n = self.points.max(2);
        let ratio = (self.to_hz / self.from_hz).ln();
        (0..n)
            .map(|i| match i {
                _ if i == n - 1 => self.to_hz,
                _ => self.from_hz * (ratio * i as f64 / (n - 1) as f64).exp(),
            })
            .collect()
    }

    /// The frequencies added about the first sweep's deepest dip at `dip_hz` (between its
    /// neighbours `below_hz` and `above_hz`), Hz.
    pub fn refinement(&self, below_hz: f64, above_hz: f64) -> Vec<f64> {
        let n = self.points.max(2);
        let ratio = (above_hz / below_hz).ln();
        (1..=n)
            .map(|i| below_hz * (ratio * i as f64 / (n + 1) as f64).exp())
            .collect()
    }
}

/// How long the swing at `frequency_hz` is held and read, s (after its fade-in and settling).
pub fn read_s(frequency_hz: f64) -> f64 {
    (PERIODS_READ / frequency_hz).max(1.0)
}
