//! Commands as every frontend encodes them (the CLI, the HMI): an operator's words (`x`,
//! `all`, `+`, `feed`) to a [`CommandRequest`] with its codes. A word that is not one of
//! the command's is refused here with the text the operator sees; the values themselves
//! (ranges, limits, the machine's state) are the loop's to check.

use crate::Error;
use crate::codec::Axis;
use crate::types::{CommandRequest, command, direction};

/// A command without arguments (`RESET`, `FEED_HOLD`, `STOP` ...).
pub fn simple(code: u32) -> CommandRequest {
    CommandRequest::new(code)
}

/// `START`, the whole program or (`single`) its single-mode pass.
pub fn start(single: bool) -> CommandRequest {
    let mut r = CommandRequest::new(command::START);
    r.single = u8::from(single);
    r
}

fn axis_of(command: &'static str, axis: &str) -> Result<Axis, Error> {
    Axis::parse(axis).ok_or_else(|| Error::NotAnAxis {
        command,
        word: axis.to_string(),
    })
}

/// `JOG`: a distance, mm (deg for B).
pub fn jog(axis: &str, distance: f64) -> Result<CommandRequest, Error> {
    let a = axis_of("jog", axis)?;
    let mut r = CommandRequest::new(command::JOG);
    r.axis = a.code();
    r.value = distance;
    Ok(r)
}

/// `HOME`: `x`, `y`, or `all` (X then Y).
pub fn home(axes: &str) -> Result<CommandRequest, Error> {
    let mut r = CommandRequest::new(command::HOME);
    r.axis = match axes.to_ascii_lowercase().as_str() {
        "all" | "xy" => 0,
        other => match Axis::parse(other) {
            Some(a @ (Axis::X | Axis::Y)) => a.code(),
            _ => {
                return Err(Error::NotHomeAxes {
                    word: axes.to_string(),
                });
            }
        },
    };
    Ok(r)
}

/// `JOG_CONTINUOUS`: `+` or `-` at `speed` (mm/min, deg/min for B), renewed by sending it again.
pub fn jog_continuous(axis: &str, dir: &str, speed: f64) -> Result<CommandRequest, Error> {
    let a = axis_of("jog-hold", axis)?;
    let d = direction_of("jog-hold", dir)?;
    let mut r = CommandRequest::new(command::JOG_CONTINUOUS);
    r.axis = a.code();
    r.direction = d;
    r.value = speed;
    Ok(r)
}

fn direction_of(command: &'static str, dir: &str) -> Result<u8, Error> {
    match dir {
        "+" | "plus" | "positive" => Ok(direction::POSITIVE),
        "-" | "minus" | "negative" => Ok(direction::NEGATIVE),
        _ => Err(Error::NotADirection {
            command,
            word: dir.to_string(),
        }),
    }
}

/// `TOUCH_FLANK`: a flank of the cut gap touches the hob's tooth, the table having been
/// turned `+` or `-` to it.
pub fn touch_flank(dir: &str) -> Result<CommandRequest, Error> {
    let mut r = CommandRequest::new(command::TOUCH_FLANK);
    r.direction = direction_of("touch-flank", dir)?;
    Ok(r)
}

/// `JOG_RELEASE`: the continuous jog stops.
pub fn nodes() -> CommandRequest {
    CommandRequest::new(command::NODES)
}

pub fn jog_release() -> CommandRequest {
    CommandRequest::new(command::JOG_RELEASE)
}

/// `FEED_OVERRIDE` or `SPINDLE_OVERRIDE` (`feed`, `spindle`), percent.
pub fn override_request(what: &str, percent: f64) -> Result<CommandRequest, Error> {
    let code = match what {
        "feed" => command::FEED_OVERRIDE,
        "spindle" => command::SPINDLE_OVERRIDE,
        _ => {
            return Err(Error::NotAnOverride {
                word: what.to_string(),
            });
        }
    };
    let mut r = CommandRequest::new(code);
    r.value = percent;
    Ok(r)
}

/// `PITCH_COMPENSATION` (`on`, `off`): the loaded pitch compensation applied or not.
pub fn pitch_compensation(word: &str) -> Result<CommandRequest, Error> {
    let value = match word {
        "on" => 1.0,
        "off" => 0.0,
        _ => {
            return Err(Error::NotOnOff {
                command: "pitch-compensation",
                word: word.to_string(),
            });
        }
    };
    let mut r = CommandRequest::new(command::PITCH_COMPENSATION);
    r.value = value;
    Ok(r)
}

/// `TOUCH_OFF` as the CLI takes it: X with the gauge's diameter, or Y with its height;
/// `confirm`: the operator confirms the new offset the loop asked about.
pub fn touch_off(
    axis: &str,
    diameter: Option<f64>,
    height: Option<f64>,
    confirm: bool,
) -> Result<CommandRequest, Error> {
    match (Axis::parse(axis), diameter, height) {
        (Some(Axis::X), Some(d), None) => touch_off_value("x", d, confirm),
        (Some(Axis::Y), None, Some(h)) => touch_off_value("y", h, confirm),
        _ => Err(Error::TouchOffGauge),
    }
}

/// `TOUCH_OFF` of an axis with its gauge's size: X its diameter, Y its height, mm. With
/// `confirm` the loop applies an offset it would otherwise refuse as
/// `OffsetNeedsConfirmation` (never one beyond its limits).
pub fn touch_off_value(axis: &str, value_mm: f64, confirm: bool) -> Result<CommandRequest, Error> {
    let a = match Axis::parse(axis) {
        Some(a @ (Axis::X | Axis::Y)) => a,
        _ => {
            return Err(Error::NotATouchOffAxis {
                word: axis.to_string(),
            });
        }
    };
    let mut r = CommandRequest::new(command::TOUCH_OFF);
    r.axis = a.code();
    r.value = value_mm;
    r.confirm = u8::from(confirm);
    Ok(r)
}

/// `SPINDLE_HOLD` at `rpm`: the hob spindle turns while this is renewed (dead-man).
pub fn spindle_hold(rpm: f64) -> CommandRequest {
    let mut r = CommandRequest::new(command::SPINDLE_HOLD);
    r.value = rpm;
    r
}

/// `EXCITE_TABLE` at `frequency_hz`, the table creeping `creep` (`+`, `-`): the table's
/// target swings while this is renewed.
pub fn excite_table(frequency_hz: f64, creep: &str) -> Result<CommandRequest, Error> {
    let mut r = CommandRequest::new(command::EXCITE_TABLE);
    r.value = frequency_hz;
    r.direction = direction_of("excite-table", creep)?;
    Ok(r)
}

/// `SPINDLE_ON` at `rpm`.
pub fn spindle_on(rpm: f64) -> CommandRequest {
    let mut r = CommandRequest::new(command::SPINDLE_ON);
    r.value = rpm;
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_builder_sets_the_codes_the_loop_reads() {
        let h = home("all").expect("home");
        assert_eq!((h.command, h.axis), (command::HOME, 0));
        assert_eq!(home("Y").expect("home").axis, Axis::Y.code());
        let j = jog("b", -1.5).expect("jog");
        assert_eq!((j.command, j.axis, j.value), (command::JOG, Axis::B.code(), -1.5));
        let c = jog_continuous("x", "-", 300.0).expect("jog-hold");
        assert_eq!(
            (c.command, c.axis, c.direction, c.value),
            (
                command::JOG_CONTINUOUS,
                Axis::X.code(),
                direction::NEGATIVE,
                300.0
            )
        );
        assert_eq!(
            jog_continuous("y", "plus", 1.0).expect("jog-hold").direction,
            direction::POSITIVE
        );
        let e = excite_table(40.0, "-").expect("excite");
        assert_eq!(
            (e.command, e.value, e.direction),
            (command::EXCITE_TABLE, 40.0, direction::NEGATIVE)
        );
        let p = pitch_compensation("on").expect("on");
        assert_eq!((p.command, p.value), (command::PITCH_COMPENSATION, 1.0));
        assert_eq!(pitch_compensation("off").expect("off").value, 0.0);
        assert!(pitch_compensation("yes").is_err());
        let o = override_request("spindle", 110.0).expect("override");
        assert_eq!((o.command, o.value), (command::SPINDLE_OVERRIDE, 110.0));
        let t = touch_off("x", Some(120.0), None, false).expect("touch-off");
        assert_eq!(t, touch_off_value("X", 120.0, false).expect("touch-off"));
        assert_eq!(
            (t.command, t.axis, t.value, t.confirm),
            (command::TOUCH_OFF, Axis::X.code(), 120.0, 0)
        );
        let y = touch_off("y", None, Some(3.0), true).expect("touch-off");
        assert_eq!((y.axis, y.confirm), (Axis::Y.code(), 1));
        // The confirmation is the only difference: the same gauge, the same axis.
        assert_eq!(
            CommandRequest {
                confirm: 0,
                ..touch_off_value("x", 120.0, true).expect("touch-off")
            },
            t
        );
        assert_eq!(start(true).single, 1);
        assert_eq!(spindle_on(20.0).value, 20.0);
        assert_eq!(jog_release().command, command::JOG_RELEASE);
    }

    #[test]
    fn a_word_that_is_not_the_commands_is_refused_with_the_operators_text() {
        assert_eq!(
            home("b").unwrap_err().to_string(),
            "home: b is not x, y or all (the table needs no reference for hobbing)"
        );
        assert_eq!(
            jog("z", 1.0).unwrap_err().to_string(),
            "jog: axis z is not x, y or b"
        );
        assert_eq!(
            jog_continuous("x", "up", 1.0).unwrap_err().to_string(),
            "jog-hold: direction up is not + or -"
        );
        assert_eq!(
            override_request("rapid", 50.0).unwrap_err().to_string(),
            "override: rapid is not feed or spindle"
        );
        assert!(touch_off("x", None, Some(1.0), false).is_err());
        assert!(touch_off("x", Some(1.0), Some(1.0), true).is_err());
        assert_eq!(
            touch_off_value("b", 1.0, false).unwrap_err().to_string(),
            "touch-off: axis b is not x or y"
        );
        assert!(
            touch_off("y", None, None, false)
                .unwrap_err()
                .to_string()
                .contains("--height MM")
        );
    }
}
