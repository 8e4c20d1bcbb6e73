//! The 1 kHz loop of `hob-rt`. Each cycle, at its absolute deadline on CLOCK_MONOTONIC:
//! drain the received frames, take at most one command, run the control step, send the
//! PDOs and SYNC, publish the state sample and the events, record the timing.
//!
//! Nothing here allocates, locks, blocks (besides the deadline sleep) or logs: the
//! publishers write into preallocated shared memory and never wait for a subscriber
//! (a slow one loses its oldest samples, the loop never notices).

use crate::commands::{LoadedAs, LoopMailbox, Mail, Verdict};
use crate::encode;
use crate::recorder::{AFTER_FAULT_CYCLES, Reason, Recorder};
use crate::stats::LoopTiming;
use hob_canopen::bus::CanBus;
use hob_control::{Controller, CycleOutputs, State};
use hob_ipc::iceoryx2::port::publisher::Publisher;
use hob_ipc::{EventSample, StateSample, Svc, event_kind};
use hob_master::{BUS_EVENTS, BusEvent, Cyclic};
use hob_rt_os::alloc_guard;
use hob_rt_os::{now_ns, sleep_until_ns};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// Cycles between two hand-overs of the timing histograms to the stats thread.
pub const TIMING_HANDOVER_CYCLES: u64 = 500;
/// After a termination request, how long the loop keeps cycling for the controlled stop.
pub const STOP_GRACE_S: f64 = 60.0;

/// Counters shared with the stats thread (atomics, written by the loop only).
#[derive(Debug, Default)]
pub struct LoopCounters {
    pub cycle: AtomicU64,
    pub overruns: AtomicU64,
    pub tx_errors: AtomicU64,
    /// State samples the loop could not publish (no sample free to loan, or the send
    /// failed): a follower sees them as a gap it did not cause.
    pub state_unpublished: AtomicU64,
}

/// Everything the loop owns.
#[derive(Debug)]
pub struct RtLoop<B: CanBus> {
    pub controller: Controller,
    pub cyclic: Cyclic,
    pub bus: B,
    pub state_pub: Publisher<Svc, StateSample, ()>,
    pub events_pub: Publisher<Svc, EventSample, ()>,
    pub mailbox: LoopMailbox,
    pub timing: LoopTiming,
    pub counters: Arc<LoopCounters>,
    pub period_ns: u64,
    event_seq: u64,
    /// What names the program loaded last: its text's hash (published while a program is
    /// loaded) and its file and part (in its PROGRAM_LOADED event).
    loaded: Option<LoadedAs>,
    bus_events: [Option<BusEvent>; BUS_EVENTS],
    outputs: CycleOutputs,
    /// The flight recorder: each cycle's mail, inputs and outputs.
    pub recorder: Recorder,
    /// A fault was latched after the last cycle (a new one asks for a record).
    was_faulted: bool,
    /// A cycle stop to apply as the next cycle's mail (the termination's controlled stop).
    stop_pending: bool,
}

impl<B: CanBus> RtLoop<B> {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        controller: Controller,
        cyclic: Cyclic,
        bus: B,
        state_pub: Publisher<Svc, StateSample, ()>,
        events_pub: Publisher<Svc, EventSample, ()>,
        mailbox: LoopMailbox,
        timing: LoopTiming,
        counters: Arc<LoopCounters>,
        recorder: Recorder,
    ) -> Self {
        let period_ns = (cyclic.plan().cycle_s * 1e9).round() as u64;
        Self {
            controller,
            cyclic,
            bus,
            state_pub,
            events_pub,
            mailbox,
            timing,
            counters,
            period_ns,
            event_seq: 0,
            loaded: None,
            bus_events: [None; BUS_EVENTS],
            outputs: CycleOutputs::default(),
            recorder,
            was_faulted: false,
            stop_pending: false,
        }
    }

    /// Publishes a message event (start-up and shutdown; allocation-free too).
    pub fn message(&mut self, text: &str) {
        let mut e = EventSample {
            kind: event_kind::MESSAGE,
            cycle: self.controller.status().cycle,
            ..EventSample::default()
        };
        e.text_len = hob_ipc::write_text(&mut e.text, text);
        self.publish_event(e);
    }

    fn publish_event(&mut self, mut e: EventSample) {
        self.event_seq += 1;
        e.seq = self.event_seq;
        let _ = self.events_pub.send_copy(e);
    }

    /// The cycle's events; `fault_met`: the state the latched fault met (this cycle's
    /// status, already built).
    fn publish_events(&mut self, cycle: u64, fault_met: State) {
        // An alarm says where its fault met the machine (what its reaction did): the
        // fault is latched at most once between resets, so the state it met is the one.
        let met = fault_met.situation();
        while let Some(ev) = self.controller.events().pop() {
            let mut s = encode::event_sample(0, &ev);
            if s.kind == hob_ipc::event_kind::ALARM {
                s.alarm.situation = met;
            }
            if let Some(l) = &self.loaded {
                l.name_event(&mut s);
            }
            self.publish_event(s);
        }
        let n = self.cyclic.take_events(&mut self.bus_events);
        for i in 0..n {
            if let Some(be) = self.bus_events[i] {
                self.publish_event(encode::bus_event_sample(cycle, &be));
            }
        }
    }

    /// This cycle's one piece of mail, if any: a stop asked by a signal first, else a
    /// command thread's request, carried out and answered (nothing here waits).
    fn take_mail(&mut self) {
        if self.stop_pending {
            // Alone in its cycle: one mail per cycle, as the record holds it.
            self.stop_pending = false;
            self.recorder.command(hob_control::Command::Stop);
            let _ = self.controller.command(hob_control::Command::Stop);
        } else if let Ok(mail) = self.mailbox.requests.try_recv() {
            let result = match mail {
                Mail::Load(p, loaded) => {
                    self.recorder.load(&p);
                    self.controller.load(p).map(|()| self.loaded = Some(loaded))
                }
                Mail::Command(c) => {
                    self.recorder.command(c);
                    self.controller.command(c)
                }
                // The sender means another program than the loaded one (its file was
                // changed since LOAD): nothing reaches the control core.
                Mail::CommandFor(_, hash)
                    if self.loaded.is_none_or(|l| l.hash != hash) || self.controller.program().is_none() =>
                {
                    Err(hob_control::fault::Refusal::ProgramChanged)
                }
                Mail::CommandFor(c, _) => {
                    self.recorder.command(c);
                    self.controller.command(c)
                }
                Mail::Record => {
                    self.recorder.request(Reason::Request, self.controller.cycle());
                    Ok(())
                }
            }
            .map(|()| self.controller.offsets());
            // A touch-off's figures go with its answer: the offset it set, or the one the
            // operator is asked to confirm.
            let touch_off = match mail {
                Mail::Command(hob_control::Command::TouchOff { .. }) => self.controller.last_touch_off(),
                _ => None,
            };
            let _ = self.mailbox.verdicts.try_send(Verdict { result, touch_off });
        }
    }

    /// One cycle, woken at `wake_ns` for the deadline `deadline_ns`; returns the
    /// sequencer's state after it.
    pub fn cycle(&mut self, deadline_ns: u64, wake_ns: u64) -> State {
        while let Ok(Some(f)) = self.bus.try_recv() {
            self.cyclic.receive(&f);
        }
        self.recorder.begin_cycle(&self.controller);
        self.take_mail();
        let inputs = self.cyclic.inputs();
        self.outputs = self.controller.step(&inputs);
        self.recorder.end_cycle(&inputs, &self.outputs);
        let sync_ns = now_ns();
        if self.cyclic.transmit(&self.outputs, &mut self.bus).is_err() {
            self.counters.tx_errors.fetch_add(1, Ordering::Relaxed);
        }
        let status = self.controller.status();
        // A new fault, latched (its reaction starts now): its record, once the first
        // seconds of the reaction have run too.
        let faulted = status.fault.is_some();
        if !self.was_faulted
            && let Some(f) = status.fault
        {
            self.recorder
                .request(Reason::Fault(f), status.cycle + AFTER_FAULT_CYCLES);
        }
        self.was_faulted = faulted;
        let (passes, loaded, pitch_radius_mm, normal_module_mm) =
            self.controller.program().map_or((0, false, 0.0, 0.0), |p| {
                (
                    p.passes().len() as u32,
                    true,
                    p.pitch_diameter_mm / 2.0,
                    p.normal_module_mm,
                )
            });
        let compute_ns = now_ns().saturating_sub(wake_ns);
        let wake_latency_ns = wake_ns.saturating_sub(deadline_ns);
        let mut s = StateSample::default();
        encode::fill_state(&mut s, &status, passes, loaded);
        s.sync_time_ns = sync_ns;
        s.digital_inputs = inputs.digital_inputs;
        s.digital_outputs = self.outputs.digital_outputs;
        s.io_valid = u8::from(inputs.io_valid);
        s.wake_latency_ns = wake_latency_ns.min(u64::from(u32::MAX)) as u32;
        s.compute_ns = compute_ns.min(u64::from(u32::MAX)) as u32;
        s.overruns = self.counters.overruns.load(Ordering::Relaxed);
        s.events_lost = self.controller.events().lost();
        s.pitch_radius_mm = pitch_radius_mm;
        s.normal_module_mm = normal_module_mm;
        s.program_hash = match (&self.loaded, loaded) {
            (Some(l), true) => l.hash,
            _ => 0,
        };
        s.drive_statusword = self.cyclic.statuswords();
        s.last_emcy_code = self.cyclic.last_emcy();
        for (i, l) in self.cyclic.liveness().iter().enumerate() {
            s.nmt_state[i] = l.state.map_or(hob_ipc::NMT_NOT_HEARD, |n| n as u8);
            s.heartbeat_age_cycles[i] = l.cycles_since_heartbeat;
        }
        let published = match self.state_pub.loan_uninit() {
            Ok(sample) => sample.write_payload(s).send().is_ok(),
            Err(_) => false,
        };
        if !published {
            self.counters.state_unpublished.fetch_add(1, Ordering::Relaxed);
        }
        self.publish_events(status.cycle, status.fault_met);
        self.counters.cycle.store(status.cycle, Ordering::Relaxed);
        self.timing
            .current
            .record(wake_latency_ns, now_ns().saturating_sub(wake_ns));
        if status.cycle.is_multiple_of(TIMING_HANDOVER_CYCLES) {
            self.timing.hand_over();
        }
        status.state
    }

    /// Runs until `stop`; then stops a running cycle (out of the cut, gearbox engaged until
    /// X is clear) and returns when the machine is at rest or after [`STOP_GRACE_S`].
    /// `max_cycles` ends the run earlier (benchmarks).
    pub fn run(&mut self, stop: &AtomicBool, max_cycles: Option<u64>) {
        let mut deadline = now_ns() + self.period_ns;
        let mut stopping_since: Option<u64> = None;
        let mut n = 0u64;
        loop {
            sleep_until_ns(deadline);
            alloc_guard::in_cycle(true);
            let wake = now_ns();
            let state = self.cycle(deadline, wake);
            n += 1;
            alloc_guard::in_cycle(false);
            let at_rest = matches!(state, State::Init | State::Idle | State::Faulted);
            if stop.load(Ordering::Relaxed) && stopping_since.is_none() {
                stopping_since = Some(n);
                if !at_rest {
                    self.stop_pending = true;
                }
            }
            if let Some(since) = stopping_since {
                let waited_s = (n - since) as f64 * self.period_ns as f64 * 1e-9;
                if at_rest || waited_s > STOP_GRACE_S {
                    break;
                }
            }
            if max_cycles.is_some_and(|m| n >= m) {
                break;
            }
            deadline += self.period_ns;
            let now = now_ns();
            if now >= deadline {
                // The next deadline has passed already: count it and keep the phase.
                let missed = (now - deadline) / self.period_ns + 1;
                self.counters.overruns.fetch_add(missed, Ordering::Relaxed);
                deadline += missed * self.period_ns;
            }
        }
    }
}
