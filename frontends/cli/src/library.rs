//! `hob lib programs|tools ...`, `hob load --lib NAME`, and the library behind `hob check`,
//! `hob plan` and `hob load` when a program's `[tool]` names a library tool: the program
//! and tool library of `hob_store::library`, in the directory `--library DIR`, else
//! `$HOB_LIBRARY`, else `[library] dir` of the machine file.
//!
//! Exit statuses as every `hob` command: 0 done, 2 refused (bad name, missing or existing
//! entry, a program or tool that does not check; nothing is written), 1 anything else.

use crate::util::{Failure, emit, load_machine};
use hob_setup::config::LoadError;
use hob_setup::config::machine::MachineConfig;
use hob_setup::job::ToolReference;
use hob_setup::planner::Plan;
use hob_store::library::{Entry, Kind, Library, Refusal};
use std::path::{Path, PathBuf};

/// The environment variable that names the library directory (below `--library`, above
/// the machine file).
pub const LIBRARY_ENV: &str = "HOB_LIBRARY";

/// What `hob lib programs|tools` does.
#[derive(Debug, Clone)]
pub enum Action {
    List,
    Show(String),
    Create {
        name: String,
        file: PathBuf,
    },
    Copy {
        from: String,
        to: String,
    },
    Rename {
        from: String,
        to: String,
    },
    Delete(String),
    /// Tools only: add a recorded cut's passes and Y travel in the cut.
    RecordUsage {
        name: String,
        log: PathBuf,
        when_utc: Option<String>,
    },
}

/// Where the library is, and the machine file when one is needed.
#[derive(Debug, Clone, Default)]
pub struct Place {
    pub library: Option<PathBuf>,
    pub machine: Option<PathBuf>,
}

impl Place {
    /// `--library`, else `$HOB_LIBRARY`, else `[library] dir` of the machine file.
    pub fn dir(&self, machine: Option<&MachineConfig>) -> Result<PathBuf, Failure> {
        if let Some(d) = &self.library {
            return Ok(d.clone());
        }
        if let Some(d) = std::env::var_os(LIBRARY_ENV).filter(|d| !d.is_empty()) {
            return Ok(PathBuf::from(d));
        }
        match machine {
            Some(m) => Ok(PathBuf::from(&m.library.dir)),
            None => Ok(PathBuf::from(&load_machine(self.machine.as_deref())?.library.dir)),
        }
    }

    pub fn open(&self, machine: Option<&MachineConfig>) -> Result<Library, Failure> {
        Library::open(&self.dir(machine)?).map_err(refused)
    }
}

/// A library refusal as `hob` reports it: exit 2 (refused) or 1 (the file system).
pub fn refused(r: Refusal) -> Failure {
    if r.is_io() {
        Failure::Other(r.to_string())
    } else {
        eprintln!("hob: refused: {r}");
        Failure::Exit(2)
    }
}

fn read_file(file: &Path) -> Result<String, Failure> {
    std::fs::read_to_string(file).map_err(|error| {
        Failure::Refused(LoadError::Io {
            file: file.to_path_buf(),
            error,
        })
    })
}

fn listing(kind: Kind, dir: &Path, entries: &[Entry]) -> String {
    if entries.is_empty() {
        return format!("{}: no {}s\n", dir.join(kind.dir()).display(), kind.word());
    }
    let width = entries.iter().map(|e| e.name.len()).max().unwrap_or(0);
    entries
        .iter()
        .map(|e| match &e.problem {
            None => format!("{:width$}  ok\n", e.name),
            Some(p) => format!("{:width$}  INVALID: {p}\n", e.name),
        })
        .collect()
}

fn passes_text(plan: &Plan) -> String {
    format!(
        "{} pass{}, {:.0} s",
        plan.passes.len(),
        if plan.passes.len() == 1 { "" } else { "es" },
        plan.total_time_s
    )
}

/// `hob lib programs|tools ACTION`.
pub fn run(kind: Kind, action: Action, place: &Place) -> Result<(), Failure> {
    let word = kind.word();
    // Programs are checked on the machine; tools need it only to find the library.
    let machine = match (&action, kind) {
        (Action::List | Action::Create { .. }, Kind::Program) => {
            Some(load_machine(place.machine.as_deref())?)
        }
        _ => None,
    };
    let lib = place.open(machine.as_ref())?;
    match action {
        Action::List => {
            let entries = match &machine {
                Some(m) => lib.list_programs(m),
                None => lib.list_tools(),
            }
            .map_err(refused)?;
            emit(&listing(kind, lib.dir(), &entries))
        }
        Action::Show(name) => emit(&lib.text(kind, &name).map_err(refused)?),
        Action::Create { name, file } => {
            let text = read_file(&file)?;
            let what = match (kind, &machine) {
                (Kind::Program, Some(m)) => {
                    passes_text(&lib.create_program(&name, &text, m).map_err(refused)?)
                }
                _ => {
                    let r = lib.create_tool(&name, &text).map_err(refused)?;
                    format!("{:?}, module {} mm", r.tool.kind, r.tool.module_mm).to_lowercase()
                }
            };
            emit(&format!(
                "{word} {name} created in {}: {what}\n",
                lib.dir().display()
            ))
        }
        Action::Copy { from, to } => {
            lib.copy(kind, &from, &to).map_err(refused)?;
            emit(&format!("{word} {from} copied to {to}\n"))
        }
        Action::Rename { from, to } => {
            lib.rename(kind, &from, &to).map_err(refused)?;
            emit(&format!("{word} {from} renamed to {to}\n"))
        }
        Action::Delete(name) => {
            lib.delete(kind, &name).map_err(refused)?;
            emit(&format!("{word} {name} deleted\n"))
        }
        Action::RecordUsage { name, log, when_utc } => {
            let report = hob_logger::export::report(&log).map_err(|e| {
                eprintln!("hob: refused: {e}");
                Failure::Exit(2)
            })?;
            let cut: Vec<_> = report.passes.iter().filter(|p| p.cut_time_s > 0.0).collect();
            let y_travel_m = cut.iter().map(|p| p.y_travel_in_cut_mm).sum::<f64>() / 1000.0;
            let when = when_utc.unwrap_or_else(hob_store::utc::now);
            let r = lib
                .record_usage(&name, cut.len() as u64, y_travel_m, &when)
                .map_err(refused)?;
            emit(&format!(
                "tool {name}: +{} pass{} and {:.4} m of Y in the cut from {}; now {} passes, {:.4} m, last used {}\n",
                cut.len(),
                if cut.len() == 1 { "" } else { "es" },
                y_travel_m,
                log.display(),
                r.usage.passes_cut,
                r.usage.y_travel_in_cut_m,
                r.usage.last_used_utc.as_deref().unwrap_or("never")
            ))
        }
    }
}

/// A program's text made self-contained: its library tool filled in from the library
/// (opened only when the program names one).
pub fn resolve(
    origin: &Path,
    text: &str,
    place: &Place,
    machine: Option<&MachineConfig>,
) -> Result<String, Failure> {
    match ToolReference::find(origin, text).map_err(Failure::Refused)? {
        None => Ok(text.to_string()),
        Some(_) => place.open(machine)?.resolve(origin, text).map_err(refused),
    }
}

/// `hob check PROGRAM` and `hob plan PROGRAM`: the program's file, its library tool
/// resolved, parsed, checked and planned on `machine`.
pub fn plan_file(file: &Path, place: &Place, machine: &MachineConfig) -> Result<Plan, Failure> {
    let text = read_file(file)?;
    let resolved = resolve(file, &text, place, Some(machine))?;
    hob_setup::planner::plan_source(file, &resolved, machine).map_err(Failure::Refused)
}

/// What `hob load` sends: the name and the self-contained text of a program file or of a
/// library program (`lib`).
pub fn load_text(file: Option<&Path>, lib: Option<&str>, place: &Place) -> Result<(String, String), Failure> {
    match (file, lib) {
        (Some(file), None) => {
            let text = read_file(file)?;
            let resolved = resolve(file, &text, place, None)?;
            Ok((file.display().to_string(), resolved))
        }
        (None, Some(name)) => {
            let library = place.open(None)?;
            let text = library.text(Kind::Program, name).map_err(refused)?;
            let origin = library.path(Kind::Program, name).map_err(refused)?;
            let resolved = library.resolve(&origin, &text).map_err(refused)?;
            Ok((format!("library program {name}"), resolved))
        }
        _ => {
            eprintln!("hob: refused: load: give a PROGRAM file or --lib NAME (one of them)");
            Err(Failure::Exit(2))
        }
    }
}
