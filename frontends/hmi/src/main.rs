//! `hob-hmi`: serves the touch HMI on the loopback for the panel's kiosk browser.

use axum::serve::ListenerExt;
use clap::Parser;
use hob_hmi::{app::App, bridge, commander, web};
use hob_ipc::gateway::Role;
use hob_store::library::Library;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

#[derive(Debug, Parser)]
#[command(
    name = "hob-hmi",
    version,
    about = "The operator's touch HMI of hob: a web page for the panel's kiosk browser"
)]
struct Args {
    /// The machine file (as hob-rt's).
    #[arg(long, default_value = "/etc/hob/machine.toml")]
    machine: PathBuf,
    /// The program and tool library (default: the machine file's [library] dir).
    #[arg(long)]
    library: Option<PathBuf>,
    /// The logger's directory, for cut reports.
    #[arg(long)]
    log_dir: Option<PathBuf>,
    /// The folder of the gear checker's files (docs/gear-measurement.md): a USB stick's
    /// mount or a share; the COMPENSATE screen lists its .csv files (without it, the screen
    /// says it is off: the machine file has no key for it).
    #[arg(long, value_name = "DIR")]
    measurements_dir: Option<PathBuf>,
    /// The `hob` CLI the COMPENSATE screen runs (`hob compensate`) [default: the hob next to
    /// hob-hmi's own executable].
    #[arg(long, value_name = "PATH")]
    hob: Option<PathBuf>,
    /// Where the panel is served: a loopback address only (port 0: any free port).
    #[arg(long, default_value = "127.0.0.1:8080")]
    bind: SocketAddr,
    /// Also serve a view-only screen (no commands, no changes) at this address; needs
    /// --view-token-file.
    #[arg(long, requires = "view_token_file")]
    view_bind: Option<SocketAddr>,
    /// The view-only screen's secret (at least 16 printable characters): a remote browser
    /// opens http://ADDR/?token=SECRET once and keeps it in a cookie.
    #[arg(long)]
    view_token_file: Option<PathBuf>,
    /// The npm install holding Preact and htm (default: next to the binary in
    /// ../share/hob/hmi/vendor, else frontends/hmi/node_modules).
    #[arg(long)]
    vendor: Option<PathBuf>,
    /// After this long without a sample the screen says the loop is silent, ms.
    #[arg(long, default_value_t = 100)]
    silence_ms: u64,
    /// The panel's user level: viewer, operator, setter or builder (at most what the
    /// gateway gives this process's user: `hob-gateway --operators/--setters/--builders`).
    #[arg(long, default_value = "builder")]
    level: String,
    /// The panel's language at start: en (English) or de (German); the page's language
    /// key changes it.
    #[arg(long, default_value = "en", value_parser = language)]
    language: hob_hmi::words::Lang,
}

fn language(s: &str) -> Result<hob_hmi::words::Lang, String> {
    hob_hmi::words::Lang::parse(s).ok_or_else(|| format!("no language {s:?}: en or de"))
}

fn vendor_dir(given: Option<PathBuf>) -> PathBuf {
    if let Some(d) = given {
        return d;
    }
    let installed = std::env::current_exe()
        .ok()
        .and_then(|e| e.parent().map(|p| p.join("../share/hob/hmi/vendor")))
        .filter(|p| p.is_dir());
    installed.unwrap_or_else(|| PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/node_modules")))
}

fn main() -> std::process::ExitCode {
    match run(Args::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("hob-hmi: {e}");
            std::process::ExitCode::from(2)
        }
    }
}

/// Frames go out as they are written: with Nagle's algorithm a frame sent soon after the
/// previous one waited for its acknowledgement, which the browser delays by up to 40 ms (a
/// state change reached the page 38 ms after its SYNC at the median; 2026-11-27).
fn no_delay(tcp: &mut tokio::net::TcpStream) {
    if let Err(e) = tcp.set_nodelay(true) {
        eprintln!("hob-hmi: TCP_NODELAY on a connection: {e}");
    }
}

/// The panel's level: `--level`, and through the gateway at most its user's level there
/// (on the bus itself this process is the bus's own user, a builder).
fn panel_level(asked: &str) -> Result<Role, String> {
    let asked = Role::from_level(asked)
        .ok_or_else(|| format!("--level {asked}: not viewer, operator, setter or builder"))?;
    Ok(
        match hob_ipc::gateway::gateway_role().map_err(|e| format!("the panel's level: {e}"))? {
            Some((user, at_gateway)) => {
                let level = asked.min(at_gateway);
                println!(
                    "hob-hmi: the panel at the {} level ({user} is {} at the gateway, --level {})",
                    level.level(),
                    at_gateway.level(),
                    asked.level()
                );
                level
            }
            None => asked,
        },
    )
}

/// The COMPENSATE screen's `hob` CLI and checker's folder (`--hob`, `--measurements-dir`).
fn compensation(a: &Args) -> hob_hmi::compensation::Setup {
    hob_hmi::compensation::Setup {
        hob: a
            .hob
            .clone()
            .unwrap_or_else(hob_hmi::compensation::Setup::hob_beside_me),
        measurements_dir: a.measurements_dir.clone(),
    }
}

fn run(a: Args) -> Result<(), String> {
    if !a.bind.ip().is_loopback() {
        return Err(format!(
            "--bind {}: the panel (commands and jog) is served on the loopback only; use --view-bind for a view-only screen elsewhere",
            a.bind
        ));
    }
    if a.silence_ms == 0 {
        return Err("--silence-ms must be above 0".into());
    }
    hob_hmi::words::set(a.language);
    let view_token = match &a.view_token_file {
        Some(f) => Some(
            std::fs::read_to_string(f)
                .map_err(|e| format!("--view-token-file {}: {e}", f.display()))
                .and_then(|t| {
                    web::ViewToken::new(&t).map_err(|e| format!("--view-token-file {}: {e}", f.display()))
                })?,
        ),
        None => None,
    };
    let level = panel_level(&a.level)?;
    let machine = hob_store::files::load_machine(&a.machine).map_err(|e| e.to_string())?;
    let library_dir = a
        .library
        .clone()
        .unwrap_or_else(|| PathBuf::from(&machine.library.dir));
    let library = Library::open(&library_dir).map_err(|e| e.to_string())?;
    let vendor = Arc::new(web::Vendor::load(&vendor_dir(a.vendor.clone())).map_err(|e| e.to_string())?);
    // Off the loop's core, like every frontend.
    hob_rt_os::keep_off_core(machine.service.loop_core);

    let (b, hub) = bridge::Bridge::new(machine.io.clone(), Duration::from_millis(a.silence_ms));
    let stop = hob_rt_os::termination_flag();
    let bridge_thread = std::thread::Builder::new()
        .name("bridge".into())
        .spawn(move || bridge::run(b, stop))
        .map_err(|e| e.to_string())?;
    let (commands, jobs) = commander::Commander::new();
    std::thread::Builder::new()
        .name("commander".into())
        .spawn(move || commander::run(jobs))
        .map_err(|e| e.to_string())?;
    let app = Arc::new(
        App::new(
            hub,
            commands,
            machine,
            a.machine.clone(),
            library,
            a.log_dir.clone(),
            level,
        )
        .with_compensation(compensation(&a)),
    );

    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| e.to_string())?;
    rt.block_on(async move {
        let listener = tokio::net::TcpListener::bind(a.bind)
            .await
            .map_err(|e| format!("--bind {}: {e}", a.bind))?;
        let addr = listener.local_addr().map_err(|e| e.to_string())?;
        let panel = web::panel_router(app.clone(), vendor.clone(), addr.to_string());
        // The first line says where: tests and the kiosk unit read it.
        println!(
            "hob-hmi: serving the panel at http://{addr}/ (instance {})",
            hob_ipc::instance()
        );
        if let (Some(v), Some(token)) = (a.view_bind, view_token) {
            let vl = tokio::net::TcpListener::bind(v)
                .await
                .map_err(|e| format!("--view-bind {v}: {e}"))?;
            let vaddr = vl.local_addr().map_err(|e| e.to_string())?;
            let view = web::view_router(app.clone(), vendor, token);
            println!("hob-hmi: serving a view-only screen at http://{vaddr}/ (open it once with ?token=)");
            tokio::spawn(async move { axum::serve(vl.tap_io(no_delay), view).await });
        }
        let stopping = async {
            while !stop.load(Ordering::Relaxed) {
                tokio::time::sleep(Duration::from_millis(100)).await;
            }
        };
        axum::serve(listener.tap_io(no_delay), panel)
            .with_graceful_shutdown(stopping)
            .await
            .map_err(|e| e.to_string())
    })?;
    bridge_thread
        .join()
        .map_err(|_| "the bridge thread panicked".to_string())?;
    Ok(())
}
