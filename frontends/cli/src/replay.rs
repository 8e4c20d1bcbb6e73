//! `hob replay FILE`: a flight record of `hob-rt` (written on a fault, at its stop, on `hob
//! record`) replayed through this build's control core: from the state the record starts
//! with, over its commands and inputs, every output compared with the recorded one to the
//! bit. With `--observer-bandwidth-hz` it replays a second time with the spindle
//! observer's bandwidth changed and shows what that changes: for the same inputs (the
//! machine does not answer a replay), how far the targets move and what the controller's
//! own estimate of its synchronisation error becomes.

use hob_control::flight::FlightRecord;
use hob_control::{Controller, CycleOutputs, State};
use std::fmt::Write as _;
use std::path::Path;

/// The controller's own figures along a replay.
#[derive(Debug, Clone, Copy, Default)]
struct Along {
    /// Largest |estimated sync error| in the synchronised cut, arcsec.
    sync_error_max_arcsec: f64,
    cut_cycles: usize,
    /// The first fault latched, at which record.
    fault: Option<(usize, hob_control::fault::Fault)>,
}

fn along(r: &FlightRecord, c: Controller) -> (Vec<CycleOutputs>, Along) {
    let mut outs = Vec::with_capacity(r.records.len());
    let mut a = Along::default();
    r.replay_each(c, |k, c, out| {
        outs.push(*out);
        let s = c.status();
        if a.fault.is_none()
            && let Some(f) = s.fault
        {
            a.fault = Some((k, f));
        }
        if s.state == State::Cut {
            a.cut_cycles += 1;
            a.sync_error_max_arcsec = a.sync_error_max_arcsec.max(s.sync_error_arcsec.abs());
        }
    });
    (outs, a)
}

/// The replay's report; Err(text) when the outputs do not match (exit 1) or the file is
/// refused.
pub fn replay(path: &Path, observer_bandwidth_hz: Option<f64>) -> Result<String, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let r = hob_control::flight::decode(&bytes, &path.display().to_string())?;
    let mut o = String::new();
    let _ = writeln!(
        o,
        "{}: {} ({}), {} cycles from cycle {} ({:.1} s), {} program(s) loaded in it",
        path.display(),
        r.reason,
        r.written_utc,
        r.records.len(),
        r.first_cycle,
        r.records.len() as f64 * r.start.params().period_s,
        r.programs.len()
    );
    let rep = r.replay(r.start.clone());
    if let Some(k) = rep.stopped_at {
        let _ = writeln!(
            o,
            "replayed {} cycles; cycle {} loaded a program the record could not keep: not replayed past it",
            rep.cycles,
            r.first_cycle + k as u64
        );
    }
    if let Some((k, recorded, replayed)) = rep.first_difference {
        let _ = writeln!(
            o,
            "NOT REPRODUCED: the outputs part at cycle {} (record {k}):\n  recorded {recorded:?}\n  replayed {replayed:?}",
            r.first_cycle + k as u64
        );
        return Err(o);
    }
    let _ = writeln!(
        o,
        "reproduced: {} cycles replayed, every output identical to the recorded one, bit for bit",
        rep.cycles
    );
    if let Some(hz) = observer_bandwidth_hz {
        if !(hz.is_finite() && hz > 0.0 && hz < 0.5 / r.start.params().period_s) {
            return Err(format!(
                "{o}--observer-bandwidth-hz {hz}: must be above 0 and below half the cycle rate"
            ));
        }
        let was = r.start.params().observer_bandwidth_hz;
        let (base_out, base) = along(&r, r.start.clone());
        let mut changed = r.start.clone();
        changed.set_observer_bandwidth_hz(hz);
        let (new_out, new) = along(&r, changed);
        let (mut d_table, mut d_x, mut first) = (0i64, 0i64, None);
        for (k, (a, b)) in base_out.iter().zip(&new_out).enumerate() {
            let dt = i64::from(b.table_target_counts.wrapping_sub(a.table_target_counts)).abs();
            let dx = i64::from(b.x_target_counts.wrapping_sub(a.x_target_counts)).abs();
            if (dt > 0 || dx > 0) && first.is_none() {
                first = Some(k);
            }
            d_table = d_table.max(dt);
            d_x = d_x.max(dx);
        }
        let _ = writeln!(
            o,
            "what if the spindle observer's bandwidth were {hz} Hz instead of {was} Hz (the same inputs: the machine does not answer a replay):"
        );
        let _ = writeln!(
            o,
            "  table targets differ by up to {d_table} counts, X targets by up to {d_x} counts{}",
            first.map_or(String::new(), |k| format!(
                ", from cycle {}",
                r.first_cycle + k as u64
            ))
        );
        let _ = writeln!(
            o,
            "  the controller's estimate of its sync error in the cut ({} cycles): at most {:.3} arcsec, recorded settings {:.3} arcsec",
            new.cut_cycles, new.sync_error_max_arcsec, base.sync_error_max_arcsec
        );
        let fault = |a: &Along| {
            a.fault.map_or("none".to_string(), |(k, f)| {
                format!("{f:?} at cycle {}", r.first_cycle + k as u64)
            })
        };
        let _ = writeln!(
            o,
            "  the first fault: {} (recorded settings: {})",
            fault(&new),
            fault(&base)
        );
    }
    Ok(o)
}
