//! Single mode's span measurement carried into the program: after the single pass (cut to
//! `cycle.single_depth_mm`) the operator measures the span over k teeth; its excess over
//! the drawing's span is the radial depth still to cut (`hob_gearing::span`), so the
//! program's total depth becomes the single pass's depth plus that.

use super::Program;
use crate::config::Problems;
use hob_gearing::span::SpanGear;
use serde::Serialize;

/// A span below the drawing's by more than this is a gear cut too deep (a micrometer reads
/// to 1 um; the drawing's tolerance is tens of um).
pub const TOO_DEEP_TOLERANCE_MM: f64 = 0.005;

/// What the operator measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpanReading {
    /// Teeth spanned (k).
    pub k: u32,
    pub measured_mm: f64,
    /// The drawing's span over k teeth; `None`: the nominal span of the gear (x = 0).
    pub drawing_mm: Option<f64>,
}

/// The formula's inputs and its result, for the operator to see.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SpanCorrection {
    pub teeth: u32,
    pub normal_module_mm: f64,
    pub normal_pressure_angle_deg: f64,
    pub helix_deg: f64,
    /// The k the gear calls for (DIN 3960), beside the k measured over.
    pub k_recommended: u32,
    pub k: u32,
    pub nominal_span_mm: f64,
    pub drawing_span_mm: f64,
    pub measured_span_mm: f64,
    pub excess_mm: f64,
    /// excess / (2 sin alpha_n).
    pub depth_to_cut_mm: f64,
    pub single_depth_mm: f64,
    pub program_total_depth_mm: f64,
    pub new_total_depth_mm: f64,
}

/// The correction for `program` after its single pass, or the problems with the reading
/// (keys `span.k`, `span.measured_mm`, `span.drawing_mm`, `cycle.single_depth_mm`).
pub fn correction(program: &Program, r: SpanReading) -> Result<SpanCorrection, Problems> {
    let w = &program.workpiece;
    let mut p = Problems::new();
    let teeth = u32::try_from(w.teeth).unwrap_or(0);
    let gear = SpanGear {
        teeth,
        normal_module_mm: w.module_mm,
        normal_pressure_angle_deg: program.tool.pressure_angle_deg,
        helix_deg: w.helix_deg,
        profile_shift: 0.0,
    };
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
    let single = program.cycle.single_depth_mm;
    p.require(single.is_some(), "cycle.single_depth_mm", || {
        "the program has no single pass: its depth is what the span is measured after".into()
    });
    if !p.is_empty() {
        return Err(p);
    }
    let nominal = gear.span_mm(r.k);
    let drawing = r.drawing_mm.unwrap_or(nominal);
    let excess = r.measured_mm - drawing;
    p.require(excess >= -TOO_DEEP_TOLERANCE_MM, "span.measured_mm", || {
        format!(
            "{:.4} mm is {:.4} mm under the drawing's {drawing:.4} mm: the gear is already cut too deep, no depth can correct it",
            r.measured_mm, -excess
        )
    });
    // A reading far from the gear (wrong k, wrong gear) is not a correction either: more than
    // a whole module of depth still to cut.
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
    let single = single.unwrap_or(0.0);
    Ok(SpanCorrection {
        teeth,
        normal_module_mm: w.module_mm,
        normal_pressure_angle_deg: program.tool.pressure_angle_deg,
        helix_deg: w.helix_deg,
        k_recommended: gear.teeth_to_span(),
        k: r.k,
        nominal_span_mm: nominal,
        drawing_span_mm: drawing,
        measured_span_mm: r.measured_mm,
        excess_mm: excess,
        depth_to_cut_mm: depth,
        single_depth_mm: single,
        program_total_depth_mm: program.strategy.total_depth_mm,
        new_total_depth_mm: single + depth,
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
        let c = correction(
            &prog,
            SpanReading {
                k: 2,
                measured_mm: 23.3315 + excess,
                drawing_mm: None,
            },
        )
        .expect("a correction");
        assert!((c.nominal_span_mm - 23.3315).abs() < 1e-3, "{c:?}");
        assert!((c.depth_to_cut_mm - 0.5).abs() < 2e-3, "{c:?}");
        assert!((c.new_total_depth_mm - 1.5).abs() < 2e-3, "{c:?}");
        assert_eq!((c.k_recommended, c.single_depth_mm), (2, 1.0));
        // The drawing's span rather than the nominal one.
        let c = correction(
            &prog,
            SpanReading {
                k: 2,
                measured_mm: 23.2,
                drawing_mm: Some(23.2),
            },
        )
        .expect("ok");
        assert_eq!((c.excess_mm, c.new_total_depth_mm), (0.0, 1.0));
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
        assert_eq!(
            keys(SpanReading {
                k: 0,
                measured_mm: 23.0,
                drawing_mm: None
            }),
            ["span.k"]
        );
        assert_eq!(
            keys(SpanReading {
                k: 17,
                measured_mm: 23.0,
                drawing_mm: None
            }),
            ["span.k"]
        );
        assert_eq!(
            keys(SpanReading {
                k: 2,
                measured_mm: f64::NAN,
                drawing_mm: None
            }),
            ["span.measured_mm"]
        );
        assert_eq!(
            keys(SpanReading {
                k: 2,
                measured_mm: 23.0,
                drawing_mm: Some(-1.0)
            }),
            ["span.drawing_mm"]
        );
        // Cut too deep already: under the drawing's span.
        let e = correction(
            &prog,
            SpanReading {
                k: 2,
                measured_mm: 23.2,
                drawing_mm: Some(23.3),
            },
        )
        .expect_err("too deep");
        assert!(e.as_slice()[0].message.contains("too deep"), "{:?}", e.as_slice());
        // k = 3 measured but read against k = 2's span: 15 mm of depth, refused.
        assert_eq!(
            keys(SpanReading {
                k: 2,
                measured_mm: 38.1,
                drawing_mm: None
            }),
            ["span.measured_mm"]
        );
        let mut no_single = prog.clone();
        no_single.cycle.single_depth_mm = None;
        let e = correction(
            &no_single,
            SpanReading {
                k: 2,
                measured_mm: 23.5,
                drawing_mm: None,
            },
        )
        .expect_err("no single");
        assert_eq!(e.as_slice()[0].key, "cycle.single_depth_mm");
    }
}
