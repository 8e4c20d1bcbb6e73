//! The HMI's server in process, on a real TCP socket, with a fake loop: the bridge fed by
//! the test, the command thread replaced by one that records every request.
#![allow(clippy::unwrap_used)]

use futures_util::{SinkExt, StreamExt};
use hob_hmi::app::App;
use hob_hmi::bridge::Bridge;
use hob_hmi::commander::{Commander, Job};
use hob_hmi::compensation::Setup;
use hob_hmi::web::{self, Vendor};
use hob_ipc::gateway::Role;
use hob_ipc::{CommandResponse, EventSample, StateSample, command, event_kind};
use hob_setup::config::machine::MachineConfig;
use hob_store::library::Library;
use serde_json::{Value, json};
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tokio_tungstenite::tungstenite::{Message, client::IntoClientRequest, http::HeaderValue};

struct Fixture {
    addr: String,
    bridge: Arc<Mutex<Bridge>>,
    seen: Arc<Mutex<Vec<u32>>>,
    _dir: TempDir,
}

struct TempDir(std::path::PathBuf);
impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn machine() -> MachineConfig {
    hob_store::files::load_machine(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/machine.toml"))
        .unwrap()
}

/// A fake loop that accepts every command and records its code.
fn fake_loop(jobs: std::sync::mpsc::Receiver<Job>, seen: Arc<Mutex<Vec<u32>>>) {
    std::thread::spawn(move || {
        for j in jobs {
            seen.lock().unwrap().push(j.request.command);
            let _ = j
                .reply
                .send(Ok(CommandResponse::new(true, 0, "accepted by the fake loop")));
        }
    });
}

/// The view-only screen's token in these tests.
const VIEW_TOKEN: &str = "test-token-0123456789";

async fn start(view: bool) -> Fixture {
    start_with(view, |_| None).await
}

/// [`start`] of a panel at a user level (`hob-hmi --level`).
async fn start_at(level: Role) -> Fixture {
    start_full(false, |_| None, level, |_| None).await
}

/// [`start`] with the logger's directory `log(dir)` makes in the fixture's directory.
async fn start_with(view: bool, log: impl FnOnce(&Path) -> Option<std::path::PathBuf>) -> Fixture {
    start_full(view, log, Role::Build, |_| None).await
}

/// [`start_full`]'s COMPENSATE screen: the `hob` CLI and the checker's folder that
/// `setup(dir)` makes in the fixture's directory (`None`: the defaults, no folder).
type SetupFn = fn(&Path) -> Option<Setup>;

async fn start_full(
    view: bool,
    log: impl FnOnce(&Path) -> Option<std::path::PathBuf>,
    level: Role,
    setup: SetupFn,
) -> Fixture {
    let dir = std::env::temp_dir().join(format!(
        "hob-hmi-server-{}-{:?}",
        std::process::id(),
        Instant::now()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    let log_dir = log(&dir);
    let m = machine();
    let (bridge, hub) = Bridge::new(m.io.clone(), Duration::from_millis(100));
    let (commands, jobs) = Commander::new();
    let seen = Arc::new(Mutex::new(Vec::new()));
    fake_loop(jobs, seen.clone());
    let mut app = App::new(
        hub,
        commands,
        m,
        dir.join("machine.toml"),
        Library::open(&dir.join("library")).unwrap(),
        log_dir,
        level,
    );
    if let Some(s) = setup(&dir) {
        app = app.with_compensation(s);
    }
    let app = Arc::new(app);
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    let vendor = Arc::new(Vendor::default());
    let router = if view {
        web::view_router(app, vendor, web::ViewToken::new(VIEW_TOKEN).unwrap())
    } else {
        web::panel_router(app, vendor, addr.clone())
    };
    tokio::spawn(async move { axum::serve(listener, router).await });
    Fixture {
        addr,
        bridge: Arc::new(Mutex::new(bridge)),
        seen,
        _dir: TempDir(dir),
    }
}

type Ws = tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

async fn connect(f: &Fixture, path: &str, origin: &str) -> Result<Ws, String> {
    let mut req = format!("ws://{}{path}", f.addr).into_client_request().unwrap();
    req.headers_mut()
        .insert("origin", HeaderValue::from_str(origin).unwrap());
    req.headers_mut().insert(
        "cookie",
        HeaderValue::from_str(&format!("{}={VIEW_TOKEN}", web::VIEW_COOKIE)).unwrap(),
    );
    tokio_tungstenite::connect_async(req)
        .await
        .map(|(ws, _)| ws)
        .map_err(|e| e.to_string())
}

async fn send(ws: &mut Ws, v: Value) {
    ws.send(Message::Text(v.to_string().into())).await.unwrap();
}

/// The next message of type `t` within `within`.
async fn next(ws: &mut Ws, t: &str, within: Duration) -> Value {
    let end = tokio::time::Instant::now() + within;
    loop {
        let m = tokio::time::timeout_at(end, ws.next())
            .await
            .unwrap_or_else(|_| panic!("no {t} within {within:?}"));
        if let Some(Ok(Message::Text(s))) = m {
            let v: Value = serde_json::from_str(&s).unwrap();
            if v["t"] == t {
                return v;
            }
        } else if m.is_none() {
            panic!("socket closed waiting for {t}");
        }
    }
}

fn sample(cycle: u64) -> StateSample {
    StateSample {
        cycle,
        sync_time_ns: hob_rt_os::now_ns(),
        ..Default::default()
    }
}

fn event(seq: u64) -> EventSample {
    EventSample {
        seq,
        cycle: seq,
        kind: event_kind::PASS_STARTED,
        a: seq as u32,
        ..Default::default()
    }
}

/// Feeds the bridge `n` samples and publishes a frame.
fn frame(f: &Fixture, from: u64, n: u64) {
    let mut b = f.bridge.lock().unwrap();
    for c in from..from + n {
        b.state(sample(c), Instant::now());
    }
    b.frame(Instant::now(), hob_rt_os::now_ns(), 1_000);
}

#[tokio::test]
async fn a_page_gets_frames_with_their_age_and_the_silence_of_the_loop() {
    let f = start(false).await;
    let origin = format!("http://{}", f.addr);
    let mut ws = connect(&f, "/ws/panel", &origin).await.unwrap();
    send(&mut ws, json!({"t": "hello", "last_event": 0})).await;
    let hello = next(&mut ws, "hello", Duration::from_secs(2)).await;
    assert_eq!(hello["panel"], true);
    assert!(hello["signals"]["inputs"].as_array().unwrap().len() >= 10);
    // The snapshot after the hello: nothing from the loop yet, and it says so.
    let snap = next(&mut ws, "frame", Duration::from_secs(2)).await;
    assert!(snap["state"].is_null() && snap["loop_age_ms"].is_null(), "{snap}");
    frame(&f, 1, 40);
    let fr = next(&mut ws, "frame", Duration::from_secs(2)).await;
    assert_eq!(fr["state"]["cycle"], 40);
    assert_eq!(fr["plot"]["n"], 40);
    assert!(fr["loop_age_ms"].as_f64().unwrap() < 1000.0);
    assert!(fr["silent_ms"].is_null());
    // The loop goes quiet: the next frame says so.
    tokio::time::sleep(Duration::from_millis(150)).await;
    f.bridge
        .lock()
        .unwrap()
        .frame(Instant::now(), hob_rt_os::now_ns(), 2_000);
    let quiet = next(&mut ws, "frame", Duration::from_secs(2)).await;
    assert!(quiet["silent_ms"].as_u64().unwrap() >= 100, "{quiet}");
}

#[tokio::test]
async fn a_reconnecting_page_gets_exactly_the_events_it_missed() {
    let f = start(false).await;
    let origin = format!("http://{}", f.addr);
    {
        let mut b = f.bridge.lock().unwrap();
        for s in 1..=5 {
            b.event(event(s));
        }
    }
    let mut ws = connect(&f, "/ws/panel", &origin).await.unwrap();
    send(&mut ws, json!({"t": "hello", "last_event": 3})).await;
    let ev = next(&mut ws, "events", Duration::from_secs(2)).await;
    let seqs: Vec<u64> = ev["list"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["seq"].as_u64().unwrap())
        .collect();
    assert_eq!(seqs, vec![4, 5]);
    // A new event reaches the page at once, by itself.
    f.bridge.lock().unwrap().event(event(6));
    let ev = next(&mut ws, "events", Duration::from_secs(2)).await;
    assert_eq!(ev["list"][0]["seq"], 6);
    assert_eq!(ev["list"][0]["text"], "pass 6 started");
}

#[tokio::test]
async fn older_alarms_come_from_the_loggers_record_with_their_advice() {
    use hob_ipc::codec::Fault;
    // The logger recorded events 1-3 before hob-hmi started (3: a following error of Y);
    // the HMI itself saw 4 and 5.
    let alarm = EventSample {
        seq: 3,
        cycle: 3,
        kind: event_kind::ALARM,
        alarm: hob_ipc::AlarmCode {
            code: Fault::FollowingError.code(),
            axis: 3,
            value_a: 0.25,
            ..Default::default()
        },
        ..Default::default()
    };
    let f = start_with(false, |dir| {
        let log = dir.join("log");
        std::fs::create_dir_all(&log).unwrap();
        let lines: Vec<String> = [event(1), event(2), alarm]
            .iter()
            .map(|e| hob_logger::format::event_line(e) + "\n")
            .collect();
        std::fs::write(log.join("events.log"), lines.concat()).unwrap();
        Some(log)
    })
    .await;
    {
        let mut b = f.bridge.lock().unwrap();
        for s in 4..=5 {
            b.event(event(s));
        }
    }
    let origin = format!("http://{}", f.addr);
    let body = |r: &str| -> Value { serde_json::from_str(r.split("\r\n\r\n").nth(1).unwrap()).unwrap() };
    let page = body(&raw_http(&f.addr, "GET /api/alarms/page", &origin, "").await);
    let seqs: Vec<u64> = page["events"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["seq"].as_u64().unwrap())
        .collect();
    assert_eq!(seqs, vec![5, 4, 3, 2, 1], "{page}");
    assert_eq!(page["from_log"], 3, "{page}");
    let logged = &page["events"][2];
    assert_eq!(logged["kind"], "alarm", "{page}");
    let fault = Fault::FollowingError;
    assert_eq!(logged["alarm"]["remedy"], fault.remedy(), "{page}");
    assert_eq!(
        logged["alarm"]["how_to_continue"],
        fault.how_to_continue(),
        "{page}"
    );
    assert!(
        logged["alarm"]["text"].as_str().unwrap().contains('Y'),
        "the axis comes back with the code: {page}"
    );
    // A page before 4 is the log's alone; before 1 there is nothing.
    let older = body(&raw_http(&f.addr, "GET /api/alarms/page?before=3", &origin, "").await);
    assert_eq!(older["events"].as_array().unwrap().len(), 2, "{older}");
    let none = body(&raw_http(&f.addr, "GET /api/alarms/page?before=1", &origin, "").await);
    assert_eq!(none["events"].as_array().unwrap().len(), 0, "{none}");
}

#[tokio::test]
async fn a_restarted_server_sends_a_page_only_what_it_had_not_seen() {
    // The page saw up to 3 from the server before it was killed; the new server starts
    // with no events and receives the loop's history (1..=5) after the page's hello.
    let f = start(false).await;
    let origin = format!("http://{}", f.addr);
    let mut ws = connect(&f, "/ws/panel", &origin).await.unwrap();
    send(&mut ws, json!({"t": "hello", "last_event": 3})).await;
    next(&mut ws, "hello", Duration::from_secs(2)).await;
    tokio::time::sleep(Duration::from_millis(100)).await;
    {
        let mut b = f.bridge.lock().unwrap();
        for s in 1..=5 {
            b.event(event(s));
        }
    }
    let mut seqs = Vec::new();
    while seqs.last() != Some(&5) {
        let ev = next(&mut ws, "events", Duration::from_secs(2)).await;
        seqs.extend(
            ev["list"]
                .as_array()
                .unwrap()
                .iter()
                .map(|e| e["seq"].as_u64().unwrap()),
        );
    }
    assert_eq!(seqs, vec![4, 5]);
    // The loop restarts: its numbers start over, and the page is told before it gets them.
    f.bridge.lock().unwrap().event(EventSample {
        cycle: 999,
        ..event(1)
    });
    next(&mut ws, "events_restart", Duration::from_secs(2)).await;
    let ev = next(&mut ws, "events", Duration::from_secs(2)).await;
    assert_eq!(ev["list"][0]["seq"], 1);
}

#[tokio::test]
async fn closing_the_page_mid_jog_releases_the_jog() {
    let f = start(false).await;
    let origin = format!("http://{}", f.addr);
    let mut ws = connect(&f, "/ws/panel", &origin).await.unwrap();
    send(&mut ws, json!({"t": "hello", "last_event": 0})).await;
    next(&mut ws, "hello", Duration::from_secs(2)).await;
    send(
        &mut ws,
        json!({"t": "jog_hold", "id": 1, "axis": "x", "dir": "-", "speed": 300}),
    )
    .await;
    for _ in 0..3 {
        tokio::time::sleep(Duration::from_millis(100)).await;
        send(&mut ws, json!({"t": "jog_renew"})).await;
    }
    tokio::time::sleep(Duration::from_millis(100)).await;
    drop(ws);
    let end = Instant::now() + Duration::from_secs(2);
    loop {
        let seen = f.seen.lock().unwrap().clone();
        if seen.last() == Some(&command::JOG_RELEASE) {
            assert!(
                seen[..seen.len() - 1]
                    .iter()
                    .all(|c| *c == command::JOG_CONTINUOUS),
                "{seen:?}"
            );
            assert!(seen.len() >= 3, "the renewals were not forwarded: {seen:?}");
            break;
        }
        assert!(
            Instant::now() < end,
            "no release after the socket closed: {seen:?}"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

#[tokio::test]
async fn a_command_is_answered_by_its_id_and_a_bad_one_never_reaches_the_loop() {
    let f = start(false).await;
    let origin = format!("http://{}", f.addr);
    let mut ws = connect(&f, "/ws/panel", &origin).await.unwrap();
    send(&mut ws, json!({"t": "hello", "last_event": 0})).await;
    send(&mut ws, json!({"t": "cmd", "id": 7, "op": "home", "axis": "all"})).await;
    let a = next(&mut ws, "answer", Duration::from_secs(2)).await;
    assert_eq!((a["id"].as_u64(), a["ok"].as_bool()), (Some(7), Some(true)));
    send(&mut ws, json!({"t": "cmd", "id": 8, "op": "home", "axis": "b"})).await;
    let a = next(&mut ws, "answer", Duration::from_secs(2)).await;
    assert_eq!((a["id"].as_u64(), a["ok"].as_bool()), (Some(8), Some(false)));
    send(&mut ws, json!({"t": "cmd", "id": 9, "op": "launch_missiles"})).await;
    let a = next(&mut ws, "answer", Duration::from_secs(2)).await;
    assert_eq!((a["id"].as_u64(), a["ok"].as_bool()), (Some(9), Some(false)));
    assert_eq!(
        *f.seen.lock().unwrap(),
        vec![command::HOME],
        "only the valid command reached the loop"
    );
}

/// The pitch compensation as the loop's state has it (none, off, on) reaches the page in
/// words with the machine's worm set, and its key is the loop's command 23 (the suite's
/// loop has none loaded: OFF and ON are shown here, from the fake loop's samples).
#[tokio::test]
async fn the_pitch_compensation_reaches_the_page_and_its_key_is_the_loops_command() {
    use hob_ipc::vocab::pitch_compensation::{NONE, OFF, ON};
    let f = start(false).await;
    let origin = format!("http://{}", f.addr);
    let mut ws = connect(&f, "/ws/panel", &origin).await.unwrap();
    send(&mut ws, json!({"t": "hello", "last_event": 0})).await;
    let hello = next(&mut ws, "hello", Duration::from_secs(2)).await;
    assert_eq!(hello["worm_set"], machine().table.worm_set.unwrap().as_str());
    for (cycle, (code, word)) in (1u64..).zip([(NONE, "none"), (OFF, "off"), (ON, "on"), (7, "?")]) {
        {
            let mut b = f.bridge.lock().unwrap();
            b.state(
                StateSample {
                    pitch_compensation: code,
                    ..sample(cycle)
                },
                Instant::now(),
            );
            b.frame(Instant::now(), hob_rt_os::now_ns(), cycle);
        }
        let fr = loop {
            let fr = next(&mut ws, "frame", Duration::from_secs(2)).await;
            if fr["state"]["cycle"] == cycle {
                break fr;
            }
        };
        assert_eq!(fr["state"]["pitch_compensation"], word, "code {code}");
    }
    for (id, on) in [(11, true), (12, false)] {
        send(
            &mut ws,
            json!({"t": "cmd", "id": id, "op": "pitch_compensation", "on": on}),
        )
        .await;
        let a = next(&mut ws, "answer", Duration::from_secs(2)).await;
        assert_eq!((a["id"].as_u64(), a["ok"].as_bool()), (Some(id), Some(true)));
    }
    assert_eq!(*f.seen.lock().unwrap(), vec![command::PITCH_COMPENSATION; 2]);
}

#[tokio::test]
async fn a_foreign_origin_is_refused_and_the_view_screen_cannot_command() {
    let f = start(false).await;
    assert!(connect(&f, "/ws/panel", "http://evil.example").await.is_err());
    let v = start(true).await;
    let origin = format!("http://{}", v.addr);
    assert!(
        connect(&v, "/ws/panel", &origin).await.is_err(),
        "the view screen has no panel socket"
    );
    let mut ws = connect(&v, "/ws/view", &origin).await.unwrap();
    send(&mut ws, json!({"t": "hello", "last_event": 0})).await;
    assert_eq!(
        next(&mut ws, "hello", Duration::from_secs(2)).await["panel"],
        false
    );
    send(&mut ws, json!({"t": "cmd", "id": 1, "op": "reset"})).await;
    // The view socket closes on any command; nothing reaches the loop.
    let end = tokio::time::Instant::now() + Duration::from_secs(2);
    loop {
        match tokio::time::timeout_at(end, ws.next()).await {
            Ok(Some(Ok(Message::Text(_)))) => continue,
            Ok(_) => break,
            Err(_) => panic!("the view socket stayed open after a command"),
        }
    }
    assert!(v.seen.lock().unwrap().is_empty());
    // Without its token the view screen shows nothing; the link with it sets the cookie.
    let r = raw_http(&v.addr, "GET /api/cut/report", &origin, "").await;
    assert!(r.starts_with("HTTP/1.1 401"), "{r}");
    let r = raw_http(&v.addr, "GET /", &origin, "").await;
    assert!(r.starts_with("HTTP/1.1 401"), "{r}");
    let r = raw_http(&v.addr, &format!("GET /?token={VIEW_TOKEN}"), &origin, "").await;
    assert!(r.starts_with("HTTP/1.1 303"), "{r}");
    assert!(
        r.contains(&format!("{}={VIEW_TOKEN}; HttpOnly", web::VIEW_COOKIE)),
        "{r}"
    );
    let mut no_cookie = format!("ws://{}/ws/view", v.addr).into_client_request().unwrap();
    no_cookie
        .headers_mut()
        .insert("origin", HeaderValue::from_str(&origin).unwrap());
    assert!(
        tokio_tungstenite::connect_async(no_cookie).await.is_err(),
        "a socket without the token"
    );
    // And it has no route that changes the library.
    let cookie = format!("Cookie: {}={VIEW_TOKEN}\r\n", web::VIEW_COOKIE);
    let r = raw_http(&v.addr, "GET /", &origin, &cookie).await;
    assert!(
        r.starts_with("HTTP/1.1 200") && r.contains(r#"content="/ws/view""#),
        "the view page uses the view socket: {r}"
    );
    let r = raw_http(&v.addr, "DELETE /api/programs/x", &origin, &cookie).await;
    assert!(
        r.starts_with("HTTP/1.1 404") || r.starts_with("HTTP/1.1 405"),
        "{r}"
    );
    let r = raw_http(&f.addr, "DELETE /api/programs/x", "http://evil.example", "").await;
    assert!(r.starts_with("HTTP/1.1 403"), "{r}");
}

async fn raw_http(addr: &str, line: &str, origin: &str, extra_headers: &str) -> String {
    raw_request(addr, line, origin, extra_headers, "").await
}

async fn raw_request(addr: &str, line: &str, origin: &str, extra_headers: &str, body: &str) -> String {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let mut s = tokio::net::TcpStream::connect(addr).await.unwrap();
    let req = format!(
        "{line} HTTP/1.1\r\nHost: {addr}\r\nOrigin: {origin}\r\n{extra_headers}Connection: close\r\n\r\n{body}"
    );
    s.write_all(req.as_bytes()).await.unwrap();
    let mut out = String::new();
    s.read_to_string(&mut out).await.unwrap();
    out
}

/// A request with a JSON body, as the page sends it.
async fn raw_post(addr: &str, line: &str, body: &str) -> String {
    let headers = format!(
        "Content-Type: application/json\r\nContent-Length: {}\r\n",
        body.len()
    );
    raw_request(addr, line, &format!("http://{addr}"), &headers, body).await
}

/// An operator's panel defines programs but changes no tool and carries no correction:
/// refused with the level in words (HTTP 403), nothing written; a setter's panel may.
#[tokio::test]
async fn an_operators_panel_changes_no_tool_and_carries_no_correction() {
    let f = start_at(Role::Operate).await;
    let body = json!({ "text": "format_version = 1\n" }).to_string();
    for (line, body) in [
        ("POST /api/tools/new-hob", body.as_str()),
        ("DELETE /api/tools/new-hob", ""),
        ("POST /api/tools/new-hob/copy", r#"{"to":"other"}"#),
        ("POST /api/tool-from-form", r#"{"name":"t","fields":[]}"#),
        (
            "POST /api/span/carry",
            r#"{"program":"p","k":"2","measured_mm":"24,1"}"#,
        ),
    ] {
        let r = raw_post(&f.addr, line, body).await;
        assert!(r.starts_with("HTTP/1.1 403"), "{line}: {r}");
        assert!(
            r.contains("this panel is at the operator level, which may not"),
            "{line}: {r}"
        );
        assert!(r.contains("a setter's work"), "{line}: {r}");
    }
    assert!(!f._dir.0.join("library/tools/new-hob.toml").exists());
    // A program is the operator's: the library's own check answers, not the level.
    let r = raw_post(
        &f.addr,
        "POST /api/programs/p",
        &json!({"text": "not toml ["}).to_string(),
    )
    .await;
    assert!(!r.starts_with("HTTP/1.1 403"), "{r}");
    // The hello says what the level may.
    let origin = format!("http://{}", f.addr);
    let mut ws = connect(&f, "/ws/panel", &origin).await.unwrap();
    send(&mut ws, json!({"t": "hello", "last_event": 0})).await;
    let hello = next(&mut ws, "hello", Duration::from_secs(2)).await;
    assert_eq!(hello["level"]["name"], "operator");
    assert!(
        hello["level"]["may_not"]
            .as_array()
            .unwrap()
            .contains(&json!("change tools")),
        "{hello}"
    );
    // A setter's panel: the tool is the library's to check.
    let s = start_at(Role::Set).await;
    let r = raw_post(&s.addr, "DELETE /api/tools/new-hob", "").await;
    assert!(!r.starts_with("HTTP/1.1 403"), "{r}");
}

/// The JSON body of a raw HTTP answer.
fn json_body(r: &str) -> Value {
    let body = r.split_once("\r\n\r\n").map_or("", |(_, b)| b);
    serde_json::from_str(body).unwrap_or_else(|e| panic!("{e}: {r}"))
}

/// A stand-in for the `hob` CLI (the HMI links no control core and runs the real one; the
/// browser suite runs that): it notes each call's arguments in `calls.txt` beside it and
/// answers as `mode` beside it says: `refuse` as `hob compensate` refuses (exit 2, its
/// words on standard error), `ok` with its arguments and a plot into `--svg`.
const FAKE_HOB: &str = r#"#!/bin/sh
here=$(dirname "$0")
echo "$*" >> "$here/calls.txt"
if [ "$(cat "$here/mode")" = refuse ]; then
  echo 'hob: refused: /media/usb/other.csv: gear: the measurement is of "Spur z99", the program cuts "Thesis worst case"' >&2
  exit 2
fi
prev=""
for a in "$@"; do
  [ "$prev" = "--svg" ] && echo '<svg xmlns="http://www.w3.org/2000/svg"><polyline points="0,0 1,1"/></svg>' > "$a"
  echo "arg: $a"
  prev="$a"
done
echo "not written (run again with --yes to write it)"
"#;

/// The COMPENSATE screen's set-up in the fixture's directory: the fake `hob` (answering as
/// `mode` says) and a folder of two checker's files, `older.csv` a day older than `newer.csv`.
fn fake_setup(dir: &Path) -> Option<Setup> {
    use std::os::unix::fs::PermissionsExt;
    let bin = dir.join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    let hob = bin.join("hob");
    std::fs::write(&hob, FAKE_HOB).unwrap();
    std::fs::set_permissions(&hob, std::fs::Permissions::from_mode(0o755)).unwrap();
    std::fs::write(bin.join("mode"), "ok").unwrap();
    let folder = dir.join("measurements");
    std::fs::create_dir_all(folder.join("sub")).unwrap();
    for name in ["older.csv", "newer.csv", "sub/inner.csv", "notes.txt"] {
        std::fs::write(folder.join(name), "# hob gear measurement 1\n").unwrap();
    }
    let day_ago = std::time::SystemTime::now() - Duration::from_secs(86_400);
    std::fs::File::options()
        .write(true)
        .open(folder.join("older.csv"))
        .unwrap()
        .set_modified(day_ago)
        .unwrap();
    Some(Setup {
        hob,
        measurements_dir: Some(folder),
    })
}

/// A panel at `level` with the fake `hob`, the folder, a log directory and the library
/// program `gear`.
async fn compensate_panel(level: Role) -> Fixture {
    let f = start_full(false, |d| Some(d.join("log")), level, fake_setup).await;
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/programs/spur-z17-m5.toml"),
    )
    .unwrap();
    let r = raw_post(
        &f.addr,
        "POST /api/programs/gear",
        &json!({ "text": text }).to_string(),
    )
    .await;
    assert!(r.starts_with("HTTP/1.1 201"), "{r}");
    f
}

fn calls(f: &Fixture) -> Vec<String> {
    std::fs::read_to_string(f._dir.0.join("bin/calls.txt"))
        .map(|t| t.lines().map(str::to_string).collect())
        .unwrap_or_default()
}

async fn preview(f: &Fixture, measurements: &[&str]) -> String {
    let body = json!({"program": "gear", "measurements": measurements, "cycles": [5, 9]});
    raw_post(&f.addr, "POST /api/compensate/preview", &body.to_string()).await
}

#[tokio::test]
async fn without_a_measurements_folder_the_screen_says_so_and_runs_nothing() {
    let f = start_full(false, |d| Some(d.join("log")), Role::Build, |_| None).await;
    let words = "hob-hmi was started without --measurements-dir";
    let r = raw_http(&f.addr, "GET /api/compensate", &format!("http://{}", f.addr), "").await;
    let v = json_body(&r);
    assert!(v["files_refused"].as_str().unwrap().starts_with(words), "{v}");
    assert_eq!(v["files"], json!([]));
    let r = preview(&f, &["a.csv"]).await;
    assert!(r.starts_with("HTTP/1.1 422"), "{r}");
    assert!(
        json_body(&r)["refused"].as_str().unwrap().starts_with(words),
        "{r}"
    );
}

#[tokio::test]
async fn only_the_names_of_the_folders_checker_files_are_taken() {
    let f = compensate_panel(Role::Build).await;
    let r = raw_http(&f.addr, "GET /api/compensate", &format!("http://{}", f.addr), "").await;
    let v = json_body(&r);
    let names: Vec<&str> = v["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["newer.csv", "older.csv"], "newest first, .csv files only");
    assert_eq!(v["files_refused"], Value::Null);
    for (name, words) in [
        ("../newer.csv", "only the name of a file"),
        ("/etc/passwd", "only the name of a file"),
        ("sub/inner.csv", "only the name of a file"),
        ("..", "only the name of a file"),
        ("notes.txt", "no such checker's file"),
        ("absent.csv", "no such checker's file"),
    ] {
        let r = preview(&f, &["newer.csv", name]).await;
        assert!(r.starts_with("HTTP/1.1 422"), "{name}: {r}");
        let refused = json_body(&r)["refused"].as_str().unwrap().to_string();
        assert!(
            refused.contains(words) && refused.contains("nothing was read"),
            "{name}: {refused}"
        );
    }
    assert_eq!(calls(&f), Vec::<String>::new(), "hob ran for a bad name");
    let r = preview(&f, &[]).await;
    assert!(
        r.starts_with("HTTP/1.1 422") && r.contains("none is picked"),
        "{r}"
    );
}

#[tokio::test]
async fn the_clis_refusal_reaches_the_page_word_for_word_and_nothing_is_held() {
    let f = compensate_panel(Role::Set).await;
    std::fs::write(f._dir.0.join("bin/mode"), "refuse").unwrap();
    let r = preview(&f, &["newer.csv"]).await;
    assert!(r.starts_with("HTTP/1.1 422"), "{r}");
    let v = json_body(&r);
    let said = "hob: refused: /media/usb/other.csv: gear: the measurement is of \"Spur z99\", the program cuts \"Thesis worst case\"";
    assert_eq!(v["refused"], said);
    assert_eq!(
        (v["state"].as_str(), v["text"].as_str()),
        (Some("refused"), Some(said))
    );
    let c = calls(&f);
    assert_eq!(c.len(), 1);
    assert!(!c[0].contains("--yes"), "{}", c[0]);
    let r = raw_http(&f.addr, "GET /api/compensate", &format!("http://{}", f.addr), "").await;
    assert_eq!(json_body(&r)["held"], Value::Null, "a refusal held a request");
    let r = raw_post(&f.addr, "POST /api/compensate/write", "").await;
    assert!(
        r.starts_with("HTTP/1.1 422") && r.contains("nothing previewed to write"),
        "{r}"
    );
    assert_eq!(calls(&f).len(), 1, "WRITE ran hob without a preview");
}

#[tokio::test]
async fn a_preview_is_written_with_yes_and_only_at_the_setters_level() {
    let origin = |f: &Fixture| format!("http://{}", f.addr);
    // An operator's panel previews (nothing is written) but may not write.
    let f = compensate_panel(Role::Operate).await;
    let r = preview(&f, &["newer.csv", "older.csv"]).await;
    assert!(r.starts_with("HTTP/1.1 200"), "{r}");
    let v = json_body(&r);
    assert_eq!(v["state"], "preview");
    let text = v["text"].as_str().unwrap();
    let folder = f._dir.0.join("measurements");
    for arg in [
        "arg: compensate".to_string(),
        format!("arg: {}", f._dir.0.join("machine.toml").display()),
        format!("arg: {}", f._dir.0.join("library/programs/gear.toml").display()),
        format!("arg: {}", f._dir.0.join("log").display()),
        format!("arg: {}", folder.join("newer.csv").display()),
        format!("arg: {}", folder.join("older.csv").display()),
        "arg: --cycles\narg: 5..9".to_string(),
    ] {
        assert!(text.contains(&arg), "{arg:?} not in:\n{text}");
    }
    assert!(!text.contains("arg: --yes"), "{text}");
    assert!(v["svg"].as_str().unwrap().starts_with("<svg"), "{v}");
    let over = json_body(&raw_http(&f.addr, "GET /api/compensate", &origin(&f), "").await);
    assert_eq!(over["held"]["measurements"], json!(["newer.csv", "older.csv"]));
    assert!(
        over["write_refused"]
            .as_str()
            .unwrap()
            .contains("a setter's work"),
        "{over}"
    );
    let r = raw_post(&f.addr, "POST /api/compensate/write", "").await;
    assert!(r.starts_with("HTTP/1.1 403"), "{r}");
    assert!(
        r.contains("this panel is at the operator level") && r.contains("a setter's work"),
        "{r}"
    );
    assert_eq!(calls(&f).len(), 1, "the operator's WRITE ran hob");
    // A setter's panel writes what it previewed, with --yes, once.
    let s = compensate_panel(Role::Set).await;
    assert!(preview(&s, &["older.csv"]).await.starts_with("HTTP/1.1 200"));
    let r = raw_post(&s.addr, "POST /api/compensate/write", "").await;
    assert!(r.starts_with("HTTP/1.1 200"), "{r}");
    assert_eq!(json_body(&r)["state"], "written");
    let c = calls(&s);
    assert_eq!(c.len(), 2);
    // The same arguments but the plot's scratch file, and --yes.
    let without_svg = |call: &str| {
        let words: Vec<&str> = call.split(' ').collect();
        let at = words.iter().position(|w| *w == "--svg").unwrap();
        [&words[..at], &words[at + 2..]].concat().join(" ")
    };
    assert_eq!(without_svg(&c[1]), format!("{} --yes", without_svg(&c[0])));
    assert!(c[0].contains("older.csv --cycles 5..9 --svg"), "{}", c[0]);
    let over = json_body(&raw_http(&s.addr, "GET /api/compensate", &origin(&s), "").await);
    assert_eq!(over["held"], Value::Null, "the written request is still held");
    let r = raw_post(&s.addr, "POST /api/compensate/write", "").await;
    assert!(r.starts_with("HTTP/1.1 422"), "{r}");
}
