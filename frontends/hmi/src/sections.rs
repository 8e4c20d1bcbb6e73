//! The state of each sub-menu of the program definition (green: complete and valid; red:
//! missing or invalid), from the Rust checks of the whole program file.

use crate::app::App;
use crate::definition::problems_of;
use hob_store::library::Refusal;
use serde_json::{Value, json};

/// The program's tables, in the order of the sub-menus.
pub const SECTIONS: [&str; 4] = ["workpiece", "tool", "cycle", "strategy"];

/// Checks a program file made from the form: `{sections, problems, plan}`.
pub fn check(app: &App, text: &str) -> Value {
    let origin = app.library.dir().join("(the program being defined)");
    let (problems, plan) = match app.library.check_program(&origin, text, &app.machine) {
        Ok(p) => (Vec::new(), serde_json::to_value(p).ok()),
        Err(Refusal::Invalid { error, .. }) => (problems_of(&error, text), None),
        Err(other) => (
            vec![json!({"key": "tool.library", "message": other.to_string()})],
            None,
        ),
    };
    let present = |s: &str| text.lines().any(|l| l.trim() == format!("[{s}]"));
    let mut sections = serde_json::Map::new();
    for s in SECTIONS {
        let mine = problems.iter().any(|p| {
            p["key"]
                .as_str()
                .is_some_and(|k| k == s || k.starts_with(&format!("{s}.")) || k.starts_with(&format!("{s}[")))
        });
        let state = if !present(s) {
            "missing"
        } else if mine {
            "invalid"
        } else {
            "ok"
        };
        sections.insert(s.into(), json!(state));
    }
    json!({"ok": true, "sections": sections, "problems": problems, "plan": plan, "toml": text})
}
