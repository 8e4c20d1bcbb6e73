//! Step cost: the control step's cost per cycle in every sequencer state, measured on the
//! closed loop against the simulated machine (so every state is reached with realistic
//! inputs). Scenarios: the demo job (the conventional cycle start to end), the spline's
//! plunge cycle and the tooth-by-tooth cycle (their first minutes), a drive fault in the
//! cut (the fault reaction), and a jog.
//!
//! - Time: every step is timed (CLOCK_MONOTONIC around the call) into a histogram per
//!   state; the scenarios are repeated and each state's median is reported with the spread
//!   of the per-repetition medians, so a noisy run shows as a wide spread, not as a number.
//! - Instructions: the same scenarios once under `valgrind --tool=callgrind`, collecting
//!   only inside one `#[inline(never)]` function per state (`step_in_<state>`), so the
//!   count is the step's own; divided by the calls, stable on a noisy machine.

use crate::hist::{self, Summary};
use crate::system::{self, SystemInfo};
use hob_control::fault::Axis;
use hob_control::program::CycleProgram;
use hob_control::{Command, Controller, CycleInputs, CycleOutputs, State};
use hob_plant::config::PlantConfig;
use hob_plant::plant::Injection;
use hob_plant::sim::RowState;
use hob_plant::sim::Simulation;
use hob_setup::config::Problems;
use hob_setup::config::machine::MachineConfig;
use hob_setup::job::Program;
use hob_setup::planner;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command as Process;

type StepFn = fn(&mut Controller, &CycleInputs) -> CycleOutputs;

macro_rules! per_state {
    ($($state:ident => $f:ident),* $(,)?) => {
        $(
            #[inline(never)]
            fn $f(c: &mut Controller, i: &CycleInputs) -> CycleOutputs {
                // A body of its own (identical functions would be merged into one symbol).
                std::hint::black_box(stringify!($f));
                std::hint::black_box(c.step(std::hint::black_box(i)))
            }
        )*
        /// The step through this state's own function (callgrind collects inside it).
        fn step_fn(s: State) -> StepFn {
            match s {
                $(State::$state => $f,)*
            }
        }
        /// Every state.
        pub const STATES: &[State] = &[$(State::$state),*];
    };
}

per_state! {
    Init => step_in_init, Idle => step_in_idle, Jog => step_in_jog, ToSafe => step_in_tosafe,
    ToStart => step_in_tostart, SpindleUp => step_in_spindleup, Engage => step_in_engage,
    Infeed => step_in_infeed, Plunge => step_in_plunge, ExtraRev => step_in_extrarev,
    Clamp => step_in_clamp, Cut => step_in_cut, Unclamp => step_in_unclamp,
    Retract => step_in_retract, Return => step_in_return, Index => step_in_index,
    Home => step_in_home, Disengage => step_in_disengage, SpindleDown => step_in_spindledown,
    FaultRetract => step_in_faultretract, FaultStop => step_in_faultstop, Faulted => step_in_faulted,
    Referencing => step_in_referencing,
}

/// The name of a state's function in callgrind's output.
fn fn_name(s: State) -> String {
    format!("step_in_{}", format!("{s:?}").to_lowercase())
}

#[derive(Debug, Clone, Copy)]
enum Extra {
    None,
    /// A drive fault on Y after this long in the cut.
    FaultInCut(f64),
    Jog,
}

#[derive(Debug, Clone, Copy)]
struct Scenario {
    program: &'static str,
    /// Simulated seconds after the start at most.
    max_s: f64,
    extra: Extra,
}

const SCENARIOS: &[Scenario] = &[
    Scenario {
        program: "demo-short-spur-z17-m5.toml",
        max_s: 300.0,
        extra: Extra::None,
    },
    Scenario {
        program: "spline-z12-m2-plunge.toml",
        max_s: 90.0,
        extra: Extra::None,
    },
    Scenario {
        program: "tooth-by-tooth-z24-m8.toml",
        max_s: 150.0,
        extra: Extra::None,
    },
    Scenario {
        program: "demo-short-spur-z17-m5.toml",
        max_s: 60.0,
        extra: Extra::FaultInCut(2.0),
    },
    Scenario {
        program: "demo-short-spur-z17-m5.toml",
        max_s: 10.0,
        extra: Extra::Jog,
    },
];

#[derive(Debug, Clone)]
pub struct Args {
    pub out: PathBuf,
    pub machine: PathBuf,
    pub plant: PathBuf,
    pub programs: PathBuf,
    pub repeat: usize,
    pub callgrind: bool,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct StateCost {
    pub state: String,
    /// Steps measured in this state per repetition.
    pub calls: u64,
    /// All repetitions pooled.
    pub time: Summary,
    /// Median of the per-repetition medians, and their smallest and largest.
    pub median_ns: f64,
    pub median_min_ns: f64,
    pub median_max_ns: f64,
    /// Instructions per step (callgrind), when counted.
    pub instructions: Option<f64>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StepBench {
    pub system: SystemInfo,
    pub repeat: usize,
    pub states: Vec<StateCost>,
    /// States no scenario reached (none expected).
    pub not_reached: Vec<String>,
    pub callgrind: Option<String>,
}

struct Loaded {
    machine: MachineConfig,
    plant: PlantConfig,
    jobs: Vec<(Program, CycleProgram, planner::Plan)>,
}

fn load(a: &Args) -> Result<Loaded, String> {
    let machine = hob_store::files::load_machine(&a.machine).map_err(|e| e.to_string())?;
    let plant = PlantConfig::load(&a.plant).map_err(|e| e.to_string())?;
    let mut jobs = Vec::new();
    for s in SCENARIOS {
        let path = a.programs.join(s.program);
        let (job, src) = hob_store::files::read_program(&path).map_err(|e| e.to_string())?;
        let mut p = Problems::new();
        let cycle = CycleProgram::build(&job, &machine, &mut p);
        let plan = planner::plan(&job, &machine, &mut p);
        match (cycle, plan) {
            (Some(c), Some(pl)) => jobs.push((job, c, pl)),
            _ => {
                return Err(p
                    .into_result(&path, &src)
                    .err()
                    .map_or_else(|| format!("{}: refused", path.display()), |e| e.to_string()));
            }
        }
    }
    Ok(Loaded { machine, plant, jobs })
}

/// Runs every scenario once, each step through `step`.
fn run_scenarios(
    l: &Loaded,
    step: &mut dyn FnMut(&mut Controller, &CycleInputs) -> CycleOutputs,
) -> Result<(), String> {
    for (s, (job, cycle, plan)) in SCENARIOS.iter().zip(&l.jobs) {
        let mut sim = Simulation::for_program(&l.machine, &l.plant, cycle, plan, job);
        // Power-up and referencing X and Y from where the machine stands (Y up to 450 mm at
        // the 600 mm/min switch search).
        if !sim.power_up_with(180.0, &mut |_| {}, step) {
            return Err(format!("{}: no power-up", s.program));
        }
        match s.extra {
            Extra::Jog => {
                sim.command(Command::Jog {
                    axis: Axis::X,
                    distance: 5.0,
                })
                .map_err(|r| format!("jog refused: {r:?}"))?;
                sim.run_until_with(s.max_s, &mut |_| {}, &mut |r, _| r.state == RowState::Idle, step);
                continue;
            }
            Extra::None | Extra::FaultInCut(_) => {}
        }
        sim.controller
            .load(*cycle)
            .map_err(|r| format!("{}: {r:?}", s.program))?;
        sim.command(Command::Start { single: false })
            .map_err(|r| format!("{}: start refused: {r:?}", s.program))?;
        if let Extra::FaultInCut(after_s) = s.extra {
            let mut cut_s = 0.0;
            let period = l.machine.control.cycle_period_us as f64 * 1e-6;
            sim.run_until_with(
                s.max_s,
                &mut |_| {},
                &mut |r, _| {
                    if r.state == RowState::Cut {
                        cut_s += period;
                    }
                    cut_s >= after_s
                },
                step,
            );
            sim.inject(Injection::DriveFault(Axis::Y));
        }
        sim.run_until_with(
            s.max_s,
            &mut |_| {},
            &mut |r, _| matches!(r.state, RowState::Idle | RowState::Faulted) && r.t_s > 1.0,
            step,
        );
        // A few cycles at rest (Idle or Faulted) after the end.
        sim.run_until_with(0.2, &mut |_| {}, &mut |_, _| false, step);
    }
    Ok(())
}

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// `callgrind_annotate --inclusive=yes` lines: "12,345 (1.2%)  ???:crate::module::fn [...]".
pub fn parse_annotate(text: &str) -> BTreeMap<String, u64> {
    let mut m = BTreeMap::new();
    for line in text.lines() {
        let line = line.trim();
        let Some((count, rest)) = line.split_once(' ') else {
            continue;
        };
        let Ok(n) = count.replace(',', "").parse::<u64>() else {
            continue;
        };
        if let Some(pos) = rest.find("step_in_") {
            let name: String = rest[pos..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            m.entry(name).or_insert(n);
        }
    }
    m
}

fn callgrind(a: &Args) -> Result<(BTreeMap<String, u64>, String), String> {
    let me = std::env::current_exe().map_err(|e| e.to_string())?;
    let out_file = a.out.join("callgrind.out");
    let status = Process::new("valgrind")
        .args([
            "--tool=callgrind",
            "--collect-atstart=no",
            "--toggle-collect=*step_in_*",
        ])
        .arg(format!("--callgrind-out-file={}", out_file.display()))
        .arg(&me)
        .arg("step")
        .arg("--count-only")
        .arg("--out")
        .arg(&a.out)
        .arg("--machine")
        .arg(&a.machine)
        .arg("--plant")
        .arg(&a.plant)
        .arg("--programs")
        .arg(&a.programs)
        .stdout(std::process::Stdio::null())
        .stderr(std::fs::File::create(a.out.join("callgrind.log")).map_err(|e| e.to_string())?)
        .status()
        .map_err(|e| format!("valgrind (apt install valgrind, or bash ci/bench-setup): {e}"))?;
    if !status.success() {
        return Err(format!(
            "valgrind failed ({status}): see {}",
            a.out.join("callgrind.log").display()
        ));
    }
    let ann = Process::new("callgrind_annotate")
        .arg("--inclusive=yes")
        .arg("--threshold=100")
        .arg(&out_file)
        .output()
        .map_err(|e| format!("callgrind_annotate: {e}"))?;
    let text = String::from_utf8_lossy(&ann.stdout).to_string();
    std::fs::write(a.out.join("callgrind.txt"), &text).map_err(|e| e.to_string())?;
    Ok((parse_annotate(&text), out_file.display().to_string()))
}

fn counts(a: &Args, l: &Loaded) -> Result<BTreeMap<String, u64>, String> {
    let mut n: BTreeMap<String, u64> = BTreeMap::new();
    run_scenarios(l, &mut |c, i| {
        let s = c.status().state;
        *n.entry(fn_name(s)).or_default() += 1;
        step_fn(s)(c, i)
    })?;
    crate::write_json(&a.out.join("step-calls.json"), &n)?;
    Ok(n)
}

/// `--count-only`: the scenarios once through the per-state functions (run under callgrind).
pub fn count_only(a: &Args) -> Result<(), String> {
    let l = load(a)?;
    std::fs::create_dir_all(&a.out).map_err(|e| e.to_string())?;
    counts(a, &l).map(|_| ())
}

pub fn run(a: &Args) -> Result<StepBench, String> {
    std::fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;
    let l = load(a)?;
    let mut pooled: BTreeMap<String, hdrhistogram::Histogram<u64>> = BTreeMap::new();
    let mut medians: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    let mut calls: BTreeMap<String, u64> = BTreeMap::new();
    for rep in 0..a.repeat.max(1) {
        let mut this: BTreeMap<String, hdrhistogram::Histogram<u64>> = BTreeMap::new();
        run_scenarios(&l, &mut |c, i| {
            let s = c.status().state;
            let t0 = std::time::Instant::now();
            let o = step_fn(s)(c, i);
            let ns = t0.elapsed().as_nanos() as u64;
            hist::record(this.entry(fn_name(s)).or_insert_with(hist::new), ns);
            o
        })?;
        for (k, h) in this {
            if rep == 0 {
                calls.insert(k.clone(), h.len());
            }
            medians
                .entry(k.clone())
                .or_default()
                .push(h.value_at_quantile(0.5) as f64);
            let _ = pooled.entry(k).or_insert_with(hist::new).add(&h);
        }
    }
    let (instr, cg_file) = if a.callgrind {
        let (m, f) = callgrind(a)?;
        (Some(m), Some(f))
    } else {
        (None, None)
    };
    let mut states = Vec::new();
    let mut not_reached = Vec::new();
    for &s in STATES {
        let k = fn_name(s);
        let Some(h) = pooled.get(&k) else {
            not_reached.push(s.name().to_string());
            continue;
        };
        let m = medians.get_mut(&k).map(|v| v.as_mut_slice()).unwrap_or_default();
        let med = median(m);
        let n = calls.get(&k).copied().unwrap_or(0);
        states.push(StateCost {
            state: s.name().to_string(),
            calls: n,
            time: hist::summary(h),
            median_ns: med,
            median_min_ns: m.first().copied().unwrap_or(0.0),
            median_max_ns: m.last().copied().unwrap_or(0.0),
            instructions: instr
                .as_ref()
                .and_then(|i| i.get(&k))
                .map(|&ir| ir as f64 / n.max(1) as f64),
        });
    }
    let r = StepBench {
        system: system::probe(),
        repeat: a.repeat.max(1),
        states,
        not_reached,
        callgrind: cg_file,
    };
    crate::write_json(&a.out.join("step.json"), &r)?;
    Ok(r)
}

pub fn text(r: &StepBench) -> String {
    let mut o = format!(
        "step cost per cycle by sequencer state ({} repetitions; time: median of the repetitions' medians [their range], pooled p99; instructions: callgrind)\n",
        r.repeat
    );
    o.push_str("state          calls   median ns          range   p99 ns   max ns   instructions\n");
    for s in &r.states {
        o.push_str(&format!(
            "{:<12} {:>7} {:>11.0} {:>7.0}-{:<7.0} {:>8.0} {:>8.0} {:>14}\n",
            s.state,
            s.calls,
            s.median_ns,
            s.median_min_ns,
            s.median_max_ns,
            s.time.p99_us * 1e3,
            s.time.max_us * 1e3,
            s.instructions.map_or("-".to_string(), |i| format!("{i:.0}"))
        ));
    }
    if !r.not_reached.is_empty() {
        o.push_str(&format!("not reached: {}\n", r.not_reached.join(", ")));
    }
    o
}

/// The directory of the example programs next to a machine configuration.
pub fn programs_dir(machine: &Path) -> PathBuf {
    machine
        .parent()
        .map_or_else(|| PathBuf::from("config/programs"), |p| p.join("programs"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn annotate_lines_are_parsed_per_state() {
        let text = "--------\nIr\n--------\n\
            3,456,789 (12.00%)  ???:hob_bench::step::step_in_cut [/x/hob-bench]\n\
            1,000 ( 0.01%)  ???:hob_bench::step::step_in_idle [/x/hob-bench]\n\
            5 ( 0.00%)  ???:other\n";
        let m = parse_annotate(text);
        assert_eq!(m.get("step_in_cut"), Some(&3_456_789));
        assert_eq!(m.get("step_in_idle"), Some(&1_000));
        assert_eq!(m.len(), 2);
    }

    #[test]
    fn every_state_has_its_function() {
        for &s in STATES {
            assert!(fn_name(s).starts_with("step_in_"));
        }
        // As many as the wire knows: a state added to the loop is added here too.
        assert_eq!(STATES.len(), hob_ipc::codec::State::ALL.len());
    }
}
