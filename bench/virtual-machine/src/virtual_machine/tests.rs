//! The virtual machine as a late-scheduled process sees the bus: several SYNCs read at once.
#![allow(clippy::unwrap_used)]

use super::*;
use hob_canopen::frame::{NMT, SYNC};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A virtual machine with every node operational and TPDO1 sent on every SYNC.
fn operational_vm() -> VirtualMachine {
    let m = hob_store::files::load_machine(&root().join("config/machine.toml")).unwrap();
    let p = PlantConfig::load(&root().join("config/plant.toml")).unwrap();
    let start = Start {
        x_mm: 150.0,
        y_mm: 150.0,
        table_deg: 0.0,
    };
    let mut vm = VirtualMachine::new(&m, &p, start, 10);
    for n in vm.nodes_mut() {
        n.od.put(0x1800, 2, 1);
    }
    let mut out = Vec::new();
    vm.on_frame(&Frame::new(NMT, &[0x01, 0]), &mut out);
    assert!(vm.any_operational());
    vm
}

fn pdos(out: &[Frame]) -> Vec<u16> {
    out.iter()
        .map(|f| f.id)
        .filter(|id| (0x180..0x500).contains(id))
        .collect()
}

#[test]
fn of_several_syncs_read_at_once_only_the_last_is_answered() {
    let mut vm = operational_vm();
    let mut out = Vec::new();
    vm.on_frames(&[Frame::new(SYNC, &[])], &mut out);
    let one = pdos(&out);
    assert_eq!(one.len(), 4, "one TPDO1 per node: {one:x?}");
    assert_eq!(vm.superseded_syncs(), 0);

    out.clear();
    let t0 = vm.time_s();
    let sync = Frame::new(SYNC, &[]);
    vm.on_frames(&[sync, sync, sync], &mut out);
    assert_eq!(pdos(&out), one, "the answers of the last SYNC only");
    assert_eq!(vm.superseded_syncs(), 2);
    assert_eq!(vm.syncs(), 4, "every SYNC latched");
    vm.settle();
    let period_s = vm.period_s;
    // Three periods, each SYNC at its nominal instant plus the plant's jitter (+-20 us as
    // shipped): the two ends differ by at most twice it.
    let computed = vm.time_s() - t0;
    assert!(
        (computed - 3.0 * period_s).abs() <= 40e-6 + 1e-12 && computed > 2.9 * period_s,
        "three periods computed: {computed} s"
    );
}

#[test]
fn a_batch_without_a_later_sync_is_answered_in_full() {
    let mut vm = operational_vm();
    let mut out = Vec::new();
    // A target, then the SYNC, then a frame after it: the SYNC is the last one.
    let after = Frame::new(0x700 + 5, &[0x05]);
    vm.on_frames(&[Frame::new(SYNC, &[]), after], &mut out);
    assert_eq!(pdos(&out).len(), 4);
    assert_eq!(vm.superseded_syncs(), 0);
    // The next single SYNC is answered as well: nothing carries over.
    out.clear();
    vm.on_frames(&[Frame::new(SYNC, &[])], &mut out);
    assert_eq!(pdos(&out).len(), 4);
}

/// A bus on which the frames of each step arrive while the simulator works on the last.
struct Scripted {
    steps: std::collections::VecDeque<Vec<Frame>>,
    waiting: std::collections::VecDeque<Frame>,
    sent: Vec<Frame>,
}

impl hob_canopen::bus::CanBus for Scripted {
    fn send(&mut self, f: &Frame) -> Result<(), hob_canopen::bus::BusError> {
        self.sent.push(*f);
        Ok(())
    }

    fn try_recv(&mut self) -> Result<Option<Frame>, hob_canopen::bus::BusError> {
        if let Some(f) = self.waiting.pop_front() {
            return Ok(Some(f));
        }
        // The queue ran dry: the next step's frames arrive (after this read).
        if let Some(next) = self.steps.pop_front() {
            self.waiting.extend(next);
        }
        Ok(None)
    }

    fn wait_for_frame(&mut self, timeout: std::time::Duration) {
        std::thread::sleep(timeout.min(std::time::Duration::from_micros(50)));
    }
}

#[test]
fn an_answer_overtaken_by_the_next_sync_is_withdrawn() {
    let mut vm = operational_vm();
    let sync = Frame::new(SYNC, &[]);
    let mut bus = Scripted {
        steps: [vec![sync], vec![]].into(),
        waiting: [sync].into(),
        sent: Vec::new(),
    };
    let (mut batch, mut out) = (Vec::new(), Vec::new());
    let read = crate::runner::serve_waiting(&mut vm, &mut bus, &mut batch, &mut out).unwrap();
    assert_eq!(read, 2);
    assert_eq!(vm.syncs(), 2);
    assert_eq!(vm.superseded_syncs(), 1);
    assert_eq!(
        pdos(&bus.sent).len(),
        4,
        "only the second SYNC answered: {:x?}",
        bus.sent
    );

    // On time: every SYNC answered.
    bus.waiting.push_back(sync);
    bus.steps = [vec![], vec![]].into();
    bus.sent.clear();
    crate::runner::serve_waiting(&mut vm, &mut bus, &mut batch, &mut out).unwrap();
    assert_eq!(pdos(&bus.sent).len(), 4);
    assert_eq!(vm.superseded_syncs(), 1);
}

/// Drive B's statusword on an event-driven TPDO, as the master configures TPDO2.
fn statusword_on_change(vm: &mut VirtualMachine) -> (u16, u16) {
    let d = &mut vm.drives[0];
    d.od.put(0x1800, 2, 255);
    (0x180 + u16::from(d.id), 0x200 + u16::from(d.id))
}

#[test]
fn a_changed_statusword_goes_out_even_when_its_sync_is_superseded() {
    let mut vm = operational_vm();
    let (status_cob, control_cob) = statusword_on_change(&mut vm);
    let mut out = Vec::new();
    vm.on_frames(&[Frame::new(SYNC, &[])], &mut out);
    out.clear();
    // "Shutdown" (0x0006), then two SYNCs read at once: the first one's synchronous
    // answers are withheld, the statusword's change is not.
    let sync = Frame::new(SYNC, &[]);
    vm.on_frames(&[Frame::new(control_cob, &[0x06, 0x00]), sync, sync], &mut out);
    assert_eq!(vm.drive_state(Axis::B), PowerState::ReadyToSwitchOn);
    let status: Vec<&Frame> = out.iter().filter(|f| f.id == status_cob).collect();
    assert_eq!(status.len(), 1, "the change reported once: {out:x?}");
    assert_eq!(
        status[0].payload(),
        PowerState::ReadyToSwitchOn.statusword().to_le_bytes()
    );
    assert_eq!(
        pdos(&out).len(),
        4,
        "3 synchronous answers of the last SYNC and the change"
    );
}

#[test]
fn withdrawing_an_answer_keeps_the_event_driven_tpdos() {
    let mut vm = operational_vm();
    let (status_cob, _) = statusword_on_change(&mut vm);
    let status = Frame::new(status_cob, &[0x21, 0x02]);
    let answer = Frame::new(0x181 + 2, &[0; 4]);
    let heartbeat = Frame::new(0x700 + 5, &[0x05]);
    let mut out = vec![status, answer, heartbeat];
    vm.withdraw_answer(&mut out);
    assert_eq!(out, vec![status, heartbeat]);
    assert_eq!(vm.superseded_syncs(), 1);
}
