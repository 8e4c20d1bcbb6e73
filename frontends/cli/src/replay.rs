//! `hob replay FILE`: a flight record of `hob-rt` (written on a fault, at its stop, on `hob
//! record`) replayed through this build's control core: from the state the record starts
//! with, over its commands and inputs, every output compared with the recorded one to the
//! bit. With `--observer-bandwidth-hz` it replays a second time with the spindle
//! observer's bandwidth changed, the machine answering the changed targets
//! (`FlightRecord::replay_answered`: each drive follows them with the lag found in the
//! record and the recorded deviation), and shows what that changes: how far the targets
//! and the table move, what the controller's own estimate of its synchronisation error
//! becomes, and the first fault.

use crate::error::Error;
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

/// A replay's outputs, the table's positions as answered (and whether in the cut), its figures.
type Run = (Vec<CycleOutputs>, Vec<(i32, bool)>, Along);

/// The replay of `c`, the machine answering (with the recorded controller: the recorded
/// run); the outputs, the table positions as answered and the figures.
fn along(r: &FlightRecord, c: Controller, lags: [usize; 3]) -> Run {
    let mut outs = Vec::with_capacity(r.records.len());
    let mut table = Vec::with_capacity(r.records.len());
    let mut a = Along::default();
    r.replay_answered(c, lags, |k, c, inputs, out| {
        outs.push(*out);
        let s = c.status();
        table.push((inputs.table.position_counts, s.state == State::Cut));
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
    (outs, table, a)
}

/// The replay's report; an error when the outputs do not match (exit 1, the report in it)
/// or the file is refused.
pub fn replay(path: &Path, observer_bandwidth_hz: Option<f64>) -> Result<String, Error> {
    let bytes = std::fs::read(path).map_err(|error| Error::Io {
        path: path.to_path_buf(),
        error,
    })?;
    let r = hob_control::flight::decode(&bytes, &path.display().to_string())
        .map_err(|e| Error::FlightRecord(e.to_string()))?;
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
        return Err(Error::NotReproduced { report: o });
    }
    let _ = writeln!(
        o,
        "reproduced: {} cycles replayed, every output identical to the recorded one, bit for bit",
        rep.cycles
    );
    if let Some(hz) = observer_bandwidth_hz {
        if !(hz.is_finite() && hz > 0.0 && hz < 0.5 / r.start.params().period_s) {
            return Err(Error::ObserverBandwidth { report: o, hz });
        }
        what_if(&mut o, &r, hz);
    }
    Ok(o)
}

/// How a replay with a changed observer parts from the recorded settings' replay, in the
/// cycles both ran.
#[derive(Debug, Default)]
struct Parting {
    /// Largest difference of the table's and X's targets, counts.
    table_counts: i64,
    x_counts: i64,
    /// The first record whose targets differ.
    first: Option<usize>,
    /// The table's position against the recorded one, in the cycles both cut, counts.
    moved: Vec<f64>,
}

fn parting(base: &Run, new: &Run) -> Parting {
    let mut p = Parting::default();
    for (k, (a, b)) in base.0.iter().zip(&new.0).enumerate() {
        let dt = i64::from(b.table_target_counts.wrapping_sub(a.table_target_counts)).abs();
        let dx = i64::from(b.x_target_counts.wrapping_sub(a.x_target_counts)).abs();
        if (dt > 0 || dx > 0) && p.first.is_none() {
            p.first = Some(k);
        }
        p.table_counts = p.table_counts.max(dt);
        p.x_counts = p.x_counts.max(dx);
        let ((new_at, new_cut), (base_at, base_cut)) = (new.1[k], base.1[k]);
        if new_cut && base_cut {
            p.moved.push(f64::from(new_at.wrapping_sub(base_at)));
        }
    }
    p
}

/// The replay a second time with the spindle observer's bandwidth `hz`, the machine
/// answering the changed targets, against the recorded settings' replay.
fn what_if(o: &mut String, r: &FlightRecord, hz: f64) {
    let was = r.start.params().observer_bandwidth_hz;
    let found = r.follow_lags();
    // An axis that did not move follows with the lag of those that did.
    let fallback = found.iter().flatten().copied().max().unwrap_or(2);
    let lags = found.map(|l| l.unwrap_or(fallback));
    let base_run = along(r, r.start.clone(), lags);
    let mut changed = r.start.clone();
    changed.set_observer_bandwidth_hz(hz);
    let new_run = along(r, changed, lags);
    let p = parting(&base_run, &new_run);
    let (base, new) = (&base_run.2, &new_run.2);
    let arcsec_per_count = 3600.0 / r.start.params().table.counts_per_unit;
    // A constant shift is the phase the engagement took, which only places the teeth
    // on the blank; what changes the gear is the rest.
    let phase = p.moved.iter().sum::<f64>() / p.moved.len().max(1) as f64;
    let varies = p.moved.iter().map(|d| (d - phase).abs()).fold(0.0f64, f64::max);
    let lag_text = |l: Option<usize>| l.map_or(format!("{fallback} (did not move)"), |l| l.to_string());
    let _ = writeln!(
        o,
        "what if the spindle observer's bandwidth were {hz} Hz instead of {was} Hz, the machine answering the changed targets (each drive follows them with the lag found in the record, B {}, X {}, Y {} cycles, and the recorded deviation from them):",
        lag_text(found[0]),
        lag_text(found[1]),
        lag_text(found[2])
    );
    let _ = writeln!(
        o,
        "  table targets differ by up to {} counts ({:.2} arcsec), X targets by up to {} counts{}; in the cut ({} cycles) the table's path differs from the recorded one by a constant {:.2} arcsec (the engagement's phase: where the teeth fall on the blank) and beyond it by up to {:.2} arcsec",
        p.table_counts,
        p.table_counts as f64 * arcsec_per_count,
        p.x_counts,
        p.first.map_or(String::new(), |k| format!(
            ", from cycle {}",
            r.first_cycle + k as u64
        )),
        p.moved.len(),
        phase * arcsec_per_count,
        varies * arcsec_per_count
    );
    let _ = writeln!(
        o,
        "  the controller's estimate of its sync error in the cut ({} cycles): at most {:.3} arcsec, recorded settings {:.3} arcsec (its own estimate, against its own observer: not the truth)",
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
        fault(new),
        fault(base)
    );
}
