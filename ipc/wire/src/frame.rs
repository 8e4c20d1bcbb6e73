//! The gateway's frames: how a frontend of another user and `hob-gateway` talk over a
//! Unix socket (the socket itself is `hob-ipc`'s and the gateway's). A frame is a
//! little-endian `u32` length and that many bytes of postcard: [`ToGateway`] one way,
//! [`FromGateway`] the other. Pure: bytes in, messages out.

use crate::{CommandRequest, CommandResponse, EventSample, RecorderSample, StateSample, StatsSample};
use serde::{Deserialize, Serialize};

/// The largest frame either side accepts (a program's text is 16 KiB).
pub const MAX_FRAME: usize = 64 * 1024;

/// What a peer may do, its user level: decided by the gateway from the peer's user and
/// groups (`--viewers`, `--operators`, `--setters`, `--builders`), and by `hob-hmi` for its
/// panel (at most its own user's level). The numbers on the wire are the order of the
/// variants here: never reorder them, only add at the end.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Role {
    /// The operator: watch and command the machine, define and edit programs (the
    /// operators' group).
    Operate,
    /// Watch only (the viewers' group).
    Watch,
    /// The setter: the operator's rights and tools and compensation (the span's depth
    /// carried into a program) (the setters' group).
    Set,
    /// The machine builder: everything, machine data too (the builders' group, the bus's
    /// own user, root).
    Build,
}

/// What a level may or may not do.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Action {
    Watch,
    /// Any command to the loop.
    Command,
    EditPrograms,
    EditTools,
    /// A measured correction written into a program (the span's depth).
    Compensate,
    EditMachineData,
}

impl Action {
    pub const ALL: [Action; 6] = [
        Action::Watch,
        Action::Command,
        Action::EditPrograms,
        Action::EditTools,
        Action::Compensate,
        Action::EditMachineData,
    ];

    /// Its name for programs (`edit_tools`).
    pub fn key(self) -> &'static str {
        match self {
            Action::Watch => "watch",
            Action::Command => "command",
            Action::EditPrograms => "edit_programs",
            Action::EditTools => "edit_tools",
            Action::Compensate => "compensate",
            Action::EditMachineData => "edit_machine_data",
        }
    }

    /// In the operator's words.
    pub fn words(self) -> &'static str {
        match self {
            Action::Watch => "watch the machine",
            Action::Command => "command the machine",
            Action::EditPrograms => "define and change programs",
            Action::EditTools => "change tools",
            Action::Compensate => "carry a measured correction into a program",
            Action::EditMachineData => "change machine data",
        }
    }
}

impl Role {
    /// Lowest first.
    pub const ALL: [Role; 4] = [Role::Watch, Role::Operate, Role::Set, Role::Build];

    pub fn name(self) -> &'static str {
        match self {
            Role::Operate => "operate",
            Role::Watch => "watch",
            Role::Set => "set",
            Role::Build => "build",
        }
    }

    /// The level's name for people: viewer, operator, setter, builder.
    pub fn level(self) -> &'static str {
        match self {
            Role::Watch => "viewer",
            Role::Operate => "operator",
            Role::Set => "setter",
            Role::Build => "builder",
        }
    }

    /// A level by its name (`operator`, ...), or `None`.
    pub fn from_level(word: &str) -> Option<Role> {
        Self::ALL.into_iter().find(|r| r.level() == word)
    }

    /// 0 for the viewer up to 3 for the builder.
    pub fn rank(self) -> u8 {
        match self {
            Role::Watch => 0,
            Role::Operate => 1,
            Role::Set => 2,
            Role::Build => 3,
        }
    }

    /// The lower of two levels.
    pub fn min(self, other: Role) -> Role {
        if self.rank() <= other.rank() { self } else { other }
    }

    /// The one table of who may do what.
    pub fn allows(self, a: Action) -> bool {
        let least = match a {
            Action::Watch => Role::Watch,
            Action::Command | Action::EditPrograms => Role::Operate,
            Action::EditTools | Action::Compensate => Role::Set,
            Action::EditMachineData => Role::Build,
        };
        self.rank() >= least.rank()
    }
}

/// A frontend to the gateway.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum ToGateway {
    /// Send me the loop's streams (state, events, stats, the recorder's health).
    Watch,
    /// A command for the loop.
    Request(Box<CommandRequest>),
}

/// The gateway to a frontend.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum FromGateway {
    /// The first frame of a connection the gateway took: who the peer is and what it may do.
    Welcome {
        user: String,
        role: Role,
    },
    /// The connection, or a request on it, was refused by the gateway (the loop never saw it).
    Refused(String),
    /// The loop's answer to the last request.
    Answer(Box<CommandResponse>),
    State(Box<StateSample>),
    Event(Box<EventSample>),
    Stats(Box<StatsSample>),
    Recorder(Box<RecorderSample>),
}

/// One frame: length and postcard bytes.
pub fn encode<T: Serialize>(msg: &T) -> Result<Vec<u8>, crate::Error> {
    let body = postcard::to_stdvec(msg).map_err(|e| crate::Error::Encode(e.to_string()))?;
    if body.len() > MAX_FRAME {
        return Err(crate::Error::FrameTooLong {
            bytes: body.len(),
            max: MAX_FRAME,
        });
    }
    let mut out = Vec::with_capacity(4 + body.len());
    out.extend_from_slice(&(body.len() as u32).to_le_bytes());
    out.extend_from_slice(&body);
    Ok(out)
}

/// The first whole frame at the start of `buf`: `Ok(None)` when it is not all there yet,
/// else the message and the bytes it took. A length over [`MAX_FRAME`] or bytes that do
/// not decode are an error (the connection is closed: nothing after it can be trusted).
pub fn decode<T: for<'de> Deserialize<'de>>(buf: &[u8]) -> Result<Option<(T, usize)>, crate::Error> {
    let Some(len) = buf.get(..4) else {
        return Ok(None);
    };
    let len = u32::from_le_bytes([len[0], len[1], len[2], len[3]]) as usize;
    if len > MAX_FRAME {
        return Err(crate::Error::FrameTooLong {
            bytes: len,
            max: MAX_FRAME,
        });
    }
    let Some(body) = buf.get(4..4 + len) else {
        return Ok(None);
    };
    let msg = postcard::from_bytes(body).map_err(|e| crate::Error::Decode(e.to_string()))?;
    Ok(Some((msg, 4 + len)))
}

/// Serde for the byte arrays of the samples that are longer than serde's 32 (texts): the
/// bytes, and exactly as many back.
pub mod fixed_bytes {
    use serde::de::{Error, Visitor};
    use serde::{Deserializer, Serializer};

    pub fn serialize<S: Serializer, const N: usize>(a: &[u8; N], s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(a)
    }

    pub fn deserialize<'de, D: Deserializer<'de>, const N: usize>(d: D) -> Result<[u8; N], D::Error> {
        struct Exactly<const N: usize>;
        impl<const N: usize> Visitor<'_> for Exactly<N> {
            type Value = [u8; N];
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                write!(f, "{N} bytes")
            }
            fn visit_bytes<E: Error>(self, v: &[u8]) -> Result<[u8; N], E> {
                v.try_into().map_err(|_| E::invalid_length(v.len(), &self))
            }
        }
        d.deserialize_bytes(Exactly::<N>)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn sample(cycle: u64, err: f64) -> StateSample {
        StateSample {
            cycle,
            sync_error_arcsec: err,
            drive_statusword: [0x1237, 0x0637, 0xFFFF],
            ..Default::default()
        }
    }

    /// The levels' table: an operator commands and edits programs but changes no tools,
    /// compensation or machine data; each level may what the one below may. The wire
    /// numbers of the older two levels stay (a welcome from an older gateway decodes).
    #[test]
    fn each_level_may_what_the_table_says() {
        let may = |r: Role| Action::ALL.iter().filter(|a| r.allows(**a)).count();
        assert_eq!(Role::ALL.map(may), [1, 3, 5, 6]);
        assert!(Role::Operate.allows(Action::EditPrograms) && !Role::Operate.allows(Action::EditTools));
        assert!(!Role::Operate.allows(Action::Compensate) && !Role::Operate.allows(Action::EditMachineData));
        assert!(Role::Set.allows(Action::Compensate) && !Role::Set.allows(Action::EditMachineData));
        assert!(!Role::Watch.allows(Action::Command));
        for r in Role::ALL {
            assert_eq!(Role::from_level(r.level()), Some(r));
            for a in Action::ALL {
                for lower in Role::ALL.iter().filter(|l| l.rank() < r.rank()) {
                    assert!(!lower.allows(a) || r.allows(a), "{r:?} {a:?}");
                }
            }
        }
        assert_eq!(Role::Set.min(Role::Operate), Role::Operate);
        let wire = |r: Role| postcard::to_stdvec(&r).unwrap();
        assert_eq!(
            [
                wire(Role::Operate),
                wire(Role::Watch),
                wire(Role::Set),
                wire(Role::Build)
            ],
            [[0], [1], [2], [3]]
        );
    }

    proptest! {
        #[test]
        fn every_decode_of_an_encode_is_the_identity(
            cycle in any::<u64>(),
            err in any::<f64>().prop_filter("NaN is not equal to itself", |f| !f.is_nan()),
            name in "[a-z/._-]{0,200}",
            text in "\\PC{0,3000}",
            accepted in any::<bool>(),
        ) {
            let req = CommandRequest::load_program(&name, &text).unwrap();
            let mut ev = EventSample { seq: cycle, kind: 7, ..Default::default() };
            ev.text_len = crate::write_text(&mut ev.text, &text);
            let msgs = [
                FromGateway::State(Box::new(sample(cycle, err))),
                FromGateway::Event(Box::new(ev)),
                FromGateway::Answer(Box::new(CommandResponse::new(accepted, 3, &text))),
                FromGateway::Welcome { user: name.clone(), role: Role::Watch },
            ];
            for m in msgs {
                let bytes = encode(&m).unwrap();
                let (back, used) = decode::<FromGateway>(&bytes).unwrap().unwrap();
                prop_assert_eq!(used, bytes.len());
                prop_assert_eq!(back, m);
            }
            let bytes = encode(&ToGateway::Request(Box::new(req))).unwrap();
            let (back, _) = decode::<ToGateway>(&bytes).unwrap().unwrap();
            prop_assert_eq!(back, ToGateway::Request(Box::new(req)));
        }

        #[test]
        fn a_frame_cut_short_waits_and_garbage_is_refused(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
            // Whatever arrives: a whole message, "not yet", or a refusal; never a panic.
            let _ = decode::<ToGateway>(&bytes);
            let frame = encode(&FromGateway::State(Box::new(sample(5, 1.5)))).unwrap();
            for cut in 0..frame.len() {
                prop_assert_eq!(decode::<FromGateway>(&frame[..cut]).unwrap(), None);
            }
        }
    }

    #[test]
    fn a_length_over_the_limit_is_refused_before_anything_is_read() {
        let mut b = ((MAX_FRAME + 1) as u32).to_le_bytes().to_vec();
        b.extend_from_slice(&[0; 16]);
        assert!(
            decode::<ToGateway>(&b)
                .unwrap_err()
                .to_string()
                .contains("at most")
        );
        // A fixed array of the wrong length does not decode.
        let mut bad = encode(&FromGateway::Answer(Box::new(CommandResponse::new(
            true, 0, "ok",
        ))))
        .unwrap();
        bad.truncate(bad.len() - 1);
        let n = (bad.len() - 4) as u32;
        bad[..4].copy_from_slice(&n.to_le_bytes());
        assert!(decode::<FromGateway>(&bad).is_err());
    }
}
