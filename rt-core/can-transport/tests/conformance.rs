//! One CAN transport conformance suite ([`suite`]), run against every transport:
//! [`MemoryBus`], [`ShmCan`] (iceoryx2, an instance of its own per process) and
//! [`SocketCan`] on `vcan0`. A transport is skipped (the reason printed) only where it
//! declares itself unavailable on this host ([`suite::Transport::unavailable`]): SocketCAN
//! where `/sys/class/net/vcan0` does not exist (the kernel has no vcan0) and no interface
//! was named. `HOB_CONFORMANCE_IFACE` names the interface and declares it present:
//! `ci/vcan/run` runs `socketcan::` so in the PREEMPT_RT guest, where a missing interface
//! is then a failure. Any other error (a shared-memory endpoint that does not open, a
//! SocketCAN socket refused) fails the test.
//!
//! What differs, as documented by each transport and checked here:
//! - own frames: `MemoryBus` echoes its own SYNCs when asked, nothing else of its own;
//!   `ShmCan` cannot keep the echo in bus order (`echo_own_sync()` is false) and never
//!   delivers an endpoint's own frames; `SocketCan`'s echo mode is the kernel's
//!   `CAN_RAW_RECV_OWN_MSGS` under filters that pass SYNC/EMCY, TPDO 1-4, SDO answers and
//!   heartbeats (`id & 0x780` in 0x080, 0x180, 0x280, 0x380, 0x480, 0x580, 0x700): its own
//!   RPDOs, NMT and SDO requests are not delivered back, its own heartbeat is; from the
//!   others it no longer hears RPDO-, NMT- or SDO-request-class frames;
//! - a full queue: `MemoryBus` refuses with `Full` (nothing lost), `ShmCan` keeps sending
//!   and the slow endpoint keeps the newest 2048 frames (iceoryx2's safe overflow),
//!   `SocketCan` sends or says `Full` and the receiving socket drops what its buffer
//!   cannot hold;
//! - allocation: none on the system heap for any of them in the cycle; `MemoryBus` takes a
//!   mutex (a test bus, never the machine's loop) and allocates only while capturing.
#![allow(clippy::unwrap_used, clippy::expect_used)]

#[path = "conformance/suite.rs"]
mod suite;

use hob_can_transport::{MemoryBus, ShmCan, SocketCan};
use hob_rt_os::alloc_guard::{self, CountingAllocator};
use std::sync::Mutex;
use suite::{Guard, Overflow, Transport};

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

/// Heap operations (system, pool) made by `f` on this thread, counted as in a cycle.
fn in_cycle<T>(f: impl FnOnce() -> T) -> (T, u64, u64) {
    let _ = Box::new(0u8); // the allocator notes it is installed
    let (s0, p0) = alloc_guard::counts().unwrap();
    alloc_guard::in_cycle(true);
    let out = f();
    alloc_guard::in_cycle(false);
    let (s1, p1) = alloc_guard::counts().unwrap();
    (out, s1 - s0, p1 - p0)
}

/// One test at a time on a shared bus (the shared-memory instance of this process, vcan0),
/// also under `cargo test`'s threads.
fn exclusive(lock: &'static Mutex<()>) -> Guard {
    Some(lock.lock().unwrap_or_else(std::sync::PoisonError::into_inner))
}

#[derive(Debug)]
struct Memory;

const MEMORY_CAPACITY: usize = 128;

impl Transport for Memory {
    type Bus = MemoryBus;
    fn unavailable() -> Option<String> {
        None // in this process: always
    }
    fn open(n: usize) -> Result<(Vec<MemoryBus>, Guard), String> {
        let first = MemoryBus::new(MEMORY_CAPACITY);
        let mut buses = vec![first.clone()];
        buses.extend((1..n).map(|_| first.endpoint()));
        Ok((buses, None))
    }
    fn own_echo(id: u16) -> bool {
        id == hob_canopen::frame::SYNC
    }
    fn hears_after_echo(_: u16) -> bool {
        true
    }
    fn overflow() -> Overflow {
        Overflow::Refuses {
            capacity: MEMORY_CAPACITY,
        }
    }
}

#[derive(Debug)]
struct Shm;

static SHM: Mutex<()> = Mutex::new(());

/// Frames a shared-memory endpoint buffers (`hob_ipc`'s `CAN_BUFFER`).
const SHM_CAPACITY: usize = 2048;

impl Transport for Shm {
    type Bus = ShmCan;
    fn unavailable() -> Option<String> {
        None // shared memory: every host the project runs on
    }
    fn open(n: usize) -> Result<(Vec<ShmCan>, Guard), String> {
        let guard = exclusive(&SHM);
        // A bus of this process's own: parallel test processes do not meet.
        hob_ipc::use_instance(&format!("conformance-{}", std::process::id()));
        let buses = (0..n)
            .map(|i| ShmCan::open(&format!("conformance-{i}")))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| e.to_string())?;
        // Endpoints opened before another know it only after this (outside the cycle).
        for b in &buses {
            b.update_connections();
        }
        Ok((buses, guard))
    }
    fn own_echo(_: u16) -> bool {
        false // echo_own_sync() is false: never asked
    }
    fn hears_after_echo(_: u16) -> bool {
        true
    }
    fn overflow() -> Overflow {
        Overflow::DropsOldest {
            capacity: SHM_CAPACITY,
        }
    }
}

#[derive(Debug)]
struct Socket;

static VCAN: Mutex<()> = Mutex::new(());

/// The interface unless `HOB_CONFORMANCE_IFACE` names another.
const DEFAULT_IFACE: &str = "vcan0";

/// What passes `SocketCan`'s filters in echo mode: node-to-master classes, any node.
fn node_to_master(id: u16) -> bool {
    [0x080, 0x180, 0x280, 0x380, 0x480, 0x580, 0x700].contains(&(id & 0x780))
}

impl Transport for Socket {
    type Bus = SocketCan;
    fn unavailable() -> Option<String> {
        if std::env::var_os("HOB_CONFORMANCE_IFACE").is_some() {
            return None; // named: declared present (ci/vcan/run), must run
        }
        (!std::path::Path::new("/sys/class/net")
            .join(DEFAULT_IFACE)
            .exists())
        .then(|| {
            format!(
                "no /sys/class/net/{DEFAULT_IFACE} on this host (the kernel has no (v)CAN); \
                 ci/vcan/run runs these in the PREEMPT_RT guest"
            )
        })
    }
    fn open(n: usize) -> Result<(Vec<SocketCan>, Guard), String> {
        let iface = std::env::var("HOB_CONFORMANCE_IFACE").unwrap_or_else(|_| DEFAULT_IFACE.into());
        let guard = exclusive(&VCAN);
        let buses = (0..n)
            .map(|_| SocketCan::open(&iface).map_err(|e| e.to_string()))
            .collect::<Result<Vec<_>, String>>()?;
        Ok((buses, guard))
    }
    fn own_echo(id: u16) -> bool {
        node_to_master(id)
    }
    fn hears_after_echo(id: u16) -> bool {
        node_to_master(id)
    }
    fn overflow() -> Overflow {
        Overflow::ReceiverDrops { sends: 20_000 }
    }
}

macro_rules! conformance {
    ($module:ident, $transport:ty) => {
        mod $module {
            use super::*;

            #[test]
            fn order() {
                suite::order::<$transport>();
            }

            #[test]
            fn own_sync() {
                suite::own_sync::<$transport>();
            }

            #[test]
            fn full_queue() {
                suite::full_queue::<$transport>();
            }

            #[test]
            fn no_alloc() {
                suite::no_alloc::<$transport>();
            }
        }
    };
}

conformance!(memory, Memory);
conformance!(shm, Shm);
conformance!(socketcan, Socket);

/// A failed send on the shared-memory virtual CAN (iceoryx2's error mapped to ours) allocates
/// nothing, and still says what happened outside the cycle. iceoryx2 0.10's send cannot
/// be made to fail from outside (a full subscriber queue overflows safely, a missing
/// subscriber is no error), so the mapping `CanPort::send` uses is tested directly.
#[test]
fn shm_failed_send_allocates_nothing() {
    use hob_ipc::iceoryx2::port::{LoanError, SendError};
    for e in [
        SendError::ConnectionCorrupted,
        SendError::LoanError(LoanError::OutOfMemory),
        SendError::UnableToDeliver,
    ] {
        let (err, system, pool) = in_cycle(|| std::hint::black_box(hob_ipc::CanPort::send_error(e)));
        let text = err.to_string();
        assert_eq!((system, pool), (0, 0), "{e:?} allocated in the cycle");
        assert!(
            text.contains("virtual CAN send") && text.contains(&format!("{e:?}")),
            "{text}"
        );
    }
}
