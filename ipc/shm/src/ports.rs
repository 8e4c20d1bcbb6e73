//! Opening the services with the same settings in every process (iceoryx2 refuses to open
//! a service whose settings differ from its creator's, and a subscriber's buffer can only
//! be as large as the service allows).

use hob_wire::{
    CanFrameSample, CommandRequest, CommandResponse, EventSample, RecorderSample, StateSample, StatsSample,
};
use iceoryx2::node::Node;
use iceoryx2::port::client::Client as IoxClient;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::server::Server;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::port::{LoanError, ReceiveError, SendError};
use iceoryx2::prelude::{NodeBuilder, NodeName, ServiceName, SignalHandlingMode};
use iceoryx2::service::port_factory::PortFactory as _;
use std::time::{Duration, Instant};

/// iceoryx2's service type used by every process (inter-process, not thread-safe ports).
pub type Svc = iceoryx2::prelude::ipc::Service;

/// State samples a subscriber may buffer: 2 s of cycles, so a logger that is descheduled
/// for a while loses nothing (its own `buffer_size` must be raised to this too).
pub const STATE_BUFFER: usize = 2048;
/// Events kept for late subscribers (a freshly started HMI sees the recent ones).
pub const EVENT_HISTORY: usize = 256;
pub const EVENT_BUFFER: usize = 1024;
/// Frames an endpoint of the virtual CAN bus may buffer (about 0.5 s of traffic).
pub const CAN_BUFFER: usize = 2048;
const MAX_PORTS: usize = 8;
/// Publishers of `state`, `events` and `stats`, and servers of `command`: the loop's alone.
/// A second process could otherwise feed the watchdog and the HMI a live-looking stream or
/// answer commands in the loop's place (issue 18); it is refused when it opens its port.
pub const LOOP_ONLY: usize = 1;

/// A failure to set up a port: start-up only, with iceoryx2's reason.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct IpcError(pub String);

impl std::fmt::Display for IpcError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // The gateway's own failures name it; the rest are iceoryx2's.
        if self.0.starts_with("the gateway") {
            write!(f, "{}", self.0)
        } else {
            write!(f, "shared-memory services: {}", self.0)
        }
    }
}

impl std::error::Error for IpcError {}

fn err<E: std::fmt::Debug>(what: &str) -> impl FnOnce(E) -> IpcError + '_ {
    move |e| IpcError(format!("{what}: {e:?}"))
}

static INSTANCE: std::sync::OnceLock<String> = std::sync::OnceLock::new();

/// Sets this process's instance name (before any port is opened; later calls are ignored).
pub fn use_instance(name: &str) {
    let _ = INSTANCE.set(name.to_string());
}

/// The instance name (`use_instance`, else `HOB_INSTANCE`, default `main`): separates
/// several controllers or parallel tests on one PC.
pub fn instance() -> String {
    if let Some(i) = INSTANCE.get() {
        return i.clone();
    }
    std::env::var("HOB_INSTANCE")
        .ok()
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "main".into())
}

/// `hob/<instance>/<what>`.
pub fn service_name(what: &str) -> Result<ServiceName, IpcError> {
    let s = format!("hob/{}/{what}", instance());
    ServiceName::new(&s).map_err(err("service name"))
}

/// A node named `name`, after removing what processes killed earlier left behind.
/// Signals are left to the process (iceoryx2 installs no handler).
pub fn node(name: &str) -> Result<Node<Svc>, IpcError> {
    // iceoryx2 warns on stderr when it finds no iceoryx2.toml; its defaults are ours.
    iceoryx2::prelude::set_log_level(iceoryx2::prelude::LogLevel::Error);
    let node_name = NodeName::new(name).map_err(err("node name"))?;
    let node = NodeBuilder::new()
        .name(&node_name)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<Svc>()
        .map_err(|e| {
            IpcError(format!(
                "node: {e:?} (every process of the bus runs as the user that made it, hob on the machine PC: \
                 its files in /tmp/iceoryx2 and /dev/shm are that user's alone)"
            ))
        })?;
    // Resources of nodes killed with `kill -9` (their ports still count against the
    // services' limits until removed).
    let _ = node.try_cleanup_dead_nodes();
    Ok(node)
}

/// A publish-subscribe service of this bus.
pub type PubSub<T> = iceoryx2::service::port_factory::publish_subscribe::PortFactory<Svc, T, ()>;

/// A publisher on `service`, connected to the subscribers that exist already.
pub fn publisher<T>(service: &PubSub<T>, what: &str) -> Result<Publisher<Svc, T, ()>, IpcError>
where
    T: std::fmt::Debug + iceoryx2::prelude::ZeroCopySend + 'static,
{
    let p = service.publisher_builder().create().map_err(err(what))?;
    let _ = p.update_connections();
    Ok(p)
}

fn pub_sub<T>(
    node: &Node<Svc>,
    what: &str,
    buffer: usize,
    history: usize,
    publishers: usize,
) -> Result<PubSub<T>, IpcError>
where
    T: std::fmt::Debug + iceoryx2::prelude::ZeroCopySend + 'static,
{
    let service = node
        .service_builder(&service_name(what)?)
        .publish_subscribe::<T>()
        .subscriber_max_buffer_size(buffer)
        .history_size(history)
        .max_subscribers(MAX_PORTS)
        .max_publishers(publishers)
        .max_nodes(MAX_PORTS * 2)
        .open_or_create()
        .map_err(err(what))?;
    // iceoryx2 opens a service that allows more ports than asked for: one made by another
    // program with room for a second publisher is refused here, in every process.
    let allowed = service.static_config().max_publishers();
    if allowed != publishers {
        return Err(ports_mismatch(what, "publishers", allowed, publishers));
    }
    Ok(service)
}

fn ports_mismatch(what: &str, ports: &str, allowed: usize, wanted: usize) -> IpcError {
    IpcError(format!(
        "service hob/{}/{what} allows {allowed} {ports}, not {wanted}: it was made by another program; \
         stop every process of this instance and remove it (iceoryx2's files in /dev/shm and /tmp/iceoryx2)",
        instance()
    ))
}

pub fn open_state(node: &Node<Svc>) -> Result<PubSub<StateSample>, IpcError> {
    pub_sub(node, "state", STATE_BUFFER, 0, LOOP_ONLY)
}

pub fn open_events(node: &Node<Svc>) -> Result<PubSub<EventSample>, IpcError> {
    pub_sub(node, "events", EVENT_BUFFER, EVENT_HISTORY, LOOP_ONLY)
}

pub fn open_stats(node: &Node<Svc>) -> Result<PubSub<StatsSample>, IpcError> {
    pub_sub(node, "stats", 16, 1, LOOP_ONLY)
}

/// The recorder's health: `hob-logger` alone publishes it (a second logger records
/// without reporting).
pub fn open_recorder(node: &Node<Svc>) -> Result<PubSub<RecorderSample>, IpcError> {
    pub_sub(node, "recorder", 4, 1, LOOP_ONLY)
}

pub fn open_can(node: &Node<Svc>) -> Result<PubSub<CanFrameSample>, IpcError> {
    pub_sub(node, "can", CAN_BUFFER, 0, MAX_PORTS)
}

type ReqRes = iceoryx2::service::port_factory::request_response::PortFactory<
    Svc,
    CommandRequest,
    (),
    CommandResponse,
    (),
>;

pub fn open_command(node: &Node<Svc>) -> Result<ReqRes, IpcError> {
    let service = node
        .service_builder(&service_name("command")?)
        .request_response::<CommandRequest, CommandResponse>()
        .max_clients(MAX_PORTS)
        .max_servers(LOOP_ONLY)
        .max_active_requests_per_client(2)
        .max_response_buffer_size(2)
        .max_nodes(MAX_PORTS * 2)
        .open_or_create()
        .map_err(err("command"))?;
    let allowed = service.static_config().max_servers();
    if allowed != LOOP_ONLY {
        return Err(ports_mismatch("command", "servers", allowed, LOOP_ONLY));
    }
    Ok(service)
}

/// The ports of a process that follows the loop (HMI, CLI, logger, watchdog): subscribers
/// with buffers as large as the services allow.
#[derive(Debug)]
pub struct Ports {
    pub node: Node<Svc>,
    pub state: Subscriber<Svc, StateSample, ()>,
    pub events: Subscriber<Svc, EventSample, ()>,
    pub stats: Subscriber<Svc, StatsSample, ()>,
    pub recorder: Subscriber<Svc, RecorderSample, ()>,
}

impl Ports {
    pub fn subscribe(name: &str) -> Result<Self, IpcError> {
        let node = node(name)?;
        let state = open_state(&node)?
            .subscriber_builder()
            .buffer_size(STATE_BUFFER)
            .create()
            .map_err(err("state subscriber"))?;
        let events = open_events(&node)?
            .subscriber_builder()
            .buffer_size(EVENT_BUFFER)
            .create()
            .map_err(err("events subscriber"))?;
        let stats = open_stats(&node)?
            .subscriber_builder()
            .create()
            .map_err(err("stats subscriber"))?;
        let recorder = open_recorder(&node)?
            .subscriber_builder()
            .create()
            .map_err(err("recorder subscriber"))?;
        let _ = state.update_connections();
        let _ = events.update_connections();
        let _ = stats.update_connections();
        let _ = recorder.update_connections();
        Ok(Self {
            node,
            state,
            events,
            stats,
            recorder,
        })
    }

    /// The next state sample, if one is waiting.
    pub fn next_state(&self) -> Option<StateSample> {
        self.state.receive().ok().flatten().map(|s| *s)
    }

    pub fn next_event(&self) -> Option<EventSample> {
        self.events.receive().ok().flatten().map(|s| *s)
    }

    /// The newest stats sample waiting, if any.
    pub fn latest_stats(&self) -> Option<StatsSample> {
        let mut last = None;
        while let Ok(Some(s)) = self.stats.receive() {
            last = Some(*s);
        }
        last
    }

    /// The newest report of the recorder's health waiting, if any.
    pub fn latest_recorder(&self) -> Option<RecorderSample> {
        let mut last = None;
        while let Ok(Some(s)) = self.recorder.receive() {
            last = Some(*s);
        }
        last
    }

    /// Waits up to `timeout` for a state sample; returns the newest one waiting.
    pub fn wait_state(&self, timeout: Duration) -> Option<StateSample> {
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

/// A frontend's command channel to the loop.
#[derive(Debug)]
pub struct Client {
    _node: Node<Svc>,
    client: IoxClient<Svc, CommandRequest, (), CommandResponse, ()>,
}

impl Client {
    pub fn connect(name: &str) -> Result<Self, IpcError> {
        let node = node(name)?;
        let client = open_command(&node)?
            .client_builder()
            .create()
            .map_err(err("command client"))?;
        let _ = client.update_connections();
        Ok(Self { _node: node, client })
    }

    /// Sends `req` and waits up to `timeout` for the answer.
    pub fn request(&self, req: &CommandRequest, timeout: Duration) -> Result<CommandResponse, IpcError> {
        let end = Instant::now() + timeout;
        let pending = self.client.send_copy(*req).map_err(err("send request"))?;
        loop {
            if let Some(r) = pending.receive().map_err(err("receive response"))? {
                return Ok(*r);
            }
            if Instant::now() >= end {
                return Err(IpcError(format!(
                    "no answer from hob-rt within {} ms (is it running? HOB_INSTANCE={})",
                    timeout.as_millis(),
                    instance()
                )));
            }
            std::thread::sleep(Duration::from_millis(1));
        }
    }
}

/// The server side of the command service (`hob-rt`'s command thread).
pub fn command_server(
    node: &Node<Svc>,
) -> Result<Server<Svc, CommandRequest, (), CommandResponse, ()>, IpcError> {
    let server = open_command(node)?
        .server_builder()
        .create()
        .map_err(err("command server"))?;
    let _ = server.update_connections();
    Ok(server)
}

/// A failure of an endpoint of the virtual CAN bus in the cycle: iceoryx2's reason, a
/// `Copy` value (nothing is formatted or allocated when it happens); [`std::fmt::Display`]
/// words it for the operator, outside the cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CanError {
    Send(SendError),
    Receive(ReceiveError),
}

impl CanError {
    /// Whether trying again later may succeed: the publisher had no sample free.
    pub fn is_transient(self) -> bool {
        matches!(
            self,
            CanError::Send(SendError::LoanError(
                LoanError::OutOfMemory | LoanError::ExceedsMaxLoans
            ))
        )
    }
}

impl std::fmt::Display for CanError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CanError::Send(e) => write!(f, "virtual CAN send: {e:?}"),
            CanError::Receive(e) => write!(f, "virtual CAN receive: {e:?}"),
        }
    }
}

impl std::error::Error for CanError {}

/// One endpoint of the shared-memory virtual CAN bus: every frame published reaches every
/// other endpoint; an endpoint never receives its own frames. Used where the kernel has
/// no CAN (no vcan): the same CANopen code runs on top of it.
#[derive(Debug)]
pub struct CanPort {
    _node: Node<Svc>,
    origin: u64,
    publisher: Publisher<Svc, CanFrameSample, ()>,
    subscriber: Subscriber<Svc, CanFrameSample, ()>,
    start: Instant,
}

/// Opens an endpoint of the virtual CAN bus.
pub fn open_can_port(name: &str) -> Result<CanPort, IpcError> {
    let node = node(name)?;
    let service = open_can(&node)?;
    let publisher = service
        .publisher_builder()
        .max_loaned_samples(4)
        .create()
        .map_err(err("can publisher"))?;
    let subscriber = service
        .subscriber_builder()
        .buffer_size(CAN_BUFFER)
        .create()
        .map_err(err("can subscriber"))?;
    let _ = publisher.update_connections();
    let _ = subscriber.update_connections();
    // Unique per endpoint: process id and a per-process counter.
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
    let origin =
        (u64::from(std::process::id()) << 16) | NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    Ok(CanPort {
        _node: node,
        origin,
        publisher,
        subscriber,
        start: Instant::now(),
    })
}

impl CanPort {
    /// Publishes one frame; never blocks (a slow endpoint loses its oldest frames). Runs in
    /// the cycle: a failure is a [`CanError`], copied, nothing allocated.
    pub fn send(&self, id: u16, data: &[u8]) -> Result<(), CanError> {
        let len = data.len().min(8);
        let mut d = [0u8; 8];
        d[..len].copy_from_slice(&data[..len]);
        let s = CanFrameSample {
            origin: self.origin,
            time_ns: self.start.elapsed().as_nanos() as u64,
            id,
            len: len as u8,
            _pad: [0; 5],
            data: d,
        };
        self.publisher.send_copy(s).map(|_| ()).map_err(Self::send_error)
    }

    /// What a failed send reports (in the cycle): iceoryx2's reason, copied; no text.
    pub fn send_error(e: SendError) -> CanError {
        CanError::Send(e)
    }

    /// The next frame from another endpoint, if one is waiting (in the cycle: a failure is
    /// a [`CanError`]).
    pub fn try_recv(&self) -> Result<Option<CanFrameSample>, CanError> {
        loop {
            match self.subscriber.receive() {
                Ok(Some(s)) if s.origin == self.origin => continue,
                Ok(Some(s)) => return Ok(Some(*s)),
                Ok(None) => return Ok(None),
                Err(e) => return Err(CanError::Receive(e)),
            }
        }
    }

    /// Makes ports that appeared since the last call known (new endpoints): outside the
    /// cycle, from time to time.
    pub fn update_connections(&self) {
        let _ = self.publisher.update_connections();
        let _ = self.subscriber.update_connections();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One test: the instance name is set once per process.
    #[test]
    fn only_the_loop_may_publish_the_state_and_serve_commands() {
        use_instance(&format!("ipc-test-{}", std::process::id()));
        let loop_node = node("loop").unwrap();
        let _state = publisher(&open_state(&loop_node).unwrap(), "state publisher").unwrap();
        let _events = publisher(&open_events(&loop_node).unwrap(), "events publisher").unwrap();
        let _server = command_server(&loop_node).unwrap();

        // A second process's publisher or server is refused...
        let other = node("impostor").unwrap();
        let e = publisher(&open_state(&other).unwrap(), "state publisher").unwrap_err();
        assert!(e.0.contains("state publisher"), "{e}");
        assert!(publisher(&open_events(&other).unwrap(), "events publisher").is_err());
        let e = command_server(&other).unwrap_err();
        assert!(e.0.contains("command server"), "{e}");
        // ... while followers still subscribe and send commands.
        let _follower = open_state(&other)
            .unwrap()
            .subscriber_builder()
            .buffer_size(STATE_BUFFER)
            .create()
            .unwrap();
        let _client = Client::connect("client").unwrap();

        // A service made by another program with room for more publishers: refused by
        // everyone who opens it, the loop and its followers alike.
        let maker = node("maker").unwrap();
        let _roomy = maker
            .service_builder(&service_name("stats").unwrap())
            .publish_subscribe::<StatsSample>()
            .subscriber_max_buffer_size(16)
            .history_size(1)
            .max_subscribers(MAX_PORTS)
            .max_publishers(MAX_PORTS)
            .max_nodes(MAX_PORTS * 2)
            .create()
            .unwrap();
        let e = open_stats(&loop_node).unwrap_err();
        assert!(e.0.contains("stats allows 8 publishers, not 1"), "{e}");
        let e = Ports::subscribe("follower").unwrap_err();
        assert!(e.0.contains("stats allows 8 publishers"), "{e}");
    }
}
