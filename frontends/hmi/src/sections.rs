//! The state of each sub-menu of the program definition (green: complete and valid; red:
//! missing or invalid) from `hob_setup::form::check_sections`: each table read on its
//! own, then the whole program checked and planned as `hob check` does; a library tool
//! filled in from the library.

use crate::app::App;
use crate::error::Error;
use hob_setup::form::{SECTIONS, check_sections};
use serde_json::{Value, json};

/// Checks a program file made from the form: `{sections, problems, plan}`.
pub fn check(app: &App, text: &str) -> Value {
    // `check_sections` takes the tool's refusal in words.
    let c = check_sections(text, &app.machine, &|name| {
        library_tool(app, name).map_err(|e| e.to_string())
    });
    let sections: serde_json::Map<String, Value> = SECTIONS
        .iter()
        .map(|s| ((*s).to_string(), json!(c.state(s))))
        .collect();
    let problems: Vec<Value> = c
        .problems
        .iter()
        .map(|p| json!({"key": p.key, "message": p.message}))
        .collect();
    json!({"ok": true, "sections": sections, "problems": problems, "plan": c.plan, "toml": text})
}

/// A library tool's fields as a TOML table, as a program's `[tool]` would hold them.
fn library_tool(app: &App, name: &str) -> Result<toml::Table, Error> {
    let record = app.library.tool(name).map_err(Error::Library)?;
    match toml::Value::try_from(&record.tool) {
        Ok(toml::Value::Table(t)) => Ok(t),
        Ok(_) => Err(Error::ToolNotATable {
            name: name.to_string(),
        }),
        Err(error) => Err(Error::ToolToml {
            name: name.to_string(),
            error,
        }),
    }
}
