//! The thread that owns the HMI's command client (iceoryx2 ports are not thread-safe): the
//! web server hands it requests and awaits the loop's answers, so drawing never waits on a
//! command and a command never waits on drawing. Requests are sent one at a time, in order.

use crate::error::Error;
use hob_ipc::{CommandRequest, CommandResponse};
use std::sync::mpsc;
use std::time::Duration;
use tokio::sync::oneshot;

/// How long a command may wait for the loop's answer (as the CLI).
pub const ANSWER: Duration = Duration::from_secs(3);

/// The loop's answer, or why none came.
pub type Reply = Result<CommandResponse, Error>;

#[derive(Debug)]
pub struct Job {
    pub request: Box<CommandRequest>,
    pub reply: oneshot::Sender<Reply>,
}

/// The sending side, cloned into every socket.
#[derive(Debug, Clone)]
pub struct Commander {
    jobs: mpsc::Sender<Job>,
}

impl Commander {
    /// A commander whose jobs go to `jobs` (the thread below, or a test's fake loop).
    pub fn new() -> (Self, mpsc::Receiver<Job>) {
        let (jobs, rx) = mpsc::channel();
        (Self { jobs }, rx)
    }

    /// Queues a request; the receiver gets the answer (or an error when the commander is gone).
    pub fn submit(&self, request: CommandRequest) -> oneshot::Receiver<Reply> {
        let (reply, rx) = oneshot::channel();
        if let Err(mpsc::SendError(job)) = self.jobs.send(Job {
            request: Box::new(request),
            reply,
        }) {
            let _ = job.reply.send(Err(Error::CommandThreadStopped));
        }
        rx
    }
}

/// Serves jobs until every [`Commander`] is dropped; connects to the loop's command service
/// as `hob-hmi-cmd-PID`, or to `hob-gateway` when `HOB_GATEWAY` names it (again after a failure,
/// so a loop started later is reached).
pub fn run(jobs: mpsc::Receiver<Job>) {
    let name = format!("hob-hmi-cmd-{}", std::process::id());
    let mut client: Option<Box<dyn hob_ipc::Commands>> = None;
    for job in jobs {
        if client.is_none() {
            client = hob_ipc::commands(&name).ok();
        }
        let reply = match &mut client {
            Some(c) => c.request(&job.request, ANSWER).map_err(|error| Error::NoAnswer {
                error,
                within: ANSWER,
            }),
            None => Err(Error::Unreachable),
        };
        if reply.is_err() {
            client = None;
        }
        let _ = job.reply.send(reply);
    }
}
