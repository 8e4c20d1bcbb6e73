//! The operator's program and tool library: a directory (`[library] dir` of the machine
//! file) with `programs/` and `tools/`, one TOML file `<name>.toml` per entry.
//!
//! A program is stored as written (a `[tool]` may name a library tool,
//! `[tool] library = "NAME"`), after it parsed and passed the same checks as `hob check`
//! on the machine; [`Library::resolve`] fills the named tool in, so that the loop only
//! ever receives a self-contained program. A tool is a [`ToolRecord`]: the fields of a
//! program's `[tool]` and what the tool has cut. Every write goes through
//! [`crate::atomic`]; copy and rename never replace an entry.

pub mod name;
mod tool;

pub use name::{NameError, check_name};
pub use tool::{FORMAT_VERSION as TOOL_FORMAT_VERSION, ToolRecord, Usage};

use crate::atomic;
use hob_setup::config::machine::MachineConfig;
use hob_setup::config::source::locate_key;
use hob_setup::config::{LoadError, Problem};
use hob_setup::job::{TOOL_LIBRARY_KEY, ToolReference};
use hob_setup::planner::{Plan, plan_source};
use std::fmt;
use std::io;
use std::path::{Path, PathBuf};

/// Programs or tools.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    Program,
    Tool,
}

impl Kind {
    /// The entry's directory in the library.
    pub fn dir(self) -> &'static str {
        match self {
            Kind::Program => "programs",
            Kind::Tool => "tools",
        }
    }

    pub fn word(self) -> &'static str {
        match self {
            Kind::Program => "program",
            Kind::Tool => "tool",
        }
    }
}

/// Why the library refused (nothing was changed), or could not do its work.
#[derive(Debug)]
pub enum Refusal {
    /// The name is not accepted, and why.
    BadName {
        kind: Kind,
        name: String,
        why: NameError,
    },
    Missing {
        kind: Kind,
        name: String,
    },
    Exists {
        kind: Kind,
        name: String,
    },
    /// The text does not parse or check (`what` says what was being done).
    Invalid {
        what: String,
        error: LoadError,
    },
    /// A program names a library tool that is not in the library.
    MissingTool {
        origin: PathBuf,
        tool: String,
    },
    /// The file system failed (not a refusal of the input).
    Io {
        path: PathBuf,
        error: io::Error,
    },
}

impl Refusal {
    /// Whether the input was fine and the file system failed.
    pub fn is_io(&self) -> bool {
        matches!(self, Refusal::Io { .. })
    }
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Refusal::BadName { kind, name, why } => write!(f, "{} name {name:?} {why}", kind.word()),
            Refusal::Missing { kind, name } => write!(
                f,
                "no {} {name:?} in the library (hob lib {} list)",
                kind.word(),
                kind.dir()
            ),
            Refusal::Exists { kind, name } => {
                write!(f, "the library already has a {} {name:?}", kind.word())
            }
            Refusal::Invalid { what, error } => write!(f, "{what}: {error}"),
            Refusal::MissingTool { origin, tool } => write!(
                f,
                "{}: {TOOL_LIBRARY_KEY}: names the library tool {tool:?}, which is not in the library (hob lib tools list)",
                origin.display()
            ),
            Refusal::Io { path, error } => write!(f, "{}: {error}", path.display()),
        }
    }
}

impl std::error::Error for Refusal {}

/// One entry of a listing: its name, and why it is not usable (`None`: valid).
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    pub name: String,
    pub problem: Option<String>,
}

/// An open library.
#[derive(Debug, Clone)]
pub struct Library {
    dir: PathBuf,
}

fn io_error(path: &Path) -> impl FnOnce(io::Error) -> Refusal + '_ {
    move |error| Refusal::Io {
        path: path.to_path_buf(),
        error,
    }
}

/// A tool's text parsed and validated; refused as `tool NAME not <not_done>`.
fn check_tool(path: &Path, name: &str, not_done: &str, text: &str) -> Result<ToolRecord, Refusal> {
    ToolRecord::parse(path, text).map_err(|error| Refusal::Invalid {
        what: format!("tool {name:?} not {not_done}"),
        error,
    })
}

/// A load error on one line, for listings.
fn one_line(e: &LoadError) -> String {
    e.to_string().replace("\n  ", "; ")
}

/// A listed entry from its check: valid, or the reason in one line; a file system error
/// stops the listing.
fn entry<T>(name: String, checked: Result<T, Refusal>) -> Result<Entry, Refusal> {
    let problem = match checked {
        Ok(_) => None,
        Err(e) if e.is_io() => return Err(e),
        Err(Refusal::Invalid { error, .. }) => Some(one_line(&error)),
        Err(e) => Some(e.to_string()),
    };
    Ok(Entry { name, problem })
}

impl Library {
    /// Opens the library in `dir`, creating it and its `programs/` and `tools/` when
    /// missing.
    pub fn open(dir: &Path) -> Result<Self, Refusal> {
        for kind in [Kind::Program, Kind::Tool] {
            let sub = dir.join(kind.dir());
            std::fs::create_dir_all(&sub).map_err(io_error(&sub))?;
        }
        Ok(Self {
            dir: dir.to_path_buf(),
        })
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The file of an entry; refused when the name is not accepted.
    pub fn path(&self, kind: Kind, name: &str) -> Result<PathBuf, Refusal> {
        check_name(name).map_err(|why| Refusal::BadName {
            kind,
            name: name.to_string(),
            why,
        })?;
        Ok(self.dir.join(kind.dir()).join(name::file_name(name)))
    }

    /// The entries' names, sorted; temporary and foreign files are skipped.
    pub fn names(&self, kind: Kind) -> Result<Vec<String>, Refusal> {
        let dir = self.dir.join(kind.dir());
        let mut names = Vec::new();
        for e in std::fs::read_dir(&dir).map_err(io_error(&dir))? {
            let e = e.map_err(io_error(&dir))?;
            if !e.file_type().map_err(io_error(&dir))?.is_file() {
                continue;
            }
            if let Some(n) = e.file_name().to_str().and_then(name::entry_name) {
                names.push(n.to_string());
            }
        }
        names.sort();
        Ok(names)
    }

    /// An entry's text as stored.
    pub fn text(&self, kind: Kind, name: &str) -> Result<String, Refusal> {
        let path = self.path(kind, name)?;
        std::fs::read_to_string(&path).map_err(|error| match error.kind() {
            io::ErrorKind::NotFound => Refusal::Missing {
                kind,
                name: name.to_string(),
            },
            _ => Refusal::Io { path, error },
        })
    }

    /// The programs, each checked as `hob check` checks it on `machine` (its library tool
    /// resolved).
    pub fn list_programs(&self, machine: &MachineConfig) -> Result<Vec<Entry>, Refusal> {
        self.names(Kind::Program)?
            .into_iter()
            .map(|name| {
                let text = self.text(Kind::Program, &name)?;
                let origin = self.path(Kind::Program, &name)?;
                entry(name, self.check_program(&origin, &text, machine))
            })
            .collect()
    }

    /// The tools, each validated.
    pub fn list_tools(&self) -> Result<Vec<Entry>, Refusal> {
        self.names(Kind::Tool)?
            .into_iter()
            .map(|name| {
                let checked = self.tool(&name);
                entry(name, checked)
            })
            .collect()
    }

    /// A tool, parsed and validated.
    pub fn tool(&self, name: &str) -> Result<ToolRecord, Refusal> {
        let text = self.text(Kind::Tool, name)?;
        let path = self.path(Kind::Tool, name)?;
        ToolRecord::parse(&path, &text).map_err(|error| Refusal::Invalid {
            what: format!("tool {name:?}"),
            error,
        })
    }

    /// A program's text with its library tool filled in: self-contained TOML that
    /// [`hob_setup::job::Program::parse`] accepts. A program without a reference comes back
    /// unchanged; one that names a missing tool is refused with the tool's name; one with
    /// both a reference and tool fields is refused.
    pub fn resolve(&self, origin: &Path, program_text: &str) -> Result<String, Refusal> {
        let invalid = |error| Refusal::Invalid {
            what: format!("program {}", origin.display()),
            error,
        };
        let Some(reference) = ToolReference::find(origin, program_text).map_err(invalid)? else {
            return Ok(program_text.to_string());
        };
        let problem = |message: String| {
            invalid(LoadError::Invalid {
                file: origin.to_path_buf(),
                problems: vec![Problem {
                    key: TOOL_LIBRARY_KEY.into(),
                    message,
                    position: locate_key(program_text, TOOL_LIBRARY_KEY),
                }],
            })
        };
        if !reference.tool_keys.is_empty() {
            return Err(problem(reference.both_message()));
        }
        if let Err(why) = check_name(&reference.library) {
            return Err(problem(format!("tool name {:?} {why}", reference.library)));
        }
        let record = self.tool(&reference.library).map_err(|e| match e {
            Refusal::Missing { name, .. } => Refusal::MissingTool {
                origin: origin.to_path_buf(),
                tool: name,
            },
            other => other,
        })?;
        let mut table: toml::Table =
            toml::from_str(program_text).map_err(|e| problem(format!("not TOML: {}", e.message())))?;
        let tool = toml::Value::try_from(&record.tool)
            .map_err(|e| problem(format!("the library tool does not serialise: {e}")))?;
        table.insert("tool".into(), tool);
        let body = toml::to_string(&table)
            .map_err(|e| problem(format!("the resolved program does not serialise: {e}")))?;
        Ok(format!(
            "# {}, with the library tool {:?} filled in\n{body}",
            origin.display(),
            reference.library
        ))
    }

    /// Resolves and checks a program's text on `machine`, as `hob check` does.
    pub fn check_program(&self, origin: &Path, text: &str, machine: &MachineConfig) -> Result<Plan, Refusal> {
        let resolved = self.resolve(origin, text)?;
        plan_source(origin, &resolved, machine).map_err(|error| Refusal::Invalid {
            what: format!("program {}", origin.display()),
            error,
        })
    }

    /// Stores a new program; refused (nothing written) when the name is taken or the text
    /// does not parse and check on `machine`.
    pub fn create_program(&self, name: &str, text: &str, machine: &MachineConfig) -> Result<Plan, Refusal> {
        let path = self.path(Kind::Program, name)?;
        self.refuse_existing(Kind::Program, name, &path)?;
        let plan = self.check_entry(&path, name, "created", text, machine)?;
        self.write_new(Kind::Program, name, &path, text)?;
        Ok(plan)
    }

    /// Writes a changed program over an existing one (atomically: a crash leaves the old or
    /// the new file); refused (nothing written) when it does not exist or the text does not
    /// parse and check on `machine`.
    pub fn replace_program(&self, name: &str, text: &str, machine: &MachineConfig) -> Result<Plan, Refusal> {
        let path = self.path(Kind::Program, name)?;
        self.refuse_missing(Kind::Program, name, &path)?;
        let plan = self.check_entry(&path, name, "changed", text, machine)?;
        atomic::write_atomic(&path, text.as_bytes()).map_err(io_error(&path))?;
        Ok(plan)
    }

    fn check_entry(
        &self,
        path: &Path,
        name: &str,
        not_done: &str,
        text: &str,
        machine: &MachineConfig,
    ) -> Result<Plan, Refusal> {
        self.check_program(path, text, machine).map_err(|e| match e {
            Refusal::Invalid { error, .. } => Refusal::Invalid {
                what: format!("program {name:?} not {not_done}"),
                error,
            },
            other => other,
        })
    }

    /// Stores a new tool; refused (nothing written) when the name is taken or the text is
    /// not a valid tool record.
    pub fn create_tool(&self, name: &str, text: &str) -> Result<ToolRecord, Refusal> {
        let path = self.path(Kind::Tool, name)?;
        self.refuse_existing(Kind::Tool, name, &path)?;
        let record = check_tool(&path, name, "created", text)?;
        self.write_new(Kind::Tool, name, &path, text)?;
        Ok(record)
    }

    /// Writes a changed tool over an existing one (atomically, as
    /// [`Library::replace_program`]); refused (nothing written) when it does not exist or
    /// the text is not a valid tool record. What the tool has cut is recorded by the cuts
    /// ([`Library::record_usage`]), never typed: a text without `[usage]` keeps the stored
    /// usage (written after the text), one with another usage than the stored one is
    /// refused. Over a stored file that no longer parses, the text is taken as it is.
    pub fn replace_tool(&self, name: &str, text: &str) -> Result<ToolRecord, Refusal> {
        let path = self.path(Kind::Tool, name)?;
        self.refuse_missing(Kind::Tool, name, &path)?;
        let stored = match self.tool(name) {
            Ok(r) => Some(r.usage),
            Err(Refusal::Invalid { .. }) => None,
            Err(e) => return Err(e),
        };
        let mut record = check_tool(&path, name, "changed", text)?;
        let gives_usage = toml::from_str::<toml::Table>(text).is_ok_and(|t| t.contains_key("usage"));
        let mut written = text.to_string();
        match stored {
            Some(usage) if gives_usage => {
                let mut p = hob_setup::config::Problems::new();
                p.require(record.usage == usage, "usage", || {
                    format!(
                        "is what the tool has cut, recorded after each cut, and stays as stored \
                         ({usage:?}); leave [usage] out or as it is"
                    )
                });
                p.into_result(&path, text).map_err(|error| Refusal::Invalid {
                    what: format!("tool {name:?} not changed"),
                    error,
                })?;
            }
            Some(usage) => {
                #[derive(serde::Serialize)]
                struct UsageTable<'a> {
                    usage: &'a Usage,
                }
                let table = toml::to_string(&UsageTable { usage: &usage }).map_err(|e| Refusal::Io {
                    path: path.clone(),
                    error: io::Error::other(format!("the stored usage does not serialise: {e}")),
                })?;
                if !written.ends_with('\n') {
                    written.push('\n');
                }
                written.push('\n');
                written.push_str(&table);
                record.usage = usage;
            }
            None => {}
        }
        atomic::write_atomic(&path, written.as_bytes()).map_err(io_error(&path))?;
        Ok(record)
    }

    /// Copies an entry under a new name (never over an existing one).
    pub fn copy(&self, kind: Kind, from: &str, to: &str) -> Result<(), Refusal> {
        let target = self.path(kind, to)?;
        let text = self.text(kind, from)?;
        self.write_new(kind, to, &target, &text)
    }

    /// Renames an entry (never over an existing one).
    pub fn rename(&self, kind: Kind, from: &str, to: &str) -> Result<(), Refusal> {
        let source = self.path(kind, from)?;
        let target = self.path(kind, to)?;
        self.refuse_missing(kind, from, &source)?;
        atomic::rename_new(&source, &target).map_err(|error| match error.kind() {
            io::ErrorKind::AlreadyExists => Refusal::Exists {
                kind,
                name: to.to_string(),
            },
            _ => Refusal::Io { path: target, error },
        })
    }

    /// Deletes an entry.
    pub fn delete(&self, kind: Kind, name: &str) -> Result<(), Refusal> {
        let path = self.path(kind, name)?;
        self.refuse_missing(kind, name, &path)?;
        atomic::remove(&path).map_err(io_error(&path))
    }

    /// Adds a cut's usage to a tool: `passes` passes, `y_travel_m` metres of Y in the cut,
    /// last used `when_utc` (`YYYY-MM-DDTHH:MM:SSZ`). Two processes recording at the same
    /// moment may lose one record (read, add, replace); the frontends record after a cut.
    pub fn record_usage(
        &self,
        name: &str,
        passes: u64,
        y_travel_m: f64,
        when_utc: &str,
    ) -> Result<ToolRecord, Refusal> {
        let mut record = self.tool(name)?;
        let path = self.path(Kind::Tool, name)?;
        record.usage.passes_cut = record.usage.passes_cut.saturating_add(passes);
        record.usage.y_travel_in_cut_m += y_travel_m;
        record.usage.last_used_utc = Some(when_utc.to_string());
        let text = record.to_toml();
        // The added values are checked as the file's keys.
        let mut p = hob_setup::config::Problems::new();
        p.non_negative("y_travel_m", y_travel_m);
        record.validate(&mut p);
        p.into_result(&path, &text).map_err(|error| Refusal::Invalid {
            what: format!("usage of tool {name:?} not recorded"),
            error,
        })?;
        atomic::write_atomic(&path, text.as_bytes()).map_err(io_error(&path))?;
        Ok(record)
    }

    fn refuse_existing(&self, kind: Kind, name: &str, path: &Path) -> Result<(), Refusal> {
        if path.exists() {
            return Err(Refusal::Exists {
                kind,
                name: name.to_string(),
            });
        }
        Ok(())
    }

    fn refuse_missing(&self, kind: Kind, name: &str, path: &Path) -> Result<(), Refusal> {
        if !path.is_file() {
            return Err(Refusal::Missing {
                kind,
                name: name.to_string(),
            });
        }
        Ok(())
    }

    fn write_new(&self, kind: Kind, name: &str, path: &Path, text: &str) -> Result<(), Refusal> {
        atomic::write_new(path, text.as_bytes()).map_err(|error| match error.kind() {
            io::ErrorKind::AlreadyExists => Refusal::Exists {
                kind,
                name: name.to_string(),
            },
            _ => Refusal::Io {
                path: path.to_path_buf(),
                error,
            },
        })
    }
}

#[cfg(test)]
mod tests;
