//! Pictures a person can look at: the percentile distribution of several latency
//! histograms in one SVG (HdrHistogram's classic plot: x is the percentile on a
//! 1/(1-q) log scale, y the latency on a log scale); grouped bars with reference lines
//! (the accuracy breakdown).

use hdrhistogram::Histogram;
use std::fmt::Write as _;

const W: f64 = 860.0;
const H: f64 = 480.0;
const LEFT: f64 = 80.0;
const RIGHT: f64 = 200.0;
const TOP: f64 = 40.0;
const BOTTOM: f64 = 60.0;
const COLOURS: [&str; 4] = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd"];

/// One line of the plot.
#[derive(Debug)]
pub struct Series<'a> {
    pub label: String,
    pub hist: &'a Histogram<u64>,
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// The points (log10 of 1/(1-q), value us) of a histogram's percentile distribution.
fn points(h: &Histogram<u64>) -> Vec<(f64, f64)> {
    let mut v = Vec::new();
    for it in h.iter_quantiles(5) {
        let q = it.quantile_iterated_to();
        if q >= 1.0 {
            break;
        }
        v.push(((1.0 / (1.0 - q)).log10(), it.value_iterated_to() as f64 / 1e3));
    }
    if !h.is_empty() {
        let n = h.len() as f64;
        v.push((n.log10(), h.max() as f64 / 1e3));
    }
    v
}

/// The SVG text; `period_us` is drawn as a dashed line.
pub fn percentile_svg(title: &str, series: &[Series<'_>], period_us: f64) -> String {
    let all: Vec<Vec<(f64, f64)>> = series.iter().map(|s| points(s.hist)).collect();
    let x_max = all
        .iter()
        .flatten()
        .map(|p| p.0)
        .fold(1.0_f64, f64::max)
        .ceil()
        .max(2.0);
    let y_lo = all
        .iter()
        .flatten()
        .map(|p| p.1)
        .fold(f64::INFINITY, f64::min)
        .max(0.1)
        .log10()
        .floor();
    let y_hi = all
        .iter()
        .flatten()
        .map(|p| p.1)
        .fold(period_us, f64::max)
        .log10()
        .ceil()
        .max(y_lo + 1.0);
    let pw = W - LEFT - RIGHT;
    let ph = H - TOP - BOTTOM;
    let sx = |x: f64| LEFT + x / x_max * pw;
    let sy = |us: f64| TOP + ph - (us.max(0.1).log10() - y_lo) / (y_hi - y_lo) * ph;
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(s, r#"<rect width="{W}" height="{H}" fill="white"/>"#);
    let _ = writeln!(
        s,
        r#"<text x="{}" y="22" font-size="15" text-anchor="middle">{}</text>"#,
        LEFT + pw / 2.0,
        escape(title)
    );
    // Axes and grid.
    for d in 0..=(x_max as i32) {
        let x = sx(f64::from(d));
        let label = match d {
            0 => "0%".to_string(),
            1 => "90%".to_string(),
            d => format!("99.{}%", "9".repeat(d as usize - 1)),
        };
        let _ = writeln!(
            s,
            r##"<line x1="{x:.1}" y1="{TOP}" x2="{x:.1}" y2="{:.1}" stroke="#ddd"/><text x="{x:.1}" y="{:.1}" text-anchor="middle">{label}</text>"##,
            TOP + ph,
            TOP + ph + 18.0
        );
    }
    for e in (y_lo as i32)..=(y_hi as i32) {
        let us = 10f64.powi(e);
        let y = sy(us);
        let label = if us >= 1000.0 {
            format!("{} ms", us / 1000.0)
        } else {
            format!("{us} us")
        };
        let _ = writeln!(
            s,
            r##"<line x1="{LEFT}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#ddd"/><text x="{:.1}" y="{:.1}" text-anchor="end">{label}</text>"##,
            LEFT + pw,
            LEFT - 6.0,
            y + 4.0
        );
    }
    let _ = writeln!(
        s,
        r##"<rect x="{LEFT}" y="{TOP}" width="{pw}" height="{ph}" fill="none" stroke="#333"/>"##
    );
    let _ = writeln!(
        s,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">percentile</text>"#,
        LEFT + pw / 2.0,
        H - 14.0
    );
    let _ = writeln!(
        s,
        r#"<text x="16" y="{:.1}" text-anchor="middle" transform="rotate(-90 16 {:.1})">latency</text>"#,
        TOP + ph / 2.0,
        TOP + ph / 2.0
    );
    let py = sy(period_us);
    let _ = writeln!(
        s,
        r##"<line x1="{LEFT}" y1="{py:.1}" x2="{:.1}" y2="{py:.1}" stroke="#888" stroke-dasharray="6 4"/><text x="{:.1}" y="{:.1}" fill="#555">period {period_us} us</text>"##,
        LEFT + pw,
        LEFT + 6.0,
        py - 4.0
    );
    for (i, (ser, pts)) in series.iter().zip(&all).enumerate() {
        let c = COLOURS[i % COLOURS.len()];
        let path: Vec<String> = pts
            .iter()
            .map(|&(x, us)| format!("{:.1},{:.1}", sx(x), sy(us)))
            .collect();
        let _ = writeln!(
            s,
            r#"<polyline fill="none" stroke="{c}" stroke-width="2" points="{}"/>"#,
            path.join(" ")
        );
        let ly = TOP + 20.0 + 20.0 * i as f64;
        let lx = LEFT + pw + 14.0;
        let _ = writeln!(
            s,
            r#"<line x1="{lx}" y1="{ly}" x2="{}" y2="{ly}" stroke="{c}" stroke-width="3"/><text x="{}" y="{}">{}</text>"#,
            lx + 22.0,
            lx + 28.0,
            ly + 4.0,
            escape(&ser.label)
        );
    }
    s.push_str("</svg>\n");
    s
}

/// One group of bars (a gear): each bar a label and a value.
#[derive(Debug, Clone)]
pub struct BarGroup {
    pub label: String,
    pub bars: Vec<(String, f64)>,
}

/// Grouped bars on a linear scale from 0, with dashed reference lines; the legend names
/// each bar of the first group by its position (every group has the same bars).
pub fn bars_svg(title: &str, groups: &[BarGroup], lines: &[(f64, &str)]) -> String {
    const BAR_COLOURS: [&str; 8] = [
        "#000000", "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#7f7f7f",
    ];
    let width = 1100.0;
    let right = 300.0;
    let bottom = 110.0;
    let y_max_raw = groups
        .iter()
        .flat_map(|g| g.bars.iter().map(|b| b.1))
        .chain(lines.iter().map(|l| l.0))
        .fold(1.0_f64, f64::max);
    // A round top: 1, 2, 3 or 5 times a power of ten.
    let decade = 10f64.powf(y_max_raw.log10().floor());
    let y_max = [1.0, 2.0, 3.0, 5.0, 10.0]
        .iter()
        .map(|k| k * decade)
        .find(|v| *v >= y_max_raw)
        .unwrap_or(10.0 * decade);
    let pw = width - LEFT - right;
    let ph = H - TOP - bottom;
    let sy = |v: f64| TOP + ph - v / y_max * ph;
    let n = groups.len().max(1) as f64;
    let group_w = pw / n;
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{H}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(s, r#"<rect width="{width}" height="{H}" fill="white"/>"#);
    let _ = writeln!(
        s,
        r#"<text x="{}" y="22" text-anchor="middle" font-size="14">{}</text>"#,
        LEFT + pw / 2.0,
        escape(title)
    );
    for k in 0..=5 {
        let v = y_max * f64::from(k) / 5.0;
        let y = sy(v);
        let _ = writeln!(
            s,
            r##"<line x1="{LEFT}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#ddd"/><text x="{:.1}" y="{:.1}" text-anchor="end">{v:.0}</text>"##,
            LEFT + pw,
            LEFT - 6.0,
            y + 4.0
        );
    }
    for (gi, g) in groups.iter().enumerate() {
        let x0 = LEFT + gi as f64 * group_w;
        let bw = group_w * 0.8 / g.bars.len().max(1) as f64;
        for (bi, (label, v)) in g.bars.iter().enumerate() {
            let x = x0 + group_w * 0.1 + bi as f64 * bw;
            let y = sy(*v);
            let _ = writeln!(
                s,
                r#"<rect x="{x:.1}" y="{y:.1}" width="{:.1}" height="{:.1}" fill="{}"><title>{}: {v:.0}</title></rect>"#,
                bw * 0.9,
                (TOP + ph - y).max(0.0),
                BAR_COLOURS[bi % BAR_COLOURS.len()],
                escape(label)
            );
        }
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="end" transform="rotate(-25 {:.1} {:.1})">{}</text>"#,
            x0 + group_w / 2.0,
            TOP + ph + 18.0,
            x0 + group_w / 2.0,
            TOP + ph + 18.0,
            escape(&g.label)
        );
    }
    for (v, label) in lines {
        let y = sy(*v);
        let _ = writeln!(
            s,
            r##"<line x1="{LEFT}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#d62728" stroke-dasharray="6 4"/><text x="{:.1}" y="{:.1}" fill="#d62728">{} ({v:.0})</text>"##,
            LEFT + pw,
            LEFT + pw + 6.0,
            y + 4.0,
            escape(label)
        );
    }
    let _ = writeln!(
        s,
        r#"<line x1="{LEFT}" y1="{TOP}" x2="{LEFT}" y2="{:.1}" stroke="black"/><line x1="{LEFT}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="black"/>"#,
        TOP + ph,
        TOP + ph,
        LEFT + pw,
        TOP + ph
    );
    if let Some(first) = groups.first() {
        for (bi, (label, _)) in first.bars.iter().enumerate() {
            let y = TOP + 40.0 + bi as f64 * 18.0;
            let _ = writeln!(
                s,
                r#"<rect x="{:.1}" y="{:.1}" width="12" height="12" fill="{}"/><text x="{:.1}" y="{:.1}">{}</text>"#,
                LEFT + pw + 10.0,
                y - 10.0,
                BAR_COLOURS[bi % BAR_COLOURS.len()],
                LEFT + pw + 28.0,
                y,
                escape(label)
            );
        }
    }
    s.push_str("</svg>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hist;

    #[test]
    fn plot_has_a_line_per_series_and_the_period() {
        let mut a = hist::new();
        let mut b = hist::new();
        for i in 1..1000u64 {
            hist::record(&mut a, 10_000 + i * 10);
            hist::record(&mut b, 20_000 + i * 30);
        }
        let svg = percentile_svg(
            "t <1>",
            &[
                Series {
                    label: "cyclictest".into(),
                    hist: &a,
                },
                Series {
                    label: "hob-rt".into(),
                    hist: &b,
                },
            ],
            1000.0,
        );
        assert_eq!(svg.matches("<polyline").count(), 2);
        assert!(svg.contains("period 1000 us"));
        assert!(svg.contains("t &lt;1&gt;"));
        assert!(svg.ends_with("</svg>\n"));
    }

    #[test]
    fn bars_have_a_rect_each_lines_and_a_legend() {
        let groups = vec![
            BarGroup {
                label: "gear <a>".into(),
                bars: vec![("one".into(), 10.0), ("two".into(), 130.0)],
            },
            BarGroup {
                label: "gear b".into(),
                bars: vec![("one".into(), 5.0), ("two".into(), 60.0)],
            },
        ];
        let svg = bars_svg("t", &groups, &[(25.0, "goal"), (100.0, "grade 4")]);
        // 4 bars, 2 legend swatches, the white background.
        assert_eq!(svg.matches("<rect").count(), 4 + 2 + 1);
        assert!(svg.contains("goal (25)") && svg.contains("grade 4 (100)"));
        assert!(svg.contains("gear &lt;a&gt;"));
        // The scale's top is the next round value above the largest bar: 200.
        assert!(svg.contains(">200</text>"), "{svg}");
        assert!(svg.ends_with("</svg>\n"));
    }
}
