//! Program definition over HTTP: a library program as form fields, the fields checked as a
//! program file by the Rust checks (each sub-menu's state, the problems by key, the plan),
//! saved into the library, and a program's plan for the set-up sheet.

use crate::api::refusal;
use crate::app::App;
use crate::form::{self, Field};
use crate::protocol::Typed;
use axum::Json;
use axum::extract::{Path, State};
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use hob_ipc::gateway::Action;
use hob_setup::config::LoadError;
use hob_store::library::{Kind, Refusal};
use serde::Deserialize;
use serde_json::{Value, json};
use std::sync::Arc;

type Shared = State<Arc<App>>;

fn bad_request(text: impl std::fmt::Display) -> Response {
    (
        StatusCode::UNPROCESSABLE_ENTITY,
        Json(json!({"refused": text.to_string(), "problems": []})),
    )
        .into_response()
}

/// `GET /api/form/{name}`: the program's fields.
pub async fn fields(State(app): Shared, Path(name): Path<String>) -> Response {
    match app.library.text(Kind::Program, &name) {
        Ok(text) => match form::fields(&text) {
            Ok(f) => Json(json!({"name": name, "fields": f})).into_response(),
            Err(e) => bad_request(format!("program {name}: not TOML: {e}")),
        },
        Err(r) => refusal(&r),
    }
}

/// `GET /api/plan/{name}`: the plan of a library program on this machine.
pub async fn plan(State(app): Shared, Path(name): Path<String>) -> Response {
    let checked = app.library.text(Kind::Program, &name).and_then(|text| {
        let origin = app.library.path(Kind::Program, &name)?;
        app.library.check_program(&origin, &text, &app.machine)
    });
    match checked {
        Ok(p) => Json(json!({"name": name, "plan": p})).into_response(),
        Err(r) => refusal(&r),
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Form {
    fields: Vec<Field>,
}

/// The problems of a load error, each on its key (a syntax error on the key of its line).
pub fn problems_of(error: &LoadError, toml_text: &str) -> Vec<Value> {
    match error {
        LoadError::Syntax {
            position, message, ..
        } => {
            let key = position
                .and_then(|p| form::key_of_line(toml_text, p.line.saturating_sub(1)))
                .unwrap_or_default();
            vec![json!({"key": key, "message": message})]
        }
        other => {
            let list = other.problems();
            if list.is_empty() {
                vec![json!({"key": "", "message": other.to_string()})]
            } else {
                list.iter()
                    .map(|p| json!({"key": p.key, "message": p.message}))
                    .collect()
            }
        }
    }
}

/// `POST /api/check`: the form as a program file, checked as `hob check` checks it.
pub async fn check(State(app): Shared, Json(f): Json<Form>) -> Response {
    let text = match form::to_toml(&f.fields) {
        Ok(t) => t,
        Err(e) => return bad_request(e),
    };
    Json(crate::sections::check(&app, &text)).into_response()
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Save {
    name: String,
    new: bool,
    fields: Vec<Field>,
}

/// `POST /api/save`: a new program, or a changed one written over the old (checked first;
/// refused, nothing is written).
pub async fn save(State(app): Shared, Json(s): Json<Save>) -> Response {
    if let Err(r) = app.may(Action::EditPrograms) {
        return *r;
    }
    let text = match form::to_toml(&s.fields) {
        Ok(t) => t,
        Err(e) => return bad_request(e),
    };
    let r = if s.new {
        app.library.create_program(&s.name, &text, &app.machine)
    } else {
        app.library.replace_program(&s.name, &text, &app.machine)
    };
    match r {
        Ok(plan) => Json(json!({"ok": true, "name": s.name, "plan": plan})).into_response(),
        Err(Refusal::Invalid { what, error }) => (
            StatusCode::UNPROCESSABLE_ENTITY,
            Json(json!({"refused": format!("{what}: {error}"), "problems": problems_of(&error, &text)})),
        )
            .into_response(),
        Err(r) => refusal(&r),
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Span {
    program: String,
    /// Each number as the operator typed it (a decimal point or comma), read by
    /// `hob_ipc::number`; an empty optional field is no value.
    k: Typed,
    measured_mm: Typed,
    #[serde(default)]
    drawing_mm: Option<Typed>,
    #[serde(default)]
    upper_mm: Option<Typed>,
    #[serde(default)]
    lower_mm: Option<Typed>,
    #[serde(default)]
    profile_shift: Option<Typed>,
    #[serde(default)]
    after: hob_setup::job::span::CutMeasured,
}

/// The span form's typed numbers, or each one that is not a number as a problem by its key.
fn span_reading(s: &Span) -> Result<hob_setup::job::span::SpanReading, Vec<Value>> {
    let mut problems = Vec::new();
    let mut num = |key: &str, label: &str, t: Option<&Typed>| -> Option<f64> {
        match t {
            None => None,
            Some(Typed::Text(x)) if x.trim().is_empty() => None,
            Some(t) => t
                .read(label)
                .map_err(|e| problems.push(json!({"key": key, "message": e.to_string()})))
                .ok(),
        }
    };
    let k = num("span.k", "teeth spanned k", Some(&s.k));
    let measured = num("span.measured_mm", "measured span W", Some(&s.measured_mm));
    let drawing_mm = num("span.drawing_mm", "drawing's span", s.drawing_mm.as_ref());
    let upper_mm = num("span.upper_mm", "upper allowance", s.upper_mm.as_ref());
    let lower_mm = num("span.lower_mm", "lower allowance", s.lower_mm.as_ref());
    let profile_shift = num("span.profile_shift", "profile shift x", s.profile_shift.as_ref());
    let (Some(k), Some(measured_mm)) = (k, measured) else {
        if problems.is_empty() {
            problems.push(json!({"key": "span.measured_mm", "message": "the teeth spanned and the measured span are needed"}));
        }
        return Err(problems);
    };
    if !problems.is_empty() {
        return Err(problems);
    }
    if k.fract() != 0.0 || !(0.0..=1000.0).contains(&k) {
        return Err(vec![
            json!({"key": "span.k", "message": format!("teeth spanned k: {k} is not a whole number of teeth")}),
        ]);
    }
    Ok(hob_setup::job::span::SpanReading {
        k: k as u32,
        measured_mm,
        drawing_mm,
        upper_mm,
        lower_mm,
        profile_shift,
        after: s.after,
    })
}

fn span_correction(
    app: &App,
    s: &Span,
) -> Result<(String, hob_setup::job::span::SpanCorrection), Box<Response>> {
    let refused = |r: Refusal| Box::new(refusal(&r));
    let reading = span_reading(s).map_err(|problems| {
        Box::new(
            (
                StatusCode::UNPROCESSABLE_ENTITY,
                Json(json!({"refused": "the span reading is refused", "problems": problems})),
            )
                .into_response(),
        )
    })?;
    let text = app.library.text(Kind::Program, &s.program).map_err(refused)?;
    let origin = app.library.path(Kind::Program, &s.program).map_err(refused)?;
    let resolved = app.library.resolve(&origin, &text).map_err(refused)?;
    let program = hob_setup::job::Program::parse(&origin, &resolved).map_err(|e| {
        Box::new(
            (
                StatusCode::UNPROCESSABLE_ENTITY,
                Json(json!({"refused": e.to_string(), "problems": problems_of(&e, &text)})),
            )
                .into_response(),
        )
    })?;
    let c = hob_setup::job::span::correction(&program, reading).map_err(|p| {
        let problems: Vec<Value> = p
            .as_slice()
            .iter()
            .map(|p| json!({"key": p.key, "message": p.message}))
            .collect();
        Box::new(
            (
                StatusCode::UNPROCESSABLE_ENTITY,
                Json(json!({"refused": "the span reading is refused", "problems": problems})),
            )
                .into_response(),
        )
    })?;
    Ok((text, c))
}

/// `POST /api/span`: the depth still to cut from the span over k teeth, with every input.
pub async fn span(State(app): Shared, Json(s): Json<Span>) -> Response {
    match span_correction(&app, &s) {
        Ok((_, c)) => Json(json!({"ok": true, "inputs": c})).into_response(),
        Err(r) => *r,
    }
}

/// `POST /api/span/carry`: the new total depth written into the library program (checked
/// as any change; the file is rewritten from its fields, its comments are not kept).
pub async fn span_carry(State(app): Shared, Json(s): Json<Span>) -> Response {
    if let Err(r) = app.may(Action::Compensate) {
        return *r;
    }
    let (text, c) = match span_correction(&app, &s) {
        Ok(x) => x,
        Err(r) => return *r,
    };
    let mut fields = match form::fields(&text) {
        Ok(f) => f,
        Err(e) => return bad_request(format!("program {}: not TOML: {e}", s.program)),
    };
    let depth = format!("{:.4}", c.new_total_depth_mm);
    match fields.iter_mut().find(|f| f.key == "strategy.total_depth_mm") {
        Some(f) => f.text = depth,
        None => return bad_request(format!("program {}: no strategy.total_depth_mm", s.program)),
    }
    let new_text = match form::to_toml(&fields) {
        Ok(t) => t,
        Err(e) => return bad_request(e),
    };
    match app.library.replace_program(&s.program, &new_text, &app.machine) {
        Ok(_) => {
            Json(json!({"ok": true, "total_depth_mm": c.new_total_depth_mm, "inputs": c})).into_response()
        }
        Err(Refusal::Invalid { what, error }) => (
            StatusCode::UNPROCESSABLE_ENTITY,
            Json(json!({"refused": format!("{what}: {error}"), "problems": problems_of(&error, &new_text)})),
        )
            .into_response(),
        Err(r) => refusal(&r),
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToolFromForm {
    name: String,
    fields: Vec<Field>,
}

/// `POST /api/tool-from-form`: the definition's own tool fields stored as a new library
/// tool (`hob lib tools create`'s checks; refused, nothing written).
pub async fn tool_from_form(State(app): Shared, Json(t): Json<ToolFromForm>) -> Response {
    if let Err(r) = app.may(Action::EditTools) {
        return *r;
    }
    let tool: Vec<Field> = t
        .fields
        .into_iter()
        .filter(|f| f.key.starts_with("tool.") && f.key != "tool.library")
        .collect();
    let text = match form::to_toml(&tool) {
        Ok(body) => format!(
            "format_version = {}\n\n{body}",
            hob_store::library::TOOL_FORMAT_VERSION
        ),
        Err(e) => return bad_request(e),
    };
    match app.library.create_tool(&t.name, &text) {
        Ok(_) => (StatusCode::CREATED, Json(json!({"ok": true, "name": t.name}))).into_response(),
        Err(Refusal::Invalid { what, error }) => (
            StatusCode::UNPROCESSABLE_ENTITY,
            Json(json!({"refused": format!("{what}: {error}"), "problems": problems_of(&error, &text)})),
        )
            .into_response(),
        Err(r) => refusal(&r),
    }
}
