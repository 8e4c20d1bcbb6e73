//! The fuzz targets (issue 18): each takes arbitrary bytes, feeds them to a decoder of outside
//! data and asserts its properties, not just "no panic". libFuzzer drives them from
//! `fuzz/fuzz_targets/` (`cargo +nightly fuzz run TARGET`, `ci/fuzz`); the test command
//! replays `fuzz/corpus/TARGET/` and `fuzz/regressions/TARGET/` through them on stable
//! (`tests/replay.rs`), so a past crash stays fixed.

use hob_canopen::frame::Frame;
use hob_process_image::capture::{check_schedule, parse_candump};
use hob_process_image::master::Cyclic;
use hob_process_image::plan::BusPlan;
use hob_setup::config::Problems;
use hob_setup::config::machine::MachineConfig;
use hob_setup::job::Program;
use hob_setup::planner;
use std::path::Path;
use std::sync::OnceLock;

/// A target: its properties asserted on one input.
pub type Target = fn(&[u8]);

/// The targets, by name (`fuzz/fuzz_targets/NAME.rs`, `fuzz/corpus/NAME/`).
pub const TARGETS: [(&str, Target); 4] = [
    ("candump", candump),
    ("program", program),
    ("machine", machine),
    ("cyclic", cyclic),
];

/// The shipped machine file, the machine the programs are planned on.
fn shipped() -> &'static MachineConfig {
    static M: OnceLock<MachineConfig> = OnceLock::new();
    M.get_or_init(|| {
        let src = include_str!("../../../config/machine.toml");
        MachineConfig::parse(Path::new("config/machine.toml"), src).expect("the shipped machine file")
    })
}

/// A `candump -L` capture (`hob can check-capture`, `hob can dump --file`): every frame it
/// reads writes back to the text it was read from and reads again to itself (decode of
/// encode is the identity); the schedule check over any capture returns a report whose
/// counts add up.
pub fn candump(data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    let frames = parse_candump(&text);
    for c in &frames {
        let line = c.frame.to_candump();
        assert_eq!(Frame::from_candump(&line), Some(c.frame), "{line}");
        assert!(c.frame.len <= 8 && c.frame.id <= 0x7FF);
    }
    let r = check_schedule(&frames, &BusPlan::from_machine(shipped()));
    assert_eq!(r.frames, frames.len());
    assert!(r.syncs <= r.frames && r.cycles_checked <= r.syncs);
}

/// A program file (`hob check`, `hob plan`, the HMI's editor, the library): parsed, checked
/// and planned on the shipped machine. A refusal names at least one problem; an accepted
/// program has passes and finite figures.
pub fn program(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(job) = Program::parse(Path::new("fuzz.toml"), text) else {
        return;
    };
    let mut p = Problems::new();
    match planner::plan(&job, shipped(), &mut p) {
        None => assert!(!p.is_empty(), "refused without a reason"),
        Some(plan) => {
            assert!(p.is_empty());
            assert!(!plan.passes.is_empty(), "accepted with no pass");
            assert!(plan.total_time_s.is_finite() && plan.total_time_s > 0.0);
            for pass in &plan.passes {
                assert!(pass.spindle_rpm.is_finite() && pass.x_mm.is_finite() && pass.cut_time_s.is_finite());
            }
        }
    }
}

/// A machine file (`hob check --machine`, every service at start-up): parsed and validated;
/// an accepted one yields a bus plan.
pub fn machine(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(m) = MachineConfig::parse(Path::new("fuzz-machine.toml"), text) {
        let plan = BusPlan::from_machine(&m);
        assert!(
            plan.nodes().iter().all(|n| (1..=127).contains(n)),
            "{:?}",
            plan.nodes()
        );
    }
}

/// The frames the bus brings into the master's cyclic exchange, any ids, lengths and order,
/// cycles cut anywhere: a byte 0 ends a cycle (`Cyclic::inputs`), any other byte starts a
/// frame `[len % 9] [id lo] [id hi] [data...]`. Each drive's reported position is one a
/// TPDO1 of that drive carried (or the start's 0), and a drive is fresh only in a cycle in
/// which such a frame arrived.
pub fn cyclic(data: &[u8]) {
    let plan = BusPlan::from_machine(shipped());
    let mut c = Cyclic::unbooted(plan);
    let pdo1 = plan.drives.map(|d| d.actual);
    let mut carried: [Vec<i32>; 3] = [vec![0], vec![0], vec![0]];
    let mut arrived = [false; 3];
    let mut i = 0;
    while i < data.len() {
        let op = data[i];
        i += 1;
        if op == 0 {
            let inp = c.inputs();
            for (k, fb) in [inp.table, inp.x, inp.y].iter().enumerate() {
                assert!(
                    carried[k].contains(&fb.position_counts),
                    "drive {k} reports {} that no TPDO carried",
                    fb.position_counts
                );
                assert!(
                    !fb.fresh || arrived[k],
                    "drive {k} fresh without a TPDO this cycle"
                );
            }
            arrived = [false; 3];
            continue;
        }
        let len = usize::from(op % 9);
        let Some(head) = data.get(i..i + 2) else { break };
        let id = u16::from_le_bytes([head[0], head[1]]) & 0x7FF;
        i += 2;
        let end = (i + len).min(data.len());
        let f = Frame::new(id, &data[i..end]);
        i = end;
        for (k, p) in pdo1.iter().enumerate() {
            if p.unpack(&f).is_some() {
                let b = f.payload();
                carried[k].push(i32::from_le_bytes([b[0], b[1], b[2], b[3]]));
                arrived[k] = true;
            }
        }
        c.receive(&f);
    }
}
