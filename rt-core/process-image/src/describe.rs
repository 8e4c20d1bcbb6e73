//! Frames in words, for `hob can dump` and capture checks: NMT, SYNC, PDOs with the mapped
//! objects' names (from this machine's bus plan), SDO, EMCY with the error code's meaning,
//! heartbeats.

use crate::plan::BusPlan;
use hob_canopen::emcy::Emcy;
use hob_canopen::frame::{Cob, Frame};
use hob_canopen::nmt::{NmtCommand, NmtState};
use hob_canopen::pdo::Pdo;
use hob_canopen::sdo::AbortCode;

/// Name of an object of the drives' and coupler's dictionaries.
pub fn object_name(index: u16, plan: Option<&BusPlan>) -> &'static str {
    if plan.is_some_and(|p| p.spindle_encoder.index == index) {
        return "spindle encoder";
    }
    match index {
        0x1000 => "device type",
        0x1001 => "error register",
        0x1006 => "communication cycle period",
        0x1008 => "device name",
        0x1016 => "consumer heartbeat time",
        0x1017 => "producer heartbeat time",
        0x1018 => "identity",
        0x1400..=0x15FF => "RPDO communication",
        0x1600..=0x17FF => "RPDO mapping",
        0x1800..=0x19FF => "TPDO communication",
        0x1A00..=0x1BFF => "TPDO mapping",
        0x6000 => "digital inputs",
        0x6040 => "controlword",
        0x6041 => "statusword",
        0x6060 => "modes of operation",
        0x6061 => "modes of operation display",
        0x6064 => "position actual",
        0x6065 => "following error window",
        0x607A => "target position",
        0x607C => "home offset",
        0x6098 => "homing method",
        0x6099 => "homing speeds",
        0x609A => "homing acceleration",
        0x60B1 => "velocity offset",
        0x60C2 => "interpolation time period",
        0x6200 => "digital outputs",
        0x6401 => "analog inputs",
        0x6411 => "analog outputs",
        0x6502 => "supported drive modes",
        _ => "object",
    }
}

fn pdo_of(plan: &BusPlan, id: u16) -> Option<(&'static str, &Pdo)> {
    for d in &plan.drives {
        for p in [&d.target, &d.control, &d.actual, &d.status] {
            if p.cob_id == id {
                return Some((d.axis.name(), p));
            }
        }
    }
    [&plan.io.inputs, &plan.io.outputs, &plan.io.analog]
        .into_iter()
        .chain(plan.io.gauge.as_ref())
        .find(|p| p.cob_id == id)
        .map(|p| ("I/O", p))
}

fn describe_sdo(f: &Frame, request: bool, node: u8) -> String {
    let d = f.data;
    let who = if request { "request to" } else { "response from" };
    let index = u16::from_le_bytes([d[1], d[2]]);
    let mux = format!("0x{index:04X}:{:02X} {}", d[3], object_name(index, None));
    let value = u32::from_le_bytes([d[4], d[5], d[6], d[7]]);
    let text = match (request, d[0] >> 5) {
        (_, 4) => format!("abort {mux}: 0x{value:08X} {}", AbortCode(value).text()),
        (true, 1) if d[0] & 0x02 != 0 => {
            let n = if d[0] & 0x01 != 0 {
                4 - usize::from((d[0] >> 2) & 3)
            } else {
                4
            };
            format!("download {mux} = {}", hex(&d[4..4 + n]))
        }
        (true, 1) => format!("download {mux}, segmented, {value} bytes"),
        (true, 2) => format!("upload {mux}"),
        (true, 0) => format!(
            "download segment ({} bytes{})",
            7 - ((d[0] >> 1) & 7),
            if d[0] & 1 != 0 { ", last" } else { "" }
        ),
        (true, 3) => "upload segment request".to_string(),
        (false, 3) => format!("download acknowledged {mux}"),
        (false, 1) => "segment acknowledged".to_string(),
        (false, 2) if d[0] & 0x02 != 0 => {
            let n = if d[0] & 0x01 != 0 {
                4 - usize::from((d[0] >> 2) & 3)
            } else {
                4
            };
            format!("upload {mux} = {}", hex(&d[4..4 + n]))
        }
        (false, 2) => format!("upload {mux}, segmented, {value} bytes"),
        (false, 0) => format!(
            "upload segment {}{}",
            hex(&d[1..8 - usize::from((d[0] >> 1) & 7)]),
            if d[0] & 1 != 0 { " (last)" } else { "" }
        ),
        _ => format!("command 0x{:02X}", d[0]),
    };
    format!("SDO {who} node {node}: {text}")
}

fn hex(b: &[u8]) -> String {
    b.iter().map(|x| format!("{x:02X}")).collect::<Vec<_>>().join(" ")
}

/// One frame in words.
pub fn describe(f: &Frame, plan: Option<&BusPlan>) -> String {
    if let Some((cmd, node)) = NmtCommand::parse(f) {
        let target = if node == 0 {
            "all nodes".to_string()
        } else {
            format!("node {node}")
        };
        let what = match cmd {
            NmtCommand::Start => "start",
            NmtCommand::Stop => "stop",
            NmtCommand::EnterPreOperational => "enter pre-operational",
            NmtCommand::ResetNode => "reset node",
            NmtCommand::ResetCommunication => "reset communication",
        };
        return format!("NMT {what}: {target}");
    }
    match Cob::of(f.id) {
        Cob::Sync => "SYNC".to_string(),
        Cob::Emcy(_) => match Emcy::parse(f) {
            Some(e) => format!(
                "EMCY node {}: 0x{:04X} {} (error register 0x{:02X})",
                e.node,
                e.code,
                e.text(),
                e.register
            ),
            None => format!("EMCY (malformed, {} bytes)", f.len),
        },
        Cob::Heartbeat(_) => match NmtState::parse_heartbeat(f) {
            Some((node, NmtState::BootUp)) => format!("boot-up node {node}"),
            Some((node, s)) => format!("heartbeat node {node}: {}", s.name()),
            None => format!("heartbeat (malformed, {} bytes)", f.len),
        },
        Cob::SdoRx(node) if f.len == 8 => describe_sdo(f, true, node),
        Cob::SdoTx(node) if f.len == 8 => describe_sdo(f, false, node),
        Cob::Tpdo(n, node) | Cob::Rpdo(n, node) => {
            let kind = if matches!(Cob::of(f.id), Cob::Tpdo(..)) {
                "TPDO"
            } else {
                "RPDO"
            };
            match plan.and_then(|p| pdo_of(p, f.id).map(|(axis, pdo)| (p, axis, pdo))) {
                Some((p, axis, pdo)) => match pdo.unpack(f) {
                    Some(v) => {
                        let fields: Vec<String> = pdo
                            .entries()
                            .iter()
                            .zip(v)
                            .map(|(e, raw)| {
                                let value = match e.bits {
                                    32 => (raw as u32 as i32).to_string(),
                                    16 if matches!(e.index, 0x6401 | 0x6411) => {
                                        (raw as u16 as i16).to_string()
                                    }
                                    16 => format!("0x{:04X}", raw as u16),
                                    // Modes of operation and their display: the signed
                                    // code (8 cyclic synchronous position, 6 homing).
                                    8 if matches!(e.index, 0x6060 | 0x6061) => (raw as u8 as i8).to_string(),
                                    _ => format!("0x{:02X}", raw as u8),
                                };
                                format!("{} = {value}", object_name(e.index, Some(p)))
                            })
                            .collect();
                        format!("{kind}{n} node {node} ({axis}): {}", fields.join(", "))
                    }
                    None => format!(
                        "{kind}{n} node {node} ({axis}): wrong length {} bytes: {}",
                        f.len,
                        hex(f.payload())
                    ),
                },
                None => format!("{kind}{n} node {node}: {}", hex(f.payload())),
            }
        }
        _ => format!("0x{:03X}: {}", f.id, hex(f.payload())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan() -> BusPlan {
        BusPlan::from_machine(&hob_config::machine::shipped_for_tests())
    }

    #[test]
    fn frames_in_words() {
        let p = plan();
        let d = |s: &str| describe(&Frame::from_candump(s).expect("frame"), Some(&p));
        assert_eq!(d("000#0100"), "NMT start: all nodes");
        assert_eq!(d("080#"), "SYNC");
        assert_eq!(d("702#05"), "heartbeat node 2: operational");
        assert_eq!(d("703#00"), "boot-up node 3");
        assert_eq!(
            d("083#1186010000000000"),
            "EMCY node 3: 0x8611 following error (error register 0x01)"
        );
        assert_eq!(
            d("182#10270000FBFFFFFF"),
            "TPDO1 node 2 (B): position actual = 10000, spindle encoder = -5"
        );
        assert_eq!(d("203#E8030000"), "RPDO1 node 3 (X): target position = 1000");
        assert_eq!(
            d("284#371208"),
            "TPDO2 node 4 (Y): statusword = 0x1237, modes of operation display = 8"
        );
        assert_eq!(
            d("303#061F00"),
            "RPDO2 node 3 (X): modes of operation = 6, controlword = 0x001F"
        );
        assert_eq!(
            d("302#080F00"),
            "RPDO2 node 2 (B): modes of operation = 8, controlword = 0x000F"
        );
        assert_eq!(
            d("284#3702"),
            "TPDO2 node 4 (Y): wrong length 2 bytes: 37 02",
            "the statusword alone is no longer this plan's"
        );
        assert_eq!(
            d("603#2F98600003000000"),
            "SDO request to node 3: download 0x6098:00 homing method = 03"
        );
        assert_eq!(
            d("602#4000100000000000"),
            "SDO request to node 2: upload 0x1000:00 device type"
        );
        assert_eq!(
            d("582#4300100092010200"),
            "SDO response from node 2: upload 0x1000:00 device type = 92 01 02 00"
        );
        assert_eq!(
            d("582#8034120500000206"),
            "SDO response from node 2: abort 0x1234:05 object: 0x06020000 object does not exist in the object dictionary"
        );
        assert_eq!(d("182#1027"), "TPDO1 node 2 (B): wrong length 2 bytes: 10 27");
    }
}
