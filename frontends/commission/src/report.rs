//! The commissioning report the machine builder keeps with the machine: what the machine
//! file's `[commissioning]` records say was measured, when and on what, what each figure
//! does in the loop, and what hob does not measure yet (text); and the spindle encoder's
//! record as a plot over the spindle's speeds (SVG): the encoder's error, the spindle's
//! true swing, and what the loop's identifier sees of the two at each speed.

use hob_setup::config::machine::MachineConfig;
use hob_setup::config::machine::commissioning::{SpindleEncoderRecord, identity_text};
use std::fmt::Write as _;

/// The report in words.
pub fn text(machine: &MachineConfig) -> String {
    let records = machine.commissioning.clone().unwrap_or_default();
    let mut o = format!("Commissioning report: {}\n\n", machine.machine.name);
    match &records.drive_delay {
        Some(d) => {
            let _ = writeln!(
                o,
                "Table drive's delay (hob commission delay, {}):\n  found {:.1} us (residual {:.2} \
                 arcsec over {} cycles of steady jog); in use: control.drive_delay_us = {} us\n  \
                 measured on the table drive {}\n",
                d.utc,
                d.found_us,
                d.residual_arcsec,
                d.samples,
                machine.control.drive_delay_us,
                identity_text(
                    d.table_drive_vendor_id,
                    d.table_drive_product_code,
                    d.table_drive_serial
                )
            );
        }
        None => o.push_str(
            "Table drive's delay: not commissioned (hob-rt refuses START and CONTINUE until \
             `hob commission delay` has measured it)\n\n",
        ),
    }
    match &records.spindle_encoder {
        Some(e) => {
            let speeds: Vec<String> = e.speeds_rpm.iter().map(|r| format!("{r:.0}")).collect();
            let _ = writeln!(
                o,
                "Spindle encoder (hob commission encoder, {}), at {} rpm:\n  the encoder's error: \
                 {:.2} +- {:.2} arcsec once per turn, {:.2} twice, {:.2} three times (the loop \
                 corrects the first, identified anew at each start)\n  the spindle's true swing \
                 once per turn: {:.2} arcsec at {:.0} rpm, {:+.1} deg from the error's phase, \
                 tau = J/D {:.4} s (the table follows it)\n  misfit of the model over the \
                 speeds: {:.2} arcsec RMS\n",
                e.utc,
                speeds.join(", "),
                e.error_arcsec,
                e.error_uncertainty_arcsec,
                e.error_2_arcsec,
                e.error_3_arcsec,
                e.swing_arcsec,
                e.reference_rpm,
                e.swing_phase_deg,
                e.swing_tau_s,
                e.misfit_arcsec
            );
        }
        None => o.push_str(
            "Spindle encoder: not commissioned (the loop takes all of the once-per-turn sine it \
             identifies for the encoder's error)\n\n",
        ),
    }
    match &records.table_backlash {
        Some(b) => {
            let _ = writeln!(
                o,
                "Table drive's lost motion (hob commission backlash, {}):\n  {:.2} +- {:.2} arcsec \
                 of the table at a reversal ({:.1} deg/min, {} gauge readings): the worm's \
                 backlash and the mesh's wind-up; recorded, not used by the loop (a cut turns \
                 the table one way)\n",
                b.utc, b.lost_motion_arcsec, b.uncertainty_arcsec, b.speed_deg_min, b.samples
            );
        }
        None => o.push_str(
            "Table drive's lost motion: not measured (`hob commission backlash`, with a gauge on \
             the table)\n\n",
        ),
    }
    drive_gains(&mut o, &records);
    o.push_str("Not measured by hob yet: the X and Y drives' frequency response, tuning and delays.\n");
    o
}

/// The table drive's gains in words.
fn drive_gains(o: &mut String, records: &hob_setup::config::machine::commissioning::Commissioning) {
    match &records.table_drive_gains {
        Some(g) => {
            let _ = writeln!(
                o,
                "Table drive's gains (hob commission response, {}):\n  written to the drive at \
                 each boot: kp {:.3} Nm s/rad, Ti {:.2} ms, kv {:.1} 1/s (velocity loop GM {:.1} \
                 dB, PM {:.1} deg; cascade GM {:.1} dB, PM {:.1} deg on the fitted mechanism)\n  \
                 the drive's own before: kp {:.3}, Ti {:.2} ms, kv {:.1}\n  the mesh: \
                 anti-resonance {:.1} Hz, resonance {:.1} Hz; measured on the table drive {}\n",
                g.utc,
                g.velocity_kp_nm_s_per_rad,
                g.velocity_integral_time_ms,
                g.position_kv_per_s,
                g.velocity_gain_margin_db,
                g.velocity_phase_margin_deg,
                g.position_gain_margin_db,
                g.position_phase_margin_deg,
                g.previous_velocity_kp_nm_s_per_rad,
                g.previous_velocity_integral_time_ms,
                g.previous_position_kv_per_s,
                g.mesh_antiresonance_hz,
                g.mesh_resonance_hz,
                identity_text(
                    g.table_drive_vendor_id,
                    g.table_drive_product_code,
                    g.table_drive_serial
                )
            );
        }
        None => o.push_str(
            "Table drive's gains: not commissioned by hob (the drive's own tuning; `hob \
             commission response` measures the table's frequency response and proposes gains)\n\n",
        ),
    }
}

/// The spindle encoder's record over the spindle's speeds, up to `max_rpm`: the once-per-turn
/// amplitude of the encoder's error (flat), of the true swing, and of what the loop's
/// identifier sees of both (their sum with its phase), arcsec of spindle; the speeds it was
/// measured at marked.
pub fn encoder_svg(e: &SpindleEncoderRecord, max_rpm: f64) -> String {
    let swing = e.swing();
    let (sw_s, sw_c) = (swing.swing_sin_arcsec, swing.swing_cos_arcsec);
    // (error, swing, seen) at rpm.
    let at = |rpm: f64| {
        let (gr, gi) = swing.scale(rpm);
        let (br, bi) = (sw_s * gr - sw_c * gi, sw_s * gi + sw_c * gr);
        (e.error_arcsec, br.hypot(bi), (e.error_arcsec + br).hypot(bi))
    };
    let lo = (0.2 * max_rpm).max(10.0);
    let n = 120;
    let rpms: Vec<f64> = (0..=n)
        .map(|i| lo + (max_rpm - lo) * f64::from(i) / f64::from(n))
        .collect();
    let top = rpms
        .iter()
        .map(|&r| {
            let (a, b, c) = at(r);
            a.max(b).max(c)
        })
        .fold(1.0f64, f64::max)
        * 1.1;
    let (w, h, bx, by, bw, bh) = (760.0, 460.0, 70.0, 50.0, 640.0, 300.0);
    let x = |rpm: f64| bx + (rpm - lo) / (max_rpm - lo) * bw;
    let y = |arcsec: f64| by + bh - arcsec / top * bh;
    let mut o = String::new();
    let _ = writeln!(
        o,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif" font-size="13">"#
    );
    let _ = writeln!(o, r#"<rect width="{w}" height="{h}" fill="white"/>"#);
    let _ = writeln!(
        o,
        r#"<text x="{bx}" y="30">spindle encoder, once per turn ({}): arcsec of spindle over its speed</text>"#,
        e.utc
    );
    let _ = writeln!(
        o,
        r#"<rect x="{bx}" y="{by}" width="{bw}" height="{bh}" fill="none" stroke="gray"/>"#
    );
    for k in 0..=4 {
        let v = top * f64::from(k) / 4.0;
        let _ = writeln!(
            o,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="end">{v:.0}</text>"#,
            bx - 6.0,
            y(v) + 4.0
        );
    }
    for k in 0..=4 {
        let r = lo + (max_rpm - lo) * f64::from(k) / 4.0;
        let _ = writeln!(
            o,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{r:.0} rpm</text>"#,
            x(r),
            by + bh + 18.0
        );
    }
    /// Which of (error, swing, seen) a curve draws.
    type Pick = fn((f64, f64, f64)) -> f64;
    let curves: [(&str, &str, Pick); 3] = [
        ("the encoder's error (corrected)", "#1f77b4", |v| v.0),
        ("the spindle's true swing (followed)", "#2ca02c", |v| v.1),
        ("what the loop identifies: both", "#d62728", |v| v.2),
    ];
    for (i, (label, colour, pick)) in curves.iter().enumerate() {
        let pts: Vec<String> = rpms
            .iter()
            .map(|&r| format!("{:.1},{:.1}", x(r), y(pick(at(r)))))
            .collect();
        let _ = writeln!(
            o,
            r#"<polyline points="{}" fill="none" stroke="{colour}" stroke-width="2"/>"#,
            pts.join(" ")
        );
        let ly = by + bh + 40.0 + 16.0 * i as f64;
        let _ = writeln!(
            o,
            r#"<line x1="{bx}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="{colour}" stroke-width="2"/><text x="{:.1}" y="{:.1}">{label}</text>"#,
            ly - 4.0,
            bx + 24.0,
            ly - 4.0,
            bx + 30.0,
            ly
        );
    }
    for &r in e.speeds_rpm.iter().filter(|&&r| (lo..=max_rpm).contains(&r)) {
        let _ = writeln!(
            o,
            r#"<circle cx="{:.1}" cy="{:.1}" r="4" fill="none" stroke="black"><title>measured at {r:.0} rpm</title></circle>"#,
            x(r),
            y(at(r).2)
        );
    }
    o.push_str("</svg>\n");
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    fn machine(records: &str) -> MachineConfig {
        let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/machine.toml"))
            .unwrap_or_else(|e| panic!("{e}"));
        let text = format!("{text}\n{records}");
        toml::from_str(&text).unwrap_or_else(|e| panic!("{e}"))
    }

    const ENCODER: &str = "[commissioning.spindle_encoder]\nutc = 2026-11-29T02:10:05Z\n\
        error_arcsec = 15.2\nerror_2_arcsec = 4.1\nerror_3_arcsec = 1.6\nswing_arcsec = 12.0\n\
        swing_phase_deg = 131.0\nswing_tau_s = 0.003\nreference_rpm = 212.0\n\
        speeds_rpm = [64.0, 110.0, 212.0]\nmisfit_arcsec = 0.5\nerror_uncertainty_arcsec = 0.9\n\
        [commissioning.table_backlash]\nutc = 2026-11-29T06:10:05Z\nlost_motion_arcsec = 25.15\n\
        uncertainty_arcsec = 0.02\nspeed_deg_min = 3.0\nsamples = 278\n\
        [commissioning.table_drive_gains]\nutc = 2026-11-29T09:10:05Z\n\
        velocity_kp_nm_s_per_rad = 1.89\nvelocity_integral_time_ms = 7.24\nposition_kv_per_s = 53.7\n\
        previous_velocity_kp_nm_s_per_rad = 1.909\nprevious_velocity_integral_time_ms = 8.6\n\
        previous_position_kv_per_s = 100.5\nvelocity_gain_margin_db = 9.2\n\
        velocity_phase_margin_deg = 45.0\nposition_gain_margin_db = 9.1\n\
        position_phase_margin_deg = 40.0\nmesh_antiresonance_hz = 37.4\nmesh_resonance_hz = 93.2\n\
        table_drive_vendor_id = 0x00000B0B\ntable_drive_product_code = 0x00020192\n\
        table_drive_serial = 0x00001002\n";

    #[test]
    fn the_report_says_what_was_measured_and_what_was_not() {
        let t = text(&machine(ENCODER));
        println!("{t}");
        assert!(t.contains("Table drive's delay (hob commission delay"), "{t}");
        assert!(t.contains("15.20 +- 0.90 arcsec once per turn"), "{t}");
        assert!(t.contains("12.00 arcsec at 212 rpm"), "{t}");
        assert!(
            t.contains("25.15 +- 0.02 arcsec of the table at a reversal"),
            "{t}"
        );
        assert!(t.contains("kp 1.890 Nm s/rad, Ti 7.24 ms, kv 53.7 1/s"), "{t}");
        assert!(t.contains("anti-resonance 37.4 Hz, resonance 93.2 Hz"), "{t}");
        assert!(
            t.contains("Not measured by hob yet: the X and Y drives' frequency response"),
            "{t}"
        );
        let mut bare = machine("");
        bare.commissioning = None;
        let t = text(&bare);
        assert!(t.contains("Table drive's delay: not commissioned"), "{t}");
        assert!(t.contains("Spindle encoder: not commissioned"), "{t}");
        assert!(t.contains("Table drive's lost motion: not measured"), "{t}");
        assert!(t.contains("Table drive's gains: not commissioned by hob"), "{t}");
    }

    #[test]
    fn the_plot_shows_the_error_the_swing_and_their_sum_with_the_speeds_measured() {
        let m = machine(ENCODER);
        let e = m
            .commissioning
            .as_ref()
            .and_then(|c| c.spindle_encoder.clone())
            .unwrap_or_else(|| panic!("the record"));
        let svg = encoder_svg(&e, m.spindle.max_spindle_rpm);
        assert!(svg.starts_with("<svg") && svg.ends_with("</svg>\n"));
        assert_eq!(svg.matches("<polyline").count(), 3);
        assert_eq!(svg.matches("<circle").count(), 3);
        assert!(!svg.contains("NaN") && !svg.contains("inf"), "{svg}");
    }
}
