//! `hob-loop-double`: a stand-in for `hob-rt` that the safety channel's tests can break in
//! ways the real loop never breaks on purpose. It publishes a `state` sample and sends a
//! SYNC frame every period, as the loop does, and after `--after-ms` stops one of the two
//! (`--mute sync`: a loop that keeps publishing but no longer drives the bus; `--mute
//! state`: one that keeps sending SYNC but no longer publishes). It listens on the bus for
//! the watchdog's reaction (the SDO download that switches the I/O coupler's digital outputs
//! off: PC-OK dropped) and reports, as one JSON line, how long after its last sign of life
//! on the muted channel that frame arrived: the watchdog's reaction time measured from the
//! loop's side, on the loop's clock.
//!
//! It also claims the loop's ports (`state`, and with `--serve-commands` the `command`
//! server): a second publisher or server, another double or a `hob-rt`, must be refused.
//!
//! usage: hob-loop-double --iface IFACE|shm [--machine FILE] [--period-us N]
//!        [--mute sync|state --after-ms N] [--serve-commands | --commands-only] [--run-ms N]

use clap::{Parser, ValueEnum};
use hob_can_transport::shm::open_bus;
use hob_canopen::frame::{Cob, Frame, SYNC};
use hob_ipc::StateSample;
use hob_ipc::codec::State;
use hob_process_image::plan::{BusPlan, DIGITAL_OUTPUTS};
use hob_rt_os::{now_ns, sleep_until_ns};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::Ordering;

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Mute {
    Sync,
    State,
}

#[derive(Debug, Parser)]
#[command(
    name = "hob-loop-double",
    about = "A stand-in for hob-rt that goes silent on one channel (tests of hob-watchdog)"
)]
struct Args {
    /// CAN interface (`vcan0`, `can0`) or `shm`.
    #[arg(long)]
    iface: String,
    /// The machine file (the I/O coupler's node id).
    #[arg(long, default_value = "config/machine.toml")]
    machine: PathBuf,
    #[arg(long, default_value_t = 1000)]
    period_us: u32,
    /// The channel that goes silent.
    #[arg(long, value_enum)]
    mute: Option<Mute>,
    /// When it goes silent, ms after the start.
    #[arg(long, default_value_t = 1000)]
    after_ms: u64,
    /// Also hold the `command` server (answers nothing).
    #[arg(long)]
    serve_commands: bool,
    /// Hold only the `command` server: no state, no SYNC (a second server's refusal).
    #[arg(long)]
    commands_only: bool,
    /// Ends after this long (default: at a termination signal).
    #[arg(long)]
    run_ms: Option<u64>,
}

fn main() -> ExitCode {
    let args = Args::parse();
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("hob-loop-double: refused: {e}");
            ExitCode::from(2)
        }
    }
}

/// The watchdog's frame that switches the coupler's first byte of digital outputs off.
fn outputs_off(f: &Frame, io_node: u8) -> bool {
    matches!(Cob::of(f.id), Cob::SdoRx(n) if n == io_node)
        && f.len >= 5
        && f.data[0] & 0xE0 == 0x20
        && u16::from_le_bytes([f.data[1], f.data[2]]) == DIGITAL_OUTPUTS
        && f.data[3] == 1
        && f.data[4] == 0
}

fn run(args: &Args) -> Result<(), String> {
    let machine = hob_store::files::load_machine(&args.machine).map_err(|e| e.to_string())?;
    let io_node = BusPlan::from_machine(&machine).io.node;
    let node = hob_ipc::node("hob-loop-double").map_err(|e| e.to_string())?;
    let stop = hob_rt_os::termination_flag();
    let start = now_ns();
    let end = args.run_ms.map(|ms| start + ms * 1_000_000);
    if args.commands_only {
        let _server = hob_ipc::command_server(&node).map_err(|e| e.to_string())?;
        eprintln!("hob-loop-double: holding the command server");
        while !stop.load(Ordering::Relaxed) && end.is_none_or(|e| now_ns() < e) {
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
        return Ok(());
    }
    let state = hob_ipc::open_state(&node)
        .and_then(|s| hob_ipc::publisher(&s, "state publisher"))
        .map_err(|e| e.to_string())?;
    let _server = if args.serve_commands {
        Some(hob_ipc::command_server(&node).map_err(|e| e.to_string())?)
    } else {
        None
    };
    let mut bus = open_bus(&args.iface, "hob-loop-double-can")?;
    // At the loop's priority, as the loop runs (in the emulated guest a stand-in at normal
    // priority stalls for longer than the watchdog's deadline).
    let mut report = hob_rt_os::RtReport::default();
    hob_rt_os::set_fifo(machine.service.loop_priority, &mut report);
    for p in &report.problems {
        eprintln!("hob-loop-double: note: {p}");
    }
    let period_ns = u64::from(args.period_us) * 1000;
    let mute_at = start + args.after_ms * 1_000_000;
    eprintln!(
        "hob-loop-double: publishing state and sending SYNC on {} every {} us{}",
        args.iface,
        args.period_us,
        args.mute
            .map(|m| format!(", {m:?} silent after {} ms", args.after_ms))
            .unwrap_or_default()
    );
    let (mut last_sync_ns, mut last_state_ns) = (0u64, 0u64);
    let mut muted_reported = false;
    let mut reaction_seen = false;
    let mut cycle = 0u64;
    let mut next = start;
    while !stop.load(Ordering::Relaxed) && end.is_none_or(|e| now_ns() < e) {
        next += period_ns;
        sleep_until_ns(next);
        let now = now_ns();
        cycle += 1;
        let muted = (now >= mute_at).then_some(args.mute).flatten();
        if muted.is_some() && !muted_reported {
            muted_reported = true;
            eprintln!(
                "hob-loop-double: {} silent from cycle {cycle}",
                args.mute
                    .map_or("nothing", |m| if m == Mute::Sync { "SYNC" } else { "state" })
            );
        }
        if muted != Some(Mute::Sync) {
            bus.send(&Frame::new(SYNC, &[]))
                .map_err(|e| format!("SYNC: {e}"))?;
            last_sync_ns = now;
        }
        if muted != Some(Mute::State) {
            let sample = StateSample {
                cycle,
                sync_time_ns: now,
                state: State::Idle.code(),
                ..StateSample::default()
            };
            state
                .send_copy(sample)
                .map_err(|e| format!("state sample: {e:?}"))?;
            last_state_ns = now;
        }
        while let Ok(Some(f)) = bus.try_recv() {
            if !reaction_seen && outputs_off(&f, io_node) {
                reaction_seen = true;
                let after = match muted {
                    Some(Mute::Sync) => Some(last_sync_ns),
                    Some(Mute::State) => Some(last_state_ns),
                    None => None,
                }
                .map(|t| (now_ns() - t) as f64 / 1e6);
                eprintln!(
                    "hob-loop-double: the watchdog switched the I/O coupler's outputs off (PC-OK dropped)"
                );
                println!(
                    "{}",
                    serde_json::json!({
                        "pc_ok_dropped": true,
                        "muted": args.mute.map(|m| format!("{m:?}").to_lowercase()),
                        "ms_after_last_sign": after,
                        "cycle": cycle,
                    })
                );
            }
        }
    }
    Ok(())
}
