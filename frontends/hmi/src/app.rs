//! What every request of the web server shares: the hub of the loop's streams, the command
//! thread, the machine file, the program and tool library, and the machine's description
//! for the page.

use crate::bridge::Hub;
use crate::commander::Commander;
use crate::error::Error;
use hob_ipc::CommandRequest;
use hob_ipc::gateway::{Action, Role};
use hob_setup::config::machine::MachineConfig;
use hob_setup::planner::Plan;
use hob_store::library::{Kind, Library};
use std::path::PathBuf;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// A program this HMI loaded into the loop.
#[derive(Debug, Clone)]
pub struct Loaded {
    pub name: String,
    pub plan: Plan,
    pub hash: u64,
}

#[derive(Debug)]
pub struct App {
    pub hub: Hub,
    pub commands: Commander,
    pub machine: MachineConfig,
    /// The machine file (as hob-rt's): what commissioning measures for and writes.
    pub machine_file: PathBuf,
    pub library: Library,
    /// The logger's directory (cut reports), when given.
    pub log_dir: Option<PathBuf>,
    /// The `hello` the page gets: the machine's name, limits and signal names, the panel's
    /// level and what it may.
    pub hello: serde_json::Value,
    /// The panel's user level (`hob-hmi --level`, at most its own user's at the gateway):
    /// what it may change in the library ([`App::may`]); the loop's commands are the
    /// gateway's to allow.
    pub level: Role,
    /// The program this HMI loaded last (accepted by the loop): its name, plan and the
    /// [`hob_ipc::program_hash`] of the text sent; used while the loop publishes that hash.
    pub loaded: Mutex<Option<Loaded>>,
    /// The COMPENSATE screen: the `hob` CLI it runs, the checker's folder, what PREVIEW
    /// holds for WRITE.
    pub compensation: crate::compensation::Compensation,
    /// The last answer of [`App::changed_since_load`]: when, for which loop program, what.
    changed: Mutex<Option<(Instant, u64, bool)>>,
}

/// How long [`App::changed_since_load`] keeps its answer before it reads the file again.
const CHANGED_CHECK_EVERY: Duration = Duration::from_secs(1);

impl App {
    pub fn new(
        hub: Hub,
        commands: Commander,
        machine: MachineConfig,
        machine_file: PathBuf,
        library: Library,
        log_dir: Option<PathBuf>,
        level: Role,
    ) -> Self {
        let hello = hello(&machine, level);
        Self {
            level,
            hub,
            commands,
            machine,
            machine_file,
            library,
            log_dir,
            hello,
            loaded: Mutex::new(None),
            compensation: crate::compensation::Compensation::new(crate::compensation::Setup {
                hob: crate::compensation::Setup::hob_beside_me(),
                measurements_dir: None,
            }),
            changed: Mutex::new(None),
        }
    }

    /// With the COMPENSATE screen's `hob` CLI and checker's folder (`hob-hmi --hob`,
    /// `--measurements-dir`).
    pub fn with_compensation(self, setup: crate::compensation::Setup) -> Self {
        Self {
            compensation: crate::compensation::Compensation::new(setup),
            ..self
        }
    }

    /// Why the panel's level may not `action`, naming the level and the one that may
    /// (`None`: it may).
    pub fn not_allowed(&self, action: Action) -> Option<String> {
        if self.level.allows(action) {
            return None;
        }
        let needs = Role::ALL
            .into_iter()
            .find(|r| r.allows(action))
            .unwrap_or(Role::Build);
        Some(crate::words::tr(&format!(
            "this panel is at the {} level, which may not {}: {} {}'s work",
            self.level.level(),
            action.words(),
            if needs.level().starts_with(['a', 'e', 'i', 'o', 'u']) {
                "an"
            } else {
                "a"
            },
            needs.level()
        )))
    }

    /// Whether the panel's level may `action`: else a refusal in words (HTTP 403) naming
    /// the level and the one that may.
    pub fn may(&self, action: Action) -> Result<(), Box<axum::response::Response>> {
        use axum::response::IntoResponse;
        match self.not_allowed(action) {
            None => Ok(()),
            Some(refused) => Err(Box::new(
                (
                    axum::http::StatusCode::FORBIDDEN,
                    axum::Json(serde_json::json!({
                        "refused": refused,
                        "problems": [],
                    })),
                )
                    .into_response(),
            )),
        }
    }

    /// A library program as `hob load --lib NAME` sends it: its text with the library tool
    /// filled in (the loop parses and checks it again and answers), and what to remember
    /// once the loop accepts it.
    pub fn load_request(&self, name: &str) -> Result<(CommandRequest, Loaded), Error> {
        let text = self.library.text(Kind::Program, name).map_err(Error::Library)?;
        let origin = self.library.path(Kind::Program, name).map_err(Error::Library)?;
        let resolved = self.library.resolve(&origin, &text).map_err(Error::Library)?;
        let plan =
            hob_setup::planner::plan_source(&origin, &resolved, &self.machine).map_err(Error::Program)?;
        let request = CommandRequest::load_program(&format!("library program {name}"), &resolved)
            .map_err(Error::Request)?;
        Ok((
            request,
            Loaded {
                name: name.to_string(),
                plan,
                hash: hob_ipc::program_hash(&resolved),
            },
        ))
    }

    /// Remembers a program the loop accepted from this HMI.
    pub fn loaded(&self, l: Loaded) {
        *self
            .loaded
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner) = Some(l);
    }

    /// The program this HMI loaded, while the loop's program is that text (its hash).
    pub fn loaded_here(&self, program_hash: u64) -> Option<Loaded> {
        let loaded = self
            .loaded
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        loaded
            .as_ref()
            .filter(|l| program_hash != 0 && l.hash == program_hash)
            .cloned()
    }

    /// The [`hob_ipc::program_hash`] of the program this HMI loaded as its library file
    /// is now (what LOAD would send now), while the loop's program is that one; 0 when the
    /// loop's program is not one this HMI loaded (START and CONTINUE then claim none); 1
    /// when the file cannot be read or planned any more (it changed, for the worse).
    pub fn current_hash(&self, loop_hash: u64) -> u64 {
        match self.loaded_here(loop_hash) {
            Some(l) => self.load_request(&l.name).map_or(1, |(_, now)| now.hash),
            None => 0,
        }
    }

    /// Whether the program this HMI loaded was changed in the library since LOAD (the
    /// loop would refuse START and CONTINUE for it); read again at most once a second.
    pub fn changed_since_load(&self, loop_hash: u64) -> bool {
        let mut last = self
            .changed
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some((at, hash, changed)) = *last
            && hash == loop_hash
            && at.elapsed() < CHANGED_CHECK_EVERY
        {
            return changed;
        }
        let now = self.current_hash(loop_hash);
        let changed = now != 0 && now != loop_hash;
        *last = Some((Instant::now(), loop_hash, changed));
        changed
    }

    /// The time left of the cycle under way (`hob_setup::planner::progress`), when the loop's
    /// program is the one this HMI loaded and a pass runs.
    pub fn time_left_s(&self, s: &crate::protocol::StateView) -> Option<f64> {
        if s.pass == 0 {
            return None;
        }
        let l = self.loaded_here(s.program_hash)?;
        hob_setup::planner::progress::time_left_s(&l.plan, s.pass, s.y_mm.act, s.feed_override_percent)
    }
}

fn hello(m: &MachineConfig, level: Role) -> serde_json::Value {
    let words = |may: bool| {
        Action::ALL
            .iter()
            .filter(|a| level.allows(**a) == may)
            .map(|a| a.words())
            .collect::<Vec<_>>()
    };
    let names = |l: &[(&'static str, hob_setup::config::machine::DigitalBinding)]| {
        l.iter().map(|(n, _)| *n).collect::<Vec<_>>()
    };
    serde_json::json!({
        "server": concat!("hob-hmi ", env!("CARGO_PKG_VERSION")),
        "instance": hob_ipc::instance(),
        "machine": m.machine.name,
        // The table's worm set: the pitch compensation hob-rt loads is this set's (null: the
        // machine file names none, and none is loaded).
        "worm_set": m.table.worm_set,
        "overrides": {
            "feed": [m.overrides.feed_min_percent, m.overrides.feed_max_percent],
            "spindle": [m.overrides.spindle_min_percent, m.overrides.spindle_max_percent],
        },
        "jog": {
            "renew_ms": 100,
            "deadman_ms": m.jog.deadman_timeout_ms,
            "unreferenced_mm_min": m.jog.unreferenced_mm_min,
        },
        "signals": {
            "inputs": names(&m.io.inputs.bindings()),
            "outputs": names(&m.io.outputs.bindings()),
        },
        "commissioning": commissioning(m),
        "level": {
            "name": level.level(),
            "may": words(true),
            "may_not": words(false),
            "allows": Action::ALL.iter().map(|a| (a.key().to_string(), serde_json::Value::Bool(level.allows(*a)))).collect::<serde_json::Map<_, _>>(),
        },
    })
}

/// What the DIAGNOSTICS card tells of the procedures before they are pressed (the panel runs
/// their default options): the speeds the hob spindle will turn at for the encoder and about
/// how long (each speed read, and some 14 s to ramp and settle before it); the table's jogs
/// for the backlash (three, each left to rest) and the gauge the machine file
/// names (`null`: none, the measurement is refused); the response's frequencies, about how
/// long the table swings and how far it creeps meanwhile (`ResponseOptions::announcement`'s
/// figures), and whether the machine file has the drive's `[table.drive_model]` (without it
/// the measurement is refused).
fn commissioning(m: &MachineConfig) -> serde_json::Value {
    let o = hob_commission::encoder::EncoderOptions::default().on_machine(m.spindle.max_spindle_rpm);
    let b = hob_commission::backlash::BacklashOptions::default();
    let r = hob_commission::response::ResponseOptions::default();
    serde_json::json!({
        "encoder": {
            "max_rpm": o.speeds_rpm.iter().fold(0.0f64, |a, &r| a.max(r)),
            "seconds": o.seconds,
            "about_min": (o.about_s() / 60.0).ceil(),
            "speeds_rpm": o.speeds_rpm,
        },
        "backlash": {
            "speed_deg_min": b.speed_deg_min,
            "seconds": b.seconds,
            "travel_deg": b.travel_deg(),
            "about_s": b.about_s().ceil(),
            "gauge_channel": m.io.analog_inputs.table_gauge.map(|g| g.channel),
        },
        "response": {
            "points": r.points,
            "from_hz": r.from_hz,
            "to_hz": r.to_hz,
            "about_s": r.about_s().ceil(),
            "creep_deg": r.creep_deg().ceil(),
            "creep_deg_min": r.creep_deg_min(),
            "drive_model": m.table.drive_model.is_some(),
        },
    })
}
