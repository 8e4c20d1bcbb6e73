//! The hobbing planner: turns a program on a machine into everything the operator and the
//! controller need (docs/domain.md sections 3-5): gearbox ratio, differential, hob swivel, and
//! per pass the depth, X position, speeds, VFD set-point, Y stroke and times. A program the
//! machine cannot cut is refused here, each problem named by the key to change.
//!
//! ```
//! use hob_setup::{config::machine::MachineConfig, planner::plan_source};
//! use std::path::Path;
//! // The texts are read by the caller (hob_store::files reads them from disk).
//! let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
//! let (m, p) = (root.join("config/machine.toml"), root.join("config/programs/spur-z17-m5.toml"));
//! let machine = MachineConfig::parse(&m, &std::fs::read_to_string(&m).unwrap()).unwrap();
//! let plan = plan_source(&p, &std::fs::read_to_string(&p).unwrap(), &machine).unwrap();
//! assert!((plan.passes[0].spindle_rpm - 119.366).abs() < 1e-3);
//! ```

pub mod cutter;
pub mod motion;
pub mod progress;

use crate::config::machine::MachineConfig;
use crate::config::{LoadError, Problems};
use crate::job::{CheckedProgram, CuttingData, CycleKind, Mode, Program, SingleSpeeds, ToolKind};
use hob_gearing::approach::approach_mm;
use hob_gearing::cutting::{axial_feed_mm_min, spindle_rpm, table_rpm};
use hob_gearing::gearbox::{differential_deg_per_mm, egb_ratio, helix_lead_mm, pitch_diameter_mm};
use hob_gearing::iso1328::single_pitch_tolerance_um;
use hob_gearing::signs::{GearboxSigns, Hand, SignInputs, StartSide};
use motion::move_time_s;
use serde::Serialize;
use std::path::Path;

/// What a pass is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PassKind {
    Rough,
    Finish,
    Single,
}

/// One pass through the face width at one depth.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Pass {
    pub kind: PassKind,
    /// Cumulative depth reached by this pass, from the blank's outside diameter.
    pub depth_mm: f64,
    /// Centre distance hob axis to table axis at that depth (before crowning/contour).
    pub x_mm: f64,
    pub cutting_speed_m_min: f64,
    pub feed_mm_per_rev: f64,
    pub spindle_rpm: f64,
    pub spindle_motor_rpm: f64,
    /// Table speed during the cut, base rotation and differential together.
    pub table_rpm: f64,
    pub table_motor_rpm: f64,
    pub axial_feed_mm_min: f64,
    pub vfd_hz: f64,
    pub analog_out_v: f64,
    /// Axial approach length before the face at this depth.
    pub approach_mm: f64,
    /// Y (hob axis height above the table) where the feed starts and ends.
    pub y_start_mm: f64,
    pub y_end_mm: f64,
    /// Time at feed in the gear (all strokes of the pass for tooth-by-tooth).
    pub cut_time_s: f64,
    /// Whole pass: rapids, plunge, extra revolution, indexing and cut.
    pub pass_time_s: f64,
}

/// Shape of X along the face, as planned (crowning and contour add up).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ShapePlan {
    pub crowning: Option<CrowningPlan>,
    /// `[face_mm, x_offset_mm]` points.
    pub contour: Option<Vec<[f64; 2]>>,
    /// Whether X moves in the cut (then it is never clamped).
    pub x_moves_in_cut: bool,
}

/// A crowning arc.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CrowningPlan {
    pub height_mm: f64,
    pub radius_mm: f64,
}

/// The whole plan of a program on a machine.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Plan {
    pub machine: String,
    pub cycle: CycleKind,
    pub mode: Mode,
    pub teeth: u32,
    pub starts: u32,
    pub normal_module_mm: f64,
    pub helix_deg: f64,
    /// `None` for spur.
    pub helix_hand: Option<Hand>,
    pub pitch_diameter_mm: f64,
    /// The gear's face width (the helix tolerances of ISO 1328-1 depend on it).
    pub face_width_mm: f64,
    /// Lead of the gear's helix; `None` for spur.
    pub helix_lead_mm: Option<f64>,
    /// Table revolutions per hob revolution (z0/z); 0 for tooth-by-tooth (indexing).
    pub egb_ratio: f64,
    /// 360 sin(beta) / (pi m_n z), deg of table per mm of Y; 0 for spur.
    pub differential_deg_per_mm: f64,
    /// Swivel angle eta to set on the manual A axis.
    pub hob_swivel_deg: f64,
    /// The sense the hob axis is swivelled in: that of a right- or left-hand helix.
    pub hob_swivel_sense: Option<Hand>,
    pub signs: GearboxSigns,
    /// Indexing angle per tooth (tooth-by-tooth only).
    pub index_deg: Option<f64>,
    /// X with the tool clear of the blank by `strategy.retract_mm`.
    pub x_safe_mm: f64,
    pub x_shape: ShapePlan,
    /// ISO 1328-1 single pitch tolerance of this gear at grade 5, for scale.
    pub single_pitch_tolerance_grade5_um: f64,
    pub passes: Vec<Pass>,
    /// Whole cycle: spindle ramps, rapids with the configured speed and acceleration,
    /// plunges, indexing and cuts, back to the start position.
    pub total_time_s: f64,
    /// Plausibility notes that do not stop the program.
    pub warnings: Vec<String>,
    /// A tooth-by-tooth program's disk cutter with a profile: its fit and dynamics.
    pub cutter: Option<cutter::CutterPlan>,
}

/// Parses, checks and plans a program's text on `machine` (`origin` names it in errors):
/// what `hob check` and `hob plan` do with a file.
pub fn plan_source(origin: &Path, src: &str, machine: &MachineConfig) -> Result<Plan, LoadError> {
    let program = Program::parse(origin, src)?;
    let mut problems = Problems::new();
    match plan(&program, machine, &mut problems) {
        Some(plan) => Ok(plan),
        None => {
            problems.into_result(origin, src)?;
            unreachable!("a refused plan always records a problem")
        }
    }
}

/// Checks `program` and plans it on `machine`; `None` with the problems recorded when the
/// program cannot be cut.
pub fn plan(program: &Program, machine: &MachineConfig, p: &mut Problems) -> Option<Plan> {
    let checked = program.check(p)?;
    let plan = Planner::new(&checked, machine).plan(p);
    if p.is_empty() { Some(plan) } else { None }
}

struct Planner<'a> {
    c: &'a CheckedProgram,
    m: &'a MachineConfig,
    signs: GearboxSigns,
    swivel_signed_deg: f64,
    differential_deg_per_mm: f64,
}

/// One planned pass before timing.
struct PassSpec {
    kind: PassKind,
    depth_mm: f64,
    data: CuttingData,
    data_key: &'static str,
}

/// A pass's speeds: cutting speed (m/min), spindle rpm, the table's base rotation and its
/// speed with the differential (rpm), axial feed (mm/min).
struct PassSpeeds {
    v_c: f64,
    n_c: f64,
    n_b_base: f64,
    v_f: f64,
    n_b: f64,
}

/// A pass's stroke in Y: the approach and the ends, mm.
struct Stroke {
    approach: f64,
    y_start: f64,
    y_end: f64,
}

impl<'a> Planner<'a> {
    fn new(c: &'a CheckedProgram, m: &'a MachineConfig) -> Self {
        let w = &c.program.workpiece;
        let helical = c.program.is_helical();
        let gear_hand = helical.then_some(w.helix_hand);
        let signs = GearboxSigns::derive(SignInputs {
            hob_hand: c.hob_hand,
            gear_hand,
            start: c.program.cycle.start,
            method: c.program.cycle.method,
        });
        // eta = beta -/+ gamma (same / opposite hand); spur: gamma. Signed: positive in the
        // sense of a right-hand helix.
        let beta_signed = gear_hand.map_or(0.0, Hand::sign) * w.helix_deg;
        let swivel_signed_deg = beta_signed - c.hob_hand.sign() * c.lead_angle_deg;
        Self {
            c,
            m,
            signs,
            swivel_signed_deg,
            differential_deg_per_mm: differential_deg_per_mm(w.helix_deg, w.module_mm, c.teeth),
        }
    }

    fn program(&self) -> &Program {
        &self.c.program
    }

    fn is_indexing(&self) -> bool {
        self.program().cycle.kind == CycleKind::ToothByTooth
    }

    fn plan(&self, p: &mut Problems) -> Plan {
        let prog = self.program();
        let w = &prog.workpiece;
        let t = &prog.tool;
        self.check_machine(p);
        let specs = self.pass_specs();
        let passes: Vec<Pass> = specs.iter().map(|s| self.pass(s, p)).collect();
        let total_time_s = self.total_time_s(&passes);
        let pitch_diameter = pitch_diameter_mm(w.module_mm, self.c.teeth, w.helix_deg);
        let helical = prog.is_helical();
        let mut warnings = self.warnings(pitch_diameter, t.kind);
        let cutter = cutter::plan(prog, self.c.gashes, &passes, p, &mut warnings);
        Plan {
            machine: self.m.machine.name.clone(),
            cycle: prog.cycle.kind,
            mode: prog.cycle.mode,
            teeth: self.c.teeth,
            starts: self.c.starts,
            normal_module_mm: w.module_mm,
            helix_deg: w.helix_deg,
            helix_hand: helical.then_some(w.helix_hand),
            pitch_diameter_mm: pitch_diameter,
            face_width_mm: w.face_width_mm,
            helix_lead_mm: helix_lead_mm(w.helix_deg, w.module_mm, self.c.teeth),
            egb_ratio: if self.is_indexing() {
                0.0
            } else {
                egb_ratio(self.c.starts, self.c.teeth)
            },
            differential_deg_per_mm: self.differential_deg_per_mm,
            hob_swivel_deg: self.swivel_signed_deg.abs(),
            hob_swivel_sense: match self.swivel_signed_deg {
                s if s > 0.0 => Some(Hand::Right),
                s if s < 0.0 => Some(Hand::Left),
                _ => None,
            },
            signs: self.signs,
            index_deg: self.is_indexing().then(|| 360.0 / f64::from(self.c.teeth)),
            x_safe_mm: self.x_safe_mm(),
            x_shape: ShapePlan {
                crowning: self.c.x_shape.crowning.map(|c| CrowningPlan {
                    height_mm: c.height_mm,
                    radius_mm: c.radius_mm,
                }),
                contour: self
                    .c
                    .x_shape
                    .contour
                    .map(|c| c.points().iter().map(|&(f, x)| [f, x]).collect()),
                x_moves_in_cut: self.c.x_shape.moves_x(),
            },
            single_pitch_tolerance_grade5_um: single_pitch_tolerance_um(pitch_diameter, w.module_mm, 5),
            passes,
            total_time_s,
            warnings,
            cutter,
        }
    }

    /// Machine limits that do not depend on a pass.
    fn check_machine(&self, p: &mut Problems) {
        let prog = self.program();
        let lim = &self.m.process;
        let t = &prog.tool;
        let w = &prog.workpiece;
        p.require(
            (lim.min_tool_diameter_mm..=lim.max_tool_diameter_mm).contains(&t.outside_diameter_mm),
            "tool.outside_diameter_mm",
            || {
                format!(
                    "{} mm is outside the machine's tool range process.min_tool_diameter_mm .. max_tool_diameter_mm = {} .. {} mm",
                    t.outside_diameter_mm, lim.min_tool_diameter_mm, lim.max_tool_diameter_mm
                )
            },
        );
        p.require(w.helix_deg <= lim.max_helix_deg, "workpiece.helix_deg", || {
            format!(
                "{} deg is above the machine's process.max_helix_deg = {}",
                w.helix_deg, lim.max_helix_deg
            )
        });
        p.require(self.c.starts <= lim.max_hob_starts, "tool.starts", || {
            format!(
                "{} starts is above the machine's process.max_hob_starts = {}",
                self.c.starts, lim.max_hob_starts
            )
        });
        let s = &prog.strategy;
        p.require(
            s.total_depth_mm < w.outside_diameter_mm / 2.0,
            "strategy.total_depth_mm",
            || {
                format!(
                    "{} mm reaches the blank's axis (outside radius {} mm)",
                    s.total_depth_mm,
                    w.outside_diameter_mm / 2.0
                )
            },
        );
        p.require(
            s.total_depth_mm < t.outside_diameter_mm / 2.0,
            "strategy.total_depth_mm",
            || {
                format!(
                    "{} mm is deeper than the tool's radius {} mm",
                    s.total_depth_mm,
                    t.outside_diameter_mm / 2.0
                )
            },
        );
        let x = &self.m.x;
        let x_safe = self.x_safe_mm();
        p.require(x_safe <= x.soft_limit_max_mm, "strategy.retract_mm", || {
            format!(
                "the safe position X = {x_safe:.3} mm is beyond the soft limit x.soft_limit_max_mm = {}",
                x.soft_limit_max_mm
            )
        });
        if let Some(f) = s
            .plunge_feed_mm_min
            .filter(|_| prog.cycle.kind == CycleKind::RadialPlunge)
        {
            p.require(f <= x.max_feed_mm_min, "strategy.plunge_feed_mm_min", || {
                format!(
                    "{f} mm/min is above the X axis' x.max_feed_mm_min = {}",
                    x.max_feed_mm_min
                )
            });
        }
    }

    fn x_at_depth_mm(&self, depth_mm: f64) -> f64 {
        let prog = self.program();
        prog.workpiece.outside_diameter_mm / 2.0 + prog.tool.outside_diameter_mm / 2.0 - depth_mm
    }

    fn x_safe_mm(&self) -> f64 {
        self.x_at_depth_mm(0.0) + self.program().strategy.retract_mm
    }

    fn pass_specs(&self) -> Vec<PassSpec> {
        let prog = self.program();
        let s = &prog.strategy;
        if prog.cycle.mode == Mode::Single {
            let (data, data_key) = match prog.cycle.single_speeds {
                SingleSpeeds::Rough => (s.rough, "strategy.rough"),
                SingleSpeeds::Finish => (s.finish, "strategy.finish"),
            };
            return vec![PassSpec {
                kind: PassKind::Single,
                depth_mm: prog.cycle.single_depth_mm.unwrap_or(s.total_depth_mm),
                data,
                data_key,
            }];
        }
        let rough_total = s.total_depth_mm - s.finish_allowance_mm;
        let n = self.c.rough_passes;
        let mut depth = 0.0;
        let mut specs: Vec<PassSpec> = (0..n)
            .map(|i| {
                depth = match &s.rough_depths_mm {
                    Some(d) => depth + d[i as usize],
                    None => rough_total * f64::from(i + 1) / f64::from(n),
                };
                PassSpec {
                    kind: PassKind::Rough,
                    depth_mm: depth,
                    data: s.rough,
                    data_key: "strategy.rough",
                }
            })
            .collect();
        if let Some(last) = specs.last_mut() {
            // Entered depths sum to the rough total within a micrometre; land on it exactly.
            last.depth_mm = rough_total;
        }
        if s.finish_allowance_mm > 0.0 {
            specs.push(PassSpec {
                kind: PassKind::Finish,
                depth_mm: s.total_depth_mm,
                data: s.finish,
                data_key: "strategy.finish",
            });
        }
        specs
    }

    fn pass(&self, spec: &PassSpec, p: &mut Problems) -> Pass {
        let m = self.m;
        let sp = self.pass_speeds(spec, p);
        let x_mm = self.x_at_depth_mm(spec.depth_mm);
        self.check_deepest_x(spec, x_mm, p);
        let st = self.stroke(spec, p);
        let drive = m.spindle.drive();
        let stroke_s = if sp.v_f > 0.0 {
            (st.y_end - st.y_start).abs() / sp.v_f * 60.0
        } else {
            0.0
        };
        let strokes = if self.is_indexing() {
            f64::from(self.c.teeth)
        } else {
            1.0
        };
        let cut_time_s = stroke_s * strokes;
        let mut pass = Pass {
            kind: spec.kind,
            depth_mm: spec.depth_mm,
            x_mm,
            cutting_speed_m_min: sp.v_c,
            feed_mm_per_rev: spec.data.feed_mm_per_rev,
            spindle_rpm: sp.n_c,
            spindle_motor_rpm: drive.motor_rpm(sp.n_c),
            table_rpm: sp.n_b,
            table_motor_rpm: sp.n_b * m.table.worm_ratio,
            axial_feed_mm_min: sp.v_f,
            vfd_hz: drive.vfd_hz(sp.n_c),
            analog_out_v: drive.analog_out_v(sp.n_c),
            approach_mm: st.approach,
            y_start_mm: st.y_start,
            y_end_mm: st.y_end,
            cut_time_s,
            pass_time_s: 0.0,
        };
        pass.pass_time_s = self.pass_time_s(&pass, sp.n_b_base);
        pass
    }

    /// A pass's cutting speed, spindle and table speeds and axial feed, each checked
    /// against the machine's limits.
    fn pass_speeds(&self, spec: &PassSpec, p: &mut Problems) -> PassSpeeds {
        let (t, m) = (&self.program().tool, self.m);
        let key_vc = format!("{}.cutting_speed_m_min", spec.data_key);
        let key_f = format!("{}.feed_mm_per_rev", spec.data_key);
        let v_c = spec.data.cutting_speed_m_min;
        p.require(v_c <= m.process.max_cutting_speed_m_min, &key_vc, || {
            format!(
                "{v_c} m/min is above the machine's process.max_cutting_speed_m_min = {}",
                m.process.max_cutting_speed_m_min
            )
        });
        let n_c = spindle_rpm(v_c, t.outside_diameter_mm);
        p.require(n_c <= m.spindle.max_spindle_rpm, &key_vc, || {
            format!(
                "gives {n_c:.1} spindle rpm with the {} mm tool, above the machine's spindle.max_spindle_rpm = {}",
                t.outside_diameter_mm, m.spindle.max_spindle_rpm
            )
        });
        // Base rotation of the table (hobbing) and the axial feed.
        let (n_b_base, v_f) = if self.is_indexing() {
            (0.0, spec.data.feed_mm_per_rev * n_c)
        } else {
            let n_b = table_rpm(n_c, self.c.starts, self.c.teeth);
            (n_b, axial_feed_mm_min(spec.data.feed_mm_per_rev, n_b))
        };
        // Table speed in the frame of gearing::signs: base rotation plus differential.
        let table_deg_min = self.signs.s_i() * self.signs.spindle.sign() * n_b_base * 360.0
            + self.signs.s_d() * self.differential_deg_per_mm * self.signs.s_f() * v_f;
        let n_b = table_deg_min.abs() / 360.0;
        p.require(n_b <= m.table.max_table_rpm, &key_vc, || {
            format!(
                "makes the table turn {n_b:.2} rpm ({} teeth, {} starts), above the machine's table.max_table_rpm = {}",
                self.c.teeth, self.c.starts, m.table.max_table_rpm
            )
        });
        p.require(v_f <= m.y.max_feed_mm_min, &key_f, || {
            format!(
                "gives an axial feed of {v_f:.1} mm/min, above the machine's y.max_feed_mm_min = {}",
                m.y.max_feed_mm_min
            )
        });
        PassSpeeds {
            v_c,
            n_c,
            n_b_base,
            v_f,
            n_b,
        }
    }

    /// The deepest X of a pass at `x_mm` (with the X shape's offsets) within the soft limit.
    fn check_deepest_x(&self, spec: &PassSpec, x_mm: f64, p: &mut Problems) {
        let m = self.m;
        let deepest = x_mm + self.c.x_shape.min_offset_mm();
        p.require(
            deepest >= m.x.soft_limit_min_mm,
            "strategy.total_depth_mm",
            || {
                format!(
                    "the {:?} pass needs X = {deepest:.3} mm, below the soft limit x.soft_limit_min_mm = {}",
                    spec.kind, m.x.soft_limit_min_mm
                )
            },
        );
    }

    /// A pass's stroke in Y (the approach, then the face width, with the allowances), its
    /// ends checked against Y's soft limits.
    fn stroke(&self, spec: &PassSpec, p: &mut Problems) -> Stroke {
        let prog = self.program();
        let (w, t, m) = (&prog.workpiece, &prog.tool, self.m);
        let approach = match prog.cycle.kind {
            CycleKind::RadialPlunge => 0.0,
            _ => approach_mm(
                spec.depth_mm,
                t.outside_diameter_mm,
                t.length_mm,
                self.swivel_signed_deg,
            ),
        };
        let bottom = w.height_above_table_mm;
        let top = bottom + w.face_width_mm;
        let (y_start, y_end) = match prog.cycle.start {
            StartSide::Top => (top + approach + w.allowance_mm, bottom - w.allowance_mm),
            StartSide::Bottom => (bottom - approach - w.allowance_mm, top + w.allowance_mm),
        };
        for y in [y_start, y_end] {
            p.require((m.y.soft_limit_min_mm..=m.y.soft_limit_max_mm).contains(&y), "workpiece.height_above_table_mm", || {
                format!(
                    "the stroke needs Y = {y:.3} mm, outside the soft limits y.soft_limit_min_mm .. y.soft_limit_max_mm = {} .. {}",
                    m.y.soft_limit_min_mm, m.y.soft_limit_max_mm
                )
            });
        }
        Stroke {
            approach,
            y_start,
            y_end,
        }
    }

    fn x_rapid_s(&self, distance_mm: f64) -> f64 {
        let x = &self.m.x;
        move_time_s(distance_mm, x.rapid_mm_min / 60.0, x.max_accel_mm_s2)
    }

    fn y_rapid_s(&self, distance_mm: f64) -> f64 {
        let y = &self.m.y;
        move_time_s(distance_mm, y.rapid_mm_min / 60.0, y.max_accel_mm_s2)
    }

    /// Time of one pass from X safe at Y start to X safe at Y end (the return to the next
    /// start is counted in [`Self::total_time_s`]).
    fn pass_time_s(&self, pass: &Pass, table_base_rpm: f64) -> f64 {
        let prog = self.program();
        let x_in = self.x_safe_mm() - pass.x_mm;
        let stroke = (pass.y_end_mm - pass.y_start_mm).abs();
        let stroke_s = if pass.axial_feed_mm_min > 0.0 {
            stroke / pass.axial_feed_mm_min * 60.0
        } else {
            0.0
        };
        match prog.cycle.kind {
            CycleKind::RadialAxial => self.x_rapid_s(x_in) + stroke_s + self.x_rapid_s(x_in),
            CycleKind::RadialPlunge => {
                // Rapid to 1 mm from the blank, feed to depth, one table turn at depth.
                let feed_mm_min = prog.strategy.plunge_feed_mm_min.unwrap_or(f64::INFINITY);
                let rapid = prog.strategy.retract_mm - 1.0;
                let plunge_s = (1.0 + pass.depth_mm) / feed_mm_min * 60.0;
                let turn_s = if table_base_rpm > 0.0 {
                    60.0 / table_base_rpm
                } else {
                    0.0
                };
                self.x_rapid_s(rapid) + plunge_s + turn_s + stroke_s + self.x_rapid_s(x_in)
            }
            CycleKind::ToothByTooth => {
                let t = &self.m.table;
                let index_s = move_time_s(
                    360.0 / f64::from(self.c.teeth),
                    t.max_table_rpm * 6.0,
                    t.max_accel_deg_s2,
                );
                let per_tooth = 2.0 * self.x_rapid_s(x_in) + stroke_s + self.y_rapid_s(stroke) + index_s;
                // The last tooth's return stroke is the cycle's move to the next start.
                per_tooth * f64::from(self.c.teeth) - self.y_rapid_s(stroke)
            }
        }
    }

    fn total_time_s(&self, passes: &[Pass]) -> f64 {
        let drive = self.m.spindle.drive();
        let ramp_s = |from_rpm: f64, to_rpm: f64| {
            (drive.vfd_hz(to_rpm) - drive.vfd_hz(from_rpm)).abs() / drive.vfd_hz_at_full_scale
                * self.m.spindle.vfd_ramp_s
        };
        let Some(first) = passes.first() else { return 0.0 };
        let mut total = ramp_s(0.0, first.spindle_rpm);
        let mut spindle = first.spindle_rpm;
        let mut y = first.y_start_mm;
        for pass in passes {
            total += ramp_s(spindle, pass.spindle_rpm) + self.y_rapid_s(pass.y_start_mm - y);
            total += pass.pass_time_s;
            spindle = pass.spindle_rpm;
            y = pass.y_end_mm;
        }
        total + self.y_rapid_s(first.y_start_mm - y) + ramp_s(spindle, 0.0)
    }

    fn warnings(&self, pitch_diameter_mm: f64, kind: ToolKind) -> Vec<String> {
        let prog = self.program();
        let w = &prog.workpiece;
        let m_n = w.module_mm;
        let mut out = Vec::new();
        let standard_tip = pitch_diameter_mm + 2.0 * m_n;
        if (w.outside_diameter_mm - standard_tip).abs() > m_n {
            out.push(format!(
                "workpiece.outside_diameter_mm = {} differs by more than a module from the standard tip diameter {standard_tip:.3} mm",
                w.outside_diameter_mm
            ));
        }
        let standard_depth = 2.25 * m_n;
        let depth = prog.strategy.total_depth_mm;
        if (depth - standard_depth).abs() > 0.1 * standard_depth {
            out.push(format!(
                "strategy.total_depth_mm = {depth} differs by more than 10 % from the standard tooth depth 2.25 m = {standard_depth:.3} mm"
            ));
        }
        if kind == ToolKind::Disk && prog.is_helical() {
            out.push(
                "a disk cutter on a helical gear: the profile is exact only for the helix it was ground for"
                    .into(),
            );
        }
        out
    }
}

#[cfg(test)]
mod tests;
