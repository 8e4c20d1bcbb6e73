//! The routes, the guard in front of them, and the page's files. The page (HTML, CSS, ES
//! modules) is built into the binary; the third-party view library (Preact and htm) is read
//! once at start-up from an npm install (`--vendor`), never copied into the repository.

use crate::app::App;
use crate::{api, definition, ws};
use axum::Router;
use axum::body::Body;
use axum::extract::{Path, Request, State, WebSocketUpgrade};
use axum::http::{HeaderMap, HeaderValue, Method, StatusCode, header};
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use std::collections::BTreeMap;
use std::sync::Arc;

/// The page's own files, built in.
pub const ASSETS: &[(&str, &str)] = &[
    ("index.html", include_str!("../web/index.html")),
    ("app.css", include_str!("../web/app.css")),
    ("main.mjs", include_str!("../web/js/main.mjs")),
    ("ui.mjs", include_str!("../web/js/ui.mjs")),
    ("conn.mjs", include_str!("../web/js/conn.mjs")),
    ("hold.mjs", include_str!("../web/js/hold.mjs")),
    ("screens.mjs", include_str!("../web/js/screens.mjs")),
    ("library.mjs", include_str!("../web/js/library.mjs")),
    ("plot.mjs", include_str!("../web/js/plot.mjs")),
    ("plot-reduce.mjs", include_str!("../web/js/plot-reduce.mjs")),
];

/// The third-party modules the page imports (import map in index.html), relative to an
/// npm install's `node_modules`.
pub const VENDOR: &[(&str, &str)] = &[
    ("preact.mjs", "preact/dist/preact.module.js"),
    ("hooks.mjs", "preact/hooks/dist/hooks.module.js"),
    ("htm.mjs", "htm/dist/htm.module.js"),
];

/// The vendor files, read at start-up.
#[derive(Debug, Clone, Default)]
pub struct Vendor(pub BTreeMap<&'static str, String>);

impl Vendor {
    /// Reads [`VENDOR`] from `dir` (a `node_modules`); names the missing file and the fix.
    pub fn load(dir: &std::path::Path) -> Result<Self, String> {
        let mut m = BTreeMap::new();
        for (name, rel) in VENDOR {
            let p = dir.join(rel);
            let text = std::fs::read_to_string(&p).map_err(|e| {
                format!(
                    "the HMI's front-end libraries are missing: {}: {e}. Install them with \
                     `npm ci --omit=dev --prefix frontends/hmi` (README, Deploying) or give --vendor DIR",
                    p.display()
                )
            })?;
            m.insert(*name, text);
        }
        Ok(Self(m))
    }
}

#[derive(Debug, Clone)]
struct Files {
    app: Arc<App>,
    vendor: Arc<Vendor>,
}

fn content_type(name: &str) -> &'static str {
    match name.rsplit('.').next() {
        Some("html") => "text/html; charset=utf-8",
        Some("css") => "text/css; charset=utf-8",
        _ => "text/javascript; charset=utf-8",
    }
}

fn file(name: &str, text: &str) -> Response {
    (
        [
            (header::CONTENT_TYPE, HeaderValue::from_static(content_type(name))),
            (header::CACHE_CONTROL, HeaderValue::from_static("no-cache")),
        ],
        text.to_string(),
    )
        .into_response()
}

async fn index() -> Response {
    file("index.html", ASSETS[0].1)
}

async fn asset(Path(name): Path<String>) -> Response {
    match ASSETS.iter().find(|(n, _)| *n == name) {
        Some((n, t)) => file(n, t),
        None => StatusCode::NOT_FOUND.into_response(),
    }
}

async fn vendor(State(f): State<Files>, Path(name): Path<String>) -> Response {
    match f.vendor.0.get(name.as_str()) {
        Some(t) => file(&name, t),
        None => StatusCode::NOT_FOUND.into_response(),
    }
}

async fn ws_panel(State(f): State<Files>, up: WebSocketUpgrade) -> Response {
    up.on_upgrade(move |s| ws::serve(s, f.app, true))
}

async fn ws_view(State(f): State<Files>, up: WebSocketUpgrade) -> Response {
    up.on_upgrade(move |s| ws::serve(s, f.app, false))
}

/// The panel: the page, both sockets, the library's changes. Bound to the loopback only.
pub fn panel_router(app: Arc<App>, vendor_files: Arc<Vendor>, host: String) -> Router {
    let files = Files {
        app: app.clone(),
        vendor: vendor_files,
    };
    let api = Router::new()
        .route("/api/{what}", get(api::list))
        .route(
            "/api/{what}/{name}",
            get(api::get).post(api::create).delete(api::delete),
        )
        .route("/api/{what}/{name}/{action}", post(api::copy_or_rename))
        .route("/api/alarms/page", get(api::alarms))
        .route("/api/cut/report", get(api::report))
        .route("/api/form/{name}", get(definition::fields))
        .route("/api/plan/{name}", get(definition::plan))
        .route("/api/check", post(definition::check))
        .route("/api/save", post(definition::save))
        .route("/api/span", post(definition::span))
        .route("/api/tool-from-form", post(definition::tool_from_form))
        .route("/api/span/carry", post(definition::span_carry))
        .with_state(app);
    Router::new()
        .route("/", get(index))
        .route("/assets/{name}", get(asset))
        .route("/vendor/{name}", get(vendor))
        .route("/ws/panel", get(ws_panel))
        .route("/ws/view", get(ws_view))
        .with_state(files)
        .merge(api)
        .layer(middleware::from_fn_with_state(Arc::new(host), guard))
}

/// A view-only screen elsewhere: the page, the view socket and the reports. It has no
/// command socket and no route that changes anything (built apart, not a flag per request).
pub fn view_router(app: Arc<App>, vendor_files: Arc<Vendor>, host: String) -> Router {
    let files = Files {
        app: app.clone(),
        vendor: vendor_files,
    };
    let api = Router::new()
        .route("/api/alarms/page", get(api::alarms))
        .route("/api/cut/report", get(api::report))
        .with_state(app);
    Router::new()
        .route("/", get(index))
        .route("/assets/{name}", get(asset))
        .route("/vendor/{name}", get(vendor))
        .route("/ws/view", get(ws_view))
        .with_state(files)
        .merge(api)
        .layer(middleware::from_fn_with_state(Arc::new(host), guard))
}

/// Whether a request may pass: its `Host` must be the address served (no DNS rebinding),
/// and a WebSocket or any change needs an `Origin` of that same host (no other site's page
/// can drive the machine through the operator's browser).
pub fn allowed(headers: &HeaderMap, method: &Method, path: &str, served: &str) -> Result<(), &'static str> {
    let host = headers
        .get(header::HOST)
        .and_then(|h| h.to_str().ok())
        .unwrap_or("");
    let port = served.rsplit(':').next().unwrap_or("");
    let host_ok = host == served || host == format!("localhost:{port}");
    if !host_ok {
        return Err("this server answers only requests to its own address");
    }
    let needs_origin = path.starts_with("/ws/") || method != Method::GET;
    if needs_origin {
        let origin = headers
            .get(header::ORIGIN)
            .and_then(|h| h.to_str().ok())
            .unwrap_or("");
        if origin != format!("http://{host}") {
            return Err("commands are taken only from this server's own page");
        }
    }
    Ok(())
}

async fn guard(State(served): State<Arc<String>>, req: Request<Body>, next: Next) -> Response {
    match allowed(req.headers(), req.method(), req.uri().path(), &served) {
        Ok(()) => next.run(req).await,
        Err(why) => (StatusCode::FORBIDDEN, why).into_response(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn h(pairs: &[(header::HeaderName, &str)]) -> HeaderMap {
        let mut m = HeaderMap::new();
        for (k, v) in pairs {
            m.insert(k.clone(), HeaderValue::from_str(v).expect("header"));
        }
        m
    }

    #[test]
    fn a_foreign_host_or_origin_is_refused() {
        let served = "127.0.0.1:8080";
        let own = h(&[(header::HOST, served), (header::ORIGIN, "http://127.0.0.1:8080")]);
        assert_eq!(allowed(&own, &Method::POST, "/api/programs/a", served), Ok(()));
        assert_eq!(allowed(&own, &Method::GET, "/ws/panel", served), Ok(()));
        let local = h(&[
            (header::HOST, "localhost:8080"),
            (header::ORIGIN, "http://localhost:8080"),
        ]);
        assert_eq!(allowed(&local, &Method::GET, "/ws/panel", served), Ok(()));
        let evil = h(&[(header::HOST, served), (header::ORIGIN, "http://evil.example")]);
        assert!(allowed(&evil, &Method::GET, "/ws/panel", served).is_err());
        assert!(allowed(&evil, &Method::DELETE, "/api/programs/a", served).is_err());
        let no_origin = h(&[(header::HOST, served)]);
        assert!(allowed(&no_origin, &Method::GET, "/ws/panel", served).is_err());
        assert_eq!(
            allowed(&no_origin, &Method::GET, "/", served),
            Ok(()),
            "the page itself"
        );
        let rebound = h(&[(header::HOST, "attacker.example:8080")]);
        assert!(allowed(&rebound, &Method::GET, "/", served).is_err());
    }
}
