//! Which SYNC a drive's TPDO answers: counted (SYNCs owed) or heard (own SYNC echoed in
//! bus order), and what the control core is told about it.

use super::*;
use hob_can_transport::MemoryBus;
use hob_control::CycleOutputs;
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
    let e = sdo_read(&mut bus, 2, 0x1008, 0, t).unwrap_err();
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
    let e = sdo_write(&mut bus, 4, 0x2000, 0, b"Y axis, hob head", t).unwrap_err();
    let text = e.to_string();
    assert!(
        text.contains("2000:00") && text.contains("interface down"),
        "{text}"
    );
}
