//! CiA 301 network management: node control (COB-ID 0) and the NMT states carried by
//! heartbeats and boot-up messages.

use super::frame::{Frame, NMT, heartbeat_id};

/// NMT node-control command specifiers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NmtCommand {
    Start = 0x01,
    Stop = 0x02,
    EnterPreOperational = 0x80,
    ResetNode = 0x81,
    ResetCommunication = 0x82,
}

impl NmtCommand {
    /// The node-control frame; `node` 0 addresses every node.
    pub fn frame(self, node: u8) -> Frame {
        Frame::new(NMT, &[self as u8, node])
    }

    pub fn parse(f: &Frame) -> Option<(Self, u8)> {
        if f.id != NMT || f.len != 2 {
            return None;
        }
        let cmd = match f.data[0] {
            0x01 => NmtCommand::Start,
            0x02 => NmtCommand::Stop,
            0x80 => NmtCommand::EnterPreOperational,
            0x81 => NmtCommand::ResetNode,
            0x82 => NmtCommand::ResetCommunication,
            _ => return None,
        };
        Some((cmd, f.data[1]))
    }
}

/// NMT state of a node.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NmtState {
    BootUp = 0x00,
    Stopped = 0x04,
    Operational = 0x05,
    PreOperational = 0x7F,
}

impl NmtState {
    pub fn name(self) -> &'static str {
        hob_wire::bus::nmt_state_name(self as u8)
    }

    /// The heartbeat (or boot-up, state 0) frame of `node`.
    pub fn heartbeat(self, node: u8) -> Frame {
        Frame::new(heartbeat_id(node), &[self as u8])
    }

    /// Node and state of a heartbeat frame.
    pub fn parse_heartbeat(f: &Frame) -> Option<(u8, Self)> {
        if !(0x701..=0x77F).contains(&f.id) || f.len != 1 {
            return None;
        }
        let state = match f.data[0] & 0x7F {
            0x00 => NmtState::BootUp,
            0x04 => NmtState::Stopped,
            0x05 => NmtState::Operational,
            0x7F => NmtState::PreOperational,
            _ => return None,
        };
        Some(((f.id - 0x700) as u8, state))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn node_control_layout() {
        // CiA 301 7.2.8.3.1: COB-ID 0, byte 0 command specifier, byte 1 node-ID.
        assert_eq!(NmtCommand::Start.frame(3).to_candump(), "000#0103");
        assert_eq!(NmtCommand::ResetCommunication.frame(0).to_candump(), "000#8200");
        assert_eq!(
            NmtCommand::parse(&Frame::new(0, &[0x80, 5])),
            Some((NmtCommand::EnterPreOperational, 5))
        );
    }

    #[test]
    fn heartbeat_layout() {
        assert_eq!(NmtState::Operational.heartbeat(2).to_candump(), "702#05");
        assert_eq!(NmtState::BootUp.heartbeat(2).to_candump(), "702#00");
        assert_eq!(
            NmtState::parse_heartbeat(&Frame::new(0x705, &[0x7F])),
            Some((5, NmtState::PreOperational))
        );
        assert_eq!(NmtState::parse_heartbeat(&Frame::new(0x705, &[0x7F, 0])), None);
    }
}
