//! The German catalogue (`lang/de.po`) against everything the panel can show: every text
//! the loop's vocabulary produces (states, refusals, every alarm in every situation with
//! what the machine did, the remedy and how to continue, the homing failures, the events,
//! the bus and drive states, the EMCY meanings, the user levels) and every label the page
//! writes with `t("...")` in `web/js/*.mjs`. A text the catalogue lacks fails the test with
//! the missing entries printed as PO, ready to translate.
#![allow(clippy::unwrap_used)]

use hob_hmi::words::{Catalogue, DE_PO};
use hob_ipc::codec::{self, Axis, Fault, HomingFailure, Refusal, State};
use hob_ipc::gateway::{Action, Role};
use hob_ipc::{AlarmCode, EventSample, event_kind};
use std::collections::BTreeSet;
use std::path::Path;

fn alarms() -> Vec<AlarmCode> {
    let mut all = Vec::new();
    for code in Fault::ALL.map(Fault::code) {
        for axis in 0..=3u8 {
            for end in 0..=4u8 {
                for situation in 0..=3u8 {
                    let a = AlarmCode {
                        code,
                        axis,
                        end,
                        situation,
                        value_a: 12.5,
                        value_b: 3.25,
                        ..AlarmCode::default()
                    };
                    if Fault::of(&a).and_then(|f| f.text(&a)).is_some() {
                        all.push(a);
                    }
                }
            }
        }
    }
    all
}

/// Every text of the vocabulary the panel can show.
fn vocabulary() -> BTreeSet<String> {
    let mut t = BTreeSet::new();
    let mut add = |s: &str| {
        if !s.is_empty() {
            t.insert(s.to_string());
        }
    };
    for s in State::ALL {
        add(s.words());
    }
    for r in Refusal::ALL {
        add(r.text());
    }
    for h in HomingFailure::ALL {
        add(h.text());
    }
    for a in alarms() {
        let f = Fault::of(&a).unwrap();
        add(&codec::alarm_text(&a));
        add(f.reaction(&a));
        add(f.remedy());
        add(f.how_to_continue());
        for emcy in [0x2310u16, 0x4210, 0x7303] {
            let mut last = [0u16; 4];
            last[usize::from(a.axis.saturating_sub(1)).min(3)] = emcy;
            if let Some(w) = codec::drive_reported(&a, &last) {
                add(&w);
            }
        }
    }
    for code in [
        0x1000u16, 0x2310, 0x2320, 0x3210, 0x3220, 0x4210, 0x5441, 0x6010, 0x7303, 0x7305, 0x8110, 0x8120,
        0x8130, 0x8140, 0x8210, 0x8611, 0xFF01, 0x9000,
    ] {
        add(&codec::emcy_words(code).unwrap());
    }
    for nmt in [0u8, 4, 5, 0x7F, 0x33, hob_ipc::NMT_NOT_HEARD] {
        add(codec::nmt_state_name(nmt));
    }
    for sw in [0x0000u16, 0x0040, 0x0021, 0x0023, 0x0027, 0x0007, 0x000F, 0x0008] {
        add(codec::cia402_state_name(sw));
    }
    for a in Action::ALL {
        add(a.words());
        for r in Role::ALL {
            if !r.allows(a) {
                let needs = Role::ALL.into_iter().find(|n| n.allows(a)).unwrap();
                let article = if needs == Role::Operate { "an" } else { "a" };
                add(&format!(
                    "this panel is at the {} level, which may not {}: {article} {}'s work",
                    r.level(),
                    a.words(),
                    needs.level()
                ));
            }
        }
    }
    for r in Role::ALL {
        add(r.level());
    }
    for e in events() {
        add(&codec::event_text(&e));
    }
    t
}

fn events() -> Vec<EventSample> {
    let mut all = Vec::new();
    let ev = |kind, a, b, value| EventSample {
        kind,
        a,
        b,
        value,
        ..EventSample::default()
    };
    for a in alarms() {
        all.push(EventSample {
            kind: event_kind::ALARM,
            alarm: a,
            ..EventSample::default()
        });
    }
    for s in State::ALL {
        all.push(ev(event_kind::STATE_CHANGED, State::Idle.code(), s.code(), 0.0));
    }
    for c in codec::COMMANDS {
        all.push(ev(event_kind::ACCEPTED, c, 0, 0.0));
        for r in Refusal::ALL {
            all.push(ev(event_kind::REFUSED, c, r.code(), 0.0));
        }
    }
    for k in [
        event_kind::ALARM_CLEARED,
        event_kind::PASS_STARTED,
        event_kind::PHASE_RECORDED,
        event_kind::PROGRAM_LOADED,
        event_kind::CYCLE_DONE,
        event_kind::PHASE_ALIGNED,
    ] {
        all.push(ev(k, 2, 0, 1.25));
    }
    for axis in [Axis::X, Axis::Y] {
        let a = u32::from(axis.code());
        all.push(ev(event_kind::REFERENCED, a, 0, 0.0));
        all.push(ev(event_kind::OFFSET_CHANGED, a, 0, -0.005));
        all.push(ev(event_kind::DEAD_MAN_STOP, a, 0, 0.0));
    }
    all.push(ev(event_kind::DEAD_MAN_STOP, 0, 0, 0.0));
    for dir in [0u32, 1, 2] {
        all.push(ev(event_kind::FLANK_TOUCHED, dir, 0, 3.5));
    }
    use hob_ipc::bus_event;
    for (b, a, v) in [
        (bus_event::EMCY, 4, f64::from(0x2310)),
        (bus_event::HEARTBEAT_LOST, 3, 0.0),
        (bus_event::TPDO_MISSING, 4 | (3 << 8), 1.0),
        (bus_event::TPDO_MISSING, 4 | (3 << 8), 17.0),
        (bus_event::SEND_FAILED, hob_ipc::send_error::QUEUE_FULL, 0.0),
        (bus_event::SEND_FAILED, hob_ipc::send_error::INTERFACE_DOWN, 0.0),
    ] {
        all.push(ev(event_kind::BUS, a, b, v));
    }
    all
}

/// The labels the page translates: every `t("...")` literal in its scripts.
fn page_labels() -> BTreeSet<String> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("web/js");
    let mut out = BTreeSet::new();
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "mjs") {
            continue;
        }
        let src = std::fs::read_to_string(&path).unwrap();
        let mut rest = src.as_str();
        while let Some(i) = rest.find("t(\"") {
            // Only the call `t(`, not `sort(` or `get(`.
            let before = rest[..i].chars().next_back();
            rest = &rest[i + 3..];
            if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == '.') {
                continue;
            }
            let mut lit = String::new();
            let mut chars = rest.char_indices();
            let mut end = rest.len();
            while let Some((k, c)) = chars.next() {
                match c {
                    '\\' => {
                        if let Some((_, e)) = chars.next() {
                            lit.push(e);
                        }
                    }
                    '"' => {
                        end = k;
                        break;
                    }
                    c => lit.push(c),
                }
            }
            rest = &rest[end..];
            out.insert(lit);
        }
    }
    out
}

fn po_entry(s: &str) -> String {
    let q = s.replace('\\', "\\\\").replace('"', "\\\"").replace('\n', "\\n");
    format!("msgid \"{q}\"\nmsgstr \"\"\n")
}

fn missing_from(c: &Catalogue, texts: &BTreeSet<String>) -> Vec<String> {
    texts
        .iter()
        // A sentence translated is another sentence; a short word may read the same.
        .filter(|s| c.get(s).is_none_or(|d| d == **s && s.len() > 12))
        .cloned()
        .collect()
}

#[test]
fn every_text_of_the_vocabulary_has_its_german() {
    let de = Catalogue::from_po(DE_PO).unwrap();
    let texts = vocabulary();
    assert!(texts.len() > 200, "{} texts", texts.len());
    let missing = missing_from(&de, &texts);
    assert!(
        missing.is_empty(),
        "{} of {} texts have no German in lang/de.po:\n\n{}",
        missing.len(),
        texts.len(),
        missing.iter().map(|s| po_entry(s)).collect::<Vec<_>>().join("\n")
    );
}

#[test]
fn every_label_of_the_page_has_its_german() {
    let de = Catalogue::from_po(DE_PO).unwrap();
    let page = de.page();
    let labels = page_labels();
    assert!(
        labels.len() > 100,
        "{} labels found: is the page written with t(...)?",
        labels.len()
    );
    let missing: Vec<_> = labels.iter().filter(|s| !page.contains_key(s.as_str())).collect();
    assert!(
        missing.is_empty(),
        "{} of {} page labels have no German in lang/de.po:\n\n{}",
        missing.len(),
        labels.len(),
        missing.iter().map(|s| po_entry(s)).collect::<Vec<_>>().join("\n")
    );
}

#[test]
fn composed_texts_translate_in_their_parts() {
    let de = Catalogue::from_po(DE_PO).unwrap();
    // A lost node in an older recording: every case, and the watchdog's part.
    let a = AlarmCode {
        code: Fault::FeedbackLost.code(),
        axis: Axis::Y.code(),
        ..AlarmCode::default()
    };
    let r = de.tr(Fault::FeedbackLost.reaction(&a));
    assert!(
        r.starts_with("im Zyklus konnte X") || r.starts_with("im Schnitt"),
        "{r}"
    );
    assert!(
        r.contains("außerhalb eines Zyklus") && r.contains("Watchdog"),
        "{r}"
    );
    // The loop's answer to the typo (rt-core/service's refusal_text), as sent.
    let typo = "touch-off refused: this touch-off does not fit what the machine knows (the loaded blank, the previous offset, where the hob stands): check the gauge's value and the hob's position, and confirm the new offset only if both are right; nothing was changed.\nConfirmed, it sets the X offset -0.0050 mm -> +49.9950 mm (change +50.0000 mm).\nWhy: the gauge, 194.940 mm, is 99.940 mm larger than the loaded blank's outside diameter, 95.000 mm; the offset would move by +50.0000 mm, more than the 0.500 mm a touch-off may move it unasked";
    let d = de.tr(&format!("{typo}."));
    assert_eq!(
        d,
        "touch-off abgelehnt: dieses Antasten passt nicht zu dem, was die Maschine weiß (geladener Rohling, bisherige Verschiebung, Stand des Fräsers): Maßwert und Fräserposition prüfen und die neue Verschiebung nur bestätigen, wenn beide stimmen; nichts wurde geändert.\nBestätigt, setzt es die Verschiebung X -0.0050 mm -> +49.9950 mm (Änderung +50.0000 mm).\nGrund: das Maß, 194.940 mm, ist 99.940 mm größer als der Außendurchmesser des geladenen Rohlings, 95.000 mm; die Verschiebung würde sich um +50.0000 mm ändern, mehr als die 0.500 mm, die ein Antasten ohne Rückfrage ändern darf."
    );
}
