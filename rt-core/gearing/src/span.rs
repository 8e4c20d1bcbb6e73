//! The span measurement (base tangent length W_k over k teeth, ISO 21771 / DIN 3960) and
//! what it says about the depth still to cut. After a single pass the operator measures
//! W_k with a disc micrometer; the excess over the drawing's W_k is the tooth thickness
//! still to remove, and a radial infeed removes it at a known rate.
//!
//! Derivations (normal section, involute flanks):
//! - W_k = m_n cos(alpha_n) [ (k - 0.5) pi + z inv(alpha_t) ] + 2 x m_n sin(alpha_n):
//!   k - 1 base pitches (p_bn = pi m_n cos alpha_n) plus one base tooth thickness.
//! - A radial infeed delta thins every tooth on the reference circle by 2 delta tan(alpha_n)
//!   (both flanks, normal section); measured along the base tangent that is
//!   2 delta tan(alpha_n) cos(alpha_n) = 2 delta sin(alpha_n). So the depth still to cut for
//!   a span excess dW is dW / (2 sin alpha_n) (the same 2 x m_n sin alpha_n as a profile
//!   shift of x m_n in the formula above: the two agree).

/// The involute function, inv(alpha) = tan(alpha) - alpha.
pub fn involute(alpha_rad: f64) -> f64 {
    alpha_rad.tan() - alpha_rad
}

/// The transverse pressure angle of a helical gear: tan(alpha_t) = tan(alpha_n) / cos(beta).
pub fn transverse_pressure_angle_rad(alpha_n_rad: f64, beta_rad: f64) -> f64 {
    (alpha_n_rad.tan() / beta_rad.cos()).atan()
}

/// The base helix angle: sin(beta_b) = sin(beta) cos(alpha_n).
pub fn base_helix_angle_rad(alpha_n_rad: f64, beta_rad: f64) -> f64 {
    (beta_rad.sin() * alpha_n_rad.cos()).asin()
}

/// A gear as the span needs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpanGear {
    pub teeth: u32,
    pub normal_module_mm: f64,
    pub normal_pressure_angle_deg: f64,
    pub helix_deg: f64,
    /// Profile shift coefficient x (0: unshifted).
    pub profile_shift: f64,
}

impl SpanGear {
    fn angles(&self) -> (f64, f64, f64) {
        let alpha_n = self.normal_pressure_angle_deg.to_radians();
        let beta = self.helix_deg.to_radians();
        (alpha_n, beta, transverse_pressure_angle_rad(alpha_n, beta))
    }

    /// The number of teeth to span so that the micrometer's anvils touch the flanks near
    /// mid-height: (z / pi) (tan(alpha_m) / cos^2(beta_b) - inv(alpha_t) - 2 x tan(alpha_n) / z) + 0.5,
    /// rounded, with alpha_m the transverse pressure angle on the circle d + 2 x m_n
    /// (DIN 3960); at least 1. Spur, x = 0: z alpha / pi + 0.5.
    pub fn teeth_to_span(&self) -> u32 {
        let (alpha_n, beta, alpha_t) = self.angles();
        let z = f64::from(self.teeth);
        let d = z * self.normal_module_mm / beta.cos();
        let d_b = d * alpha_t.cos();
        let d_m = d + 2.0 * self.profile_shift * self.normal_module_mm;
        let tan_alpha_m = ((d_m / d_b).powi(2) - 1.0).max(0.0).sqrt();
        let beta_b = base_helix_angle_rad(alpha_n, beta);
        let k = z / std::f64::consts::PI
            * (tan_alpha_m / beta_b.cos().powi(2)
                - involute(alpha_t)
                - 2.0 * self.profile_shift * alpha_n.tan() / z)
            + 0.5;
        (k.round().max(1.0) as u32).min(self.teeth.saturating_sub(1).max(1))
    }

    /// The base tangent length over `k` teeth, mm.
    pub fn span_mm(&self, k: u32) -> f64 {
        let (alpha_n, _, alpha_t) = self.angles();
        let z = f64::from(self.teeth);
        self.normal_module_mm
            * alpha_n.cos()
            * ((f64::from(k) - 0.5) * std::f64::consts::PI + z * involute(alpha_t))
            + 2.0 * self.profile_shift * self.normal_module_mm * alpha_n.sin()
    }

    /// The radial depth still to cut when the span measures `excess_mm` over the drawing's.
    pub fn depth_for_span_excess_mm(&self, excess_mm: f64) -> f64 {
        excess_mm / (2.0 * self.normal_pressure_angle_deg.to_radians().sin())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn spur(z: u32, x: f64) -> SpanGear {
        SpanGear {
            teeth: z,
            normal_module_mm: 1.0,
            normal_pressure_angle_deg: 20.0,
            helix_deg: 0.0,
            profile_shift: x,
        }
    }

    #[test]
    fn spur_spans_match_the_handbook_table() {
        // W_k / m for alpha = 20 deg, x = 0 (the tables of DIN 3960 / Maag): z = 17 spans
        // k = 2 teeth with W = 4.6663 m; z = 30: k = 4, 10.7526 m; z = 50: k = 6, 16.9370 m.
        for (z, k, w) in [(17, 2, 4.6663), (30, 4, 10.7526), (50, 6, 16.9370)] {
            let g = spur(z, 0.0);
            assert_eq!(g.teeth_to_span(), k, "z = {z}");
            assert!(
                (g.span_mm(k) - w).abs() < 5e-4,
                "z = {z}: {} against {w}",
                g.span_mm(k)
            );
        }
    }

    #[test]
    fn a_helical_span_follows_from_the_virtual_spur_gear() {
        // Computed another way: W_k of a helical gear is that of a spur gear of z inv(alpha_t)
        // / inv(alpha_n) virtual teeth in the normal section (the involute's definition),
        // here z = 31, m_n = 3, alpha_n = 20 deg, beta = 15 deg.
        let g = SpanGear {
            teeth: 31,
            normal_module_mm: 3.0,
            normal_pressure_angle_deg: 20.0,
            helix_deg: 15.0,
            profile_shift: 0.0,
        };
        let alpha_n = 20f64.to_radians();
        let alpha_t = transverse_pressure_angle_rad(alpha_n, 15f64.to_radians());
        let z_virtual = 31.0 * involute(alpha_t) / involute(alpha_n);
        let k = g.teeth_to_span();
        let w_virtual = 3.0
            * alpha_n.cos()
            * ((f64::from(k) - 0.5) * std::f64::consts::PI + z_virtual * involute(alpha_n));
        assert!((g.span_mm(k) - w_virtual).abs() < 1e-9);
        assert_eq!(k, 4, "z_virtual = {z_virtual:.2}: 4 teeth spanned");
    }

    #[test]
    fn a_profile_shift_is_the_radial_depth_it_stands_for() {
        // x m_n of shift changes W by 2 x m_n sin(alpha_n): the depth of a span excess is
        // the same rule read backwards.
        let g0 = spur(17, 0.0);
        let g1 = spur(17, 0.25);
        let excess = g1.span_mm(2) - g0.span_mm(2);
        assert!((g0.depth_for_span_excess_mm(excess) - 0.25).abs() < 1e-12);
    }

    proptest! {
        #[test]
        fn one_more_tooth_spanned_adds_one_base_pitch(
            z in 6u32..200, m in 0.5f64..20.0, alpha in 14.5f64..25.0, beta in 0.0f64..40.0, k in 1u32..10,
        ) {
            let g = SpanGear { teeth: z, normal_module_mm: m, normal_pressure_angle_deg: alpha, helix_deg: beta, profile_shift: 0.0 };
            let p_bn = std::f64::consts::PI * m * alpha.to_radians().cos();
            prop_assert!((g.span_mm(k + 1) - g.span_mm(k) - p_bn).abs() < 1e-9);
            prop_assert_eq!(g.depth_for_span_excess_mm(0.0), 0.0);
            let k0 = g.teeth_to_span();
            prop_assert!(k0 >= 1 && k0 < z);
        }
    }
}
