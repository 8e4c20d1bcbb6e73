//! Every sign of the hobbing set-up as a named input, and the one place that turns names
//! into +1/-1 (docs/domain.md section 3: a wrong sign makes scrap, silently).
//!
//! ## Frame (the convention every sign below refers to)
//!
//! Right-handed frame at the table: `y` up along the table axis, `x` radial from the table
//! axis towards the hob, `t` tangential with `x × t = y`.
//! - Table angle `phi_B` is positive counter-clockwise seen from above (right-hand rule
//!   about `+y`); at the cutting point on `+x` a positive table turn moves the work `+t`.
//! - Hob spindle angle `theta_C` is positive by the right-hand rule about `+t` (hob axis
//!   along `t` before swivel). A positive spindle turn moves the hob's teeth **up** (`+y`)
//!   where they meet the work (on the hob's `-x` side): `t × (-x) = +y`.
//! - `Y` (hob height above the table) is positive up.
//!
//! Each drive's own counting direction is mapped onto this frame by its `polarity` in the
//! machine configuration, set once at commissioning.
//!
//! ## Derivations
//! - Feed direction: start at the top feeds down (`-y`), start at the bottom feeds up.
//! - Climb hobbing: the hob's teeth move at the cut in the feed direction; conventional:
//!   against it. Teeth moving up need a positive spindle, so the spindle sign is fixed.
//! - Base ratio: a right-hand worm turning positive about `+t` moves its thread pattern
//!   `-t` (points of the thread satisfy `theta = 2 pi t / lead + c`; turning the body by
//!   `+w` shifts the pattern to `t - lead w / 2 pi`). The work must follow the generating
//!   rack, so the table turns negative: `s_i = -hand(hob) * sign(spindle)`.
//! - Differential: a right-hand tooth rises counter-clockwise seen from above (the helix
//!   `(cos a, sin a, c a)` with `c > 0`). To keep the same tooth space under the hob while
//!   `Y` grows by `dY`, the table turns by `-360 dY / lead`: `s_d = -hand(gear)`.

use serde::{Deserialize, Serialize};

/// Hand of a helix (gear teeth or hob thread).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Hand {
    Right,
    Left,
}

impl Hand {
    /// +1 for right, -1 for left.
    pub fn sign(self) -> f64 {
        match self {
            Hand::Right => 1.0,
            Hand::Left => -1.0,
        }
    }
}

/// Where the hob starts the axial stroke.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum StartSide {
    Top,
    Bottom,
}

/// Climb (teeth move with the feed at the cut) or conventional (against it).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum CutMethod {
    Climb,
    Conventional,
}

/// A direction along `y`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Vertical {
    Up,
    Down,
}

impl Vertical {
    /// +1 up, -1 down.
    pub fn sign(self) -> f64 {
        match self {
            Vertical::Up => 1.0,
            Vertical::Down => -1.0,
        }
    }

    fn opposite(self) -> Self {
        match self {
            Vertical::Up => Vertical::Down,
            Vertical::Down => Vertical::Up,
        }
    }
}

/// A sense of rotation in the frame of this module.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Rotation {
    /// Positive by the frame's convention.
    Positive,
    /// Negative by the frame's convention.
    Negative,
}

impl Rotation {
    /// +1 or -1.
    pub fn sign(self) -> f64 {
        match self {
            Rotation::Positive => 1.0,
            Rotation::Negative => -1.0,
        }
    }

    fn from_sign(sign: f64) -> Self {
        if sign >= 0.0 {
            Rotation::Positive
        } else {
            Rotation::Negative
        }
    }
}

/// The named inputs that decide every sign of the gearbox.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SignInputs {
    pub hob_hand: Hand,
    /// `None` for a spur gear (no differential).
    pub gear_hand: Option<Hand>,
    pub start: StartSide,
    pub method: CutMethod,
}

/// The signs of the electronic-gearbox law, derived from [`SignInputs`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct GearboxSigns {
    /// Direction of the axial feed during the cut.
    pub feed: Vertical,
    /// Direction the hob's teeth move at the cut.
    pub cutting: Vertical,
    /// Spindle sense of rotation.
    pub spindle: Rotation,
    /// Table sense of rotation per positive spindle turn (`s_i`).
    pub table_per_spindle: Rotation,
    /// Sign of the helical differential (`s_d`); positive for spur (unused there).
    pub differential: Rotation,
}

impl GearboxSigns {
    /// Derives every sign from the named inputs (see the module documentation).
    pub fn derive(inputs: SignInputs) -> Self {
        let feed = match inputs.start {
            StartSide::Top => Vertical::Down,
            StartSide::Bottom => Vertical::Up,
        };
        let cutting = match inputs.method {
            CutMethod::Climb => feed,
            CutMethod::Conventional => feed.opposite(),
        };
        let spindle = Rotation::from_sign(cutting.sign());
        let table_per_spindle = Rotation::from_sign(-inputs.hob_hand.sign() * spindle.sign());
        let differential = Rotation::from_sign(-inputs.gear_hand.map_or(-1.0, Hand::sign));
        Self {
            feed,
            cutting,
            spindle,
            table_per_spindle,
            differential,
        }
    }

    /// `s_i`: table turns per spindle turn, as a sign.
    pub fn s_i(&self) -> f64 {
        self.table_per_spindle.sign()
    }

    /// `s_f`: sign of the axial feed.
    pub fn s_f(&self) -> f64 {
        self.feed.sign()
    }

    /// `s_d`: sign of the differential.
    pub fn s_d(&self) -> f64 {
        self.differential.sign()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn derive(hob: Hand, gear: Option<Hand>, start: StartSide, method: CutMethod) -> GearboxSigns {
        GearboxSigns::derive(SignInputs {
            hob_hand: hob,
            gear_hand: gear,
            start,
            method,
        })
    }

    #[test]
    fn climb_from_top_feeds_down_with_teeth_moving_down() {
        let s = derive(Hand::Right, None, StartSide::Top, CutMethod::Climb);
        assert_eq!(s.feed, Vertical::Down);
        assert_eq!(s.cutting, Vertical::Down);
        assert_eq!(s.spindle, Rotation::Negative);
        // Right-hand hob turning negative pushes the rack +t: table turns positive.
        assert_eq!(s.table_per_spindle, Rotation::Positive);
    }

    #[test]
    fn conventional_from_top_turns_the_spindle_the_other_way() {
        let s = derive(Hand::Right, None, StartSide::Top, CutMethod::Conventional);
        assert_eq!(s.feed, Vertical::Down);
        assert_eq!(s.cutting, Vertical::Up);
        assert_eq!(s.spindle, Rotation::Positive);
        assert_eq!(s.table_per_spindle, Rotation::Negative);
    }

    #[test]
    fn left_hand_hob_reverses_the_table() {
        let r = derive(Hand::Right, None, StartSide::Bottom, CutMethod::Climb);
        let l = derive(Hand::Left, None, StartSide::Bottom, CutMethod::Climb);
        assert_eq!(r.spindle, l.spindle);
        assert_eq!(r.s_i(), -l.s_i());
    }

    #[test]
    fn differential_sign_follows_the_gear_hand_only() {
        for hob in [Hand::Right, Hand::Left] {
            for start in [StartSide::Top, StartSide::Bottom] {
                for method in [CutMethod::Climb, CutMethod::Conventional] {
                    assert_eq!(derive(hob, Some(Hand::Right), start, method).s_d(), -1.0);
                    assert_eq!(derive(hob, Some(Hand::Left), start, method).s_d(), 1.0);
                }
            }
        }
    }

    #[test]
    fn rack_motion_of_a_right_hand_worm() {
        // Check the derivation numerically: a right-hand thread point theta = 2 pi t / L.
        // Turning the body by +w, the point that was at theta0 moves to theta0 + w; the
        // thread through a fixed theta is then at t = (theta - w) L / 2 pi: it moved -t.
        let lead = 15.7;
        let t_of = |theta: f64, w: f64| (theta - w) * lead / std::f64::consts::TAU;
        assert!(t_of(1.0, 0.1) < t_of(1.0, 0.0));
    }
}
