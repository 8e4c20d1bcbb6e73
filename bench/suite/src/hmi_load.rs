//! The touch HMI as a load on the loop (`hob-bench loop --load hmi`): `hob-hmi` serving the
//! panel and Chromium (Debian's, headless, software rendering as on a machine PC without a
//! GPU driver) showing AUTOMATIC with the live plot, switched on and off in blocks of a few
//! seconds: off is every one of their processes stopped (SIGSTOP), on is them running
//! (SIGCONT). On a VM the p99 of two runs minutes apart differs by up to 40 % with nothing
//! changed, so one run with and one without would measure the VM's mood; blocks in the
//! order on, off, off, on (repeated) put both cases under the same drift, and the spread
//! of the block pairs says how much a difference means.
//!
//! What each block measures: cyclictest's blocks (one cyclictest run per block, hob-rt not
//! running: they share a core and a priority) and hob-rt's blocks (the state samples' own
//! wake-up latency, cycle by cycle, while the loop cuts the demo job). The CPU time the
//! HMI's processes took in each block is counted from /proc, so that a block "on" is seen
//! to have rendered and a block "off" to have cost nothing.

use crate::hist::{self, Summary};
use hdrhistogram::Histogram;
use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;
use serde::{Deserialize, Serialize};
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

/// Where Debian installs Chromium (`bash ci/hmi-setup`).
pub const CHROMIUM: &str = "/usr/bin/chromium";

/// Whether block `i` has the HMI on: on, off, off, on, on, off, off, on, ...
pub fn block_on(i: usize) -> bool {
    matches!(i % 4, 0 | 3)
}

/// hob-hmi and Chromium, running or stopped.
#[derive(Debug)]
pub struct HmiLoad {
    hmi: Child,
    chromium: Child,
    on: bool,
}

/// Every process below `root` (its children, theirs, ...) and `root`, from /proc.
fn tree(root: u32) -> Vec<u32> {
    let mut parent_of = Vec::new();
    if let Ok(dir) = std::fs::read_dir("/proc") {
        for e in dir.flatten() {
            let Some(pid) = e.file_name().to_str().and_then(|s| s.parse::<u32>().ok()) else {
                continue;
            };
            if let Some(ppid) = stat_fields(pid).and_then(|f| f.get(1).and_then(|p| p.parse::<u32>().ok())) {
                parent_of.push((pid, ppid));
            }
        }
    }
    let mut out = vec![root];
    let mut i = 0;
    while i < out.len() {
        let p = out[i];
        out.extend(parent_of.iter().filter(|(_, pp)| *pp == p).map(|(c, _)| *c));
        i += 1;
    }
    out
}

/// The fields of /proc/PID/stat after the command's name: state, ppid, ... (index 0 is
/// the state, 1 the parent).
fn stat_fields(pid: u32) -> Option<Vec<String>> {
    let s = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    let rest = &s[s.rfind(')')? + 2..];
    Some(rest.split_whitespace().map(str::to_string).collect())
}

/// CPU time of a process, ns: the sum over its threads of /proc/PID/task/TID/schedstat's
/// first field (time on a CPU).
fn cpu_ns(pid: u32) -> u64 {
    let Ok(tasks) = std::fs::read_dir(format!("/proc/{pid}/task")) else {
        return 0;
    };
    tasks
        .flatten()
        .filter_map(|t| std::fs::read_to_string(t.path().join("schedstat")).ok())
        .filter_map(|s| s.split_whitespace().next().and_then(|v| v.parse::<u64>().ok()))
        .sum()
}

impl HmiLoad {
    /// Starts hob-hmi (beside `hob`'s other binaries) on a free loopback port with the
    /// given machine file, and Chromium on its AUTOMATIC screen; waits `settle` for the
    /// page to load. Both run on every core but the loop's (they inherit this thread's
    /// affinity: the caller keeps off the loop's core).
    pub fn start(machine_file: &Path, log_dir: &Path, settle: Duration) -> Result<Self, String> {
        if !Path::new(CHROMIUM).exists() {
            return Err(format!("{CHROMIUM} is missing: bash ci/hmi-setup installs it"));
        }
        let hmi_bin = hob_virtual_machine::procs::sibling("hob-hmi")?;
        std::fs::create_dir_all(log_dir.join("hmi-library")).map_err(|e| e.to_string())?;
        let mut hmi = Command::new(hmi_bin)
            .arg("--machine")
            .arg(machine_file)
            .arg("--library")
            .arg(log_dir.join("hmi-library"))
            .args(["--bind", "127.0.0.1:0"])
            .env("HOB_INSTANCE", hob_ipc::instance())
            .stdout(Stdio::piped())
            .stderr(std::fs::File::create(log_dir.join("hob-hmi.log")).map_err(|e| e.to_string())?)
            .spawn()
            .map_err(|e| format!("hob-hmi: {e}"))?;
        let mut line = String::new();
        let out = hmi.stdout.take().ok_or("hob-hmi: no stdout")?;
        BufReader::new(out)
            .read_line(&mut line)
            .map_err(|e| format!("hob-hmi: {e}"))?;
        let url = line
            .split_whitespace()
            .find(|w| w.starts_with("http://"))
            .ok_or_else(|| {
                let _ = hmi.kill();
                format!(
                    "hob-hmi did not say where it serves: {line:?} (see {})",
                    log_dir.join("hob-hmi.log").display()
                )
            })?
            .to_string();
        let profile = log_dir.join("chromium-profile");
        let _ = std::fs::remove_dir_all(&profile);
        let chromium = Command::new(CHROMIUM)
            .args([
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--no-first-run",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                "--window-size=1280,800",
                "--remote-debugging-port=0",
            ])
            .arg(format!("--user-data-dir={}", profile.display()))
            .arg(format!("{url}#automatic"))
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(log_dir.join("chromium.log")).map_err(|e| e.to_string())?)
            .spawn()
            .map_err(|e| format!("{CHROMIUM}: {e}"));
        let chromium = match chromium {
            Ok(c) => c,
            Err(e) => {
                let _ = hmi.kill();
                return Err(e);
            }
        };
        std::thread::sleep(settle);
        Ok(Self {
            hmi,
            chromium,
            on: true,
        })
    }

    fn pids(&self) -> Vec<u32> {
        let mut p = tree(self.hmi.id());
        p.extend(tree(self.chromium.id()));
        p
    }

    /// Runs (true) or stops (false) every process of the HMI.
    pub fn set(&mut self, on: bool) {
        if on == self.on {
            return;
        }
        let sig = if on { Signal::SIGCONT } else { Signal::SIGSTOP };
        for p in self.pids() {
            let _ = kill(Pid::from_raw(p as i32), sig);
        }
        self.on = on;
    }

    /// CPU seconds the HMI's processes have used so far.
    pub fn cpu_s(&self) -> f64 {
        self.pids().into_iter().map(cpu_ns).sum::<u64>() as f64 * 1e-9
    }

    /// Whether both are still running (not exited).
    pub fn alive(&mut self) -> bool {
        matches!(self.hmi.try_wait(), Ok(None)) && matches!(self.chromium.try_wait(), Ok(None))
    }
}

impl Drop for HmiLoad {
    fn drop(&mut self) {
        let pids = self.pids();
        for p in &pids {
            let _ = kill(Pid::from_raw(*p as i32), Signal::SIGCONT);
        }
        for p in pids.iter().rev() {
            let _ = kill(Pid::from_raw(*p as i32), Signal::SIGKILL);
        }
        let _ = self.chromium.wait();
        let _ = self.hmi.wait();
    }
}

/// One block's measurement.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Block {
    /// "cyclictest" or "hob-rt".
    pub what: String,
    pub index: usize,
    pub hmi_on: bool,
    pub wake: Summary,
    /// CPU seconds the HMI's processes took during the block.
    pub hmi_cpu_s: f64,
    pub seconds: f64,
}

impl Block {
    pub fn of(
        what: &str,
        index: usize,
        hmi_on: bool,
        h: &Histogram<u64>,
        hmi_cpu_s: f64,
        seconds: f64,
    ) -> Self {
        Self {
            what: what.into(),
            index,
            hmi_on,
            wake: hist::summary(h),
            hmi_cpu_s,
            seconds,
        }
    }
}

/// Mean and sample standard deviation.
fn mean_sd(v: &[f64]) -> (f64, f64) {
    if v.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let m = v.iter().sum::<f64>() / v.len() as f64;
    let sd = if v.len() > 1 {
        (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
    } else {
        f64::NAN
    };
    (m, sd)
}

/// One measure (e.g. p99) of one program's blocks, on against off.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct OnOff {
    pub on_mean_us: f64,
    pub on_sd_us: f64,
    pub off_mean_us: f64,
    pub off_sd_us: f64,
    /// Over the pairs of neighbouring blocks (one on, one off): mean of on - off, its
    /// standard deviation, and the smallest and largest difference.
    pub pair_diff_mean_us: f64,
    pub pair_diff_sd_us: f64,
    pub pair_diff_min_us: f64,
    pub pair_diff_max_us: f64,
    pub pairs: usize,
}

/// Compares the blocks of `what` by `measure`; the pairs are blocks 2k and 2k+1 (each pair
/// holds one on and one off, by [`block_on`]).
pub fn on_off(blocks: &[Block], what: &str, measure: impl Fn(&Summary) -> f64) -> OnOff {
    let mine: Vec<&Block> = blocks.iter().filter(|b| b.what == what).collect();
    let of = |on: bool| -> Vec<f64> {
        mine.iter()
            .filter(|b| b.hmi_on == on)
            .map(|b| measure(&b.wake))
            .collect()
    };
    let (on_mean_us, on_sd_us) = mean_sd(&of(true));
    let (off_mean_us, off_sd_us) = mean_sd(&of(false));
    let diffs: Vec<f64> = mine
        .chunks_exact(2)
        .filter(|p| p[0].hmi_on != p[1].hmi_on)
        .map(|p| {
            let (on, off) = if p[0].hmi_on { (p[0], p[1]) } else { (p[1], p[0]) };
            measure(&on.wake) - measure(&off.wake)
        })
        .collect();
    let (pair_diff_mean_us, pair_diff_sd_us) = mean_sd(&diffs);
    OnOff {
        on_mean_us,
        on_sd_us,
        off_mean_us,
        off_sd_us,
        pair_diff_mean_us,
        pair_diff_sd_us,
        pair_diff_min_us: diffs.iter().copied().fold(f64::INFINITY, f64::min),
        pair_diff_max_us: diffs.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        pairs: diffs.len(),
    }
}

/// The HMI's effect on the loop against cyclictest, from the blocks.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct HmiEffect {
    pub block_s: f64,
    pub blocks: Vec<Block>,
    pub cyclictest_p99: OnOff,
    pub hob_rt_p99: OnOff,
    pub cyclictest_max: OnOff,
    pub hob_rt_max: OnOff,
    /// hob-rt's p99 over cyclictest's, each the mean over its blocks: with the HMI
    /// rendering and without.
    pub ratio_p99_on: f64,
    pub ratio_p99_off: f64,
    /// The HMI's CPU share (of one core) in the blocks on and off.
    pub hmi_cpu_share_on: f64,
    pub hmi_cpu_share_off: f64,
    /// State samples hob-bench missed (its subscriber fell behind): they are in no block.
    pub samples_missed: u64,
}

impl HmiEffect {
    pub fn of(block_s: f64, blocks: Vec<Block>, samples_missed: u64) -> Self {
        let p99 = |s: &Summary| s.p99_us;
        let max = |s: &Summary| s.max_us;
        let cyclictest_p99 = on_off(&blocks, "cyclictest", p99);
        let hob_rt_p99 = on_off(&blocks, "hob-rt", p99);
        let share = |on: bool| {
            let (cpu, s) = blocks
                .iter()
                .filter(|b| b.hmi_on == on)
                .fold((0.0, 0.0), |(c, s), b| (c + b.hmi_cpu_s, s + b.seconds));
            if s > 0.0 { cpu / s } else { f64::NAN }
        };
        Self {
            block_s,
            ratio_p99_on: hob_rt_p99.on_mean_us / cyclictest_p99.on_mean_us,
            ratio_p99_off: hob_rt_p99.off_mean_us / cyclictest_p99.off_mean_us,
            cyclictest_max: on_off(&blocks, "cyclictest", max),
            hob_rt_max: on_off(&blocks, "hob-rt", max),
            hmi_cpu_share_on: share(true),
            hmi_cpu_share_off: share(false),
            cyclictest_p99,
            hob_rt_p99,
            blocks,
            samples_missed,
        }
    }

    /// The lines a person reads.
    pub fn text(&self) -> String {
        let line = |name: &str, o: &OnOff| {
            format!(
                "{name:<16} on {:7.1} +- {:5.1}   off {:7.1} +- {:5.1}   on - off per pair {:+7.1} +- {:5.1} (min {:+.1}, max {:+.1}, {} pairs)\n",
                o.on_mean_us,
                o.on_sd_us,
                o.off_mean_us,
                o.off_sd_us,
                o.pair_diff_mean_us,
                o.pair_diff_sd_us,
                o.pair_diff_min_us,
                o.pair_diff_max_us,
                o.pairs
            )
        };
        let mut o = format!(
            "the HMI (hob-hmi + Chromium on AUTOMATIC) on and off in blocks of {} s, wake-up latency in us (mean +- sd over blocks):\n",
            self.block_s
        );
        o.push_str(&line("cyclictest p99", &self.cyclictest_p99));
        o.push_str(&line("hob-rt p99", &self.hob_rt_p99));
        o.push_str(&line("cyclictest max", &self.cyclictest_max));
        o.push_str(&line("hob-rt max", &self.hob_rt_max));
        o.push_str(&format!(
            "ratio hob-rt/cyclictest p99: HMI on {:.2}, off {:.2}; HMI CPU (share of a core): on {:.2}, off {:.3}; samples missed {}\n",
            self.ratio_p99_on,
            self.ratio_p99_off,
            self.hmi_cpu_share_on,
            self.hmi_cpu_share_off,
            self.samples_missed
        ));
        o
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn block(what: &str, index: usize, p99: f64) -> Block {
        Block {
            what: what.into(),
            index,
            hmi_on: block_on(index),
            wake: Summary {
                p99_us: p99,
                ..Summary::default()
            },
            hmi_cpu_s: if block_on(index) { 0.5 } else { 0.0 },
            seconds: 5.0,
        }
    }

    #[test]
    fn blocks_alternate_so_that_each_pair_holds_one_on_and_one_off() {
        let on: Vec<bool> = (0..8).map(block_on).collect();
        assert_eq!(on, [true, false, false, true, true, false, false, true]);
    }

    #[test]
    fn the_effect_is_the_mean_of_the_pairs_differences_with_their_spread() {
        // A drift of +10 us per block and an HMI effect of +3 us: the pairs see 3 +- the drift.
        let blocks: Vec<Block> = (0..8)
            .map(|i| {
                block(
                    "hob-rt",
                    i,
                    100.0 + 10.0 * i as f64 + if block_on(i) { 3.0 } else { 0.0 },
                )
            })
            .chain((0..8).map(|i| block("cyclictest", i, 50.0)))
            .collect();
        let e = HmiEffect::of(5.0, blocks, 0);
        let r = e.hob_rt_p99;
        assert_eq!(r.pairs, 4);
        // Pairs (0 on, 1 off): 3 - 10 = -7; (2 off, 3 on): 3 + 10 = 13; and again.
        assert!((r.pair_diff_mean_us - 3.0).abs() < 1e-9, "{r:?}");
        assert!((r.pair_diff_min_us + 7.0).abs() < 1e-9 && (r.pair_diff_max_us - 13.0).abs() < 1e-9);
        assert!(r.pair_diff_sd_us > 10.0);
        assert_eq!(e.cyclictest_p99.pair_diff_mean_us, 0.0);
        assert!((e.hmi_cpu_share_on - 0.1).abs() < 1e-12 && e.hmi_cpu_share_off == 0.0);
        assert!(e.ratio_p99_on > e.ratio_p99_off);
    }
}
