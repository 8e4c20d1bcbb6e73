//! `hob-bench flood`: one process of a command flood (issue 18, load): it sends requests
//! to the loop's `command` service one after another, as fast as the answers come, and
//! counts what came back. Half of them reach the loop (a feed override of 100 %, which the
//! loop takes in any state, at most one request per cycle), half are refused by the command
//! thread without reaching it (an unknown command code): a flood of both kinds from
//! several processes must leave the loop at its pace and every request answered.

use hob_ipc::{Client, CommandRequest};
use std::time::{Duration, Instant};

/// What one flood did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Flood {
    pub sent: u64,
    pub answered: u64,
    pub accepted: u64,
    pub refused: u64,
    /// Requests with no answer within the timeout (the target is 0).
    pub unanswered: u64,
    pub seconds: f64,
}

impl Flood {
    pub fn json(&self) -> String {
        serde_json::json!({
            "sent": self.sent,
            "answered": self.answered,
            "accepted": self.accepted,
            "refused": self.refused,
            "unanswered": self.unanswered,
            "seconds": self.seconds,
            "requests_per_s": self.sent as f64 / self.seconds.max(1e-9),
        })
        .to_string()
    }
}

/// A request that the loop itself answers, and one the command thread refuses.
fn requests() -> [CommandRequest; 2] {
    let mut to_loop = CommandRequest::new(hob_ipc::command::FEED_OVERRIDE);
    to_loop.value = 100.0;
    [to_loop, CommandRequest::new(9999)]
}

/// Sends `n` requests, alternating the two kinds, each waiting for its answer up to
/// `timeout`.
pub fn run(n: u64, timeout: Duration) -> Result<Flood, String> {
    let client =
        Client::connect(&format!("hob-bench-flood-{}", std::process::id())).map_err(|e| e.to_string())?;
    let kinds = requests();
    let mut f = Flood::default();
    let t0 = Instant::now();
    for i in 0..n {
        f.sent += 1;
        match client.request(&kinds[(i % 2) as usize], timeout) {
            Ok(r) => {
                f.answered += 1;
                if r.accepted != 0 {
                    f.accepted += 1;
                } else {
                    f.refused += 1;
                }
            }
            Err(_) => f.unanswered += 1,
        }
    }
    f.seconds = t0.elapsed().as_secs_f64();
    Ok(f)
}
