//! Unit conversions. Quantities are `f64` with the unit in the name (`_mm`, `_deg`,
//! `_rpm`, `_counts`, `_arcsec`, `_um`); these helpers are the only place the factors live.

/// Arc seconds in one degree.
pub const ARCSEC_PER_DEG: f64 = 3600.0;
/// Degrees in one revolution.
pub const DEG_PER_REV: f64 = 360.0;
/// Seconds in one minute.
pub const S_PER_MIN: f64 = 60.0;

/// Degrees per second for a speed in revolutions per minute.
pub fn rpm_to_deg_per_s(speed_rpm: f64) -> f64 {
    speed_rpm * DEG_PER_REV / S_PER_MIN
}

/// Revolutions per minute for a speed in degrees per second.
pub fn deg_per_s_to_rpm(speed_deg_per_s: f64) -> f64 {
    speed_deg_per_s * S_PER_MIN / DEG_PER_REV
}

/// Arc length in micrometres of an angle in arc seconds at radius `radius_mm`.
pub fn arcsec_to_um_at_radius(angle_arcsec: f64, radius_mm: f64) -> f64 {
    (angle_arcsec / ARCSEC_PER_DEG).to_radians() * radius_mm * 1000.0
}

/// Angle in arc seconds of an arc length in micrometres at radius `radius_mm`.
pub fn um_to_arcsec_at_radius(length_um: f64, radius_mm: f64) -> f64 {
    (length_um / 1000.0 / radius_mm).to_degrees() * ARCSEC_PER_DEG
}

/// Scaling of one axis between counts and units.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct AxisScale {
    pub counts_per_unit: f64,
    pub sign: f64,
}

impl AxisScale {
    /// Position of an encoder reading: the middle of the count's interval (an encoder
    /// reports `floor(position)`, so taking the count itself would bias every reading by
    /// half a count: 3.8 arcsec of table at z = 17 for the spindle's 10 000 counts).
    pub fn to_units(&self, counts: i64) -> f64 {
        (counts as f64 + 0.5) / self.counts_per_unit * self.sign
    }

    /// Wrapping 32-bit counts for a position (drives count modulo 2^32 in CSP).
    pub fn to_counts(&self, units: f64) -> i32 {
        let c = (units * self.sign * self.counts_per_unit).round();
        // Saturating cast, then wrap to the drive's 32-bit range.
        (c as i64) as i32
    }
}

/// Extends a wrapping 32-bit counter to a continuous 64-bit one.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Unwrapper {
    last: Option<i32>,
    total: i64,
}

impl Unwrapper {
    /// Continuous count for a new raw reading (at most half the counter range between
    /// readings).
    pub fn update(&mut self, raw: i32) -> i64 {
        match self.last {
            None => self.total = i64::from(raw),
            Some(last) => self.total += i64::from(raw.wrapping_sub(last)),
        }
        self.last = Some(raw);
        self.total
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_arcsec_at_42_5_mm_is_0_21_um() {
        // docs/domain.md section 9.
        let um = arcsec_to_um_at_radius(1.0, 42.5);
        assert!((um - 0.206).abs() < 0.001, "{um}");
        assert!((um_to_arcsec_at_radius(um, 42.5) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn speeds_convert_both_ways() {
        assert!((rpm_to_deg_per_s(212.2) - 1273.2).abs() < 1e-9);
        assert!((deg_per_s_to_rpm(rpm_to_deg_per_s(14.1)) - 14.1).abs() < 1e-12);
    }
}
