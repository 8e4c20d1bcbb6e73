//! The mechanism fitted to a measured frequency response: the model of the drive's loops
//! ([`super::model`]) with the drive's own gains, on a two-mass worm drive whose table
//! inertia, mesh stiffness and damping, and the target's delay, are found by least squares
//! (a Nelder-Mead simplex over their logarithms, started from the measured dip taken as the
//! anti-resonance and a few table inertias); the motor side's inertia is given. The fitted mechanism is an equivalent linear one:
//! the worm's play and the table's friction make the real one depend on the swing.

use super::frf::Point;
use super::model::{self, CspTiming, DriveLoops, Mechanism};
use nalgebra::Complex;
use std::f64::consts::TAU;

/// What the fit found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fitted {
    pub mechanism: Mechanism,
    /// From the target the loop sent to the motor's reading of the same cycle: the bus,
    /// the drive's interpolation and its delay, s.
    pub delay_s: f64,
    /// The points' distance from the model, RMS (of the complex response).
    pub misfit: f64,
}

/// The model's response at `f_hz` for `delay_s` from the loop's target to the reading
/// (one SYNC period of it the target's way to the drive, the rest the drive's own).
pub fn response(m: &Mechanism, d: &DriveLoops, sync_s: f64, delay_s: f64, f_hz: f64) -> Complex<f64> {
    let lm = model::LoopModel::new(m, d);
    at(&lm, sync_s, delay_s, f_hz)
}

fn at(lm: &model::LoopModel, sync_s: f64, delay_s: f64, f_hz: f64) -> Complex<f64> {
    // The drive's delay beyond one period is the CSP model's; the reading of the cycle
    // the target was sent in comes one SYNC before the drive's interpolation starts.
    let extra = (delay_s - 2.0 * sync_s).clamp(-0.9 * sync_s, 0.9 * sync_s);
    let csp = CspTiming {
        sync_period_s: sync_s,
        extra_delay_s: extra,
    };
    lm.target_response(&csp, f_hz) * Complex::from_polar(1.0, -TAU * f_hz * sync_s)
}

/// The mechanism behind `points`, measured with the drive's loops `d` (its gains as it
/// reported them) every `sync_s`, the worm's ratio `worm_ratio` and the motor side's
/// inertia `motor_inertia_kg_m2` (rotor, coupling and worm, from their data sheets: it acts
/// above the band a 1 kHz loop can measure, and a fit of it from these points was 2.6 times
/// off on the simulated machine).
pub fn fit(
    points: &[Point],
    d: &DriveLoops,
    sync_s: f64,
    worm_ratio: f64,
    motor_inertia_kg_m2: f64,
) -> Option<Fitted> {
    let dip = &points[super::frf::deepest(points)?];
    let w_dip = TAU * dip.frequency_hz;
    let cost = |x: &[f64; 4]| {
        let Some(m) = mechanism(x, worm_ratio, motor_inertia_kg_m2) else {
            return f64::INFINITY;
        };
        let lm = model::LoopModel::new(&m, d);
        if lm.largest_pole().0 >= 1.0 {
            return f64::INFINITY;
        }
        points
            .iter()
            .map(|p| {
                let e = p.response - at(&lm, sync_s, x[3] * 1e-3, p.frequency_hz);
                e.norm_sqr() / (p.uncertainty.powi(2) + 1e-4)
            })
            .sum::<f64>()
    };
    let mut best: Option<([f64; 4], f64)> = None;
    for j_t in [2.0, 8.0, 30.0, 100.0] {
        let k = j_t * w_dip * w_dip;
        let c = 2.0 * 0.05 * (k * j_t).sqrt();
        let start = [f64::ln(j_t), f64::ln(k), f64::ln(c), 2.0 * sync_s * 1e3];
        let (x, v) = nelder_mead(&cost, start, [0.5, 0.3, 0.7, 0.3], 400);
        if best.is_none_or(|(_, b)| v < b) {
            best = Some((x, v));
        }
    }
    let (x, _) = best?;
    let m = mechanism(&x, worm_ratio, motor_inertia_kg_m2)?;
    let lm = model::LoopModel::new(&m, d);
    let misfit = (points
        .iter()
        .map(|p| (p.response - at(&lm, sync_s, x[3] * 1e-3, p.frequency_hz)).norm_sqr())
        .sum::<f64>()
        / points.len() as f64)
        .sqrt();
    Some(Fitted {
        mechanism: m,
        delay_s: x[3] * 1e-3,
        misfit,
    })
}

/// The least damping of the mesh's coupled mode gains are proposed for (a share of
/// critical): the fit's damping holds the table's friction as the creep loads it, which a
/// cut at another speed or a table at rest does not have.
pub const CAUTIOUS_MODAL_DAMPING: f64 = 0.02;

/// `m` with its mesh damping no more than [`CAUTIOUS_MODAL_DAMPING`] of critical: what gains
/// are proposed for. On the simulated machine, gains proposed for the fitted damping (3.5
/// times the mesh's own) left the cascade 19.5 deg of phase margin on the true mechanism.
pub fn cautious(m: &Mechanism) -> Mechanism {
    Mechanism {
        mesh_damping_nm_s_per_rad: m
            .mesh_damping_nm_s_per_rad
            .min(m.damping_for_modal_ratio_nm_s_per_rad(CAUTIOUS_MODAL_DAMPING)),
        ..*m
    }
}

/// The mechanism of the fit's parameters (logarithms of J_t, k, c; the delay, ms).
fn mechanism(x: &[f64; 4], worm_ratio: f64, motor_inertia_kg_m2: f64) -> Option<Mechanism> {
    let m = Mechanism {
        motor_inertia_kg_m2,
        table_inertia_kg_m2: x[0].exp(),
        mesh_stiffness_nm_per_rad: x[1].exp(),
        mesh_damping_nm_s_per_rad: x[2].exp(),
        worm_ratio,
    };
    let finite = x.iter().all(|v| v.is_finite());
    (finite && (0.0..5.0).contains(&x[3])).then_some(m)
}

/// The minimum of `f` by the Nelder-Mead simplex from `start` (steps `scale`), at most
/// `evaluations` evaluations; (where, value).
pub fn nelder_mead<const N: usize>(
    f: &dyn Fn(&[f64; N]) -> f64,
    start: [f64; N],
    scale: [f64; N],
    evaluations: usize,
) -> ([f64; N], f64) {
    let mut simplex: Vec<([f64; N], f64)> = (0..=N)
        .map(|i| {
            let mut x = start;
            if i > 0 {
                x[i - 1] += scale[i - 1];
            }
            (x, f(&x))
        })
        .collect();
    let mut used = N + 1;
    let along = |a: &[f64; N], b: &[f64; N], t: f64| {
        let mut x = [0.0; N];
        for i in 0..N {
            x[i] = a[i] + t * (b[i] - a[i]);
        }
        x
    };
    while used < evaluations {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let mut centroid = [0.0; N];
        for (x, _) in &simplex[..N] {
            for i in 0..N {
                centroid[i] += x[i] / N as f64;
            }
        }
        let worst = simplex[N];
        let reflected = along(&centroid, &worst.0, -1.0);
        let fr = f(&reflected);
        used += 1;
        if fr < simplex[0].1 {
            let expanded = along(&centroid, &worst.0, -2.0);
            let fe = f(&expanded);
            used += 1;
            simplex[N] = if fe < fr { (expanded, fe) } else { (reflected, fr) };
        } else if fr < simplex[N - 1].1 {
            simplex[N] = (reflected, fr);
        } else {
            let contracted = along(&centroid, &worst.0, 0.5);
            let fc = f(&contracted);
            used += 1;
            if fc < worst.1 {
                simplex[N] = (contracted, fc);
            } else {
                let best = simplex[0].0;
                for s in simplex.iter_mut().skip(1) {
                    s.0 = along(&best, &s.0, 0.5);
                    s.1 = f(&s.0);
                }
                used += N;
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    simplex[0]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_simplex_finds_a_valley_floor() {
        let rosen = |x: &[f64; 2]| (1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2);
        let (x, v) = nelder_mead(&rosen, [-1.2, 1.0], [0.5, 0.5], 4000);
        assert!(v < 1e-8 && (x[0] - 1.0).abs() < 1e-3, "{x:?} {v}");
    }
}
