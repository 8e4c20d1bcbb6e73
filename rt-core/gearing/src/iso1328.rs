//! ISO 1328-1:2013 tolerances, to express the controller's error in the user's terms
//! (docs/domain.md section 9).

/// Single pitch tolerance `f_p` in micrometres for accuracy grade `grade` (1..=11):
/// `f_p = (0.001 d + 0.4 m_n + 5) * sqrt(2)^(grade - 5)`, unrounded.
pub fn single_pitch_tolerance_um(reference_diameter_mm: f64, normal_module_mm: f64, grade: u8) -> f64 {
    let base = 0.001 * reference_diameter_mm + 0.4 * normal_module_mm + 5.0;
    base * std::f64::consts::SQRT_2.powi(i32::from(grade) - 5)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grade_5_module_5_d_85_is_about_7_um() {
        let t = single_pitch_tolerance_um(85.0, 5.0, 5);
        assert!((t - 7.085).abs() < 1e-9, "{t}");
    }

    #[test]
    fn each_grade_is_sqrt_2_coarser() {
        let g5 = single_pitch_tolerance_um(85.0, 5.0, 5);
        let g6 = single_pitch_tolerance_um(85.0, 5.0, 6);
        assert!((g6 / g5 - std::f64::consts::SQRT_2).abs() < 1e-12);
    }
}
