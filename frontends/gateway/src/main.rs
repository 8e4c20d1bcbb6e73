//! `hob-gateway`: the frontends of other users reach the loop through it (`hob_ipc::gateway`).
//!
//! ```sh
//! hob-gateway --socket /run/hob/gateway.sock --operators hob-ops --setters hob-set \
//!     --builders hob-build --viewers hob-view
//! ```
//!
//! It runs as the bus's user, beside `hob-rt`. Each connection is asked the kernel who is on
//! the other end (`SO_PEERCRED`), and its groups give its user level (`Role`: viewer,
//! operator, setter, builder; root and the bus's user are builders): a viewer watches, the
//! others watch and command (what each level may change in the library is the HMI's to hold
//! to, `Role::allows`); anyone in none is refused with a line saying why. Every command is
//! forwarded to the loop, which checks and answers it as it does the CLI's; each is written
//! to standard output with who sent it and the loop's answer (the journal keeps it). A slow
//! watcher loses samples (it sees the gap in the cycle numbers), never slows anybody.

use hob_ipc::gateway::{self as gw, Action, FromGateway, Role, ToGateway};
use hob_ipc::{CommandRequest, CommandResponse, EventSample};
use nix::sys::socket::{getsockopt, sockopt::PeerCredentials};
use nix::unistd::{Gid, Group, Uid, User};
use std::collections::{HashMap, VecDeque};
use std::ffi::CString;
use std::io::{Read, Write};
use std::os::unix::fs::PermissionsExt;
use std::os::unix::net::{UnixListener, UnixStream};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicI64, Ordering};
use std::sync::mpsc::{self, Receiver, Sender, SyncSender, TrySendError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Frames a watcher may have queued before it loses samples (2 s of the loop's state).
const WATCH_QUEUE: usize = 2048;
/// Events a new watcher is sent first (as iceoryx2's history gives a new subscriber).
const EVENT_BACKLOG: usize = hob_ipc::EVENT_HISTORY;
/// How long a command may wait for the loop's answer.
const ANSWER: Duration = Duration::from_secs(2);
/// A command not sent to the loop within this long of its arrival (others ahead of it in
/// the queue) is answered "expired" and never sent: the frontends give up after 3 s, and a
/// START or a jog must not reach the loop after the operator was told it failed.
const EXPIRES: Duration = Duration::from_millis(2500);
/// How long the writing to one peer may block before the connection is given up.
const WRITE_TIMEOUT: Duration = Duration::from_secs(5);
/// Connections served at once for one user (an HMI takes two, a CLI call one): one more is
/// refused with the reason, so that no user can exhaust the gateway's threads or crowd out
/// another user (the HMI's own user keeps its connections whatever an operator's shell does).
const MAX_CONNECTIONS_PER_USER: usize = 16;

const USAGE: &str = "usage: hob-gateway --socket PATH --operators GROUP [--viewers GROUP] [--setters GROUP] [--builders GROUP]";

#[derive(Debug)]
struct Args {
    socket: PathBuf,
    operators: Group,
    viewers: Option<Group>,
    setters: Option<Group>,
    builders: Option<Group>,
}

/// Why the gateway cannot start, or a peer cannot be served: the facts, worded as the
/// gateway prints them.
#[derive(Debug)]
enum Error {
    /// `-h` or `--help`: the usage is the answer.
    Usage,
    NeedsValue(&'static str),
    UnknownArgument(String),
    Required(&'static str),
    /// Two levels' options name one group (the options, the group).
    SameGroup(&'static str, &'static str, String),
    NoSuchGroup {
        option: &'static str,
        value: String,
    },
    Group {
        option: &'static str,
        value: String,
        error: nix::errno::Errno,
    },
    /// The socket's path (`--socket`) could not be made.
    Socket {
        path: PathBuf,
        error: std::io::Error,
    },
    AnotherGate {
        path: PathBuf,
    },
    PeerCredentials(nix::errno::Errno),
}

impl std::fmt::Display for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Error::Usage => f.write_str(USAGE),
            Error::NeedsValue(name) => write!(f, "{name} needs a value\n{USAGE}"),
            Error::UnknownArgument(other) => write!(f, "unknown argument {other}\n{USAGE}"),
            Error::Required(option) => write!(f, "{option} is required\n{USAGE}"),
            Error::SameGroup(a, b, name) => write!(f, "{b} {name}: the same group as {a} {name}"),
            Error::NoSuchGroup { option, value } => write!(f, "{option} {value}: no such group on this PC"),
            Error::Group { option, value, error } => write!(f, "{option} {value}: {error}"),
            Error::Socket { path, error } => write!(f, "--socket {}: {error}", path.display()),
            Error::AnotherGate { path } => {
                write!(f, "--socket {}: another gate answers on it", path.display())
            }
            Error::PeerCredentials(e) => write!(f, "SO_PEERCRED: {e}"),
        }
    }
}

impl std::error::Error for Error {}

/// A group by name or number, or an error naming the option.
fn group(option: &'static str, v: &str) -> Result<Group, Error> {
    let found = match v.parse::<u32>() {
        Ok(n) => Group::from_gid(Gid::from_raw(n)),
        Err(_) => Group::from_name(v),
    };
    match found {
        Ok(Some(g)) => Ok(g),
        Ok(None) => Err(Error::NoSuchGroup {
            option,
            value: v.to_string(),
        }),
        Err(error) => Err(Error::Group {
            option,
            value: v.to_string(),
            error,
        }),
    }
}

fn parse(mut it: impl Iterator<Item = String>) -> Result<Args, Error> {
    let (mut socket, mut operators, mut viewers, mut setters, mut builders) = (None, None, None, None, None);
    while let Some(a) = it.next() {
        let mut value = |name: &'static str| it.next().ok_or(Error::NeedsValue(name));
        match a.as_str() {
            "--socket" => socket = Some(PathBuf::from(value("--socket")?)),
            "--operators" => operators = Some(group("--operators", &value("--operators")?)?),
            "--viewers" => viewers = Some(group("--viewers", &value("--viewers")?)?),
            "--setters" => setters = Some(group("--setters", &value("--setters")?)?),
            "--builders" => builders = Some(group("--builders", &value("--builders")?)?),
            "-h" | "--help" => return Err(Error::Usage),
            other => return Err(Error::UnknownArgument(other.to_string())),
        }
    }
    let operators: Group = operators.ok_or(Error::Required("--operators"))?;
    // Each level its own group: one group for two levels would give its members the higher.
    let named = [
        ("--operators", Some(&operators)),
        ("--viewers", viewers.as_ref()),
        ("--setters", setters.as_ref()),
        ("--builders", builders.as_ref()),
    ];
    for (i, (a, ga)) in named.iter().enumerate() {
        for (b, gb) in &named[i + 1..] {
            if let (Some(ga), Some(gb)) = (ga, gb)
                && ga.gid == gb.gid
            {
                return Err(Error::SameGroup(a, b, ga.name.clone()));
            }
        }
    }
    Ok(Args {
        socket: socket.ok_or(Error::Required("--socket"))?,
        operators,
        viewers,
        setters,
        builders,
    })
}

/// The watchers (each connection's queue, by connection number) and what a new one is sent
/// first.
#[derive(Debug, Default)]
struct Watchers {
    queues: Vec<(u64, SyncSender<Arc<FromGateway>>)>,
    events: VecDeque<EventSample>,
    stats: Option<Arc<FromGateway>>,
    recorder: Option<Arc<FromGateway>>,
}

impl Watchers {
    fn send(&mut self, msg: &Arc<FromGateway>) {
        self.queues.retain(|(_, q)| match q.try_send(msg.clone()) {
            Ok(()) | Err(TrySendError::Full(_)) => true,
            Err(TrySendError::Disconnected(_)) => false,
        });
    }

    /// A connection that ended: its queue goes, so its writer ends too.
    fn remove(&mut self, id: u64) {
        self.queues.retain(|(i, _)| *i != id);
    }
}

/// The core the loop runs on, once its stats said it (-1: not yet).
static LOOP_CORE: AtomicI64 = AtomicI64::new(-1);

/// Keeps the calling thread off the loop's core, if it is known (every thread of the
/// gateway calls this as it starts; the feed thread moves the whole process when it learns
/// the core).
fn off_the_loops_core() {
    if let Ok(core) = u32::try_from(LOOP_CORE.load(Ordering::Relaxed)) {
        let _ = hob_rt_os::keep_off_core(core);
    }
}

/// Follows the loop's streams and hands every frame to every watcher.
fn feed(watchers: Arc<Mutex<Watchers>>) {
    let name = format!("hob-gateway-{}", std::process::id());
    loop {
        let mut ports = match hob_ipc::Ports::subscribe(&name) {
            Ok(p) => p,
            Err(e) => {
                eprintln!("hob-gateway: {e}; trying again in 1 s");
                std::thread::sleep(Duration::from_secs(1));
                continue;
            }
        };
        let mut last_cycle = 0u64;
        loop {
            {
                let mut w = watchers.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
                while let Some(s) = gw::Feed::next_state(&mut ports) {
                    // A restarted loop: the previous one's stats and recorder report are
                    // not a new watcher's first news.
                    if s.cycle < last_cycle {
                        w.stats = None;
                        w.recorder = None;
                    }
                    last_cycle = s.cycle;
                    w.send(&Arc::new(FromGateway::State(Box::new(s))));
                }
                while let Some(e) = gw::Feed::next_event(&mut ports) {
                    // A restarted loop numbers its events from 1 again (its start-up
                    // messages may come before its first state): the previous loop's
                    // events are not given to a new watcher as its own.
                    if w.events.back().is_some_and(|b| e.seq <= b.seq) {
                        w.events.clear();
                    }
                    if w.events.len() >= EVENT_BACKLOG {
                        w.events.pop_front();
                    }
                    w.events.push_back(e);
                    w.send(&Arc::new(FromGateway::Event(Box::new(e))));
                }
                if let Some(s) = gw::Feed::latest_stats(&mut ports) {
                    // Off the loop's core, as every frontend, once the loop's stats say
                    // which it is: every thread of the gateway, and those started later.
                    if LOOP_CORE.load(Ordering::Relaxed) < 0 && s.core >= 0 {
                        LOOP_CORE.store(i64::from(s.core), Ordering::Relaxed);
                        if let Ok(core) = u32::try_from(s.core) {
                            let _ = hob_rt_os::keep_process_off_core(core);
                        }
                    }
                    let m = Arc::new(FromGateway::Stats(Box::new(s)));
                    w.send(&m);
                    w.stats = Some(m);
                }
                if let Some(r) = gw::Feed::latest_recorder(&mut ports) {
                    let m = Arc::new(FromGateway::Recorder(Box::new(r)));
                    w.send(&m);
                    w.recorder = Some(m);
                }
            }
            std::thread::sleep(Duration::from_millis(2));
        }
    }
}

/// A command, when it must have been sent by, and where its answer goes.
type Job = (Box<CommandRequest>, Instant, SyncSender<CommandResponse>);

/// Owns the command client (iceoryx2's ports are not thread-safe): one request at a time;
/// one that waited past its deadline behind others is not sent.
fn commander(jobs: Receiver<Job>) {
    off_the_loops_core();
    let name = format!("hob-gateway-cmd-{}", std::process::id());
    let mut client: Option<hob_ipc::Client> = None;
    for (req, expires, reply) in jobs {
        if Instant::now() >= expires {
            let _ = reply.send(CommandResponse::new(
                false,
                0,
                "not sent to the loop: it waited too long behind other commands (try again)",
            ));
            continue;
        }
        if client.is_none() {
            client = hob_ipc::Client::connect(&name).ok();
        }
        let answer = match client.as_ref().map(|c| c.request(&req, ANSWER)) {
            Some(Ok(a)) => a,
            Some(Err(e)) => {
                // Connect again for the next one (a loop restarted since).
                client = None;
                CommandResponse::new(false, 0, &format!("no answer from the loop (hob-rt): {e}"))
            }
            None => CommandResponse::new(
                false,
                0,
                "cannot reach the loop's command service (is hob-rt running?)",
            ),
        };
        let _ = reply.send(answer);
    }
}

/// Who is on the other end: user name, uid, pid and every group it is in.
fn peer(stream: &UnixStream) -> Result<(String, u32, i32, Vec<u32>), Error> {
    let cred = getsockopt(stream, PeerCredentials).map_err(Error::PeerCredentials)?;
    let uid = cred.uid();
    let mut groups = vec![cred.gid()];
    let name = match User::from_uid(Uid::from_raw(uid)) {
        Ok(Some(u)) => {
            if let Ok(c) = CString::new(u.name.clone())
                && let Ok(list) = nix::unistd::getgrouplist(&c, u.gid)
            {
                groups.extend(list.iter().map(|g| g.as_raw()));
            }
            u.name
        }
        _ => format!("uid {uid}"),
    };
    Ok((name, uid, cred.pid(), groups))
}

fn write(stream: &mut UnixStream, msg: &FromGateway) -> std::io::Result<()> {
    let bytes = gw::encode(msg).map_err(std::io::Error::other)?;
    stream.write_all(&bytes)
}

/// A peer let in: its user name, how it is named in the journal, what it may do.
#[derive(Debug)]
struct Peer {
    user: String,
    who: String,
    role: Role,
}

/// Who is on the other end and what it may do; a peer refused is told why (none).
fn admit(stream: &mut UnixStream, policy: &Policy, groups_named: &str) -> Option<Peer> {
    let (user, uid, pid, groups) = match peer(stream) {
        Ok(p) => p,
        Err(e) => {
            let _ = write(stream, &FromGateway::Refused(e.to_string()));
            return None;
        }
    };
    let who = format!("{user} (uid {uid}, pid {pid})");
    let Some(role) = policy.role(uid, &groups) else {
        println!("hob-gateway: {who} refused: in none of the groups {groups_named}");
        let _ = write(
            stream,
            &FromGateway::Refused(format!("{who} is in none of the groups {groups_named}")),
        );
        return None;
    };
    Some(Peer { user, who, role })
}

/// The connection's writer: it ends when every sender of its queue is gone (the reading
/// thread's at the end, the watchers' copy removed then) or a write fails (the peer gone,
/// or blocked past WRITE_TIMEOUT).
fn spawn_writer(
    mut out: UnixStream,
    frames: Receiver<Arc<FromGateway>>,
) -> std::io::Result<std::thread::JoinHandle<()>> {
    std::thread::Builder::new().spawn(move || {
        off_the_loops_core();
        for f in frames {
            if write(&mut out, &f).is_err() {
                break;
            }
        }
        let _ = out.shutdown(std::net::Shutdown::Both);
    })
}

/// The reading side of one connection (number `id`): the peer's requests, answered through
/// its queue.
struct Connection<'a> {
    id: u64,
    peer: Peer,
    queue: SyncSender<Arc<FromGateway>>,
    watching: bool,
    watchers: &'a Arc<Mutex<Watchers>>,
    jobs: &'a Sender<Job>,
}

impl Connection<'_> {
    /// Reads requests until the peer is gone or sends what cannot be read.
    fn read(&mut self, stream: &mut UnixStream) {
        let mut buf = Vec::new();
        let mut chunk = [0u8; 16 * 1024];
        loop {
            let n = match stream.read(&mut chunk) {
                Ok(0) | Err(_) => return,
                Ok(n) => n,
            };
            buf.extend_from_slice(&chunk[..n]);
            if !self.handle_whole_messages(&mut buf) {
                return;
            }
        }
    }

    /// Handles every whole message at the start of `buf` (taken out of it); false when one
    /// cannot be read (the peer is told why; the connection ends).
    fn handle_whole_messages(&mut self, buf: &mut Vec<u8>) -> bool {
        loop {
            let (msg, used) = match gw::decode::<ToGateway>(buf) {
                Ok(Some(x)) => x,
                Ok(None) => return true,
                Err(e) => {
                    println!("hob-gateway: {}: {e}; connection closed", self.peer.who);
                    let _ = self.queue.send(Arc::new(FromGateway::Refused(e.to_string())));
                    return false;
                }
            };
            buf.drain(..used);
            match msg {
                ToGateway::Watch => self.watch(),
                ToGateway::Request(req) => self.request(req),
            }
        }
    }

    /// The peer watches from now on (a second Watch is ignored): the recent events, stats
    /// and recorder report first.
    fn watch(&mut self) {
        if self.watching {
            return;
        }
        self.watching = true;
        let mut w = self
            .watchers
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let first = w
            .events
            .iter()
            .map(|e| Arc::new(FromGateway::Event(Box::new(*e))))
            .chain(w.stats.clone())
            .chain(w.recorder.clone());
        for m in first {
            let _ = self.queue.try_send(m);
        }
        w.queues.push((self.id, self.queue.clone()));
    }

    /// A command: to the loop from an operator (or a setter, a builder), refused to a
    /// viewer; journalled either way.
    fn request(&self, req: Box<CommandRequest>) {
        let who = &self.peer.who;
        let what = hob_ipc::codec::command_name(req.command);
        if !self.peer.role.allows(Action::Command) {
            println!("hob-gateway: {who}: {what} refused: may watch, not command");
            let _ = self.queue.send(Arc::new(FromGateway::Refused(format!(
                "{} may watch, not command (not in the operators' group)",
                self.peer.user
            ))));
            return;
        }
        let (reply, answer) = mpsc::sync_channel(1);
        let a = if self.jobs.send((req, Instant::now() + EXPIRES, reply)).is_ok() {
            answer.recv().ok()
        } else {
            None
        }
        .unwrap_or_else(|| CommandResponse::new(false, 0, "the gateway's command thread has stopped"));
        println!(
            "hob-gateway: {who}: {what} -> {}: {}",
            if a.accepted != 0 { "accepted" } else { "refused" },
            a.text()
        );
        let _ = self.queue.send(Arc::new(FromGateway::Answer(Box::new(a))));
    }
}

/// One connection (number `id`): its writer drains the connection's queue; this thread
/// reads requests. Returns when the peer is gone and the writer has ended.
fn serve(
    mut stream: UnixStream,
    id: u64,
    policy: &Policy,
    groups_named: &str,
    watchers: &Arc<Mutex<Watchers>>,
    jobs: &Sender<Job>,
) {
    off_the_loops_core();
    let _ = stream.set_write_timeout(Some(WRITE_TIMEOUT));
    let Some(peer) = admit(&mut stream, policy, groups_named) else {
        return;
    };
    println!(
        "hob-gateway: {} connected, at the {} level",
        peer.who,
        peer.role.level()
    );
    let (queue, frames) = mpsc::sync_channel::<Arc<FromGateway>>(WATCH_QUEUE);
    let _ = queue.send(Arc::new(FromGateway::Welcome {
        user: peer.user.clone(),
        role: peer.role,
    }));
    let Ok(out) = stream.try_clone() else {
        return;
    };
    let Ok(writer) = spawn_writer(out, frames) else {
        println!(
            "hob-gateway: {}: no thread for its writing; connection closed",
            peer.who
        );
        return;
    };
    let mut c = Connection {
        id,
        peer,
        queue,
        watching: false,
        watchers,
        jobs,
    };
    c.read(&mut stream);
    // The writer sends what is queued (a refusal's reason included) and ends.
    watchers
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
        .remove(id);
    drop(c);
    let _ = writer.join();
    let _ = stream.shutdown(std::net::Shutdown::Both);
}

fn bind(path: &Path) -> Result<UnixListener, Error> {
    let socket = |error| Error::Socket {
        path: path.to_path_buf(),
        error,
    };
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(socket)?;
    }
    // A socket left by a gate that was killed: nobody answers on it.
    if path.exists() {
        if UnixStream::connect(path).is_ok() {
            return Err(Error::AnotherGate {
                path: path.to_path_buf(),
            });
        }
        std::fs::remove_file(path).map_err(socket)?;
    }
    let l = UnixListener::bind(path).map_err(socket)?;
    // Anyone may connect: who may do what is the gateway's check, with an answer that says why.
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o666)).map_err(socket)?;
    Ok(l)
}

/// The levels' groups as the gateway decides by them, and in words for its first line.
fn policy_of(args: &Args) -> (Policy, String) {
    let gid = |g: &Option<Group>| g.as_ref().map(|g| g.gid.as_raw());
    let policy = Policy {
        own_uid: Uid::effective().as_raw(),
        operators_gid: args.operators.gid.as_raw(),
        viewers_gid: gid(&args.viewers),
        setters_gid: gid(&args.setters),
        builders_gid: gid(&args.builders),
    };
    let named = [
        (Some(&args.operators), Role::Operate),
        (args.viewers.as_ref(), Role::Watch),
        (args.setters.as_ref(), Role::Set),
        (args.builders.as_ref(), Role::Build),
    ]
    .iter()
    .filter_map(|(g, r)| g.map(|g| format!("{} ({})", g.name, r.level())))
    .collect::<Vec<_>>()
    .join(", ");
    (policy, named)
}

fn main() {
    let args = match parse(std::env::args().skip(1)) {
        Ok(a) => a,
        Err(e) => {
            eprintln!("hob-gateway: {e}");
            std::process::exit(2);
        }
    };
    let listener = match bind(&args.socket) {
        Ok(l) => l,
        Err(e) => {
            eprintln!("hob-gateway: {e}");
            std::process::exit(2);
        }
    };
    let (policy, groups_named) = policy_of(&args);
    println!(
        "hob-gateway: instance {}, socket {}, groups {groups_named}",
        hob_ipc::instance(),
        args.socket.display()
    );
    let watchers = Arc::new(Mutex::new(Watchers::default()));
    let (jobs, rx) = mpsc::channel::<Job>();
    {
        let w = watchers.clone();
        // The feed and the commander are the gateway: if either ends (a panic), so does the
        // process, and systemd starts it again.
        std::thread::spawn(move || {
            feed(w);
            std::process::exit(1);
        });
        std::thread::spawn(move || {
            commander(rx);
            std::process::exit(1);
        });
    }
    let policy = Arc::new(policy);
    let groups_named = Arc::new(groups_named);
    let open: Arc<Mutex<HashMap<u32, usize>>> = Arc::default();
    let mut next_id = 0u64;
    for stream in listener.incoming() {
        let mut stream = match stream {
            Ok(s) => s,
            Err(e) => {
                // Out of file descriptors or the like: not a busy loop.
                eprintln!("hob-gateway: accept: {e}");
                std::thread::sleep(Duration::from_millis(100));
                continue;
            }
        };
        let Ok(uid) = getsockopt(&stream, PeerCredentials).map(|c| c.uid()) else {
            continue;
        };
        {
            let mut open = open.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            let n = open.entry(uid).or_default();
            if *n >= MAX_CONNECTIONS_PER_USER {
                let _ = write(
                    &mut stream,
                    &FromGateway::Refused(format!(
                        "uid {uid} has {MAX_CONNECTIONS_PER_USER} connections open, the most one user may; try again when one ends"
                    )),
                );
                continue;
            }
            *n += 1;
        }
        next_id += 1;
        let id = next_id;
        let slot = Slot {
            open: open.clone(),
            uid,
        };
        let (policy, groups_named, watchers, jobs) = (
            policy.clone(),
            groups_named.clone(),
            watchers.clone(),
            jobs.clone(),
        );
        let started = std::thread::Builder::new().spawn(move || {
            let _slot = slot;
            serve(stream, id, &policy, &groups_named, &watchers, &jobs);
        });
        if let Err(e) = started {
            // The slot was given back when the closure was dropped.
            eprintln!("hob-gateway: no thread for a connection of uid {uid}: {e}");
        }
    }
}

/// One of a user's connections; given back when dropped (also when its thread panics).
#[derive(Debug)]
struct Slot {
    open: Arc<Mutex<HashMap<u32, usize>>>,
    uid: u32,
}

impl Drop for Slot {
    fn drop(&mut self) {
        let mut open = self
            .open
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some(n) = open.get_mut(&self.uid) {
            *n = n.saturating_sub(1);
        }
    }
}

/// Who may do what, from the peer's user and groups (the gateway's `--builders`,
/// `--setters`, `--operators` and `--viewers` groups): root and the bus's own user are
/// builders; a member of several groups has the highest of their levels; anyone in none is
/// refused. What each level may is `Role::allows`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Policy {
    pub own_uid: u32,
    pub operators_gid: u32,
    pub viewers_gid: Option<u32>,
    pub setters_gid: Option<u32>,
    pub builders_gid: Option<u32>,
}

impl Policy {
    /// `groups`: the peer's primary group and every group it is a member of.
    pub fn role(&self, uid: u32, groups: &[u32]) -> Option<Role> {
        let member = |g: Option<u32>| g.is_some_and(|g| groups.contains(&g));
        if uid == 0 || uid == self.own_uid || member(self.builders_gid) {
            Some(Role::Build)
        } else if member(self.setters_gid) {
            Some(Role::Set)
        } else if member(Some(self.operators_gid)) {
            Some(Role::Operate)
        } else if member(self.viewers_gid) {
            Some(Role::Watch)
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_policy_gives_each_peer_its_role() {
        let p = Policy {
            own_uid: 998,
            operators_gid: 1001,
            viewers_gid: Some(1002),
            setters_gid: Some(1003),
            builders_gid: Some(1004),
        };
        assert_eq!(p.role(0, &[0]), Some(Role::Build));
        assert_eq!(p.role(998, &[998]), Some(Role::Build));
        assert_eq!(p.role(1500, &[1500, 1001]), Some(Role::Operate));
        assert_eq!(p.role(1500, &[1500, 1002]), Some(Role::Watch));
        assert_eq!(p.role(1500, &[1002, 1001]), Some(Role::Operate));
        assert_eq!(
            p.role(1500, &[1001, 1003]),
            Some(Role::Set),
            "the highest of its groups"
        );
        assert_eq!(p.role(1500, &[1004]), Some(Role::Build));
        assert_eq!(p.role(1500, &[1500]), None);
        let only_operators = Policy {
            setters_gid: None,
            builders_gid: None,
            ..p.clone()
        };
        assert_eq!(only_operators.role(1500, &[1003, 1004]), None);
        let no_viewers = Policy {
            viewers_gid: None,
            ..p
        };
        assert_eq!(no_viewers.role(1500, &[1002]), None);
    }
}
