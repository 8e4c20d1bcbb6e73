//! The COMPENSATE screen (issue 34): `hob compensate` from the panel. The HMI links no control
//! core (`bench/suite/tests/layers.rs`), so it runs the CLI itself (`hob-hmi --hob`, by
//! default the `hob` next to its own executable) and shows what it says: its findings and
//! the diff against the worm set's current compensation, its plot (`--svg`), and its
//! refusals (exit 2) word for word, nothing changed. No check is made here but that each
//! file named is a checker's file in the measurements folder (`--measurements-dir`: a USB
//! stick's mount or a share; the page never sends a path) and that the panel's level may
//! write.
//!
//! The flow follows the commissioning screen's (`crate::commission`): PREVIEW runs `hob
//! compensate` without `--yes` and holds what it was given; WRITE runs the held request
//! again with `--yes` (the setter's level: [`Action::Compensate`]), and drops it. One run at
//! a time, off the async runtime, killed after [`RUN_LIMIT`].

use crate::app::App;
use crate::compensation::{RUN_LIMIT, Ran, Request, checked_name, listing, no_folder, run_cli};
use crate::words::tr;
use axum::Json;
use axum::extract::State;
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use hob_ipc::gateway::Action;
use hob_store::library::Kind;
use serde::Serialize;
use serde_json::json;
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::Ordering;

/// The program file `hob compensate --program` reads for a library program: its own file,
/// or (a program naming a library tool) the program with the tool filled in, as `hob load
/// --lib` sends it, written under `scratch` by the program's own file name (its stem is the
/// gear's name when the program names none).
fn program_file(app: &App, name: &str, scratch: &Path) -> Result<PathBuf, String> {
    let refusal = |r: hob_store::library::Refusal| tr(&r.to_string());
    let text = app.library.text(Kind::Program, name).map_err(refusal)?;
    let origin = app.library.path(Kind::Program, name).map_err(refusal)?;
    let resolved = app.library.resolve(&origin, &text).map_err(refusal)?;
    if resolved == text {
        return Ok(origin);
    }
    let file = scratch.join(origin.file_name().unwrap_or(origin.as_os_str()));
    std::fs::create_dir_all(scratch)
        .and_then(|()| std::fs::write(&file, resolved))
        .map_err(|e| format!("{}: {e}", file.display()))?;
    Ok(file)
}

/// The arguments of `hob compensate` for `r` (`svg`: where its plot goes).
fn arguments(app: &App, r: &Request, scratch: &Path, yes: bool) -> Result<Vec<OsString>, String> {
    let Some(dir) = app.compensation.setup.measurements_dir.as_deref() else {
        return Err(no_folder());
    };
    let Some(log) = app.log_dir.as_deref() else {
        return Err(tr(
            "hob-hmi was started without --log-dir: no log of the cut to match the measurements to",
        ));
    };
    if r.measurements.is_empty() {
        return Err(tr(
            "pick the checker's file of the gear (one per height): none is picked",
        ));
    }
    let program = program_file(app, &r.program, scratch)?;
    let mut a: Vec<OsString> = vec!["compensate".into(), "--machine".into()];
    a.push(app.machine_file.clone().into());
    a.extend(["--program".into(), program.into(), "--log".into()]);
    a.push(log.into());
    for m in &r.measurements {
        a.extend(["--measurement".into(), checked_name(dir, m)?.into()]);
    }
    if let Some((first, last)) = r.cycles {
        a.extend(["--cycles".into(), format!("{first}..{last}").into()]);
    }
    a.extend(["--svg".into(), scratch.join("plot.svg").into()]);
    if yes {
        a.push("--yes".into());
    }
    Ok(a)
}

/// What a run answers the page: the CLI's text and plot, or its refusal word for word.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Answer {
    /// `preview`, `written`, `refused` or `failed`.
    pub state: &'static str,
    /// The CLI's output, its refusal, or why it could not run.
    pub text: String,
    /// The plot of the table's error and the residuals (`--svg`), SVG.
    pub svg: Option<String>,
}

/// Runs `hob compensate` for `r` off the runtime (one run at a time); `yes`: writes.
async fn compute(app: &Arc<App>, r: &Request, yes: bool) -> Answer {
    let c = &app.compensation;
    if c.busy.swap(true, Ordering::SeqCst) {
        return answer(
            "refused",
            tr("hob compensate is running for this panel: wait for its answer"),
        );
    }
    let n = c.runs.fetch_add(1, Ordering::SeqCst);
    let scratch = std::env::temp_dir().join(format!("hob-hmi-compensate-{}-{n}", std::process::id()));
    let args = arguments(app, r, &scratch, yes);
    let hob = c.setup.hob.clone();
    let plot = scratch.join("plot.svg");
    let done = tokio::task::spawn_blocking(move || {
        let ran = args.and_then(|a| {
            std::fs::create_dir_all(plot.parent().unwrap_or(&plot))
                .map_err(|e| format!("{}: {e}", plot.display()))?;
            Ok(run_cli(&hob, &a, RUN_LIMIT))
        });
        let svg = std::fs::read_to_string(&plot).ok();
        let _ = std::fs::remove_dir_all(&scratch);
        (ran, svg)
    })
    .await;
    c.busy.store(false, Ordering::SeqCst);
    match done {
        Ok((Ok(Ran::Done(text)), svg)) => Answer {
            state: if yes { "written" } else { "preview" },
            text,
            svg,
        },
        Ok((Ok(Ran::Refused(text)) | Err(text), _)) => answer("refused", text),
        Ok((Ok(Ran::Failed(text)), _)) => answer("failed", text),
        Err(e) => answer("failed", e.to_string()),
    }
}

fn answer(state: &'static str, text: String) -> Answer {
    Answer {
        state,
        text,
        svg: None,
    }
}

fn reply(a: &Answer) -> Response {
    let status = match a.state {
        "preview" | "written" => StatusCode::OK,
        "refused" => StatusCode::UNPROCESSABLE_ENTITY,
        _ => StatusCode::INTERNAL_SERVER_ERROR,
    };
    let refused = (status != StatusCode::OK).then_some(&a.text);
    (
        status,
        Json(json!({"state": a.state, "text": a.text, "svg": a.svg, "refused": refused})),
    )
        .into_response()
}

type Shared = State<Arc<App>>;

/// `GET /api/compensate`: the checker's files in the folder (newest first), the cuts the
/// HMI saw finish (newest first), the program this HMI loaded, the worm set, whether the
/// panel may write, and what PREVIEW holds.
pub async fn overview(State(app): Shared) -> Response {
    let c = &app.compensation;
    let dir = c.setup.measurements_dir.clone();
    let listed = match dir.clone() {
        Some(d) => tokio::task::spawn_blocking(move || listing(&d))
            .await
            .unwrap_or_else(|e| Err(e.to_string())),
        None => Err(no_folder()),
    };
    let (files, files_refused) = match listed {
        Ok(f) => (f, None),
        Err(why) => (Vec::new(), Some(why)),
    };
    let cuts: Vec<(u64, u64)> = app.hub.book().log.cycle_runs();
    let loaded = app
        .loaded
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
        .as_ref()
        .map(|l| l.name.clone());
    Json(json!({
        "dir": dir.map(|d| d.display().to_string()),
        "files": files,
        "files_refused": files_refused,
        "log_dir": app.log_dir.is_some(),
        "cuts": cuts,
        "loaded": loaded,
        "worm_set": app.machine.table.worm_set,
        "write_refused": app.not_allowed(Action::Compensate),
        "held": *c.held(),
    }))
    .into_response()
}

/// `POST /api/compensate/preview`: `hob compensate` without `--yes`; on its answer the
/// request is held for WRITE (a refusal holds nothing).
pub async fn preview(State(app): Shared, Json(r): Json<Request>) -> Response {
    *app.compensation.held() = None;
    let a = compute(&app, &r, false).await;
    if a.state == "preview" {
        *app.compensation.held() = Some(r);
    }
    reply(&a)
}

/// `POST /api/compensate/write`: the request PREVIEW holds, with `--yes` (the setter's
/// level); the held request is dropped either way.
pub async fn write(State(app): Shared) -> Response {
    if let Err(r) = app.may(Action::Compensate) {
        return *r;
    }
    let Some(r) = app.compensation.held().take() else {
        return reply(&answer(
            "refused",
            tr("nothing previewed to write: PREVIEW first"),
        ));
    };
    reply(&compute(&app, &r, true).await)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::compensation::tests::scratch;

    /// Every text this screen's server makes has its German (the unit tests keep the panel
    /// in English: each text is made in English, then looked up).
    #[test]
    fn the_screens_own_words_have_their_german() {
        let d = scratch("german");
        std::fs::write(d.join("a.csv"), "x").unwrap();
        let de = crate::words::catalogue(crate::words::Lang::De).unwrap();
        let texts = [
            no_folder(),
            checked_name(&d, "../a.csv").unwrap_err(),
            checked_name(&d, "b.csv").unwrap_err(),
            listing(&d.join("absent")).unwrap_err(),
            tr("hob-hmi was started without --log-dir: no log of the cut to match the measurements to"),
            tr("pick the checker's file of the gear (one per height): none is picked"),
            tr("hob compensate is running for this panel: wait for its answer"),
            tr("nothing previewed to write: PREVIEW first"),
        ];
        for t in texts {
            assert_ne!(de.tr(&t), t, "no German for {t:?}");
        }
        let _ = std::fs::remove_dir_all(&d);
    }
}
