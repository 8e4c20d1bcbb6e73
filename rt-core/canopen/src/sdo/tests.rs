use super::*;
use proptest::prelude::*;
use std::collections::HashMap;

#[derive(Default)]
struct Od(HashMap<(u16, u8), Vec<u8>>);

impl ObjectDictionary for Od {
    fn read(&mut self, index: u16, sub: u8) -> Result<Vec<u8>, AbortCode> {
        self.0.get(&(index, sub)).cloned().ok_or(AbortCode::NO_OBJECT)
    }
    fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        if index == 0x1000 {
            return Err(AbortCode::READ_ONLY);
        }
        self.0.insert((index, sub), data.to_vec());
        Ok(())
    }
}

fn hex(f: &Frame) -> String {
    f.to_candump()
}

#[test]
fn expedited_download_layouts() {
    // CiA 301 7.2.4.3.3: ccs = 1, n = unused bytes, e = 1, s = 1.
    let mut c = SdoClient::new(3);
    assert_eq!(
        hex(&c.download(0x6081, 0, &0x1234_5678u32.to_le_bytes()).unwrap()),
        "603#2381600078563412"
    );
    assert_eq!(hex(&c.download(0x6060, 0, &[8]).unwrap()), "603#2F60600008000000");
    assert_eq!(
        hex(&c.download(0x6040, 0, &0x000Fu16.to_le_bytes()).unwrap()),
        "603#2B4060000F000000"
    );
    assert_eq!(
        hex(&c.download(0x1017, 0, &[0x64, 0, 0]).unwrap()),
        "603#2717100064000000"
    );
}

#[test]
fn upload_layouts() {
    let mut c = SdoClient::new(2);
    assert_eq!(hex(&c.upload(0x1000, 0)), "602#4000100000000000");
    // Expedited response with size: scs = 2, n = 0, e = 1, s = 1.
    let r = Frame::from_candump("582#4300100092010200").unwrap();
    assert_eq!(c.on_frame(&r), Progress::Uploaded);
    assert_eq!(c.data(), &0x0002_0192u32.to_le_bytes());
}

#[test]
fn segmented_upload_layouts() {
    let mut od = Od::default();
    od.0.insert((0x1008, 0), b"hob-sim drive".to_vec());
    let mut s = SdoServer::new(2);
    let mut c = SdoClient::new(2);
    let req = c.upload(0x1008, 0);
    let r1 = s.on_request(&req, &mut od).unwrap();
    assert_eq!(hex(&r1), "582#410810000D000000", "initiate: segmented, 13 bytes");
    let Progress::Send(seg1) = c.on_frame(&r1) else {
        panic!()
    };
    assert_eq!(hex(&seg1), "602#6000000000000000", "segment request, toggle 0");
    let r2 = s.on_request(&seg1, &mut od).unwrap();
    assert_eq!(hex(&r2), "582#00686F622D73696D", "7 bytes, toggle 0, more");
    let Progress::Send(seg2) = c.on_frame(&r2) else {
        panic!()
    };
    assert_eq!(hex(&seg2), "602#7000000000000000", "toggle 1");
    let r3 = s.on_request(&seg2, &mut od).unwrap();
    assert_eq!(
        hex(&r3),
        "582#1320647269766500",
        "6 bytes: n = 1, toggle 1, last; SDO frames are always 8 bytes"
    );
    assert_eq!(c.on_frame(&r3), Progress::Uploaded);
    assert_eq!(c.data(), b"hob-sim drive");
}

#[test]
fn segmented_download_layouts() {
    let mut od = Od::default();
    let mut s = SdoServer::new(4);
    let mut c = SdoClient::new(4);
    let data = b"0123456789";
    let init = c.download(0x2000, 1, data).unwrap();
    assert_eq!(hex(&init), "604#210020010A000000");
    let r = s.on_request(&init, &mut od).unwrap();
    assert_eq!(hex(&r), "584#6000200100000000");
    let Progress::Send(seg) = c.on_frame(&r) else {
        panic!()
    };
    assert_eq!(hex(&seg), "604#0030313233343536");
    let r = s.on_request(&seg, &mut od).unwrap();
    assert_eq!(hex(&r), "584#2000000000000000");
    let Progress::Send(seg) = c.on_frame(&r) else {
        panic!()
    };
    assert_eq!(
        hex(&seg),
        "604#1937383900000000",
        "3 bytes: n = 4, toggle 1, last"
    );
    let r = s.on_request(&seg, &mut od).unwrap();
    assert_eq!(hex(&r), "584#3000000000000000");
    assert_eq!(c.on_frame(&r), Progress::Downloaded);
    assert_eq!(od.0[&(0x2000, 1)], data);
}

#[test]
fn aborts_carry_the_code_both_ways() {
    let mut od = Od::default();
    let mut s = SdoServer::new(2);
    let mut c = SdoClient::new(2);
    let r = s.on_request(&c.upload(0x1234, 5), &mut od).unwrap();
    assert_eq!(hex(&r), "582#8034120500000206");
    let Progress::Failed(e, None) = c.on_frame(&r) else {
        panic!()
    };
    assert_eq!(
        e.to_string(),
        "SDO 1234:05 aborted: 0x06020000 object does not exist in the object dictionary"
    );
    let r = s
        .on_request(&c.download(0x1000, 0, &[1, 2, 3, 4]).unwrap(), &mut od)
        .unwrap();
    let Progress::Failed(SdoError::Aborted { code, .. }, None) = c.on_frame(&r) else {
        panic!()
    };
    assert_eq!(code, AbortCode::READ_ONLY);
    assert_eq!(code.text(), "attempt to write a read-only object");
    // A client timeout aborts with 0x05040000.
    c.upload(0x1000, 0);
    assert_eq!(hex(&c.abort(AbortCode::TIMEOUT)), "602#8000100000000405");
    assert!(!c.busy());
}

#[test]
fn a_wrong_toggle_is_aborted() {
    let mut od = Od::default();
    od.0.insert((0x1008, 0), b"0123456789".to_vec());
    let mut s = SdoServer::new(2);
    let mut c = SdoClient::new(2);
    let r = s.on_request(&c.upload(0x1008, 0), &mut od).unwrap();
    assert!(matches!(c.on_frame(&r), Progress::Send(_)));
    // The server answers with toggle 1 where 0 is due.
    let bad = Frame::new(0x582, &[0x10, b'0', b'1', b'2', b'3', b'4', b'5', b'6']);
    let Progress::Failed(SdoError::Protocol { .. }, Some(abort)) = c.on_frame(&bad) else {
        panic!()
    };
    assert_eq!(
        u32::from_le_bytes([abort.data[4], abort.data[5], abort.data[6], abort.data[7]]),
        0x0503_0000
    );
}

#[test]
fn frames_for_other_nodes_are_ignored() {
    let mut c = SdoClient::new(2);
    c.upload(0x1000, 0);
    assert_eq!(
        c.on_frame(&Frame::new(0x583, &[0x43, 0, 0x10, 0, 1, 2, 3, 4])),
        Progress::Ignored
    );
    assert_eq!(
        SdoServer::new(2).on_request(&Frame::new(0x603, &[0x40; 8]), &mut Od::default()),
        None
    );
}

proptest! {
    #[test]
    fn any_object_round_trips(data in proptest::collection::vec(any::<u8>(), 0..=SDO_MAX)) {
        let mut od = Od::default();
        let mut s = SdoServer::new(7);
        let mut c = SdoClient::new(7);
        let mut f = c.download(0x2100, 3, &data).unwrap();
        loop {
            let r = s.on_request(&f, &mut od).unwrap();
            match c.on_frame(&r) {
                Progress::Send(next) => f = next,
                Progress::Downloaded => break,
                other => prop_assert!(false, "{other:?}"),
            }
        }
        let mut f = c.upload(0x2100, 3);
        loop {
            let r = s.on_request(&f, &mut od).unwrap();
            match c.on_frame(&r) {
                Progress::Send(next) => f = next,
                Progress::Uploaded => break,
                other => prop_assert!(false, "{other:?}"),
            }
        }
        // Zero bytes upload as an expedited transfer of size 0 = 4 bytes unsized; the
        // server answers 0 bytes as "n = 4": the client reads 0 bytes.
        prop_assert_eq!(c.data(), &data[..]);
    }
}

#[test]
fn a_request_not_sent_names_the_object_and_the_bus_reason() {
    let e = SdoError::Send {
        index: 0x6040,
        sub: 0,
        error: crate::bus::BusError::Full,
    };
    assert_eq!(
        e.to_string(),
        "SDO 6040:00: request not sent: transmit queue full"
    );
}
