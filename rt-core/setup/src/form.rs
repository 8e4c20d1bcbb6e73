//! A program checked table by table, for an editor whose sub-menus are the program's
//! tables (the HMI's WORKPIECE, TOOL, CYCLE, STRATEGY): each table is read on its own, so a
//! table still empty or wrong does not hide the state of the others; then, when all four
//! read, the whole program is checked and planned as `hob check` does, and every problem
//! goes to its table by its key.

use crate::config::machine::MachineConfig;
use crate::config::source::key_at;
use crate::config::{Problem, Problems};
use crate::job::{Cycle, Program, Strategy, Tool, Workpiece};
use crate::planner::{self, Plan};
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::fmt;

/// The program's tables, in the order of the sub-menus.
pub const SECTIONS: [&str; 4] = ["workpiece", "tool", "cycle", "strategy"];

/// The state of one table.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SectionState {
    /// Complete and valid (as far as the tables given can be checked).
    Ok,
    /// Not there at all.
    Missing,
    /// There, with a problem.
    Invalid,
}

/// The check of a program's text, table by table.
#[derive(Debug, Clone, PartialEq)]
pub struct SectionCheck {
    pub sections: Vec<(&'static str, SectionState)>,
    /// Each with the key path of its field (`workpiece.teeth`, `strategy.rough_depths_mm[1]`).
    pub problems: Vec<Problem>,
    /// The plan, when every table is complete and the program checks on the machine.
    pub plan: Option<Plan>,
}

impl SectionCheck {
    pub fn state(&self, section: &str) -> Option<SectionState> {
        self.sections
            .iter()
            .find(|(s, _)| *s == section)
            .map(|(_, st)| *st)
    }
}

fn problem(key: String, message: impl Into<String>) -> Problem {
    Problem {
        key,
        message: message.into(),
        position: None,
    }
}

/// One table read alone: its value, or the problems by key.
fn read_section<T: DeserializeOwned>(section: &str, table: &toml::Table) -> Result<T, Vec<Problem>> {
    // Written out on its own, so the parser's error points into this table's text.
    let text = toml::to_string(table).map_err(|e| vec![problem(section.into(), e.to_string())])?;
    toml::from_str::<T>(&text).map_err(|e| {
        let message = e.message().trim().to_string();
        let field = message
            .strip_prefix("missing field `")
            .or_else(|| message.strip_prefix("unknown field `"))
            .and_then(|r| r.split('`').next());
        let key = match (field, e.span()) {
            (Some(f), _) if message.starts_with("missing") => format!("{section}.{f}"),
            (_, Some(span)) => {
                key_at(&text, span.start).map_or_else(|| section.to_string(), |k| format!("{section}.{k}"))
            }
            (Some(f), None) => format!("{section}.{f}"),
            (None, None) => section.to_string(),
        };
        vec![problem(key, hob_config::in_words(&message))]
    })
}

/// Checks `src` table by table on `machine`. `resolve_tool` gives a library tool's table
/// for `[tool] library = "NAME"`, or its own error, shown as the problem of `tool.library`.
pub fn check_sections<E: fmt::Display>(
    src: &str,
    machine: &MachineConfig,
    resolve_tool: &dyn Fn(&str) -> Result<toml::Table, E>,
) -> SectionCheck {
    let root: toml::Table = match src.parse() {
        Ok(t) => t,
        Err(e) => return not_toml(&e),
    };
    let mut problems = unknown_tables(&root);
    let table = |s: &str| root.get(s).and_then(toml::Value::as_table);
    let tool_table = tool_table(table("tool"), resolve_tool, &mut problems);
    let sections = Sections {
        workpiece: table("workpiece").map(|t| read_section::<Workpiece>("workpiece", t)),
        tool: tool_table.as_ref().map(|t| read_section::<Tool>("tool", t)),
        cycle: table("cycle").map(|t| read_section::<Cycle>("cycle", t)),
        strategy: table("strategy").map(|t| read_section::<Strategy>("strategy", t)),
    };
    // The tool alone can be checked without the gear.
    if let Some(Ok(t)) = &sections.tool {
        let mut p = Problems::new();
        t.check(&mut p);
        problems.extend(p.as_slice().iter().cloned());
    }
    let plan = sections.plan(machine, &mut problems);
    let sections = section_states(&root, &problems);
    let plan = if problems.is_empty() { plan } else { None };
    SectionCheck {
        sections,
        problems,
        plan,
    }
}

/// The check of a text that is not TOML: every table invalid.
fn not_toml(e: &toml::de::Error) -> SectionCheck {
    SectionCheck {
        sections: SECTIONS.iter().map(|s| (*s, SectionState::Invalid)).collect(),
        problems: vec![problem(
            String::new(),
            format!("not TOML: {}", e.message().trim()),
        )],
        plan: None,
    }
}

/// A problem for each top-level key that is not one of the program's tables.
fn unknown_tables(root: &toml::Table) -> Vec<Problem> {
    root.keys()
        .filter(|k| !SECTIONS.contains(&k.as_str()))
        .map(|k| {
            problem(
                k.clone(),
                format!("a program has no table {k:?}: only {}", SECTIONS.join(", ")),
            )
        })
        .collect()
}

/// The `[tool]` table to read: as written, or the library tool it names; None (with the
/// problem of `tool.library`) when it names one with other fields too or one that does not
/// resolve.
fn tool_table<E: fmt::Display>(
    written: Option<&toml::Table>,
    resolve_tool: &dyn Fn(&str) -> Result<toml::Table, E>,
    problems: &mut Vec<Problem>,
) -> Option<toml::Table> {
    let t = written?;
    let Some(name) = t.get("library").and_then(toml::Value::as_str) else {
        return Some(t.clone());
    };
    if t.len() > 1 {
        problems.push(problem(
            "tool.library".into(),
            "a library tool or the tool's own fields, not both",
        ));
        return None;
    }
    match resolve_tool(name) {
        Ok(resolved) => Some(resolved),
        Err(why) => {
            problems.push(problem("tool.library".into(), why.to_string()));
            None
        }
    }
}

/// The four tables, each read alone (None: not there).
struct Sections {
    workpiece: Option<Result<Workpiece, Vec<Problem>>>,
    tool: Option<Result<Tool, Vec<Problem>>>,
    cycle: Option<Result<Cycle, Vec<Problem>>>,
    strategy: Option<Result<Strategy, Vec<Problem>>>,
}

impl Sections {
    /// With every table read, the whole program checked and planned on `machine` (its
    /// problems added unless already there); otherwise the tables' reading problems added.
    fn plan(self, machine: &MachineConfig, problems: &mut Vec<Problem>) -> Option<Plan> {
        match (&self.workpiece, &self.tool, &self.cycle, &self.strategy) {
            (Some(Ok(w)), Some(Ok(t)), Some(Ok(c)), Some(Ok(s))) => {
                let program = Program {
                    workpiece: w.clone(),
                    tool: t.clone(),
                    cycle: c.clone(),
                    strategy: s.clone(),
                };
                let mut p = Problems::new();
                let plan = planner::plan(&program, machine, &mut p);
                for q in p.as_slice() {
                    if !problems.iter().any(|x| x.key == q.key && x.message == q.message) {
                        problems.push(q.clone());
                    }
                }
                plan
            }
            _ => {
                let errors = [
                    self.workpiece.and_then(Result::err),
                    self.tool.and_then(Result::err),
                    self.cycle.and_then(Result::err),
                    self.strategy.and_then(Result::err),
                ];
                problems.extend(errors.into_iter().flatten().flatten());
                None
            }
        }
    }
}

/// Each table's state: missing, or invalid when a problem's key is in it.
fn section_states(root: &toml::Table, problems: &[Problem]) -> Vec<(&'static str, SectionState)> {
    SECTIONS
        .iter()
        .map(|s| {
            let present = root.get(*s).and_then(toml::Value::as_table).is_some();
            let mine = problems
                .iter()
                .any(|p| p.key == *s || p.key.starts_with(&format!("{s}.")));
            let state = match (present, mine) {
                (false, _) => SectionState::Missing,
                (true, true) => SectionState::Invalid,
                (true, false) => SectionState::Ok,
            };
            (*s, state)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::machine::shipped_for_tests;
    use std::path::Path;

    /// A library without tools: its refusal.
    struct NoTool(String);

    impl fmt::Display for NoTool {
        fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            write!(f, "no library tool {:?}", self.0)
        }
    }

    fn no_library(name: &str) -> Result<toml::Table, NoTool> {
        Err(NoTool(name.to_string()))
    }

    fn programs() -> Vec<(std::path::PathBuf, String)> {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/programs");
        let mut v: Vec<_> = std::fs::read_dir(dir)
            .expect("programs")
            .map(|e| {
                let p = e.expect("entry").path();
                let s = std::fs::read_to_string(&p).expect("read");
                (p, s)
            })
            .collect();
        v.sort();
        v
    }

    #[test]
    fn every_shipped_program_is_green_everywhere_with_the_plan_hob_check_gives() {
        let m = shipped_for_tests();
        for (path, src) in programs() {
            let c = check_sections(&src, &m, &no_library);
            assert!(c.problems.is_empty(), "{}: {:?}", path.display(), c.problems);
            assert!(
                c.sections.iter().all(|(_, s)| *s == SectionState::Ok),
                "{}",
                path.display()
            );
            let want = crate::planner::plan_source(&path, &src, &m).expect("hob check");
            assert_eq!(c.plan.as_ref(), Some(&want), "{}", path.display());
        }
    }

    fn demo() -> String {
        programs()
            .into_iter()
            .find(|(p, _)| p.ends_with("demo-short-spur-z17-m5.toml"))
            .expect("demo")
            .1
    }

    #[test]
    fn a_typo_is_red_on_its_table_only_and_named_by_its_key() {
        let m = shipped_for_tests();
        let c = check_sections(&demo().replace("teeth = 17", "teeth = \"1O\""), &m, &no_library);
        assert_eq!(c.state("workpiece"), Some(SectionState::Invalid));
        for s in ["tool", "cycle", "strategy"] {
            assert_eq!(c.state(s), Some(SectionState::Ok), "{s}: {:?}", c.problems);
        }
        assert_eq!(c.problems.len(), 1, "{:?}", c.problems);
        assert_eq!(c.problems[0].key, "workpiece.teeth");
        assert!(c.plan.is_none());
    }

    #[test]
    fn an_empty_tool_does_not_hide_the_other_tables() {
        let m = shipped_for_tests();
        let src = demo();
        let start = src.find("[tool]").expect("tool");
        let end = src.find("[cycle]").expect("cycle");
        let without_tool = format!("{}{}", &src[..start], &src[end..]);
        let c = check_sections(&without_tool, &m, &no_library);
        assert_eq!(c.state("tool"), Some(SectionState::Missing));
        assert_eq!(c.state("workpiece"), Some(SectionState::Ok));
        // A workpiece missing its teeth is red, named by the missing key, while TOOL is missing.
        let c = check_sections(&without_tool.replace("teeth = 17\n", ""), &m, &no_library);
        assert_eq!(c.state("workpiece"), Some(SectionState::Invalid));
        assert!(
            c.problems.iter().any(|p| p.key == "workpiece.teeth"),
            "{:?}",
            c.problems
        );
        // A tool alone is checked on its own: a pressure angle of 50 deg.
        let c = check_sections(
            &src.replace("pressure_angle_deg = 20.0", "pressure_angle_deg = 50.0"),
            &m,
            &no_library,
        );
        assert_eq!(c.state("tool"), Some(SectionState::Invalid));
        assert!(
            c.problems.iter().any(|p| p.key == "tool.pressure_angle_deg"),
            "{:?}",
            c.problems
        );
        // A library tool comes from the resolver; a missing one is the resolver's refusal.
        let library_src = format!("{}[tool]\nlibrary = \"hob-m5\"\n\n{}", &src[..start], &src[end..]);
        let c = check_sections(&library_src, &m, &no_library);
        assert_eq!(c.state("tool"), Some(SectionState::Invalid));
        assert_eq!(c.problems[0].key, "tool.library");
        let tool: toml::Table = src[start..end].parse::<toml::Table>().expect("tool")["tool"]
            .as_table()
            .expect("table")
            .clone();
        let c = check_sections(&library_src, &m, &|_| Ok::<_, NoTool>(tool.clone()));
        assert!(c.problems.is_empty() && c.plan.is_some(), "{:?}", c.problems);
    }

    #[test]
    fn a_value_out_of_range_is_red_on_its_table_after_the_whole_check() {
        let m = shipped_for_tests();
        let c = check_sections(
            &demo().replace("retract_mm = 5.0", "retract_mm = -5.0"),
            &m,
            &no_library,
        );
        assert_eq!(c.state("strategy"), Some(SectionState::Invalid));
        assert_eq!(c.state("workpiece"), Some(SectionState::Ok));
        assert!(
            c.problems.iter().any(|p| p.key == "strategy.retract_mm"),
            "{:?}",
            c.problems
        );
    }
}
