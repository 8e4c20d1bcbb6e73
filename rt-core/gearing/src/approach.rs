//! Approach length of the hob before the face (docs/domain.md section 5).

/// Axial distance from the face at which a hob of tip diameter `tool_diameter_mm` and
/// length `tool_length_mm`, swivelled by `swivel_deg`, first touches the blank with the
/// blank at depth `depth_mm`: `l = sqrt(h (D - h)) cos(eta) + (L/2) sin(eta)`.
///
/// A safe bound: for a spur gear (eta near 0) it is the classic `sqrt(h (D - h))`.
pub fn approach_mm(depth_mm: f64, tool_diameter_mm: f64, tool_length_mm: f64, swivel_deg: f64) -> f64 {
    let h = depth_mm.clamp(0.0, tool_diameter_mm);
    let eta = swivel_deg.to_radians();
    (h * (tool_diameter_mm - h)).sqrt() * eta.cos() + tool_length_mm / 2.0 * eta.sin().abs()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spur_is_the_chord_half_length() {
        // h = 11.25, D = 80: sqrt(11.25 * 68.75) = 27.81 mm.
        assert!((approach_mm(11.25, 80.0, 100.0, 0.0) - 27.811).abs() < 1e-3);
    }

    #[test]
    fn swivel_adds_the_hob_half_length_projection() {
        let l = approach_mm(10.0, 80.0, 100.0, 30.0);
        let expected = (10.0f64 * 70.0).sqrt() * 30f64.to_radians().cos() + 50.0 * 0.5;
        assert!((l - expected).abs() < 1e-9);
    }

    #[test]
    fn zero_depth_needs_no_approach_on_a_spur() {
        assert_eq!(approach_mm(0.0, 80.0, 100.0, 0.0), 0.0);
    }
}
