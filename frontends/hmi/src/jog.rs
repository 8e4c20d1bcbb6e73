//! The dead-man of a press-and-hold jog across the browser, the server and the loop. The
//! browser renews while the finger is down; this session forwards each renewal to the loop
//! (at most one in flight, at most one per [`MIN_RENEW_GAP`]) and never renews on its own,
//! so a jog outlives the last renewal by at most the loop's dead-man time. Lifting the
//! finger, hiding the page, an error or the socket closing releases it at once (also when
//! the session is dropped for any reason).

use crate::commander::{Commander, Reply};
use crate::error::Error;
use hob_ipc::{CommandRequest, command, request};
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};
use tokio::sync::oneshot;

/// Renewals closer together than this are coalesced (the browser renews every 100 ms).
pub const MIN_RENEW_GAP: Duration = Duration::from_millis(50);

/// One socket's jog.
#[derive(Debug)]
pub struct JogSession {
    commander: Commander,
    active: Option<(u64, CommandRequest)>,
    last_sent: Option<Instant>,
    in_flight: Arc<AtomicUsize>,
}

/// A request sent for the session: its id and the loop's answer to come.
#[derive(Debug)]
pub struct Sent {
    pub id: u64,
    pub reply: oneshot::Receiver<Reply>,
}

impl JogSession {
    pub fn new(commander: Commander) -> Self {
        Self {
            commander,
            active: None,
            last_sent: None,
            in_flight: Arc::new(AtomicUsize::new(0)),
        }
    }

    /// The id of the hold being renewed, if any.
    pub fn active_id(&self) -> Option<u64> {
        self.active.as_ref().map(|(id, _)| *id)
    }

    fn send(&mut self, req: CommandRequest, now: Instant) -> oneshot::Receiver<Reply> {
        self.last_sent = Some(now);
        self.in_flight.fetch_add(1, Ordering::SeqCst);
        let inner = self.commander.submit(req);
        let (tx, rx) = oneshot::channel();
        let counter = self.in_flight.clone();
        // The counter drops when the answer comes, whoever waits for it.
        tokio::spawn(async move {
            let r = inner.await.unwrap_or(Err(Error::CommandThreadStopped));
            counter.fetch_sub(1, Ordering::SeqCst);
            let _ = tx.send(r);
        });
        rx
    }

    /// Finger down: starts a continuous jog, or for axis `c` turns the hob spindle at
    /// `speed` rpm (a running hold of this socket is replaced).
    pub fn hold(&mut self, id: u64, axis: &str, dir: &str, speed: f64, now: Instant) -> Result<Sent, Error> {
        let req = if axis.eq_ignore_ascii_case("c") {
            if dir != "+" {
                return Err(Error::SpindleOneWay { dir: dir.to_string() });
            }
            request::spindle_hold(speed)
        } else {
            request::jog_continuous(axis, dir, speed).map_err(Error::Request)?
        };
        self.active = Some((id, req));
        Ok(Sent {
            id,
            reply: self.send(req, now),
        })
    }

    /// A renewal from the browser: forwarded unless one is still in flight or the last went
    /// out less than [`MIN_RENEW_GAP`] ago; nothing without an active hold.
    pub fn renew(&mut self, now: Instant) -> Option<Sent> {
        let (id, req) = self.active?;
        if self.in_flight.load(Ordering::SeqCst) > 0 {
            return None;
        }
        if self
            .last_sent
            .is_some_and(|t| now.duration_since(t) < MIN_RENEW_GAP)
        {
            return None;
        }
        Some(Sent {
            id,
            reply: self.send(req, now),
        })
    }

    /// The loop refused the hold or a renewal: the session ends (no further renewals).
    pub fn refused(&mut self, id: u64) {
        if self.active_id() == Some(id) {
            self.active = None;
        }
    }

    /// Finger up, page hidden, socket closed: releases a running jog at once.
    pub fn release(&mut self) -> Option<oneshot::Receiver<Reply>> {
        let (_, held) = self.active.take()?;
        let stop = if held.command == command::SPINDLE_HOLD {
            command::SPINDLE_OFF
        } else {
            command::JOG_RELEASE
        };
        Some(self.commander.submit(CommandRequest::new(stop)))
    }
}

impl Drop for JogSession {
    fn drop(&mut self) {
        let _ = self.release();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::commander::Job;
    use hob_ipc::CommandResponse;
    use std::sync::mpsc;

    /// A fake loop that accepts everything and records the command codes.
    fn answer_all(jobs: mpsc::Receiver<Job>) -> std::thread::JoinHandle<Vec<u32>> {
        std::thread::spawn(move || {
            let mut seen = Vec::new();
            for j in jobs {
                seen.push(j.request.command);
                let _ = j.reply.send(Ok(CommandResponse::new(true, 0, "ok")));
            }
            seen
        })
    }

    fn rt() -> tokio::runtime::Runtime {
        tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .expect("runtime")
    }

    #[test]
    fn renewals_are_forwarded_one_for_one_and_none_after_the_release() {
        let (commander, jobs) = Commander::new();
        let fake = answer_all(jobs);
        rt().block_on(async {
            let mut s = JogSession::new(commander);
            let t0 = Instant::now();
            assert!(s.renew(t0).is_none(), "no hold, nothing to renew");
            let sent = s.hold(7, "x", "-", 300.0, t0).expect("a hold");
            assert!(sent.reply.await.expect("answer").is_ok());
            // Coalesced: too soon after the hold.
            assert!(s.renew(t0 + Duration::from_millis(20)).is_none());
            for k in 1..=3u64 {
                let r = s.renew(t0 + Duration::from_millis(100 * k)).expect("forwarded");
                assert_eq!(r.id, 7);
                r.reply.await.expect("answer").expect("accepted");
            }
            s.release()
                .expect("a release")
                .await
                .expect("answer")
                .expect("accepted");
            assert!(
                s.renew(t0 + Duration::from_millis(500)).is_none(),
                "released: no renewal"
            );
            assert!(s.release().is_none(), "released once");
            drop(s);
        });
        let seen = fake.join().expect("fake loop");
        let (jc, jr) = (command::JOG_CONTINUOUS, command::JOG_RELEASE);
        assert_eq!(seen, vec![jc, jc, jc, jc, jr]);
    }

    #[test]
    fn dropping_a_holding_session_releases_the_jog() {
        let (commander, jobs) = Commander::new();
        let fake = answer_all(jobs);
        rt().block_on(async {
            let mut s = JogSession::new(commander);
            s.hold(1, "y", "+", 100.0, Instant::now())
                .expect("a hold")
                .reply
                .await
                .expect("answer")
                .expect("ok");
            drop(s);
        });
        assert_eq!(
            fake.join().expect("fake loop"),
            vec![command::JOG_CONTINUOUS, command::JOG_RELEASE]
        );
    }

    #[test]
    fn a_held_spindle_is_renewed_as_a_jog_and_stopped_by_spindle_off() {
        let (commander, jobs) = Commander::new();
        let fake = answer_all(jobs);
        rt().block_on(async {
            let mut s = JogSession::new(commander);
            assert!(s.hold(1, "c", "-", 20.0, Instant::now()).is_err(), "one way only");
            let t0 = Instant::now();
            s.hold(2, "c", "+", 20.0, t0)
                .expect("a hold")
                .reply
                .await
                .expect("answer")
                .expect("ok");
            let r = s.renew(t0 + Duration::from_millis(100)).expect("forwarded");
            r.reply.await.expect("answer").expect("ok");
            drop(s);
        });
        let (h, off) = (command::SPINDLE_HOLD, command::SPINDLE_OFF);
        assert_eq!(fake.join().expect("fake loop"), vec![h, h, off]);
    }

    #[test]
    fn a_refused_hold_is_not_renewed_and_a_bad_axis_sends_nothing() {
        let (commander, jobs) = Commander::new();
        let fake = answer_all(jobs);
        rt().block_on(async {
            let mut s = JogSession::new(commander);
            assert!(s.hold(1, "q", "+", 100.0, Instant::now()).is_err());
            let sent = s.hold(2, "x", "+", 100.0, Instant::now()).expect("a hold");
            sent.reply.await.expect("answer").expect("ok");
            s.refused(2);
            assert!(s.renew(Instant::now() + Duration::from_secs(1)).is_none());
            assert!(s.release().is_none(), "nothing left to release");
        });
        assert_eq!(fake.join().expect("fake loop"), vec![command::JOG_CONTINUOUS]);
    }
}
