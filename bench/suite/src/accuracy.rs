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
use hob_setup::planner::{self, Plan};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// How hard the plant disturbs the gearbox (hob-plant's, shared with its tests).
pub use hob_plant::disturbance::Disturbance;

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
    /// share: from the drive's motion through an ideal worm against the law where each gap
    /// passed the hob (`hob_logger::predicted`): single pitch deviation f_pt and cumulative
    /// pitch deviation F_p, um, and each as a share of its grade-4 tolerance. None where the
    /// last pass completed no face section.
    #[serde(default)]
    pub finished_fpt_um: Option<f64>,
    #[serde(default)]
    pub finished_fp_um: Option<f64>,
    #[serde(default)]
    pub finished_fpt_of_grade4: Option<f64>,
    #[serde(default)]
    pub finished_fp_of_grade4: Option<f64>,
    /// The same for the gear itself: from the blank's true error (the worm's pitch errors,
    /// its play and compliance and the work's twist included).
    #[serde(default)]
    pub gear_fpt_um: Option<f64>,
    #[serde(default)]
    pub gear_fp_um: Option<f64>,
    #[serde(default)]
    pub gear_fpt_of_grade4: Option<f64>,
    #[serde(default)]
    pub gear_fp_of_grade4: Option<f64>,
    /// Largest blank error in the cut (the truth), arcsec, worst pass.
    #[serde(default)]
    pub blank_max_arcsec: Option<f64>,
    /// The figures above take the gaps at fixed table angles `k * 360 / z`; these take
    /// them where the hob cut them (`hob_logger::predicted::GapsAt::Hob`), as shares of
    /// grade 4: the controller's share at the hob's phase 0 and the worst over the hob's
    /// phase, and the gear itself's worst over the phase. Reported, not gated.
    #[serde(default)]
    pub hob_fpt_of_grade4: Option<f64>,
    #[serde(default)]
    pub hob_fp_of_grade4: Option<f64>,
    #[serde(default)]
    pub worst_phase_fpt_of_grade4: Option<f64>,
    #[serde(default)]
    pub worst_phase_fp_of_grade4: Option<f64>,
    #[serde(default)]
    pub gear_worst_phase_fpt_of_grade4: Option<f64>,
    #[serde(default)]
    pub gear_worst_phase_fp_of_grade4: Option<f64>,
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

/// A program built for a machine: the job, its cycle and its plan, or the refusal.
fn job_on(machine: &MachineConfig, path: &std::path::Path) -> Result<(Program, CycleProgram, Plan), String> {
    let (job, src) = hob_store::files::read_program(path).map_err(|e| e.to_string())?;
    let mut p = Problems::new();
    let cycle = CycleProgram::build(&job, machine, &mut p);
    let plan = planner::plan(&job, machine, &mut p);
    match (cycle, plan) {
        (Some(cycle), Some(plan)) => Ok((job, cycle, plan)),
        _ => Err(p
            .into_result(path, &src)
            .err()
            .map_or_else(|| format!("{}: refused", path.display()), |e| e.to_string())),
    }
}

/// A program's name in the tables: its file's stem.
fn gear_name(path: &std::path::Path) -> String {
    path.file_stem()
        .map_or_else(String::new, |n| n.to_string_lossy().to_string())
}

/// The output directory made, the machine and the plant loaded.
fn prepare(a: &Args) -> Result<(MachineConfig, PlantConfig), String> {
    std::fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;
    let machine = hob_store::files::load_machine(&a.machine).map_err(|e| e.to_string())?;
    let plant = PlantConfig::load(&a.plant).map_err(|e| e.to_string())?;
    Ok((machine, plant))
}

/// Independent whole-program runs, one thread per core: `f` of every case, in the cases'
/// order; the first error stops the bench.
fn on_every_core<C: Sync, R: Send>(
    cases: &[C],
    f: impl Fn(&C) -> Result<R, String> + Sync,
) -> Result<Vec<R>, String> {
    let threads = std::thread::available_parallelism().map_or(1, usize::from);
    let mut rows: Vec<(usize, R)> = Vec::new();
    std::thread::scope(|scope| -> Result<(), String> {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                let f = &f;
                scope.spawn(move || -> Result<Vec<(usize, R)>, String> {
                    cases
                        .iter()
                        .enumerate()
                        .filter(|(i, _)| i % threads == t)
                        .map(|(i, c)| f(c).map(|r| (i, r)))
                        .collect()
                })
            })
            .collect();
        for h in handles {
            rows.extend(
                h.join()
                    .map_err(|_| "an accuracy thread panicked".to_string())??,
            );
        }
        Ok(())
    })?;
    rows.sort_by_key(|(i, _)| *i);
    Ok(rows.into_iter().map(|(_, r)| r).collect())
}

fn one(
    machine: &MachineConfig,
    plant: &PlantConfig,
    path: &std::path::Path,
    d: Disturbance,
    ccc: bool,
    predictor: bool,
) -> Result<Row, String> {
    let (job, cycle, plan) = job_on(machine, path)?;
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
    let gear = gear_name(path);
    let finished = s.passes.last().and_then(|p| p.controller_share.as_ref());
    let gear_cut = s.passes.last().and_then(|p| p.predicted.as_ref());
    let last = s.passes.last();
    let at_hob = last
        .and_then(|p| p.controller_share_at_hob.as_ref())
        .map(|g| g.shares());
    let worst_phase = last
        .and_then(|p| p.controller_share_worst_phase.as_ref())
        .map(|g| g.shares());
    let gear_worst_phase = last
        .and_then(|p| p.predicted_worst_phase.as_ref())
        .map(|g| g.shares());
    Ok(Row {
        hob_fpt_of_grade4: at_hob.map(|g| g.0),
        hob_fp_of_grade4: at_hob.map(|g| g.1),
        worst_phase_fpt_of_grade4: worst_phase.map(|g| g.0),
        worst_phase_fp_of_grade4: worst_phase.map(|g| g.1),
        gear_worst_phase_fpt_of_grade4: gear_worst_phase.map(|g| g.0),
        gear_worst_phase_fp_of_grade4: gear_worst_phase.map(|g| g.1),
        finished_fpt_um: finished.map(|g| g.single_pitch_um),
        finished_fp_um: finished.map(|g| g.cumulative_pitch_um),
        finished_fpt_of_grade4: finished.map(|g| g.shares().0),
        finished_fp_of_grade4: finished.map(|g| g.shares().1),
        gear_fpt_um: gear_cut.map(|g| g.single_pitch_um),
        gear_fp_um: gear_cut.map(|g| g.cumulative_pitch_um),
        gear_fpt_of_grade4: gear_cut.map(|g| g.shares().0),
        gear_fp_of_grade4: gear_cut.map(|g| g.shares().1),
        blank_max_arcsec: s
            .passes
            .iter()
            .filter_map(|p| p.blank_err_max_arcsec)
            .reduce(f64::max),
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
    let (machine, plant) = prepare(a)?;
    let mut cases: Vec<Case> = Vec::new();
    for p in &a.programs {
        for &d in &a.disturbances {
            for ccc in [true, false] {
                for predictor in [true, false] {
                    cases.push((p.clone(), d, ccc, predictor));
                }
            }
        }
    }
    let r = AccuracyBench {
        system: system::probe(),
        rows: on_every_core(&cases, |(p, d, ccc, pr)| one(&machine, &plant, p, *d, *ccc, *pr))?,
    };
    crate::write_json(&a.out.join("accuracy.json"), &r)?;
    Ok(r)
}

/// A run's last column: "done", "not finished" or "fault F".
fn result(fault: Option<&str>, completed: bool) -> String {
    match fault {
        Some(f) => format!("fault {f}"),
        None if completed => "done".into(),
        None => "not finished".into(),
    }
}

/// "40 %", or "-" where not known.
fn percent(of: Option<f64>) -> String {
    of.map_or_else(|| "-".into(), |v| format!("{:.0} %", 100.0 * v))
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
        "| gear | disturbance | CCC | predictor | RMS arcsec | max arcsec | RMS um | max um | max of grade-5 f_p | bound um | controller's f_pt um (of grade 4) | controller's F_p um (of grade 4) | gear f_pt um (of grade 4) | gear F_p um (of grade 4) | at the hob's gaps, of grade 4: controller's f_pt, F_p at phase 0; worst over phase; the gear's worst | result |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let onoff = |b: bool| if b { "on" } else { "off" };
    for x in &r.rows {
        o.push_str(&format!(
            "| {} | {} | {} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.0} % | {:.2} | {} | {} | {} | {} | {}, {}; {}, {}; {}, {} | {} |\n",
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
            share(x.gear_fpt_um, x.gear_fpt_of_grade4),
            share(x.gear_fp_um, x.gear_fp_of_grade4),
            percent(x.hob_fpt_of_grade4),
            percent(x.hob_fp_of_grade4),
            percent(x.worst_phase_fpt_of_grade4),
            percent(x.worst_phase_fp_of_grade4),
            percent(x.gear_worst_phase_fpt_of_grade4),
            percent(x.gear_worst_phase_fp_of_grade4),
            result(x.fault.as_deref(), x.completed)
        ));
    }
    o
}

/// One element of the machine between the drive and the gear, switched on alone over an
/// ideal machine in the breakdown ([`breakdown`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MachinePart {
    /// A perfect wheel, no runout, no play, a stiff mesh (the table rings at 400 Hz), a hob
    /// without runout: the controller's share and the work's twist only.
    Ideal,
    /// The shipped wheel's pitch errors (its grade) alone.
    WheelPitch,
    /// The shipped worm's axial runout alone.
    WormRunout,
    /// The shipped backlash alone.
    Backlash,
    /// The shipped mesh stiffness (the table on it) alone.
    Compliance,
    /// The hob's shipped axial runout alone.
    HobRunout,
    /// Everything as shipped (`config/plant.toml`).
    Shipped,
}

impl MachinePart {
    pub const ALL: [MachinePart; 7] = [
        MachinePart::Ideal,
        MachinePart::WheelPitch,
        MachinePart::WormRunout,
        MachinePart::Backlash,
        MachinePart::Compliance,
        MachinePart::HobRunout,
        MachinePart::Shipped,
    ];

    pub fn name(self) -> &'static str {
        match self {
            MachinePart::Ideal => "ideal machine",
            MachinePart::WheelPitch => "+ wheel pitch errors",
            MachinePart::WormRunout => "+ worm runout",
            MachinePart::Backlash => "+ backlash",
            MachinePart::Compliance => "+ mesh compliance",
            MachinePart::HobRunout => "+ hob axial runout",
            MachinePart::Shipped => "all (shipped plant)",
        }
    }

    /// The plant with only this part of the machine (the worm drive's, or the hob's
    /// runout) as shipped.
    pub fn apply(self, shipped: &PlantConfig) -> PlantConfig {
        if self == MachinePart::Shipped {
            return shipped.clone();
        }
        let mut p = shipped.clone();
        let w = &mut p.table.worm;
        let step_s = f64::from(p.simulation.inner_step_us) * 1e-6;
        // A quarter of the stiffest mesh the physics step resolves (config validation).
        let stiff = 0.25 * (0.5 / step_s).powi(2) * p.table.table_inertia_kg_m2;
        let (grade, runout, backlash, stiffness) = (
            w.wheel_grade,
            w.worm_axial_runout_um,
            w.backlash_arcsec,
            w.stiffness_nm_rad,
        );
        w.wheel_grade = 0;
        w.worm_axial_runout_um = 0.0;
        w.backlash_arcsec = 0.0;
        w.stiffness_nm_rad = stiff;
        match self {
            MachinePart::WheelPitch => w.wheel_grade = grade,
            MachinePart::WormRunout => w.worm_axial_runout_um = runout,
            MachinePart::Backlash => w.backlash_arcsec = backlash,
            MachinePart::Compliance => w.stiffness_nm_rad = stiffness,
            MachinePart::Ideal | MachinePart::HobRunout | MachinePart::Shipped => {}
        }
        if self != MachinePart::HobRunout {
            p.spindle.hob_axial_runout_um = 0.0;
        }
        p
    }
}

/// One gear on one machine of the breakdown: the finished gear's deviations (grade 4).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BreakdownRow {
    pub gear: String,
    pub part: MachinePart,
    pub completed: bool,
    pub controller_fpt_um: Option<f64>,
    pub controller_fp_um: Option<f64>,
    pub gear_fpt_um: Option<f64>,
    pub gear_fp_um: Option<f64>,
    pub gear_helix_um: Option<f64>,
    pub fpt_tolerance_grade4_um: Option<f64>,
    pub fp_tolerance_grade4_um: Option<f64>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BreakdownBench {
    pub system: SystemInfo,
    pub rows: Vec<BreakdownRow>,
}

fn breakdown_one(
    machine: &MachineConfig,
    plant: &PlantConfig,
    path: &std::path::Path,
    part: MachinePart,
) -> Result<BreakdownRow, String> {
    let (job, cycle, plan) = job_on(machine, path)?;
    let options = SimOptions {
        grade: 4,
        ..SimOptions::default()
    };
    let s = run_program(
        machine,
        &part.apply(plant),
        &cycle,
        &plan,
        &job,
        &options,
        &mut |_| {},
    )?;
    let last = s.passes.last();
    let controller = last.and_then(|p| p.controller_share.as_ref());
    let gear_cut = last.and_then(|p| p.predicted.as_ref());
    Ok(BreakdownRow {
        gear: gear_name(path),
        part,
        completed: s.completed,
        controller_fpt_um: controller.map(|g| g.single_pitch_um),
        controller_fp_um: controller.map(|g| g.cumulative_pitch_um),
        gear_fpt_um: gear_cut.map(|g| g.single_pitch_um),
        gear_fp_um: gear_cut.map(|g| g.cumulative_pitch_um),
        gear_helix_um: gear_cut.map(|g| g.helix_um),
        fpt_tolerance_grade4_um: gear_cut.map(|g| g.single_pitch_tolerance_um),
        fp_tolerance_grade4_um: gear_cut.map(|g| g.cumulative_pitch_tolerance_um),
    })
}

/// Where the finished gear's deviations come from: each program at the nominal
/// disturbance, cross-coupling and predictor on, on an ideal machine and with each part of
/// the worm drive alone, then all of them (`hob-bench accuracy --breakdown`).
pub fn breakdown(a: &Args) -> Result<BreakdownBench, String> {
    let (machine, plant) = prepare(a)?;
    let cases: Vec<(PathBuf, MachinePart)> = a
        .programs
        .iter()
        .flat_map(|p| MachinePart::ALL.map(|m| (p.clone(), m)))
        .collect();
    let r = BreakdownBench {
        system: system::probe(),
        rows: on_every_core(&cases, |(p, m)| breakdown_one(&machine, &plant, p, *m))?,
    };
    crate::write_json(&a.out.join("breakdown.json"), &r)?;
    std::fs::write(a.out.join("breakdown.svg"), breakdown_svg(&r)).map_err(|e| e.to_string())?;
    Ok(r)
}

/// The breakdown as a picture: per gear, the controller's share of f_pt (on the ideal
/// machine) and the gear's f_pt with each part of the machine alone and all together, in
/// percent of grade 4, against the goal (25 %) and the tolerance (100 %).
pub fn breakdown_svg(r: &BreakdownBench) -> String {
    let mut gears: Vec<&str> = r.rows.iter().map(|x| x.gear.as_str()).collect();
    gears.dedup();
    let pct = |v: Option<f64>, t: Option<f64>| match (v, t) {
        (Some(v), Some(t)) if t > 0.0 => Some(100.0 * v / t),
        _ => None,
    };
    let groups: Vec<crate::plot::BarGroup> = gears
        .iter()
        .map(|g| {
            let rows: Vec<&BreakdownRow> = r.rows.iter().filter(|x| x.gear == *g).collect();
            let mut bars = Vec::new();
            if let Some(ideal) = rows.iter().find(|x| x.part == MachinePart::Ideal)
                && let Some(v) = pct(ideal.controller_fpt_um, ideal.fpt_tolerance_grade4_um)
            {
                bars.push(("controller's share".to_string(), v));
            }
            for x in &rows {
                if let Some(v) = pct(x.gear_fpt_um, x.fpt_tolerance_grade4_um) {
                    bars.push((format!("gear, {}", x.part.name()), v));
                }
            }
            crate::plot::BarGroup {
                label: (*g).to_string(),
                bars,
            }
        })
        .filter(|g| !g.bars.is_empty())
        .collect();
    crate::plot::bars_svg(
        "Finished gear's f_pt, % of ISO 1328-1 grade 4 (nominal disturbance; hob-bench accuracy --breakdown)",
        &groups,
        &[(25.0, "goal for the controller's share"), (100.0, "grade 4")],
    )
}

pub fn breakdown_text(r: &BreakdownBench) -> String {
    let mut o = String::from(
        "| gear | machine | controller's f_pt um | controller's F_p um | gear f_pt um (of grade 4) | gear F_p um (of grade 4) | gear helix um | result |\n|---|---|---|---|---|---|---|---|\n",
    );
    let um = |v: Option<f64>| v.map_or_else(|| "-".to_string(), |v| format!("{v:.2}"));
    let of = |v: Option<f64>, t: Option<f64>| match (v, t) {
        (Some(v), Some(t)) => format!("{v:.2} ({:.0} %)", 100.0 * v / t),
        _ => "-".to_string(),
    };
    for x in &r.rows {
        o.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} |\n",
            x.gear,
            x.part.name(),
            um(x.controller_fpt_um),
            um(x.controller_fp_um),
            of(x.gear_fpt_um, x.fpt_tolerance_grade4_um),
            of(x.gear_fp_um, x.fp_tolerance_grade4_um),
            um(x.gear_helix_um),
            if x.completed { "done" } else { "not finished" },
        ));
    }
    o
}

/// One change of the machine or the plant from the shipped files, for the sensitivity table
/// ([`sensitivity`]): what the controller's share and the gear each depend on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Variation {
    Nominal,
    Ripple0p5,
    Ripple2,
    JitterNone,
    Jitter50,
    MeasuredSync,
    NoPll,
    NoPllMeasuredSync,
    InertiaHalf,
    InertiaDouble,
    TableUnit10000,
    BandwidthHalf,
    BandwidthDouble,
    WheelPerfect,
    WheelGrade6,
    SpindleEncoderExact,
    SpindleEncoderUnidentified,
    SpindleEncoder10000Lines,
    HobRunoutNone,
    HobRunout10,
    TpdoLate,
    RpdoLate,
    NoAxialCutForce,
}

impl Variation {
    pub const ALL: [Variation; 23] = [
        Variation::Nominal,
        Variation::Ripple0p5,
        Variation::Ripple2,
        Variation::JitterNone,
        Variation::Jitter50,
        Variation::MeasuredSync,
        Variation::NoPll,
        Variation::NoPllMeasuredSync,
        Variation::InertiaHalf,
        Variation::InertiaDouble,
        Variation::TableUnit10000,
        Variation::BandwidthHalf,
        Variation::BandwidthDouble,
        Variation::WheelPerfect,
        Variation::WheelGrade6,
        Variation::SpindleEncoderExact,
        Variation::SpindleEncoderUnidentified,
        Variation::SpindleEncoder10000Lines,
        Variation::HobRunoutNone,
        Variation::HobRunout10,
        Variation::TpdoLate,
        Variation::RpdoLate,
        Variation::NoAxialCutForce,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Variation::Nominal => "nominal (shipped files)",
            Variation::Ripple0p5 => "cutting ripple 0.5 % (5 %)",
            Variation::Ripple2 => "cutting ripple 2 % (5 %)",
            Variation::JitterNone => "SYNC jitter none (+-20 us)",
            Variation::Jitter50 => "SYNC jitter +-50 us (+-20 us)",
            Variation::MeasuredSync => "SYNC late as measured on the VM",
            Variation::NoPll => "drives without a SYNC PLL (AKD's)",
            Variation::NoPllMeasuredSync => "no SYNC PLL, SYNC late as measured",
            Variation::InertiaHalf => "table inertia x0.5, drive tuned for x1",
            Variation::InertiaDouble => "table inertia x2, drive tuned for x1",
            Variation::TableUnit10000 => "table position unit 10 000 counts/turn (2^20)",
            Variation::BandwidthHalf => "table servo loops x0.5 (16/74 Hz)",
            Variation::BandwidthDouble => "table servo loops x2",
            Variation::WheelPerfect => "worm wheel perfect (grade 4)",
            Variation::WheelGrade6 => "worm wheel grade 6 (grade 4)",
            Variation::SpindleEncoderExact => "spindle encoder exact (2500 lines, +-26 arcsec)",
            Variation::SpindleEncoderUnidentified => "spindle encoder's error not identified (5 s)",
            Variation::SpindleEncoder10000Lines => "spindle encoder 10 000 lines, +-6.5 arcsec",
            Variation::HobRunoutNone => "hob axial runout none (3 um)",
            Variation::HobRunout10 => "hob axial runout 10 um (3 um)",
            Variation::TpdoLate => "position TPDOs 1 in 1000 late (none)",
            Variation::RpdoLate => "target RPDOs 1 in 1000 late (none)",
            Variation::NoAxialCutForce => "no cut force on the hob slide (0.99 of F_c)",
        }
    }

    /// The machine and the plant with this change.
    pub fn apply(self, machine: &MachineConfig, plant: &PlantConfig) -> (MachineConfig, PlantConfig) {
        let (mut m, mut p) = (machine.clone(), plant.clone());
        let t = &mut p.table;
        match self {
            Variation::Nominal => {}
            Variation::Ripple0p5 => p.spindle.cutting_ripple = 0.005,
            Variation::Ripple2 => p.spindle.cutting_ripple = 0.02,
            Variation::JitterNone => p.simulation.sync_jitter_us = 0.0,
            Variation::Jitter50 => p.simulation.sync_jitter_us = 50.0,
            Variation::MeasuredSync => {
                p.simulation.sync_late_quantiles_us = hob_plant::config::MEASURED_VM_SYNC_LATE_US.to_vec();
            }
            Variation::NoPll => p.simulation.drive_clock_slew_percent = None,
            Variation::NoPllMeasuredSync => {
                p.simulation.drive_clock_slew_percent = None;
                p.simulation.sync_late_quantiles_us = hob_plant::config::MEASURED_VM_SYNC_LATE_US.to_vec();
            }
            Variation::InertiaHalf | Variation::InertiaDouble => {
                t.tuned_table_inertia_kg_m2 = Some(t.table_inertia_kg_m2);
                t.table_inertia_kg_m2 *= if self == Variation::InertiaHalf { 0.5 } else { 2.0 };
            }
            Variation::TableUnit10000 => m.table.encoder_counts_per_motor_rev = 10_000,
            Variation::BandwidthHalf | Variation::BandwidthDouble => {
                let k = if self == Variation::BandwidthHalf {
                    0.5
                } else {
                    2.0
                };
                t.velocity_loop_hz *= k;
                t.position_loop_hz *= k;
            }
            Variation::WheelPerfect => t.worm.wheel_grade = 0,
            Variation::WheelGrade6 => t.worm.wheel_grade = 6,
            Variation::SpindleEncoderExact => p.spindle.encoder_error_arcsec = 0.0,
            Variation::SpindleEncoderUnidentified => m.control.spindle_encoder_identification_s = 0.0,
            Variation::SpindleEncoder10000Lines => {
                // The same class of encoder, four times the lines: +-1/20 of its grating
                // period. The controller knows the lines (machine file).
                m.spindle.encoder_counts_per_rev *= 4;
                p.spindle.encoder_error_arcsec /= 4.0;
            }
            Variation::HobRunoutNone => p.spindle.hob_axial_runout_um = 0.0,
            Variation::HobRunout10 => p.spindle.hob_axial_runout_um = 10.0,
            Variation::TpdoLate => p.simulation.tpdo_late_rate = 1e-3,
            Variation::RpdoLate => p.simulation.rpdo_late_rate = 1e-3,
            Variation::NoAxialCutForce => p.y.cut_force_share = 0.0,
        }
        (m, p)
    }
}

/// One gear under one variation: the finished gear's deviations at grade 4.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SensitivityRow {
    pub gear: String,
    pub variation: Variation,
    pub completed: bool,
    pub fault: Option<String>,
    pub max_um: f64,
    pub bound_um: f64,
    pub controller_fpt_of_grade4: Option<f64>,
    pub controller_fp_of_grade4: Option<f64>,
    pub gear_fpt_of_grade4: Option<f64>,
    pub gear_fp_of_grade4: Option<f64>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SensitivityBench {
    pub system: SystemInfo,
    pub rows: Vec<SensitivityRow>,
}

fn sensitivity_one(
    machine: &MachineConfig,
    plant: &PlantConfig,
    path: &std::path::Path,
    v: Variation,
) -> Result<SensitivityRow, String> {
    let (machine, plant) = v.apply(machine, plant);
    let mut problems = Problems::new();
    machine.validate(&mut problems);
    plant.validate(&mut problems);
    if !problems.is_empty() {
        return Err(format!("{}: {problems:?}", v.name()));
    }
    let (job, cycle, plan) = job_on(&machine, path)?;
    let options = SimOptions {
        grade: 4,
        ..SimOptions::default()
    };
    let s = run_program(&machine, &plant, &cycle, &plan, &job, &options, &mut |_| {})?;
    let last = s.passes.last();
    let mine = last.and_then(|p| p.controller_share.as_ref()).map(|g| g.shares());
    let gear_cut = last.and_then(|p| p.predicted.as_ref()).map(|g| g.shares());
    Ok(SensitivityRow {
        gear: gear_name(path),
        variation: v,
        completed: s.completed,
        fault: s.fault.clone(),
        max_um: s.max_sync_err_um,
        bound_um: s.bound_um,
        controller_fpt_of_grade4: mine.map(|x| x.0),
        controller_fp_of_grade4: mine.map(|x| x.1),
        gear_fpt_of_grade4: gear_cut.map(|x| x.0),
        gear_fp_of_grade4: gear_cut.map(|x| x.1),
    })
}

/// What the controller's share and the gear depend on: each program under each
/// [`Variation`] (CCC and predictor on; `hob-bench accuracy --sensitivity`).
pub fn sensitivity(a: &Args) -> Result<SensitivityBench, String> {
    let (machine, plant) = prepare(a)?;
    let cases: Vec<(PathBuf, Variation)> = a
        .programs
        .iter()
        .flat_map(|p| Variation::ALL.map(|v| (p.clone(), v)))
        .collect();
    let r = SensitivityBench {
        system: system::probe(),
        rows: on_every_core(&cases, |(p, v)| sensitivity_one(&machine, &plant, p, *v))?,
    };
    crate::write_json(&a.out.join("sensitivity.json"), &r)?;
    Ok(r)
}

pub fn sensitivity_text(r: &SensitivityBench) -> String {
    let mut o = String::from(
        "| gear | variation (shipped) | max um (bound) | controller's f_pt of grade 4 | controller's F_p of grade 4 | gear f_pt of grade 4 | gear F_p of grade 4 | result |\n|---|---|---|---|---|---|---|---|\n",
    );
    let pct = |v: Option<f64>| v.map_or_else(|| "-".to_string(), |v| format!("{:.0} %", 100.0 * v));
    for x in &r.rows {
        o.push_str(&format!(
            "| {} | {} | {:.2} ({:.2}) | {} | {} | {} | {} | {} |\n",
            x.gear,
            x.variation.name(),
            x.max_um,
            x.bound_um,
            pct(x.controller_fpt_of_grade4),
            pct(x.controller_fp_of_grade4),
            pct(x.gear_fpt_of_grade4),
            pct(x.gear_fp_of_grade4),
            result(x.fault.as_deref(), x.completed)
        ));
    }
    o
}

/// A share of grade 4 as a share of grade `grade` (ISO 1328-1:2013's grade factor).
pub fn of_grade(of_grade4: f64, grade: u8) -> f64 {
    use hob_gearing::iso1328::grade_factor;
    of_grade4 * grade_factor(4) / grade_factor(grade)
}

/// One gear under one disturbance over many SYNC-timing and wheel seeds: the worst seed's
/// controller's share of the finished gear's f_pt and F_p against the goal grade.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SeedsRow {
    pub gear: String,
    pub disturbance: Disturbance,
    pub seeds: Vec<u64>,
    pub goal_grade: u8,
    /// Every seed's run completed (no fault, no timeout).
    pub completed: bool,
    pub fault: Option<String>,
    pub worst_fpt_of_goal: Option<f64>,
    pub worst_fpt_seed: Option<u64>,
    pub worst_fp_of_goal: Option<f64>,
    pub worst_fp_seed: Option<u64>,
    pub median_fpt_of_goal: Option<f64>,
    /// The controller's share with the gaps where the hob cut them, worst over the seeds
    /// and the hob's phase, of the goal grade (reported, not gated).
    #[serde(default)]
    pub worst_phase_fpt_of_goal: Option<f64>,
    #[serde(default)]
    pub worst_phase_fp_of_goal: Option<f64>,
    pub worst_max_um: f64,
    pub bound_um: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SeedsBench {
    pub system: SystemInfo,
    pub rows: Vec<SeedsRow>,
}

/// Issue 16's goal at every seed (`hob-bench accuracy --seeds N`): each program under each
/// disturbance, CCC and predictor on, with `simulation.seed` 1..=N (the SYNC timing, the
/// power-on positions and the worm wheel's tooth errors all follow it).
pub fn seeds(a: &Args, n: u64) -> Result<SeedsBench, String> {
    let (machine, plant) = prepare(a)?;
    let mut cases: Vec<(PathBuf, Disturbance, u64)> = Vec::new();
    for p in &a.programs {
        for &d in &a.disturbances {
            for seed in 1..=n {
                cases.push((p.clone(), d, seed));
            }
        }
    }
    let runs = on_every_core(&cases, |(p, d, seed)| {
        let mut seeded = plant.clone();
        seeded.simulation.seed = *seed;
        one(&machine, &seeded, p, *d, true, true)
    })?;
    let rows = runs
        .chunks(n as usize)
        .zip(cases.chunks(n as usize))
        .map(|(rs, cs)| {
            let d = cs[0].1;
            let goal = d.goal_grade();
            let worst = |f: fn(&Row) -> Option<f64>| {
                rs.iter()
                    .zip(cs)
                    .filter_map(|(r, c)| f(r).map(|v| (of_grade(v, goal), c.2)))
                    .max_by(|a, b| a.0.total_cmp(&b.0))
            };
            let fpt = worst(|r| r.finished_fpt_of_grade4);
            let fp = worst(|r| r.finished_fp_of_grade4);
            let mut fpts: Vec<f64> = rs
                .iter()
                .filter_map(|r| r.finished_fpt_of_grade4.map(|v| of_grade(v, goal)))
                .collect();
            fpts.sort_by(f64::total_cmp);
            SeedsRow {
                gear: rs[0].gear.clone(),
                disturbance: d,
                seeds: cs.iter().map(|c| c.2).collect(),
                goal_grade: goal,
                completed: rs.iter().all(|r| r.completed),
                fault: rs.iter().find_map(|r| r.fault.clone()),
                worst_fpt_of_goal: fpt.map(|x| x.0),
                worst_fpt_seed: fpt.map(|x| x.1),
                worst_fp_of_goal: fp.map(|x| x.0),
                worst_fp_seed: fp.map(|x| x.1),
                median_fpt_of_goal: fpts.get(fpts.len() / 2).copied(),
                worst_phase_fpt_of_goal: worst(|r| r.worst_phase_fpt_of_grade4).map(|x| x.0),
                worst_phase_fp_of_goal: worst(|r| r.worst_phase_fp_of_grade4).map(|x| x.0),
                worst_max_um: rs.iter().map(|r| r.max_um).fold(0.0, f64::max),
                bound_um: rs[0].bound_um,
            }
        })
        .collect();
    let r = SeedsBench {
        system: system::probe(),
        rows,
    };
    crate::write_json(&a.out.join("seeds.json"), &r)?;
    Ok(r)
}

pub fn seeds_text(r: &SeedsBench) -> String {
    let mut o = String::from(
        "| gear | disturbance | seeds | goal grade | controller's f_pt: worst (seed), median | controller's F_p: worst (seed) | at the hob's gaps, worst over seeds and phase: f_pt, F_p | worst max um (bound) | result |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    let pct = |v: Option<f64>, seed: Option<u64>| match (v, seed) {
        (Some(v), Some(s)) => format!("{:.0} % ({s})", 100.0 * v),
        _ => "-".into(),
    };
    for x in &r.rows {
        o.push_str(&format!(
            "| {} | {} | {} | {} | {}, {} | {} | {}, {} | {:.2} ({:.2}) | {} |\n",
            x.gear,
            x.disturbance.name(),
            x.seeds.len(),
            x.goal_grade,
            pct(x.worst_fpt_of_goal, x.worst_fpt_seed),
            x.median_fpt_of_goal
                .map_or_else(|| "-".into(), |v| format!("{:.0} %", 100.0 * v)),
            pct(x.worst_fp_of_goal, x.worst_fp_seed),
            percent(x.worst_phase_fpt_of_goal),
            percent(x.worst_phase_fp_of_goal),
            x.worst_max_um,
            x.bound_um,
            result(x.fault.as_deref(), x.completed)
        ));
    }
    o
}
