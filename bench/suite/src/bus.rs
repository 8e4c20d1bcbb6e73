//! Bus latency: one-way latency of a `state` sample from a publisher in one process to a
//! subscriber in another, over iceoryx2 (the service and publisher `hob-rt` uses, through
//! `hob_ipc`) and, as the reference in the same run, the same number of bytes over a Unix
//! datagram socket. Two paces: 1 kHz (the publisher pinned to the loop's core at the loop's
//! SCHED_FIFO priority, absolute deadlines like `hob-rt`) and flat out.
//!
//! The publisher stamps CLOCK_MONOTONIC into the message just before sending; the
//! receiver takes the difference on arrival. The iceoryx2 subscriber polls (`receive()`
//! in a loop: the transport's own latency, as a frontend that polls sees it); the socket
//! receiver blocks in `recv` (how a socket is read). Gaps in the sequence are lost messages.

use crate::hist::{self, Summary};
use crate::system::{self, SystemInfo};
use hob_ipc::StateSample;
use hob_ipc::iceoryx2::port::update_connections::UpdateConnections as _;
use hob_rt_os as rt;
use hob_rt_os::RtReport;
use hob_setup::config::machine::ServiceConfig;
use serde::{Deserialize, Serialize};
use std::os::unix::net::UnixDatagram;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

pub const MESSAGE_BYTES: usize = std::mem::size_of::<StateSample>();

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Transport {
    Iceoryx2,
    Unix,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Pace {
    /// One message per 1 ms, on absolute deadlines.
    Khz,
    /// As fast as the publisher can send.
    Flat,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Case {
    pub transport: Transport,
    pub pace: Pace,
    pub sent: u64,
    pub received: u64,
    pub lost: u64,
    pub messages_per_s: f64,
    pub latency: Summary,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BusBench {
    pub system: SystemInfo,
    pub seconds_per_case: f64,
    pub message_bytes: usize,
    pub cases: Vec<Case>,
}

#[derive(Debug, Clone)]
pub struct Args {
    pub seconds: f64,
    pub out: PathBuf,
    pub machine: PathBuf,
}

/// The publishing side, run as `hob-bench bus-peer` in its own process.
#[derive(Debug, Clone)]
pub struct PeerArgs {
    pub transport: Transport,
    pub pace: Pace,
    pub seconds: f64,
    pub socket: PathBuf,
    pub core: u32,
    pub priority: u32,
    pub cpu_dma_latency_us: u32,
}

fn message(seq: u64, stamp_ns: u64) -> [u8; MESSAGE_BYTES] {
    let mut m = [0u8; MESSAGE_BYTES];
    m[..8].copy_from_slice(&seq.to_le_bytes());
    m[8..16].copy_from_slice(&stamp_ns.to_le_bytes());
    m
}

fn unpack(m: &[u8]) -> Option<(u64, u64)> {
    let seq = u64::from_le_bytes(m.get(..8)?.try_into().ok()?);
    let stamp = u64::from_le_bytes(m.get(8..16)?.try_into().ok()?);
    Some((seq, stamp))
}

/// Sequence number of the end marker.
const END: u64 = u64::MAX;

pub fn peer(a: &PeerArgs) -> Result<(), String> {
    let mut report = RtReport::default();
    if a.pace == Pace::Khz {
        rt::pin(a.core, &mut report);
        rt::set_fifo(a.priority, &mut report);
    }
    // The stand-in for hob-rt holds its idle-state request too.
    let _idle = rt::hold_cpu_dma_latency(a.cpu_dma_latency_us, &mut report);
    let period_ns = 1_000_000;
    let mut send: Box<dyn FnMut(u64) -> Result<(), String>> = match a.transport {
        Transport::Iceoryx2 => {
            let node = hob_ipc::node("hob-bench-bus-pub").map_err(|e| e.to_string())?;
            let service = hob_ipc::open_state(&node).map_err(|e| e.to_string())?;
            let publisher = hob_ipc::publisher(&service, "bench publisher").map_err(|e| e.to_string())?;
            // Give the subscriber's side a moment to see the publisher.
            std::thread::sleep(Duration::from_millis(200));
            let _ = publisher.update_connections();
            let _node = node;
            Box::new(move |seq| {
                let s = StateSample {
                    cycle: seq,
                    sync_time_ns: rt::now_ns(),
                    ..StateSample::default()
                };
                let sample = publisher.loan_uninit().map_err(|e| format!("loan: {e:?}"))?;
                sample
                    .write_payload(s)
                    .send()
                    .map_err(|e| format!("send: {e:?}"))?;
                Ok(())
            })
        }
        Transport::Unix => {
            let sock = UnixDatagram::unbound().map_err(|e| e.to_string())?;
            sock.connect(&a.socket)
                .map_err(|e| format!("{}: {e}", a.socket.display()))?;
            Box::new(move |seq| {
                sock.send(&message(seq, rt::now_ns()))
                    .map(|_| ())
                    .map_err(|e| format!("send: {e}"))
            })
        }
    };
    let mut seq = 0;
    let n_end = rt::now_ns() + (a.seconds * 1e9) as u64;
    let mut deadline = rt::now_ns() + period_ns;
    while rt::now_ns() < n_end {
        if a.pace == Pace::Khz {
            rt::sleep_until_ns(deadline);
            deadline += period_ns;
        }
        send(seq)?;
        seq += 1;
    }
    std::thread::sleep(Duration::from_millis(50));
    send(END)?;
    println!("{seq}");
    Ok(())
}

fn spawn_peer(
    a: &Args,
    t: Transport,
    p: Pace,
    socket: &Path,
    sv: &ServiceConfig,
    instance: &str,
) -> Result<Child, String> {
    let me = std::env::current_exe().map_err(|e| e.to_string())?;
    Command::new(me)
        .env("HOB_INSTANCE", instance)
        .arg("bus-peer")
        .arg("--transport")
        .arg(match t {
            Transport::Iceoryx2 => "iceoryx2",
            Transport::Unix => "unix",
        })
        .arg("--pace")
        .arg(match p {
            Pace::Khz => "khz",
            Pace::Flat => "flat",
        })
        .arg("--seconds")
        .arg(a.seconds.to_string())
        .arg("--socket")
        .arg(socket)
        .arg("--core")
        .arg(sv.loop_core.to_string())
        .arg("--priority")
        .arg(sv.loop_priority.to_string())
        .arg("--cpu-dma-latency-us")
        .arg(sv.cpu_dma_latency_us.to_string())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|e| format!("bus-peer: {e}"))
}

fn finish(child: Child) -> Result<u64, String> {
    let out = child.wait_with_output().map_err(|e| e.to_string())?;
    if !out.status.success() {
        return Err(format!("bus-peer failed ({})", out.status));
    }
    String::from_utf8_lossy(&out.stdout)
        .trim()
        .parse()
        .map_err(|_| "bus-peer: no count".to_string())
}

/// Counts arrivals, gaps and latency.
struct Receiver {
    h: hdrhistogram::Histogram<u64>,
    received: u64,
    next: u64,
    lost: u64,
}

impl Receiver {
    fn new() -> Self {
        Self {
            h: hist::new(),
            received: 0,
            next: 0,
            lost: 0,
        }
    }

    /// Returns false at the end marker.
    fn take(&mut self, seq: u64, stamp_ns: u64, now_ns: u64) -> bool {
        if seq == END {
            return false;
        }
        hist::record(&mut self.h, now_ns.saturating_sub(stamp_ns));
        self.received += 1;
        if seq > self.next {
            self.lost += seq - self.next;
        }
        self.next = seq + 1;
        true
    }
}

fn case(a: &Args, t: Transport, p: Pace, sv: &ServiceConfig) -> Result<Case, String> {
    // The instance is fixed at its first use in this process: the child gets that one.
    hob_ipc::use_instance(&format!("bench-{}", std::process::id()));
    let instance = hob_ipc::instance();
    let socket = std::env::temp_dir().join(format!("hob-bench-bus-{}.sock", std::process::id()));
    let _ = std::fs::remove_file(&socket);
    let mut r = Receiver::new();
    let t0 = Instant::now();
    let timeout = Duration::from_secs_f64(a.seconds + 10.0);
    let sent = match t {
        Transport::Iceoryx2 => {
            let node = hob_ipc::node("hob-bench-bus-sub").map_err(|e| e.to_string())?;
            let sub = hob_ipc::open_state(&node)
                .map_err(|e| e.to_string())?
                .subscriber_builder()
                .buffer_size(hob_ipc::STATE_BUFFER)
                .create()
                .map_err(|e| format!("subscriber: {e:?}"))?;
            let child = spawn_peer(a, t, p, &socket, sv, &instance)?;
            'recv: loop {
                if r.received == 0 {
                    let _ = sub.update_connections();
                }
                loop {
                    match sub.receive() {
                        Ok(Some(s)) => {
                            let now = rt::now_ns();
                            if !r.take(s.cycle, s.sync_time_ns, now) {
                                break 'recv;
                            }
                        }
                        Ok(None) => break,
                        Err(e) => return Err(format!("receive: {e:?}")),
                    }
                }
                if t0.elapsed() > timeout {
                    return Err(format!("iceoryx2: no end marker ({} received)", r.received));
                }
                std::hint::spin_loop();
            }
            finish(child)?
        }
        Transport::Unix => {
            let sock = UnixDatagram::bind(&socket).map_err(|e| format!("{}: {e}", socket.display()))?;
            sock.set_read_timeout(Some(timeout)).map_err(|e| e.to_string())?;
            let child = spawn_peer(a, t, p, &socket, sv, &instance)?;
            let mut buf = [0u8; MESSAGE_BYTES];
            loop {
                let n = sock.recv(&mut buf).map_err(|e| format!("unix recv: {e}"))?;
                let now = rt::now_ns();
                let (seq, stamp) = unpack(&buf[..n]).ok_or("unix: short message")?;
                if !r.take(seq, stamp, now) {
                    break;
                }
            }
            let _ = std::fs::remove_file(&socket);
            finish(child)?
        }
    };
    Ok(Case {
        transport: t,
        pace: p,
        sent,
        received: r.received,
        lost: sent.saturating_sub(r.received),
        messages_per_s: sent as f64 / a.seconds,
        latency: hist::summary(&r.h),
    })
}

pub fn run(a: &Args) -> Result<BusBench, String> {
    std::fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;
    let machine = hob_store::files::load_machine(&a.machine).map_err(|e| e.to_string())?;
    let mut cases = Vec::new();
    for p in [Pace::Khz, Pace::Flat] {
        for t in [Transport::Iceoryx2, Transport::Unix] {
            cases.push(case(a, t, p, &machine.service)?);
        }
    }
    let r = BusBench {
        system: system::probe(),
        seconds_per_case: a.seconds,
        message_bytes: MESSAGE_BYTES,
        cases,
    };
    crate::write_json(&a.out.join("bus.json"), &r)?;
    Ok(r)
}

pub fn text(r: &BusBench) -> String {
    let mut o = format!(
        "bus latency: one-way, {} bytes (a state sample), {} s per case\n",
        r.message_bytes, r.seconds_per_case
    );
    o.push_str(
        "transport  pace       msg/s      lost      p50 us    p99 us  p99.9 us  p99.99 us     max us\n",
    );
    for c in &r.cases {
        let s = &c.latency;
        o.push_str(&format!(
            "{:<10} {:<5} {:>10.0} {:>9} {:>10.1} {:>9.1} {:>9.1} {:>10.1} {:>10.1}\n",
            format!("{:?}", c.transport).to_lowercase(),
            format!("{:?}", c.pace).to_lowercase(),
            c.messages_per_s,
            c.lost,
            s.p50_us,
            s.p99_us,
            s.p999_us,
            s.p9999_us,
            s.max_us
        ));
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn message_round_trips_and_receiver_counts_gaps() {
        let m = message(7, 123_456);
        assert_eq!(unpack(&m), Some((7, 123_456)));
        assert_eq!(unpack(&m[..10]), None);
        let mut r = Receiver::new();
        assert!(r.take(0, 100, 1_100));
        assert!(r.take(3, 200, 2_200));
        assert!(!r.take(END, 0, 0));
        assert_eq!((r.received, r.lost), (2, 2));
    }
}
