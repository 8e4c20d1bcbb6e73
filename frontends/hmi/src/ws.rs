//! One WebSocket per browser: a `hello` gets the machine's description and a snapshot with
//! the events the page missed (by number); then the newest frame at the screen rate (a slow
//! browser skips frames, counted, never events), every event, the loop's stats each second,
//! and the answers to its commands. A panel socket may command and jog; a view socket only
//! reads (any command closes it).

use crate::app::App;
use crate::commander::Reply;
use crate::jog::{JogSession, Sent};
use crate::protocol::{Answer, ClientMsg, EventView, Frame, Op};
use axum::extract::ws::{Message, Utf8Bytes, WebSocket};
use serde::Serialize;
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::sync::mpsc;

/// A send that takes longer closes the socket (the browser is gone or stuck).
pub const SEND_TIMEOUT: Duration = Duration::from_secs(2);

#[derive(Serialize)]
#[serde(tag = "t", rename_all = "snake_case")]
enum Out<'a> {
    Hello {
        #[serde(flatten)]
        info: &'a serde_json::Value,
        panel: bool,
    },
    Frame {
        skipped: u64,
        /// The cycle's time left, when this HMI knows the loaded program's plan.
        time_left_s: Option<f64>,
        /// The library program this HMI loaded, while it is the loop's program.
        loaded_here: Option<String>,
        #[serde(flatten)]
        frame: &'a Frame,
    },
    Events {
        list: &'a [EventView],
    },
    EventsLost {
        from: u64,
        to: u64,
        why: &'static str,
    },
    /// The loop restarted: its events are numbered from 1 again.
    EventsRestart,
    Stats {
        #[serde(flatten)]
        stats: &'a crate::protocol::StatsView,
    },
    Answer(&'a Answer),
}

struct Socket {
    ws: WebSocket,
}

impl Socket {
    async fn send(&mut self, m: &Out<'_>) -> bool {
        let Ok(text) = serde_json::to_string(m) else {
            return false;
        };
        matches!(
            tokio::time::timeout(SEND_TIMEOUT, self.ws.send(Message::Text(Utf8Bytes::from(text)))).await,
            Ok(Ok(()))
        )
    }
}

/// What the socket task waits for besides the browser: the loop's answers.
struct Waiting {
    tx: mpsc::UnboundedSender<(Answer, bool)>,
}

impl Waiting {
    /// As [`Waiting::answer`], running `accepted` first when the loop accepts.
    fn answer_then(
        &self,
        id: u64,
        reply: tokio::sync::oneshot::Receiver<Reply>,
        accepted: impl FnOnce() + Send + 'static,
    ) {
        let tx = self.tx.clone();
        tokio::spawn(async move {
            let a = match reply.await {
                Ok(Ok(r)) => Answer::of(id, &r),
                Ok(Err(e)) => Answer::refused(id, e),
                Err(_) => Answer::refused(id, "the HMI's command thread has stopped"),
            };
            if a.ok {
                accepted();
            }
            let _ = tx.send((a, false));
        });
    }

    /// Forwards the loop's answer to `id` when it comes; `jog`: a jog's answer (only a
    /// refusal is shown; it also ends the hold).
    fn answer(&self, id: u64, reply: tokio::sync::oneshot::Receiver<Reply>, jog: bool) {
        let tx = self.tx.clone();
        tokio::spawn(async move {
            let a = match reply.await {
                Ok(Ok(r)) => Answer::of(id, &r),
                Ok(Err(e)) => Answer::refused(id, e),
                Err(_) => Answer::refused(id, "the HMI's command thread has stopped"),
            };
            let _ = tx.send((a, jog));
        });
    }
}

fn time_left(app: &App, f: &Frame) -> Option<f64> {
    app.time_left_s(f.state.as_ref()?)
}

fn loaded_here(app: &App, f: &Frame) -> Option<String> {
    app.loaded_here(f.state.as_ref()?.program_hash).map(|l| l.name)
}

/// Serves one browser until it goes.
pub async fn serve(ws: WebSocket, app: Arc<App>, panel: bool) {
    let mut s = Socket { ws };
    let mut frames = app.hub.frames.clone();
    let mut events_head = app.hub.events_head.clone();
    let mut stats = app.hub.stats.clone();
    let (tx, mut answers) = mpsc::unbounded_channel();
    let waiting = Waiting { tx };
    let mut jog = JogSession::new(app.commands.clone());
    // Until the page says hello, it gets nothing.
    let mut last_event: Option<u64> = None;
    let mut generation = app.hub.book().log.generation;
    let mut last_frame = 0u64;
    let mut tick = tokio::time::interval(Duration::from_secs(1));
    loop {
        tokio::select! {
            msg = s.ws.recv() => {
                let text = match msg {
                    Some(Ok(Message::Text(t))) => t,
                    Some(Ok(Message::Ping(_) | Message::Pong(_) | Message::Binary(_))) => continue,
                    _ => break,
                };
                let msg = match serde_json::from_str::<ClientMsg>(text.as_str()) {
                    Ok(m) => m,
                    Err(e) => {
                        let id = serde_json::from_str::<serde_json::Value>(text.as_str()).ok()
                            .and_then(|v| v.get("id").and_then(serde_json::Value::as_u64)).unwrap_or(0);
                        if !s.send(&Out::Answer(&Answer::refused(id, format!("the HMI server cannot read this message: {e}")))).await {
                            break;
                        }
                        continue;
                    }
                };
                match msg {
                    ClientMsg::Hello { last_event: seen } => {
                        if !s.send(&Out::Hello { info: &app.hello, panel }).await {
                            break;
                        }
                        let f = frames.borrow_and_update().clone();
                        last_frame = f.seq;
                        if !s.send(&Out::Frame { skipped: 0, time_left_s: time_left(&app, &f), loaded_here: loaded_here(&app, &f), frame: &f }).await {
                            break;
                        }
                        last_event = Some(seen);
                        if !send_events(&mut s, &app, &mut last_event, &mut generation).await {
                            break;
                        }
                    }
                    _ if !panel => break,
                    ClientMsg::Cmd { id, op: Op::Load { program } } => match app.load_request(&program) {
                        Ok((r, loaded)) => {
                            let app2 = app.clone();
                            waiting.answer_then(id, app.commands.submit(r), move || app2.loaded(loaded));
                        }
                        Err(e) => {
                            if !s.send(&Out::Answer(&Answer::refused(id, e))).await {
                                break;
                            }
                        }
                    },
                    ClientMsg::Cmd { id, op } => {
                        match op.request() {
                            Ok(r) => waiting.answer(id, app.commands.submit(r), false),
                            Err(e) => {
                                if !s.send(&Out::Answer(&Answer::refused(id, e))).await {
                                    break;
                                }
                            }
                        }
                    }
                    ClientMsg::JogHold { id, axis, dir, speed } => {
                        match jog.hold(id, &axis, &dir, speed, Instant::now()) {
                            Ok(Sent { id, reply }) => waiting.answer(id, reply, true),
                            Err(e) => {
                                if !s.send(&Out::Answer(&Answer::refused(id, e))).await {
                                    break;
                                }
                            }
                        }
                    }
                    ClientMsg::JogRenew => {
                        if let Some(Sent { id, reply }) = jog.renew(Instant::now()) {
                            waiting.answer(id, reply, true);
                        }
                    }
                    ClientMsg::JogRelease | ClientMsg::Visibility { visible: false } => {
                        let _ = jog.release();
                    }
                    ClientMsg::Visibility { visible: true } => {}
                }
            }
            r = frames.changed() => {
                if r.is_err() {
                    break;
                }
                let f = frames.borrow_and_update().clone();
                if last_event.is_none() {
                    continue;
                }
                let skipped = f.seq.saturating_sub(last_frame + 1);
                last_frame = f.seq;
                if !s.send(&Out::Frame { skipped, time_left_s: time_left(&app, &f), loaded_here: loaded_here(&app, &f), frame: &f }).await {
                    break;
                }
            }
            r = events_head.changed() => {
                if r.is_err() {
                    break;
                }
                events_head.borrow_and_update();
                if !send_events(&mut s, &app, &mut last_event, &mut generation).await {
                    break;
                }
            }
            Some((a, is_jog)) = answers.recv() => {
                if is_jog && a.ok {
                    continue;
                }
                if is_jog {
                    jog.refused(a.id);
                }
                if !s.send(&Out::Answer(&a)).await {
                    break;
                }
            }
            _ = tick.tick() => {
                let st = stats.borrow_and_update().clone();
                if let (Some(st), Some(_)) = (st, last_event)
                    && !s.send(&Out::Stats { stats: &st }).await
                {
                    break;
                }
            }
        }
    }
    // Whatever ended the socket, a running jog stops now (also by Drop).
    let _ = jog.release();
}

/// Every event after `last` (nothing before the page's hello). A restarted HMI server
/// starts with no events and gets the loop's recent ones later: the page's number stands
/// until then. A restarted loop numbers from 1 again: the page is told and starts over.
async fn send_events(s: &mut Socket, app: &App, last: &mut Option<u64>, generation: &mut u64) -> bool {
    let Some(mut seen) = *last else { return true };
    let (events, lost, restarted) = {
        let book = app.hub.book();
        let restarted = book.log.generation != *generation;
        *generation = book.log.generation;
        if restarted {
            seen = 0;
        }
        let (events, lost) = book.since(seen);
        (events, lost, restarted)
    };
    if restarted && !s.send(&Out::EventsRestart).await {
        return false;
    }
    if let Some((from, to)) = lost
        && !s
            .send(&Out::EventsLost {
                from,
                to,
                why: "older than the HMI's memory of events: see the logger's events.log",
            })
            .await
    {
        return false;
    }
    match events.last() {
        Some(e) => {
            *last = Some(e.seq);
            s.send(&Out::Events { list: &events }).await
        }
        None => {
            *last = Some(seen);
            true
        }
    }
}
