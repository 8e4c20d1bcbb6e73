//! `hob-logger`: records every state sample and event of the loop into a log directory
//! (format: `hob_logger` crate docs). An unprivileged process; killing it never disturbs
//! the loop, and a restarted logger continues in the same directory.
//!
//! When the disk fills or a write fails it keeps running: it raises the recorder alarm on
//! the bus (the `recorder` service: `hob status` and the HMI show it), counts what it
//! could not write, and resumes in a new state file when a write succeeds again (module
//! `writer`). The loop never waits for it.
//!
//! usage: hob-logger DIR

use hob_logger::LogWriter;
use hob_logger::pump::{Item, Queue};
use std::process::ExitCode;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

/// How often the subscriber buffers are drained (the state buffer holds 2 s).
const POLL: Duration = Duration::from_millis(10);
const FLUSH: Duration = Duration::from_millis(200);

fn main() -> ExitCode {
    let Some(dir) = std::env::args().nth(1) else {
        eprintln!("usage: hob-logger DIR   (HOB_INSTANCE selects the bus instance)");
        return ExitCode::from(2);
    };
    let stop = hob_rt_os::termination_flag();
    let ports = match hob_ipc::Ports::subscribe("hob-logger") {
        Ok(p) => p,
        Err(e) => {
            eprintln!("hob-logger: {e}");
            return ExitCode::from(1);
        }
    };
    let w = match LogWriter::open(std::path::Path::new(&dir), &hob_ipc::instance()) {
        Ok(w) => w,
        Err(e) => {
            eprintln!("hob-logger: {dir}: {e}");
            return ExitCode::from(1);
        }
    };
    eprintln!("hob-logger: recording into {dir}");
    // The disk is written by a thread of its own: a write that blocks never keeps this one
    // from draining the bus (module `pump`).
    let (mut forward, queue) = hob_logger::pump::queue(hob_logger::pump::QUEUE_BATCHES);
    let writer = {
        let dir = dir.clone();
        std::thread::Builder::new()
            .name("writer".into())
            .spawn(move || write(&dir, queue, w))
    };
    let writer = match writer {
        Ok(t) => t,
        Err(e) => {
            eprintln!("hob-logger: cannot start the writing thread: {e}");
            return ExitCode::from(1);
        }
    };
    let mut dropped_reported = 0;
    let mut last_report = Instant::now() - Duration::from_secs(1);
    // The longest this thread went between two drains (the bus keeps 2048 samples: a pause
    // longer than they last loses the oldest), and when.
    let mut last_drain = Instant::now();
    let mut longest_pause = (Duration::ZERO, 0u64);
    let mut newest_cycle = 0u64;
    // Off the loop's core, as every frontend, once the loop's stats say which it is (the
    // logger reads no machine file): on a core whose real-time processes take all but the
    // throttle's 5 %, this thread was held off for seconds (4 s in the emulated guest, its
    // 2048 samples overflowing).
    let mut off_core = false;
    loop {
        let stopping = stop.load(Ordering::Relaxed);
        let pause = last_drain.elapsed();
        if pause > longest_pause.0 {
            longest_pause = (pause, newest_cycle);
        }
        last_drain = Instant::now();
        // After the stop request: what arrived before it, then the end.
        let mut batch = Vec::new();
        while let Some(s) = ports.next_state() {
            newest_cycle = s.cycle;
            batch.push(Item::State(s));
        }
        while let Some(e) = ports.next_event() {
            batch.push(Item::Event(e));
        }
        forward.forward(batch);
        if !off_core
            && let Some(st) = ports.latest_stats()
            && let Ok(core) = u32::try_from(st.core)
        {
            off_core = true;
            if !hob_rt_os::keep_process_off_core(core) {
                eprintln!("hob-logger: note: shares the loop's core {core} (no other core allowed)");
            }
        }
        if forward.dropped_items > dropped_reported && last_report.elapsed() >= Duration::from_secs(1) {
            eprintln!(
                "hob-logger: the writing is behind by more than the queue holds: {} samples and events dropped (counted lost)",
                forward.dropped_items
            );
            dropped_reported = forward.dropped_items;
            last_report = Instant::now();
        }
        if stopping {
            break;
        }
        std::thread::sleep(POLL);
    }
    drop(forward);
    let _ = writer.join();
    eprintln!(
        "hob-logger: the longest pause between two drains of the bus: {:.0} ms (after cycle {})",
        longest_pause.0.as_secs_f64() * 1e3,
        longest_pause.1
    );
    ExitCode::SUCCESS
}

/// The writing thread: everything that touches the disk, and the recorder's health on the
/// bus after each flush.
fn write(dir: &str, queue: Queue, mut w: LogWriter) {
    let recorder = hob_ipc::node("hob-logger-recorder")
        .and_then(|n| {
            let p = hob_ipc::publisher(&hob_ipc::open_recorder(&n)?, "recorder publisher")?;
            Ok((n, p))
        })
        .map_err(|e| eprintln!("hob-logger: note: records without reporting its health on the bus: {e}"))
        .ok();
    let mut failing_since_ns = 0u64;
    let mut seq = 0u64;
    queue.write_until_closed(&mut w, FLUSH, |w, result| {
        match (w.failing(), failing_since_ns) {
            (Some(f), 0) => {
                failing_since_ns = hob_rt_os::now_ns();
                eprintln!(
                    "hob-logger: ALARM: {dir}: cannot write: {}: recording what arrives as not written until a write succeeds",
                    f.error
                );
            }
            (None, since) if since != 0 => {
                failing_since_ns = 0;
                eprintln!(
                    "hob-logger: {dir}: writing again after {:.1} s; {} samples and {} events not written in all (gaps.log)",
                    (hob_rt_os::now_ns() - since) as f64 / 1e9,
                    w.stats.samples_unwritten,
                    w.stats.events_unwritten
                );
            }
            (None, _) => {
                if let Err(e) = result {
                    eprintln!("hob-logger: {dir}/logger.json: {e}");
                }
            }
            _ => {}
        }
        if let Some((_, p)) = &recorder {
            seq += 1;
            let st = &w.stats;
            let _ = p.send_copy(hob_ipc::RecorderSample {
                seq,
                time_ns: hob_rt_os::now_ns(),
                samples_written: st.samples - st.samples_unwritten,
                samples_unwritten: st.samples_unwritten,
                events_unwritten: st.events_unwritten,
                samples_lost: st.samples_lost,
                failing_since_ns,
                last_errno: w.failing().map_or(0, |f| f.errno),
                writing: u8::from(w.failing().is_none()),
                _pad: [0; 3],
            });
        }
    });
    let s = &w.stats;
    eprintln!(
        "hob-logger: {} samples ({} lost, {} not written), {} events ({} lost, {} not written) in {}",
        s.samples, s.samples_lost, s.samples_unwritten, s.events, s.events_lost, s.events_unwritten, dir
    );
}
