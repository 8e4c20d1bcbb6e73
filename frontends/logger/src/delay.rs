//! The table drive's delay identified from a recorded run, instead of assumed.
//!
//! The controller predicts the spindle angle for the instant its table target takes
//! effect: one cycle (the target goes out with the next SYNC) plus `control.drive_delay_us`
//! (the drive's interpolation over a period and its own lag). Whether that figure is the
//! machine's can be read from any recorded cut: the table's measured angle at each SYNC is
//! the command of some time before, `actual(n) = command(n - D / T)`. The delay `D` is the
//! shift that makes the two agree best, in the least-squares sense over the synchronised
//! cut (the command interpolated linearly between cycles, scanned in 10 us steps, refined by
//! a parabola through the best three). The table turns steadily in the cut, so a shift
//! shows as an offset of speed x shift: the drive's integral action leaves no constant
//! following error of its own to confuse it with.

/// One recorded cycle: the table's command and measured angle (deg), and whether the cycle
/// is in the synchronised cut.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TableSample {
    pub command_deg: f64,
    pub actual_deg: f64,
    pub in_cut: bool,
}

/// The identified delay.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct DriveDelay {
    /// From the cycle that computed a command to the table following it, s.
    pub total_s: f64,
    /// Less the cycle to the SYNC that applies it: what `control.drive_delay_us` is.
    pub drive_delay_s: f64,
    /// Cycles the fit used.
    pub samples: usize,
    /// RMS of the measured angle against the shifted command, arcsec.
    pub residual_rms_arcsec: f64,
    /// RMS at the assumed delay, arcsec (for comparison).
    pub assumed_rms_arcsec: f64,
}

/// A recording's table samples, one per cycle (a missing cycle is a sample outside the cut,
/// so that the index stays the cycle), and its cycle period.
pub fn from_log(dir: &std::path::Path) -> Result<(Vec<TableSample>, f64), crate::error::Error> {
    let states = crate::format::read_dir_states(dir)?;
    let period_s = crate::export::cycle_period_s(&states);
    Ok((from_states(&states, crate::export::synchronised_cut), period_s))
}

/// State samples in the order they came as table samples, one per cycle: a missing cycle
/// is a sample marked outside (so that the index stays the cycle); `counts` says which
/// samples the fit may use.
pub fn from_states(
    states: &[hob_ipc::StateSample],
    counts: impl Fn(&hob_ipc::StateSample) -> bool,
) -> Vec<TableSample> {
    let mut out: Vec<TableSample> = Vec::with_capacity(states.len());
    let mut last_cycle: Option<u64> = None;
    for s in states {
        if let Some(last) = last_cycle {
            // A gap of a few cycles keeps the index; a restart (the counter goes back) or a
            // long gap ends the run: nothing is aligned across it.
            let gap = s.cycle.wrapping_sub(last);
            let fill = if (2..1000).contains(&gap) {
                gap - 1
            } else if gap == 1 {
                0
            } else {
                MAX_CYCLES as u64 + 1
            };
            for _ in 0..fill {
                out.push(TableSample {
                    command_deg: f64::NAN,
                    actual_deg: f64::NAN,
                    in_cut: false,
                });
            }
        }
        last_cycle = Some(s.cycle);
        out.push(TableSample {
            command_deg: s.table_deg.command,
            actual_deg: s.table_deg.actual,
            in_cut: counts(s),
        });
    }
    out
}

/// The longest delay scanned, in cycles.
const MAX_CYCLES: f64 = 10.0;

/// The mean square of `actual(n) - command(n - shift)` over the cut, shift in cycles, and
/// the samples it took.
fn misfit(samples: &[TableSample], shift: f64) -> (f64, usize) {
    let whole = shift.floor() as usize;
    let frac = shift - shift.floor();
    let (mut sum, mut n) = (0.0, 0usize);
    for i in (whole + 1)..samples.len() {
        let (a, b) = (&samples[i - whole - 1], &samples[i - whole]);
        let s = &samples[i];
        if !(s.in_cut && a.in_cut && b.in_cut) {
            continue;
        }
        // command at (i - shift): between i - whole - 1 and i - whole.
        let command = b.command_deg + (a.command_deg - b.command_deg) * frac;
        let e = s.actual_deg - command;
        sum += e * e;
        n += 1;
    }
    (if n > 0 { sum / n as f64 } else { f64::INFINITY }, n)
}

/// Identifies the delay from cycles sampled every `period_s`; `assumed_drive_delay_s` is
/// the machine file's, reported beside it. `None`: fewer than a second of synchronised cut.
pub fn identify(samples: &[TableSample], period_s: f64, assumed_drive_delay_s: f64) -> Option<DriveDelay> {
    let step = 10e-6 / period_s;
    let steps = (MAX_CYCLES / step) as usize;
    // (shift, mean square, samples) for each shift scanned.
    let costs: Vec<(f64, f64, usize)> = (0..=steps)
        .map(|k| {
            let shift = k as f64 * step;
            let (cost, n) = misfit(samples, shift);
            (shift, cost, n)
        })
        .collect();
    let best = (0..costs.len()).min_by(|&a, &b| costs[a].1.total_cmp(&costs[b].1))?;
    let n = costs[best].2;
    if n < (1.0 / period_s) as usize || !costs[best].1.is_finite() {
        return None;
    }
    // A parabola through the best and its neighbours.
    let shift = if best > 0 && best + 1 < costs.len() {
        let (l, c, r) = (costs[best - 1].1, costs[best].1, costs[best + 1].1);
        let curvature = l - 2.0 * c + r;
        let offset = if curvature > 0.0 {
            (0.5 * (l - r) / curvature).clamp(-1.0, 1.0)
        } else {
            0.0
        };
        costs[best].0 + offset * step
    } else {
        costs[best].0
    };
    let total_s = shift * period_s;
    let rms = |s: f64| misfit(samples, s).0.sqrt() * 3600.0;
    Some(DriveDelay {
        total_s,
        drive_delay_s: total_s - period_s,
        samples: n,
        residual_rms_arcsec: rms(shift),
        assumed_rms_arcsec: rms((period_s + assumed_drive_delay_s) / period_s),
    })
}

/// "the table follows its command 1.98 ms after the cycle that computed it: ..."
pub fn text(d: &DriveDelay, assumed_drive_delay_s: f64) -> String {
    format!(
        "table drive delay: the table follows its command {:.0} us after the cycle that computed it, \
         {:.0} us after the SYNC that applies it (control.drive_delay_us: {:.0} us assumed); \
         {} cycles of synchronised cut; measured angle against the shifted command: RMS {:.2} arcsec \
         at the identified delay, {:.2} arcsec at the assumed one\n",
        d.total_s * 1e6,
        d.drive_delay_s * 1e6,
        assumed_drive_delay_s * 1e6,
        d.samples,
        d.residual_rms_arcsec,
        d.assumed_rms_arcsec,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A table turning at `deg_s` with a speed ripple, following its command `delay_s`
    /// late (the command sampled every 1 ms).
    fn run(deg_s: f64, delay_s: f64) -> Vec<TableSample> {
        let command = |t: f64| deg_s * t + 0.02 * (std::f64::consts::TAU * 3.0 * t).sin();
        (0..4000)
            .map(|n| {
                let t = f64::from(n) * 1e-3;
                TableSample {
                    command_deg: command(t),
                    actual_deg: command(t - delay_s),
                    in_cut: n > 200,
                }
            })
            .collect()
    }

    #[test]
    fn a_known_delay_is_found() {
        let d = identify(&run(60.0, 2.0e-3), 1e-3, 1e-3).expect("identified");
        assert!((d.total_s - 2.0e-3).abs() < 2e-6, "{d:?}");
        assert!((d.drive_delay_s - 1.0e-3).abs() < 2e-6, "{d:?}");
        assert!(d.residual_rms_arcsec < 0.01, "{d:?}");
    }

    #[test]
    fn too_short_a_cut_identifies_nothing() {
        let mut s = run(60.0, 2.0e-3);
        for (i, x) in s.iter_mut().enumerate() {
            x.in_cut = (1000..1500).contains(&i);
        }
        assert_eq!(identify(&s, 1e-3, 1e-3), None);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]
        #[test]
        fn any_delay_within_the_scan_is_found_to_a_few_us(delay_us in 1000.0f64..9000.0, deg_s in 5.0f64..200.0) {
            let d = identify(&run(deg_s, delay_us * 1e-6), 1e-3, 1e-3).expect("identified");
            prop_assert!((d.total_s * 1e6 - delay_us).abs() < 5.0, "{} against {delay_us}", d.total_s * 1e6);
        }
    }
}
