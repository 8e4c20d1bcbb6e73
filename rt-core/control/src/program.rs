//! The loaded program in the form the loop runs it: fixed size and `Copy`, built at
//! start-up (or on "load program") from a checked program and its plans.

use crate::setup_math::Blank;
use hob_gearing::shapes::XShape;
use hob_setup::config::Problems;
use hob_setup::config::machine::MachineConfig;
use hob_setup::job::{CycleKind, Mode, Program};
use hob_setup::planner::{self, Pass, PassKind, Plan};

/// Most passes a program may have in the loop.
pub const MAX_PASSES: usize = 51;

/// One pass as the loop needs it.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PassSetpoint {
    pub kind: PassKind,
    pub depth_mm: f64,
    pub x_mm: f64,
    pub spindle_rpm: f64,
    /// Y travel per spindle degree in the cut (unsigned).
    pub feed_mm_per_spindle_deg: f64,
    pub y_start_mm: f64,
    pub y_end_mm: f64,
}

impl PassSetpoint {
    /// The feed of Y in the cut at the programmed spindle speed, mm/s.
    pub fn axial_feed_mm_s(&self) -> f64 {
        self.feed_mm_per_spindle_deg * self.spindle_rpm * 6.0
    }

    fn from_pass(p: &Pass) -> Self {
        Self {
            kind: p.kind,
            depth_mm: p.depth_mm,
            x_mm: p.x_mm,
            spindle_rpm: p.spindle_rpm,
            feed_mm_per_spindle_deg: p.axial_feed_mm_min / (p.spindle_rpm * 360.0),
            y_start_mm: p.y_start_mm,
            y_end_mm: p.y_end_mm,
        }
    }
}

/// A program ready for the loop.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CycleProgram {
    pub cycle: CycleKind,
    pub teeth: u32,
    /// Table deg per spindle deg, signed (0 for tooth-by-tooth).
    pub ratio_signed: f64,
    /// Table deg per mm of Y, signed.
    pub differential_signed_deg_per_mm: f64,
    /// +1 or -1: the spindle's sense of rotation.
    pub spindle_sign: f64,
    /// +1 or -1: the feed direction in the cut.
    pub feed_sign: f64,
    pub x_safe_mm: f64,
    /// X with the tool tip on the blank's outside diameter.
    pub x_surface_mm: f64,
    pub face_bottom_mm: f64,
    /// The blank as a touch-off judges it: its outside diameter, its face's width above
    /// `face_bottom_mm` and the program's total depth (`CycleProgram::blank`).
    pub blank_outside_diameter_mm: f64,
    pub face_width_mm: f64,
    pub total_depth_mm: f64,
    pub shape: XShape,
    pub plunge_feed_mm_min: f64,
    /// The hob's tip diameter (a touch-off's centre distance and height come from it).
    pub tool_tip_diameter_mm: f64,
    /// The gear's pitch diameter and normal module (to express errors at the pitch circle).
    pub pitch_diameter_mm: f64,
    pub normal_module_mm: f64,
    #[serde(with = "hob_gearing::serde_arrays")]
    passes: [PassSetpoint; MAX_PASSES],
    pass_count: usize,
    single: Option<PassSetpoint>,
}

impl CycleProgram {
    /// Y travel of a pass per table revolution, mm: how far apart along Y a tooth gap
    /// meets the hob (0 tooth by tooth, where the table does not turn with the spindle).
    pub fn feed_per_table_rev_mm(&self, pass: &PassSetpoint) -> f64 {
        if self.ratio_signed == 0.0 {
            0.0
        } else {
            pass.feed_mm_per_spindle_deg * 360.0 / self.ratio_signed.abs()
        }
    }

    /// Checks and plans `program` on `machine` (both modes); `None` with the problems
    /// recorded when it cannot be cut.
    pub fn build(program: &Program, machine: &MachineConfig, p: &mut Problems) -> Option<Self> {
        let mut automatic = program.clone();
        automatic.cycle.mode = Mode::Automatic;
        let plan = planner::plan(&automatic, machine, p)?;
        let checked = program.check(p)?;
        let single = match program.cycle.single_depth_mm {
            Some(_) => {
                let mut single = program.clone();
                single.cycle.mode = Mode::Single;
                planner::plan(&single, machine, p)?
                    .passes
                    .first()
                    .map(PassSetpoint::from_pass)
            }
            None => None,
        };
        if plan.passes.len() > MAX_PASSES {
            p.push(
                "strategy.rough_passes",
                format!("at most {} passes in all", MAX_PASSES),
            );
            return None;
        }
        Some(Self::from_plan(program, &plan, checked.x_shape, single))
    }

    fn from_plan(program: &Program, plan: &Plan, shape: XShape, single: Option<PassSetpoint>) -> Self {
        let s = &plan.signs;
        let ratio = if program.cycle.kind == CycleKind::ToothByTooth {
            0.0
        } else {
            plan.egb_ratio
        };
        let mut passes = [PassSetpoint::from_pass(&plan.passes[0]); MAX_PASSES];
        for (slot, pass) in passes.iter_mut().zip(&plan.passes) {
            *slot = PassSetpoint::from_pass(pass);
        }
        Self {
            cycle: program.cycle.kind,
            teeth: plan.teeth,
            ratio_signed: s.s_i() * ratio,
            differential_signed_deg_per_mm: s.s_d() * plan.differential_deg_per_mm,
            spindle_sign: s.spindle.sign(),
            feed_sign: s.s_f(),
            x_safe_mm: plan.x_safe_mm,
            x_surface_mm: plan.x_safe_mm - program.strategy.retract_mm,
            face_bottom_mm: program.workpiece.height_above_table_mm,
            blank_outside_diameter_mm: program.workpiece.outside_diameter_mm,
            face_width_mm: program.workpiece.face_width_mm,
            total_depth_mm: program.strategy.total_depth_mm,
            shape,
            plunge_feed_mm_min: program.strategy.plunge_feed_mm_min.unwrap_or(0.0),
            tool_tip_diameter_mm: program.tool.outside_diameter_mm,
            pitch_diameter_mm: plan.pitch_diameter_mm,
            normal_module_mm: plan.normal_module_mm,
            passes,
            pass_count: plan.passes.len(),
            single,
        }
    }

    /// The passes of the automatic cycle.
    pub fn passes(&self) -> &[PassSetpoint] {
        &self.passes[..self.pass_count]
    }

    /// The single-mode pass, if the program has a single depth.
    pub fn single(&self) -> Option<PassSetpoint> {
        self.single
    }

    /// The smallest and largest X and Y the program's moves reach (mm): X from the
    /// deepest point of the cut to the safe position, Y over every pass's stroke.
    pub fn extents_mm(&self) -> (f64, f64, f64, f64) {
        let mut x = (self.x_safe_mm, self.x_safe_mm);
        let mut y = (f64::INFINITY, f64::NEG_INFINITY);
        for p in self.passes().iter().chain(self.single.iter()) {
            x.0 = x.0.min(p.x_mm + self.shape.min_offset_mm());
            for v in [p.y_start_mm, p.y_end_mm] {
                y = (y.0.min(v), y.1.max(v));
            }
        }
        (x.0, x.1, y.0, y.1)
    }

    /// The loaded blank as a touch-off judges it.
    pub fn blank(&self) -> Blank {
        Blank {
            outside_diameter_mm: self.blank_outside_diameter_mm,
            total_depth_mm: self.total_depth_mm,
            face_bottom_mm: self.face_bottom_mm,
            face_top_mm: self.face_bottom_mm + self.face_width_mm,
        }
    }

    /// Pitch of the table between equivalent tooth phases.
    pub fn pitch_deg(&self) -> f64 {
        360.0 / f64::from(self.teeth)
    }
}
