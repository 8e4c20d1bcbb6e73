//! The operator's program ("job"): one gear on one tool with one cycle, as a TOML file the
//! operator (later the HMI) saves, lists and reloads.
//!
//! This module holds the file format and the checks that need no machine; the checks
//! against the machine (speeds, travel, tool range) are in [`crate::planner`], so
//! `hob check` and `hob plan` refuse exactly the same programs.

use crate::config::source::locate_key;
use crate::config::{LoadError, Problem, Problems, parse_toml};
use hob_gearing::shapes::{Contour, ContourError, Crowning, MAX_CONTOUR_POINTS, XShape, crowning_height_mm};
use hob_gearing::signs::{CutMethod, Hand, StartSide};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A program file.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Program {
    pub workpiece: Workpiece,
    pub tool: Tool,
    pub cycle: Cycle,
    pub strategy: Strategy,
}

/// The gear to cut.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Workpiece {
    /// Free text for the operator (part number, customer).
    #[serde(default)]
    pub name: Option<String>,
    pub teeth: i64,
    /// Normal module.
    pub module_mm: f64,
    /// 0 = spur.
    pub helix_deg: f64,
    /// Hand of the gear's helix; ignored for spur.
    pub helix_hand: Hand,
    pub face_width_mm: f64,
    pub outside_diameter_mm: f64,
    /// Bottom face of the toothed part above the table.
    pub height_above_table_mm: f64,
    /// Approach and exit allowance on Y.
    pub allowance_mm: f64,
    #[serde(default)]
    pub crowning: Option<CrowningSpec>,
    /// `[face_mm, x_offset_mm]` points, face_mm from the bottom face.
    #[serde(default)]
    pub contour: Option<Vec<[f64; 2]>>,
    /// The ISO 1328-1 grade the gear is to hold (1-11). A disk cutter's profile must then
    /// stay within the grade's profile form tolerance of the gear's involute.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grade: Option<i64>,
    /// The workpiece material's cutting coefficients (Kienzle), for a disk cutter's side
    /// force (`hob plan` of a tooth-by-tooth program).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub material: Option<MaterialSpec>,
}

/// A workpiece material: Kienzle's specific cutting force `k_c1.1` and exponent `m_c`
/// (docs/domain.md section 8: 42CrMo4, 2600 N/mm2 and 0.26).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    pub kc11_n_mm2: f64,
    pub mc: f64,
}

/// Crowning given by its arc height or its radius (exactly one).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CrowningSpec {
    #[serde(default)]
    pub height_mm: Option<f64>,
    #[serde(default)]
    pub radius_mm: Option<f64>,
}

/// Kind of cutting tool.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ToolKind {
    /// Hob: generates the gear in continuous rolling.
    Hob,
    /// Profiled disk cutter: one tooth space at a time (tooth-by-tooth cycle).
    Disk,
}

/// The cutting tool.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Tool {
    pub kind: ToolKind,
    /// Free text for the operator (tool number).
    #[serde(default)]
    pub name: Option<String>,
    pub module_mm: f64,
    pub pressure_angle_deg: f64,
    /// Number of starts (hob); must be 1 or absent for a disk.
    #[serde(default)]
    pub starts: Option<i64>,
    /// Lead angle of the hob thread; 0 or absent for a disk.
    #[serde(default)]
    pub lead_angle_deg: Option<f64>,
    /// Hand of the hob thread; absent for a disk.
    #[serde(default)]
    pub hand: Option<Hand>,
    pub outside_diameter_mm: f64,
    /// Hob length, or disk width.
    pub length_mm: f64,
    pub gashes: i64,
    /// A disk cutter's profile and geometry (`[tool.disk]`); a hob has none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub disk: Option<DiskTool>,
}

/// A profile disk cutter's own geometry (issue 17): its profile as line and arc primitives
/// in its axial plane (`hob_cutters::profile`; `hob cutter design --toml` writes one), its
/// rake and clearance, and for its dynamics (seed 003) its mass, decrement and modulus.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct DiskTool {
    pub profile: Vec<hob_cutters::profile::Primitive>,
    #[serde(default)]
    pub rake_deg: f64,
    pub clearance_deg: f64,
    /// The cutter unit's vibrating mass; without it no dynamics are predicted.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mass_kg: Option<f64>,
    /// Logarithmic decrement of its free vibration (seed 003: 0.3; a tap test measures it).
    #[serde(default = "DiskTool::default_log_decrement")]
    pub log_decrement: f64,
    /// Young's modulus of its material (alloy steel 2.1e5 MPa, seed 003).
    #[serde(default = "DiskTool::default_modulus")]
    pub youngs_modulus_mpa: f64,
    /// The bending stress its body may carry, MPa: a pass whose predicted peak side load
    /// exceeds what this allows (seed 003's beam, docs/cutters.md) is refused; if not given,
    /// [`hob_cutters::dynamics::DEFAULT_ALLOWABLE_BENDING_MPA`] (an assumption).
    #[serde(default = "DiskTool::default_allowable_bending")]
    pub allowable_bending_mpa: f64,
}

impl DiskTool {
    fn default_log_decrement() -> f64 {
        0.3
    }

    fn default_modulus() -> f64 {
        2.1e5
    }

    fn default_allowable_bending() -> f64 {
        hob_cutters::dynamics::DEFAULT_ALLOWABLE_BENDING_MPA
    }

    /// Problems named `tool.disk.<field>`.
    fn check(&self, outside_diameter_mm: f64, width_mm: f64, p: &mut Problems) {
        match hob_cutters::profile::validate(&self.profile, 0.5 * outside_diameter_mm) {
            Err(e) => p.push("tool.disk.profile", e.to_string()),
            Ok(()) => {
                let span = self.profile[self.profile.len() - 1].end().x - self.profile[0].start().x;
                p.require(span <= width_mm + 1e-6, "tool.disk.profile", || {
                    format!("spans {span:.3} mm across the cutter, wider than tool.length_mm = {width_mm} mm")
                });
            }
        }
        p.within("tool.disk.rake_deg", self.rake_deg, -20.0, 30.0, "deg");
        p.within("tool.disk.clearance_deg", self.clearance_deg, 0.0, 30.0, "deg");
        if let Some(m) = self.mass_kg {
            p.positive("tool.disk.mass_kg", m);
        }
        p.within("tool.disk.log_decrement", self.log_decrement, 0.001, 2.0, "");
        p.within(
            "tool.disk.youngs_modulus_mpa",
            self.youngs_modulus_mpa,
            1e4,
            1e6,
            "MPa",
        );
        p.within(
            "tool.disk.allowable_bending_mpa",
            self.allowable_bending_mpa,
            10.0,
            3000.0,
            "MPa",
        );
    }
}

impl Tool {
    /// The checks of the tool alone (no gear): what a program's `[tool]` and a library
    /// tool record share. Problems are named `tool.<field>`; true when there were none.
    pub fn check(&self, p: &mut Problems) -> bool {
        let before = p.as_slice().len();
        p.positive("tool.module_mm", self.module_mm);
        self.check_own(p);
        p.as_slice().len() == before
    }

    /// What [`Tool::check`] checks but the module (a program compares it with the gear's).
    fn check_own(&self, p: &mut Problems) -> (Option<u32>, Option<u32>, Option<f64>, Option<Hand>) {
        let t = self;
        p.require(
            t.pressure_angle_deg > 0.0 && t.pressure_angle_deg < 45.0,
            "tool.pressure_angle_deg",
            || {
                format!(
                    "must be within 0 .. 45 deg, exclusive (is {})",
                    t.pressure_angle_deg
                )
            },
        );
        p.positive("tool.outside_diameter_mm", t.outside_diameter_mm);
        p.positive("tool.length_mm", t.length_mm);
        let gashes = count(p, "tool.gashes", t.gashes, 1, 100);
        let (starts, lead, hand) = self.check_kind(p);
        match (&t.disk, t.kind) {
            (Some(d), ToolKind::Disk) => d.check(t.outside_diameter_mm, t.length_mm, p),
            (Some(_), ToolKind::Hob) => {
                p.push("tool.disk", "a hob has no disk profile: leave [tool.disk] out")
            }
            (None, _) => {}
        }
        (gashes, starts, lead, hand)
    }

    fn check_kind(&self, p: &mut Problems) -> (Option<u32>, Option<f64>, Option<Hand>) {
        let t = self;
        match t.kind {
            ToolKind::Hob => {
                let starts = match t.starts {
                    Some(z0) => count(p, "tool.starts", z0, 1, 10),
                    None => {
                        p.push("tool.starts", "a hob needs its number of starts");
                        None
                    }
                };
                let lead = match t.lead_angle_deg {
                    Some(g) if (0.0..15.0).contains(&g) => Some(g),
                    Some(g) => {
                        p.push(
                            "tool.lead_angle_deg",
                            format!("must be within 0 .. 15 deg (is {g})"),
                        );
                        None
                    }
                    None => {
                        p.push("tool.lead_angle_deg", "a hob needs its lead angle");
                        None
                    }
                };
                if t.hand.is_none() {
                    p.push("tool.hand", "a hob needs its hand: \"right\" or \"left\"");
                }
                (starts, lead, t.hand)
            }
            ToolKind::Disk => {
                p.require(t.starts.is_none_or(|z0| z0 == 1), "tool.starts", || {
                    "a disk cutter has no starts: leave it out or set 1".into()
                });
                p.require(
                    t.lead_angle_deg.is_none_or(|g| g == 0.0),
                    "tool.lead_angle_deg",
                    || "a disk cutter has no lead angle: leave it out or set 0".into(),
                );
                p.require(t.hand.is_none(), "tool.hand", || {
                    "a disk cutter has no hand: leave it out".into()
                });
                // The disk is swivelled by the helix angle alone; its "hand" is irrelevant.
                (Some(1), Some(0.0), Some(Hand::Right))
            }
        }
    }
}

/// The key of a program's `[tool]` that names a library tool instead of the tool's fields.
pub const TOOL_LIBRARY_KEY: &str = "tool.library";

/// A program's `[tool]` that names a library tool: `[tool] library = "NAME"`.
#[derive(Debug, Clone, PartialEq)]
pub struct ToolReference {
    /// The library tool's name.
    pub library: String,
    /// Tool fields written beside the reference (a program with both is refused).
    pub tool_keys: Vec<String>,
}

impl ToolReference {
    /// The reference in a program's text, if its `[tool]` has a `library` key. Refused:
    /// text that is not TOML, and a `library` that is not a string.
    pub fn find(origin: &Path, src: &str) -> Result<Option<Self>, LoadError> {
        let table: toml::Table = parse_toml(origin, src)?;
        let Some(tool) = table.get("tool").and_then(toml::Value::as_table) else {
            return Ok(None);
        };
        let Some(value) = tool.get("library") else {
            return Ok(None);
        };
        let Some(name) = value.as_str() else {
            return Err(LoadError::Invalid {
                file: origin.to_path_buf(),
                problems: vec![Problem {
                    key: TOOL_LIBRARY_KEY.into(),
                    message: format!("must be the name of a library tool, as a string (is {value})"),
                    position: locate_key(src, TOOL_LIBRARY_KEY),
                }],
            });
        };
        Ok(Some(Self {
            library: name.to_string(),
            tool_keys: tool.keys().filter(|k| *k != "library").cloned().collect(),
        }))
    }

    /// Why a `[tool]` with both a reference and tool fields is refused.
    pub fn both_message(&self) -> String {
        format!(
            "names the library tool {:?} and gives tool fields too ({}): keep either the reference or the fields",
            self.library,
            self.tool_keys.join(", ")
        )
    }
}

/// Which cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum CycleKind {
    RadialAxial,
    RadialPlunge,
    ToothByTooth,
}

/// Automatic (all passes) or single (one pass at an entered depth, then stop).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mode {
    Automatic,
    Single,
}

/// Which cutting data a single-mode pass uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SingleSpeeds {
    #[default]
    Rough,
    Finish,
}

/// The cycle and its options.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Cycle {
    pub kind: CycleKind,
    pub start: StartSide,
    pub method: CutMethod,
    pub mode: Mode,
    /// Depth of the single-mode pass (cumulative from the blank's outside diameter).
    #[serde(default)]
    pub single_depth_mm: Option<f64>,
    #[serde(default)]
    pub single_speeds: SingleSpeeds,
}

/// Cutting data of one kind of pass.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CuttingData {
    pub cutting_speed_m_min: f64,
    /// Axial feed per table revolution (hob) or per cutter revolution (disk).
    pub feed_mm_per_rev: f64,
}

/// Depths, passes and cutting data.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Strategy {
    pub total_depth_mm: f64,
    pub rough_passes: i64,
    /// Left for the finishing pass; 0 = no finishing pass.
    pub finish_allowance_mm: f64,
    /// Depth of cut of each rough pass; must sum to total - allowance.
    #[serde(default)]
    pub rough_depths_mm: Option<Vec<f64>>,
    /// X distance from the blank's outside diameter to the safe position.
    pub retract_mm: f64,
    /// Radial feed of the radial-plunge cycle.
    #[serde(default)]
    pub plunge_feed_mm_min: Option<f64>,
    pub rough: CuttingData,
    pub finish: CuttingData,
}

/// Tolerance for sums of depths entered with a few decimals.
const DEPTH_SUM_TOLERANCE_MM: f64 = 1e-6;

/// A program whose machine-independent checks have passed, with its derived values.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckedProgram {
    pub program: Program,
    pub teeth: u32,
    pub starts: u32,
    pub gashes: u32,
    pub rough_passes: u32,
    pub hob_hand: Hand,
    pub lead_angle_deg: f64,
    pub x_shape: XShape,
}

impl Program {
    /// Deserialises a self-contained program's text (`origin` names it in errors). A
    /// `[tool]` that names a library tool (`library = "NAME"`) is refused: such a program
    /// is planned, checked and loaded only once the library has filled in the tool
    /// (`hob_store::library::Library::resolve`).
    pub fn parse(origin: &Path, src: &str) -> Result<Self, LoadError> {
        if let Some(r) = ToolReference::find(origin, src)? {
            let message = if r.tool_keys.is_empty() {
                format!(
                    "names the library tool {:?}: resolve it through the program library first (hob check|plan|load with the library)",
                    r.library
                )
            } else {
                r.both_message()
            };
            return Err(LoadError::Invalid {
                file: origin.to_path_buf(),
                problems: vec![Problem {
                    key: TOOL_LIBRARY_KEY.into(),
                    message,
                    position: locate_key(src, TOOL_LIBRARY_KEY),
                }],
            });
        }
        parse_toml(origin, src)
    }

    /// Whether the gear is helical.
    pub fn is_helical(&self) -> bool {
        self.workpiece.helix_deg != 0.0
    }

    /// The machine-independent checks. Problems are named by key.
    pub fn check(&self, p: &mut Problems) -> Option<CheckedProgram> {
        let teeth = self.check_workpiece(p);
        let x_shape = self.check_shape(p);
        self.check_tool_module(p);
        let (gashes, starts, lead_angle_deg, hob_hand) = self.tool.check_own(p);
        self.check_cycle_fits_tool(p);
        let rough_passes = self.check_strategy(p);
        self.check_single_depth(p);
        if !p.is_empty() {
            return None;
        }
        Some(CheckedProgram {
            program: self.clone(),
            teeth: teeth?,
            starts: starts?,
            gashes: gashes?,
            rough_passes: rough_passes?,
            hob_hand: hob_hand?,
            lead_angle_deg: lead_angle_deg?,
            x_shape: x_shape?,
        })
    }

    /// `[workpiece]`'s own values (the shape apart); the number of teeth when valid.
    fn check_workpiece(&self, p: &mut Problems) -> Option<u32> {
        let w = &self.workpiece;
        let teeth = count(p, "workpiece.teeth", w.teeth, 1, 10_000);
        p.positive("workpiece.module_mm", w.module_mm);
        p.within("workpiece.helix_deg", w.helix_deg, 0.0, 89.0, "deg");
        p.positive("workpiece.face_width_mm", w.face_width_mm);
        p.positive("workpiece.outside_diameter_mm", w.outside_diameter_mm);
        p.non_negative("workpiece.height_above_table_mm", w.height_above_table_mm);
        p.non_negative("workpiece.allowance_mm", w.allowance_mm);
        if let Some(g) = w.grade {
            count(p, "workpiece.grade", g, 1, 11);
        }
        if let Some(m) = &w.material {
            p.within(
                "workpiece.material.kc11_n_mm2",
                m.kc11_n_mm2,
                100.0,
                10_000.0,
                "N/mm2",
            );
            p.within("workpiece.material.mc", m.mc, 0.0, 0.6, "");
        }
        teeth
    }

    /// The tool's module, and that it is the gear's.
    fn check_tool_module(&self, p: &mut Problems) {
        let (w, t) = (&self.workpiece, &self.tool);
        p.positive("tool.module_mm", t.module_mm);
        p.require(
            !(t.module_mm > 0.0 && w.module_mm > 0.0) || (t.module_mm - w.module_mm).abs() <= 1e-9,
            "tool.module_mm",
            || {
                format!(
                    "the tool's module {} mm differs from the gear's normal module workpiece.module_mm = {} mm",
                    t.module_mm, w.module_mm
                )
            },
        );
    }

    /// The cycle and the kind of tool go together: tooth-by-tooth with a disk cutter, the
    /// other cycles with a hob.
    fn check_cycle_fits_tool(&self, p: &mut Problems) {
        let (c, t) = (&self.cycle, &self.tool);
        p.require(
            !(c.kind == CycleKind::ToothByTooth && t.kind == ToolKind::Hob),
            "cycle.kind",
            || "tooth-by-tooth needs a profiled disk cutter: set tool.kind = \"disk\"".into(),
        );
        p.require(
            !(c.kind != CycleKind::ToothByTooth && t.kind == ToolKind::Disk),
            "tool.kind",
            || "a disk cutter cuts one tooth space at a time: set cycle.kind = \"tooth-by-tooth\"".into(),
        );
    }

    /// `[strategy]`: depths, passes, retract, cutting data and the plunge feed; the number
    /// of rough passes when valid.
    fn check_strategy(&self, p: &mut Problems) -> Option<u32> {
        let s = &self.strategy;
        p.positive("strategy.total_depth_mm", s.total_depth_mm);
        p.non_negative("strategy.finish_allowance_mm", s.finish_allowance_mm);
        p.require(
            s.finish_allowance_mm < s.total_depth_mm,
            "strategy.finish_allowance_mm",
            || {
                format!(
                    "must be smaller than strategy.total_depth_mm = {} (is {})",
                    s.total_depth_mm, s.finish_allowance_mm
                )
            },
        );
        let rough_passes = count(p, "strategy.rough_passes", s.rough_passes, 1, 50);
        self.check_rough_depths(p);
        p.positive("strategy.retract_mm", s.retract_mm);
        self.check_cutting_data(p, "strategy.rough", &s.rough);
        self.check_cutting_data(p, "strategy.finish", &s.finish);
        if self.cycle.kind == CycleKind::RadialPlunge {
            self.check_plunge(p);
        }
        rough_passes
    }

    /// The radial-plunge cycle's plunge feed and retract.
    fn check_plunge(&self, p: &mut Problems) {
        let s = &self.strategy;
        match s.plunge_feed_mm_min {
            Some(f) => p.positive("strategy.plunge_feed_mm_min", f),
            None => p.push(
                "strategy.plunge_feed_mm_min",
                "the radial-plunge cycle needs a plunge feed",
            ),
        }
        p.require(s.retract_mm > 1.0, "strategy.retract_mm", || {
            format!(
                "the radial-plunge cycle rapids to 1 mm from the blank: retract must be more than 1 mm (is {})",
                s.retract_mm
            )
        });
    }

    /// The single-mode depth, checked whenever it is given: the same program may be
    /// started in single mode from the HMI.
    fn check_single_depth(&self, p: &mut Problems) {
        let (c, s) = (&self.cycle, &self.strategy);
        match c.single_depth_mm {
            None if c.mode == Mode::Single => {
                p.push("cycle.single_depth_mm", "single mode needs the depth of its pass")
            }
            None => {}
            Some(d) => p.require(d > 0.0 && d <= s.total_depth_mm, "cycle.single_depth_mm", || {
                format!(
                    "must be within 0 .. strategy.total_depth_mm = {} mm (is {d})",
                    s.total_depth_mm
                )
            }),
        }
    }

    fn check_shape(&self, p: &mut Problems) -> Option<XShape> {
        let w = &self.workpiece;
        let b = w.face_width_mm;
        let limit_mm = self.strategy.retract_mm;
        let mut ok = true;
        let crowning = w.crowning.as_ref().map(|c| {
            let height = match (c.height_mm, c.radius_mm) {
                (Some(h), None) => {
                    p.require(h > 0.0 && h < b / 2.0, "workpiece.crowning.height_mm", || {
                        format!(
                            "must be within 0 .. half the face width {} mm, exclusive (is {h})",
                            b / 2.0
                        )
                    });
                    h
                }
                (None, Some(r)) => crowning_height_mm(r, b).filter(|h| *h > 0.0).unwrap_or_else(|| {
                    p.push(
                        "workpiece.crowning.radius_mm",
                        format!("must be at least half the face width {} mm (is {r})", b / 2.0),
                    );
                    0.0
                }),
                _ => {
                    p.push("workpiece.crowning", "give exactly one of height_mm or radius_mm");
                    0.0
                }
            };
            Crowning::from_height(height, b)
        });
        let contour = match &w.contour {
            None => None,
            Some(points) => {
                for (i, pt) in points.iter().enumerate() {
                    p.require(
                        (0.0..=b).contains(&pt[0]),
                        &format!("workpiece.contour[{i}]"),
                        || format!("face position {} mm is outside the face width 0 .. {b} mm", pt[0]),
                    );
                }
                match Contour::new(points) {
                    Ok(c) => Some(c),
                    Err(e) => {
                        ok = false;
                        let (key, msg) = match e {
                            ContourError::TooFew => (
                                "workpiece.contour".to_string(),
                                "needs at least 2 points".to_string(),
                            ),
                            ContourError::TooMany => (
                                "workpiece.contour".to_string(),
                                format!("has more than {MAX_CONTOUR_POINTS} points"),
                            ),
                            ContourError::NotIncreasing { index } => (
                                format!("workpiece.contour[{index}]"),
                                "face positions must increase strictly from point to point".to_string(),
                            ),
                        };
                        p.push(key, msg);
                        None
                    }
                }
            }
        };
        let shape = XShape { crowning, contour };
        // The tool must clear the blank at the safe position whatever the shape does.
        let deepest = -shape.min_offset_mm();
        p.require(deepest < limit_mm, "strategy.retract_mm", || {
            format!("must be more than the deepest crowning/contour offset {deepest} mm (is {limit_mm})")
        });
        ok.then_some(shape)
    }

    fn check_rough_depths(&self, p: &mut Problems) {
        let s = &self.strategy;
        let Some(depths) = &s.rough_depths_mm else { return };
        if usize::try_from(s.rough_passes).ok() != Some(depths.len()) {
            p.push(
                "strategy.rough_depths_mm",
                format!(
                    "has {} depths but strategy.rough_passes = {}",
                    depths.len(),
                    s.rough_passes
                ),
            );
        }
        for (i, d) in depths.iter().enumerate() {
            p.positive(&format!("strategy.rough_depths_mm[{i}]"), *d);
        }
        let sum: f64 = depths.iter().sum();
        let want = s.total_depth_mm - s.finish_allowance_mm;
        p.require(
            (sum - want).abs() <= DEPTH_SUM_TOLERANCE_MM,
            "strategy.rough_depths_mm",
            || {
                format!(
                    "the rough depths add up to {sum} mm but total_depth_mm - finish_allowance_mm = {want} mm"
                )
            },
        );
    }

    fn check_cutting_data(&self, p: &mut Problems, table: &str, d: &CuttingData) {
        p.positive(&format!("{table}.cutting_speed_m_min"), d.cutting_speed_m_min);
        p.positive(&format!("{table}.feed_mm_per_rev"), d.feed_mm_per_rev);
    }
}

/// A count given as a TOML integer, within `lo ..= hi`.
fn count(p: &mut Problems, key: &str, value: i64, lo: u32, hi: u32) -> Option<u32> {
    match u32::try_from(value) {
        Ok(v) if (lo..=hi).contains(&v) => Some(v),
        _ => {
            p.push(
                key,
                format!("must be a whole number within {lo} .. {hi} (is {value})"),
            );
            None
        }
    }
}

pub mod span;
#[cfg(test)]
mod tests;
