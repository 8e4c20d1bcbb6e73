//! Cutting speeds and the spindle drive chain (docs/domain.md sections 2 and 3).

use std::f64::consts::PI;

/// Spindle speed for cutting speed `cutting_speed_m_min` with a tool of diameter
/// `tool_diameter_mm`: `n = 1000 v_c / (pi D)`.
pub fn spindle_rpm(cutting_speed_m_min: f64, tool_diameter_mm: f64) -> f64 {
    1000.0 * cutting_speed_m_min / (PI * tool_diameter_mm)
}

/// Table speed when it follows the hob: `n_B = n_C z0 / z`.
pub fn table_rpm(spindle_rpm: f64, starts: u32, teeth: u32) -> f64 {
    spindle_rpm * f64::from(starts) / f64::from(teeth)
}

/// Axial feed rate for `feed_mm_per_rev` per table revolution: `v_f = f n_B`.
pub fn axial_feed_mm_min(feed_mm_per_rev: f64, table_rpm: f64) -> f64 {
    feed_mm_per_rev * table_rpm
}

/// The spindle's drive chain: induction motor through a belt/gear ratio, fed by a VFD
/// whose frequency is set by an analog voltage.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SpindleDrive {
    /// Motor revolutions per spindle revolution (6 on the thesis machine).
    pub motor_to_spindle_ratio: f64,
    /// VFD output frequency at full-scale analog input (80 Hz).
    pub vfd_hz_at_full_scale: f64,
    /// Motor speed at that frequency (1500 rpm).
    pub motor_rpm_at_full_scale: f64,
    /// Analog input full scale (10 V).
    pub analog_full_scale_v: f64,
}

impl SpindleDrive {
    /// Motor speed for a spindle speed.
    pub fn motor_rpm(&self, spindle_rpm: f64) -> f64 {
        spindle_rpm * self.motor_to_spindle_ratio
    }

    /// VFD frequency that gives a spindle speed (ignoring slip: the loop follows the
    /// measured spindle angle, never this command).
    pub fn vfd_hz(&self, spindle_rpm: f64) -> f64 {
        self.motor_rpm(spindle_rpm) * self.vfd_hz_at_full_scale / self.motor_rpm_at_full_scale
    }

    /// Analog output voltage for a spindle speed.
    pub fn analog_out_v(&self, spindle_rpm: f64) -> f64 {
        self.vfd_hz(spindle_rpm) * self.analog_full_scale_v / self.vfd_hz_at_full_scale
    }

    /// Spindle speed for the full-scale analog output.
    pub fn spindle_rpm_at_full_scale(&self) -> f64 {
        self.motor_rpm_at_full_scale / self.motor_to_spindle_ratio
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const THESIS: SpindleDrive = SpindleDrive {
        motor_to_spindle_ratio: 6.0,
        vfd_hz_at_full_scale: 80.0,
        motor_rpm_at_full_scale: 1500.0,
        analog_full_scale_v: 10.0,
    };

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn thesis_spindle_speed_30_m_min_80_mm() {
        // Thesis eq. 3.1: 119.366 1/min.
        assert!(close(spindle_rpm(30.0, 80.0), 119.366, 5e-4));
    }

    #[test]
    fn thesis_max_spindle_speed_40_m_min_60_mm() {
        // Thesis eq. 4.2 / 4.14: 212.2 1/min.
        assert!(close(spindle_rpm(40.0, 60.0), 212.2, 0.05));
    }

    #[test]
    fn thesis_max_table_speed_z_15() {
        // Thesis eq. 4.15: 14.1 1/min with a single-start hob.
        let n_b = table_rpm(spindle_rpm(40.0, 60.0), 1, 15);
        assert!(close(n_b, 14.1, 0.05), "{n_b}");
    }

    #[test]
    fn thesis_axial_feed_f_2_z_17() {
        // Thesis eq. 3.2: 14.0422 mm/min (f = 2 mm/rev, z = 17, 119.366 1/min).
        let v_f = axial_feed_mm_min(2.0, table_rpm(spindle_rpm(30.0, 80.0), 1, 17));
        assert!(close(v_f, 14.04, 0.005), "{v_f}");
    }

    #[test]
    fn vfd_scaling_10_v_is_80_hz_is_1500_motor_rpm() {
        let full = THESIS.spindle_rpm_at_full_scale();
        assert!(close(full, 250.0, 1e-12));
        assert!(close(THESIS.vfd_hz(full), 80.0, 1e-12));
        assert!(close(THESIS.analog_out_v(full), 10.0, 1e-12));
        // The thesis example: 119.366 rpm -> 716.2 motor rpm -> 38.20 Hz -> 4.775 V.
        let n = spindle_rpm(30.0, 80.0);
        assert!(close(THESIS.motor_rpm(n), 716.2, 0.05));
        assert!(close(THESIS.vfd_hz(n), 38.197, 1e-3));
        assert!(close(THESIS.analog_out_v(n), 4.775, 1e-3));
    }
}
