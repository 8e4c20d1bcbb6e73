//! How hard the simulated machine disturbs the gearbox: the levels the accuracy benchmark
//! and gate measure at (hob-bench) and the plant's own tests cut at, with the goal each is
//! held to.

use crate::config::PlantConfig;
use serde::{Deserialize, Serialize};

/// How hard the plant disturbs the gearbox.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Disturbance {
    /// No cutting torque, no ripple, no SYNC jitter.
    None,
    /// `config/plant.toml` as it is (thesis cutting torque, 5 % ripple, +-20 us jitter).
    Nominal,
    /// Cutting torque x1.5, ripple x3, SYNC jitter x2.5.
    Heavy,
    /// Nominal, but the SYNC late by the loop's wake-up latency as measured, with its tail
    /// (`crate::config::MEASURED_VM_SYNC_LATE_US`), instead of uniform jitter.
    #[serde(rename = "measured-sync")]
    MeasuredSync,
}

impl Disturbance {
    pub const ALL: [Disturbance; 4] = [
        Disturbance::None,
        Disturbance::Nominal,
        Disturbance::Heavy,
        Disturbance::MeasuredSync,
    ];

    pub fn apply(self, p: &PlantConfig) -> PlantConfig {
        let mut p = p.clone();
        match self {
            Disturbance::None => {
                p.spindle.cutting_torque_nm = 0.0;
                p.spindle.cutting_ripple = 0.0;
                p.simulation.sync_jitter_us = 0.0;
            }
            Disturbance::Nominal => {}
            Disturbance::Heavy => {
                p.spindle.cutting_torque_nm *= 1.5;
                p.spindle.cutting_ripple *= 3.0;
                p.simulation.sync_jitter_us *= 2.5;
            }
            Disturbance::MeasuredSync => {
                p.simulation.sync_late_quantiles_us = crate::config::MEASURED_VM_SYNC_LATE_US.to_vec();
            }
        }
        p
    }

    /// Issue 16's goal for the controller's share of the finished gear's f_pt and F_p: a
    /// quarter of this ISO 1328-1 grade's tolerances (grade 5 under the heavy disturbance).
    pub fn goal_grade(self) -> u8 {
        match self {
            Disturbance::Heavy => 5,
            _ => 4,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Disturbance::None => "none",
            Disturbance::Nominal => "nominal",
            Disturbance::Heavy => "heavy",
            Disturbance::MeasuredSync => "measured-sync",
        }
    }
}
