use super::*;

/// A play of `play_arcsec` simulated apart from the fit: the motor jogs at `deg_min` from
/// wherever the last jog left it; the table stands while the motor crosses the play and
/// then follows at the contact flank; a gauge with its own scale, sign, curvature and
/// noise reads the table every `every` cycles (1 ms).
fn jogs(play_arcsec: f64, scale: f64, deg_min: f64, seconds: f64, every: usize) -> Vec<Jog> {
    let h = play_arcsec / 3600.0 / 2.0;
    let (mut motor, mut table) = (0.0f64, -h);
    let mut noise = 0x9E37_79B9_7F4A_7C15u64;
    let mut out = Vec::new();
    for way in [Way::Positive, Way::Negative, Way::Positive] {
        let mut samples = Vec::new();
        let step = way.sign() * deg_min / 60.0 * 1e-3;
        let mut command = motor;
        for k in 0..(seconds * 1000.0) as usize {
            command += step;
            motor = command - step * 2.0; // a following lag
            // The table is pushed by whichever flank the motor reaches.
            table = table.clamp(motor - h, motor + h);
            let u = {
                noise ^= noise << 13;
                noise ^= noise >> 7;
                noise ^= noise << 17;
                (noise >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            };
            let um = table.to_radians() * 150_000.0;
            let gauge = (scale * (um + 0.002 * um * um) / 0.05 + u * 2.0).round();
            samples.push(GaugeSample {
                table_deg: motor,
                command_deg: command,
                gauge_counts: if k.is_multiple_of(every) { gauge } else { f64::NAN },
            });
        }
        out.push(Jog { way, samples });
    }
    out
}

fn found(jogs: &[Jog]) -> Result<LostMotion, FitError> {
    let w: Result<Vec<Window>, FitError> = jogs.iter().enumerate().map(|(i, j)| window(j, i + 1)).collect();
    lost_motion(&w?)
}

#[test]
fn finds_the_play_within_two_percent_whichever_way_the_gauge_counts() {
    for play in [6.0, 25.0, 50.0, 120.0] {
        for scale in [1.0, -0.7] {
            let l = found(&jogs(play, scale, 3.0, 4.0, 50)).unwrap();
            assert!(
                (l.arcsec - play).abs() <= 0.02 * play + 0.1,
                "{play} arcsec, gauge x{scale}: {l:?}"
            );
            assert!(l.uncertainty_arcsec < 0.1 * play, "{l:?}");
            assert_eq!(l.per_reversal_arcsec.len(), 2);
        }
    }
}

#[test]
fn a_gauge_that_does_not_move_is_named() {
    let mut j = jogs(25.0, 1.0, 3.0, 4.0, 50);
    for s in &mut j[1].samples {
        if s.gauge_counts.is_finite() {
            s.gauge_counts = 100.0;
        }
    }
    assert_eq!(window(&j[1], 2), Err(FitError::GaugeStill { jog: 2 }));
}

#[test]
fn too_short_a_jog_or_a_gauge_not_sent_is_refused() {
    let j = jogs(25.0, 1.0, 3.0, 0.4, 50);
    assert!(matches!(
        window(&j[0], 1),
        Err(FitError::TooFewReadings { jog: 1, .. })
    ));
    let mut j = jogs(25.0, 1.0, 3.0, 4.0, 50);
    j[0].samples.iter_mut().for_each(|s| s.gauge_counts = f64::NAN);
    assert!(matches!(
        window(&j[0], 1),
        Err(FitError::TooFewReadings { readings: 0, .. })
    ));
}

#[test]
fn one_way_only_is_refused() {
    let j = jogs(25.0, 1.0, 3.0, 4.0, 50);
    let w = window(&j[0], 1).unwrap();
    assert_eq!(lost_motion(&[w.clone(), w]), Err(FitError::OneWay));
}

#[test]
fn a_gauge_at_the_end_of_its_range_is_named() {
    let mut j = jogs(25.0, 1.0, 3.0, 4.0, 50);
    for s in &mut j[0].samples {
        if s.gauge_counts.is_finite() {
            s.gauge_counts = -32768.0;
        }
    }
    assert_eq!(window(&j[0], 1), Err(FitError::GaugeAtItsEnd { jog: 1 }));
    assert!(
        FitError::GaugeAtItsEnd { jog: 1 }
            .to_string()
            .contains("set it to zero")
    );
}
