//! SocketCAN (raw `CAN_RAW`, non-blocking, usable from the real-time thread).

use hob_canopen::bus::{BusError, CanBus};
use hob_canopen::frame::Frame;
use socketcan::{
    CanDataFrame, CanFilter, CanFrame, CanSocket, EmbeddedFrame, Id, Socket, SocketOptions, StandardId,
};
use std::io::ErrorKind;
use std::os::fd::AsRawFd;

const ENETDOWN: i32 = 100;
const ENOBUFS: i32 = 105;

/// A raw SocketCAN socket in non-blocking mode.
#[derive(Debug)]
pub struct SocketCan {
    socket: CanSocket,
    iface: String,
}

impl SocketCan {
    /// Opens `iface` (e.g. `can0`, `vcan0`); start-up only.
    pub fn open(iface: &str) -> std::io::Result<Self> {
        let socket = CanSocket::open(iface).map_err(|e| {
            std::io::Error::new(
                e.kind(),
                format!("{iface}: {e} (does the interface exist and is it up?)"),
            )
        })?;
        socket.set_nonblocking(true)?;
        Ok(Self {
            socket,
            iface: iface.to_string(),
        })
    }

    pub fn iface(&self) -> &str {
        &self.iface
    }

    /// Waits up to `timeout` for a frame (start-up tools only: blocks).
    pub fn recv_timeout(&mut self, timeout: std::time::Duration) -> Result<Option<Frame>, BusError> {
        let deadline = std::time::Instant::now() + timeout;
        loop {
            if let Some(f) = self.try_recv()? {
                return Ok(Some(f));
            }
            if std::time::Instant::now() >= deadline {
                return Ok(None);
            }
            std::thread::sleep(std::time::Duration::from_micros(200));
        }
    }
}

fn os(e: std::io::Error) -> BusError {
    match e.kind() {
        ErrorKind::WouldBlock => BusError::Full,
        ErrorKind::NotFound | ErrorKind::BrokenPipe => BusError::Down,
        _ => match e.raw_os_error() {
            // ENETDOWN: the interface was taken down.
            Some(ENETDOWN) => BusError::Down,
            // ENOBUFS: the interface's transmit queue is full (a real controller under load).
            Some(ENOBUFS) => BusError::Full,
            Some(n) => BusError::Os(n),
            None => BusError::Os(0),
        },
    }
}

impl CanBus for SocketCan {
    fn send(&mut self, f: &Frame) -> Result<(), BusError> {
        let id = StandardId::new(f.id).ok_or(BusError::Os(22))?;
        let frame = CanDataFrame::new(id, f.payload()).ok_or(BusError::Os(22))?;
        self.socket.write_frame(&frame).map_err(os)
    }

    fn try_recv(&mut self) -> Result<Option<Frame>, BusError> {
        loop {
            match self.socket.read_frame() {
                Ok(CanFrame::Data(d)) => {
                    if let Id::Standard(id) = d.id() {
                        return Ok(Some(Frame::new(id.as_raw(), d.data())));
                    }
                    // 29-bit identifiers are not CANopen's: skip.
                }
                Ok(_) => {} // remote and error frames: skip
                Err(e) if e.kind() == ErrorKind::WouldBlock => return Ok(None),
                Err(e) => return Err(os(e)),
            }
        }
    }

    /// The kernel delivers a socket's own frames (`CAN_RAW_RECV_OWN_MSGS`) when they
    /// are on the bus: on vcan at once, on a controller with echo when transmitted, in
    /// order with the frames received. Filters keep out the other frames this master
    /// sends (NMT, RPDOs, SDO requests): what passes is SYNC and EMCY, TPDO 1-4, SDO
    /// responses and heartbeats, from any node, this socket's own among them (its own
    /// heartbeat comes back too; the master ignores it). The conformance suite checks it.
    fn echo_own_sync(&mut self) -> bool {
        let node_to_master = [0x080, 0x180, 0x280, 0x380, 0x480, 0x580, 0x700];
        let filters: Vec<CanFilter> = node_to_master
            .iter()
            .map(|&id| CanFilter::new(id, 0x780))
            .collect();
        self.socket.set_filters(&filters).is_ok() && self.socket.set_recv_own_msgs(true).is_ok()
    }

    /// Blocks in `poll(2)` until the socket is readable: the process wakes when a frame
    /// arrives, as a node reacts to reception.
    #[allow(unsafe_code)]
    fn wait_for_frame(&mut self, timeout: std::time::Duration) {
        let mut fd = libc::pollfd {
            fd: self.socket.as_raw_fd(),
            events: libc::POLLIN,
            revents: 0,
        };
        let ms = libc::c_int::try_from(timeout.as_millis().max(1)).unwrap_or(libc::c_int::MAX);
        // SAFETY: one valid pollfd for the duration of the call; the result only tells
        // whether to read, which the caller does with `try_recv` in any case.
        unsafe { libc::poll(&mut fd, 1, ms) };
    }
}
