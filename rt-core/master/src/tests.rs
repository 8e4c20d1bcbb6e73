//! Which SYNC a drive's TPDO answers: counted (SYNCs owed) or heard (own SYNC echoed in
//! bus order), and what the control core is told about it.

use super::*;
use hob_can_transport::{MemoryBus, SystemClock};
use hob_control::{CycleOutputs, DriveMode};
use hob_setup::config::machine::shipped_for_tests;

/// A master on one end of an in-memory bus, the drives' side on the other.
fn master(echo: bool) -> (Cyclic, MemoryBus, MemoryBus) {
    let plan = BusPlan::from_machine(&shipped_for_tests());
    let mut m = Cyclic::new(plan);
    let mut ours = MemoryBus::new(4096);
    let nodes = ours.endpoint();
    if echo {
        assert!(m.hear_own_sync(&mut ours));
    }
    (m, ours, nodes)
}

/// Every drive answers with `position` (the spindle counts the same).
fn answer(m: &Cyclic, nodes: &mut MemoryBus, position: i32) {
    for d in m.plan().drives {
        let f = d.actual.pack(&[position as u32 as u64, position as u32 as u64]);
        nodes.send(&f).unwrap();
    }
}

/// The first half of the master's cycle: drain, inputs.
fn drain(m: &mut Cyclic, ours: &mut MemoryBus) -> CycleInputs {
    while let Some(f) = ours.try_recv().unwrap() {
        m.receive(&f);
    }
    m.inputs()
}

/// One cycle of the master: drain, inputs, transmit (targets, then SYNC).
fn cycle(m: &mut Cyclic, ours: &mut MemoryBus) -> CycleInputs {
    let inputs = drain(m, ours);
    m.transmit(&CycleOutputs::default(), ours).unwrap();
    inputs
}

/// The drives' side reads what the master sent; true if a SYNC was among it.
fn heard_sync(nodes: &mut MemoryBus) -> bool {
    let mut sync = false;
    while let Some(f) = nodes.try_recv().unwrap() {
        sync |= f.id == SYNC;
    }
    sync
}

#[test]
fn answers_before_the_next_cycle_are_current_either_way() {
    for echo in [false, true] {
        let (mut m, mut ours, mut nodes) = master(echo);
        cycle(&mut m, &mut ours);
        for k in 1..50 {
            assert!(heard_sync(&mut nodes));
            answer(&m, &mut nodes, k);
            let i = cycle(&mut m, &mut ours);
            assert!(i.table.fresh && i.x.fresh && i.y.fresh, "echo {echo}, cycle {k}");
            assert_eq!(i.table.position_counts, k);
            assert_eq!(i.spindle_counts, k);
        }
    }
}

/// A node whose answers come every cycle just after the master has read its inputs (a
/// slow drive, or a simulated machine on an emulated CPU), before the next SYNC: counting
/// forgives the steady lag after two cycles and takes the previous SYNC's values for this
/// cycle's (one period of motion wrong); hearing the SYNCs never does.
#[test]
fn a_node_one_cycle_late_is_never_current_when_the_syncs_are_heard() {
    for echo in [false, true] {
        let (mut m, mut ours, mut nodes) = master(echo);
        cycle(&mut m, &mut ours);
        let mut current = 0;
        for k in 1..50 {
            let i = drain(&mut m, &mut ours);
            if i.table.fresh {
                current += 1;
                // Taken as this cycle's: it answers the SYNC before the last one.
                assert_eq!(i.table.position_counts, k - 1);
            }
            // The answer to the last SYNC arrives now, before the next SYNC goes out.
            assert!(heard_sync(&mut nodes));
            answer(&m, &mut nodes, k);
            m.transmit(&CycleOutputs::default(), &mut ours).unwrap();
        }
        if echo {
            assert_eq!(current, 0, "a late answer was taken for this cycle's");
        } else {
            assert!(current > 40, "counting forgives a steady lag ({current})");
        }
    }
}

#[test]
fn a_lost_answer_costs_one_cycle_when_the_syncs_are_heard() {
    let (mut m, mut ours, mut nodes) = master(true);
    cycle(&mut m, &mut ours);
    let mut fresh = Vec::new();
    for k in 1..20 {
        assert!(heard_sync(&mut nodes));
        if k != 7 {
            answer(&m, &mut nodes, k);
        }
        fresh.push(cycle(&mut m, &mut ours).table.fresh);
    }
    let missed: Vec<usize> = fresh
        .iter()
        .enumerate()
        .filter(|(_, f)| !**f)
        .map(|(i, _)| i + 1)
        .collect();
    assert_eq!(missed, vec![7]);
}

#[test]
fn a_burst_of_late_answers_is_not_current_until_the_last_sync_is_answered() {
    let (mut m, mut ours, mut nodes) = master(true);
    cycle(&mut m, &mut ours);
    assert!(heard_sync(&mut nodes));
    answer(&m, &mut nodes, 1);
    assert!(cycle(&mut m, &mut ours).table.fresh);
    // SYNC 2 and 3 go out unanswered; then both answers arrive after SYNC 3.
    assert!(heard_sync(&mut nodes));
    assert!(!cycle(&mut m, &mut ours).table.fresh);
    assert!(heard_sync(&mut nodes));
    answer(&m, &mut nodes, 2);
    answer(&m, &mut nodes, 3);
    let i = cycle(&mut m, &mut ours);
    assert!(i.table.fresh);
    assert_eq!(i.table.position_counts, 3);
}

/// Runs a master with cycle period `period_us` whose nodes (and the I/O coupler's inputs)
/// were heard once, then fall silent. Returns the heartbeat timeout (ms), the cycles after
/// which each `HeartbeatLost` fired (with its node) and the first cycle the I/O inputs
/// were no longer valid.
fn silence(period_us: u32) -> (u32, Vec<(u32, u8)>, Option<u32>) {
    let mut plan = BusPlan::from_machine(&shipped_for_tests());
    plan.cycle_s = f64::from(period_us) * 1e-6;
    let timeout_ms = u32::from(plan.heartbeat_timeout_ms);
    let mut m = Cyclic::new(plan);
    for node in plan.nodes() {
        m.receive(&NmtState::Operational.heartbeat(node));
    }
    m.receive(&plan.io.inputs.pack(&[0, 0, 0]));
    let mut lost = Vec::new();
    let mut io_invalid = None;
    let mut events = [None; BUS_EVENTS];
    let cycles = 4 * timeout_ms * 1000 / period_us;
    for k in 1..=cycles {
        if !m.inputs().io_valid && io_invalid.is_none() {
            io_invalid = Some(k);
        }
        let n = m.take_events(&mut events);
        for e in events[..n].iter().flatten() {
            if let BusEvent::HeartbeatLost { node } = e {
                lost.push((k, *node));
            }
        }
    }
    (timeout_ms, lost, io_invalid)
}

/// Heartbeat loss fires once per node, at the first cycle whose silence (the cycles since
/// the heartbeat's own cycle) reaches the timeout: also for a period that does not divide
/// the timeout (1.5 ms into 250 ms), where comparing floats never matched.
#[test]
fn heartbeat_loss_fires_once_at_the_timeout_for_any_period() {
    for period_us in [1000u32, 1500, 2000, 3000, 700] {
        let (timeout_ms, lost, io_invalid) = silence(period_us);
        // The first cycle k whose silence (k - 1 periods) reaches the timeout.
        let expected = (1..)
            .find(|k| (k - 1) * period_us >= timeout_ms * 1000)
            .unwrap_or(0);
        let plan = BusPlan::from_machine(&shipped_for_tests());
        let want: Vec<(u32, u8)> = plan.nodes().iter().map(|n| (expected, *n)).collect();
        assert_eq!(lost, want, "period {period_us} us, timeout {timeout_ms} ms");
        assert_eq!(
            io_invalid,
            Some(expected),
            "period {period_us} us: I/O invalid with the loss"
        );
    }
}

/// A bus that takes `accept` frames, answers with `replies` and then refuses every send.
#[derive(Debug)]
struct RefusingBus {
    accept: usize,
    replies: std::collections::VecDeque<Frame>,
}

impl CanBus for RefusingBus {
    fn send(&mut self, _: &Frame) -> Result<(), BusError> {
        if self.accept == 0 {
            return Err(BusError::Down);
        }
        self.accept -= 1;
        Ok(())
    }

    fn try_recv(&mut self) -> Result<Option<Frame>, BusError> {
        Ok(self.replies.pop_front())
    }

    fn wait_for_frame(&mut self, _: Duration) {}
}

/// A request the bus refused is not a timeout: the error names the bus's reason and the
/// object, for the first request and for a later segment alike.
#[test]
fn a_refused_sdo_request_reports_the_bus_error_and_the_object() {
    let t = Duration::from_millis(20);
    let mut bus = RefusingBus {
        accept: 0,
        replies: Default::default(),
    };
    let e = sdo_read(&mut bus, &mut SystemClock::new(), 2, 0x1008, 0, t).unwrap_err();
    let text = e.to_string();
    assert!(
        text.contains("1008:00") && text.contains("interface down"),
        "{text}"
    );
    // A segmented download: the initiate goes out and is answered, the first segment is refused.
    let mut bus = RefusingBus {
        accept: 1,
        replies: [Frame::new(0x584, &[0x60, 0x00, 0x20, 0x00, 0, 0, 0, 0])].into(),
    };
    let e = sdo_write(
        &mut bus,
        &mut SystemClock::new(),
        4,
        0x2000,
        0,
        b"Y axis, hob head",
        t,
    )
    .unwrap_err();
    let text = e.to_string();
    assert!(
        text.contains("2000:00") && text.contains("interface down"),
        "{text}"
    );
}

// ---------------------------------------------------------------------------------------
// Homing (issue 14): the boot's checks and SDO writes, RPDO2 and TPDO2 in the cycle.

#[global_allocator]
static ALLOCATOR: hob_rt_os::alloc_guard::CountingAllocator = hob_rt_os::alloc_guard::CountingAllocator;

/// One scripted node: an object dictionary of raw bytes, every SDO write recorded.
#[derive(Debug)]
struct FakeNode {
    id: u8,
    od: std::collections::BTreeMap<(u16, u8), Vec<u8>>,
    /// Writing 0x6060 changes 0x6061 (false: the drive keeps displaying what it had).
    takes_mode: bool,
    /// The drive keeps 0x60F9:02 in whole ms (a drive of other units than the plan's).
    coarse_integral_time: bool,
    sdo: hob_canopen::sdo::SdoServer,
}

/// The dictionary side of a [`FakeNode`] during one request.
#[derive(Debug)]
struct FakeOd<'a> {
    node: u8,
    od: &'a mut std::collections::BTreeMap<(u16, u8), Vec<u8>>,
    takes_mode: bool,
    coarse_integral_time: bool,
    log: &'a mut Vec<(u8, u16, u8, Vec<u8>)>,
}

impl hob_canopen::sdo::ObjectDictionary for FakeOd<'_> {
    fn read(&mut self, index: u16, sub: u8) -> Result<Vec<u8>, AbortCode> {
        self.log.push((self.node, index, sub, Vec::new()));
        self.od.get(&(index, sub)).cloned().ok_or(AbortCode::NO_OBJECT)
    }

    fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        self.log.push((self.node, index, sub, data.to_vec()));
        let mut data = data.to_vec();
        if (index, sub) == (object::VELOCITY_CONTROL_PARAMETERS, 2) && self.coarse_integral_time {
            let us = u32::from_le_bytes(data[..4].try_into().unwrap_or([0; 4]));
            data = (us / 1000 * 1000).to_le_bytes().to_vec();
        }
        self.od.insert((index, sub), data.clone());
        if index == object::MODES_OF_OPERATION && self.takes_mode {
            self.od.insert((object::MODES_DISPLAY, 0), data.to_vec());
        }
        Ok(())
    }
}

/// The nodes of the shipped plan answering at once, in the sender's thread: NMT reset ->
/// boot-up, NMT start -> operational heartbeat, SDO from each node's dictionary. Reads are
/// logged with empty data, writes with theirs.
#[derive(Debug)]
struct FakeBus {
    nodes: Vec<FakeNode>,
    queue: std::collections::VecDeque<Frame>,
    log: Vec<(u8, u16, u8, Vec<u8>)>,
}

impl FakeBus {
    /// Drives B, X, Y announcing `modes` (0x6502) each, and the I/O coupler.
    fn new(plan: &BusPlan, modes: [u32; 3]) -> Self {
        let mut nodes = Vec::new();
        for (d, supported) in plan.drives.iter().zip(modes) {
            let mut od = std::collections::BTreeMap::new();
            od.insert((0x1000, 0), (0x0002_0000 | PROFILE_DRIVE).to_le_bytes().to_vec());
            od.insert((object::SUPPORTED_MODES, 0), supported.to_le_bytes().to_vec());
            od.insert((object::MODES_DISPLAY, 0), vec![0]);
            nodes.push(FakeNode {
                id: d.node,
                od,
                takes_mode: true,
                coarse_integral_time: false,
                sdo: hob_canopen::sdo::SdoServer::new(d.node),
            });
        }
        let mut od = std::collections::BTreeMap::new();
        od.insert((0x1000, 0), PROFILE_IO.to_le_bytes().to_vec());
        nodes.push(FakeNode {
            id: plan.io.node,
            od,
            takes_mode: false,
            coarse_integral_time: false,
            sdo: hob_canopen::sdo::SdoServer::new(plan.io.node),
        });
        Self {
            nodes,
            queue: Default::default(),
            log: Vec::new(),
        }
    }

    /// The data written to `node`'s `index:sub`, in order.
    fn written(&self, node: u8, index: u16, sub: u8) -> Vec<Vec<u8>> {
        self.log
            .iter()
            .filter(|(n, i, s, d)| (*n, *i, *s) == (node, index, sub) && !d.is_empty())
            .map(|e| e.3.clone())
            .collect()
    }
}

impl CanBus for FakeBus {
    fn send(&mut self, f: &Frame) -> Result<(), BusError> {
        if let Some((cmd, target)) = NmtCommand::parse(f) {
            for n in self.nodes.iter().filter(|n| target == 0 || target == n.id) {
                let state = match cmd {
                    NmtCommand::Start => NmtState::Operational,
                    _ => NmtState::BootUp,
                };
                self.queue.push_back(state.heartbeat(n.id));
            }
            return Ok(());
        }
        if let Cob::SdoRx(id) = Cob::of(f.id)
            && let Some(n) = self.nodes.iter_mut().find(|n| n.id == id)
        {
            let mut od = FakeOd {
                node: id,
                od: &mut n.od,
                takes_mode: n.takes_mode,
                coarse_integral_time: n.coarse_integral_time,
                log: &mut self.log,
            };
            if let Some(r) = n.sdo.on_request(f, &mut od) {
                self.queue.push_back(r);
            }
        }
        Ok(())
    }

    fn try_recv(&mut self) -> Result<Option<Frame>, BusError> {
        Ok(self.queue.pop_front())
    }

    fn wait_for_frame(&mut self, _: Duration) {}
}

/// 0x6502 announcing CSP only, and CSP with homing.
const CSP_ONLY: u32 = 1 << 7;
const CSP_AND_HOMING: u32 = 1 << 7 | 1 << 5;

#[test]
fn boot_writes_the_homing_parameters_in_counts_and_confirms_csp() {
    let m = shipped_for_tests();
    let plan = BusPlan::from_machine(&m);
    // The table needs only CSP.
    let mut bus = FakeBus::new(&plan, [CSP_ONLY, CSP_AND_HOMING, CSP_AND_HOMING]);
    let booted = boot(
        &plan,
        &mut bus,
        &mut SystemClock::new(),
        Duration::from_millis(50),
    )
    .expect("boots");
    assert_eq!(booted.nodes.len(), 4);
    // Shipped X and Y: 3000 counts/mm, normal polarity, method 3, home at 240 and 440 mm,
    // 600 and 60 mm/min, 50 mm/s^2.
    for (node, home) in [(m.x.can_node_id, 720_000i32), (m.y.can_node_id, 1_320_000)] {
        assert_eq!(bus.written(node, 0x6098, 0), [vec![3]]);
        assert_eq!(bus.written(node, 0x6099, 1), [30_000u32.to_le_bytes().to_vec()]);
        assert_eq!(bus.written(node, 0x6099, 2), [3_000u32.to_le_bytes().to_vec()]);
        assert_eq!(bus.written(node, 0x609A, 0), [150_000u32.to_le_bytes().to_vec()]);
        assert_eq!(bus.written(node, 0x607C, 0), [home.to_le_bytes().to_vec()]);
    }
    let b = m.table.can_node_id;
    assert!(
        bus.log
            .iter()
            .all(|(n, i, ..)| *n != b || ![0x6098, 0x6099, 0x609A, 0x607C].contains(i)),
        "the table is not homed"
    );
    // Every drive: 0x6060 = 8 written, then 0x6061 read back (before the NMT start).
    for d in plan.drives {
        let at = |index: u16, write: bool| {
            bus.log
                .iter()
                .position(|(n, i, _, data)| *n == d.node && *i == index && data.is_empty() != write)
        };
        let (written, read) = (at(0x6060, true), at(0x6061, false));
        assert!(
            written.is_some() && read > written,
            "node {}: {:?}",
            d.node,
            bus.log
        );
        assert_eq!(bus.written(d.node, 0x6060, 0), [vec![8]]);
    }
}

#[test]
fn boot_mirrors_the_method_and_the_home_offset_of_an_inverted_axis() {
    let mut m = shipped_for_tests();
    m.y.polarity = hob_setup::config::machine::Polarity::Inverted;
    m.y.homing.method = 4;
    let plan = BusPlan::from_machine(&m);
    let mut bus = FakeBus::new(&plan, [CSP_AND_HOMING; 3]);
    boot(
        &plan,
        &mut bus,
        &mut SystemClock::new(),
        Duration::from_millis(50),
    )
    .expect("boots");
    let y = m.y.can_node_id;
    // The switch on the machine's positive side is on the inverted drive's negative side.
    assert_eq!(bus.written(y, 0x6098, 0), [vec![6]]);
    assert_eq!(
        bus.written(y, 0x607C, 0),
        [(-1_320_000i32).to_le_bytes().to_vec()]
    );
    assert_eq!(bus.written(y, 0x6099, 1), [30_000u32.to_le_bytes().to_vec()]);
    assert_eq!(bus.written(m.x.can_node_id, 0x6098, 0), [vec![3]]);
}

#[test]
fn boot_refuses_an_axis_drive_without_homing_naming_node_and_mode() {
    let m = shipped_for_tests();
    let plan = BusPlan::from_machine(&m);
    let mut bus = FakeBus::new(&plan, [CSP_AND_HOMING, CSP_ONLY, CSP_AND_HOMING]);
    let e = boot(
        &plan,
        &mut bus,
        &mut SystemClock::new(),
        Duration::from_millis(50),
    )
    .unwrap_err();
    assert_eq!(
        e,
        BootError::NoHoming {
            node: m.x.can_node_id,
            supported_modes: CSP_ONLY
        }
    );
    let text = e.to_string();
    assert!(
        text.contains("drive 3") && text.contains("homing mode (6)") && text.contains("0x00000080"),
        "{text}"
    );
    // Refused before anything was written to it.
    assert!(bus.written(m.x.can_node_id, 0x6098, 0).is_empty());
    // Without CSP the refusal names CSP, as before (also on the table).
    let mut bus = FakeBus::new(&plan, [1 << 5, CSP_AND_HOMING, CSP_AND_HOMING]);
    let e = boot(
        &plan,
        &mut bus,
        &mut SystemClock::new(),
        Duration::from_millis(50),
    )
    .unwrap_err();
    assert!(matches!(e, BootError::NoCsp { node: 2, .. }), "{e:?}");
}

#[test]
fn boot_refuses_a_drive_that_does_not_display_csp() {
    let m = shipped_for_tests();
    let plan = BusPlan::from_machine(&m);
    let mut bus = FakeBus::new(&plan, [CSP_AND_HOMING; 3]);
    bus.nodes[2].takes_mode = false;
    let e = boot(
        &plan,
        &mut bus,
        &mut SystemClock::new(),
        Duration::from_millis(20),
    )
    .unwrap_err();
    assert_eq!(
        e,
        BootError::ModeNotTaken {
            node: m.y.can_node_id,
            display: 0
        }
    );
    assert!(e.to_string().contains("0x6061 displays 0"), "{e}");
}

/// Every drive reports "operation enabled" in `mode` with `extra` statusword bits.
fn status(m: &mut Cyclic, mode: i8, extra: u16) {
    for d in m.plan().drives {
        let sw = PowerState::OperationEnabled.statusword() | extra;
        m.receive(&d.status.pack(&[u64::from(sw), u64::from(mode as u8)]));
    }
}

/// The RPDO2 payloads the drives received since the last call, per drive (B, X, Y).
fn rpdo2(m: &Cyclic, nodes: &mut MemoryBus) -> [Vec<Vec<u8>>; 3] {
    let mut out: [Vec<Vec<u8>>; 3] = Default::default();
    while let Some(f) = nodes.try_recv().unwrap() {
        if let Some(i) = m.plan().drives.iter().position(|d| d.control.cob_id == f.id) {
            out[i].push(f.payload().to_vec());
        }
    }
    out
}

#[test]
fn rpdo2_carries_the_mode_and_bit_4_only_for_a_drive_asked_for_homing() {
    let (mut m, mut ours, mut nodes) = master(false);
    let spacing = usize::from(m.plan().event_rpdo_spacing_ms); // 1 ms cycles
    status(&mut m, 8, 0);
    let mut out = CycleOutputs {
        drives_enabled: true,
        ..CycleOutputs::default()
    };
    // The enabling logic in CSP is unchanged: "enable operation" in mode 8 at once.
    m.transmit(&out, &mut ours).unwrap();
    let sent = rpdo2(&m, &mut nodes);
    assert_eq!(
        sent,
        [
            [vec![8, 0x0F, 0x00]],
            [vec![8, 0x0F, 0x00]],
            [vec![8, 0x0F, 0x00]]
        ]
    );
    // The loop asks X for homing and holds bit 4 for X and Y; Y stays in CSP, and the
    // table stays in CSP whatever it is asked.
    out.drive_modes = [DriveMode::Homing, DriveMode::Homing, DriveMode::CyclicPosition];
    out.homing_start = [true, true, true];
    let mut when = Vec::new();
    for k in 1..=3 * spacing {
        m.transmit(&out, &mut ours).unwrap();
        let sent = rpdo2(&m, &mut nodes);
        assert!(sent[0].is_empty() && sent[2].is_empty(), "{sent:?}");
        for p in &sent[1] {
            when.push((k, p.clone()));
        }
    }
    // At the spacing after the last RPDO2: mode 6, controlword 0x001F.
    assert_eq!(when, [(spacing, vec![6, 0x1F, 0x00])]);
    // Back to CSP (the spacing has long passed: at once); bit 4 goes with the homing mode.
    out.drive_modes[1] = DriveMode::CyclicPosition;
    m.transmit(&out, &mut ours).unwrap();
    assert_eq!(rpdo2(&m, &mut nodes)[1], [vec![8, 0x0F, 0x00]]);
    // Homing again right after: the mode change waits for the spacing.
    out.drive_modes[1] = DriveMode::Homing;
    let mut when = Vec::new();
    for k in 1..=spacing {
        m.transmit(&out, &mut ours).unwrap();
        when.extend(rpdo2(&m, &mut nodes)[1].iter().map(|p| (k, p.clone())));
    }
    assert_eq!(when, [(spacing, vec![6, 0x1F, 0x00])]);
    // In homing mode a stop goes at once and without bit 4.
    out.drives_enabled = false;
    m.transmit(&out, &mut ours).unwrap();
    let sent = rpdo2(&m, &mut nodes);
    assert_eq!(sent[1], [vec![6, 0x00, 0x00]]);
    assert_eq!(sent[0], [vec![8, 0x00, 0x00]]);
}

#[test]
fn bit_4_waits_for_operation_enabled() {
    let (mut m, mut ours, mut nodes) = master(false);
    // X in "switched on": the next step is "enable operation", sent with bit 4.
    let x = m.plan().drives[1];
    let sw = PowerState::SwitchedOn.statusword();
    m.receive(&x.status.pack(&[u64::from(sw), 6]));
    let mut out = CycleOutputs {
        drives_enabled: true,
        ..CycleOutputs::default()
    };
    out.drive_modes[1] = DriveMode::Homing;
    out.homing_start[1] = true;
    m.transmit(&out, &mut ours).unwrap();
    assert_eq!(rpdo2(&m, &mut nodes)[1], [vec![6, 0x1F, 0x00]]);
    // In "ready to switch on" the step is "switch on", without bit 4.
    let (mut m, mut ours, mut nodes) = master(false);
    let sw = PowerState::ReadyToSwitchOn.statusword();
    m.receive(&x.status.pack(&[u64::from(sw), 6]));
    m.transmit(&out, &mut ours).unwrap();
    assert_eq!(rpdo2(&m, &mut nodes)[1], [vec![6, 0x07, 0x00]]);
}

#[test]
fn tpdo2_gives_the_mode_display_and_the_homing_bits() {
    let (mut m, mut ours, mut nodes) = master(false);
    // Before any TPDO2: what the boot read back.
    let i = cycle(&mut m, &mut ours);
    assert_eq!([i.table.mode_display, i.x.mode_display, i.y.mode_display], [8; 3]);
    assert!(heard_sync(&mut nodes));
    let [b, x, y] = m.plan().drives;
    let enabled = PowerState::OperationEnabled.statusword();
    use hob_canopen::cia402::{SW_HOMING_ATTAINED, SW_HOMING_ERROR, SW_TARGET_REACHED};
    nodes
        .send(
            &x.status
                .pack(&[u64::from(enabled | SW_HOMING_ATTAINED | SW_TARGET_REACHED), 6]),
        )
        .unwrap();
    nodes
        .send(&y.status.pack(&[u64::from(enabled | SW_HOMING_ERROR), 6]))
        .unwrap();
    nodes.send(&b.status.pack(&[u64::from(enabled), 8])).unwrap();
    let i = cycle(&mut m, &mut ours);
    assert_eq!(
        (i.x.mode_display, i.y.mode_display, i.table.mode_display),
        (6, 6, 8)
    );
    assert!(i.x.enabled && i.y.enabled && i.table.enabled);
    assert_eq!(
        i.x.homing,
        hob_control::HomingBits {
            attained: true,
            error: false,
            target_reached: true
        }
    );
    assert_eq!(
        i.y.homing,
        hob_control::HomingBits {
            attained: false,
            error: true,
            target_reached: false
        }
    );
    // A display the loop does not know is passed on as it is (the loop waits for 6 or 8).
    nodes.send(&x.status.pack(&[u64::from(enabled), 0xFF])).unwrap();
    assert_eq!(cycle(&mut m, &mut ours).x.mode_display, -1);
    // A statusword-only TPDO2 (the old 2-byte layout) is not this plan's: ignored.
    nodes.send(&Frame::new(x.status.cob_id, &[0x50, 0x02])).unwrap();
    let i = cycle(&mut m, &mut ours);
    assert_eq!((i.x.mode_display, i.x.enabled), (-1, true));
}

#[test]
fn the_cycle_with_mode_changes_and_homing_allocates_nothing() {
    use hob_rt_os::alloc_guard;
    let (mut m, mut ours, mut nodes) = master(true);
    let [_, x, _] = m.plan().drives;
    let mut out = CycleOutputs {
        drives_enabled: true,
        ..CycleOutputs::default()
    };
    let _ = Box::new(0u8); // the allocator notes it is installed
    let (mut system, mut pool) = (0, 0);
    for k in 0..400u32 {
        // The drives' side (not counted): positions, and X's status in the mode asked.
        answer(&m, &mut nodes, k as i32);
        let mode = out.drive_modes[1].code();
        let extra = if k % 50 == 0 {
            hob_canopen::cia402::SW_HOMING_ATTAINED
        } else {
            0
        };
        let sw = PowerState::OperationEnabled.statusword() | extra;
        nodes
            .send(&x.status.pack(&[u64::from(sw), u64::from(mode as u8)]))
            .unwrap();
        while nodes.try_recv().unwrap().is_some() {}
        out.drive_modes[1] = if (k / 100) % 2 == 1 {
            DriveMode::Homing
        } else {
            DriveMode::CyclicPosition
        };
        out.homing_start[1] = k % 100 > 60;
        let (s0, p0) = alloc_guard::counts().expect("installed");
        alloc_guard::in_cycle(true);
        let inputs = drain(&mut m, &mut ours);
        m.transmit(&out, &mut ours).unwrap();
        alloc_guard::in_cycle(false);
        let (s1, p1) = alloc_guard::counts().expect("installed");
        system += s1 - s0;
        pool += p1 - p0;
        if k > 2 {
            assert_eq!(inputs.x.mode_display, mode, "cycle {k}");
        }
    }
    assert_eq!((system, pool), (0, 0), "heap operations in 400 cycles");
}

/// A burst of late or lost TPDOs is a few counted reports, not an event per cycle: the
/// first miss after a quiet second at once, the rest at most once a second, the miss that
/// reaches the fault count at once; the reports' counts add up to every miss.
#[test]
fn missing_tpdos_are_reported_counted_at_most_once_a_second() {
    let (mut m, mut ours, mut nodes) = master(true);
    let table = m.plan().drives[0];
    let to_fault = m.plan().tpdo_misses_to_fault;
    assert!(to_fault >= 2, "{to_fault}");
    // The first cycle has no answers yet (each drive's miss reported at once). Then the
    // table drive's answer missing: every other cycle in 1100..2100 (500), a run of the
    // fault count from 2500 (within a second of the last report), once at 5000, and silent
    // for 3000 cycles from 6000 (unplugged).
    let missing = |k: u32| {
        ((1100..2100).contains(&k) && k.is_multiple_of(2))
            || (2500..2500 + to_fault).contains(&k)
            || k == 5000
            || (6000..9000).contains(&k)
    };
    cycle(&mut m, &mut ours);
    let mut events = [None; BUS_EVENTS];
    assert_eq!(
        m.take_events(&mut events),
        3,
        "the first cycle: each drive's answer missing"
    );
    let (mut misses, mut reports) = (0u32, Vec::new());
    for k in 1..11_000u32 {
        assert!(heard_sync(&mut nodes));
        for d in m.plan().drives {
            if d.node != table.node || !missing(k) {
                nodes.send(&d.actual.pack(&[u64::from(k), u64::from(k)])).unwrap();
            }
        }
        let i = cycle(&mut m, &mut ours);
        misses += u32::from(!i.table.fresh);
        let n = m.take_events(&mut events);
        for e in events[..n].iter().flatten() {
            match *e {
                BusEvent::TpdoMissing {
                    node,
                    missed,
                    longest_in_a_row,
                } => {
                    assert_eq!(node, table.node, "only the table drive missed (cycle {k})");
                    reports.push((k, missed, longest_in_a_row));
                }
                // The test's nodes send no heartbeats.
                BusEvent::HeartbeatLost { .. } => {}
                ref other => panic!("{other:?}"),
            }
        }
    }
    assert_eq!(misses, 500 + to_fault + 1 + 3000);
    let counted: u32 = reports.iter().map(|r| r.1).sum();
    assert_eq!(counted, misses, "{reports:?}");
    // At 1100 at once; the burst's rest a second after it (499 at 2100); the run at its
    // fault count at once though a report came 400 cycles before; the single one; the
    // silence at its start, at the fault count, and the rest of it once it ended (not once
    // a second while it lasted).
    let expected = [
        (1100, 1, 1),
        (2100, 499, 1),
        (2500 + to_fault - 1, to_fault, to_fault),
        (5000, 1, 1),
        (6000, 1, 1),
        (6000 + to_fault - 1, to_fault - 1, to_fault),
        (9000, 3000 - to_fault, 3000),
    ];
    assert_eq!(reports, expected, "{reports:?}");
}

/// A clock that only moves when start-up pauses on it: no wall time passes.
#[derive(Debug, Default)]
struct StepClock {
    now: Duration,
    pauses: u32,
}

impl Clock for StepClock {
    fn now(&self) -> Duration {
        self.now
    }

    fn pause(&mut self, d: Duration) {
        self.now += d;
        self.pauses += 1;
    }
}

/// The boot waits on the clock it is given, not the wall clock: a drive that never
/// displays CSP is refused once that clock passed the timeout (a minute of it here, in next to no
/// wall time), and a silent bus is refused after four timeouts of it.
#[test]
fn boot_waits_on_the_injected_clock() {
    let m = shipped_for_tests();
    let plan = BusPlan::from_machine(&m);
    let minute = Duration::from_secs(60);
    let wall = std::time::Instant::now();
    let mut bus = FakeBus::new(&plan, [CSP_AND_HOMING; 3]);
    bus.nodes[2].takes_mode = false;
    let mut clock = StepClock::default();
    let e = boot(&plan, &mut bus, &mut clock, minute).unwrap_err();
    assert!(matches!(e, BootError::ModeNotTaken { .. }), "{e:?}");
    assert!(
        clock.now >= minute && clock.now < minute + Duration::from_millis(100),
        "{:?}",
        clock.now
    );
    // Nobody on the bus: no boot-up within four timeouts of the clock.
    let mut silent = RefusingBus {
        accept: usize::MAX,
        replies: Default::default(),
    };
    let mut clock = StepClock::default();
    let e = boot(&plan, &mut silent, &mut clock, minute).unwrap_err();
    assert!(matches!(e, BootError::NoBootUp { .. }), "{e:?}");
    assert!(clock.now >= 4 * minute, "{:?}", clock.now);
    assert!(clock.pauses > 0);
    assert!(
        wall.elapsed() < Duration::from_secs(60),
        "{:?} of wall time",
        wall.elapsed()
    );
}

/// The commissioned set of the example, for the drive that names itself as the
/// fake drives do (no 0x1018: vendor, product and serial read as 0).
fn commissioned_for_fakes() -> hob_process_image::gains::CommissionedGains {
    hob_process_image::gains::CommissionedGains {
        gains: DriveGains {
            values: [19_100, 8_600, 100_500],
        },
        vendor_id: 0,
        product_code: 0,
        serial: 0,
    }
}

#[test]
fn a_table_drive_without_gain_objects_boots_with_its_gains_unknown() {
    let plan = BusPlan::from_machine(&shipped_for_tests());
    let mut bus = FakeBus::new(&plan, [CSP_ONLY, CSP_AND_HOMING, CSP_AND_HOMING]);
    let booted = boot(
        &plan,
        &mut bus,
        &mut SystemClock::new(),
        Duration::from_millis(50),
    )
    .expect("boots");
    assert!(
        booted.nodes.iter().all(|n| n.gains.is_none()),
        "{:?}",
        booted.nodes
    );
    // Asked for (the table only), aborted, not written.
    let b = plan.drives[0].node;
    assert!(bus.log.iter().any(|(n, i, ..)| (*n, *i) == (b, 0x60F9)));
    assert!(
        bus.log
            .iter()
            .all(|(n, i, _, d)| ![0x60F9, 0x60FB].contains(i) || (*n == b && d.is_empty()))
    );
}

#[test]
fn a_commissioned_set_is_written_to_the_drive_it_names_and_read_back() {
    let mut plan = BusPlan::from_machine(&shipped_for_tests());
    plan.table_drive_gains = Some(commissioned_for_fakes());
    let mut bus = FakeBus::new(&plan, [CSP_ONLY, CSP_AND_HOMING, CSP_AND_HOMING]);
    let booted = boot(
        &plan,
        &mut bus,
        &mut SystemClock::new(),
        Duration::from_millis(50),
    )
    .expect("boots");
    let b = plan.drives[0].node;
    assert_eq!(bus.written(b, 0x60F9, 1), [19_100u32.to_le_bytes().to_vec()]);
    assert_eq!(bus.written(b, 0x60F9, 2), [8_600u32.to_le_bytes().to_vec()]);
    assert_eq!(bus.written(b, 0x60FB, 1), [100_500u32.to_le_bytes().to_vec()]);
    assert_eq!(booted.nodes[0].gains, Some(commissioned_for_fakes().gains));
    // Another drive's set (serial differs) is not written.
    plan.table_drive_gains = Some(hob_process_image::gains::CommissionedGains {
        serial: 0x1002,
        ..commissioned_for_fakes()
    });
    let mut bus = FakeBus::new(&plan, [CSP_ONLY, CSP_AND_HOMING, CSP_AND_HOMING]);
    let booted = boot(
        &plan,
        &mut bus,
        &mut SystemClock::new(),
        Duration::from_millis(50),
    )
    .expect("boots");
    assert!(bus.written(b, 0x60F9, 1).is_empty());
    assert_eq!(booted.nodes[0].gains, None);
}

#[test]
fn a_commissioned_gain_the_drive_does_not_hold_fails_the_boot_naming_the_object() {
    let mut plan = BusPlan::from_machine(&shipped_for_tests());
    plan.table_drive_gains = Some(commissioned_for_fakes());
    let mut bus = FakeBus::new(&plan, [CSP_ONLY, CSP_AND_HOMING, CSP_AND_HOMING]);
    bus.nodes[0].coarse_integral_time = true;
    let e = boot(
        &plan,
        &mut bus,
        &mut SystemClock::new(),
        Duration::from_millis(50),
    )
    .unwrap_err();
    assert_eq!(
        e,
        BootError::GainNotTaken {
            node: plan.drives[0].node,
            index: 0x60F9,
            sub: 2,
            name: "velocity control integration time",
            written: 8_600,
            read: Some(8_000),
        }
    );
    let text = e.to_string();
    assert!(
        text.contains("60F9:02") && text.contains("integration time"),
        "{text}"
    );
}
