//! The fuzz targets (issue 18): each takes arbitrary bytes, feeds them to a decoder of outside
//! data and asserts its properties, not just "no panic". libFuzzer drives them from
//! `fuzz/fuzz_targets/` (`cargo +nightly fuzz run TARGET`, `ci/fuzz`); the test command
//! replays `fuzz/corpus/TARGET/`, `fuzz/seeds/TARGET/` and `fuzz/regressions/TARGET/` through
//! them on stable (`tests/replay.rs`), so a past crash stays fixed.

use hob_canopen::frame::{Frame, sdo_rx_id, sdo_tx_id};
use hob_canopen::sdo::{AbortCode, ObjectDictionary, Progress, SDO_MAX, SdoClient, SdoServer};
use hob_control::{Command, ControlParams, Controller};
use hob_hmi::protocol::ClientMsg;
use hob_ipc::CommandRequest;
use hob_logger::format::{decode as decode_state, encode as encode_state, parse_event_line, states_in_file};
use hob_master::Cyclic;
use hob_process_image::capture::{check_schedule, parse_candump};
use hob_process_image::plan::BusPlan;
use hob_rt_os::alloc_guard;
/// The allocator a target binary installs to have `cyclic`'s heap check count.
pub use hob_rt_os::alloc_guard::CountingAllocator;
use hob_service::commands::{Mail, to_mail};
use hob_service::encode;
use hob_setup::config::Problems;
use hob_setup::config::machine::MachineConfig;
use hob_setup::job::Program;
use hob_setup::planner;
use std::path::Path;
use std::sync::OnceLock;

/// A target: its properties asserted on one input.
pub type Target = fn(&[u8]);

/// The targets, by name (`fuzz/fuzz_targets/NAME.rs`, `fuzz/corpus/NAME/`).
pub const TARGETS: [(&str, Target); 9] = [
    ("candump", candump),
    ("program", program),
    ("machine", machine),
    ("cyclic", cyclic),
    ("sdo", sdo),
    ("command", command),
    ("log", log),
    ("hmi", hmi),
    ("gateway", gateway),
];

/// The shipped machine file, the machine the programs are planned on.
fn shipped() -> &'static MachineConfig {
    static M: OnceLock<MachineConfig> = OnceLock::new();
    M.get_or_init(|| {
        let src = include_str!("../../../config/machine.toml");
        MachineConfig::parse(Path::new("config/machine.toml"), src).expect("the shipped machine file")
    })
}

/// A `candump -L` capture (`hob can check-capture`, `hob can dump --file`): every frame it
/// reads writes back to the text it was read from and reads again to itself (decode of
/// encode is the identity); the schedule check over any capture returns a report whose
/// counts add up.
pub fn candump(data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    let frames = parse_candump(&text);
    for c in &frames {
        let line = c.frame.to_candump();
        assert_eq!(Frame::from_candump(&line), Some(c.frame), "{line}");
        assert!(c.frame.len <= 8 && c.frame.id <= 0x7FF);
    }
    let r = check_schedule(&frames, &BusPlan::from_machine(shipped()));
    assert_eq!(r.frames, frames.len());
    assert!(r.syncs <= r.frames && r.cycles_checked <= r.syncs);
}

/// A program file (`hob check`, `hob plan`, the HMI's editor, the library): parsed, checked
/// and planned on the shipped machine. A refusal names at least one problem; an accepted
/// program has passes and finite figures.
pub fn program(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(job) = Program::parse(Path::new("fuzz.toml"), text) else {
        return;
    };
    let mut p = Problems::new();
    match planner::plan(&job, shipped(), &mut p) {
        None => assert!(!p.is_empty(), "refused without a reason"),
        Some(plan) => {
            assert!(p.is_empty());
            assert!(!plan.passes.is_empty(), "accepted with no pass");
            assert!(plan.total_time_s.is_finite() && plan.total_time_s > 0.0);
            for pass in &plan.passes {
                assert!(pass.spindle_rpm.is_finite() && pass.x_mm.is_finite() && pass.cut_time_s.is_finite());
            }
        }
    }
}

/// A machine file (`hob check --machine`, every service at start-up): parsed and validated;
/// an accepted one yields a bus plan.
pub fn machine(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(m) = MachineConfig::parse(Path::new("fuzz-machine.toml"), text) {
        let plan = BusPlan::from_machine(&m);
        assert!(
            plan.nodes().iter().all(|n| (1..=127).contains(n)),
            "{:?}",
            plan.nodes()
        );
    }
}

/// The frames the bus brings into the master's cyclic exchange, any ids, lengths and order,
/// cycles cut anywhere: a byte 0 ends a cycle (`Cyclic::inputs`), any other byte starts a
/// frame `[len % 9] [id lo] [id hi] [data...]`. Each drive's reported position is one a
/// TPDO1 of that drive carried (or the start's 0), and a drive is fresh only in a cycle in
/// which such a frame arrived. Neither `receive` nor `inputs` touches the heap: where the
/// counting allocator is the global one (the fuzz target, the replay test), every call is
/// counted as a cycle's and must count nothing.
pub fn cyclic(data: &[u8]) {
    let plan = BusPlan::from_machine(shipped());
    let mut c = Cyclic::unbooted(plan);
    let pdo1 = plan.drives.map(|d| d.actual);
    let mut carried: [Vec<i32>; 3] = [vec![0], vec![0], vec![0]];
    let mut arrived = [false; 3];
    let mut i = 0;
    while i < data.len() {
        let op = data[i];
        i += 1;
        if op == 0 {
            let inp = no_heap("Cyclic::inputs", || c.inputs());
            for (k, fb) in [inp.table, inp.x, inp.y].iter().enumerate() {
                assert!(
                    carried[k].contains(&fb.position_counts),
                    "drive {k} reports {} that no TPDO carried",
                    fb.position_counts
                );
                assert!(
                    !fb.fresh || arrived[k],
                    "drive {k} fresh without a TPDO this cycle"
                );
            }
            arrived = [false; 3];
            continue;
        }
        let len = usize::from(op % 9);
        let Some(head) = data.get(i..i + 2) else { break };
        let id = u16::from_le_bytes([head[0], head[1]]) & 0x7FF;
        i += 2;
        let end = (i + len).min(data.len());
        let f = Frame::new(id, &data[i..end]);
        i = end;
        for (k, p) in pdo1.iter().enumerate() {
            if p.unpack(&f).is_some() {
                let b = f.payload();
                carried[k].push(i32::from_le_bytes([b[0], b[1], b[2], b[3]]));
                arrived[k] = true;
            }
        }
        no_heap("Cyclic::receive", || c.receive(&f));
    }
}

/// Runs `f` as a control cycle's code under `hob_rt_os::alloc_guard` and asserts it made no
/// heap operation (none is counted when that allocator is not the global one).
pub fn no_heap<T>(what: &str, f: impl FnOnce() -> T) -> T {
    let before = alloc_guard::counts();
    alloc_guard::in_cycle(true);
    let out = f();
    alloc_guard::in_cycle(false);
    if let (Some(b), Some(a)) = (before, alloc_guard::counts()) {
        assert_eq!(
            a, b,
            "{what} touched the heap (system, pool operations before and after)"
        );
    }
    out
}

/// A small object dictionary for the SDO target: a read-only entry, writable entries of
/// any length up to the SDO buffer.
#[derive(Debug, Clone, Default, PartialEq)]
struct Od(std::collections::BTreeMap<(u16, u8), Vec<u8>>);

impl ObjectDictionary for Od {
    fn read(&mut self, index: u16, sub: u8) -> Result<Vec<u8>, AbortCode> {
        self.0.get(&(index, sub)).cloned().ok_or(AbortCode::NO_OBJECT)
    }
    fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        match (index, sub) {
            (0x1000, _) => Err(AbortCode::READ_ONLY),
            (0x2000..=0x20FF, _) if data.len() <= SDO_MAX => {
                self.0.insert((index, sub), data.to_vec());
                Ok(())
            }
            _ => Err(AbortCode::NO_OBJECT),
        }
    }
}

/// The SDO client and server (CiA 301), both directions. The first byte chooses:
/// - even: the client against a hostile server: an upload or a download is started, then
///   every 8 bytes are a response frame. Every frame the client sends is an 8-byte request
///   to its node; a finished upload holds at most the buffer; a finished or failed
///   transfer leaves the client idle.
/// - odd: the server against a hostile client: every 8 bytes are a request frame. Every
///   answer is an 8-byte response from the node; an abort changes nothing in the object
///   dictionary (a refused input changes nothing).
///
/// Then, in both cases, a real client downloads the rest of the input (up to the buffer)
/// through the real server and uploads it again: the same bytes (decode of encode).
pub fn sdo(data: &[u8]) {
    const NODE: u8 = 3;
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let mut od = Od::default();
    od.0.insert((0x1000, 0), vec![0x92, 0x01, 0x02, 0x00]);
    od.0.insert((0x2000, 1), b"a segmented value, longer than four bytes".to_vec());
    if mode % 2 == 0 {
        let mut c = SdoClient::new(NODE);
        let first = if mode % 4 == 0 {
            Ok(c.upload(0x2000, 1))
        } else {
            c.download(0x2001, 0, &rest[..rest.len().min(SDO_MAX)])
        };
        if let Ok(f) = first {
            assert!(f.id == sdo_rx_id(NODE) && f.len == 8, "{f:?}");
        }
        for chunk in rest.chunks(8) {
            if !c.busy() {
                break;
            }
            match c.on_frame(&Frame::new(sdo_tx_id(NODE), chunk)) {
                Progress::Send(f) | Progress::Failed(_, Some(f)) => {
                    assert!(f.id == sdo_rx_id(NODE) && f.len == 8, "{f:?}")
                }
                Progress::Uploaded => assert!(c.data().len() <= SDO_MAX && !c.busy()),
                Progress::Downloaded => assert!(!c.busy()),
                Progress::Failed(_, None) | Progress::Ignored => {}
            }
            if let Progress::Failed(..) = c.on_frame(&Frame::new(0x123, &[])) {
                panic!("a frame of another id failed the transfer");
            }
        }
    } else {
        let mut server = SdoServer::new(NODE);
        for chunk in rest.chunks(8) {
            let before = od.clone();
            if let Some(answer) = server.on_request(&Frame::new(sdo_rx_id(NODE), chunk), &mut od) {
                assert!(answer.id == sdo_tx_id(NODE) && answer.len == 8, "{answer:?}");
                if answer.data[0] == 0x80 {
                    assert_eq!(od, before, "an aborted request changed the object dictionary");
                }
            }
        }
    }
    // The round trip through the real pair.
    let value = &rest[..rest.len().min(SDO_MAX)];
    let mut server = SdoServer::new(NODE);
    let mut client = SdoClient::new(NODE);
    let exchange = |client: &mut SdoClient, server: &mut SdoServer, od: &mut Od, first: Frame| {
        let mut req = first;
        for _ in 0..200 {
            let Some(answer) = server.on_request(&req, od) else {
                panic!("the server did not answer {req:?}");
            };
            match client.on_frame(&answer) {
                Progress::Send(f) => req = f,
                Progress::Uploaded | Progress::Downloaded => return,
                other => panic!("the round trip failed: {other:?}"),
            }
        }
        panic!("the round trip did not end in 200 frames");
    };
    if let Ok(first) = client.download(0x20FF, 7, value) {
        exchange(&mut client, &mut server, &mut od, first);
        let first = client.upload(0x20FF, 7);
        exchange(&mut client, &mut server, &mut od, first);
        assert_eq!(client.data(), value, "upload of a download is not the same bytes");
    } else {
        assert!(value.is_empty(), "a download of {} bytes refused", value.len());
    }
}

/// The command decoding of `hob-rt` (`hob_service::commands::to_mail`): arbitrary bytes as
/// a `CommandRequest`, its length fields included. A decoded command encodes to the
/// arguments it was decoded from and decodes again to itself (decode of encode is the
/// identity); a refusal says why; and a command the control core refuses changes nothing
/// in it (its status before and after are equal).
pub fn command(data: &[u8]) {
    let mut b = [0u8; 32];
    b[..data.len().min(32)].copy_from_slice(&data[..data.len().min(32)]);
    let mut req = CommandRequest::new(u32::from_le_bytes([b[0], b[1], b[2], b[3]]) % 32);
    req.single = b[4];
    req.axis = b[5] % 6;
    req.direction = b[6] % 4;
    req.value = f64::from_le_bytes([b[8], b[9], b[10], b[11], b[12], b[13], b[14], b[15]]);
    req.name_len = u32::from_le_bytes([b[16], b[17], b[18], b[19]]);
    req.text_len = u32::from_le_bytes([b[20], b[21], b[22], b[23]]);
    req.program_hash = u64::from_le_bytes([b[24], b[25], b[26], b[27], b[28], b[29], b[30], b[31]]);
    let text = data.get(32..).unwrap_or_default();
    let n = text.len().min(req.text.len());
    req.text[..n].copy_from_slice(&text[..n]);
    let _ = (req.name(), req.text());
    match to_mail(&req, shipped()) {
        Err(why) => assert!(!why.is_empty()),
        Ok(Mail::Load(p, _)) => assert!(!p.passes().is_empty()),
        Ok(Mail::Record) => assert_eq!(req.command, hob_ipc::command::FLIGHT_RECORD),
        // Only START and CONTINUE name a program; the loop checks it before the core.
        Ok(Mail::CommandFor(c, hash)) => {
            assert!(matches!(c, Command::Start { .. } | Command::Continue), "{c:?}");
            assert_ne!(hash, 0);
        }
        Ok(Mail::Command(c)) => {
            let args = encode::command_code(c);
            let again =
                encode::command_from_code(&args).expect("a decoded command encodes to a decodable one");
            assert_eq!(
                format!("{again:?}"),
                format!("{c:?}"),
                "decode of encode is not the identity"
            );
            let mut controller = Controller::new(ControlParams::from_machine(shipped()));
            let before = controller.status();
            if controller.command(c).is_err() {
                let after = controller.status();
                assert_eq!(
                    format!("{after:?}"),
                    format!("{before:?}"),
                    "a refused {c:?} changed the control core"
                );
            }
        }
    }
}

/// The logger's file reader (`hob log export|report`, the HMI's report): arbitrary bytes as
/// a state file and as `events.log` lines. A file is read or refused with a reason; every
/// record read encodes to bytes that read back to the same record; every event line
/// parsed keeps its numbers when written back in the same form.
pub fn log(data: &[u8]) {
    let mut records = Vec::new();
    match states_in_file(data, "fuzz.hoblog", &mut |s| records.push(s)) {
        Err(why) => assert!(why.starts_with("fuzz.hoblog: "), "{why}"),
        Ok(()) => {
            for s in &records {
                let mut once = Vec::new();
                encode_state(s, &mut once);
                let back = decode_state(&once).expect("an encoded record decodes");
                let mut twice = Vec::new();
                encode_state(&back, &mut twice);
                assert_eq!(once, twice, "decode of encode is not the identity");
            }
        }
    }
    for line in String::from_utf8_lossy(data).lines() {
        if let Some(e) = parse_event_line(line) {
            let args = e.args.map_or(String::new(), |(a, b)| format!("#{a}/{b}"));
            let kind = match e.alarm {
                Some(a) => format!(
                    "{}{args}@{}/{}/{}/{}/{}",
                    e.kind, a.code, a.axis, a.end, a.value_a, a.value_b
                ),
                None => format!("{}{args}", e.kind),
            };
            let again =
                parse_event_line(&format!("{} {} {kind} {}", e.seq, e.cycle, e.text)).expect("written back");
            assert_eq!(
                (again.seq, again.cycle, again.kind, again.alarm, again.args),
                (e.seq, e.cycle, e.kind, e.alarm, e.args)
            );
        }
    }
}

/// The HMI's request decoding: a WebSocket message from the page (`ClientMsg`, JSON) and
/// its command (`Op::request`, the CLI's builders). A command the HMI builds is one the
/// loop decodes (`to_mail` accepts it): the HMI cannot send what the loop cannot read.
pub fn hmi(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(msg) = serde_json::from_str::<ClientMsg>(text) else {
        return;
    };
    if let ClientMsg::Cmd { op, .. } = msg {
        match op.request() {
            Err(why) => assert!(!why.to_string().is_empty()),
            Ok(req) => {
                if let Err(why) = to_mail(&req, shipped()) {
                    panic!("the HMI built {op:?} that the loop refuses to decode: {why}");
                }
            }
        }
    }
}

/// The gateway's frames (`hob_ipc::gateway`): what `hob-gateway` reads from a user who is
/// not the bus's, and what a frontend reads back. Any bytes are a whole message, "not all
/// there yet" (only when the length says more than there is), or a refusal with a reason,
/// never a panic; a decoded message encodes, and the decode of that encode is the identity
/// (compared as bytes: a NaN in a request is not equal to itself); a request that gets
/// through is one the loop's own decode answers (accepts, or refuses with a reason).
pub fn gateway(data: &[u8]) {
    use hob_ipc::gateway::{FromGateway, ToGateway, decode, encode};
    fn check<T>(data: &[u8]) -> Option<T>
    where
        T: serde::Serialize + for<'de> serde::Deserialize<'de>,
    {
        match decode::<T>(data) {
            Err(why) => {
                assert!(!why.to_string().is_empty());
                None
            }
            Ok(None) => {
                if let Some(len) = data.get(..4) {
                    let len = u32::from_le_bytes([len[0], len[1], len[2], len[3]]) as usize;
                    assert!(4 + len > data.len(), "a whole frame of {len} bytes not decoded");
                }
                None
            }
            Ok(Some((msg, used))) => {
                assert!((4..=data.len()).contains(&used));
                let bytes = encode(&msg).expect("a decoded message encodes");
                let (again, n) = decode::<T>(&bytes)
                    .expect("an encoded message decodes")
                    .expect("an encoded message is whole");
                assert_eq!(n, bytes.len());
                assert_eq!(
                    encode(&again).expect("encodes"),
                    bytes,
                    "decode of encode is not the identity"
                );
                Some(msg)
            }
        }
    }
    if let Some(ToGateway::Request(req)) = check::<ToGateway>(data)
        && let Err(why) = to_mail(&req, shipped())
    {
        assert!(!why.is_empty());
    }
    let _ = check::<FromGateway>(data);
}
