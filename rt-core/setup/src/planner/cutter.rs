//! A tooth-by-tooth program's disk cutter against its gear (issue 17): how far the cutter's
//! profile (`[tool.disk]`) is from the gear's involute, refused beyond the profile form
//! tolerance of the grade the program asks for (`workpiece.grade`); with the cutter's mass,
//! its natural frequency (seed 003) against each pass's tooth-passing frequency, warned near
//! resonance, and refused where its predicted peak side load overloads its body.

use crate::config::Problems;
use crate::job::{DiskTool, Program, SingleSpeeds, ToolKind};
use crate::planner::{Pass, PassKind};
use hob_cutters::dynamics::{CutterBody, Link, Material, SideCut, deflection, speed_ranges};
use hob_cutters::fit::{Fit, fit};
use hob_cutters::space::{Gear, Space};
use hob_gearing::iso1328::profile_form_tolerance_um;
use serde::Serialize;

/// The tooth-passing frequency within this factor of the natural frequency is near
/// resonance.
pub const NEAR_RESONANCE: (f64, f64) = (0.8, 1.25);

/// The cutter's part of a plan.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CutterPlan {
    /// The profile's largest distance from the gear's active involute, um, and where.
    pub profile_deviation_um: f64,
    pub at_gear_radius_mm: f64,
    /// `workpiece.grade` and its profile form tolerance `f_falpha`, um.
    pub grade: Option<u8>,
    pub profile_form_tolerance_um: Option<f64>,
    /// Seed 003's link, with `tool.disk.mass_kg`.
    pub natural_frequency_hz: Option<f64>,
    pub damping_ratio: Option<f64>,
    /// Each pass's tooth-passing frequency, Hz.
    pub tooth_passing_hz: Vec<f64>,
    /// With `workpiece.material` too: each pass's side force and predicted profile error
    /// (one flank's force, unbalanced: the worst case), and the cutting speeds that keep the
    /// error within the grade's `f_falpha`.
    pub passes: Vec<CutterPass>,
}

/// One pass of the cutter (seed 003's model, closed form).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CutterPass {
    pub side_chip_thickness_mm: f64,
    pub side_chip_width_mm: f64,
    pub side_force_n: f64,
    pub frequency_ratio: f64,
    pub amplification: f64,
    pub profile_error_um: f64,
    /// The load on the cutter body at the peak deflection, and what it takes at
    /// `tool.disk.allowable_bending_mpa` (a pass above it is refused), N.
    pub peak_load_n: f64,
    pub load_limit_n: Option<f64>,
    /// Cutting speeds (m/min, 5-200) with the error within `f_falpha`, when a grade is given.
    pub speed_ranges_m_min: Vec<(f64, f64)>,
}

/// The side edge's cut of a pass, one flank's (the worst case): the chip thickness is the
/// feed per tooth, the width the flank engaged to the pass's depth (`depth / cos(alpha)`).
pub fn side_cut(
    feed_mm_per_rev: f64,
    gashes: u32,
    depth_mm: f64,
    pressure_angle_deg: f64,
    speed_m_min: f64,
) -> SideCut {
    SideCut {
        chip_thickness_mm: feed_mm_per_rev / f64::from(gashes.max(1)),
        chip_width_mm: depth_mm / pressure_angle_deg.to_radians().cos(),
        cutting_speed_m_min: speed_m_min,
    }
}

/// The cutter's plan, problems and warnings; None without a disk profile.
pub fn plan(
    prog: &Program,
    gashes: u32,
    passes: &[Pass],
    p: &mut Problems,
    warnings: &mut Vec<String>,
) -> Option<CutterPlan> {
    let t = &prog.tool;
    let disk = t.disk.as_ref().filter(|_| t.kind == ToolKind::Disk)?;
    let w = &prog.workpiece;
    let gear = Gear {
        teeth: u32::try_from(w.teeth).ok()?,
        normal_module_mm: w.module_mm,
        pressure_angle_deg: t.pressure_angle_deg,
        profile_shift: 0.0,
        helix_deg: w.helix_deg,
    };
    let grade = w.grade.and_then(|g| u8::try_from(g).ok());
    let space = gear_space(gear, grade, p, warnings)?;
    let f = fit(&space, &disk.profile, 0.5 * t.outside_diameter_mm);
    let tolerance = grade.map(|g| profile_form_tolerance_um(w.module_mm, g));
    check_profile(&f, grade, tolerance, p);
    let body = cutter_body(prog, disk, gashes);
    let link = body.and_then(|b| b.link().ok());
    let mut cutter_passes = Vec::new();
    if let (Some(body), Some(m)) = (body, w.material.as_ref()) {
        let judge = PassJudge {
            body,
            material: Material {
                kc11_n_mm2: m.kc11_n_mm2,
                mc: m.mc,
            },
            gashes,
            pressure_angle_deg: t.pressure_angle_deg,
            allowable_bending_mpa: disk.allowable_bending_mpa,
            single_speeds: prog.cycle.single_speeds,
            grade,
            tolerance,
        };
        for (k, pass) in passes.iter().enumerate() {
            cutter_passes.extend(judge.judge(k, pass, p, warnings));
        }
    }
    let tooth_passing_hz: Vec<f64> = passes
        .iter()
        .map(|pass| f64::from(gashes) * pass.spindle_rpm / 60.0)
        .collect();
    if let Some(l) = link {
        warn_near_resonance(&l, &tooth_passing_hz, warnings);
    }
    Some(CutterPlan {
        profile_deviation_um: f.deviation_um,
        at_gear_radius_mm: f.at_gear_radius_mm,
        grade,
        profile_form_tolerance_um: tolerance,
        natural_frequency_hz: link.map(|l| l.natural_frequency_hz),
        damping_ratio: link.map(|l| l.damping_ratio),
        tooth_passing_hz,
        passes: cutter_passes,
    })
}

/// The gear's tooth space; when there is none, a problem with a grade to judge against,
/// a warning without.
fn gear_space(gear: Gear, grade: Option<u8>, p: &mut Problems, warnings: &mut Vec<String>) -> Option<Space> {
    match Space::new(gear) {
        Ok(s) => Some(s),
        Err(e) => {
            match grade {
                Some(_) => p.push(
                    "tool.disk.profile",
                    format!("cannot be judged against this gear: {e}"),
                ),
                None => warnings.push(format!("the disk cutter's profile is not judged: {e}")),
            }
            None
        }
    }
}

/// The profile's deviation against the grade's profile form tolerance, when a grade is
/// given.
fn check_profile(f: &Fit, grade: Option<u8>, tolerance: Option<f64>, p: &mut Problems) {
    if let (Some(g), Some(tol)) = (grade, tolerance) {
        p.require(f.deviation_um <= tol, "tool.disk.profile", || {
            format!(
                "departs from the gear's involute by {:.1} um (at radius {:.3} mm): beyond f_falpha {tol:.2} um of grade {g} (workpiece.grade)",
                f.deviation_um, f.at_gear_radius_mm
            )
        });
    }
}

/// The cutter's body for seed 003's model, with `tool.disk.mass_kg`.
fn cutter_body(prog: &Program, disk: &DiskTool, gashes: u32) -> Option<CutterBody> {
    let t = &prog.tool;
    disk.mass_kg.map(|m| CutterBody {
        width_mm: t.length_mm,
        outside_diameter_mm: t.outside_diameter_mm,
        mass_kg: m,
        youngs_modulus_mpa: disk.youngs_modulus_mpa,
        log_decrement: disk.log_decrement,
        teeth: gashes,
    })
}

/// The strategy whose feed a pass runs at (a single pass: the one `cycle.single_speeds`
/// names).
fn feed_key(kind: PassKind, single_speeds: SingleSpeeds) -> &'static str {
    match (kind, single_speeds) {
        (PassKind::Finish, _) | (PassKind::Single, SingleSpeeds::Finish) => "strategy.finish.feed_mm_per_rev",
        (PassKind::Rough, _) | (PassKind::Single, SingleSpeeds::Rough) => "strategy.rough.feed_mm_per_rev",
    }
}

/// What judges each pass of a cutter with a body and a workpiece material.
struct PassJudge {
    body: CutterBody,
    material: Material,
    gashes: u32,
    pressure_angle_deg: f64,
    allowable_bending_mpa: f64,
    single_speeds: SingleSpeeds,
    grade: Option<u8>,
    tolerance: Option<f64>,
}

impl PassJudge {
    /// Pass `k`'s side cut and deflection: refused where its peak load overloads the body,
    /// warned where its profile error is beyond the grade; None where the model has no
    /// answer.
    fn judge(
        &self,
        k: usize,
        pass: &Pass,
        p: &mut Problems,
        warnings: &mut Vec<String>,
    ) -> Option<CutterPass> {
        let cut = side_cut(
            pass.feed_mm_per_rev,
            self.gashes,
            pass.depth_mm,
            self.pressure_angle_deg,
            pass.cutting_speed_m_min,
        );
        let d = deflection(&self.body, &self.material, &cut).ok()?;
        let load_limit_n = self.body.load_limit_n(self.allowable_bending_mpa).ok();
        if let Some(limit) = load_limit_n {
            let key = feed_key(pass.kind, self.single_speeds);
            p.require(d.peak_load_n <= limit, key, || {
                format!(
                    "pass {}: the disk cutter's predicted peak side load {:.0} N (deflection {:.0} um, seed 003) overloads it: its body takes {limit:.0} N at tool.disk.allowable_bending_mpa = {} MPa; a smaller feed, a shallower pass or another cutting speed lowers the load",
                    k + 1,
                    d.peak_load_n,
                    d.profile_error_um,
                    self.allowable_bending_mpa
                )
            });
        }
        let speed_ranges_m_min = self
            .tolerance
            .and_then(|tol| speed_ranges(&self.body, &self.material, &cut, (5.0, 200.0, 0.5), tol).ok())
            .unwrap_or_default();
        if let (Some(g), Some(tol)) = (self.grade, self.tolerance)
            && d.profile_error_um > tol
        {
            warnings.push(format!(
                "pass {}: the disk cutter's predicted profile error {:.1} um (one flank's side force {:.0} N, seed 003) is beyond f_falpha {tol:.2} um of grade {g}",
                k + 1,
                d.profile_error_um,
                d.side_force_n
            ));
        }
        Some(CutterPass {
            side_chip_thickness_mm: cut.chip_thickness_mm,
            side_chip_width_mm: cut.chip_width_mm,
            side_force_n: d.side_force_n,
            frequency_ratio: d.frequency_ratio,
            amplification: d.amplification,
            profile_error_um: d.profile_error_um,
            peak_load_n: d.peak_load_n,
            load_limit_n,
            speed_ranges_m_min,
        })
    }
}

/// A warning for each pass whose tooth-passing frequency is near the cutter's natural
/// frequency.
fn warn_near_resonance(link: &Link, tooth_passing_hz: &[f64], warnings: &mut Vec<String>) {
    for (k, fz) in tooth_passing_hz.iter().enumerate() {
        let r = fz / link.natural_frequency_hz;
        if (NEAR_RESONANCE.0..=NEAR_RESONANCE.1).contains(&r) {
            warnings.push(format!(
                "pass {}: the cutter's teeth pass at {fz:.1} Hz, {r:.2} of its natural frequency {:.1} Hz (seed 003): near resonance, choose another cutting speed",
                k + 1,
                link.natural_frequency_hz
            ));
        }
    }
}
