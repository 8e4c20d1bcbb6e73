//! `candump -L` captures: reading them, and checking that a run kept to the bus schedule
//! (SYNC each cycle; between two SYNCs exactly one target RPDO and one actual-position
//! TPDO per drive; no frame outside the schedule, a PDO of the plan's length; no SDO once
//! the cycle runs; RPDO2, mode of operation then controlword: the table only in cyclic
//! synchronous position (8), X and Y in 8 or homing (6), controlword bit 4 (homing start)
//! only in homing).

use crate::plan::{BusPlan, DrivePdos};
use hob_canopen::cia402;
use hob_canopen::frame::{Cob, Frame};

/// One captured frame and its timestamp (s), if the capture has one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Captured {
    pub t_s: Option<f64>,
    pub frame: Frame,
}

/// Parses `candump -L` lines (`(1700000000.123456) vcan0 080#`) or bare `ID#DATA`.
///
/// Frames are returned in the order of their kernel timestamps: `candump` writes frames
/// received on different sockets' paths out of order now and then under load (measured in
/// the emulated guest: a TPDO stamped before a SYNC logged after it), while the stamps
/// keep the order on the bus. Lines without a stamp keep the file's order.
pub fn parse_candump(text: &str) -> Vec<Captured> {
    let mut frames: Vec<Captured> = text
        .lines()
        .filter_map(|line| {
            let mut t_s = None;
            let mut rest = line.trim();
            if let Some(r) = rest.strip_prefix('(') {
                let (t, after) = r.split_once(')')?;
                t_s = t.trim().parse().ok();
                rest = after.trim();
            }
            let frame_text = rest.split_whitespace().last()?;
            Frame::from_candump(frame_text).map(|frame| Captured { t_s, frame })
        })
        .collect();
    if frames.iter().all(|c| c.t_s.is_some()) {
        // Stable: frames with the same stamp keep the file's order.
        frames.sort_by(|a, b| a.t_s.partial_cmp(&b.t_s).unwrap_or(std::cmp::Ordering::Equal));
    }
    frames
}

/// A `candump -L` line for a frame.
pub fn candump_line(t_s: f64, iface: &str, f: &Frame) -> String {
    format!("({t_s:.6}) {iface} {}", f.to_candump())
}

/// What a capture shows.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ScheduleReport {
    pub frames: usize,
    pub syncs: usize,
    /// Intervals between SYNCs checked for the cyclic PDO set.
    pub cycles_checked: usize,
    /// Position TPDOs that came one SYNC late (the master counts and holds them; on an
    /// emulated machine a slow node process causes this, on the real bus a late drive).
    pub late_tpdos: usize,
    /// Cycles whose cyclic PDO count was off beyond one late TPDO (kept apart from
    /// `violations`: a capture taken by `candump` on an emulated machine can lose or
    /// misorder frames under load; the caller decides how many it tolerates).
    pub count_anomalies: Vec<String>,
    pub violations: Vec<String>,
    /// Intervals between SYNCs from the timestamps (s): median and maximum.
    pub sync_interval_median_s: Option<f64>,
    pub sync_interval_max_s: Option<f64>,
}

/// Checks a capture against the bus plan.
pub fn check_schedule(frames: &[Captured], plan: &BusPlan) -> ScheduleReport {
    let mut check = ScheduleCheck::new(plan, frames.len());
    for (i, c) in frames.iter().enumerate() {
        check.frame(i, c);
    }
    check.finish()
}

/// [`check_schedule`]'s state along the capture.
struct ScheduleCheck<'a> {
    plan: &'a BusPlan,
    nodes: [u8; 4],
    r: ScheduleReport,
    /// Whether a SYNC was seen: the cycle runs.
    in_cycle: bool,
    /// Per drive since the last SYNC: target RPDOs and position TPDOs.
    counts: Option<[[u32; 2]; 3]>,
    /// Per drive: position TPDOs seen minus intervals (-1: one is late).
    backlog: [i64; 3],
    sync_times: Vec<f64>,
}

impl<'a> ScheduleCheck<'a> {
    fn new(plan: &'a BusPlan, frames: usize) -> Self {
        Self {
            plan,
            nodes: plan.nodes(),
            r: ScheduleReport {
                frames,
                ..ScheduleReport::default()
            },
            in_cycle: false,
            counts: None,
            backlog: [0; 3],
            sync_times: Vec::new(),
        }
    }

    /// Frame `i`: in the schedule, a control RPDO's mode and controlword, the cycle's counts.
    fn frame(&mut self, i: usize, c: &Captured) {
        let f = &c.frame;
        let cob = Cob::of(f.id);
        if !self.known(i, f, cob) {
            self.r
                .violations
                .push(format!("frame {i}: {} is not in the schedule", f.to_candump()));
        } else if let Some(d) = self.plan.drives.iter().find(|d| d.control.cob_id == f.id)
            && let Some(v) = d.control.unpack(f)
        {
            check_control(&mut self.r, i, f, d, &v);
        }
        if cob == Cob::Sync {
            self.sync(i, c.t_s);
            return;
        }
        if let Some(k) = self.counts.as_mut() {
            for (j, d) in self.plan.drives.iter().enumerate() {
                if f.id == d.target.cob_id {
                    k[j][0] += 1;
                } else if f.id == d.actual.cob_id {
                    k[j][1] += 1;
                }
            }
        }
    }

    /// Whether the frame is in the schedule (an SDO is, to a planned node, but a violation
    /// once the cycle runs).
    fn known(&mut self, i: usize, f: &Frame, cob: Cob) -> bool {
        let plan = self.plan;
        match cob {
            Cob::Nmt | Cob::Sync => true,
            Cob::Emcy(n) | Cob::Heartbeat(n) => self.nodes.contains(&n) || n == crate::plan::MASTER_NODE,
            Cob::SdoRx(n) | Cob::SdoTx(n) => {
                if self.in_cycle {
                    self.r
                        .violations
                        .push(format!("frame {i}: SDO to node {n} while the cycle runs"));
                }
                self.nodes.contains(&n)
            }
            Cob::Tpdo(_, _) | Cob::Rpdo(_, _) => plan
                .drives
                .iter()
                .flat_map(|d| [d.target, d.control, d.actual, d.status])
                .chain(plan.io.pdos())
                .any(|p| p.cob_id == f.id && usize::from(f.len) == p.len_bytes()),
            _ => false,
        }
    }

    /// A SYNC at frame `i`: the interval before it checked for one target RPDO and one
    /// position TPDO per drive (a TPDO may be one SYNC late), and a new interval begun.
    fn sync(&mut self, i: usize, t_s: Option<f64>) {
        let r = &mut self.r;
        r.syncs += 1;
        self.in_cycle = true;
        if let Some(t) = t_s {
            self.sync_times.push(t);
        }
        if let Some(k) = self.counts.take() {
            r.cycles_checked += 1;
            for (j, (d, [rpdo, tpdo])) in self.plan.drives.iter().zip(k).enumerate() {
                // A TPDO may come one SYNC late: it then stands in the next interval.
                self.backlog[j] += i64::from(tpdo) - 1;
                if tpdo == 0 && self.backlog[j] >= -1 {
                    r.late_tpdos += 1;
                }
                if rpdo != 1 || !(-1..=0).contains(&self.backlog[j]) {
                    r.count_anomalies.push(format!(
                        "frame {i}: before this SYNC drive {} had {rpdo} target RPDOs and {tpdo} position TPDOs (1 each expected, one may be late)",
                        d.node
                    ));
                    self.backlog[j] = 0;
                }
            }
        }
        self.counts = Some([[0; 2]; 3]);
    }

    /// The report, with the SYNC intervals' median and maximum.
    fn finish(self) -> ScheduleReport {
        let mut r = self.r;
        let mut gaps: Vec<f64> = self.sync_times.windows(2).map(|w| w[1] - w[0]).collect();
        gaps.sort_by(f64::total_cmp);
        r.sync_interval_median_s = gaps.get(gaps.len() / 2).copied();
        r.sync_interval_max_s = gaps.last().copied();
        r
    }
}

/// A drive's RPDO2 (`v`: mode of operation, controlword) at frame `i`: the mode one the
/// drive may run in, controlword bit 4 (homing start) only in homing.
fn check_control(r: &mut ScheduleReport, i: usize, f: &Frame, d: &DrivePdos, v: &[u64]) {
    let (mode, cw) = (v[0] as u8 as i8, v[1] as u16);
    let allowed: &[i8] = if d.homing.is_some() {
        &[cia402::MODE_CSP, cia402::MODE_HOMING]
    } else {
        &[cia402::MODE_CSP]
    };
    if !allowed.contains(&mode) {
        r.violations.push(format!(
            "frame {i}: {}: drive {} ({}) asked for mode {mode} (allowed: {allowed:?})",
            f.to_candump(),
            d.node,
            d.axis.name()
        ));
    } else if cw & cia402::CW_HOMING_START != 0 && mode != cia402::MODE_HOMING {
        r.violations.push(format!(
            "frame {i}: {}: controlword bit 4 (homing start) to drive {} in mode {mode}",
            f.to_candump(),
            d.node
        ));
    }
}

/// What the frames show about the gearbox in the cut.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GearboxReport {
    /// Stretches of `window` cycles found entirely in a cut.
    pub windows: usize,
    /// Largest relative difference between the table targets' advance and z0/z times
    /// the received spindle angles' advance.
    pub worst_relative_error: f64,
}

/// Checks, from the frames alone, that in the cut the table targets the master sent
/// advance by the gearbox ratio of the spindle angles it received (timing plays no part).
///
/// A cycle is in the cut when the X target is at one of `cut_x_mm` (within 0.1 mm:
/// crowning and contour stay well inside) and the Y target moves. Per cycle the pair is
/// (spindle counts in the table drive's TPDO1 after SYNC k, table target in the RPDO1
/// sent next).
pub fn check_gearbox(
    frames: &[Captured],
    plan: &BusPlan,
    ratio_signed: f64,
    scales: [f64; 4],
    cut_x_mm: &[f64],
    window: usize,
) -> GearboxReport {
    let [
        spindle_counts_per_deg,
        table_counts_per_deg,
        x_counts_per_mm,
        y_counts_per_mm,
    ] = scales;
    let (b, x, y) = (&plan.drives[0], &plan.drives[1], &plan.drives[2]);
    let mut spindle = None;
    let (mut x_target, mut y_target, mut last_y) = (f64::NAN, f64::NAN, f64::NAN);
    let mut pairs: Vec<(f64, f64, bool)> = Vec::new();
    // The table's targets wrap at 32 bits (every 27 table turns in 2^20 counts per motor
    // turn): followed continuously from the first.
    let mut table_counts = hob_gearing::units::Unwrapper::default();
    for c in frames {
        let f = &c.frame;
        if f.id == b.actual.cob_id
            && let Some(v) = b.actual.unpack(f)
        {
            spindle = Some(f64::from(v[1] as u32 as i32) / spindle_counts_per_deg);
        } else if f.id == x.target.cob_id
            && let Some(v) = x.target.unpack(f)
        {
            x_target = f64::from(v[0] as u32 as i32) / x_counts_per_mm;
        } else if f.id == y.target.cob_id
            && let Some(v) = y.target.unpack(f)
        {
            y_target = f64::from(v[0] as u32 as i32) / y_counts_per_mm;
        } else if f.id == b.target.cob_id
            && let Some(v) = b.target.unpack(f)
            && let Some(s) = spindle.take()
        {
            let total = table_counts.update(v[0] as u32 as i32);
            let table = total as f64 / table_counts_per_deg;
            let feeding = y_target != last_y && last_y.is_finite();
            let at_depth = cut_x_mm.iter().any(|cx| (x_target - cx).abs() < 0.1);
            pairs.push((s, table, feeding && at_depth));
            last_y = y_target;
        }
    }
    let mut r = GearboxReport::default();
    let mut i = 0;
    while i + window < pairs.len() {
        if pairs[i..=i + window].iter().all(|p| p.2) {
            let (s0, t0, _) = pairs[i];
            let (s1, t1, _) = pairs[i + window];
            let slope = (t1 - t0) / (s1 - s0);
            r.windows += 1;
            r.worst_relative_error = r
                .worst_relative_error
                .max(((slope - ratio_signed) / ratio_signed).abs());
            i += window;
        } else {
            i += 1;
        }
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan() -> BusPlan {
        BusPlan::from_machine(&hob_config::machine::shipped_for_tests())
    }

    #[test]
    fn frames_are_put_in_the_order_of_their_stamps() {
        // As logged by candump in the guest (fresh-clone run): the TPDO stamped before the
        // SYNC was written after it.
        let text = "\
(1795251869.388954) vcan0 204#AC800200
(1795251869.389000) vcan0 080#
(1795251869.388017) vcan0 184#B1800200
(1795251869.393011) vcan0 182#9FA5E9FFD714F9FF
";
        let ids: Vec<u16> = parse_candump(text).iter().map(|c| c.frame.id).collect();
        assert_eq!(ids, [0x184, 0x204, 0x080, 0x182]);
        let unstamped = "vcan0 080#\nvcan0 184#B1800200\n";
        let ids: Vec<u16> = parse_candump(unstamped).iter().map(|c| c.frame.id).collect();
        assert_eq!(ids, [0x080, 0x184], "without stamps the file's order stands");
    }

    const GOOD: &str = "\
(1.000000) vcan0 202#00000000
(1.000010) vcan0 203#00000000
(1.000020) vcan0 204#00000000
(1.000030) vcan0 080#
(1.000100) vcan0 182#0000000000000000
(1.000110) vcan0 183#00000000
(1.000120) vcan0 184#00000000
(1.000200) vcan0 202#01000000
(1.000210) vcan0 203#00000000
(1.000220) vcan0 204#00000000
(1.001030) vcan0 080#
";

    #[test]
    fn a_run_on_schedule_passes() {
        let frames = parse_candump(GOOD);
        assert_eq!(frames.len(), 11);
        let r = check_schedule(&frames, &plan());
        assert_eq!(r.syncs, 2);
        assert_eq!(r.cycles_checked, 1);
        assert!(r.violations.is_empty(), "{:?}", r.violations);
        assert!((r.sync_interval_median_s.unwrap() - 0.001).abs() < 1e-9);
    }

    #[test]
    fn missing_pdos_and_strangers_are_reported() {
        let text = GOOD.replace("(1.000110) vcan0 183#00000000\n", "(1.000110) vcan0 6E3#01\n");
        let r = check_schedule(&parse_candump(&text), &plan());
        assert_eq!(r.violations.len(), 1, "{:?}", r.violations);
        assert!(r.violations[0].contains("6E3#01 is not in the schedule"));
        assert!(r.count_anomalies.is_empty());
        // A single missing TPDO could still be late: only the stranger is a violation.
        assert_eq!(r.late_tpdos, 1);
    }

    /// Cycles of RPDOs and SYNC; `tpdos[k]` lists the TPDO ids sent after SYNC k.
    fn cycles(tpdos: &[&[u16]]) -> String {
        let mut text = String::new();
        for ids in tpdos {
            text.push_str("202#00000000\n203#00000000\n204#00000000\n080#\n");
            for id in *ids {
                let data = if *id == 0x182 {
                    "0000000000000000"
                } else {
                    "00000000"
                };
                text.push_str(&format!("{id:03X}#{data}\n"));
            }
        }
        text + "202#00000000\n203#00000000\n204#00000000\n080#\n"
    }

    #[test]
    fn a_late_tpdo_is_counted_and_two_missing_are_a_violation() {
        let all: &[u16] = &[0x182, 0x183, 0x184];
        let on_time = check_schedule(&parse_candump(&cycles(&[all, all, all])), &plan());
        assert!(
            on_time.violations.is_empty() && on_time.late_tpdos == 0,
            "{on_time:?}"
        );
        // X's TPDO of SYNC 2 comes after SYNC 3, before its own.
        let late = check_schedule(
            &parse_candump(&cycles(&[all, &[0x182, 0x184], &[0x183, 0x182, 0x183, 0x184]])),
            &plan(),
        );
        assert!(
            late.violations.is_empty() && late.count_anomalies.is_empty(),
            "{late:?}"
        );
        assert_eq!(late.late_tpdos, 1);
        // Two in a row missing is not lateness.
        let lost = check_schedule(
            &parse_candump(&cycles(&[all, &[0x182, 0x184], &[0x182, 0x184]])),
            &plan(),
        );
        assert_eq!(lost.count_anomalies.len(), 1, "{lost:?}");
        assert!(lost.violations.is_empty());
    }

    #[test]
    fn rpdo2_modes_and_homing_start_are_checked() {
        // X (node 3) asked for homing with bit 4, Y (4) in CSP, the table in CSP; TPDO2
        // with statusword and mode display.
        let ok = GOOD.replace(
            "(1.000030) vcan0 080#\n",
            "(1.000021) vcan0 303#061F00\n(1.000022) vcan0 304#080F00\n(1.000023) vcan0 302#080F00\n\
             (1.000024) vcan0 283#371006\n(1.000030) vcan0 080#\n",
        );
        let r = check_schedule(&parse_candump(&ok), &plan());
        assert!(r.violations.is_empty(), "{:?}", r.violations);
        assert_eq!(r.frames, 15);
        for (frame, words) in [
            ("302#060F00", "drive 2 (B) asked for mode 6"),
            ("304#011F00", "drive 4 (Y) asked for mode 1"),
            ("303#081F00", "bit 4 (homing start) to drive 3 in mode 8"),
            ("303#0F00", "303#0F00 is not in the schedule"),
            ("283#3702", "283#3702 is not in the schedule"),
        ] {
            let text = GOOD.replace(
                "(1.000030) vcan0 080#\n",
                &format!("(1.000021) vcan0 {frame}\n(1.000030) vcan0 080#\n"),
            );
            let r = check_schedule(&parse_candump(&text), &plan());
            assert_eq!(r.violations.len(), 1, "{frame}: {:?}", r.violations);
            assert!(r.violations[0].contains(words), "{frame}: {:?}", r.violations);
        }
    }

    /// The table's targets in 2^20 counts per motor turn wrap at 32 bits in the cut: the
    /// law is checked across the wrap as anywhere else, and a wrong ratio is still seen.
    #[test]
    fn the_gearbox_check_follows_the_table_targets_across_the_32_bit_wrap() {
        let plan = plan();
        let (b, x, y) = (plan.drives[0], plan.drives[1], plan.drives[2]);
        let spindle_per_deg = 10_000.0 / 360.0;
        let table_per_deg = 1_048_576.0 * 75.0 / 360.0;
        let frames = |ratio: f64| {
            let start = i64::from(i32::MAX) - 10 * 46_259;
            let mut v = Vec::new();
            for k in 0..100i64 {
                let s = k * 100;
                let t = start + (ratio * s as f64 / spindle_per_deg * table_per_deg).round() as i64;
                let frame = |f: Frame| Captured { t_s: None, frame: f };
                v.push(frame(b.actual.pack(&[0, s as u32 as u64])));
                v.push(frame(x.target.pack(&[(80.0 * 3000.0) as u32 as u64, 0])));
                v.push(frame(y.target.pack(&[(k * 30) as u32 as u64, 0])));
                v.push(frame(b.target.pack(&[t as i32 as u32 as u64, 0])));
            }
            v
        };
        let scales = [spindle_per_deg, table_per_deg, 3000.0, 3000.0];
        let ratio = 1.0 / 17.0;
        let r = check_gearbox(&frames(ratio), &plan, ratio, scales, &[80.0], 20);
        assert!(r.windows >= 3, "{r:?}");
        assert!(r.worst_relative_error < 1e-4, "{r:?}");
        let r = check_gearbox(&frames(1.01 * ratio), &plan, ratio, scales, &[80.0], 20);
        assert!((r.worst_relative_error - 0.01).abs() < 1e-3, "{r:?}");
    }

    #[test]
    fn candump_lines_round_trip() {
        let f = Frame::new(0x182, &[1, 2]);
        let line = candump_line(12.5, "vcan0", &f);
        assert_eq!(line, "(12.500000) vcan0 182#0102");
        assert_eq!(parse_candump(&line)[0].frame, f);
    }
}
