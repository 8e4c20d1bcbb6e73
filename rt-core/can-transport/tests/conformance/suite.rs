//! The suite itself: generic over a [`Transport`] (a factory for endpoints of one bus and
//! what the transport documents where transports legitimately differ). Every check runs on
//! every transport; a difference is checked as documented, never skipped.

use hob_canopen::bus::{BusError, CanBus};
use hob_canopen::frame::{Frame, SYNC};
use hob_rt_os::alloc_guard;
use std::time::{Duration, Instant};

/// What a transport does when a receiver does not read.
#[derive(Debug, Clone, Copy)]
pub enum Overflow {
    /// The sender gets [`BusError::Full`] once the receiver holds `capacity` frames, and
    /// keeps getting it until the receiver reads; nothing queued is lost.
    Refuses { capacity: usize },
    /// Every send succeeds; the receiver keeps the newest `capacity` frames.
    DropsOldest { capacity: usize },
    /// A send succeeds or gets [`BusError::Full`] (the sender's own queue); the receiver
    /// loses what its buffer cannot hold, keeping the order of what it keeps.
    ReceiverDrops { sends: usize },
}

/// A CAN transport under test.
pub trait Transport {
    type Bus: CanBus;
    /// The transport's declaration that this host cannot have it, with why (SocketCAN
    /// where the kernel has no such interface): the suite's tests are then skipped with
    /// that reason printed. `None`: the transport is available here, and every test runs.
    fn unavailable() -> Option<String>;
    /// `n` endpoints of one bus nobody else uses during the test (a guard keeps it so).
    /// Only asked where the transport is available: an error is the test's failure, never
    /// a skip.
    fn open(n: usize) -> Result<(Vec<Self::Bus>, Guard), String>;
    /// After `echo_own_sync()` returned true: whether the endpoint hears its own frame `id`.
    /// SYNC must be among them.
    fn own_echo(id: u16) -> bool;
    /// After `echo_own_sync()`: whether the endpoint still hears `id` sent by another.
    fn hears_after_echo(id: u16) -> bool;
    fn overflow() -> Overflow;
}

/// Whatever keeps a test's bus to itself while it runs (a lock, held).
pub type Guard = Option<std::sync::MutexGuard<'static, ()>>;

/// How long a frame may take to arrive (vcan delivers at once, the shared-memory virtual CAN too;
/// this is the margin for a loaded host) and how long "nothing more comes" is watched.
const ARRIVE: Duration = Duration::from_secs(2);
const QUIET: Duration = Duration::from_millis(50);

/// Opens the endpoints; `None` (the caller returns: skipped, the reason printed) only where
/// the transport declares itself unavailable on this host ([`Transport::unavailable`]).
/// Where it is available, failing to open is the test's failure.
fn open<T: Transport>(n: usize, test: &str) -> Option<(Vec<T::Bus>, Guard)> {
    if let Some(why) = T::unavailable() {
        eprintln!("SKIPPED {test}: {why}");
        return None;
    }
    match T::open(n) {
        Ok(b) => Some(b),
        Err(e) => panic!("{test}: {n} endpoints did not open on an available transport: {e}"),
    }
}

/// Frames until `n` have come or `ARRIVE` passed, then whatever else comes within `QUIET`.
fn receive(bus: &mut dyn CanBus, n: usize) -> Vec<Frame> {
    let mut got = Vec::new();
    let end = Instant::now() + ARRIVE;
    while got.len() < n && Instant::now() < end {
        match bus.try_recv() {
            Ok(Some(f)) => got.push(f),
            Ok(None) => std::thread::sleep(Duration::from_micros(100)),
            Err(e) => panic!("try_recv: {e}"),
        }
    }
    let mut quiet_until = Instant::now() + QUIET;
    while Instant::now() < quiet_until {
        match bus.try_recv() {
            Ok(Some(f)) => {
                got.push(f);
                quiet_until = Instant::now() + QUIET;
            }
            Ok(None) => std::thread::sleep(Duration::from_micros(100)),
            Err(e) => panic!("try_recv: {e}"),
        }
    }
    got
}

/// Frames of every length 0..=8, ids across the range (none a SYNC), distinct payloads.
fn traffic() -> Vec<Frame> {
    let ids = [
        0x000, 0x181, 0x201, 0x285, 0x37F, 0x482, 0x581, 0x605, 0x702, 0x7FF, 0x001, 0x100,
    ];
    (0..90usize)
        .map(|i| {
            let len = i % 9;
            let data: Vec<u8> = (0..len).map(|j| (i * 7 + j * 31) as u8).collect();
            Frame::new(ids[i % ids.len()], &data)
        })
        .collect()
}

/// Order: what one endpoint sends arrives at every other in the order sent, ids, lengths
/// (0 to 8) and data intact; the sender hears none of it (no echo unless asked).
pub fn order<T: Transport>() {
    let Some((mut b, _guard)) = open::<T>(3, "order") else {
        return;
    };
    let sent = traffic();
    for f in &sent {
        b[0].send(f).expect("send");
    }
    for (k, bus) in b.iter_mut().enumerate().skip(1) {
        let got = receive(bus, sent.len());
        assert_eq!(got, sent, "endpoint {k}");
        assert!(got.iter().any(|f| f.len == 0) && got.iter().any(|f| f.len == 8));
    }
    assert_eq!(receive(&mut b[0], 0), vec![], "the sender heard its own frames");
}

/// Own SYNC: after `echo_own_sync()` returns true the endpoint hears its own SYNCs in bus
/// order among the frames received, and its own other frames only as the transport
/// documents ([`Transport::own_echo`]); where it returns false, nothing of its own comes
/// back. Filters: what the endpoint still hears of the others' frames is as documented.
pub fn own_sync<T: Transport>() {
    let Some((mut b, _guard)) = open::<T>(2, "own_sync") else {
        return;
    };
    let echo = b[0].echo_own_sync();
    if echo {
        assert!(
            T::own_echo(SYNC),
            "echo_own_sync() returned true: SYNC must come back"
        );
    }
    // (sender, frame) in bus order: the master's SYNCs, RPDOs, NMT, SDO request and
    // heartbeat; the node's TPDO, heartbeat, SDO answer, and an RPDO-class frame.
    let script: [(usize, Frame); 12] = [
        (0, Frame::new(SYNC, &[])),
        (1, Frame::new(0x181, &[1, 2, 3, 4])),
        (0, Frame::new(0x201, &[2])),
        (0, Frame::new(0x000, &[1, 0])),
        (0, Frame::new(0x602, &[0x40, 0x00, 0x10, 0, 0, 0, 0, 0])),
        (0, Frame::new(0x701, &[5])),
        (1, Frame::new(0x202, &[3])),
        (
            1,
            Frame::new(0x582, &[0x43, 0x00, 0x10, 0, 0x92, 0x01, 0x02, 0x00]),
        ),
        (0, Frame::new(SYNC, &[])),
        (1, Frame::new(0x702, &[5])),
        (1, Frame::new(0x082, &[0x10, 0x23, 0x01, 0, 0, 0, 0, 0])),
        (0, Frame::new(SYNC, &[])),
    ];
    for (who, f) in &script {
        b[*who].send(f).expect("send");
    }
    let expected: Vec<Frame> = script
        .iter()
        .filter(|(who, f)| match (who, echo) {
            (0, true) => T::own_echo(f.id),
            (0, false) => false,
            (_, true) => T::hears_after_echo(f.id),
            (_, false) => true,
        })
        .map(|(_, f)| *f)
        .collect();
    let got = receive(&mut b[0], expected.len());
    assert_eq!(got, expected, "echo_own_sync() = {echo}");
    if echo {
        assert_eq!(
            got.iter().filter(|f| f.id == SYNC).count(),
            3,
            "every own SYNC, once"
        );
    }
    // The other endpoint hears every frame of the first (it asked for no echo).
    let from_0: Vec<Frame> = script.iter().filter(|(w, _)| *w == 0).map(|(_, f)| *f).collect();
    assert_eq!(receive(&mut b[1], from_0.len()), from_0);
}

fn numbered(n: usize) -> Frame {
    Frame::new(0x185, &(n as u32).to_le_bytes())
}

fn number(f: &Frame) -> usize {
    u32::from_le_bytes([f.data[0], f.data[1], f.data[2], f.data[3]]) as usize
}

/// A full queue: a receiver that does not read is sent to until its queue is full; the
/// sender never blocks nor panics, gets `Full` or loses the oldest as documented
/// ([`Transport::overflow`]); once the receiver drains, the bus works again.
pub fn full_queue<T: Transport>() {
    let Some((mut b, _guard)) = open::<T>(2, "full_queue") else {
        return;
    };
    let (sends, kept) = match T::overflow() {
        Overflow::Refuses { capacity } | Overflow::DropsOldest { capacity } => (capacity + 200, capacity),
        Overflow::ReceiverDrops { sends } => (sends, usize::MAX),
    };
    let t0 = Instant::now();
    let results: Vec<Result<(), BusError>> = (0..sends).map(|n| b[0].send(&numbered(n))).collect();
    assert!(t0.elapsed() < Duration::from_secs(5), "sending blocked");
    let got = receive(&mut b[1], kept);
    let numbers: Vec<usize> = got.iter().map(number).collect();
    match T::overflow() {
        Overflow::Refuses { capacity } => {
            let first_full = results.iter().position(Result::is_err);
            assert_eq!(first_full, Some(capacity), "Full exactly when the queue is");
            assert!(results[capacity..].iter().all(|r| *r == Err(BusError::Full)));
            assert_eq!(numbers, (0..capacity).collect::<Vec<_>>(), "nothing queued lost");
        }
        Overflow::DropsOldest { capacity } => {
            assert!(
                results.iter().all(Result::is_ok),
                "{:?}",
                results.iter().find(|r| r.is_err())
            );
            assert_eq!(
                numbers,
                (sends - capacity..sends).collect::<Vec<_>>(),
                "the newest kept"
            );
        }
        Overflow::ReceiverDrops { .. } => {
            assert!(
                results.iter().all(|r| matches!(r, Ok(()) | Err(BusError::Full))),
                "{:?}",
                results
                    .iter()
                    .find(|r| !matches!(r, Ok(()) | Err(BusError::Full)))
            );
            assert!(
                !numbers.is_empty() && numbers.windows(2).all(|w| w[0] < w[1]),
                "order kept"
            );
        }
    }
    // Drained: the bus works again.
    let marker = Frame::new(0x1FF, &[0xA5; 8]);
    b[0].send(&marker).expect("send after the drain");
    assert_eq!(receive(&mut b[1], 1), vec![marker]);
}

/// No allocation after open: send and try_recv in a loop on both endpoints, counted as a
/// cycle of `hob-rt` (its allocator, its pool prepared). Returns (system heap operations,
/// pool blocks) for the caller to judge; the system count must be zero for every
/// transport.
pub fn no_alloc<T: Transport>() -> Option<(u64, u64)> {
    let (mut b, _guard) = open::<T>(2, "no_alloc")?;
    alloc_guard::prepare_pool();
    let f = Frame::new(0x181, &[1, 2, 3, 4, 5, 6, 7, 8]);
    let round = |b: &mut [T::Bus]| {
        let _ = b[0].send(&f);
        while let Ok(Some(_)) = b[1].try_recv() {}
        let _ = b[1].send(&f);
        while let Ok(Some(_)) = b[0].try_recv() {}
    };
    for _ in 0..100 {
        round(&mut b);
    }
    let _ = Box::new(0u8); // the allocator notes it is installed
    let (s0, p0) = alloc_guard::counts().expect("the counting allocator is the global one");
    alloc_guard::in_cycle(true);
    for _ in 0..1000 {
        round(&mut b);
    }
    alloc_guard::in_cycle(false);
    let (s1, p1) = alloc_guard::counts().expect("installed");
    let (system, pool) = (s1 - s0, p1 - p0);
    eprintln!("no_alloc: 1000 rounds: {system} system heap operations, {pool} pool blocks");
    assert_eq!(system, 0, "send/try_recv used the system heap in the cycle");
    Some((system, pool))
}
