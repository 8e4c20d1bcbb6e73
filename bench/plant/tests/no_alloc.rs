//! The real-time rule, proven: the control step, command handling and program loading
//! allocate nothing, with a pitch compensation applied, in every sequencer state (cycles of all three kinds, single mode,
//! feed hold, stop, faults and their reaction, reset). A counting global allocator counts
//! the allocations made on this thread while the controller runs.
#![allow(clippy::unwrap_used)]

mod common;

use hob_control::fault::Axis;
use hob_control::{Command, CycleOutputs, Direction, HomeAxes, State};
use hob_plant::plant::Injection;
use hob_plant::sim::Simulation;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::collections::BTreeSet;

struct Counting;

thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    static COUNT: Cell<u64> = const { Cell::new(0) };
}

fn note() {
    // try_with: the allocator may run while thread-locals are being torn down.
    let _ = COUNTING.try_with(|c| {
        if c.get() {
            let _ = COUNT.try_with(|n| n.set(n.get() + 1));
        }
    });
}

// SAFETY: delegates every call to the system allocator unchanged; only counts.
#[allow(unsafe_code)]
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note();
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note();
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Runs `f` with allocation counting on.
fn counted<T>(f: impl FnOnce() -> T) -> T {
    COUNTING.with(|c| c.set(true));
    let out = f();
    COUNTING.with(|c| c.set(false));
    out
}

struct Driver {
    sim: Simulation,
    outputs: CycleOutputs,
    t: u64,
    states: BTreeSet<&'static str>,
    cycles: u64,
}

impl Driver {
    fn step(&mut self) -> State {
        self.t += 1;
        let t = self.t as f64 * 0.001;
        self.sim.plant.advance_to(t);
        self.sim.plant.apply(&self.outputs);
        let inputs = self.sim.plant.latch();
        let c = &mut self.sim.controller;
        self.outputs = counted(|| {
            let out = c.step(&inputs);
            while c.events().pop().is_some() {}
            out
        });
        let state = self.sim.controller.status().state;
        self.states.insert(state.name());
        self.cycles += 1;
        state
    }

    fn until(&mut self, max_s: f64, mut done: impl FnMut(State) -> bool) {
        for _ in 0..(max_s * 1000.0) as u64 {
            if done(self.step()) {
                return;
            }
        }
    }

    fn command(&mut self, cmd: Command) {
        let _ = self.answer(cmd);
    }

    /// A command that must be accepted (else its state would not be exercised).
    fn accepted(&mut self, cmd: Command) {
        let result = self.answer(cmd);
        assert_eq!(result, Ok(()), "{cmd:?}");
    }

    fn answer(&mut self, cmd: Command) -> Result<(), hob_control::fault::Refusal> {
        let c = &mut self.sim.controller;
        let result = counted(|| c.command(cmd));
        println!(
            "{:.3} {cmd:?} in {:?}: {result:?}",
            self.t as f64 * 0.001,
            c.status().state
        );
        result
    }
}

#[test]
fn the_control_step_never_allocates() {
    let (job, cycle, plan) = common::short_spur(&[("crowning = { height_mm = 0.02 }\n", "")]);
    let sim = common::powered_up(&job, &cycle, &plan);
    let mut d = Driver {
        outputs: sim.last_outputs(),
        sim,
        t: 0,
        states: BTreeSet::new(),
        cycles: 0,
    };
    d.t = (d.sim.time_s() * 1000.0) as u64;
    // Every state below runs with a pitch compensation (issue 34): its table and hob terms
    // are evaluated in each coupled cycle.
    let compensation = hob_control::pitch_comp::PitchCompensation::new(
        1.0,
        &[0.001, -0.002, 0.0015, 0.0, 0.0005],
        0.0005,
        -0.0002,
        2.0,
    )
    .unwrap();
    assert!(d.sim.controller.load_pitch_compensation(Some(compensation)));
    COUNT.with(|n| n.set(0));
    d.accepted(Command::PitchCompensation { on: true });

    // Automatic cycle with a feed hold, then single mode.
    d.command(Command::Start { single: false });
    d.until(300.0, |s| s == State::Cut);
    d.until(1.0, |_| false);
    // A copy of the whole control core in the cut (a flight recorder's snapshot, the
    // start of a replay) allocates nothing either: it is plain data, the program included.
    let before = COUNT.with(Cell::get);
    let snapshot = counted(|| d.sim.controller.clone());
    assert_eq!(
        COUNT.with(Cell::get),
        before,
        "a copy of the controller allocated"
    );
    assert_eq!(snapshot.status(), d.sim.controller.status());
    d.command(Command::FeedHold);
    d.until(1.0, |_| false);
    d.command(Command::Resume);
    d.until(300.0, |s| s == State::Idle);
    d.command(Command::Start { single: true });
    d.until(300.0, |s| s == State::Idle);
    // Jogs, spindle by hand, refusals.
    d.command(Command::Jog {
        axis: Axis::B,
        distance: 3.0,
    });
    d.until(30.0, |s| s == State::Idle);
    d.command(Command::Jog {
        axis: Axis::Y,
        distance: 5.0,
    });
    d.until(30.0, |s| s == State::Idle);
    d.command(Command::SpindleOn { rpm: 50.0 });
    d.until(3.0, |_| false);
    d.command(Command::Stop);
    d.until(10.0, |_| false);
    d.command(Command::Resume);
    // Stop in the cut, then a fault in the cut, its reaction, and reset.
    d.command(Command::Start { single: false });
    d.until(300.0, |s| s == State::Cut);
    d.until(1.0, |_| false);
    d.command(Command::Stop);
    d.until(60.0, |s| s == State::Idle);
    d.command(Command::Start { single: false });
    d.until(300.0, |s| s == State::Cut);
    d.until(1.0, |_| false);
    d.sim.plant.inject(Injection::DriveFault(Axis::Y));
    d.until(60.0, |s| s == State::Faulted);
    d.until(1.0, |_| false);
    d.sim.plant.y.fault = false;
    d.command(Command::Reset);
    d.until(30.0, |s| s == State::Idle);
    // The operator's set-up functions: continue the interrupted pass, referencing again,
    // a continuous jog released and one stopped by its dead-man, touch-off, overrides in
    // the cut.
    d.accepted(Command::Continue);
    d.until(300.0, |s| s == State::Cut);
    d.accepted(Command::FeedOverride { percent: 80.0 });
    d.accepted(Command::SpindleOverride { percent: 110.0 });
    d.until(2.0, |_| false);
    d.accepted(Command::Stop);
    d.until(60.0, |s| s == State::Idle);
    d.accepted(Command::FeedOverride { percent: 100.0 });
    d.accepted(Command::SpindleOverride { percent: 100.0 });
    d.accepted(Command::Home { axes: HomeAxes::Both });
    d.until(120.0, |s| s == State::Idle);
    let jog = Command::JogContinuous {
        axis: Axis::X,
        direction: Direction::Negative,
        speed_per_min: 300.0,
    };
    for _ in 0..5 {
        d.accepted(jog);
        d.until(0.1, |_| false);
    }
    d.accepted(Command::JogRelease);
    d.until(5.0, |s| s == State::Idle);
    d.accepted(jog);
    d.until(5.0, |s| s == State::Idle);
    // The table's target swung (commissioning's frequency response), renewed, released
    // (faded out), then again and stopped by its dead-man.
    for _ in 0..5 {
        d.accepted(Command::ExciteTable {
            frequency_hz: 40.0,
            creep: Direction::Positive,
        });
        d.until(0.1, |_| false);
    }
    d.accepted(Command::JogRelease);
    d.until(5.0, |s| s == State::Idle);
    d.accepted(Command::ExciteTable {
        frequency_hz: 3.0,
        creep: Direction::Negative,
    });
    d.until(5.0, |s| s == State::Idle);
    // The hob spindle held (renewed), released by SPINDLE OFF, then stopped by its dead-man.
    for _ in 0..5 {
        d.accepted(Command::SpindleHold { rpm: 20.0 });
        d.until(0.1, |_| false);
    }
    d.accepted(Command::SpindleOff);
    d.accepted(Command::SpindleHold { rpm: 20.0 });
    d.until(3.0, |_| false);
    // A ring gauge where X stands (not the blank): refused as needing a confirmation,
    // then confirmed; judged, asked, applied, all without allocation.
    let x_mm = d.sim.controller.status().x_mm;
    let ring = |confirmed| Command::TouchOff {
        axis: Axis::X,
        value_mm: 2.0 * x_mm - cycle.tool_tip_diameter_mm,
        confirmed,
    };
    assert_eq!(
        d.answer(ring(false)),
        Err(hob_control::fault::Refusal::OffsetNeedsConfirmation)
    );
    d.until(0.01, |_| false);
    d.accepted(ring(true));
    // The other cycles: loading a program is part of the loop's work too.
    for (name, edits) in [
        (
            "spline-z12-m2-plunge.toml",
            vec![
                ("face_width_mm = 35.0", "face_width_mm = 3.0"),
                ("plunge_feed_mm_min = 20.0", "plunge_feed_mm_min = 300.0"),
                ("feed_mm_per_rev = 1.5", "feed_mm_per_rev = 6.0"),
                ("feed_mm_per_rev = 0.8", "feed_mm_per_rev = 6.0"),
            ],
        ),
        (
            "tooth-by-tooth-z24-m8.toml",
            vec![
                ("teeth = 24", "teeth = 4"),
                // A smaller gear than the cutter's profile was made for: not judged.
                ("grade = 7 ", "# grade = 7 "),
                ("face_width_mm = 60.0", "face_width_mm = 2.0"),
                ("outside_diameter_mm = 208.0", "outside_diameter_mm = 48.0"),
                ("total_depth_mm = 18.0", "total_depth_mm = 1.0"),
                ("finish_allowance_mm = 0.5", "finish_allowance_mm = 0.2"),
                ("rough_passes = 2", "rough_passes = 1"),
                ("feed_mm_per_rev = 1.0", "feed_mm_per_rev = 6.0"),
                ("feed_mm_per_rev = 0.5", "feed_mm_per_rev = 6.0"),
            ],
        ),
    ] {
        let (other, other_cycle, other_plan) = common::program(name, &edits);
        d.sim.plant.set_workpiece(hob_plant::sim::workpiece_for(
            &other_cycle,
            &other_plan,
            other.workpiece.face_width_mm,
            other.tool.outside_diameter_mm,
        ));
        let c = &mut d.sim.controller;
        counted(|| c.load(other_cycle)).unwrap();
        d.command(Command::Start { single: false });
        d.until(600.0, |s| s == State::Idle);
    }

    let allocations = COUNT.with(|n| n.get());
    println!("{} cycles through states {:?}", d.cycles, d.states);
    for s in [
        "safe",
        "start",
        "spin",
        "sync",
        "infeed",
        "plunge",
        "rev",
        "clamp",
        "cut",
        "unclamp",
        "retract",
        "return",
        "index",
        "home",
        "disengage",
        "spindown",
        "f_retract",
        "f_stop",
        "fault",
        "init",
        "idle",
        "jog",
        "referencing",
    ] {
        assert!(d.states.contains(s), "state {s} not exercised: {:?}", d.states);
    }
    assert_eq!(allocations, 0, "allocations in the control step");
}

#[test]
fn the_counter_counts() {
    COUNT.with(|n| n.set(0));
    let v = counted(|| vec![1u8; 64]);
    assert_eq!(v.len(), 64);
    assert_eq!(COUNT.with(|n| n.get()), 1, "a test allocation must be seen");
}
