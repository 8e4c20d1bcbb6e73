//! One WebSocket per browser: a `hello` gets the machine's description and a snapshot with
//! the events the page missed (by number); then the newest frame at the screen rate (a slow
//! browser skips frames, counted, never events), every event, the loop's stats each second,
//! and the answers to its commands. A panel socket may command and jog; a view socket only
//! reads (any command closes it).

use crate::app::App;
use crate::commander::Reply;
use crate::commission::{CommissionSession, View};
use crate::error::Error;
use crate::jog::{JogSession, Sent};
use crate::protocol::{Answer, ClientMsg, EventView, Frame, Op};
use axum::extract::ws::{Message, Utf8Bytes, WebSocket};
use serde::Serialize;
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::sync::{mpsc, watch};

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
        /// That program's file was changed since LOAD: START and CONTINUE are refused.
        changed_since_load: bool,
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
    /// Commissioning from DIAGNOSTICS: the step, the result, the proposal.
    Commission(&'a View),
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

/// The loop's answer to `id`, or why none came.
async fn answer_of(id: u64, reply: tokio::sync::oneshot::Receiver<Reply>) -> Answer {
    match reply.await {
        Ok(Ok(r)) => Answer::of(id, &r),
        Ok(Err(e)) => Answer::refused(id, e.to_string()),
        Err(_) => Answer::refused(id, Error::CommandThreadStopped.to_string()),
    }
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
            let a = answer_of(id, reply).await;
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
            let a = answer_of(id, reply).await;
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

/// One browser's socket: what it may do, its jog, what it was sent. Each handler says
/// whether the socket stays open.
struct Session {
    s: Socket,
    app: Arc<App>,
    panel: bool,
    waiting: Waiting,
    jog: JogSession,
    commission: CommissionSession,
    /// The newest event the page has; none until it says hello (it gets nothing before).
    last_event: Option<u64>,
    /// The event log's generation (a restarted loop starts a new one).
    generation: u64,
    last_frame: u64,
}

impl Session {
    /// A message from the page.
    async fn message(&mut self, text: &str, frames: &mut watch::Receiver<Arc<Frame>>) -> bool {
        let msg = match serde_json::from_str::<ClientMsg>(text) {
            Ok(m) => m,
            Err(e) => {
                let id = serde_json::from_str::<serde_json::Value>(text)
                    .ok()
                    .and_then(|v| v.get("id").and_then(serde_json::Value::as_u64))
                    .unwrap_or(0);
                return self
                    .refuse(id, format!("the HMI server cannot read this message: {e}"))
                    .await;
            }
        };
        match msg {
            ClientMsg::Hello { last_event: seen } => self.hello(seen, frames).await,
            _ if !self.panel => false,
            ClientMsg::Cmd {
                id,
                op: Op::Load { program },
            } => self.load(id, &program).await,
            ClientMsg::Cmd { id, op } => match op.request() {
                Ok(mut r) => {
                    // START and CONTINUE name the program as its file is now: the loop
                    // refuses them when that is not the program it loaded.
                    if matches!(op, Op::Start { .. } | Op::Continue {}) {
                        let loop_hash = frames.borrow().state.as_ref().map_or(0, |s| s.program_hash);
                        r.program_hash = self.app.current_hash(loop_hash);
                    }
                    self.waiting.answer(id, self.app.commands.submit(r), false);
                    true
                }
                Err(e) => self.refuse(id, e.to_string()).await,
            },
            ClientMsg::JogHold { id, axis, dir, speed } => {
                let field = if axis.eq_ignore_ascii_case("c") {
                    "spindle speed"
                } else {
                    "jog speed"
                };
                match speed.read(field) {
                    Ok(speed) => self.jog_hold(id, &axis, &dir, speed).await,
                    Err(e) => self.refuse(id, e.to_string()).await,
                }
            }
            ClientMsg::JogRenew => {
                if let Some(Sent { id, reply }) = self.jog.renew(Instant::now()) {
                    self.waiting.answer(id, reply, true);
                }
                true
            }
            ClientMsg::JogRelease => {
                let _ = self.jog.release();
                true
            }
            ClientMsg::Visibility { visible: false } => {
                let _ = self.jog.release();
                self.commission.release();
                true
            }
            ClientMsg::CommissionHold { id, procedure } => {
                self.commission.hold(id, &procedure, &self.app);
                true
            }
            ClientMsg::CommissionRenew => {
                self.commission.renew();
                true
            }
            ClientMsg::CommissionRelease => {
                self.commission.release();
                true
            }
            ClientMsg::CommissionWrite { id } => {
                self.commission.write(id, &self.app);
                true
            }
            ClientMsg::Visibility { visible: true } => true,
        }
    }

    /// A refusal before the loop was asked.
    async fn refuse(&mut self, id: u64, text: impl Into<String>) -> bool {
        self.s.send(&Out::Answer(&Answer::refused(id, text))).await
    }

    /// The page's hello: the machine's description, the newest frame, the events it missed.
    async fn hello(&mut self, seen: u64, frames: &mut watch::Receiver<Arc<Frame>>) -> bool {
        let hello = Out::Hello {
            info: &self.app.hello,
            panel: self.panel,
        };
        if !self.s.send(&hello).await {
            return false;
        }
        let f = frames.borrow_and_update().clone();
        self.last_frame = f.seq;
        if !self.send_frame(0, &f).await {
            return false;
        }
        self.last_event = Some(seen);
        send_events(&mut self.s, &self.app, &mut self.last_event, &mut self.generation).await
    }

    async fn send_frame(&mut self, skipped: u64, f: &Frame) -> bool {
        let frame = Out::Frame {
            skipped,
            time_left_s: time_left(&self.app, f),
            loaded_here: loaded_here(&self.app, f),
            changed_since_load: f
                .state
                .as_ref()
                .is_some_and(|s| self.app.changed_since_load(s.program_hash)),
            frame: f,
        };
        self.s.send(&frame).await
    }

    /// A library program to load: read and resolved here, remembered once the loop accepts.
    async fn load(&mut self, id: u64, program: &str) -> bool {
        match self.app.load_request(program) {
            Ok((r, loaded)) => {
                let app = self.app.clone();
                self.waiting
                    .answer_then(id, self.app.commands.submit(r), move || app.loaded(loaded));
                true
            }
            Err(e) => self.refuse(id, e.to_string()).await,
        }
    }

    async fn jog_hold(&mut self, id: u64, axis: &str, dir: &str, speed: f64) -> bool {
        match self.jog.hold(id, axis, dir, speed, Instant::now()) {
            Ok(Sent { id, reply }) => {
                self.waiting.answer(id, reply, true);
                true
            }
            Err(e) => self.refuse(id, e.to_string()).await,
        }
    }

    /// A new frame from the bridge (none before the hello), with the frames skipped since.
    async fn frame(&mut self, frames: &mut watch::Receiver<Arc<Frame>>) -> bool {
        let f = frames.borrow_and_update().clone();
        if self.last_event.is_none() {
            return true;
        }
        let skipped = f.seq.saturating_sub(self.last_frame + 1);
        self.last_frame = f.seq;
        self.send_frame(skipped, &f).await
    }

    /// The loop's answer to a command (a jog's only when refused: it ends the hold).
    async fn answer(&mut self, a: Answer, is_jog: bool) -> bool {
        if is_jog && a.ok {
            return true;
        }
        if is_jog {
            self.jog.refused(a.id);
        }
        self.s.send(&Out::Answer(&a)).await
    }

    /// The loop's stats, once a second after the hello.
    async fn stats(&mut self, stats: &mut watch::Receiver<Option<Arc<crate::protocol::StatsView>>>) -> bool {
        let st = stats.borrow_and_update().clone();
        match (st, self.last_event) {
            (Some(st), Some(_)) => self.s.send(&Out::Stats { stats: &st }).await,
            _ => true,
        }
    }
}

/// Serves one browser until it goes.
pub async fn serve(ws: WebSocket, app: Arc<App>, panel: bool) {
    let mut frames = app.hub.frames.clone();
    let mut events_head = app.hub.events_head.clone();
    let mut stats = app.hub.stats.clone();
    let (tx, mut answers) = mpsc::unbounded_channel();
    let (commission_tx, mut commission_views) = mpsc::unbounded_channel();
    let jog = JogSession::new(app.commands.clone());
    let generation = app.hub.book().log.generation;
    let mut c = Session {
        s: Socket { ws },
        jog,
        commission: CommissionSession::new(commission_tx),
        generation,
        app,
        panel,
        waiting: Waiting { tx },
        last_event: None,
        last_frame: 0,
    };
    let mut tick = tokio::time::interval(Duration::from_secs(1));
    loop {
        let open = tokio::select! {
            msg = c.s.ws.recv() => match msg {
                Some(Ok(Message::Text(t))) => c.message(t.as_str(), &mut frames).await,
                Some(Ok(Message::Ping(_) | Message::Pong(_) | Message::Binary(_))) => true,
                _ => false,
            },
            r = frames.changed() => r.is_ok() && c.frame(&mut frames).await,
            r = events_head.changed() => {
                if r.is_ok() {
                    events_head.borrow_and_update();
                    send_events(&mut c.s, &c.app, &mut c.last_event, &mut c.generation).await
                } else {
                    false
                }
            }
            Some((a, is_jog)) = answers.recv() => c.answer(a, is_jog).await,
            Some(v) = commission_views.recv() => c.s.send(&Out::Commission(&v)).await,
            _ = tick.tick() => c.stats(&mut stats).await,
        };
        if !open {
            break;
        }
    }
    // Whatever ended the socket, a running jog stops now (also by Drop), and so does a
    // measurement's enable.
    let _ = c.jog.release();
    c.commission.release();
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
