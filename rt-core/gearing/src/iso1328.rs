//! ISO 1328-1:2013 tolerances, to express the controller's error in the user's terms
//! (docs/domain.md section 9).

/// Single pitch tolerance `f_p` in micrometres for accuracy grade `grade` (1..=11):
/// `f_p = (0.001 d + 0.4 m_n + 5) * sqrt(2)^(grade - 5)`, unrounded.
pub fn single_pitch_tolerance_um(reference_diameter_mm: f64, normal_module_mm: f64, grade: u8) -> f64 {
    let base = 0.001 * reference_diameter_mm + 0.4 * normal_module_mm + 5.0;
    base * grade_factor(grade)
}

/// The grade factor of ISO 1328-1:2013: each grade is sqrt(2) coarser than the one
/// before, grade 5 the base (a tolerance of grade g is grade 5's times this).
pub fn grade_factor(grade: u8) -> f64 {
    std::f64::consts::SQRT_2.powi(i32::from(grade) - 5)
}

/// Cumulative pitch tolerance `F_p` (total, over the whole gear) in micrometres:
/// `F_p = (0.002 d + 0.55 sqrt(d) + 0.7 m_n + 12) * sqrt(2)^(grade - 5)`, unrounded.
pub fn cumulative_pitch_tolerance_um(reference_diameter_mm: f64, normal_module_mm: f64, grade: u8) -> f64 {
    let d = reference_diameter_mm;
    (0.002 * d + 0.55 * d.sqrt() + 0.7 * normal_module_mm + 12.0) * grade_factor(grade)
}

/// Helix slope tolerance `f_Hbeta` in micrometres, for face width `b`:
/// `(0.05 sqrt(d) + 0.35 sqrt(b) + 4) * sqrt(2)^(grade - 5)` (ISO 1328-1:2013, formula 10).
pub fn helix_slope_tolerance_um(reference_diameter_mm: f64, face_width_mm: f64, grade: u8) -> f64 {
    (0.05 * reference_diameter_mm.sqrt() + 0.35 * face_width_mm.sqrt() + 4.0) * grade_factor(grade)
}

/// Helix form tolerance `f_fbeta` in micrometres, for face width `b`:
/// `(0.07 sqrt(d) + 0.45 sqrt(b) + 4) * sqrt(2)^(grade - 5)` (formula 11).
pub fn helix_form_tolerance_um(reference_diameter_mm: f64, face_width_mm: f64, grade: u8) -> f64 {
    (0.07 * reference_diameter_mm.sqrt() + 0.45 * face_width_mm.sqrt() + 4.0) * grade_factor(grade)
}

/// Total helix tolerance `F_beta` in micrometres: `sqrt(f_Hbeta^2 + f_fbeta^2)` of the
/// unrounded slope and form tolerances (formula 12). It bounds the whole spread of a helix
/// trace between two helices of the design, which is what a range along the face measures.
pub fn helix_total_tolerance_um(reference_diameter_mm: f64, face_width_mm: f64, grade: u8) -> f64 {
    helix_slope_tolerance_um(reference_diameter_mm, face_width_mm, grade).hypot(helix_form_tolerance_um(
        reference_diameter_mm,
        face_width_mm,
        grade,
    ))
}

/// Profile form tolerance `f_falpha` in micrometres: `(0.55 m_n + 5) * sqrt(2)^(grade - 5)`
/// (ISO 1328-1:2013, as the other tolerances here, unrounded). It bounds how far a profile
/// may depart from its mean line, which is what a cutter's arcs instead of an involute do.
pub fn profile_form_tolerance_um(normal_module_mm: f64, grade: u8) -> f64 {
    (0.55 * normal_module_mm + 5.0) * grade_factor(grade)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_profile_form_tolerance_doubles_every_two_grades() {
        // m 5, grade 5: 0.55 x 5 + 5 = 7.75 um; m 8, grade 7: (4.4 + 5) x 2 = 18.8 um.
        assert!((profile_form_tolerance_um(5.0, 5) - 7.75).abs() < 1e-12);
        assert!((profile_form_tolerance_um(8.0, 7) - 18.8).abs() < 1e-12);
    }

    #[test]
    fn cumulative_tolerance_matches_the_1995_table_it_replaced() {
        // ISO 1328-1:1995, grade 5, d 50..125 mm, m 3.5..6 mm: F_p = 20 um; the 2013
        // formula at d = 85, m = 5 gives 20.7 um.
        let fp = cumulative_pitch_tolerance_um(85.0, 5.0, 5);
        assert!((fp - 20.741).abs() < 1e-3, "{fp}");
        assert!((cumulative_pitch_tolerance_um(85.0, 5.0, 4) * std::f64::consts::SQRT_2 - fp).abs() < 1e-9);
    }

    #[test]
    fn helix_tolerances_by_hand() {
        // d 85, b 40, grade 5: sqrt(85) = 9.2195, sqrt(40) = 6.3246;
        // f_Hbeta = 0.461 + 2.214 + 4 = 6.675 um, f_fbeta = 0.645 + 2.846 + 4 = 7.491 um,
        // F_beta = hypot = 10.034 um; grade 7 twice each.
        let (h, f, t) = (
            helix_slope_tolerance_um(85.0, 40.0, 5),
            helix_form_tolerance_um(85.0, 40.0, 5),
            helix_total_tolerance_um(85.0, 40.0, 5),
        );
        assert!((h - 6.6746).abs() < 1e-3, "{h}");
        assert!((f - 7.4914).abs() < 1e-3, "{f}");
        assert!((t - 10.0335).abs() < 1e-3, "{t}");
        assert!((helix_total_tolerance_um(85.0, 40.0, 7) - 2.0 * t).abs() < 1e-9);
    }

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
