//! `hob-logger`: records every state sample and event of the loop into a log directory
//! (format: `hob_logger` crate docs). An unprivileged process; killing it never disturbs
//! the loop, and a restarted logger continues in the same directory.
//!
//! usage: hob-logger DIR

use hob_logger::LogWriter;
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
    let mut w = match LogWriter::open(std::path::Path::new(&dir), &hob_ipc::instance()) {
        Ok(w) => w,
        Err(e) => {
            eprintln!("hob-logger: {dir}: {e}");
            return ExitCode::from(1);
        }
    };
    eprintln!("hob-logger: recording into {dir}");
    let mut last_flush = Instant::now();
    while !stop.load(Ordering::Relaxed) {
        let mut io = Ok(());
        while let Some(s) = ports.next_state() {
            io = io.and(w.push_state(&s));
        }
        while let Some(e) = ports.next_event() {
            io = io.and(w.push_event(&e));
        }
        if last_flush.elapsed() >= FLUSH {
            io = io.and(w.flush());
            last_flush = Instant::now();
        }
        if let Err(e) = io {
            eprintln!("hob-logger: {dir}: {e}");
            return ExitCode::from(1);
        }
        std::thread::sleep(POLL);
    }
    // What arrived before the stop request.
    while let Some(s) = ports.next_state() {
        let _ = w.push_state(&s);
    }
    while let Some(e) = ports.next_event() {
        let _ = w.push_event(&e);
    }
    let _ = w.flush();
    let s = &w.stats;
    eprintln!(
        "hob-logger: {} samples ({} lost), {} events ({} lost) in {}",
        s.samples, s.samples_lost, s.events, s.events_lost, dir
    );
    ExitCode::SUCCESS
}
