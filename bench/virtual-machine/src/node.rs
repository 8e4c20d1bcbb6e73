//! A simulated CANopen node: NMT state machine, SDO server, PDO engine driven by its own
//! object dictionary (so mappings written by SDO take effect), heartbeat producer.

use crate::od::{Access, Od};
use hob_canopen::frame::{Cob, Frame, heartbeat_id};
use hob_canopen::nmt::{NmtCommand, NmtState};
use hob_canopen::sdo::SdoServer;

/// What handling a frame changed in the node.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Effect {
    /// The objects an RPDO or SDO wrote (indices, in mapping order; up to 8).
    written: [u16; 8],
    written_count: usize,
    pub sync: bool,
    pub reset: bool,
}

impl Effect {
    /// Whether the frame wrote object `index`.
    pub fn wrote(&self, index: u16) -> bool {
        self.written[..self.written_count].contains(&index)
    }

    fn write(&mut self, index: u16) {
        if self.written_count < self.written.len() && !self.wrote(index) {
            self.written[self.written_count] = index;
            self.written_count += 1;
        }
    }
}

/// One node.
#[derive(Debug, Clone)]
pub struct Node {
    pub id: u8,
    pub od: Od,
    defaults: Od,
    pub nmt: NmtState,
    sdo: SdoServer,
    /// A silent node neither sends nor hears anything (fault injection).
    pub silent: bool,
    last_tpdo: [Option<Vec<u8>>; 4],
    last_tpdo_s: [f64; 4],
    /// SYNCs since each TPDO was last sent (a synchronous type n is sent on every n-th).
    syncs_since_tpdo: [u32; 4],
    last_heartbeat_s: f64,
    /// When the master's heartbeat was last seen (s).
    pub master_seen_s: Option<f64>,
}

/// Whether a PDO transmission type (0x1800 + n, sub 2) is synchronous: sent on every
/// n-th SYNC (1..=240), as opposed to event-driven (254, 255).
fn synchronous(transmission_type: u32) -> bool {
    (1..=240).contains(&transmission_type)
}

/// The communication objects every node has: heartbeat, consumer, identity, PDOs.
pub fn communication_objects(
    od: &mut Od,
    node: u8,
    device_type: u32,
    name: &str,
    default_rpdo: &[[u32; 3]; 4],
    default_tpdo: &[[u32; 3]; 4],
) {
    od.set(0x1000, 0, Access::Ro, &device_type.to_le_bytes())
        .set(0x1001, 0, Access::Ro, &[0])
        .set_str(0x1008, 0, name)
        .set(0x1006, 0, Access::Rw, &0u32.to_le_bytes())
        .set(0x1017, 0, Access::Rw, &0u16.to_le_bytes())
        .set(0x1016, 0, Access::Ro, &[1])
        .set(0x1016, 1, Access::Rw, &0u32.to_le_bytes())
        .set(0x1018, 0, Access::Ro, &[4])
        .set(0x1018, 1, Access::Ro, &0x0000_0B0Bu32.to_le_bytes())
        .set(0x1018, 2, Access::Ro, &device_type.to_le_bytes())
        .set(0x1018, 3, Access::Ro, &0x0001_0000u32.to_le_bytes())
        .set(0x1018, 4, Access::Ro, &(0x1000 + u32::from(node)).to_le_bytes());
    for n in 0..4u16 {
        for (base, defaults) in [(0x1400u16, default_rpdo), (0x1800u16, default_tpdo)] {
            let comm = base + n;
            let cob = if base == 0x1400 {
                0x200 + 0x100 * u32::from(n)
            } else {
                0x180 + 0x100 * u32::from(n)
            } + u32::from(node);
            od.set(comm, 0, Access::Ro, &[if base == 0x1800 { 5 } else { 2 }])
                .set(comm, 1, Access::Rw, &(cob | 0x8000_0000).to_le_bytes())
                .set(comm, 2, Access::Rw, &[255]);
            if base == 0x1800 {
                od.set(comm, 3, Access::Rw, &0u16.to_le_bytes()).set(
                    comm,
                    5,
                    Access::Rw,
                    &0u16.to_le_bytes(),
                );
            }
            let map = comm + 0x200;
            let entries = defaults[usize::from(n)];
            let count = entries.iter().take_while(|e| **e != 0).count() as u8;
            od.set(map, 0, Access::Rw, &[count]);
            for s in 1..=8u8 {
                let v = entries.get(usize::from(s) - 1).copied().unwrap_or(0);
                od.set(map, s, Access::Rw, &v.to_le_bytes());
            }
            if count > 0 {
                od.put(comm, 1, u64::from(cob));
            }
        }
    }
}

impl Node {
    pub fn new(id: u8, od: Od) -> Self {
        Self {
            id,
            defaults: od.clone(),
            od,
            nmt: NmtState::PreOperational,
            sdo: SdoServer::new(id),
            silent: false,
            last_tpdo: Default::default(),
            last_tpdo_s: [f64::NEG_INFINITY; 4],
            syncs_since_tpdo: [0; 4],
            last_heartbeat_s: 0.0,
            master_seen_s: None,
        }
    }

    /// Reset communication: PDO and heartbeat parameters back to defaults; boot-up.
    fn reset(&mut self, out: &mut Vec<Frame>) {
        for index in
            (0x1000u16..0x2000).filter(|i| !(0x1000..=0x1018).contains(i) || *i == 0x1016 || *i == 0x1017)
        {
            for sub in 0..=8u8 {
                if let Some(d) = self.defaults.raw(index, sub) {
                    let v = d.to_vec();
                    let mut b = [0u8; 8];
                    b[..v.len().min(8)].copy_from_slice(&v[..v.len().min(8)]);
                    self.od.put(index, sub, u64::from_le_bytes(b));
                }
            }
        }
        self.nmt = NmtState::PreOperational;
        self.last_tpdo = Default::default();
        self.master_seen_s = None;
        out.push(NmtState::BootUp.heartbeat(self.id));
    }

    /// Power-on: the boot-up message.
    pub fn power_on(&mut self, out: &mut Vec<Frame>) {
        self.nmt = NmtState::PreOperational;
        out.push(NmtState::BootUp.heartbeat(self.id));
    }

    /// Handles one frame from the bus.
    pub fn handle(&mut self, f: &Frame, now_s: f64, out: &mut Vec<Frame>) -> Effect {
        let mut effect = Effect::default();
        if self.silent {
            return effect;
        }
        if let Some((cmd, target)) = NmtCommand::parse(f) {
            if target == 0 || target == self.id {
                let before = self.nmt;
                match cmd {
                    NmtCommand::Start => self.nmt = NmtState::Operational,
                    NmtCommand::Stop => self.nmt = NmtState::Stopped,
                    NmtCommand::EnterPreOperational => self.nmt = NmtState::PreOperational,
                    NmtCommand::ResetNode | NmtCommand::ResetCommunication => {
                        self.reset(out);
                        effect.reset = true;
                    }
                }
                if self.nmt != before && !effect.reset {
                    // Heartbeat on a state change, so the master need not wait a period.
                    out.push(self.nmt.heartbeat(self.id));
                    self.last_heartbeat_s = now_s;
                }
            }
            return effect;
        }
        match Cob::of(f.id) {
            Cob::Sync => effect.sync = self.nmt == NmtState::Operational,
            Cob::SdoRx(n) if n == self.id && self.nmt != NmtState::Stopped => {
                let index = u16::from_le_bytes([f.data[1], f.data[2]]);
                let before = self.od.raw(index, f.data[3]).map(<[u8]>::to_vec);
                if let Some(r) = self.sdo.on_request(f, &mut self.od) {
                    out.push(r);
                }
                if self.od.raw(index, f.data[3]).map(<[u8]>::to_vec) != before {
                    effect.write(index);
                }
            }
            Cob::Heartbeat(0x7F) => self.master_seen_s = Some(now_s),
            Cob::Rpdo(n, node) if node == self.id && self.nmt == NmtState::Operational => {
                self.receive_rpdo(n, f, out, &mut effect);
            }
            _ => {}
        }
        effect
    }

    fn mapping(&self, map: u16) -> Vec<(u16, u8, usize)> {
        let count = self.od.u32(map, 0) as u8;
        (1..=count)
            .map(|s| {
                let v = self.od.u32(map, s);
                ((v >> 16) as u16, (v >> 8) as u8, (v & 0xFF) as usize / 8)
            })
            .collect()
    }

    /// Writes a received RPDO's values into the dictionary. A value the entry does not
    /// accept (an unsupported mode of operation in 0x6060) is ignored, the rest applied.
    fn receive_rpdo(&mut self, n: u8, f: &Frame, out: &mut Vec<Frame>, effect: &mut Effect) {
        let comm = 0x1400 + u16::from(n) - 1;
        let cob = self.od.u32(comm, 1);
        if cob & 0x8000_0000 != 0 || (cob & 0x7FF) as u16 != f.id {
            return;
        }
        let entries = self.mapping(comm + 0x200);
        let len: usize = entries.iter().map(|e| e.2).sum();
        if usize::from(f.len) != len {
            // CiA 301: PDO not processed due to length error.
            out.push(
                hob_canopen::emcy::Emcy {
                    node: self.id,
                    code: 0x8210,
                    register: 0x10,
                    vendor: [0; 5],
                }
                .frame(),
            );
            return;
        }
        let mut pos = 0;
        for (index, sub, n) in entries {
            let mut b = [0u8; 8];
            b[..n].copy_from_slice(&f.data[pos..pos + n]);
            if self.od.accepts(index, sub, &b[..n]) {
                self.od.put(index, sub, u64::from_le_bytes(b));
                effect.write(index);
            }
            pos += n;
        }
    }

    /// Whether `cob` is one of this node's synchronous TPDOs (transmission type 1..=240):
    /// an answer to a SYNC, as opposed to an event-driven TPDO, which reports a change.
    pub fn is_sync_tpdo(&self, cob: u16) -> bool {
        (0x1800..0x1804u16).any(|comm| {
            let id = self.od.u32(comm, 1);
            id & 0x8000_0000 == 0 && (id & 0x7FF) as u16 == cob && synchronous(self.od.u32(comm, 2))
        })
    }

    /// Sends the TPDOs due: synchronous ones on a SYNC, event-driven ones on change
    /// (respecting the inhibit time).
    pub fn transmit_pdos(&mut self, sync: bool, now_s: f64, out: &mut Vec<Frame>) {
        if self.silent || self.nmt != NmtState::Operational {
            return;
        }
        for n in 0..4usize {
            let comm = 0x1800 + n as u16;
            let cob = self.od.u32(comm, 1);
            if cob & 0x8000_0000 != 0 {
                continue;
            }
            let ttype = self.od.u32(comm, 2);
            let mut data = Vec::new();
            for (index, sub, len) in self.mapping(comm + 0x200) {
                let raw = self.od.raw(index, sub).unwrap_or(&[]);
                let mut b = raw.to_vec();
                b.resize(len, 0);
                data.extend_from_slice(&b);
            }
            let due = if synchronous(ttype) {
                if sync {
                    self.syncs_since_tpdo[n] += 1;
                }
                sync && self.syncs_since_tpdo[n] >= ttype
            } else {
                let inhibit_s = f64::from(self.od.u32(comm, 3)) * 1e-4;
                let event_s = f64::from(self.od.u32(comm, 5)) * 1e-3;
                let since = now_s - self.last_tpdo_s[n];
                let changed = self.last_tpdo[n].as_ref() != Some(&data);
                (changed && since >= inhibit_s - 1e-9) || (event_s > 0.0 && since >= event_s - 1e-9)
            };
            if due {
                out.push(Frame::new((cob & 0x7FF) as u16, &data));
                self.last_tpdo[n] = Some(data);
                self.last_tpdo_s[n] = now_s;
                self.syncs_since_tpdo[n] = 0;
            }
        }
    }

    /// Sends the heartbeat when due.
    pub fn heartbeat(&mut self, now_s: f64, out: &mut Vec<Frame>) {
        let period_s = f64::from(self.od.u32(0x1017, 0)) * 1e-3;
        if self.silent || period_s <= 0.0 {
            return;
        }
        if now_s - self.last_heartbeat_s >= period_s - 1e-9 {
            out.push(Frame::new(heartbeat_id(self.id), &[self.nmt as u8]));
            self.last_heartbeat_s = now_s;
        }
    }

    /// Whether the master's heartbeat, which this node consumes, is overdue.
    pub fn master_lost(&self, now_s: f64) -> bool {
        let timeout_s = f64::from(self.od.u32(0x1016, 1) & 0xFFFF) * 1e-3;
        timeout_s > 0.0 && self.master_seen_s.is_some_and(|t| now_s - t > timeout_s)
    }
}
