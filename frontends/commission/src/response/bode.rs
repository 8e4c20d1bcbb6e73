//! The Bode plot of the table's response: magnitude (dB) and phase (deg) over a log scale
//! of frequency, the measured points with their uncertainty and the fitted model's line,
//! the mesh's anti-resonance and resonance marked.

use super::analysis::Analysis;
use super::fit;
use std::fmt::Write;

const W: f64 = 760.0;
const H: f64 = 560.0;
const LEFT: f64 = 70.0;
const PLOT_W: f64 = 640.0;
/// (top, height) of the magnitude and the phase panel.
const MAG: (f64, f64) = (50.0, 210.0);
const PHASE: (f64, f64) = (300.0, 210.0);

/// The plot as SVG.
pub fn svg(a: &Analysis) -> String {
    let (lo, hi) = (
        a.points.first().map_or(1.0, |p| p.frequency_hz),
        a.points.last().map_or(100.0, |p| p.frequency_hz),
    );
    let x = |f: f64| LEFT + (f / lo).ln() / (hi / lo).ln() * PLOT_W;
    let model: Vec<(f64, f64, f64)> = (0..=200)
        .map(|i| {
            let f = lo * (hi / lo).powf(f64::from(i) / 200.0);
            let h = fit::response(&a.fitted.mechanism, &a.present, a.period_s, a.fitted.delay_s, f);
            (f, 20.0 * h.norm().log10(), h.arg().to_degrees())
        })
        .collect();
    let model_phase = unwrap(model.iter().map(|m| m.2));
    let db: Vec<f64> = a
        .points
        .iter()
        .map(|p| p.magnitude_db())
        .chain(model.iter().map(|m| m.1))
        .collect();
    let db_range = (
        (db.iter().copied().fold(f64::INFINITY, f64::min) / 5.0).floor() * 5.0,
        (db.iter().copied().fold(f64::NEG_INFINITY, f64::max) / 5.0).ceil() * 5.0,
    );
    let ph_range = (
        (model_phase.iter().copied().fold(f64::INFINITY, f64::min) / 90.0).floor() * 90.0 - 45.0,
        (model_phase.iter().copied().fold(f64::NEG_INFINITY, f64::max) / 90.0).ceil() * 90.0 + 45.0,
    );
    let mut o = String::new();
    let _ = writeln!(
        o,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" viewBox="0 0 {W} {H}" font-family="sans-serif" font-size="13">"#
    );
    let _ = writeln!(o, r#"<rect width="{W}" height="{H}" fill="white"/>"#);
    let _ = writeln!(
        o,
        r#"<text x="{LEFT}" y="30">table drive: motor over target (points measured, line the fitted model)</text>"#
    );
    panel(&mut o, MAG, db_range, "dB", &x, (lo, hi));
    panel(&mut o, PHASE, ph_range, "deg", &x, (lo, hi));
    let y = |(top, h): (f64, f64), (a0, a1): (f64, f64), v: f64| top + h - (v - a0) / (a1 - a0) * h;
    let line = |pts: &mut dyn Iterator<Item = (f64, f64)>| {
        pts.map(|(px, py)| format!("{px:.1},{py:.1}"))
            .collect::<Vec<_>>()
            .join(" ")
    };
    let mag_line = line(&mut model.iter().map(|m| (x(m.0), y(MAG, db_range, m.1))));
    let ph_line = line(
        &mut model
            .iter()
            .zip(&model_phase)
            .map(|(m, p)| (x(m.0), y(PHASE, ph_range, *p))),
    );
    for pl in [mag_line, ph_line] {
        let _ = writeln!(
            o,
            r##"<polyline points="{pl}" fill="none" stroke="#1f5fbf" stroke-width="2"/>"##
        );
    }
    for p in &a.points {
        let near = nearest(&model, &model_phase, p.frequency_hz);
        let phase = near + wrap(p.phase_deg() - near);
        let spread_db = 20.0 * ((p.response.norm() + p.uncertainty) / p.response.norm()).log10();
        let (px, py) = (x(p.frequency_hz), y(MAG, db_range, p.magnitude_db()));
        let _ = writeln!(
            o,
            r##"<line x1="{px:.1}" x2="{px:.1}" y1="{:.1}" y2="{:.1}" stroke="#c03020"/><circle cx="{px:.1}" cy="{py:.1}" r="3.5" fill="#c03020"/>"##,
            y(MAG, db_range, p.magnitude_db() - spread_db),
            y(MAG, db_range, p.magnitude_db() + spread_db)
        );
        let _ = writeln!(
            o,
            r##"<circle cx="{px:.1}" cy="{:.1}" r="3.5" fill="#c03020"/>"##,
            y(PHASE, ph_range, phase)
        );
    }
    modes(&mut o, a.modes_hz, &x, (lo, hi));
    let _ = writeln!(
        o,
        r#"<text x="{LEFT}" y="{}">Hz (log)</text></svg>"#,
        PHASE.0 + PHASE.1 + 40.0
    );
    o
}

/// The mesh's two frequencies marked across both panels, labelled.
fn modes(o: &mut String, (anti_hz, res_hz): (f64, f64), x: &dyn Fn(f64) -> f64, (lo, hi): (f64, f64)) {
    for (row, (f, name)) in [(anti_hz, "anti-resonance"), (res_hz, "resonance")]
        .into_iter()
        .enumerate()
    {
        if (lo..=hi).contains(&f) {
            let fx = x(f);
            // Labels right of their line, or left of it near the panel's right edge.
            let (tx, anchor) = if fx > LEFT + PLOT_W - 170.0 {
                (fx - 4.0, "end")
            } else {
                (fx + 4.0, "start")
            };
            let _ = writeln!(
                o,
                r##"<line x1="{fx:.1}" x2="{fx:.1}" y1="{}" y2="{}" stroke="#888" stroke-dasharray="4 3"/><text x="{tx:.1}" y="{}" fill="#555" text-anchor="{anchor}">{name} {f:.1} Hz</text>"##,
                MAG.0,
                PHASE.0 + PHASE.1,
                MAG.0 + 14.0 + 16.0 * row as f64
            );
        }
    }
}

/// A panel's frame, its grid and labels.
fn panel(
    o: &mut String,
    (top, h): (f64, f64),
    (a0, a1): (f64, f64),
    unit: &str,
    x: &dyn Fn(f64) -> f64,
    (lo, hi): (f64, f64),
) {
    let _ = writeln!(
        o,
        r##"<rect x="{LEFT}" y="{top}" width="{PLOT_W}" height="{h}" fill="none" stroke="#444"/>"##
    );
    let step = if unit == "dB" { 5.0 } else { 90.0 };
    let mut v = a0;
    while v <= a1 + 1e-9 {
        let py = top + h - (v - a0) / (a1 - a0) * h;
        let _ = writeln!(
            o,
            r##"<line x1="{LEFT}" x2="{}" y1="{py:.1}" y2="{py:.1}" stroke="#ddd"/><text x="{}" y="{:.1}" text-anchor="end">{v:.0} {unit}</text>"##,
            LEFT + PLOT_W,
            LEFT - 6.0,
            py + 4.0
        );
        v += step;
    }
    let mut decade = 10f64.powf(lo.log10().floor());
    while decade <= hi {
        for m in [1.0, 2.0, 5.0] {
            let f = decade * m;
            if (lo..=hi).contains(&f) {
                let fx = x(f);
                let _ = writeln!(
                    o,
                    r##"<line x1="{fx:.1}" x2="{fx:.1}" y1="{top}" y2="{}" stroke="#ddd"/><text x="{fx:.1}" y="{}" text-anchor="middle">{f}</text>"##,
                    top + h,
                    top + h + 16.0
                );
            }
        }
        decade *= 10.0;
    }
}

/// Phases (deg) made continuous.
fn unwrap(phases: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut out: Vec<f64> = Vec::new();
    for p in phases {
        let v = match out.last() {
            Some(&last) => last + wrap(p - last),
            None => p,
        };
        out.push(v);
    }
    out
}

/// An angle brought into -180 .. 180 deg.
fn wrap(d: f64) -> f64 {
    (d + 180.0).rem_euclid(360.0) - 180.0
}

/// The model's continuous phase at the model frequency nearest `f`.
fn nearest(model: &[(f64, f64, f64)], phase: &[f64], f: f64) -> f64 {
    let i = (0..model.len())
        .min_by(|&a, &b| (model[a].0 - f).abs().total_cmp(&(model[b].0 - f).abs()))
        .unwrap_or(0);
    phase.get(i).copied().unwrap_or(0.0)
}
