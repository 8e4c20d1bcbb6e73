//! CiA 301 SDO: the byte layouts of expedited and segmented transfers, abort codes in
//! words, a client state machine (no I/O, fixed buffer) and a server for object
//! dictionaries (used by the simulated nodes).

use super::bus::BusError;
use super::frame::{Frame, sdo_rx_id, sdo_tx_id};

/// Largest object the client transfers (segmented), bytes.
pub const SDO_MAX: usize = 256;

/// An SDO abort code (CiA 301 table 22).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AbortCode(pub u32);

impl AbortCode {
    pub const TOGGLE: Self = Self(0x0503_0000);
    pub const TIMEOUT: Self = Self(0x0504_0000);
    pub const BAD_COMMAND: Self = Self(0x0504_0001);
    pub const OUT_OF_MEMORY: Self = Self(0x0504_0005);
    pub const UNSUPPORTED_ACCESS: Self = Self(0x0601_0000);
    pub const WRITE_ONLY: Self = Self(0x0601_0001);
    pub const READ_ONLY: Self = Self(0x0601_0002);
    pub const NO_OBJECT: Self = Self(0x0602_0000);
    pub const NOT_MAPPABLE: Self = Self(0x0604_0041);
    pub const PDO_TOO_LONG: Self = Self(0x0604_0042);
    pub const LENGTH_MISMATCH: Self = Self(0x0607_0010);
    pub const NO_SUBINDEX: Self = Self(0x0609_0011);
    pub const INVALID_VALUE: Self = Self(0x0609_0030);
    pub const GENERAL: Self = Self(0x0800_0000);
    pub const DEVICE_STATE: Self = Self(0x0800_0022);

    /// The abort code in words.
    pub fn text(self) -> &'static str {
        match self.0 {
            0x0503_0000 => "toggle bit not alternated",
            0x0504_0000 => "SDO protocol timed out",
            0x0504_0001 => "client/server command specifier not valid or unknown",
            0x0504_0002 => "invalid block size",
            0x0504_0003 => "invalid sequence number",
            0x0504_0004 => "CRC error",
            0x0504_0005 => "out of memory",
            0x0601_0000 => "unsupported access to an object",
            0x0601_0001 => "attempt to read a write-only object",
            0x0601_0002 => "attempt to write a read-only object",
            0x0602_0000 => "object does not exist in the object dictionary",
            0x0604_0041 => "object cannot be mapped to the PDO",
            0x0604_0042 => "the number and length of the objects to be mapped would exceed the PDO length",
            0x0604_0043 => "general parameter incompatibility",
            0x0604_0047 => "general internal incompatibility in the device",
            0x0606_0000 => "access failed due to a hardware error",
            0x0607_0010 => "data type does not match, length of service parameter does not match",
            0x0607_0012 => "data type does not match, length of service parameter too high",
            0x0607_0013 => "data type does not match, length of service parameter too low",
            0x0609_0011 => "sub-index does not exist",
            0x0609_0030 => "invalid value for parameter",
            0x0609_0031 => "value of parameter written too high",
            0x0609_0032 => "value of parameter written too low",
            0x0609_0036 => "maximum value is less than minimum value",
            0x060A_0023 => "resource not available: SDO connection",
            0x0800_0000 => "general error",
            0x0800_0020 => "data cannot be transferred or stored to the application",
            0x0800_0021 => "data cannot be transferred or stored because of local control",
            0x0800_0022 => "data cannot be transferred or stored because of the present device state",
            0x0800_0023 => "object dictionary dynamic generation fails or no object dictionary is present",
            0x0800_0024 => "no data available",
            _ => "unknown abort code",
        }
    }
}

/// Why an SDO transfer failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SdoError {
    /// The server aborted.
    Aborted { index: u16, sub: u8, code: AbortCode },
    /// No answer in time.
    Timeout { index: u16, sub: u8 },
    /// The answer did not follow the protocol (the client aborted).
    Protocol { index: u16, sub: u8 },
    /// More data than the client's buffer.
    TooLong { index: u16, sub: u8 },
    /// A request of the transfer could not be sent: the bus's reason.
    Send { index: u16, sub: u8, error: BusError },
}

impl std::fmt::Display for SdoError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            SdoError::Aborted { index, sub, code } => {
                write!(
                    f,
                    "SDO {index:04X}:{sub:02X} aborted: 0x{:08X} {}",
                    code.0,
                    code.text()
                )
            }
            SdoError::Timeout { index, sub } => write!(f, "SDO {index:04X}:{sub:02X}: no answer (timeout)"),
            SdoError::Protocol { index, sub } => {
                write!(f, "SDO {index:04X}:{sub:02X}: answer out of protocol")
            }
            SdoError::TooLong { index, sub } => {
                write!(f, "SDO {index:04X}:{sub:02X}: more than {SDO_MAX} bytes")
            }
            SdoError::Send { index, sub, error } => {
                write!(f, "SDO {index:04X}:{sub:02X}: request not sent: {error}")
            }
        }
    }
}

impl std::error::Error for SdoError {}

fn mux(index: u16, sub: u8) -> [u8; 3] {
    let i = index.to_le_bytes();
    [i[0], i[1], sub]
}

fn frame8(id: u16, cmd: u8, index: u16, sub: u8, data: [u8; 4]) -> Frame {
    let m = mux(index, sub);
    Frame::new(id, &[cmd, m[0], m[1], m[2], data[0], data[1], data[2], data[3]])
}

/// The abort frame (either direction: `id` of the sender's channel).
pub fn abort_frame(id: u16, index: u16, sub: u8, code: AbortCode) -> Frame {
    frame8(id, 0x80, index, sub, code.0.to_le_bytes())
}

/// What a client transfer is doing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Transfer {
    Idle,
    /// Waiting for the initiate-download response.
    DownloadInit,
    /// Sent a download segment, waiting for its response.
    DownloadSegment {
        toggle: bool,
        last: bool,
    },
    UploadInit,
    UploadSegment {
        toggle: bool,
    },
}

/// Result of feeding a frame to the client.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Progress {
    /// Not for this transfer.
    Ignored,
    /// Send this frame next.
    Send(Frame),
    /// Upload finished: the data is in [`SdoClient::data`].
    Uploaded,
    Downloaded,
    /// Failed; when the client aborted, the abort frame to send.
    Failed(SdoError, Option<Frame>),
}

/// An SDO client for one server node: one transfer at a time, fixed buffer.
#[derive(Debug, Clone)]
pub struct SdoClient {
    node: u8,
    index: u16,
    sub: u8,
    state: Transfer,
    buf: [u8; SDO_MAX],
    len: usize,
    pos: usize,
}

impl SdoClient {
    pub fn new(node: u8) -> Self {
        Self {
            node,
            index: 0,
            sub: 0,
            state: Transfer::Idle,
            buf: [0; SDO_MAX],
            len: 0,
            pos: 0,
        }
    }

    pub fn node(&self) -> u8 {
        self.node
    }

    pub fn busy(&self) -> bool {
        self.state != Transfer::Idle
    }

    /// The uploaded data.
    pub fn data(&self) -> &[u8] {
        &self.buf[..self.len]
    }

    /// The frame that starts reading `index:sub`.
    pub fn upload(&mut self, index: u16, sub: u8) -> Frame {
        self.index = index;
        self.sub = sub;
        self.len = 0;
        self.state = Transfer::UploadInit;
        frame8(sdo_rx_id(self.node), 0x40, index, sub, [0; 4])
    }

    /// The frame that starts writing `data` to `index:sub` (expedited up to 4 bytes,
    /// segmented beyond).
    pub fn download(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<Frame, SdoError> {
        if data.len() > SDO_MAX {
            return Err(SdoError::TooLong { index, sub });
        }
        self.index = index;
        self.sub = sub;
        self.buf[..data.len()].copy_from_slice(data);
        self.len = data.len();
        self.pos = 0;
        self.state = Transfer::DownloadInit;
        let id = sdo_rx_id(self.node);
        if (1..=4).contains(&data.len()) {
            // ccs = 1, n = 4 - len, e = 1, s = 1.
            let cmd = 0x20 | (((4 - data.len()) as u8) << 2) | 0x03;
            let mut d = [0u8; 4];
            d[..data.len()].copy_from_slice(data);
            Ok(frame8(id, cmd, index, sub, d))
        } else {
            // Segmented: ccs = 1, s = 1, size in bytes 4..7.
            Ok(frame8(id, 0x21, index, sub, (data.len() as u32).to_le_bytes()))
        }
    }

    /// The abort frame for the current transfer, which ends (e.g. on a timeout).
    pub fn abort(&mut self, code: AbortCode) -> Frame {
        self.state = Transfer::Idle;
        abort_frame(sdo_rx_id(self.node), self.index, self.sub, code)
    }

    fn fail_protocol(&mut self) -> Progress {
        let f = self.abort(AbortCode::BAD_COMMAND);
        Progress::Failed(
            SdoError::Protocol {
                index: self.index,
                sub: self.sub,
            },
            Some(f),
        )
    }

    fn next_download_segment(&mut self, toggle: bool) -> Frame {
        let n = (self.len - self.pos).min(7);
        let last = self.pos + n == self.len;
        let mut d = [0u8; 8];
        d[0] = (u8::from(toggle) << 4) | (((7 - n) as u8) << 1) | u8::from(last);
        d[1..1 + n].copy_from_slice(&self.buf[self.pos..self.pos + n]);
        self.pos += n;
        self.state = Transfer::DownloadSegment { toggle, last };
        Frame::new(sdo_rx_id(self.node), &d)
    }

    /// Feeds a received frame.
    pub fn on_frame(&mut self, f: &Frame) -> Progress {
        if f.id != sdo_tx_id(self.node) || self.state == Transfer::Idle || f.len != 8 {
            return Progress::Ignored;
        }
        let d = f.data;
        let same_mux = d[1..4] == mux(self.index, self.sub);
        if d[0] == 0x80 {
            return self.on_abort(&d);
        }
        match self.state {
            Transfer::Idle => Progress::Ignored,
            Transfer::DownloadInit => self.on_download_init(&d, same_mux),
            Transfer::DownloadSegment { toggle, last } => self.on_download_segment(&d, toggle, last),
            Transfer::UploadInit => self.on_upload_init(&d, same_mux),
            Transfer::UploadSegment { toggle } => self.on_upload_segment(&d, toggle),
        }
    }

    /// The server aborted the transfer.
    fn on_abort(&mut self, d: &[u8; 8]) -> Progress {
        self.state = Transfer::Idle;
        let code = AbortCode(u32::from_le_bytes([d[4], d[5], d[6], d[7]]));
        Progress::Failed(
            SdoError::Aborted {
                index: self.index,
                sub: self.sub,
                code,
            },
            None,
        )
    }

    /// The client aborts with `code`, failing as `error`.
    fn fail(&mut self, code: AbortCode, error: SdoError) -> Progress {
        let f = self.abort(code);
        Progress::Failed(error, Some(f))
    }

    /// More data than the buffer: the client aborts (out of memory).
    fn fail_too_long(&mut self) -> Progress {
        let error = SdoError::TooLong {
            index: self.index,
            sub: self.sub,
        };
        self.fail(AbortCode::OUT_OF_MEMORY, error)
    }

    /// The initiate-download response: done (expedited) or the first segment.
    fn on_download_init(&mut self, d: &[u8; 8], same_mux: bool) -> Progress {
        if d[0] != 0x60 || !same_mux {
            return self.fail_protocol();
        }
        if self.len <= 4 && self.len > 0 {
            self.state = Transfer::Idle;
            Progress::Downloaded
        } else {
            Progress::Send(self.next_download_segment(false))
        }
    }

    /// A download segment's response: done after the last, else the next segment.
    fn on_download_segment(&mut self, d: &[u8; 8], toggle: bool, last: bool) -> Progress {
        if d[0] != (0x20 | (u8::from(toggle) << 4)) {
            return self.fail_protocol();
        }
        if last {
            self.state = Transfer::Idle;
            Progress::Downloaded
        } else {
            Progress::Send(self.next_download_segment(!toggle))
        }
    }

    /// The initiate-upload response: the data (expedited) or the first segment's request.
    fn on_upload_init(&mut self, d: &[u8; 8], same_mux: bool) -> Progress {
        if d[0] & 0xE0 != 0x40 || !same_mux {
            return self.fail_protocol();
        }
        let expedited = d[0] & 0x02 != 0;
        let sized = d[0] & 0x01 != 0;
        if expedited {
            let n = if sized {
                4 - usize::from((d[0] >> 2) & 0x03)
            } else {
                4
            };
            self.buf[..n].copy_from_slice(&d[4..4 + n]);
            self.len = n;
            self.state = Transfer::Idle;
            Progress::Uploaded
        } else {
            let size = u32::from_le_bytes([d[4], d[5], d[6], d[7]]) as usize;
            if sized && size > SDO_MAX {
                return self.fail_too_long();
            }
            self.len = 0;
            self.state = Transfer::UploadSegment { toggle: false };
            Progress::Send(Frame::new(sdo_rx_id(self.node), &[0x60, 0, 0, 0, 0, 0, 0, 0]))
        }
    }

    /// An upload segment: its data kept; done after the last, else the next request.
    fn on_upload_segment(&mut self, d: &[u8; 8], toggle: bool) -> Progress {
        if d[0] & 0xE0 != 0x00 || (d[0] & 0x10 != 0) != toggle {
            let code = if d[0] & 0xE0 == 0 {
                AbortCode::TOGGLE
            } else {
                AbortCode::BAD_COMMAND
            };
            let error = SdoError::Protocol {
                index: self.index,
                sub: self.sub,
            };
            return self.fail(code, error);
        }
        let n = 7 - usize::from((d[0] >> 1) & 0x07);
        if self.len + n > SDO_MAX {
            return self.fail_too_long();
        }
        self.buf[self.len..self.len + n].copy_from_slice(&d[1..1 + n]);
        self.len += n;
        if d[0] & 0x01 != 0 {
            self.state = Transfer::Idle;
            Progress::Uploaded
        } else {
            let next = !toggle;
            self.state = Transfer::UploadSegment { toggle: next };
            Progress::Send(Frame::new(
                sdo_rx_id(self.node),
                &[0x60 | (u8::from(next) << 4), 0, 0, 0, 0, 0, 0, 0],
            ))
        }
    }
}

/// An object dictionary as an SDO server sees it.
pub trait ObjectDictionary {
    /// The value of `index:sub` as bytes.
    fn read(&mut self, index: u16, sub: u8) -> Result<Vec<u8>, AbortCode>;
    /// Writes `data` to `index:sub`.
    fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode>;
}

#[derive(Debug, Clone, Default)]
enum ServerTransfer {
    #[default]
    Idle,
    Download {
        index: u16,
        sub: u8,
        size: Option<usize>,
        data: Vec<u8>,
        toggle: bool,
    },
    Upload {
        index: u16,
        sub: u8,
        data: Vec<u8>,
        pos: usize,
        toggle: bool,
    },
}

/// An SDO server (expedited and segmented) in front of an object dictionary. Runs on
/// the simulated nodes, outside any real-time path: it allocates.
#[derive(Debug, Clone, Default)]
pub struct SdoServer {
    node: u8,
    transfer: ServerTransfer,
}

impl SdoServer {
    pub fn new(node: u8) -> Self {
        Self {
            node,
            transfer: ServerTransfer::Idle,
        }
    }

    /// Answers a request frame (or `None` if it is not an SDO request to this node).
    pub fn on_request(&mut self, f: &Frame, od: &mut dyn ObjectDictionary) -> Option<Frame> {
        if f.id != sdo_rx_id(self.node) || f.len != 8 {
            return None;
        }
        let d = f.data;
        let index = u16::from_le_bytes([d[1], d[2]]);
        let sub = d[3];
        match d[0] >> 5 {
            4 => {
                // Abort from the client.
                self.transfer = ServerTransfer::Idle;
                None
            }
            1 => self.initiate_download(&d, index, sub, od),
            0 => self.download_segment(&d, index, sub, od),
            2 => self.initiate_upload(index, sub, od),
            3 => self.upload_segment(&d, index, sub),
            _ => self.abort(index, sub, AbortCode::BAD_COMMAND),
        }
    }

    /// The server's response channel.
    fn tx(&self) -> u16 {
        sdo_tx_id(self.node)
    }

    /// Ends the transfer with the abort frame for `index:sub`.
    fn abort(&mut self, index: u16, sub: u8, code: AbortCode) -> Option<Frame> {
        self.transfer = ServerTransfer::Idle;
        Some(abort_frame(self.tx(), index, sub, code))
    }

    /// Initiate download: an expedited write done at once, or a segmented one begun.
    fn initiate_download(
        &mut self,
        d: &[u8; 8],
        index: u16,
        sub: u8,
        od: &mut dyn ObjectDictionary,
    ) -> Option<Frame> {
        let tx = self.tx();
        let expedited = d[0] & 0x02 != 0;
        let sized = d[0] & 0x01 != 0;
        if expedited {
            let n = if sized {
                4 - usize::from((d[0] >> 2) & 0x03)
            } else {
                4
            };
            self.transfer = ServerTransfer::Idle;
            return match od.write(index, sub, &d[4..4 + n]) {
                Ok(()) => Some(frame8(tx, 0x60, index, sub, [0; 4])),
                Err(code) => Some(abort_frame(tx, index, sub, code)),
            };
        }
        let size = sized.then(|| u32::from_le_bytes([d[4], d[5], d[6], d[7]]) as usize);
        self.transfer = ServerTransfer::Download {
            index,
            sub,
            size,
            data: Vec::new(),
            toggle: false,
        };
        Some(frame8(tx, 0x60, index, sub, [0; 4]))
    }

    /// A download segment: its data kept; after the last, the whole written (its size
    /// checked when the client gave one).
    fn download_segment(
        &mut self,
        d: &[u8; 8],
        index: u16,
        sub: u8,
        od: &mut dyn ObjectDictionary,
    ) -> Option<Frame> {
        let tx = self.tx();
        let ServerTransfer::Download {
            index,
            sub,
            size,
            data,
            toggle,
        } = &mut self.transfer
        else {
            return self.abort(index, sub, AbortCode::BAD_COMMAND);
        };
        let (index, sub) = (*index, *sub);
        if (d[0] & 0x10 != 0) != *toggle {
            return self.abort(index, sub, AbortCode::TOGGLE);
        }
        let n = 7 - usize::from((d[0] >> 1) & 0x07);
        data.extend_from_slice(&d[1..1 + n]);
        let response = Frame::new(tx, &[0x20 | (u8::from(*toggle) << 4), 0, 0, 0, 0, 0, 0, 0]);
        *toggle = !*toggle;
        if d[0] & 0x01 != 0 {
            let data = std::mem::take(data);
            let size = *size;
            self.transfer = ServerTransfer::Idle;
            if size.is_some_and(|s| s != data.len()) {
                return Some(abort_frame(tx, index, sub, AbortCode::LENGTH_MISMATCH));
            }
            if let Err(code) = od.write(index, sub, &data) {
                return Some(abort_frame(tx, index, sub, code));
            }
        }
        Some(response)
    }

    /// Initiate upload: the value read, answered expedited up to 4 bytes, else a
    /// segmented upload begun.
    fn initiate_upload(&mut self, index: u16, sub: u8, od: &mut dyn ObjectDictionary) -> Option<Frame> {
        let tx = self.tx();
        let data = match od.read(index, sub) {
            Ok(v) => v,
            Err(code) => return self.abort(index, sub, code),
        };
        if (1..=4).contains(&data.len()) {
            self.transfer = ServerTransfer::Idle;
            let mut v = [0u8; 4];
            v[..data.len()].copy_from_slice(&data);
            let cmd = 0x40 | (((4 - data.len()) as u8) << 2) | 0x03;
            Some(frame8(tx, cmd, index, sub, v))
        } else {
            let size = (data.len() as u32).to_le_bytes();
            self.transfer = ServerTransfer::Upload {
                index,
                sub,
                data,
                pos: 0,
                toggle: false,
            };
            Some(frame8(tx, 0x41, index, sub, size))
        }
    }

    /// An upload segment's request: the next up to 7 bytes.
    fn upload_segment(&mut self, d: &[u8; 8], index: u16, sub: u8) -> Option<Frame> {
        let tx = self.tx();
        let ServerTransfer::Upload {
            index,
            sub,
            data,
            pos,
            toggle,
        } = &mut self.transfer
        else {
            return self.abort(index, sub, AbortCode::BAD_COMMAND);
        };
        let (index, sub) = (*index, *sub);
        if (d[0] & 0x10 != 0) != *toggle {
            return self.abort(index, sub, AbortCode::TOGGLE);
        }
        let n = (data.len() - *pos).min(7);
        let last = *pos + n == data.len();
        let mut out = [0u8; 8];
        out[0] = (u8::from(*toggle) << 4) | (((7 - n) as u8) << 1) | u8::from(last);
        out[1..1 + n].copy_from_slice(&data[*pos..*pos + n]);
        *pos += n;
        *toggle = !*toggle;
        if last {
            self.transfer = ServerTransfer::Idle;
        }
        Some(Frame::new(tx, &out))
    }
}

#[cfg(test)]
mod tests;
