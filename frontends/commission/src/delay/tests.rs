use super::*;

const SHIPPED: &str = include_str!("../../../../config/machine.toml");

/// A jog recorded as the loop publishes it: the command at `speed` from cycle `start` on
/// (one way for `n` cycles, then at rest, then the other way), the drive following it
/// `delay_s` after the cycle that computed it (linear between cycles), `lost` cycles missing.
fn jogs(delay_s: f64, speed_deg_s: f64, n: usize, lost: &[u64]) -> Vec<StateSample> {
    let period_s = 1e-3;
    let mut command = Vec::new();
    let mut c = 10.0;
    for (dir, len) in [(0.0, 200), (1.0, n), (0.0, 600), (-1.0, n), (0.0, 600)] {
        for _ in 0..len {
            c += dir * speed_deg_s * period_s;
            command.push((c, dir != 0.0));
        }
    }
    let at = |t: f64| {
        let i = t / period_s;
        if i <= 0.0 {
            return command[0].0;
        }
        let k = (i.floor() as usize).min(command.len() - 2);
        let f = i - k as f64;
        command[k].0 * (1.0 - f) + command[k + 1].0 * f
    };
    (0..command.len())
        .filter(|k| !lost.contains(&(*k as u64)))
        .map(|k| {
            let mut s = StateSample {
                cycle: 5000 + k as u64,
                ..Default::default()
            };
            s.table_deg.command = command[k].0;
            s.table_deg.actual = at(k as f64 * period_s - delay_s);
            s.moving_axis = if command[k].1 { codec::Axis::B.code() } else { 0 };
            s
        })
        .collect()
}

#[test]
fn the_delay_of_a_table_that_follows_its_command_late_is_found_from_both_jogs() {
    for hidden_us in [860.0, 1000.0, 1130.0, 1250.0] {
        // One cycle to the SYNC that applies the command, then the drive's delay.
        let states = jogs((1000.0 + hidden_us) * 1e-6, 4.0, 3000, &[2400, 2401, 2402]);
        let m = measure(&states, 1e-3, 1e-3).unwrap();
        let found_us = m.delay.drive_delay_s * 1e6;
        assert!(
            (found_us - hidden_us).abs() < 2.0,
            "{hidden_us} hidden, {found_us} found"
        );
        // 3 s each way less the second of settling; the lost cycles only not counted.
        assert_eq!((m.steady_positive, m.steady_negative), (1997, 2000), "{m:?}");
    }
}

#[test]
fn too_short_a_jog_or_a_table_that_does_not_follow_is_not_a_measurement() {
    let e = measure(&jogs(2e-3, 4.0, 1500, &[]), 1e-3, 1e-3).unwrap_err();
    assert!(format!("{e:?}").contains("too little steady jog"), "{e:?}");
    // A table whose position wanders off its command by a sine of its angle (a mechanism's
    // error, not a delay): the fit does not hold and nothing is proposed.
    let mut states = jogs(2e-3, 4.0, 3000, &[]);
    for s in &mut states {
        s.table_deg.actual += 0.01 * (s.table_deg.actual * 2.0).to_radians().sin() * 30.0;
    }
    let e = measure(&states, 1e-3, 1e-3).unwrap_err();
    assert!(format!("{e:?}").contains("does not follow its command"), "{e:?}");
}

#[test]
fn the_proposal_sets_the_delay_and_its_record_and_loads_as_hob_rt_loads_it() {
    let states = jogs(2.13e-3, 4.0, 3000, &[]);
    let m = measure(&states, 1e-3, 1e-3).unwrap();
    let new = proposal(
        SHIPPED,
        &m.delay,
        "2026-11-28T23:10:05Z",
        (0xB0B, 0x20192, 0x1002),
    )
    .unwrap();
    let path = Path::new("config/machine.toml");
    let machine = machine_edit::check(path, &new).unwrap();
    assert_eq!(machine.control.drive_delay_us, 1130);
    let rec = machine.commissioning.unwrap().drive_delay.unwrap();
    assert!((rec.found_us - 1130.0).abs() < 2.0, "{rec:?}");
    assert_eq!(rec.utc.to_string(), "2026-11-28T23:10:05Z");
    assert!(rec.is_of(0xB0B, 0x20192, 0x1002));
    // Commissioned again: the record replaced, not repeated.
    let again = proposal(&new, &m.delay, "2026-11-29T08:00:00Z", (0xB0B, 0x20192, 0x1002)).unwrap();
    assert_eq!(again.matches("[commissioning.drive_delay]").count(), 1);
    assert_eq!(again.matches("Written by `hob commission delay`").count(), 1);
    assert_eq!(machine_edit::diff(&new, &again).lines().count(), 2);
}

#[test]
fn settings_outside_their_limits_are_refused_before_anything_moves() {
    for (speed, seconds) in [
        (0.0, 3.0),
        (f64::NAN, 3.0),
        (5000.0, 3.0),
        (240.0, 1.0),
        (240.0, 100.0),
    ] {
        let o = DelayOptions {
            speed_deg_min: speed,
            seconds,
        };
        assert!(
            matches!(check_options(&o), Err(Stop::Refused(_))),
            "{speed} {seconds}"
        );
    }
}

#[test]
fn the_table_drive_is_read_from_the_nodes_answer() {
    let text =
        "B 2 0x00000B0B 0x00020192 0x00010000 0x00001002\nX 3 0x00000B0B 0x00020192 0x00010000 0x00001003\n";
    assert_eq!(hob_ipc::nodes::table_drive(text), Some((0xB0B, 0x20192, 0x1002)));
    assert_eq!(hob_ipc::nodes::table_drive("X 3 0x1 0x2 0x3 0x4\n"), None);
    assert_eq!(hob_ipc::nodes::table_drive("B 2 0x1 zz 0x3 0x4\n"), None);
    assert_eq!(hob_ipc::nodes::table_drive("B 2 0x1\n"), None);
}
