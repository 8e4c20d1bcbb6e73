//! Loop latency against the kernel's limit: `cyclictest` (Debian's rt-tests) and `hob-rt`
//! (against the virtual machine `hob-sim`, cutting the demo job over and over) in the
//! same run, one after the other, with the same period, SCHED_FIFO priority and core
//! (from the machine configuration's `[service]`), optionally under a background load
//! (`hackbench` from rt-tests). Writes `loop.json`, the histograms (`.hgrm`) and
//! `loop.svg`.

use crate::hist::{self, Summary};
use crate::plot::{self, Series};
use crate::system::{self, SystemInfo};
use hob_ipc::codec::State;
use hob_ipc::{CommandRequest, Ports, command};
use hob_service::stats;
use hob_virtual_machine::procs::{Processes, relaxed_machine, sibling};
use serde::{Deserialize, Serialize};
use std::os::unix::process::CommandExt as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

#[derive(Debug, Clone)]
pub struct Args {
    pub seconds: u64,
    pub load: Load,
    pub out: PathBuf,
    pub machine: PathBuf,
    pub plant: PathBuf,
    pub program: PathBuf,
    pub iface: String,
    /// Keep the machine configuration's bus timing (else relaxed for a virtual machine).
    pub strict: bool,
    /// With `Load::Hmi`: the length of a block, s.
    pub block_s: u64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Load {
    None,
    /// `hackbench -P -g 2`: processes passing messages over sockets on every core.
    Hackbench,
    /// The touch HMI: hob-hmi and Chromium rendering AUTOMATIC's live plot, on and off in
    /// blocks (`crate::hmi_load`).
    Hmi,
}

/// Wake-ups a period or more late and the deadlines they skipped.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Late {
    pub wakeups: u64,
    pub periods_skipped: u64,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CyclictestResult {
    pub command: String,
    pub wake: Summary,
    pub late: Late,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct LoopResult {
    pub wake: Summary,
    pub compute: Summary,
    pub late: Late,
    /// hob-rt's own count of deadlines that passed before the cycle was done.
    pub overruns: u64,
    pub fifo_priority: u32,
    /// The core the loop was pinned to (None: not pinned).
    #[serde(default)]
    pub core: Option<u32>,
    pub memory_locked: bool,
    /// The idle-state exit latency hob-rt held the CPUs to, us (None: not held).
    #[serde(default)]
    pub cpu_dma_latency_us: Option<u32>,
    pub iface: String,
    pub system_allocations_in_cycles: u64,
    pub passes_cut: u32,
    pub final_state: String,
}

/// Loop percentile over cyclictest's.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Ratios {
    pub p50: f64,
    pub p99: f64,
    pub p999: f64,
    pub p9999: f64,
    pub max: f64,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct LoopBench {
    pub system: SystemInfo,
    pub seconds: u64,
    pub period_us: u64,
    pub priority: u32,
    pub core: u32,
    /// The idle-state request cyclictest ran under (`--latency`), us: the machine
    /// configuration's `service.cpu_dma_latency_us`, which hob-rt holds too.
    #[serde(default)]
    pub cpu_dma_latency_us: u32,
    pub load: Option<Load>,
    pub cyclictest: CyclictestResult,
    pub hob_rt: LoopResult,
    pub ratio: Ratios,
    /// With `--load hmi`: the blocks with the HMI on and off.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hmi: Option<crate::hmi_load::HmiEffect>,
}

fn ratio(a: f64, b: f64) -> f64 {
    if b > 0.0 { a / b } else { f64::INFINITY }
}

/// A background load in a process group of its own, stopped (the whole group: hackbench
/// forks its workers) when dropped.
struct Background(Option<std::process::Child>);

impl Drop for Background {
    fn drop(&mut self) {
        if let Some(c) = &mut self.0 {
            // The group's id is the leader's pid (`process_group(0)` below).
            let group = nix::unistd::Pid::from_raw(-(c.id() as i32));
            let _ = nix::sys::signal::kill(group, nix::sys::signal::Signal::SIGKILL);
            let _ = c.wait();
        }
    }
}

impl Background {
    fn spawn(cmd: &mut Command) -> std::io::Result<Self> {
        cmd.process_group(0)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .map(|c| Self(Some(c)))
    }
}

fn start_load(load: Load) -> Result<Background, String> {
    match load {
        // The HMI is started by the measuring thread (off the loop's core) and switched per block.
        Load::None | Load::Hmi => Ok(Background(None)),
        Load::Hackbench => {
            Background::spawn(Command::new("hackbench").args(["-P", "-g", "2", "-l", "100000000"]))
                .map_err(|e| format!("hackbench (apt install rt-tests, or bash ci/bench-setup): {e}"))
        }
    }
}

/// One run of cyclictest for `seconds`; `tag` names its files (`cyclictest{tag}.json`).
fn run_cyclictest(
    a: &Args,
    seconds: u64,
    tag: &str,
    period_us: u64,
    prio: u32,
    core: u32,
    cpu_dma_latency_us: u32,
) -> Result<(CyclictestResult, hdrhistogram::Histogram<u64>), String> {
    let json = a.out.join(format!("cyclictest{tag}.json"));
    let args = [
        "-m".to_string(),
        "-q".into(),
        "-p".into(),
        prio.to_string(),
        "-i".into(),
        period_us.to_string(),
        "-a".into(),
        core.to_string(),
        "-t".into(),
        "1".into(),
        "-D".into(),
        seconds.to_string(),
        "-h".into(),
        "100000".into(),
        format!(
            "--histfile={}",
            a.out.join(format!("cyclictest{tag}.hist")).display()
        ),
        format!("--json={}", json.display()),
        format!("--latency={cpu_dma_latency_us}"),
    ];
    let out = Command::new("cyclictest")
        .args(&args)
        .output()
        .map_err(|e| format!("cyclictest (apt install rt-tests, or bash ci/bench-setup): {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "cyclictest failed ({}): {}",
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        ));
    }
    let text = std::fs::read_to_string(&json).map_err(|e| format!("{}: {e}", json.display()))?;
    let (h, _) = hist::from_cyclictest_json(&text)?;
    let (wakeups, periods_skipped) = hist::late_wakeups(&h, period_us * 1000);
    Ok((
        CyclictestResult {
            command: format!("cyclictest {}", args.join(" ")),
            wake: hist::summary(&h),
            late: Late {
                wakeups,
                periods_skipped,
            },
        },
        h,
    ))
}

/// hob-rt cutting the program again and again until `cycles` are done; `on_sample` sees
/// every state sample this process receives.
fn run_loop(
    a: &Args,
    machine_file: &Path,
    cycles: u64,
    on_sample: &mut dyn FnMut(&hob_ipc::StateSample),
) -> Result<u32, String> {
    // The instance is fixed at its first use in this process: the children get that one.
    hob_ipc::use_instance(&format!("bench-{}", std::process::id()));
    let instance = hob_ipc::instance();
    let mut procs = Processes::default();
    let mf = machine_file.display().to_string();
    let cmd = |name: &str| -> Result<Command, String> {
        let mut c = Command::new(sibling(name)?);
        c.env("HOB_INSTANCE", &instance);
        Ok(c)
    };
    let mut sim = cmd("hob-sim")?;
    // X and Y power up within 20 mm of home: referencing (which the loop needs before it
    // cuts) takes seconds, not the first half minute of a short run.
    sim.args([
        "--iface",
        &a.iface,
        "--machine",
        &mf,
        "--rt-priority",
        "75",
        "--power-on-near-home",
        "20",
    ]);
    sim.arg("--plant").arg(&a.plant).arg("--program").arg(&a.program);
    procs.spawn("hob-sim", sim, &a.out.join("hob-sim.log"))?;
    std::thread::sleep(Duration::from_millis(300));
    let mut rt = cmd("hob-rt")?;
    rt.args(["--iface", &a.iface, "--machine", &mf, "--cycles"])
        .arg(cycles.to_string())
        .arg("--hgrm")
        .arg(&a.out);
    procs.spawn("hob-rt", rt, &a.out.join("hob-rt.log"))?;
    let ports = Ports::subscribe(&format!("hob-bench-{}", std::process::id())).map_err(|e| e.to_string())?;
    let client = hob_ipc::Client::connect(&format!("hob-bench-cmd-{}", std::process::id()))
        .map_err(|e| e.to_string())?;
    let text = std::fs::read_to_string(&a.program).map_err(|e| format!("{}: {e}", a.program.display()))?;
    let load =
        CommandRequest::load_program(&a.program.display().to_string(), &text).map_err(|e| e.to_string())?;
    let home_all = hob_ipc::request::home("all").map_err(|e| e.to_string())?;
    let mut start = CommandRequest::new(command::START);
    start.single = 0;
    let mut loaded = false;
    let mut passes = 0;
    let mut last_pass = 0;
    let end = Instant::now() + Duration::from_secs(cycles / 1000 + 120);
    loop {
        let mut newest = None;
        while let Some(s) = ports.next_state() {
            on_sample(&s);
            if s.pass != last_pass && s.pass > 0 {
                passes += 1;
            }
            last_pass = s.pass;
            newest = Some(s);
        }
        if newest.is_none() {
            std::thread::sleep(Duration::from_millis(20));
        }
        if let Some(s) = newest
            && State::from_code(s.state) == Some(State::Idle)
        {
            // The loop cuts only with X and Y referenced (bits 1 and 2): reference them
            // first, as an operator does after power-up; a refused or running homing is
            // asked again at the next idle sample.
            if s.referenced & 0b110 != 0b110 {
                if s.moving_axis == 0 {
                    let _ = client.request(&home_all, Duration::from_secs(3));
                }
            } else {
                if !loaded {
                    let r = client
                        .request(&load, Duration::from_secs(3))
                        .map_err(|e| e.to_string())?;
                    if r.accepted == 0 {
                        return Err(format!("load refused: {}", r.text()));
                    }
                    loaded = true;
                }
                // Cut the same blank again; a refused start is tried at the next idle sample.
                let _ = client.request(&start, Duration::from_secs(3));
            }
        }
        if let Some(d) = procs.dead() {
            if d.starts_with("hob-rt exited (exit status: 0)") {
                break;
            }
            return Err(format!("{d}: see {}", a.out.display()));
        }
        if Instant::now() > end {
            return Err("hob-rt did not finish its cycles in time".into());
        }
    }
    procs.stop("hob-sim", Duration::from_secs(2));
    Ok(passes)
}

pub fn run(a: &Args) -> Result<LoopBench, String> {
    std::fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;
    let machine = hob_store::files::load_machine(&a.machine).map_err(|e| e.to_string())?;
    let period_us = u64::from(machine.control.cycle_period_us);
    let prio = machine.service.loop_priority;
    let core = machine.service.loop_core;
    let machine_file = if a.strict {
        a.machine.clone()
    } else {
        relaxed_machine(&a.machine, &a.out, 100)?.0
    };
    let idle_us = machine.service.cpu_dma_latency_us;
    let _load = start_load(a.load)?;
    // This process stands in for the frontends: off the loop's core, as they are on the
    // machine PC. A thread of its own does that (and starts cyclictest, hob-sim and hob-rt,
    // which pin themselves), so the rest of the process and the load started above keep
    // every core.
    let cycles = a.seconds * 1_000_000 / period_us;
    let mut hmi_effect = None;
    let measured = std::thread::scope(|scope| {
        scope
            .spawn(|| {
                hob_rt_os::keep_off_core(core);
                if a.load == Load::Hmi {
                    let (ct, passes, effect) =
                        run_hmi_blocks(a, &machine_file, period_us, prio, core, idle_us)?;
                    hmi_effect = Some(effect);
                    return Ok::<_, String>((ct, passes));
                }
                let ct = run_cyclictest(a, a.seconds, "", period_us, prio, core, idle_us)?;
                Ok::<_, String>((ct, run_loop(a, &machine_file, cycles, &mut |_| {})?))
            })
            .join()
            .map_err(|_| "the loop benchmark's thread panicked".to_string())
    })?;
    let ((ct, ct_hist), passes_cut) = measured?;
    let read = |name: &str| -> Result<String, String> {
        let p = a.out.join(name);
        std::fs::read_to_string(&p).map_err(|e| format!("{}: {e}", p.display()))
    };
    let wake = stats::from_counts_text(&read("wake.hist")?)?;
    let compute = stats::from_counts_text(&read("compute.hist")?)?;
    let rt: serde_json::Value =
        serde_json::from_str(&read("hob-rt.json")?).map_err(|e| format!("hob-rt.json: {e}"))?;
    let (wakeups, periods_skipped) = hist::late_wakeups(&wake, period_us * 1000);
    let hob_rt = LoopResult {
        wake: hist::summary(&wake),
        compute: hist::summary(&compute),
        late: Late {
            wakeups,
            periods_skipped,
        },
        overruns: rt["overruns"].as_u64().unwrap_or(0),
        fifo_priority: rt["fifo_priority"].as_u64().unwrap_or(0) as u32,
        core: rt["core"].as_u64().map(|c| c as u32),
        memory_locked: rt["memory_locked"].as_bool().unwrap_or(false),
        cpu_dma_latency_us: rt["cpu_dma_latency_us"].as_u64().map(|us| us as u32),
        iface: rt["iface"].as_str().unwrap_or("").to_string(),
        system_allocations_in_cycles: rt["system_allocations_in_cycles"].as_u64().unwrap_or(0),
        passes_cut,
        final_state: rt["final_state"].as_str().unwrap_or("").to_string(),
    };
    let c = &ct.wake;
    let w = &hob_rt.wake;
    let result = LoopBench {
        system: system::probe(),
        seconds: a.seconds,
        period_us,
        priority: prio,
        core,
        cpu_dma_latency_us: idle_us,
        load: Some(a.load),
        ratio: Ratios {
            p50: ratio(w.p50_us, c.p50_us),
            p99: ratio(w.p99_us, c.p99_us),
            p999: ratio(w.p999_us, c.p999_us),
            p9999: ratio(w.p9999_us, c.p9999_us),
            max: ratio(w.max_us, c.max_us),
        },
        cyclictest: ct,
        hob_rt,
        hmi: hmi_effect,
    };
    if let Some(e) = &result.hmi {
        std::fs::write(a.out.join("hmi-blocks.txt"), e.text()).map_err(|e| e.to_string())?;
    }
    std::fs::write(a.out.join("cyclictest.hgrm"), stats::hgrm(&ct_hist)).map_err(|e| e.to_string())?;
    let svg = plot::percentile_svg(
        &format!(
            "wake-up latency, {} s, {} us period, SCHED_FIFO {prio}, core {core}, load {:?}",
            a.seconds, period_us, a.load
        ),
        &[
            Series {
                label: "cyclictest".into(),
                hist: &ct_hist,
            },
            Series {
                label: "hob-rt wake-up".into(),
                hist: &wake,
            },
            Series {
                label: "hob-rt compute".into(),
                hist: &compute,
            },
        ],
        period_us as f64,
    );
    std::fs::write(a.out.join("loop.svg"), svg).map_err(|e| e.to_string())?;
    crate::write_json(&a.out.join("loop.json"), &result)?;
    Ok(result)
}

/// What [`run_hmi_blocks`] returns: cyclictest's blocks merged (with their histogram), the
/// passes cut, and the blocks' comparison.
type HmiBlocks = (
    (CyclictestResult, hdrhistogram::Histogram<u64>),
    u32,
    crate::hmi_load::HmiEffect,
);

/// `--load hmi`: cyclictest's blocks, then hob-rt's, each with the HMI on and off in the
/// order of [`crate::hmi_load::block_on`]. Returns cyclictest's blocks merged (the run's
/// cyclictest result), the passes cut, and the blocks' comparison.
fn run_hmi_blocks(
    a: &Args,
    machine_file: &Path,
    period_us: u64,
    prio: u32,
    core: u32,
    idle_us: u32,
) -> Result<HmiBlocks, String> {
    use crate::hmi_load::{Block, HmiEffect, HmiLoad, block_on};
    let block_s = a.block_s.max(1);
    // A whole number of on-off-off-on rounds, at least one, for each program.
    let n = (a.seconds / block_s).div_ceil(4).max(1) as usize * 4;
    hob_ipc::use_instance(&format!("bench-{}", std::process::id()));
    let mut hmi = HmiLoad::start(machine_file, &a.out, Duration::from_secs(8))?;
    let mut blocks = Vec::new();
    let mut merged = hist::new();
    let mut last = None;
    for i in 0..n {
        hmi.set(block_on(i));
        let (cpu0, t0) = (hmi.cpu_s(), Instant::now());
        let (r, h) = run_cyclictest(a, block_s, &format!("-block{i}"), period_us, prio, core, idle_us)?;
        blocks.push(Block::of(
            "cyclictest",
            i,
            block_on(i),
            &h,
            hmi.cpu_s() - cpu0,
            t0.elapsed().as_secs_f64(),
        ));
        merged.add(&h).map_err(|e| e.to_string())?;
        last = Some(r);
    }
    if !hmi.alive() {
        return Err(format!(
            "hob-hmi or Chromium exited during cyclictest's blocks: see {}",
            a.out.display()
        ));
    }
    let mut ct = last.ok_or("no cyclictest block")?;
    let (wakeups, periods_skipped) = hist::late_wakeups(&merged, period_us * 1000);
    ct.wake = hist::summary(&merged);
    ct.late = Late {
        wakeups,
        periods_skipped,
    };
    ct.command = format!("{} ({n} blocks of {block_s} s)", ct.command);
    // hob-rt: warm up (power-up, referencing) with the HMI on, then the blocks by the
    // samples' SYNC time.
    hmi.set(true);
    let warmup_ns = 15_000_000_000u64;
    let block_ns = block_s * 1_000_000_000;
    let cycles = (warmup_ns + n as u64 * block_ns + 3_000_000_000) / (period_us * 1000);
    let mut first_ns = None;
    let mut current: Option<(usize, hdrhistogram::Histogram<u64>, f64)> = None;
    let mut prev_cycle = None;
    let mut missed = 0u64;
    let mut rt_blocks = Vec::new();
    let passes = run_loop(a, machine_file, cycles, &mut |s| {
        if let Some(p) = prev_cycle
            && s.cycle > p + 1
        {
            missed += s.cycle - p - 1;
        }
        prev_cycle = Some(s.cycle);
        let t0 = *first_ns.get_or_insert(s.sync_time_ns);
        let t = s.sync_time_ns.saturating_sub(t0);
        let block = (t >= warmup_ns)
            .then(|| ((t - warmup_ns) / block_ns) as usize)
            .filter(|b| *b < n);
        if current.as_ref().map(|c| c.0) != block {
            if let Some((i, h, cpu0)) = current.take() {
                rt_blocks.push(rt_block(i, &h, hmi.cpu_s() - cpu0, block_s));
            }
            if let Some(b) = block {
                hmi.set(block_on(b));
                current = Some((b, hist::new(), hmi.cpu_s()));
            } else {
                hmi.set(true);
            }
        }
        if let Some((_, h, _)) = current.as_mut() {
            hist::record(h, u64::from(s.wake_latency_ns));
        }
    })?;
    if let Some((i, h, cpu0)) = current.take() {
        rt_blocks.push(rt_block(i, &h, hmi.cpu_s() - cpu0, block_s));
    }
    if rt_blocks.len() < n {
        return Err(format!("hob-rt's blocks: {} of {n} measured", rt_blocks.len()));
    }
    blocks.extend(rt_blocks);
    Ok((
        (ct, merged),
        passes,
        HmiEffect::of(block_s as f64, blocks, missed),
    ))
}

/// hob-rt's block `i` (the HMI on or off as [`crate::hmi_load::block_on`] orders it), its
/// histogram and the HMI's CPU seconds in it.
fn rt_block(
    i: usize,
    h: &hdrhistogram::Histogram<u64>,
    hmi_cpu_s: f64,
    block_s: u64,
) -> crate::hmi_load::Block {
    use crate::hmi_load::{Block, block_on};
    Block::of("hob-rt", i, block_on(i), h, hmi_cpu_s, block_s as f64)
}

/// The summary a person reads.
pub fn text(r: &LoopBench) -> String {
    let row = |name: &str, s: &Summary, late: &Late| {
        format!(
            "{name:<16} {:>8.1} {:>8.1} {:>8.1} {:>8.1} {:>9.1} {:>10.1} {:>6} {:>7}\n",
            s.min_us, s.p50_us, s.p99_us, s.p999_us, s.p9999_us, s.max_us, late.wakeups, late.periods_skipped
        )
    };
    let mut o = format!(
        "loop latency: {} s at {} us, SCHED_FIFO {}, core {}, idle exit <= {} us, load {:?}; kernel {}{}{}\n",
        r.seconds,
        r.period_us,
        r.priority,
        r.core,
        r.cpu_dma_latency_us,
        r.load.unwrap_or(Load::None),
        r.system.kernel,
        if r.system.preempt_rt { " PREEMPT_RT" } else { "" },
        if r.system.virtual_machine {
            ", virtual machine"
        } else {
            ""
        }
    );
    o.push_str("wake-up us            min      p50      p99    p99.9    p99.99        max   late skipped\n");
    o.push_str(&row("cyclictest", &r.cyclictest.wake, &r.cyclictest.late));
    o.push_str(&row("hob-rt", &r.hob_rt.wake, &r.hob_rt.late));
    o.push_str(&format!(
        "ratio hob-rt/cyclictest: p50 {:.2} p99 {:.2} p99.9 {:.2} p99.99 {:.2} max {:.2}\n",
        r.ratio.p50, r.ratio.p99, r.ratio.p999, r.ratio.p9999, r.ratio.max
    ));
    let c = &r.hob_rt.compute;
    o.push_str(&format!(
        "hob-rt compute us: p50 {:.1} p99 {:.1} p99.9 {:.1} p99.99 {:.1} max {:.1}; overruns {}; {} passes cut; system heap allocations in cycles {}\n",
        c.p50_us, c.p99_us, c.p999_us, c.p9999_us, c.max_us, r.hob_rt.overruns, r.hob_rt.passes_cut, r.hob_rt.system_allocations_in_cycles
    ));
    if let Some(e) = &r.hmi {
        o.push_str(&e.text());
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Live (not yet reaped or zombie) processes of process group `pgid`.
    fn live_members(pgid: i32) -> usize {
        std::fs::read_dir("/proc")
            .unwrap()
            .flatten()
            .filter_map(|e| std::fs::read_to_string(e.path().join("stat")).ok())
            .filter(|stat| {
                // pid (comm) state ppid pgrp ...: split after the comm's closing parenthesis.
                let rest: Vec<&str> = stat
                    .rsplit_once(')')
                    .map_or("", |(_, r)| r)
                    .split_whitespace()
                    .collect();
                rest.len() > 2 && rest[2] == pgid.to_string() && rest[0] != "Z"
            })
            .count()
    }

    #[test]
    fn a_background_load_stops_with_every_process_it_forked() {
        let mut cmd = Command::new("sh");
        cmd.args(["-c", "sleep 30 & sleep 30 & wait"]);
        let load = Background::spawn(&mut cmd).unwrap();
        let pgid = load.0.as_ref().unwrap().id() as i32;
        let t0 = Instant::now();
        while live_members(pgid) < 3 && t0.elapsed() < Duration::from_secs(5) {
            std::thread::sleep(Duration::from_millis(20));
        }
        assert_eq!(live_members(pgid), 3, "the shell and its two workers");
        drop(load);
        let t0 = Instant::now();
        while live_members(pgid) > 0 && t0.elapsed() < Duration::from_secs(5) {
            std::thread::sleep(Duration::from_millis(20));
        }
        assert_eq!(live_members(pgid), 0, "a forked worker outlived the load");
    }
}
