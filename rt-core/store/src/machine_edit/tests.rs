use super::*;

const SHIPPED_COMMISSIONED: &str = include_str!("../../../../config/machine.toml");

/// The shipped file without its commissioning record: its delay may be set by hand.
static SHIPPED: std::sync::LazyLock<String> =
    std::sync::LazyLock::new(|| replace_table(SHIPPED_COMMISSIONED, "commissioning.drive_delay", ""));

fn shipped_path() -> &'static Path {
    Path::new("config/machine.toml")
}

#[test]
fn a_value_is_replaced_and_its_comment_and_every_other_line_kept() {
    let new = set_value(&SHIPPED, "control", "drive_delay_us", "1130").unwrap();
    let d = diff(&SHIPPED, &new);
    assert_eq!(d.lines().count(), 2, "{d}");
    assert!(d.contains("-  13  drive_delay_us = 1000           # CSP"), "{d}");
    assert!(d.contains("+  13  drive_delay_us = 1130           # CSP"), "{d}");
    let m = check(shipped_path(), &new).unwrap();
    assert_eq!(m.control.drive_delay_us, 1130);
}

#[test]
fn a_key_of_the_same_name_in_another_table_or_a_longer_name_is_left_alone() {
    let text = "[a]\nk_us = 1 # one\nk = 2\n[b]\nk = 3\n";
    let new = set_value(text, "b", "k", "4").unwrap();
    assert_eq!(new, "[a]\nk_us = 1 # one\nk = 2\n[b]\nk = 4\n");
    let new = set_value(text, "a", "k", "5").unwrap();
    assert_eq!(new, "[a]\nk_us = 1 # one\nk = 5\n[b]\nk = 3\n");
    assert!(matches!(
        set_value(text, "c", "k", "1"),
        Err(EditError::KeyNotFound { .. })
    ));
    // A `#` inside a string is not a comment.
    let text = "[a]\nname = \"x # y\"   # the name\n";
    assert_eq!(
        set_value(text, "a", "name", "\"z\"").unwrap(),
        "[a]\nname = \"z\"       # the name\n"
    );
}

#[test]
fn a_table_is_appended_once_and_then_replaced_in_place() {
    let block = "[commissioning.drive_delay]\nutc = 2026-11-28T23:10:05Z\nfound_us = 1128.6\nresidual_arcsec = 0.4\nsamples = 3998\ntable_drive_vendor_id = 0x00000B0B\ntable_drive_product_code = 0x00020192\ntable_drive_serial = 0x00001002\n";
    let text = set_value(&SHIPPED, "control", "drive_delay_us", "1129").unwrap();
    let once = replace_table(&text, "commissioning.drive_delay", block);
    assert!(once.ends_with(&format!("\n\n{block}")), "{once}");
    let m = check(shipped_path(), &once).unwrap();
    let rec = m.commissioning.unwrap().drive_delay.unwrap();
    assert_eq!(rec.found_us, 1128.6);
    assert_eq!(rec.samples, 3998);
    let block2 = block.replace("1128.6", "1127.0");
    let twice = replace_table(&once, "commissioning.drive_delay", &block2);
    assert_eq!(twice.matches("[commissioning.drive_delay]").count(), 1);
    assert_eq!(diff(&once, &twice).lines().count(), 2);
}

#[test]
fn a_hand_edit_that_parts_from_the_measured_delay_is_refused_by_its_key() {
    let block = "[commissioning.drive_delay]\nutc = 2026-11-28T23:10:05Z\nfound_us = 1128.6\nresidual_arcsec = 0.4\nsamples = 3998\ntable_drive_vendor_id = 0x00000B0B\ntable_drive_product_code = 0x00020192\ntable_drive_serial = 0x00001002\n";
    // The record without the value it measured: 1000 us in [control].
    let text = replace_table(&SHIPPED, "commissioning.drive_delay", block);
    let e = check(shipped_path(), &text).unwrap_err().to_string();
    assert!(e.contains("control.drive_delay_us"), "{e}");
    assert!(e.contains("1128.6"), "{e}");
    // A date without a time or zone is not a record of when.
    let text = set_value(&text, "control", "drive_delay_us", "1129").unwrap();
    let bad = text.replace("2026-11-28T23:10:05Z", "2026-11-28");
    let e = check(shipped_path(), &bad).unwrap_err().to_string();
    assert!(e.contains("commissioning.drive_delay.utc"), "{e}");
    assert!(check(shipped_path(), &text).is_ok());
}

#[test]
fn commit_keeps_the_old_file_and_refuses_an_invalid_or_changed_one() {
    let dir = crate::test_dir("machine-edit");
    let file = dir.join("machine.toml");
    std::fs::write(&file, &*SHIPPED).unwrap();
    // Invalid: refused, nothing written, nothing kept.
    let bad = set_value(&SHIPPED, "control", "drive_delay_us", "99999").unwrap();
    let e = commit(&file, &SHIPPED, &bad, "20261128T231005Z").unwrap_err();
    assert!(e.to_string().contains("control.drive_delay_us"), "{e}");
    assert_eq!(std::fs::read_to_string(&file).unwrap(), *SHIPPED);
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
    // Changed on disk since it was read: refused.
    let good = set_value(&SHIPPED, "control", "drive_delay_us", "1130").unwrap();
    let e = commit(&file, "something else", &good, "20261128T231005Z").unwrap_err();
    assert!(matches!(e, EditError::ChangedMeanwhile { .. }), "{e}");
    assert_eq!(std::fs::read_to_string(&file).unwrap(), *SHIPPED);
    // Written, the old one kept; a second commit in the same second does not overwrite it.
    let kept = commit(&file, &SHIPPED, &good, "20261128T231005Z").unwrap();
    assert_eq!(kept, dir.join("machine.toml.20261128T231005Z.bak"));
    assert_eq!(std::fs::read_to_string(&kept).unwrap(), *SHIPPED);
    assert_eq!(std::fs::read_to_string(&file).unwrap(), good);
    let again = set_value(&good, "control", "drive_delay_us", "1131").unwrap();
    assert!(commit(&file, &good, &again, "20261128T231005Z").is_err());
    assert_eq!(std::fs::read_to_string(&file).unwrap(), good);
    assert_eq!(file_stamp("2026-11-28T23:10:05Z"), "20261128T231005Z");
}

#[test]
fn the_shipped_record_comes_out_whole_and_alone() {
    assert!(SHIPPED_COMMISSIONED.contains("[commissioning.drive_delay]"));
    assert!(
        !SHIPPED.contains("[commissioning"),
        "{}",
        &SHIPPED[SHIPPED.len() - 300..]
    );
    let m = check(shipped_path(), &SHIPPED).unwrap();
    assert!(m.commissioning.is_none());
}
