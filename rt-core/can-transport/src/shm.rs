//! The shared-memory virtual CAN bus as a [`CanBus`]: where the kernel has no CAN (no
//! vcan module), `hob-rt`, `hob-sim` and the watchdog exchange the same frames through an
//! iceoryx2 service, with the same CANopen code above it.

use hob_canopen::bus::{BusError, CanBus};
use hob_canopen::frame::Frame;
use hob_ipc::CanPort;

/// An endpoint of the shared-memory virtual CAN bus.
#[derive(Debug)]
pub struct ShmCan {
    port: CanPort,
}

impl ShmCan {
    /// Opens an endpoint (start-up only).
    pub fn open(name: &str) -> Result<Self, hob_ipc::IpcError> {
        Ok(Self {
            port: hob_ipc::open_can_port(name)?,
        })
    }

    /// Connects endpoints that appeared since (outside the cycle).
    pub fn update_connections(&self) {
        self.port.update_connections();
    }
}

impl CanBus for ShmCan {
    fn send(&mut self, f: &Frame) -> Result<(), BusError> {
        self.port
            .send(f.id, &f.data[..usize::from(f.len.min(8))])
            .map_err(|e| {
                // No sample free: a full queue (try again next cycle); else the bus is down.
                if e.is_transient() {
                    BusError::Full
                } else {
                    BusError::Down
                }
            })
    }

    fn try_recv(&mut self) -> Result<Option<Frame>, BusError> {
        match self.port.try_recv() {
            Ok(Some(s)) => Ok(Some(Frame::new(s.id, &s.data[..usize::from(s.len.min(8))]))),
            Ok(None) => Ok(None),
            Err(_) => Err(BusError::Down),
        }
    }

    fn wait_for_frame(&mut self, timeout: std::time::Duration) {
        // Nothing wakes a waiter here: a short sleep, then the caller polls again.
        std::thread::sleep(timeout.min(std::time::Duration::from_micros(50)));
    }
}

/// Which bus a process is on: `vcan0`/`can0` (SocketCAN) or `shm` (the virtual bus).
pub fn open_bus(iface: &str, node_name: &str) -> Result<Box<dyn CanBus>, String> {
    if iface == "shm" {
        return ShmCan::open(node_name)
            .map(|b| Box::new(b) as Box<dyn CanBus>)
            .map_err(|e| e.to_string());
    }
    crate::socketcan::SocketCan::open(iface)
        .map(|b| Box::new(b) as Box<dyn CanBus>)
        .map_err(|e| format!("{iface}: {e}"))
}

/// The bus `hob demo` and the tests use when none is named: `vcan0` if the kernel has it,
/// else the shared-memory virtual CAN.
pub fn default_iface() -> &'static str {
    if std::path::Path::new("/sys/class/net/vcan0").exists() {
        "vcan0"
    } else {
        "shm"
    }
}
