//! `hob-bench`: the benchmarks and the release gate (see the crate documentation).

use clap::{Parser, Subcommand};
use hob_bench::accuracy::Disturbance;
use hob_bench::bus::{Pace, Transport};
use hob_bench::latency::Load;
use hob_bench::{accuracy, bus, busload, flood, gate, latency, step};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Debug, Parser)]
#[command(name = "hob-bench", about = "hob's benchmarks and release gate")]
struct Cli {
    /// Machine configuration.
    #[arg(long, global = true, default_value = "config/machine.toml")]
    machine: PathBuf,
    /// Simulated machine's parameters.
    #[arg(long, global = true, default_value = "config/plant.toml")]
    plant: PathBuf,
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Debug, Subcommand)]
enum Cmd {
    /// Loop wake-up latency of hob-rt against cyclictest, same period, priority and core.
    Loop {
        #[arg(long, default_value_t = 30)]
        seconds: u64,
        #[arg(long, value_enum, default_value = "none")]
        load: Load,
        #[arg(long, default_value = "target/bench/loop")]
        out: PathBuf,
        /// CAN interface or `shm` [default: vcan0 if it exists, else shm].
        #[arg(long)]
        iface: Option<String>,
        #[arg(long, default_value = "config/programs/demo-short-spur-z17-m5.toml")]
        program: PathBuf,
        /// Keep the configuration's bus timing (else relaxed for a virtual machine as in
        /// `hob demo`).
        #[arg(long)]
        strict: bool,
        /// With `--load hmi`: seconds per block (the HMI on or off; cyclictest's blocks,
        /// then hob-rt's, `--seconds` of each).
        #[arg(long, default_value_t = 5)]
        block_s: u64,
    },
    /// One-way latency of a state sample between processes: iceoryx2 and a Unix datagram
    /// socket, at 1 kHz and flat out.
    Bus {
        #[arg(long, default_value_t = 10.0)]
        seconds: f64,
        #[arg(long, default_value = "target/bench/bus")]
        out: PathBuf,
    },
    /// The publishing side of `bus` (started by it).
    #[command(hide = true)]
    BusPeer {
        #[arg(long, value_enum)]
        transport: Transport,
        #[arg(long, value_enum)]
        pace: Pace,
        #[arg(long)]
        seconds: f64,
        #[arg(long)]
        socket: PathBuf,
        #[arg(long)]
        core: u32,
        #[arg(long)]
        priority: u32,
        #[arg(long)]
        cpu_dma_latency_us: u32,
    },
    /// The control step's cost per sequencer state: time and callgrind instructions.
    Step {
        #[arg(long, default_value_t = 5)]
        repeat: usize,
        /// Skip the callgrind count.
        #[arg(long)]
        no_callgrind: bool,
        #[arg(long, default_value = "target/bench/step")]
        out: PathBuf,
        /// Example programs [default: the `programs` folder next to the machine file].
        #[arg(long)]
        programs: Option<PathBuf>,
        /// Only run the scenarios through the per-state functions (under callgrind).
        #[arg(long, hide = true)]
        count_only: bool,
    },
    /// Synchronisation error: gears x disturbance x cross-coupling x predictor.
    Accuracy {
        /// Programs [default: the hobbed examples: the demo job, spur-z17-m5, helical-z31-m3,
        /// spline-z12-m2-plunge, the held-out helical-z41-m2-2start].
        #[arg(long = "program")]
        programs: Vec<PathBuf>,
        /// Disturbance levels [default: all].
        #[arg(long = "disturbance", value_parser = parse_disturbance)]
        disturbances: Vec<Disturbance>,
        #[arg(long, default_value = "target/bench/accuracy")]
        out: PathBuf,
        /// Instead: where the finished gear's deviations come from, the worm drive's parts
        /// one at a time over an ideal machine (nominal disturbance, CCC and predictor on).
        #[arg(long, conflicts_with = "sensitivity")]
        breakdown: bool,
        /// Instead: the sensitivity table, each program under each variation of the
        /// machine and the plant (cutting ripple, SYNC jitter, table inertia, encoder, servo
        /// bandwidth, worm wheel).
        #[arg(long, conflicts_with = "seeds")]
        sensitivity: bool,
        /// Instead: issue 16's goal at every seed, each program under each disturbance with
        /// `simulation.seed` 1..=N (CCC and predictor on): the worst seed's controller's
        /// f_pt and F_p against grade 4 (grade 5 under the heavy disturbance).
        #[arg(long, conflicts_with = "breakdown")]
        seeds: Option<u64>,
    },
    /// The worst-case CAN bus load of the configuration.
    BusLoad {
        #[arg(long, default_value = "target/bench/busload")]
        out: PathBuf,
    },
    /// Every benchmark into one directory (what the gate reads).
    All {
        /// Short runs (ci/gate --quick, in the test command).
        #[arg(long, conflicts_with = "release")]
        quick: bool,
        /// Long runs (ci/release).
        #[arg(long)]
        release: bool,
        #[arg(long)]
        out: PathBuf,
        #[arg(long)]
        iface: Option<String>,
    },
    /// Checks a results directory against the limits; exits 1 with the table if one fails.
    /// One process of a command flood against a running hob-rt (HOB_INSTANCE): N requests
    /// as fast as the answers come, half to the loop, half refused before it; prints what
    /// came back as JSON.
    Flood {
        #[arg(long, default_value_t = 1000)]
        requests: u64,
        /// How long each request may wait for its answer, ms.
        #[arg(long, default_value_t = 2000)]
        timeout_ms: u64,
    },
    Gate {
        #[arg(long)]
        results: PathBuf,
        #[arg(long, default_value = "ci/gates.toml")]
        limits: PathBuf,
    },
}

fn parse_disturbance(s: &str) -> Result<Disturbance, String> {
    Disturbance::ALL
        .into_iter()
        .find(|d| d.name() == s)
        .ok_or_else(|| format!("{s}: one of none, nominal, heavy"))
}

fn default_iface(iface: Option<String>) -> String {
    iface.unwrap_or_else(|| hob_can_transport::shm::default_iface().to_string())
}

fn programs_dir(cli: &Cli, programs: Option<PathBuf>) -> PathBuf {
    programs.unwrap_or_else(|| step::programs_dir(&cli.machine))
}

fn accuracy_programs(cli: &Cli, quick: bool) -> Vec<PathBuf> {
    let dir = step::programs_dir(&cli.machine);
    let names: &[&str] = if quick {
        &["demo-short-spur-z17-m5.toml"]
    } else {
        &[
            "demo-short-spur-z17-m5.toml",
            "spur-z17-m5.toml",
            "helical-z31-m3.toml",
            "spline-z12-m2-plunge.toml",
            "helical-z41-m2-2start.toml",
        ]
    };
    names.iter().map(|n| dir.join(n)).collect()
}

fn run(cli: Cli) -> Result<bool, String> {
    let say = |s: String| print!("{s}");
    match &cli.command {
        Cmd::Loop {
            seconds,
            load,
            out,
            iface,
            program,
            strict,
            block_s,
        } => {
            let r = latency::run(&latency::Args {
                seconds: *seconds,
                load: *load,
                out: out.clone(),
                machine: cli.machine.clone(),
                plant: cli.plant.clone(),
                program: program.clone(),
                iface: default_iface(iface.clone()),
                strict: *strict,
                block_s: *block_s,
            })?;
            say(latency::text(&r));
            say(format!("results: {}\n", out.display()));
        }
        Cmd::Bus { seconds, out } => {
            let r = bus::run(&bus::Args {
                seconds: *seconds,
                out: out.clone(),
                machine: cli.machine.clone(),
            })?;
            say(bus::text(&r));
        }
        Cmd::BusPeer {
            transport,
            pace,
            seconds,
            socket,
            core,
            priority,
            cpu_dma_latency_us,
        } => bus::peer(&bus::PeerArgs {
            transport: *transport,
            pace: *pace,
            seconds: *seconds,
            socket: socket.clone(),
            core: *core,
            priority: *priority,
            cpu_dma_latency_us: *cpu_dma_latency_us,
        })?,
        Cmd::Step {
            repeat,
            no_callgrind,
            out,
            programs,
            count_only,
        } => {
            let a = step::Args {
                out: out.clone(),
                machine: cli.machine.clone(),
                plant: cli.plant.clone(),
                programs: programs_dir(&cli, programs.clone()),
                repeat: *repeat,
                callgrind: !no_callgrind,
            };
            if *count_only {
                step::count_only(&a)?;
            } else {
                say(step::text(&step::run(&a)?));
            }
        }
        Cmd::Accuracy {
            programs,
            disturbances,
            out,
            breakdown,
            sensitivity,
            seeds,
        } => {
            let args = accuracy::Args {
                out: out.clone(),
                machine: cli.machine.clone(),
                plant: cli.plant.clone(),
                programs: if programs.is_empty() {
                    accuracy_programs(&cli, false)
                } else {
                    programs.clone()
                },
                disturbances: if disturbances.is_empty() {
                    Disturbance::ALL.to_vec()
                } else {
                    disturbances.clone()
                },
            };
            if *breakdown {
                say(accuracy::breakdown_text(&accuracy::breakdown(&args)?));
            } else if *sensitivity {
                say(accuracy::sensitivity_text(&accuracy::sensitivity(&args)?));
            } else if let Some(n) = seeds {
                say(accuracy::seeds_text(&accuracy::seeds(&args, (*n).max(1))?));
            } else {
                say(accuracy::text(&accuracy::run(&args)?));
            }
        }
        Cmd::Flood { requests, timeout_ms } => {
            let f = flood::run(*requests, std::time::Duration::from_millis(*timeout_ms))?;
            println!("{}", f.json());
            return Ok(f.unanswered == 0);
        }
        Cmd::BusLoad { out } => say(busload::text(&busload::run(&cli.machine, out)?)),
        Cmd::All {
            quick,
            release,
            out,
            iface,
        } => {
            let quick = *quick || !*release;
            let loop_run = |seconds: u64, load: Load, out: PathBuf| {
                latency::run(&latency::Args {
                    seconds,
                    load,
                    out,
                    machine: cli.machine.clone(),
                    plant: cli.plant.clone(),
                    program: step::programs_dir(&cli.machine).join("demo-short-spur-z17-m5.toml"),
                    iface: default_iface(iface.clone()),
                    strict: false,
                    block_s: 5,
                })
                .map(|r| say(latency::text(&r)))
            };
            loop_run(if quick { 20 } else { 300 }, Load::None, out.clone())?;
            if !quick {
                loop_run(120, Load::Hackbench, out.join(hob_bench::gate::LOADED_LOOP_DIR))?;
            }
            say(bus::text(&bus::run(&bus::Args {
                seconds: if quick { 10.0 } else { 20.0 },
                out: out.clone(),
                machine: cli.machine.clone(),
            })?));
            say(step::text(&step::run(&step::Args {
                out: out.clone(),
                machine: cli.machine.clone(),
                plant: cli.plant.clone(),
                programs: step::programs_dir(&cli.machine),
                repeat: if quick { 2 } else { 10 },
                callgrind: true,
            })?));
            let accuracy_args = accuracy::Args {
                out: out.clone(),
                machine: cli.machine.clone(),
                plant: cli.plant.clone(),
                programs: accuracy_programs(&cli, quick),
                disturbances: Disturbance::ALL.to_vec(),
            };
            say(accuracy::text(&accuracy::run(&accuracy_args)?));
            say(accuracy::seeds_text(&accuracy::seeds(
                &accuracy_args,
                if quick { 3 } else { 8 },
            )?));
            say(busload::text(&busload::run(&cli.machine, out)?));
        }
        Cmd::Gate { results, limits } => {
            let l = gate::Limits::load(limits)?;
            let checks = gate::evaluate(results, &l);
            say(format!(
                "gate: {} against {}\n",
                results.display(),
                limits.display()
            ));
            say(gate::table(&checks));
            return Ok(gate::passed(&checks));
        }
    }
    Ok(true)
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(1),
        Err(e) => {
            eprintln!("hob-bench: {e}");
            ExitCode::from(2)
        }
    }
}
