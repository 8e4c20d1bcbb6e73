//! An elastic link of seed 003: `(T1^2 s^2 + T2 s + 1) y = P / C`, the deflection `y` of
//! the work under the force (here torque) `P` of the cut, with stiffness `C`.

/// The work's torsional deflection on the table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorkLink {
    t1_s: f64,
    t2_s: f64,
    stiffness: f64,
    /// Deflection, rad.
    pub angle_rad: f64,
    rate_rad_s: f64,
}

impl WorkLink {
    pub fn new(t1_s: f64, t2_s: f64, stiffness_nm_rad: f64) -> Self {
        Self {
            t1_s,
            t2_s,
            stiffness: stiffness_nm_rad,
            angle_rad: 0.0,
            rate_rad_s: 0.0,
        }
    }

    /// Advances by `dt_s` under `torque_nm` (semi-implicit Euler).
    pub fn advance(&mut self, torque_nm: f64, dt_s: f64) {
        let acc = (torque_nm / self.stiffness - self.t2_s * self.rate_rad_s - self.angle_rad)
            / (self.t1_s * self.t1_s);
        self.rate_rad_s += acc * dt_s;
        self.angle_rad += self.rate_rad_s * dt_s;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn static_deflection_is_torque_over_stiffness() {
        let mut w = WorkLink::new(0.008, 0.0001, 3e5);
        // Heavily ringing (zeta 0.6 %): run long enough for it to settle.
        let mut l = WorkLink::new(0.008, 0.004, 3e5);
        for _ in 0..200_000 {
            l.advance(3.0, 1e-4);
            w.advance(3.0, 1e-4);
        }
        assert!((l.angle_rad - 1e-5).abs() < 1e-8, "{}", l.angle_rad);
        assert!(w.angle_rad.abs() < 3e-5);
    }

    #[test]
    fn rings_at_about_20_hz() {
        let mut w = WorkLink::new(0.008, 0.0001, 3e5);
        w.advance(3e5 * 1e3, 1e-4);
        let mut crossings = 0;
        let mut last = w.angle_rad;
        for _ in 0..10_000 {
            w.advance(0.0, 1e-4);
            if (last > 0.0) != (w.angle_rad > 0.0) {
                crossings += 1;
            }
            last = w.angle_rad;
        }
        // 1 s at 19.9 Hz: about 40 zero crossings.
        assert!((38..=42).contains(&crossings), "{crossings}");
    }
}
