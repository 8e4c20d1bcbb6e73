//! Human-readable plan for the terminal.

use hob_gearing::signs::{Hand, Rotation, Vertical};
use hob_setup::job::{CycleKind, Mode};
use hob_setup::planner::cutter::CutterPlan;
use hob_setup::planner::{PassKind, Plan};
use std::fmt::Write;
use std::path::Path;

fn hand(h: Hand) -> &'static str {
    match h {
        Hand::Right => "right",
        Hand::Left => "left",
    }
}

fn vertical(v: Vertical) -> &'static str {
    match v {
        Vertical::Up => "up",
        Vertical::Down => "down",
    }
}

fn rotation(r: Rotation) -> &'static str {
    match r {
        Rotation::Positive => "positive",
        Rotation::Negative => "negative",
    }
}

fn cycle(c: CycleKind) -> &'static str {
    match c {
        CycleKind::RadialAxial => "radial-axial",
        CycleKind::RadialPlunge => "radial-axial with radial plunge at feed",
        CycleKind::ToothByTooth => "tooth by tooth (indexing, disk cutter)",
    }
}

fn pass_kind(k: PassKind) -> &'static str {
    match k {
        PassKind::Rough => "rough",
        PassKind::Finish => "finish",
        PassKind::Single => "single",
    }
}

fn minutes(s: f64) -> String {
    let total = s.round() as u64;
    format!("{} min {:02} s", total / 60, total % 60)
}

/// The plan as the operator reads it.
pub fn plan_text(program: &Path, plan: &Plan) -> String {
    let mut o = String::new();
    // Writing to a String cannot fail.
    let _ = write_plan(&mut o, program, plan);
    o
}

fn write_plan(o: &mut String, program: &Path, p: &Plan) -> std::fmt::Result {
    writeln!(o, "hob plan: {}  (machine: {})", program.display(), p.machine)?;
    write_gear(o, p)?;
    write_set_up(o, p)?;
    writeln!(o)?;
    write_passes(o, p)?;
    if let Some(c) = &p.cutter {
        write_cutter(o, c)?;
    }
    for w in &p.warnings {
        writeln!(o, "note: {w}")?;
    }
    Ok(())
}

/// The gear, its tolerance, the cycle, the gearbox and the differential.
fn write_gear(o: &mut String, p: &Plan) -> std::fmt::Result {
    let gear = match (p.helix_hand, p.helix_lead_mm) {
        (Some(h), Some(lead)) => format!(
            "helical {} hand, beta {} deg, lead {lead:.3} mm",
            hand(h),
            p.helix_deg
        ),
        _ => "spur".to_string(),
    };
    writeln!(
        o,
        "gear      z {}, m_n {} mm, {gear}, pitch diameter {:.3} mm",
        p.teeth, p.normal_module_mm, p.pitch_diameter_mm
    )?;
    writeln!(
        o,
        "          ISO 1328-1 grade 5 single pitch tolerance {:.2} um",
        p.single_pitch_tolerance_grade5_um
    )?;
    writeln!(
        o,
        "cycle     {}, {}",
        cycle(p.cycle),
        match p.mode {
            Mode::Automatic => "automatic",
            Mode::Single => "single mode (one pass, then stop)",
        }
    )?;
    match p.index_deg {
        Some(index) => writeln!(o, "gearbox   indexing {index:.4} deg per tooth")?,
        None => writeln!(
            o,
            "gearbox   table {:.6} rev per hob rev (z0/z = {}/{})",
            p.egb_ratio, p.starts, p.teeth
        )?,
    }
    writeln!(
        o,
        "          differential {:.6} deg of table per mm of Y",
        p.differential_deg_per_mm
    )
}

/// The hob's swivel, the signs, X's shape in the cut and its safe position.
fn write_set_up(o: &mut String, p: &Plan) -> std::fmt::Result {
    let sense = p.hob_swivel_sense.map_or(String::new(), |h| {
        format!(", in the sense of a {}-hand helix", hand(h))
    });
    writeln!(o, "set A     hob swivel {:.3} deg{sense}", p.hob_swivel_deg)?;
    let s = &p.signs;
    writeln!(
        o,
        "signs     feed {}, hob teeth move {} at the cut, spindle {}, table {} per spindle turn, differential {}",
        vertical(s.feed),
        vertical(s.cutting),
        rotation(s.spindle),
        rotation(s.table_per_spindle),
        rotation(s.differential),
    )?;
    let mut shape = Vec::new();
    if let Some(c) = p.x_shape.crowning {
        shape.push(format!(
            "crowning {} mm (arc radius {:.3} mm)",
            c.height_mm, c.radius_mm
        ));
    }
    if let Some(points) = &p.x_shape.contour {
        shape.push(format!("contour of {} points", points.len()));
    }
    writeln!(
        o,
        "X shape   {}{}",
        if shape.is_empty() {
            "straight".to_string()
        } else {
            shape.join(" + ")
        },
        if p.x_shape.x_moves_in_cut {
            " (X unclamped in the cut)"
        } else {
            " (X clamped in the cut)"
        }
    )?;
    writeln!(o, "X safe    {:.3} mm", p.x_safe_mm)
}

/// The passes as a table, and the total cycle time.
fn write_passes(o: &mut String, p: &Plan) -> std::fmt::Result {
    writeln!(
        o,
        "{:>4} {:<6} {:>7} {:>8} {:>8} {:>7} {:>6} {:>7} {:>8} {:>8} {:>8} {:>8} {:>8}",
        "pass",
        "kind",
        "depth",
        "X",
        "spindle",
        "VFD",
        "AO",
        "table",
        "feed",
        "Y start",
        "Y end",
        "cut",
        "pass"
    )?;
    writeln!(
        o,
        "{:>4} {:<6} {:>7} {:>8} {:>8} {:>7} {:>6} {:>7} {:>8} {:>8} {:>8} {:>8} {:>8}",
        "", "", "mm", "mm", "rpm", "Hz", "V", "rpm", "mm/min", "mm", "mm", "s", "s"
    )?;
    for (i, pass) in p.passes.iter().enumerate() {
        writeln!(
            o,
            "{:>4} {:<6} {:>7.3} {:>8.3} {:>8.3} {:>7.2} {:>6.3} {:>7.3} {:>8.3} {:>8.3} {:>8.3} {:>8.1} {:>8.1}",
            i + 1,
            pass_kind(pass.kind),
            pass.depth_mm,
            pass.x_mm,
            pass.spindle_rpm,
            pass.vfd_hz,
            pass.analog_out_v,
            pass.table_rpm,
            pass.axial_feed_mm_min,
            pass.y_start_mm,
            pass.y_end_mm,
            pass.cut_time_s,
            pass.pass_time_s,
        )?;
    }
    writeln!(o)?;
    writeln!(
        o,
        "total cycle time {:.1} s ({})",
        p.total_time_s,
        minutes(p.total_time_s)
    )
}

/// A disk cutter's profile against the involute, its dynamics and each pass's side force.
fn write_cutter(o: &mut String, c: &CutterPlan) -> std::fmt::Result {
    write!(
        o,
        "disk cutter's profile: {:.2} um from the gear's involute at most (radius {:.3} mm)",
        c.profile_deviation_um, c.at_gear_radius_mm
    )?;
    match (c.grade, c.profile_form_tolerance_um) {
        (Some(g), Some(tol)) => writeln!(
            o,
            ", {:.0} % of f_falpha {tol:.2} um at grade {g}",
            100.0 * c.profile_deviation_um / tol
        )?,
        _ => writeln!(o, " (workpiece.grade not given: not judged)")?,
    }
    match (c.natural_frequency_hz, c.damping_ratio) {
        (Some(f), Some(z)) => {
            let passes: Vec<String> = c
                .tooth_passing_hz
                .iter()
                .map(|fz| format!("{fz:.1} Hz ({:.2})", fz / f))
                .collect();
            writeln!(
                o,
                "disk cutter's natural frequency {f:.1} Hz, damping ratio {z:.4} (seed 003); teeth pass at {}",
                passes.join(", ")
            )?;
        }
        _ => writeln!(o, "disk cutter's dynamics: tool.disk.mass_kg not given")?,
    }
    for (k, cp) in c.passes.iter().enumerate() {
        let ranges: Vec<String> = cp
            .speed_ranges_m_min
            .iter()
            .map(|(a, b)| format!("{a:.1}-{b:.1}"))
            .collect();
        writeln!(
            o,
            "  pass {}: one flank's side force {:.0} N (chip {:.3} x {:.2} mm), amplification {:.2}, predicted profile error {:.2} um, peak load {:.0} N{}{}",
            k + 1,
            cp.side_force_n,
            cp.side_chip_thickness_mm,
            cp.side_chip_width_mm,
            cp.amplification,
            cp.profile_error_um,
            cp.peak_load_n,
            cp.load_limit_n
                .map(|l| format!(" of {l:.0} N the body takes"))
                .unwrap_or_default(),
            if ranges.is_empty() {
                String::new()
            } else {
                format!("; within f_falpha at {} m/min", ranges.join(", "))
            }
        )?;
    }
    if c.passes.is_empty() && c.natural_frequency_hz.is_some() {
        writeln!(
            o,
            "  (workpiece.material not given: no side force or profile error predicted)"
        )?;
    }
    Ok(())
}
