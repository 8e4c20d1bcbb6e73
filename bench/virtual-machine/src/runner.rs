//! Putting the virtual machine and the master on a bus.
//!
//! - [`serve`]: the virtual machine's loop on any transport (a thread in tests, the
//!   `hob-sim` process on vcan or the shared-memory virtual CAN).
//! - [`MasterLoop`]: the controller and the cyclic master over a bus, in lockstep with
//!   the virtual machine: after each SYNC it waits (up to a timeout) for the drives' TPDOs,
//!   so runs are reproducible on a loaded or emulated machine. Timing plays no part.

use crate::virtual_machine::{VirtualMachine, VmFault};
use hob_canopen::bus::{BusError, CanBus};
use hob_canopen::frame::{Frame, SYNC};
use hob_control::{Controller, CycleOutputs};
use hob_master::Cyclic;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

/// Without a SYNC for this long the nodes' clock runs on wall time (boot, a dead master).
/// Several times any lockstep wait of the master (`MasterLoop::tpdo_timeout`), so a live
/// master never looks dead.
pub const SYNC_SILENCE: Duration = Duration::from_secs(3);

/// Runs the virtual machine on `bus` until `stop`; faults arrive on `faults`.
pub fn serve(
    vm: &mut VirtualMachine,
    bus: &mut dyn CanBus,
    stop: &AtomicBool,
    faults: Option<&Receiver<VmFault>>,
) {
    let mut last_idle = Instant::now();
    let mut out = Vec::new();
    let mut batch = Vec::new();
    vm.power_on(&mut out);
    let mut last_sync = vm.syncs();
    let mut last_sync_wall = Instant::now();
    while !stop.load(Ordering::Relaxed) {
        if let Some(rx) = faults {
            while let Ok(f) = rx.try_recv() {
                vm.inject(f);
            }
        }
        let busy = serve_waiting(vm, bus, &mut batch, &mut out).unwrap_or(0) > 0;
        vm.settle();
        if vm.syncs() != last_sync {
            last_sync = vm.syncs();
            last_sync_wall = Instant::now();
            last_idle = Instant::now();
        } else if last_sync_wall.elapsed() > SYNC_SILENCE {
            // No SYNC running: heartbeats on wall time.
            vm.idle(last_idle.elapsed().as_secs_f64(), &mut out);
            last_idle = Instant::now();
            flush(bus, &mut out);
        }
        if !busy {
            std::thread::sleep(Duration::from_micros(50));
        }
    }
    vm.settle();
}

/// Reads every frame waiting on `bus`, lets the machine handle them as one batch
/// ([`VirtualMachine::on_frames`]: of several SYNCs read late only the last is answered)
/// and sends the answers; the caller then computes the physics owed
/// ([`VirtualMachine::settle`]). Before an answer goes out the bus is read again: if the
/// next SYNC came while it was computed, it would reach the master after that SYNC and
/// pass for its answer, so it is withdrawn (a missed frame). Returns how many frames were
/// read.
pub fn serve_waiting(
    vm: &mut VirtualMachine,
    bus: &mut dyn CanBus,
    batch: &mut Vec<Frame>,
    out: &mut Vec<Frame>,
) -> Result<usize, BusError> {
    let mut total = 0;
    let mut answer_pending = false;
    loop {
        batch.clear();
        let read = loop {
            match bus.try_recv() {
                Ok(Some(f)) => batch.push(f),
                Ok(None) => break Ok(()),
                Err(e) => break Err(e),
            }
        };
        if answer_pending && batch.iter().any(|f| f.id == SYNC) {
            vm.withdraw_answer(out);
        }
        flush(bus, out);
        total += batch.len();
        if batch.is_empty() || read.is_err() {
            vm.on_frames(batch, out);
            flush(bus, out);
            break read.map(|()| total);
        }
        answer_pending = vm.on_frames(batch, out);
    }
}

fn flush(bus: &mut dyn CanBus, out: &mut Vec<Frame>) {
    for f in out.drain(..) {
        // A full queue drops the frame, as a real node's transmit buffer would.
        let _ = bus.send(&f);
    }
}

/// The controller and the master on a bus, one cycle at a time.
#[derive(Debug)]
pub struct MasterLoop<B: CanBus> {
    pub controller: Controller,
    pub cyclic: Cyclic,
    pub bus: B,
    outputs: Option<CycleOutputs>,
    /// Longest wait for the TPDOs of a SYNC before the cycle goes on without them.
    pub tpdo_timeout: Duration,
}

impl<B: CanBus> MasterLoop<B> {
    pub fn new(controller: Controller, mut cyclic: Cyclic, mut bus: B) -> Self {
        cyclic.hear_own_sync(&mut bus);
        Self {
            controller,
            cyclic,
            bus,
            outputs: None,
            tpdo_timeout: Duration::from_millis(500),
        }
    }

    fn drain(&mut self) {
        while let Ok(Some(f)) = self.bus.try_recv() {
            self.cyclic.receive(&f);
        }
    }

    /// One cycle: wait for the TPDOs of the last SYNC, step, send targets and the SYNC.
    /// Returns the outputs of this cycle.
    pub fn cycle(&mut self) -> CycleOutputs {
        if self.outputs.is_some() {
            let deadline = Instant::now() + self.tpdo_timeout;
            loop {
                self.drain();
                if self.cyclic.all_fresh() || Instant::now() >= deadline {
                    break;
                }
                std::thread::sleep(Duration::from_micros(20));
            }
        } else {
            self.drain();
        }
        let inputs = self.cyclic.inputs();
        let out = self.controller.step(&inputs);
        let _ = self.cyclic.transmit(&out, &mut self.bus);
        self.outputs = Some(out);
        out
    }
}

/// A virtual machine served in a thread of this process (tests).
#[derive(Debug)]
pub struct VmThread {
    stop: Arc<AtomicBool>,
    pub faults: std::sync::mpsc::Sender<VmFault>,
    handle: Option<std::thread::JoinHandle<VirtualMachine>>,
}

impl VmThread {
    pub fn spawn<B: CanBus + Send + 'static>(mut vm: VirtualMachine, mut bus: B) -> Self {
        let stop = Arc::new(AtomicBool::new(false));
        let (tx, rx) = std::sync::mpsc::channel();
        let s = Arc::clone(&stop);
        let handle = std::thread::spawn(move || {
            serve(&mut vm, &mut bus, &s, Some(&rx));
            vm
        });
        Self {
            stop,
            faults: tx,
            handle: Some(handle),
        }
    }

    pub fn inject(&self, f: VmFault) {
        let _ = self.faults.send(f);
    }

    /// Stops the thread and returns the machine (to inspect its state).
    pub fn stop(mut self) -> Option<VirtualMachine> {
        self.stop.store(true, Ordering::Relaxed);
        self.handle.take().and_then(|h| h.join().ok())
    }
}

impl Drop for VmThread {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
    }
}
