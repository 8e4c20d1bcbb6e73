//! The HTTP side of the HMI: the program and tool library (the same `hob_store::Library`
//! calls as `hob program|tool ...`, so every refusal is the CLI's text and every problem
//! carries its key path for the field), the cut report from the logger's record, and the
//! alarm log's older pages. No check is written here: they all come from the Rust crates.

use crate::app::App;
use crate::protocol::EventView;
use crate::words::{Lang, tr};
use axum::Json;
use axum::extract::{Path, Query, State};
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use hob_store::library::{Kind, Refusal};
use serde::Deserialize;
use serde_json::{Value, json};
use std::sync::Arc;

type Shared = State<Arc<App>>;

/// A refusal as the page shows it: the CLI's sentence and the problems by key.
pub fn refusal(r: &Refusal) -> Response {
    let problems: Vec<Value> = match r {
        Refusal::Invalid { error, .. } => {
            let list = error.problems();
            if list.is_empty() {
                vec![json!({"key": "", "message": tr(&error.to_string())})]
            } else {
                list.iter()
                    .map(|p| json!({"key": p.key, "message": tr(&p.message)}))
                    .collect()
            }
        }
        _ => Vec::new(),
    };
    let status = if r.is_io() {
        StatusCode::INTERNAL_SERVER_ERROR
    } else {
        StatusCode::UNPROCESSABLE_ENTITY
    };
    (
        status,
        Json(json!({"refused": tr(&r.to_string()), "problems": problems})),
    )
        .into_response()
}

/// What changing a library entry of this kind needs.
fn editing(kind: Kind) -> hob_ipc::gateway::Action {
    match kind {
        Kind::Program => hob_ipc::gateway::Action::EditPrograms,
        Kind::Tool => hob_ipc::gateway::Action::EditTools,
    }
}

fn kind_of(what: &str) -> Option<Kind> {
    match what {
        "programs" => Some(Kind::Program),
        "tools" => Some(Kind::Tool),
        _ => None,
    }
}

fn not_found(what: &str) -> Response {
    (
        StatusCode::NOT_FOUND,
        Json(json!({"refused": format!("no such list: {what}")})),
    )
        .into_response()
}

/// `GET /api/{programs|tools}`: every entry, valid or not with the reason.
pub async fn list(State(app): Shared, Path(what): Path<String>) -> Response {
    let listing = match kind_of(&what) {
        Some(Kind::Program) => app.library.list_programs(&app.machine),
        Some(Kind::Tool) => app.library.list_tools(),
        None => return not_found(&what),
    };
    match listing {
        Ok(entries) => {
            let list: Vec<Value> = entries
                .iter()
                .map(|e| json!({"name": e.name, "valid": e.problem.is_none(), "problem": e.problem}))
                .collect();
            Json(json!({"dir": app.library.dir().display().to_string(), "entries": list})).into_response()
        }
        Err(r) => refusal(&r),
    }
}

/// `GET /api/{programs|tools}/{name}`: the stored text (and a tool's usage).
pub async fn get(State(app): Shared, Path((what, name)): Path<(String, String)>) -> Response {
    let Some(kind) = kind_of(&what) else {
        return not_found(&what);
    };
    match app.library.text(kind, &name) {
        Ok(text) => {
            let usage = (kind == Kind::Tool)
                .then(|| {
                    app.library
                        .tool(&name)
                        .ok()
                        .map(|t| serde_json::to_value(&t.usage).unwrap_or(Value::Null))
                })
                .flatten();
            Json(json!({"name": name, "text": text, "usage": usage})).into_response()
        }
        Err(r) => refusal(&r),
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Body {
    text: String,
}

/// `POST /api/{programs|tools}/{name}`: a new entry, checked before it is written.
pub async fn create(
    State(app): Shared,
    Path((what, name)): Path<(String, String)>,
    Json(body): Json<Body>,
) -> Response {
    let Some(kind) = kind_of(&what) else {
        return not_found(&what);
    };
    if let Err(r) = app.may(editing(kind)) {
        return *r;
    }
    let r = match kind {
        Kind::Program => app
            .library
            .create_program(&name, &body.text, &app.machine)
            .map(|p| json!({"plan": p})),
        Kind::Tool => app.library.create_tool(&name, &body.text).map(|_| json!({})),
    };
    match r {
        Ok(v) => (
            StatusCode::CREATED,
            Json(json!({"ok": true, "name": name, "result": v})),
        )
            .into_response(),
        Err(r) => refusal(&r),
    }
}

/// `DELETE /api/{programs|tools}/{name}`.
pub async fn delete(State(app): Shared, Path((what, name)): Path<(String, String)>) -> Response {
    let Some(kind) = kind_of(&what) else {
        return not_found(&what);
    };
    if let Err(r) = app.may(editing(kind)) {
        return *r;
    }
    match app.library.delete(kind, &name) {
        Ok(()) => Json(json!({"ok": true})).into_response(),
        Err(r) => refusal(&r),
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct To {
    to: String,
}

/// `POST /api/{programs|tools}/{name}/{copy|rename}` with `{"to": NEW}`.
pub async fn copy_or_rename(
    State(app): Shared,
    Path((what, name, action)): Path<(String, String, String)>,
    Json(to): Json<To>,
) -> Response {
    let Some(kind) = kind_of(&what) else {
        return not_found(&what);
    };
    if let Err(r) = app.may(editing(kind)) {
        return *r;
    }
    let r = match action.as_str() {
        "copy" => app.library.copy(kind, &name, &to.to),
        "rename" => app.library.rename(kind, &name, &to.to),
        _ => return not_found(&action),
    };
    match r {
        Ok(()) => Json(json!({"ok": true, "name": to.to})).into_response(),
        Err(r) => refusal(&r),
    }
}

#[derive(Debug, Deserialize)]
pub struct Before {
    #[serde(default)]
    before: u64,
}

/// `GET /api/alarms/page?before=SEQ`: a page of older events, newest first: from the HMI's own
/// ring, then, older than the ring holds, from the logger's `events.log` (newest run of
/// `hob-rt`) when hob-hmi has `--log-dir`. `from_log` says how many came from the log.
pub async fn alarms(State(app): Shared, Query(b): Query<Before>) -> Response {
    const PAGE: usize = 200;
    let (mut list, clock, missed) = {
        let book = app.hub.book();
        let list: Vec<EventView> = book
            .log
            .page_before(b.before, PAGE)
            .iter()
            .map(|e| EventView::of(e, book.clock))
            .collect();
        (list, book.clock, book.log.missed)
    };
    let mut from_log = 0;
    let older_than = list.last().map_or(b.before, |e| e.seq);
    if list.len() < PAGE
        && older_than != 1
        && let Some(dir) = app.log_dir.clone()
    {
        let want = PAGE - list.len();
        let read = tokio::task::spawn_blocking(move || logged_before(&dir, older_than, want)).await;
        if let Ok(Ok(events)) = read {
            from_log = events.len();
            list.extend(events.iter().map(|e| EventView::of_logged(e, clock)));
        }
    }
    Json(json!({"events": list, "missed": missed, "from_log": from_log})).into_response()
}

/// The newest `count` events of the log's newest run numbered below `seq` (0: any), newest
/// first.
fn logged_before(
    dir: &std::path::Path,
    seq: u64,
    count: usize,
) -> Result<Vec<hob_logger::export::LoggedEvent>, hob_logger::Error> {
    let mut events = hob_logger::export::read_events(dir)?;
    if let Some(newest) = events.last().map(|e| e.run) {
        events.retain(|e| e.run == newest && (seq == 0 || e.seq < seq));
    }
    Ok(events.into_iter().rev().take(count).collect())
}

#[derive(Debug, Deserialize)]
pub struct Range {
    first: Option<u64>,
    last: Option<u64>,
}

/// `GET /api/cut/report[?first=C&last=C]`: the report of a cut from the logger's record
/// (`hob log report`), by default the newest finished cycle the HMI saw (from the loop's
/// acceptance of START to its CYCLE_DONE), else the whole recording, and says which.
pub async fn report(State(app): Shared, Query(q): Query<Range>) -> Response {
    let Some(dir) = app.log_dir.clone() else {
        return (
            StatusCode::NOT_FOUND,
            Json(json!({"refused": "hob-hmi was started without --log-dir: no logger record to report"})),
        )
            .into_response();
    };
    let newest = app.hub.book().log.last_cycle_run();
    let (range, what) = match (q.first, q.last, newest) {
        (Some(f), Some(l), _) => ((f, l), format!("cycles {f} .. {l}")),
        (_, _, Some((f, l))) => ((f, l), format!("the last cycle run, cycles {f} .. {l}")),
        _ => (
            (0, u64::MAX),
            "the whole recording (no finished cycle since the HMI started)".to_string(),
        ),
    };
    let r =
        tokio::task::spawn_blocking(move || hob_logger::export::report_cycles(&dir, range.0, range.1)).await;
    match r {
        Ok(Ok(r)) => Json(report_json(&what, &r)).into_response(),
        Ok(Err(e)) => (StatusCode::NOT_FOUND, Json(json!({"refused": e.to_string()}))).into_response(),
        Err(e) => (
            StatusCode::INTERNAL_SERVER_ERROR,
            Json(json!({"refused": e.to_string()})),
        )
            .into_response(),
    }
}

/// The cut report as the HMI's REPORT screen gets it: `hob log report`'s figures, its head
/// in its own lines (the program, part, date, operator and alarms) and the words the
/// durations are given in, all from the logger's code (the screen computes nothing).
pub fn report_json(what: &str, r: &hob_logger::export::Report) -> Value {
    json!({
        "what": what,
        "header": r.header,
        "header_lines": r.header.lines(),
        "durations": hob_logger::trace::DURATIONS,
        "samples": r.samples,
        "first_cycle": r.first_cycle,
        "last_cycle": r.last_cycle,
        "missing": r.missing,
        "pitch_radius_mm": r.pitch_radius_mm,
        "grade5_single_pitch_um": r.grade5_single_pitch_um,
        "bound_um": r.grade5_single_pitch_um / 4.0,
        "passes": r.passes,
        // The simulated machine's truth beside the record (`hob-sim --truth`): the
        // cut graded by it, and the gear each pass left; absent on a real machine.
        "truth": r.truth.as_ref().map(|t| json!({
            "joined": t.joined,
            "teeth": t.gear.teeth,
            "passes": t.passes,
        })),
        "truth_refused": r.truth_refused,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use hob_ipc::StateSample;
    use hob_ipc::codec::{Coupling, State};

    /// The REPORT screen gets the same head and the same durations `hob log report` prints:
    /// the pass's time and cut time, the time stood apart, no `time_s` of another meaning.
    #[test]
    fn the_report_screen_gets_the_head_and_durations_of_hob_log_report() {
        let dir = std::env::temp_dir().join(format!("hob-hmi-report-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let mut w = hob_logger::LogWriter::open(&dir, "t").unwrap();
        for (cycle, state, pass) in [(1, State::Cut, 1), (2, State::Faulted, 0), (3, State::Cut, 1)] {
            w.push_state(&StateSample {
                cycle,
                sync_time_ns: cycle * 1_000_000,
                state: state.code(),
                pass,
                coupling: Coupling::Synchronised.code(),
                pitch_radius_mm: 42.5,
                normal_module_mm: 5.0,
                ..StateSample::default()
            })
            .unwrap();
        }
        w.flush().unwrap();
        let r = hob_logger::export::report(&dir).unwrap();
        let text = hob_logger::export::report_text(&dir, &r);
        let _ = std::fs::remove_dir_all(&dir);
        let j = report_json("the whole recording", &r);
        let lines: Vec<&str> = j["header_lines"]
            .as_array()
            .unwrap()
            .iter()
            .map(|l| l.as_str().unwrap())
            .collect();
        assert!(!lines.is_empty());
        for l in &lines {
            assert!(text.lines().any(|t| t == *l), "{l:?} not in:\n{text}");
        }
        assert!(
            lines.iter().any(|l| l.starts_with("operator: not recorded")),
            "{lines:?}"
        );
        assert!(text.contains(j["durations"].as_str().unwrap()));
        let p = &j["passes"][0];
        assert!(p.get("time_s").is_none(), "{p}");
        assert_eq!(p["pass_time_s"].as_f64(), Some(r.passes[0].pass_time_s));
        assert_eq!(p["cut_time_s"].as_f64(), Some(r.passes[0].cut_time_s));
        assert_eq!(p["stood_s"].as_f64(), Some(r.passes[0].stood_s));
        assert!(r.passes[0].stood_s > 0.0, "{:?}", r.passes[0]);
    }
}

/// `GET /api/words`: the panel's language, the languages this build has, and the
/// catalogue the page looks its labels up in (empty for English).
pub async fn words() -> Response {
    let lang = crate::words::lang();
    let langs: Vec<Value> = Lang::ALL
        .iter()
        .map(|l| json!({"code": l.code(), "name": l.own_name()}))
        .collect();
    let words = crate::words::catalogue(lang)
        .map(|c| c.page())
        .unwrap_or_default();
    Json(json!({"lang": lang.code(), "languages": langs, "words": words})).into_response()
}

#[derive(Debug, Deserialize)]
pub struct LanguageBody {
    lang: String,
}

/// `POST /api/language`: the panel's language (any level: it changes the words, not the
/// machine); an unknown language is refused and changes nothing.
pub async fn language(Json(body): Json<LanguageBody>) -> Response {
    match Lang::parse(&body.lang) {
        Some(l) => {
            crate::words::set(l);
            words().await
        }
        None => (
            StatusCode::UNPROCESSABLE_ENTITY,
            Json(json!({
                "refused": format!(
                    "no language {:?} on this panel (it has {})",
                    body.lang,
                    Lang::ALL.map(Lang::code).join(", ")
                ),
                "problems": [],
            })),
        )
            .into_response(),
    }
}
