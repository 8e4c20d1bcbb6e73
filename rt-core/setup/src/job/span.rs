//! The span measurement carried into the program: after a cut (the single pass, cut to
//! `cycle.single_depth_mm`, or the whole program) the operator measures the span over k
//! teeth and compares it with the drawing's: the span with its allowances (drawings put
//! it below the nominal for backlash, e.g. 23.281 -0.050/-0.090) and the profile shift
//! the drawing states. Within the allowances the gear is good; over them the excess over
//! the band's middle is the radial depth still to cut (`hob_gearing::span`), so the
//! program's total depth becomes the depth cut plus that; under them the gear was cut too
//! deep and no depth corrects it.

use super::Program;
use crate::config::Problems;
use hob_gearing::span::SpanGear;
use serde::{Deserialize, Serialize};

/// A span below the band by more than this is a gear cut too deep (a micrometer reads to
/// 1 um; the drawing's tolerance is tens of um).
pub const TOO_DEEP_TOLERANCE_MM: f64 = 0.005;

/// The largest profile shift coefficient taken (DIN 3960 gears lie well inside +-1.5).
pub const PROFILE_SHIFT_LIMIT: f64 = 1.5;

/// Which cut the gear measured had.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CutMeasured {
    /// The single pass, at `cycle.single_depth_mm`.
    #[default]
    Single,
    /// The whole program, at `strategy.total_depth_mm`.
    Whole,
}

/// What the operator measured and what the drawing says.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpanReading {
    /// Teeth spanned (k).
    pub k: u32,
    pub measured_mm: f64,
    /// The drawing's span over k teeth; `None`: the gear's nominal span for
    /// `profile_shift`.
    pub drawing_mm: Option<f64>,
    /// The drawing's allowances on its span, signed (upper >= lower), mm; none: 0.
    pub upper_mm: Option<f64>,
    pub lower_mm: Option<f64>,
    /// The drawing's profile shift coefficient x; none: 0.
    pub profile_shift: Option<f64>,
    pub after: CutMeasured,
}

impl SpanReading {
    /// A reading against the nominal span, after the single pass.
    pub fn nominal(k: u32, measured_mm: f64) -> Self {
        Self {
            k,
            measured_mm,
            drawing_mm: None,
            upper_mm: None,
            lower_mm: None,
            profile_shift: None,
            after: CutMeasured::Single,
        }
    }
}

/// What the reading says of the gear.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// Within the drawing's allowances.
    Good,
    /// Over them: a depth still to cut.
    Over,
}

/// The formula's inputs and its result, for the operator to see.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SpanCorrection {
    pub teeth: u32,
    pub normal_module_mm: f64,
    pub normal_pressure_angle_deg: f64,
    pub helix_deg: f64,
    pub profile_shift: f64,
    /// The k the gear calls for (DIN 3960), beside the k measured over.
    pub k_recommended: u32,
    pub k: u32,
    pub nominal_span_mm: f64,
    pub drawing_span_mm: f64,
    pub span_min_mm: f64,
    pub span_max_mm: f64,
    /// The band's middle, what a correction aims at.
    pub target_span_mm: f64,
    pub measured_span_mm: f64,
    pub verdict: Verdict,
    /// measured - target.
    pub excess_mm: f64,
    /// max(excess, 0) / (2 sin alpha_n): 0 when the gear is at or under the middle.
    pub depth_to_cut_mm: f64,
    pub after: CutMeasured,
    /// The depth the measured gear was cut to.
    pub cut_depth_mm: f64,
    pub program_total_depth_mm: f64,
    pub new_total_depth_mm: f64,
}

fn optional_finite(p: &mut Problems, key: &str, value: Option<f64>, limit: f64, what: &str) {
    if let Some(v) = value {
        p.require(v.is_finite() && v.abs() <= limit, key, || {
            format!("{what} must be within -{limit} .. {limit} (is {v})")
        });
    }
}

fn check_reading(program: &Program, r: &SpanReading, teeth: u32) -> Problems {
    let mut p = Problems::new();
    p.require(r.k >= 1 && r.k < teeth, "span.k", || {
        format!(
            "the teeth spanned must be 1 .. {} (is {})",
            teeth.saturating_sub(1),
            r.k
        )
    });
    p.positive("span.measured_mm", r.measured_mm);
    if let Some(d) = r.drawing_mm {
        p.positive("span.drawing_mm", d);
    }
    let module = program.workpiece.module_mm;
    optional_finite(&mut p, "span.upper_mm", r.upper_mm, module, "an allowance, mm,");
    optional_finite(&mut p, "span.lower_mm", r.lower_mm, module, "an allowance, mm,");
    if let (Some(u), Some(l)) = (r.upper_mm, r.lower_mm) {
        p.require(u >= l, "span.lower_mm", || {
            format!("the lower allowance ({l}) must not be above the upper one ({u})")
        });
    }
    optional_finite(
        &mut p,
        "span.profile_shift",
        r.profile_shift,
        PROFILE_SHIFT_LIMIT,
        "the profile shift x",
    );
    if r.after == CutMeasured::Single {
        p.require(program.cycle.single_depth_mm.is_some(), "span.after", || {
            "this program has no single pass: measure after the whole cut".into()
        });
    }
    p
}

/// The correction for `program` after the measured cut, or the problems with the reading
/// (keys `span.k`, `span.measured_mm`, `span.drawing_mm`, `span.upper_mm`,
/// `span.lower_mm`, `span.profile_shift`, `span.after`), each in the operator's words.
pub fn correction(program: &Program, r: SpanReading) -> Result<SpanCorrection, Problems> {
    let w = &program.workpiece;
    let teeth = u32::try_from(w.teeth).unwrap_or(0);
    let mut p = check_reading(program, &r, teeth);
    if !p.is_empty() {
        return Err(p);
    }
    let x = r.profile_shift.unwrap_or(0.0);
    let gear = SpanGear {
        teeth,
        normal_module_mm: w.module_mm,
        normal_pressure_angle_deg: program.tool.pressure_angle_deg,
        helix_deg: w.helix_deg,
        profile_shift: x,
    };
    let nominal = gear.span_mm(r.k);
    let drawing = r.drawing_mm.unwrap_or(nominal);
    let (min, max) = (
        drawing + r.lower_mm.unwrap_or(0.0),
        drawing + r.upper_mm.unwrap_or(0.0),
    );
    let target = 0.5 * (min + max);
    let excess = r.measured_mm - target;
    p.require(r.measured_mm >= min - TOO_DEEP_TOLERANCE_MM, "span.measured_mm", || {
        format!(
            "{:.4} mm is {:.4} mm under the drawing's least span {min:.4} mm: the gear is cut too deep, no depth can correct it",
            r.measured_mm,
            min - r.measured_mm
        )
    });
    // A reading far from the gear (wrong k, wrong gear) is not a correction either: more
    // than a whole tooth of depth still to cut.
    let depth = gear.depth_for_span_excess_mm(excess.max(0.0));
    p.require(depth <= 2.5 * w.module_mm, "span.measured_mm", || {
        format!(
            "{:.4} mm over k = {} would leave {depth:.3} mm to cut, more than a whole tooth: check k and the reading (nominal {nominal:.4} mm)",
            r.measured_mm, r.k
        )
    });
    if !p.is_empty() {
        return Err(p);
    }
    let cut_depth = match r.after {
        CutMeasured::Single => program.cycle.single_depth_mm.unwrap_or(0.0),
        CutMeasured::Whole => program.strategy.total_depth_mm,
    };
    Ok(SpanCorrection {
        teeth,
        normal_module_mm: w.module_mm,
        normal_pressure_angle_deg: program.tool.pressure_angle_deg,
        helix_deg: w.helix_deg,
        profile_shift: x,
        k_recommended: gear.teeth_to_span(),
        k: r.k,
        nominal_span_mm: nominal,
        drawing_span_mm: drawing,
        span_min_mm: min,
        span_max_mm: max,
        target_span_mm: target,
        measured_span_mm: r.measured_mm,
        verdict: if r.measured_mm <= max {
            Verdict::Good
        } else {
            Verdict::Over
        },
        excess_mm: excess,
        depth_to_cut_mm: depth,
        after: r.after,
        cut_depth_mm: cut_depth,
        program_total_depth_mm: program.strategy.total_depth_mm,
        new_total_depth_mm: cut_depth + depth,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn demo() -> Program {
        let p =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/programs/demo-short-spur-z17-m5.toml");
        Program::parse(&p, &std::fs::read_to_string(&p).expect("the demo program")).expect("the demo program")
    }

    #[test]
    fn the_excess_of_the_span_is_the_depth_still_to_cut() {
        let prog = demo();
        // z = 17, m = 5: W_2 = 5 x 4.66629 = 23.3315 mm. Measured 0.342 mm over it: with
        // 2 sin 20 deg = 0.68404, 0.5 mm still to cut after the 1 mm single pass.
        let excess = 0.5 * 2.0 * 20f64.to_radians().sin();
        let c = correction(&prog, SpanReading::nominal(2, 23.3315 + excess)).expect("a correction");
        assert!((c.nominal_span_mm - 23.3315).abs() < 1e-3, "{c:?}");
        assert!((c.depth_to_cut_mm - 0.5).abs() < 2e-3, "{c:?}");
        assert!((c.new_total_depth_mm - 1.5).abs() < 2e-3, "{c:?}");
        assert_eq!(
            (c.k_recommended, c.cut_depth_mm, c.verdict),
            (2, 1.0, Verdict::Over)
        );
        // The drawing's span rather than the nominal one.
        let c = correction(
            &prog,
            SpanReading {
                drawing_mm: Some(23.2),
                ..SpanReading::nominal(2, 23.2)
            },
        )
        .expect("ok");
        assert_eq!(
            (c.excess_mm, c.new_total_depth_mm, c.verdict),
            (0.0, 1.0, Verdict::Good)
        );
    }

    /// A drawing's span below the nominal for backlash, with its allowances: a gear inside
    /// them is good (the defect: it was called too deep, and CARRY cut towards zero
    /// backlash); over them, the depth aims at the band's middle.
    #[test]
    fn the_drawings_allowances_make_a_band_and_the_correction_aims_at_its_middle() {
        let prog = demo();
        let band = |measured: f64| SpanReading {
            drawing_mm: Some(23.3315),
            upper_mm: Some(-0.050),
            lower_mm: Some(-0.090),
            ..SpanReading::nominal(2, measured)
        };
        // 23.2615: inside 23.2415 .. 23.2815, under the middle 23.2615 + 0.000: good, 0 to cut.
        let c = correction(&prog, band(23.255)).expect("good");
        assert_eq!(c.verdict, Verdict::Good);
        assert_eq!(c.depth_to_cut_mm, 0.0);
        assert!((c.target_span_mm - 23.2615).abs() < 1e-9, "{c:?}");
        assert!(
            correction(&prog, band(23.245)).is_ok(),
            "inside the band, under nominal by 87 um"
        );
        // Over the band by 0.0684 mm from the middle: 0.05 mm still to cut.
        let c = correction(&prog, band(23.2615 + 0.1 * 20f64.to_radians().sin())).expect("over");
        assert_eq!(c.verdict, Verdict::Over);
        assert!((c.depth_to_cut_mm - 0.05).abs() < 1e-9, "{c:?}");
        // Under the band: too deep, refused.
        let e = correction(&prog, band(23.230)).expect_err("too deep");
        assert!(e.as_slice()[0].message.contains("too deep"), "{:?}", e.as_slice());
    }

    /// The drawing's profile shift moves the span by 2 x m sin(alpha_n) (DIN 3960), and the
    /// whole cut is measured against the program's total depth (no single pass needed).
    #[test]
    fn the_profile_shift_moves_the_span_and_a_whole_cut_needs_no_single_pass() {
        let mut prog = demo();
        let shifted = SpanReading {
            profile_shift: Some(0.2),
            ..SpanReading::nominal(2, 24.1)
        };
        let c = correction(&prog, shifted).expect("shifted");
        let shift = 2.0 * 0.2 * 5.0 * 20f64.to_radians().sin();
        assert!((c.nominal_span_mm - (23.3315 + shift)).abs() < 1e-3, "{c:?}");
        prog.cycle.single_depth_mm = None;
        let whole = SpanReading {
            after: CutMeasured::Whole,
            ..SpanReading::nominal(2, 23.3315 + 0.1)
        };
        let c = correction(&prog, whole).expect("after the whole cut");
        assert_eq!(c.cut_depth_mm, prog.strategy.total_depth_mm);
        assert!((c.new_total_depth_mm - c.cut_depth_mm - c.depth_to_cut_mm).abs() < 1e-12);
        let e = correction(&prog, SpanReading::nominal(2, 23.5)).expect_err("no single pass");
        assert_eq!(e.as_slice()[0].key, "span.after");
        assert!(
            !e.as_slice()[0].message.contains("cycle."),
            "words, not keys: {:?}",
            e.as_slice()
        );
    }

    #[test]
    fn a_reading_that_cannot_be_corrected_is_refused_by_its_key() {
        let prog = demo();
        let keys = |r: SpanReading| -> Vec<String> {
            correction(&prog, r)
                .expect_err("refused")
                .as_slice()
                .iter()
                .map(|p| p.key.clone())
                .collect()
        };
        assert_eq!(keys(SpanReading::nominal(0, 23.0)), ["span.k"]);
        assert_eq!(keys(SpanReading::nominal(17, 23.0)), ["span.k"]);
        assert_eq!(keys(SpanReading::nominal(2, f64::NAN)), ["span.measured_mm"]);
        let with = |f: fn(&mut SpanReading)| {
            let mut r = SpanReading::nominal(2, 23.4);
            f(&mut r);
            r
        };
        assert_eq!(keys(with(|r| r.drawing_mm = Some(-1.0))), ["span.drawing_mm"]);
        assert_eq!(keys(with(|r| r.upper_mm = Some(f64::NAN))), ["span.upper_mm"]);
        assert_eq!(
            keys(with(|r| (r.upper_mm, r.lower_mm) = (Some(-0.09), Some(-0.05)))),
            ["span.lower_mm"]
        );
        assert_eq!(
            keys(with(|r| r.profile_shift = Some(3.0))),
            ["span.profile_shift"]
        );
        // Cut too deep already: under the drawing's span.
        assert_eq!(keys(with(|r| r.drawing_mm = Some(23.5))), ["span.measured_mm"]);
        // k = 3 measured but read against k = 2's span: 15 mm of depth, refused.
        assert_eq!(keys(SpanReading::nominal(2, 38.1)), ["span.measured_mm"]);
    }
}
