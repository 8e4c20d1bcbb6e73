//! `hob cutter design`: a profile disk cutter designed for a gear's tooth space
//! ([`hob_cutters::design`]), its deviation against the grade, its primitives as TOML and a
//! plot to look at.

use crate::error::Error;
use hob_cutters::design::{CutterDesign, design, design_within};
use hob_cutters::profile::{Primitive, discretise, validate};
use hob_cutters::space::Gear;
use std::fmt::Write as _;
use std::path::Path;

/// What `hob cutter design` was asked.
#[derive(Debug, Clone, Copy)]
pub struct DesignArgs {
    pub gear: Gear,
    pub outside_diameter_mm: f64,
    pub grade: u8,
    /// None: the fewest arcs within the grade's profile form tolerance.
    pub arcs: Option<u32>,
}

/// Designs the cutter; the report, the design. Refusals (exit 2) name the argument.
pub fn design_cutter(a: &DesignArgs) -> Result<(String, CutterDesign), Error> {
    if !(1..=11).contains(&a.grade) {
        return Err(Error::Grade(a.grade));
    }
    let radius = 0.5 * a.outside_diameter_mm;
    let tol = hob_gearing::iso1328::profile_form_tolerance_um(a.gear.normal_module_mm, a.grade);
    let d = match a.arcs {
        Some(n) => design(a.gear, n, radius),
        None => design_within(a.gear, tol, radius),
    }
    .map_err(Error::Design)?;
    validate(&d.profile, radius).map_err(Error::DesignInvalid)?;
    let s = &d.space;
    let mut o = String::new();
    let _ = writeln!(
        o,
        "gear: z {} m_n {} mm, pressure angle {} deg, shift {}, helix {} deg ({:.2} teeth as the cutter sees them)",
        a.gear.teeth,
        a.gear.normal_module_mm,
        a.gear.pressure_angle_deg,
        a.gear.profile_shift,
        a.gear.helix_deg,
        s.virtual_teeth
    );
    let _ = writeln!(
        o,
        "radii (mm): tip {:.3}, pitch {:.3}, form {:.3} (active involute from here), base {:.3}, root {:.3}; depth {:.3}",
        s.tip_radius_mm, s.pitch_radius_mm, s.form_radius_mm, s.base_radius_mm, s.root_radius_mm, d.depth_mm
    );
    let _ = writeln!(
        o,
        "flank: {} arc(s), each through three points of the involute; root fillet {:.3} mm",
        d.arcs.len(),
        d.root_fillet_radius_mm
    );
    for (k, arc) in d.arcs.iter().enumerate() {
        let _ = writeln!(
            o,
            "  arc {}: gear radius {:.3} to {:.3} mm, radius {:.3} mm, deviation {:.2} um",
            k + 1,
            arc.from_gear_radius_mm,
            arc.to_gear_radius_mm,
            arc.radius_mm,
            arc.deviation_um
        );
    }
    let verdict = if d.deviation_um <= tol { "within" } else { "BEYOND" };
    let _ = writeln!(
        o,
        "deviation from the involute {:.2} um: {:.0} % of ISO 1328-1 f_falpha {:.2} um at grade {}, {verdict}",
        d.deviation_um,
        100.0 * d.deviation_um / tol,
        tol,
        a.grade
    );
    let _ = writeln!(
        o,
        "profile: {} primitives across {:.3} mm of the cutter's width, outside diameter {} mm",
        d.profile.len(),
        d.profile[d.profile.len() - 1].end().x - d.profile[0].start().x,
        a.outside_diameter_mm
    );
    Ok((o, d))
}

/// The profile's primitives as the tool library's TOML (`[[profile]]` tables).
pub fn profile_toml(profile: &[Primitive]) -> Result<String, Error> {
    #[derive(serde::Serialize)]
    struct File<'a> {
        profile: &'a [Primitive],
    }
    toml::to_string(&File { profile }).map_err(Error::ProfileToml)
}

/// A plot of the design: the profile in the cutter's axial plane (left), and each flank
/// arc's deviation from the involute along the flank (right, um).
pub fn svg(d: &CutterDesign) -> String {
    let (w, h) = (1000.0, 480.0);
    let mut o = String::new();
    let _ = writeln!(
        o,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif" font-size="13">"#
    );
    let _ = writeln!(o, r#"<rect width="{w}" height="{h}" fill="white"/>"#);
    // Left: the profile, equal scales.
    let pts = discretise(&d.profile, 0.05, 0.0005);
    let (u0, u1) = (pts[0].u_mm, pts[pts.len() - 1].u_mm);
    let r0 = pts.iter().map(|q| q.r_mm).fold(f64::INFINITY, f64::min);
    let r1 = d.outside_radius_mm;
    let (bx, by, bw, bh) = (50.0, 50.0, 420.0, 380.0);
    let k = (bw / (u1 - u0)).min(bh / (r1 - r0));
    let x = |u: f64| bx + (u - u0) * k + 0.5 * (bw - (u1 - u0) * k);
    let y = |r: f64| by + bh - (r - r0) * k - 0.5 * (bh - (r1 - r0) * k);
    let _ = writeln!(
        o,
        r#"<text x="{bx}" y="30">cutter profile, axial plane (equal scales), {} primitives; dots: node points</text>"#,
        d.profile.len()
    );
    let path: Vec<String> = pts
        .iter()
        .map(|q| format!("{:.2},{:.2}", x(q.u_mm), y(q.r_mm)))
        .collect();
    let _ = writeln!(
        o,
        r#"<polyline points="{}" fill="none" stroke="black" stroke-width="1.5"/>"#,
        path.join(" ")
    );
    for q in pts.iter().filter(|q| q.node) {
        let _ = writeln!(
            o,
            r#"<circle cx="{:.2}" cy="{:.2}" r="3" fill="crimson"/>"#,
            x(q.u_mm),
            y(q.r_mm)
        );
    }
    let _ = writeln!(
        o,
        r#"<text x="{bx}" y="{}">u across the width {:.2} mm; radius {:.2} to {:.2} mm</text>"#,
        by + bh + 30.0,
        u1 - u0,
        r0,
        r1
    );
    // Right: deviation along the flank.
    let (cx, cy, cw, ch) = (560.0, 50.0, 400.0, 380.0);
    let s = &d.space;
    let samples: Vec<(f64, f64)> = (0..=600)
        .map(|j| {
            let t = f64::from(j) / 600.0;
            let q = s.active_point(t);
            let n = d.arcs.len() as f64;
            let arc = &d.arcs[((t * n) as usize).min(d.arcs.len() - 1)];
            (s.active_radius(t), (q.dist(arc.centre) - arc.radius_mm) * 1000.0)
        })
        .collect();
    let dmax = samples.iter().map(|p| p.1.abs()).fold(1e-9, f64::max);
    let (g0, g1) = (s.form_radius_mm, s.tip_radius_mm);
    let px = |r: f64| cx + (r - g0) / (g1 - g0) * cw;
    let py = |dv: f64| cy + ch / 2.0 - dv / dmax * (ch / 2.0 - 10.0);
    let _ = writeln!(
        o,
        r#"<text x="{cx}" y="30">involute minus arc along the arc radius, um; max {:.2} um</text>"#,
        d.deviation_um
    );
    let _ = writeln!(
        o,
        r#"<line x1="{cx}" y1="{0:.2}" x2="{1}" y2="{0:.2}" stroke="gray"/>"#,
        py(0.0),
        cx + cw
    );
    let curve: Vec<String> = samples
        .iter()
        .map(|&(r, dv)| format!("{:.2},{:.2}", px(r), py(dv)))
        .collect();
    let _ = writeln!(
        o,
        r#"<polyline points="{}" fill="none" stroke="steelblue" stroke-width="1.5"/>"#,
        curve.join(" ")
    );
    let _ = writeln!(
        o,
        r#"<text x="{cx}" y="{}">gear radius {:.2} (form) to {:.2} mm (tip)</text>"#,
        cy + ch + 30.0,
        g0,
        g1
    );
    o.push_str("</svg>\n");
    o
}

/// Near resonance: the tooth-passing frequency within this factor of the natural one.
const NEAR_RESONANCE: (f64, f64) = (0.8, 1.25);

/// `hob cutter dynamics`: the link, the deflection at the speed asked, and with a limit the
/// speeds that keep within it (5 to 200 m/min in 0.5 m/min steps).
pub fn dynamics(
    body: &hob_cutters::dynamics::CutterBody,
    material: &hob_cutters::dynamics::Material,
    cut: &hob_cutters::dynamics::SideCut,
    allowable_bending_mpa: f64,
    limit_um: Option<f64>,
) -> Result<String, Error> {
    use hob_cutters::dynamics::{deflection, speed_ranges};
    let link = body.link().map_err(Error::OutOfRange)?;
    let d = deflection(body, material, cut).map_err(Error::OutOfRange)?;
    let load_limit_n = body
        .load_limit_n(allowable_bending_mpa)
        .map_err(Error::OutOfRange)?;
    let mut o = String::new();
    let _ = writeln!(
        o,
        "cutter link (seed 003, eqs. 6-9): stiffness {:.0} N/mm, T1 {:.3} ms, T2 {:.4} ms, natural frequency {:.1} Hz, damping ratio {:.4}",
        link.stiffness_n_mm,
        link.t1_s * 1e3,
        link.t2_s * 1e3,
        link.natural_frequency_hz,
        link.damping_ratio
    );
    let _ = writeln!(
        o,
        "at {} m/min: {:.1} rpm, teeth pass at {:.1} Hz ({:.2} of the natural frequency); side force {:.0} N lagging {:.2e} s; amplification {:.2}",
        cut.cutting_speed_m_min,
        d.cutter_rpm,
        d.tooth_passing_hz,
        d.frequency_ratio,
        d.side_force_n,
        d.force_lag_s,
        d.amplification
    );
    let _ = writeln!(
        o,
        "predicted profile error (the largest side deflection): {:.1} um",
        d.profile_error_um
    );
    let _ = writeln!(
        o,
        "peak load on the cutter body {:.0} N; it takes {load_limit_n:.0} N at {allowable_bending_mpa} MPa: {}",
        d.peak_load_n,
        if d.peak_load_n <= load_limit_n {
            "within"
        } else {
            "OVERLOADED (hob plan refuses such a pass)"
        }
    );
    if (NEAR_RESONANCE.0..=NEAR_RESONANCE.1).contains(&d.frequency_ratio) {
        let _ = writeln!(
            o,
            "WARNING: near resonance (tooth-passing within {}-{} x the natural frequency)",
            NEAR_RESONANCE.0, NEAR_RESONANCE.1
        );
    }
    if let Some(limit) = limit_um {
        if !(limit.is_finite() && limit > 0.0) {
            return Err(Error::LimitUm(limit));
        }
        let ranges =
            speed_ranges(body, material, cut, (5.0, 200.0, 0.5), limit).map_err(Error::SpeedRanges)?;
        let text: Vec<String> = ranges.iter().map(|(a, b)| format!("{a:.1}-{b:.1}")).collect();
        let verdict = if d.profile_error_um <= limit {
            "within"
        } else {
            "BEYOND"
        };
        let _ = writeln!(
            o,
            "{:.1} um is {verdict} the limit {limit} um; speeds within it (5-200 m/min): {}",
            d.profile_error_um,
            if text.is_empty() {
                "none".to_string()
            } else {
                text.join(", ") + " m/min"
            }
        );
    }
    Ok(o)
}

/// Reads a profile file (`[[profile]]` primitives) and validates it for a cutter of
/// `outside_radius_mm`; errors name the file and the primitive.
pub fn read_profile(path: &Path, outside_radius_mm: f64) -> Result<Vec<Primitive>, Error> {
    #[derive(serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    struct File {
        profile: Vec<Primitive>,
    }
    let src = std::fs::read_to_string(path).map_err(|error| Error::Io {
        path: path.to_path_buf(),
        error,
    })?;
    let f: File = toml::from_str(&src).map_err(|error| Error::ProfileFile {
        path: path.to_path_buf(),
        error,
    })?;
    validate(&f.profile, outside_radius_mm).map_err(|error| Error::ProfileInvalid {
        path: path.to_path_buf(),
        error,
    })?;
    Ok(f.profile)
}

/// `hob cutter grind`: the program to `out`, the plot to `svg`; what was written.
pub fn grind(
    profile_path: &Path,
    g: &hob_cutters::grind::Grinding,
    feed_mm_min: f64,
    out: &Path,
    svg_path: Option<&Path>,
) -> Result<String, Error> {
    let profile = read_profile(profile_path, g.outside_radius_mm)?;
    let name = profile_path
        .file_stem()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
    grind_profile(&name, &profile, g, feed_mm_min, out, svg_path)
}

/// The grinding program of a validated profile named `name` to `out`, the plot to `svg`.
pub fn grind_profile(
    name: &str,
    profile: &[Primitive],
    g: &hob_cutters::grind::Grinding,
    feed_mm_min: f64,
    out: &Path,
    svg_path: Option<&Path>,
) -> Result<String, Error> {
    use hob_cutters::grind::{gcode, path};
    if !(feed_mm_min.is_finite() && feed_mm_min > 0.0) {
        return Err(Error::FeedMmMin(feed_mm_min));
    }
    let p = path(profile, g).map_err(Error::Grind)?;
    write(out, &gcode(name, &p, g, feed_mm_min))?;
    let mut o = format!(
        "{name}: {} points per tooth ({} at nodes and corners), {} teeth, {} linear moves; written to {}\n",
        p.len(),
        p.iter().filter(|q| q.node).count(),
        g.cutter_teeth,
        p.len() * g.cutter_teeth as usize,
        out.display()
    );
    let a_max = p.iter().map(|q| q.a_deg.abs()).fold(0.0, f64::max);
    let _ = writeln!(
        o,
        "edge on the rake face ({} deg): turned up to {:.3} deg off the axial plane; the wheel lowered {:.3} mm for the {} deg clearance",
        g.rake_deg,
        a_max,
        g.outside_radius_mm * g.clearance_deg.to_radians().sin(),
        g.clearance_deg
    );
    if let Some(sp) = svg_path {
        write(sp, &grind_svg(&p))?;
        let _ = writeln!(o, "plot written to {}", sp.display());
    }
    Ok(o)
}

/// The profile, the edge (its `X`) and the wheel's path in the axial plane (`Z` across,
/// `X` up), equal scales.
fn grind_svg(p: &[hob_cutters::grind::PathPoint]) -> String {
    let (w, h) = (900.0, 560.0);
    let zs = p.iter().flat_map(|q| [q.profile[0], q.wheel[2]]);
    let xs = p.iter().flat_map(|q| [q.profile[1], q.edge[0], q.wheel[0]]);
    let (z0, z1) = zs.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    let (x0, x1) = xs.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    let (bx, by, bw, bh) = (60.0, 60.0, 780.0, 440.0);
    let k = (bw / (z1 - z0)).min(bh / (x1 - x0));
    let px = |z: f64| bx + (z - z0) * k + 0.5 * (bw - (z1 - z0) * k);
    let py = |x: f64| by + bh - (x - x0) * k - 0.5 * (bh - (x1 - x0) * k);
    let line = |pts: Vec<(f64, f64)>, colour: &str, dash: &str| {
        let s: Vec<String> = pts
            .iter()
            .map(|&(z, x)| format!("{:.2},{:.2}", px(z), py(x)))
            .collect();
        format!(
            "<polyline points=\"{}\" fill=\"none\" stroke=\"{colour}\" stroke-width=\"1.5\"{dash}/>\n",
            s.join(" ")
        )
    };
    let mut o = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\" font-family=\"sans-serif\" font-size=\"13\">\n<rect width=\"{w}\" height=\"{h}\" fill=\"white\"/>\n"
    );
    let _ = writeln!(
        o,
        "<text x=\"{bx}\" y=\"24\">axial plane, Z across the width ({:.2} mm), X radial, equal scales:</text>\n<text x=\"{bx}\" y=\"42\">profile (black), edge on the rake face (red, dashed), the wheel's rounding centre (blue)</text>",
        z1 - z0
    );
    o.push_str(&line(
        p.iter().map(|q| (q.profile[0], q.profile[1])).collect(),
        "black",
        "",
    ));
    o.push_str(&line(
        p.iter().map(|q| (q.edge[2], q.edge[0])).collect(),
        "crimson",
        " stroke-dasharray=\"6 4\"",
    ));
    o.push_str(&line(
        p.iter().map(|q| (q.wheel[2], q.wheel[0])).collect(),
        "steelblue",
        "",
    ));
    o.push_str("</svg>\n");
    o
}

/// Writes `text` to `path` whole or not at all (a grinding program cut off by a crash
/// must not reach the machining centre), naming it in the error.
pub fn write(path: &Path, text: &str) -> Result<(), Error> {
    hob_store::atomic::write_atomic(path, text.as_bytes()).map_err(|error| Error::Io {
        path: path.to_path_buf(),
        error,
    })
}
