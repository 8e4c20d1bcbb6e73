//! The routes, the guard in front of them, and the page's files. The page (HTML, CSS, ES
//! modules) is built into the binary; the third-party view library (Preact and htm) is read
//! once at start-up from an npm install (`--vendor`), never copied into the repository.

use crate::app::App;
use crate::error::Error;
use crate::{api, compensate, definition, ws};
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
    ("keypad.mjs", include_str!("../web/js/keypad.mjs")),
    ("screens.mjs", include_str!("../web/js/screens.mjs")),
    ("compensate.mjs", include_str!("../web/js/compensate.mjs")),
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
    pub fn load(dir: &std::path::Path) -> Result<Self, Error> {
        let mut m = BTreeMap::new();
        for (name, rel) in VENDOR {
            let path = dir.join(rel);
            let text =
                std::fs::read_to_string(&path).map_err(|error| Error::VendorMissing { path, error })?;
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

/// The page of the view-only screen: the same page on the view socket.
async fn view_index() -> Response {
    let page = ASSETS[0].1.replace(
        r#"<meta name="hob-socket" content="/ws/panel">"#,
        r#"<meta name="hob-socket" content="/ws/view">"#,
    );
    file("index.html", &page)
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
        .route("/api/words", get(api::words))
        .route("/api/language", post(api::language))
        .route("/api/form/{name}", get(definition::fields))
        .route("/api/plan/{name}", get(definition::plan))
        .route("/api/check", post(definition::check))
        .route("/api/save", post(definition::save))
        .route("/api/span", post(definition::span))
        .route("/api/tool-from-form", post(definition::tool_from_form))
        .route("/api/span/carry", post(definition::span_carry))
        .route("/api/compensate", get(compensate::overview))
        .route("/api/compensate/preview", post(compensate::preview))
        .route("/api/compensate/write", post(compensate::write))
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
/// Every request needs the view token ([`view_allowed`]).
pub fn view_router(app: Arc<App>, vendor_files: Arc<Vendor>, token: ViewToken) -> Router {
    let files = Files {
        app: app.clone(),
        vendor: vendor_files,
    };
    let api = Router::new()
        .route("/api/alarms/page", get(api::alarms))
        .route("/api/cut/report", get(api::report))
        .route("/api/words", get(api::words))
        .with_state(app);
    Router::new()
        .route("/", get(view_index))
        .route("/assets/{name}", get(asset))
        .route("/vendor/{name}", get(vendor))
        .route("/ws/view", get(ws_view))
        .with_state(files)
        .merge(api)
        .layer(middleware::from_fn_with_state(Arc::new(token), view_guard))
}

/// The secret of the view-only screen: a remote browser opens `/?token=SECRET` once and
/// keeps it in a cookie.
#[derive(Clone)]
pub struct ViewToken(String);

impl std::fmt::Debug for ViewToken {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("ViewToken(..)")
    }
}

/// The cookie holding the view token.
pub const VIEW_COOKIE: &str = "hob_view";
/// The shortest token taken (printable ASCII, no spaces, `;` or `=`).
pub const VIEW_TOKEN_MIN_CHARS: usize = 16;

impl ViewToken {
    /// A token as read from its file (`--view-token-file`), checked.
    pub fn new(text: &str) -> Result<Self, Error> {
        let t = text.trim();
        if t.len() < VIEW_TOKEN_MIN_CHARS {
            return Err(Error::ViewTokenShort {
                chars: t.len(),
                min: VIEW_TOKEN_MIN_CHARS,
            });
        }
        if !t
            .bytes()
            .all(|b| b.is_ascii_graphic() && b != b';' && b != b'=' && b != b'&')
        {
            return Err(Error::ViewTokenCharacters);
        }
        Ok(Self(t.to_string()))
    }

    /// Compares in time independent of where the first difference is.
    fn matches(&self, given: &str) -> bool {
        let (a, b) = (self.0.as_bytes(), given.as_bytes());
        a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
    }
}

/// What the view guard does with a request.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ViewVerdict {
    Pass,
    /// The link with the token: set the cookie and go to the page.
    SetCookie,
    Unauthorised(&'static str),
    Forbidden(&'static str),
}

/// Whether a request to the view-only screen may pass: it needs the token (in its cookie,
/// an `Authorization: Bearer` header, or once in the page's link `/?token=`), and a
/// WebSocket needs an `Origin` of the host it asks (no other site's page reads the machine
/// through a viewer's browser). The token, not the host name, guards it: a remote screen
/// reaches the machine by whatever name the shop's network gives it.
pub fn view_allowed(headers: &HeaderMap, path: &str, query: Option<&str>, token: &ViewToken) -> ViewVerdict {
    if path == "/"
        && let Some(q) = query
        && let Some(t) = q.split('&').find_map(|kv| kv.strip_prefix("token="))
    {
        return if token.matches(t) {
            ViewVerdict::SetCookie
        } else {
            ViewVerdict::Unauthorised("this link's token is not the view token")
        };
    }
    let cookie_ok = headers.get_all(header::COOKIE).iter().any(|v| {
        v.to_str().ok().is_some_and(|c| {
            c.split(';')
                .filter_map(|kv| kv.trim().strip_prefix(VIEW_COOKIE)?.strip_prefix('='))
                .any(|t| token.matches(t))
        })
    });
    let bearer_ok = headers
        .get(header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.strip_prefix("Bearer "))
        .is_some_and(|t| token.matches(t));
    if !(cookie_ok || bearer_ok) {
        return ViewVerdict::Unauthorised(
            "view-only screen of hob: open it with the link that holds its token (/?token=...)",
        );
    }
    if path.starts_with("/ws/") {
        let host = headers
            .get(header::HOST)
            .and_then(|h| h.to_str().ok())
            .unwrap_or("");
        let origin = headers
            .get(header::ORIGIN)
            .and_then(|h| h.to_str().ok())
            .unwrap_or("");
        if host.is_empty() || origin != format!("http://{host}") {
            return ViewVerdict::Forbidden("the view socket is served only to this server's own page");
        }
    }
    ViewVerdict::Pass
}

async fn view_guard(State(token): State<Arc<ViewToken>>, req: Request<Body>, next: Next) -> Response {
    match view_allowed(req.headers(), req.uri().path(), req.uri().query(), &token) {
        ViewVerdict::Pass => next.run(req).await,
        ViewVerdict::SetCookie => (
            StatusCode::SEE_OTHER,
            [
                (header::LOCATION, "/".to_string()),
                (
                    header::SET_COOKIE,
                    format!("{VIEW_COOKIE}={}; HttpOnly; SameSite=Strict; Path=/", token.0),
                ),
            ],
        )
            .into_response(),
        ViewVerdict::Unauthorised(why) => (StatusCode::UNAUTHORIZED, why).into_response(),
        ViewVerdict::Forbidden(why) => (StatusCode::FORBIDDEN, why).into_response(),
    }
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

    #[test]
    fn the_view_screen_needs_its_token_and_its_own_origin_on_the_socket() {
        let t = ViewToken::new("0123456789abcdefXYZ\n").expect("a token");
        assert!(ViewToken::new("short").is_err());
        assert!(ViewToken::new("0123456789abcdef ghij").is_err(), "a space");
        let none = h(&[(header::HOST, "hobber:8081")]);
        assert!(matches!(
            view_allowed(&none, "/", None, &t),
            ViewVerdict::Unauthorised(_)
        ));
        assert!(matches!(
            view_allowed(&none, "/api/cut/report", None, &t),
            ViewVerdict::Unauthorised(_)
        ));
        assert_eq!(
            view_allowed(&none, "/", Some("token=0123456789abcdefXYZ"), &t),
            ViewVerdict::SetCookie
        );
        assert!(matches!(
            view_allowed(&none, "/", Some("token=0123456789abcdefXYY"), &t),
            ViewVerdict::Unauthorised(_)
        ));
        let cookie = h(&[
            (header::HOST, "hobber:8081"),
            (header::COOKIE, "a=b; hob_view=0123456789abcdefXYZ"),
        ]);
        assert_eq!(
            view_allowed(&cookie, "/assets/app.css", None, &t),
            ViewVerdict::Pass
        );
        let bearer = h(&[
            (header::HOST, "hobber:8081"),
            (header::AUTHORIZATION, "Bearer 0123456789abcdefXYZ"),
        ]);
        assert_eq!(
            view_allowed(&bearer, "/api/cut/report", None, &t),
            ViewVerdict::Pass
        );
        // The socket: the token and the page's own origin.
        assert!(matches!(
            view_allowed(&cookie, "/ws/view", None, &t),
            ViewVerdict::Forbidden(_)
        ));
        let own = h(&[
            (header::HOST, "hobber:8081"),
            (header::COOKIE, "hob_view=0123456789abcdefXYZ"),
            (header::ORIGIN, "http://hobber:8081"),
        ]);
        assert_eq!(view_allowed(&own, "/ws/view", None, &t), ViewVerdict::Pass);
        let foreign = h(&[
            (header::HOST, "hobber:8081"),
            (header::COOKIE, "hob_view=0123456789abcdefXYZ"),
            (header::ORIGIN, "http://evil.example"),
        ]);
        assert!(matches!(
            view_allowed(&foreign, "/ws/view", None, &t),
            ViewVerdict::Forbidden(_)
        ));
    }
}
