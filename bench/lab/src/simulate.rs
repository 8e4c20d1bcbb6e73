//! `hob simulate`: the whole program, core against the simulated machine, in-process.

use hob_control::SpindleAngleSource;
use hob_control::program::CycleProgram;
use hob_plant::config::PlantConfig;
use hob_plant::sim::{SimOptions, TRACE_HEADER, run_program};
use hob_setup::config::Problems;
use hob_setup::config::machine::MachineConfig;
use hob_setup::planner;
use std::io::{BufWriter, Write};
use std::path::Path;

/// What `hob simulate` needs besides the files.
pub struct Args<'a> {
    pub program: &'a Path,
    pub plant: &'a Path,
    pub out: &'a Path,
    pub options: SimOptions,
}

/// Runs the simulation; `Err((refused, message))`.
pub fn run(machine: &MachineConfig, a: &Args<'_>) -> Result<String, (bool, String)> {
    let plant = PlantConfig::load(a.plant).map_err(|e| (true, e.to_string()))?;
    let (job, src) = hob_store::files::read_program(a.program).map_err(|e| (true, e.to_string()))?;
    let mut p = Problems::new();
    let built = CycleProgram::build(&job, machine, &mut p);
    let plan = planner::plan(&job, machine, &mut p);
    let (Some(cycle), Some(plan)) = (built, plan) else {
        let e = p
            .into_result(a.program, &src)
            .err()
            .map_or_else(|| "refused".to_string(), |e| e.to_string());
        return Err((true, e));
    };
    if a.options.single && cycle.single().is_none() {
        return Err((
            true,
            format!(
                "{}: cycle.single_depth_mm: --single needs a single-mode depth",
                a.program.display()
            ),
        ));
    }
    std::fs::create_dir_all(a.out).map_err(|e| (false, format!("{}: {e}", a.out.display())))?;
    let trace_path = a.out.join("trace.csv");
    let file =
        std::fs::File::create(&trace_path).map_err(|e| (false, format!("{}: {e}", trace_path.display())))?;
    let mut w = BufWriter::new(file);
    let mut io_error = None;
    let _ = writeln!(w, "{TRACE_HEADER}");
    let summary = run_program(machine, &plant, &cycle, &plan, &job, &a.options, &mut |row| {
        if io_error.is_none()
            && let Err(e) = writeln!(w, "{}", row.csv())
        {
            io_error = Some(e);
        }
    })
    .map_err(|e| (false, e))?;
    if let Some(e) = io_error.or_else(|| w.flush().err()) {
        return Err((false, format!("{}: {e}", trace_path.display())));
    }
    let json = serde_json::to_string_pretty(&summary).map_err(|e| (false, e.to_string()))?;
    let summary_path = a.out.join("summary.json");
    std::fs::write(&summary_path, json + "\n")
        .map_err(|e| (false, format!("{}: {e}", summary_path.display())))?;
    let passes: Vec<String> = summary
        .passes
        .iter()
        .map(|p| format!("{}: max {:.2} um", p.pass, p.sync_err_max_um))
        .collect();
    let predicted: String = summary
        .passes
        .iter()
        .map(|p| {
            hob_logger::predicted::pass_line(p.pass, p.predicted.as_ref(), p.controller_share.as_ref()) + "\n"
        })
        .collect();
    let predicted_cutter: Vec<f64> = plan
        .cutter
        .as_ref()
        .map(|c| c.passes.iter().map(|p| p.profile_error_um).collect())
        .unwrap_or_default();
    let cutter: String = summary
        .cutter_profile_error_um
        .iter()
        .map(|&[pass, um]| {
            let k = pass as usize;
            let predicted = predicted_cutter
                .get(k.wrapping_sub(1))
                .map_or_else(String::new, |p| format!(" (the plan predicts {p:.2} um)"));
            format!("  pass {k}: the disk cutter's simulated profile error {um:.2} um{predicted}\n")
        })
        .collect();
    let late = match summary.late_frames {
        [0, 0] => String::new(),
        [t, r] => format!("late frames (plant file): {t} position TPDOs, {r} target RPDOs\n"),
    };
    Ok(format!(
        "{}: {} in {:.1} s simulated; sync error {} (bound {:.2} um = 1/4 of grade-5 f_p); ccc {}, predictor {}; trace {}\n{late}{predicted}{cutter}",
        a.program.display(),
        match &summary.fault {
            Some(f) => format!("FAULT {f}"),
            None if summary.completed => "done".to_string(),
            None => "not finished".to_string(),
        },
        summary.total_time_s,
        passes.join(", "),
        summary.bound_um,
        if a.options.cross_coupling { "on" } else { "off" },
        if a.options.angle_source == SpindleAngleSource::Predicted {
            "on"
        } else {
            "off (last measured angle)"
        },
        trace_path.display(),
    ))
}
