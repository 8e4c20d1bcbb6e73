//! The CAN transport conformance suite.
#![allow(clippy::unwrap_used)]

use hob_rt_os::alloc_guard::{self, CountingAllocator};

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

/// A failed send on the shared-memory bus (iceoryx2's error mapped to ours) allocates
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
