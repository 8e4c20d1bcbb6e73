//! The gateway: how a frontend of another user reaches the loop. iceoryx2 0.10 makes its files
//! (`/dev/shm`, `/tmp/iceoryx2`) its creator's alone, and a process that could open them
//! could also write into them; so the processes of the bus (`hob-rt`, the logger, the
//! watchdog) run as one user, and the frontends that face people (the HMI, an operator's
//! shell) run as others and talk to `hob-gateway`, a process of the bus, over a Unix socket.
//! The gateway knows who is on the other end (the kernel's peer credentials), lets the
//! members of the operators' group command and the viewers' group watch, and only ever
//! forwards: the state it sends is the loop's, a command is the loop's to check and answer.
//!
//! Wire: frames of a little-endian `u32` length and that many bytes of postcard
//! ([`ToGateway`] one way, [`FromGateway`] the other). Frontends choose the gateway with `HOB_GATEWAY`
//! (the socket's path): [`follow`] and [`commands`] then return its client instead of the
//! shared-memory ports.

use crate::ports::{Client, IpcError, Ports, STATE_BUFFER};
pub use hob_wire::frame::{Action, FromGateway, MAX_FRAME, Role, ToGateway, decode, encode, fixed_bytes};
use hob_wire::{CommandRequest, CommandResponse, EventSample, RecorderSample, StateSample, StatsSample};
use std::collections::VecDeque;
use std::io::{ErrorKind, Read, Write};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The loop's streams as a follower reads them, from the shared memory or through the gateway.
pub trait Feed: std::fmt::Debug {
    /// The next state sample waiting, if any.
    fn next_state(&mut self) -> Option<StateSample>;
    fn next_event(&mut self) -> Option<EventSample>;
    /// The newest stats sample waiting, if any.
    fn latest_stats(&mut self) -> Option<StatsSample>;
    /// The newest report of the recorder's health waiting, if any.
    fn latest_recorder(&mut self) -> Option<RecorderSample>;

    /// Waits up to `timeout` for a state sample; returns the newest one waiting.
    fn wait_state(&mut self, timeout: Duration) -> Option<StateSample> {
        let end = Instant::now() + timeout;
        loop {
            let mut last = None;
            while let Some(s) = self.next_state() {
                last = Some(s);
            }
            if last.is_some() {
                return last;
            }
            if Instant::now() >= end {
                return None;
            }
            std::thread::sleep(Duration::from_millis(2));
        }
    }
}

/// A frontend's way to send the loop commands.
pub trait Commands: std::fmt::Debug {
    /// Sends `req` and waits up to `timeout` for the answer.
    fn request(&mut self, req: &CommandRequest, timeout: Duration) -> Result<CommandResponse, IpcError>;
}

impl Feed for Ports {
    fn next_state(&mut self) -> Option<StateSample> {
        Ports::next_state(self)
    }
    fn next_event(&mut self) -> Option<EventSample> {
        Ports::next_event(self)
    }
    fn latest_stats(&mut self) -> Option<StatsSample> {
        Ports::latest_stats(self)
    }
    fn latest_recorder(&mut self) -> Option<RecorderSample> {
        Ports::latest_recorder(self)
    }
}

impl Commands for Client {
    fn request(&mut self, req: &CommandRequest, timeout: Duration) -> Result<CommandResponse, IpcError> {
        Client::request(self, req, timeout)
    }
}

/// The gateway's socket a frontend should use: `HOB_GATEWAY`, if set.
pub fn gateway_path() -> Option<PathBuf> {
    std::env::var_os("HOB_GATEWAY")
        .filter(|s| !s.is_empty())
        .map(PathBuf::from)
}

/// The loop's streams for a follower named `name`: through the gateway when `HOB_GATEWAY` is set,
/// else the shared-memory subscribers.
pub fn follow(name: &str) -> Result<Box<dyn Feed>, IpcError> {
    Ok(match gateway_path() {
        Some(p) => {
            let mut g = GatewayClient::connect(&p)?;
            g.watch()?;
            Box::new(g)
        }
        None => Box::new(Ports::subscribe(name)?),
    })
}

/// Who the gateway says this process is and its level, when `HOB_GATEWAY` is set (`None`:
/// on the bus itself, as its own user).
pub fn gateway_role() -> Result<Option<(String, Role)>, IpcError> {
    match gateway_path() {
        Some(p) => {
            let g = GatewayClient::connect(&p)?;
            Ok(Some((g.user.clone(), g.role)))
        }
        None => Ok(None),
    }
}

/// A command channel for a frontend named `name`: through the gateway when `HOB_GATEWAY` is set.
pub fn commands(name: &str) -> Result<Box<dyn Commands>, IpcError> {
    Ok(match gateway_path() {
        Some(p) => Box::new(GatewayClient::connect(&p)?),
        None => Box::new(Client::connect(name)?),
    })
}

/// A connection to the gateway.
#[derive(Debug)]
pub struct GatewayClient {
    stream: UnixStream,
    path: PathBuf,
    /// Who the gateway says we are, and what we may do.
    pub user: String,
    pub role: Role,
    buf: Vec<u8>,
    states: VecDeque<StateSample>,
    events: VecDeque<EventSample>,
    stats: Option<StatsSample>,
    recorder: Option<RecorderSample>,
    /// Asked for the streams (asked again after a reconnection).
    watching: bool,
    /// The connection broke: when to try again.
    retry_at: Option<Instant>,
}

/// How often a follower whose gateway went away tries to connect again.
const RECONNECT_EVERY: Duration = Duration::from_secs(1);

impl GatewayClient {
    /// Connects and reads the gateway's welcome (or its refusal, as the error).
    pub fn connect(path: &Path) -> Result<Self, IpcError> {
        Self::connect_within(path, Duration::from_secs(5))
    }

    /// [`Self::connect`], waiting at most `welcome_within` for the welcome.
    fn connect_within(path: &Path, welcome_within: Duration) -> Result<Self, IpcError> {
        let stream = UnixStream::connect(path).map_err(|e| {
            IpcError(format!(
                "the gateway {}: {e} (is hob-gateway running?)",
                path.display()
            ))
        })?;
        let mut c = Self {
            stream,
            path: path.to_path_buf(),
            user: String::new(),
            role: Role::Watch,
            buf: Vec::new(),
            states: VecDeque::new(),
            events: VecDeque::new(),
            stats: None,
            recorder: None,
            watching: false,
            retry_at: None,
        };
        match c.next_frame(Some(Instant::now() + welcome_within))? {
            FromGateway::Welcome { user, role } => {
                c.user = user;
                c.role = role;
                Ok(c)
            }
            FromGateway::Refused(why) => {
                Err(IpcError(format!("the gateway {} refused: {why}", path.display())))
            }
            other => Err(IpcError(format!(
                "the gateway {}: {other:?} before its welcome",
                path.display()
            ))),
        }
    }

    /// Asks for the loop's streams.
    pub fn watch(&mut self) -> Result<(), IpcError> {
        self.watching = true;
        self.send(&ToGateway::Watch)
    }

    fn send(&mut self, msg: &ToGateway) -> Result<(), IpcError> {
        let bytes = encode(msg).map_err(|e| IpcError(e.to_string()))?;
        // Reading may have left the socket non-blocking; a gateway that stopped reading
        // does not hold a frontend for ever.
        let _ = self.stream.set_nonblocking(false);
        let _ = self.stream.set_write_timeout(Some(Duration::from_secs(5)));
        self.stream
            .write_all(&bytes)
            .map_err(|e| IpcError(format!("the gateway {}: {e}", self.path.display())))
    }

    /// The next frame: waits until `deadline` (`None`: only what has arrived already;
    /// then `ErrorKind::WouldBlock` is reported as an error text "nothing").
    fn next_frame(&mut self, deadline: Option<Instant>) -> Result<FromGateway, IpcError> {
        loop {
            if let Some((msg, used)) =
                decode::<FromGateway>(&self.buf).map_err(|e| IpcError(format!("the gateway: {e}")))?
            {
                self.buf.drain(..used);
                return Ok(msg);
            }
            let wait = match deadline {
                None => None,
                Some(d) => {
                    let left = d.saturating_duration_since(Instant::now());
                    if left.is_zero() {
                        return Err(IpcError(format!(
                            "the gateway {}: no answer in time",
                            self.path.display()
                        )));
                    }
                    Some(left)
                }
            };
            let _ = self.stream.set_nonblocking(wait.is_none());
            let _ = self.stream.set_read_timeout(wait);
            let mut chunk = [0u8; 16 * 1024];
            match self.stream.read(&mut chunk) {
                Ok(0) => {
                    return Err(IpcError(format!(
                        "the gateway {} closed the connection",
                        self.path.display()
                    )));
                }
                Ok(n) => self.buf.extend_from_slice(&chunk[..n]),
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                    if deadline.is_none() {
                        return Err(IpcError(NOTHING.into()));
                    }
                }
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) => return Err(IpcError(format!("the gateway {}: {e}", self.path.display()))),
            }
        }
    }

    /// Files a stream frame; anything else is returned.
    fn file(&mut self, msg: FromGateway) -> Option<FromGateway> {
        match msg {
            FromGateway::State(s) => {
                if self.states.len() >= STATE_BUFFER {
                    self.states.pop_front();
                }
                self.states.push_back(*s);
            }
            FromGateway::Event(e) => {
                if self.events.len() >= crate::ports::EVENT_BUFFER {
                    self.events.pop_front();
                }
                self.events.push_back(*e);
            }
            FromGateway::Stats(s) => self.stats = Some(*s),
            FromGateway::Recorder(r) => self.recorder = Some(*r),
            other => return Some(other),
        }
        None
    }

    /// Connects again (the gateway restarted, or the last request timed out): the new
    /// connection's welcome, and the streams again if they were asked for.
    fn reconnect(&mut self, welcome_within: Duration) -> Result<(), IpcError> {
        let mut fresh = GatewayClient::connect_within(&self.path, welcome_within)?;
        if self.watching {
            fresh.watch()?;
        }
        self.stream = fresh.stream;
        self.user = fresh.user;
        self.role = fresh.role;
        self.buf.clear();
        self.retry_at = None;
        Ok(())
    }

    /// Takes in whatever the gateway has sent (does not wait for more). A connection that
    /// broke (the gateway restarted) is made again, at most every [`RECONNECT_EVERY`]; the
    /// samples in between are missing, and show as a gap in the cycle numbers.
    fn pump(&mut self) {
        if let Some(at) = self.retry_at {
            if Instant::now() < at {
                return;
            }
            self.retry_at = Some(Instant::now() + RECONNECT_EVERY);
            if self.reconnect(Duration::from_millis(500)).is_err() {
                return;
            }
        }
        loop {
            match self.next_frame(None) {
                Ok(msg) => {
                    let _ = self.file(msg);
                }
                Err(e) => {
                    if e.0 != NOTHING {
                        self.retry_at = Some(Instant::now() + RECONNECT_EVERY);
                    }
                    return;
                }
            }
        }
    }
}

const NOTHING: &str = "nothing waiting";

impl Commands for GatewayClient {
    fn request(&mut self, req: &CommandRequest, timeout: Duration) -> Result<CommandResponse, IpcError> {
        if self.retry_at.is_some() {
            self.reconnect(Duration::from_secs(2))?;
        }
        self.send(&ToGateway::Request(Box::new(*req)))?;
        let end = Instant::now() + timeout;
        loop {
            let msg = self.next_frame(Some(end)).map_err(|e| {
                // A late answer must not be taken for the next request's: this connection
                // is done, the next request makes a new one.
                let _ = self.stream.shutdown(std::net::Shutdown::Both);
                self.retry_at = Some(Instant::now());
                IpcError(format!(
                    "{e} (no answer from hob-rt within {} ms through the gateway)",
                    timeout.as_millis()
                ))
            })?;
            match self.file(msg) {
                Some(FromGateway::Answer(r)) => return Ok(*r),
                Some(FromGateway::Refused(why)) => {
                    return Ok(CommandResponse::new(
                        false,
                        0,
                        &format!("refused by the gateway: {why}"),
                    ));
                }
                Some(other) => return Err(IpcError(format!("the gateway sent {other:?} for a request"))),
                None => {}
            }
        }
    }
}

impl Feed for GatewayClient {
    fn next_state(&mut self) -> Option<StateSample> {
        if self.states.is_empty() {
            self.pump();
        }
        self.states.pop_front()
    }
    fn next_event(&mut self) -> Option<EventSample> {
        if self.events.is_empty() {
            self.pump();
        }
        self.events.pop_front()
    }
    fn latest_stats(&mut self) -> Option<StatsSample> {
        self.pump();
        self.stats.take()
    }
    fn latest_recorder(&mut self) -> Option<RecorderSample> {
        self.pump();
        self.recorder.take()
    }
}
