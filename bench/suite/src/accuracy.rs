//! Accuracy: synchronisation error in the cut (RMS and max, arcsec and um at the pitch
//! circle, as a fraction of the ISO 1328-1 grade-5 single pitch tolerance) for the example
//! gears x plant disturbance level x cross-coupling on/off x predictor on/off, each a whole
//! program cut core-against-plant (`hob simulate`'s closed loop). Without the predictor the
//! synchronism windows would stop the cut within seconds, so those runs widen them (as
//! `hob simulate --no-windows`) to measure the error at all.

use crate::system::{self, SystemInfo};
use hob_control::SpindleAngleSource;
use hob_control::program::CycleProgram;
use hob_plant::config::PlantConfig;
use hob_plant::sim::{SimOptions, run_program};
use hob_setup::config::Problems;
use hob_setup::config::machine::MachineConfig;
use hob_setup::job::Program;
use hob_setup::planner;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

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
    /// (`hob_plant::config::MEASURED_VM_SYNC_LATE_US`), instead of uniform jitter.
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
                p.simulation.sync_late_quantiles_us = hob_plant::config::MEASURED_VM_SYNC_LATE_US.to_vec();
            }
        }
        p
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

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Row {
    pub gear: String,
    pub disturbance: Disturbance,
    pub cross_coupling: bool,
    pub predictor: bool,
    pub completed: bool,
    pub fault: Option<String>,
    /// Worst pass.
    pub rms_arcsec: f64,
    pub max_arcsec: f64,
    pub rms_um: f64,
    pub max_um: f64,
    /// ISO 1328-1 grade-5 single pitch tolerance f_p of this gear, um.
    pub grade5_fp_um: f64,
    /// max_um / grade5_fp_um.
    pub max_of_grade5: f64,
    /// The control core's bound (a quarter of f_p), um.
    pub bound_um: f64,
    /// The finished gear (the last pass) as ISO 1328-1 would measure it, the controller's
    /// share from the true error where each gap passed the hob (`hob_logger::predicted`):
    /// single pitch deviation f_pt and cumulative pitch deviation F_p, um, and each as a
    /// share of its grade-4 tolerance. None where the last pass completed no face section.
    #[serde(default)]
    pub finished_fpt_um: Option<f64>,
    #[serde(default)]
    pub finished_fp_um: Option<f64>,
    #[serde(default)]
    pub finished_fpt_of_grade4: Option<f64>,
    #[serde(default)]
    pub finished_fp_of_grade4: Option<f64>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AccuracyBench {
    pub system: SystemInfo,
    pub rows: Vec<Row>,
}

/// Program, disturbance, cross-coupling, predictor.
type Case = (PathBuf, Disturbance, bool, bool);

#[derive(Debug, Clone)]
pub struct Args {
    pub out: PathBuf,
    pub machine: PathBuf,
    pub plant: PathBuf,
    pub programs: Vec<PathBuf>,
    pub disturbances: Vec<Disturbance>,
}

fn one(
    machine: &MachineConfig,
    plant: &PlantConfig,
    path: &std::path::Path,
    d: Disturbance,
    ccc: bool,
    predictor: bool,
) -> Result<Row, String> {
    let (job, src) = Program::read(path).map_err(|e| e.to_string())?;
    let mut p = Problems::new();
    let cycle = CycleProgram::build(&job, machine, &mut p);
    let plan = planner::plan(&job, machine, &mut p);
    let (Some(cycle), Some(plan)) = (cycle, plan) else {
        return Err(p
            .into_result(path, &src)
            .err()
            .map_or_else(|| format!("{}: refused", path.display()), |e| e.to_string()));
    };
    let options = SimOptions {
        cross_coupling: ccc,
        angle_source: if predictor {
            SpindleAngleSource::Predicted
        } else {
            SpindleAngleSource::LastMeasured
        },
        windows_off: !predictor,
        grade: 4,
        ..SimOptions::default()
    };
    let s = run_program(
        machine,
        &d.apply(plant),
        &cycle,
        &plan,
        &job,
        &options,
        &mut |_| {},
    )?;
    let worst = |f: fn(&hob_plant::sim::PassSummary) -> f64| s.passes.iter().map(f).fold(0.0, f64::max);
    let fp = s.grade5_single_pitch_um;
    let gear = path
        .file_stem()
        .map_or_else(String::new, |n| n.to_string_lossy().to_string());
    let finished = s.passes.last().and_then(|p| p.predicted.as_ref());
    Ok(Row {
        finished_fpt_um: finished.map(|g| g.single_pitch_um),
        finished_fp_um: finished.map(|g| g.cumulative_pitch_um),
        finished_fpt_of_grade4: finished.map(|g| g.shares().0),
        finished_fp_of_grade4: finished.map(|g| g.shares().1),
        gear,
        disturbance: d,
        cross_coupling: ccc,
        predictor,
        completed: s.completed,
        fault: s.fault.clone(),
        rms_arcsec: worst(|p| p.sync_err_rms_arcsec),
        max_arcsec: worst(|p| p.sync_err_max_arcsec),
        rms_um: worst(|p| p.sync_err_rms_um),
        max_um: s.max_sync_err_um,
        grade5_fp_um: fp,
        max_of_grade5: s.max_sync_err_um / fp,
        bound_um: s.bound_um,
    })
}

pub fn run(a: &Args) -> Result<AccuracyBench, String> {
    std::fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;
    let machine = MachineConfig::load(&a.machine).map_err(|e| e.to_string())?;
    let plant = PlantConfig::load(&a.plant).map_err(|e| e.to_string())?;
    let mut cases = Vec::new();
    for p in &a.programs {
        for &d in &a.disturbances {
            for ccc in [true, false] {
                for predictor in [true, false] {
                    cases.push((p.clone(), d, ccc, predictor));
                }
            }
        }
    }
    // Independent runs: one thread per core.
    let threads = std::thread::available_parallelism().map_or(1, usize::from);
    let chunks: Vec<Vec<(usize, Case)>> = (0..threads)
        .map(|t| {
            cases
                .iter()
                .cloned()
                .enumerate()
                .filter(|(i, _)| i % threads == t)
                .collect()
        })
        .collect();
    let mut rows: Vec<(usize, Row)> = Vec::new();
    std::thread::scope(|scope| -> Result<(), String> {
        let handles: Vec<_> = chunks
            .into_iter()
            .map(|chunk| {
                let (machine, plant) = (&machine, &plant);
                scope.spawn(move || -> Result<Vec<(usize, Row)>, String> {
                    chunk
                        .into_iter()
                        .map(|(i, (p, d, ccc, pr))| one(machine, plant, &p, d, ccc, pr).map(|r| (i, r)))
                        .collect()
                })
            })
            .collect();
        for h in handles {
            rows.extend(h.join().map_err(|_| "accuracy thread panicked".to_string())??);
        }
        Ok(())
    })?;
    rows.sort_by_key(|(i, _)| *i);
    let r = AccuracyBench {
        system: system::probe(),
        rows: rows.into_iter().map(|(_, r)| r).collect(),
    };
    crate::write_json(&a.out.join("accuracy.json"), &r)?;
    Ok(r)
}

/// "0.71 (40 %)", or "-" where the last pass completed no face section.
fn share(um: Option<f64>, of: Option<f64>) -> String {
    match (um, of) {
        (Some(um), Some(of)) => format!("{um:.2} ({:.0} %)", of * 100.0),
        _ => "-".into(),
    }
}

pub fn text(r: &AccuracyBench) -> String {
    let mut o = String::from(
        "| gear | disturbance | CCC | predictor | RMS arcsec | max arcsec | RMS um | max um | max of grade-5 f_p | bound um | finished f_pt um (of grade 4) | finished F_p um (of grade 4) | result |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let onoff = |b: bool| if b { "on" } else { "off" };
    for x in &r.rows {
        o.push_str(&format!(
            "| {} | {} | {} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.0} % | {:.2} | {} | {} | {} |\n",
            x.gear,
            x.disturbance.name(),
            onoff(x.cross_coupling),
            onoff(x.predictor),
            x.rms_arcsec,
            x.max_arcsec,
            x.rms_um,
            x.max_um,
            x.max_of_grade5 * 100.0,
            x.bound_um,
            share(x.finished_fpt_um, x.finished_fpt_of_grade4),
            share(x.finished_fp_um, x.finished_fp_of_grade4),
            match &x.fault {
                Some(f) => format!("fault {f}"),
                None if x.completed => "done".into(),
                None => "not finished".into(),
            }
        ));
    }
    o
}
