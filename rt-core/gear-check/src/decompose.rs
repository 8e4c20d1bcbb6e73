//! A pitch measurement split, against the cut's record, into the parts a compensation can
//! remove (issue 34: measure the first gear, correct the second). Pure mathematics, no I/O.
//!
//! The model (the simulated machine's physics, docs/gear-measurement.md): gap `i` is
//! generated with the table at `theta_i`; the table standing `e` um ahead (its positive
//! direction, at the pitch circle) puts both flanks of the gap `e` ahead. At each measured
//! height `h` (one table revolution, one face section) the gap's error is
//!
//! ```text
//! m[h][i] = E[i] + H(phi[h][i]) + c[h][i] + o[h] + noise,   H(phi) = a cos(phi) + b sin(phi)
//! ```
//!
//! - `E[i]`: the table's repeatable error at the gap's angle (worm wheel eccentricity and
//!   pitch errors, worm runout), the same at every height; reported mean-free (a common
//!   offset is a rotation of the gear).
//! - `H`: the hob's once-per-turn error (axial runout) at its phase `phi` (deg) when the gap
//!   passed. A one-start hob has one phase for every gap: `H` is a constant, invisible and
//!   harmless, and is not fitted. With two starts and an odd tooth count alternate gaps
//!   differ by 180 deg and flip from one height to the next: `H` is told from `E` only by
//!   heights whose phases differ, and with phases of only two values 180 deg apart only its
//!   component along that phase ([`Identified::Direction`]), the only one that acts on such a
//!   gear. With an even tooth count and two starts the phases never flip: `H` stays in `E`,
//!   which is right for that gear ([`Identified::None`]).
//! - `c[h][i]`: the controller's own share, from the cut's record; removed before the fit so
//!   that it is not compensated twice.
//! - `o[h]`: each height's own offset. A flank's `Fp` carries an arbitrary offset, so each
//!   flank's mean is removed and every height is mean-free over its gaps; `H` and `c` are not
//!   (with an odd tooth count `H`'s mean over the gaps is `+-a/z`, flipping with the height).
//!   Fitting without `o` would bias `a` (by `a/z^2` with two flipped heights); the offset is
//!   fitted and reported, and is no error of the gear.
//!
//! The fit is least squares over `E`, `o`, `a`, `b`: `E` and `o` are eliminated by centring
//! every table of the data over the heights and over the gaps (the data are complete and
//! balanced), which leaves a 2x2 normal system for `(a, b)`. Its eigen-directions whose
//! eigenvalue is below `1e-6` times the number of data are not identifiable: `(a, b)` is the
//! minimum-norm solution in the identifiable subspace.
//!
//! Teeth to gaps (the measurement's header): pitch `p = 360 / z`. Counted `table_positive`,
//! tooth `j` (1-based) stands at `tooth_1_table_deg + (j - 1) p`, its right flank faces the
//! gap half a pitch on, its left flank the gap half a pitch back, and a flank's displacement
//! in the table's positive direction is `+Fp`. Counted `table_negative`, the angles run the
//! other way (`- (j - 1) p`), the right flank faces the gap at `- p/2`, the left at `+ p/2`,
//! and the displacement is `-Fp`. A gap's measured error is the mean of the two flanks facing
//! it (each flank's mean removed first); it is matched to the record's gap with the nearest
//! table angle, within a quarter pitch.

use crate::{Counting, Flank, FlankPitch, PitchMeasurement, TEETH_RANGE};
use std::fmt;

/// The cut's record of one gap at one measured height.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GapRecord {
    /// The table's angle, deg, when the gap passed the hob (any multiple of 360 allowed).
    pub table_deg: f64,
    /// The hob's phase, deg, when the gap passed the hob.
    pub hob_phase_deg: f64,
    /// What the controller itself did to the gap, um at the pitch circle, positive where the
    /// table stood ahead (its positive direction).
    pub controller_um: f64,
}

/// One measured height: the checker's measurement there and the cut's record of the gaps in
/// that face section, in table order (gap `i` of every height is the same gap).
#[derive(Debug, Clone, Copy)]
pub struct Height<'a> {
    pub measurement: &'a PitchMeasurement,
    pub gaps: &'a [GapRecord],
}

/// How much of the hob's term the data tell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Identified {
    /// Nothing: the phases do not differ within a gap (a one-start hob; two starts on an even
    /// tooth count; one height). `a` and `b` are zero; what the hob did is in `E`.
    None,
    /// Only the component along this phase (deg, in `[0, 180)`): `a cos + b sin` is known at
    /// this phase and at this phase plus 180 deg; `(a, b)` is the minimum-norm answer.
    Direction { phase_deg: f64 },
    /// Both `a` and `b`.
    Full,
}

/// The hob's once-per-turn error, `H(phi) = a cos(phi) + b sin(phi)`, um at the pitch circle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HobTerm {
    pub a_um: f64,
    pub b_um: f64,
    pub identified: Identified,
}

impl HobTerm {
    /// `H` at the hob's phase `phase_deg`, um.
    pub fn um_at(&self, phase_deg: f64) -> f64 {
        let phi = phase_deg.rem_euclid(360.0).to_radians();
        self.a_um * phi.cos() + self.b_um * phi.sin()
    }
}

/// The measurement split into the table's and the hob's repeatable errors and what does not
/// repeat. Gaps in the first height's record order (table order).
#[derive(Debug, Clone, PartialEq)]
pub struct Decomposition {
    pub teeth: u32,
    /// `theta_i`: the first height's record, as given.
    pub gap_table_deg: Vec<f64>,
    /// Per height, per gap: the record's hob phase, deg.
    pub hob_phase_deg: Vec<Vec<f64>>,
    /// `E_i`, um, mean-free: the table's error that repeats with its angle.
    pub table_error_um: Vec<f64>,
    pub hob: HobTerm,
    /// Per height: the mean over the gaps of `m - c - H`, um. The measurement itself is
    /// mean-free (each flank's `Fp` reference removed), so this is minus the mean of what the
    /// record and the hob term put in: a rotation of that height, no error of the gear.
    pub height_offset_um: Vec<f64>,
    /// Per height, per gap: what does not repeat, `m - c - E - H - o`, um.
    pub residual_um: Vec<Vec<f64>>,
    pub residual_rms_um: f64,
    /// The rms over gaps and heights of the two flanks' difference over two (each flank's
    /// mean removed): the checker's noise as seen.
    pub flank_disagreement_rms_um: f64,
    /// The rms of the controller's share removed, um.
    pub controller_rms_um: f64,
}

impl Decomposition {
    /// f_pt and F_p, um, of the part a compensation removes: `E + H` at the first height's
    /// hob phases, gaps in the order of their table angles.
    pub fn removable_figures_um(&self) -> (f64, f64) {
        let phases = self.hob_phase_deg.first();
        let removable: Vec<f64> = self
            .table_error_um
            .iter()
            .enumerate()
            .map(|(i, e)| {
                let phase = phases.and_then(|p| p.get(i)).copied().unwrap_or(0.0);
                e + self.hob.um_at(phase)
            })
            .collect();
        self.figures(&removable)
    }

    /// f_pt and F_p, um, of the residual: the worst height's each.
    pub fn residual_figures_um(&self) -> (f64, f64) {
        self.residual_um
            .iter()
            .map(|r| self.figures(r))
            .fold((0.0, 0.0), |(f, c), (fh, ch)| (f.max(fh), c.max(ch)))
    }

    /// f_pt (largest neighbour difference, cyclic) and F_p (range) of per-gap positions taken
    /// in the order of the gaps' table angles.
    fn figures(&self, per_gap: &[f64]) -> (f64, f64) {
        let mut order: Vec<usize> = (0..per_gap.len().min(self.gap_table_deg.len())).collect();
        order.sort_by(|&i, &j| {
            let a = self.gap_table_deg[i].rem_euclid(360.0);
            let b = self.gap_table_deg[j].rem_euclid(360.0);
            a.total_cmp(&b)
        });
        let positions: Vec<f64> = order.iter().map(|&i| per_gap[i]).collect();
        let f = FlankPitch::from_positions(&positions);
        (f.single_pitch_um(), f.cumulative_pitch_um())
    }
}

/// Why the measurements cannot be decomposed. `height` is 1-based (the n-th of the heights
/// given), `gap` is 1-based in the record's order, `tooth` is the measurement's tooth number.
#[derive(Debug, Clone, PartialEq)]
pub enum DecomposeError {
    NoHeights,
    /// The hob's starts: zero.
    Starts {
        starts: u32,
    },
    /// A tooth count outside [`TEETH_RANGE`].
    Teeth {
        height: usize,
        teeth: u32,
    },
    TeethDisagree {
        height: usize,
        teeth: u32,
        first: u32,
    },
    GearDisagree {
        height: usize,
        gear: String,
        first: String,
    },
    /// A flank's `Fp` with another number of teeth than the header's.
    FlankLength {
        height: usize,
        flank: Flank,
        len: usize,
        teeth: u32,
    },
    /// A measurement number that is NaN or infinite (`tooth` None: the header's
    /// `tooth_1_table_deg`).
    MeasurementNotFinite {
        height: usize,
        tooth: Option<u32>,
        field: &'static str,
    },
    RecordLength {
        height: usize,
        gaps: usize,
        teeth: u32,
    },
    RecordNotFinite {
        height: usize,
        gap: usize,
        field: &'static str,
    },
    /// The record's gap at this height is not the first height's gap of the same place.
    RecordOrder {
        height: usize,
        gap: usize,
        table_deg: f64,
        first_deg: f64,
    },
    /// The gap between `tooth` and `next_tooth` has no record's gap within a quarter pitch.
    NoGapNear {
        height: usize,
        tooth: u32,
        next_tooth: u32,
        gap_deg: f64,
        nearest_deg: Option<f64>,
        pitch_deg: f64,
    },
    /// Two measured gaps matched the same record's gap.
    GapMatchedTwice {
        height: usize,
        gap: usize,
        tooth: u32,
    },
}

impl fmt::Display for DecomposeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use DecomposeError as E;
        match self {
            E::NoHeights => write!(f, "no measured height given"),
            E::Starts { starts } => write!(f, "the hob's starts: {starts}, at least 1"),
            E::Teeth { height, teeth } => write!(
                f,
                "height {height}, teeth: {teeth}, outside {}..={}",
                TEETH_RANGE.0, TEETH_RANGE.1
            ),
            E::TeethDisagree { height, teeth, first } => {
                write!(f, "height {height}, teeth: {teeth}, but height 1 has {first}")
            }
            E::GearDisagree { height, gear, first } => write!(
                f,
                "height {height}, gear: '{gear}', but height 1 measured '{first}'"
            ),
            E::FlankLength {
                height,
                flank,
                len,
                teeth,
            } => write!(
                f,
                "height {height}, {}_Fp_um: {len} teeth, the header says {teeth}",
                flank.name()
            ),
            E::MeasurementNotFinite {
                height,
                tooth: None,
                field,
            } => write!(f, "height {height}, {field}: not a finite number"),
            E::MeasurementNotFinite {
                height,
                tooth: Some(tooth),
                field,
            } => write!(f, "height {height}, tooth {tooth}, {field}: not a finite number"),
            E::RecordLength { height, gaps, teeth } => write!(
                f,
                "height {height}, the cut's record: {gaps} gaps, the measurement {teeth} teeth"
            ),
            E::RecordNotFinite { height, gap, field } => write!(
                f,
                "height {height}, the record's gap {gap}, {field}: not a finite number"
            ),
            E::RecordOrder {
                height,
                gap,
                table_deg,
                first_deg,
            } => write!(
                f,
                "height {height}, the record's gap {gap} at table {table_deg:.4} deg, but height \
                 1's gap {gap} at {first_deg:.4} deg: not the same gap (records in table order)"
            ),
            E::NoGapNear {
                height,
                tooth,
                next_tooth,
                gap_deg,
                nearest_deg,
                pitch_deg,
            } => {
                write!(
                    f,
                    "height {height}, the gap between tooth {tooth} and tooth {next_tooth} \
                     (table {gap_deg:.4} deg by the header's tooth_1_table_deg and counting): "
                )?;
                match nearest_deg {
                    Some(n) => write!(
                        f,
                        "the record's nearest gap is at {n:.4} deg, more than a quarter pitch \
                         ({:.4} deg) away",
                        pitch_deg / 4.0
                    ),
                    None => write!(f, "no record's gap to compare"),
                }
            }
            E::GapMatchedTwice { height, gap, tooth } => write!(
                f,
                "height {height}, the record's gap {gap} is nearest to two measured gaps (the \
                 second after tooth {tooth})"
            ),
        }
    }
}

impl std::error::Error for DecomposeError {}

/// One measured gap: where the header puts it, its error and its flanks' disagreement.
struct MeasuredGap {
    table_deg: f64,
    error_um: f64,
    disagreement_um: f64,
}

/// The table distance between two angles, deg, in `[0, 180]` (NaN if either is not finite
/// or their difference overflows).
fn apart_deg(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(360.0);
    d.min(360.0 - d)
}

fn mean(v: &[f64]) -> f64 {
    if v.is_empty() {
        0.0
    } else {
        v.iter().sum::<f64>() / v.len() as f64
    }
}

fn rms<'a>(values: impl IntoIterator<Item = &'a f64>) -> f64 {
    let (sum, n) = values
        .into_iter()
        .fold((0.0, 0usize), |(s, n), v| (s + v * v, n + 1));
    if n == 0 { 0.0 } else { (sum / n as f64).sqrt() }
}

/// The measurement's gaps, in the measurement's order: gap `k` (0-based) between tooth `k+1`
/// and tooth `k+2` (1-based, cyclic).
fn measured_gaps(m: &PitchMeasurement, height: usize) -> Result<Vec<MeasuredGap>, DecomposeError> {
    let teeth = m.header.teeth;
    let z = teeth as usize;
    let tooth_1 = m.header.tooth_1_table_deg;
    if !tooth_1.is_finite() {
        return Err(DecomposeError::MeasurementNotFinite {
            height,
            tooth: None,
            field: "tooth_1_table_deg",
        });
    }
    let mut flanks = [Vec::new(), Vec::new()];
    for (slot, flank) in flanks.iter_mut().zip(Flank::BOTH) {
        let fp = &m.flank(flank).cumulative_um;
        if fp.len() != z {
            return Err(DecomposeError::FlankLength {
                height,
                flank,
                len: fp.len(),
                teeth,
            });
        }
        if let Some(k) = fp.iter().position(|v| !v.is_finite()) {
            return Err(DecomposeError::MeasurementNotFinite {
                height,
                tooth: Some(k as u32 + 1),
                field: match flank {
                    Flank::Left => "left_Fp_um",
                    Flank::Right => "right_Fp_um",
                },
            });
        }
        let offset = mean(fp);
        *slot = fp.iter().map(|v| v - offset).collect::<Vec<f64>>();
    }
    let [left, right] = flanks;
    let pitch = 360.0 / teeth as f64;
    let sign = match m.header.counting {
        Counting::TablePositive => 1.0,
        Counting::TableNegative => -1.0,
    };
    Ok((0..z)
        .map(|k| {
            // Tooth k+1's right flank and tooth k+2's left flank face this gap.
            let (r, l) = (right[k], left[(k + 1) % z]);
            MeasuredGap {
                table_deg: tooth_1 + sign * (k as f64 + 0.5) * pitch,
                error_um: sign * (r + l) / 2.0,
                disagreement_um: (r - l) / 2.0,
            }
        })
        .collect())
}

/// Checks one height's record: its length, its numbers, and (after the first) that its gaps
/// are the first height's.
fn check_record(
    gaps: &[GapRecord],
    first: &[GapRecord],
    height: usize,
    teeth: u32,
) -> Result<(), DecomposeError> {
    if gaps.len() != teeth as usize {
        return Err(DecomposeError::RecordLength {
            height,
            gaps: gaps.len(),
            teeth,
        });
    }
    for (i, g) in gaps.iter().enumerate() {
        let field = if !g.table_deg.is_finite() {
            "table_deg"
        } else if !g.hob_phase_deg.is_finite() {
            "hob_phase_deg"
        } else if !g.controller_um.is_finite() {
            "controller_um"
        } else {
            continue;
        };
        return Err(DecomposeError::RecordNotFinite {
            height,
            gap: i + 1,
            field,
        });
    }
    let quarter = 90.0 / teeth as f64;
    for (i, (g, f)) in gaps.iter().zip(first).enumerate() {
        // NaN: a difference that overflows.
        let apart = apart_deg(g.table_deg, f.table_deg);
        if apart.is_nan() || apart > quarter {
            return Err(DecomposeError::RecordOrder {
                height,
                gap: i + 1,
                table_deg: g.table_deg,
                first_deg: f.table_deg,
            });
        }
    }
    Ok(())
}

/// For each of the record's gaps, the measured gap matched to it (nearest table angle, within
/// a quarter pitch; one to one).
fn match_gaps(
    measured: &[MeasuredGap],
    gaps: &[GapRecord],
    height: usize,
    teeth: u32,
) -> Result<Vec<usize>, DecomposeError> {
    let z = teeth as usize;
    let pitch = 360.0 / teeth as f64;
    let mut of_record: Vec<Option<usize>> = vec![None; gaps.len()];
    for (k, m) in measured.iter().enumerate() {
        let mut nearest: Option<(usize, f64)> = None;
        for (i, g) in gaps.iter().enumerate() {
            let d = apart_deg(m.table_deg, g.table_deg);
            if nearest.is_none_or(|(_, best)| d < best) {
                nearest = Some((i, d));
            }
        }
        let tooth = k as u32 + 1;
        let next_tooth = (k as u32 + 1) % teeth + 1;
        match nearest {
            Some((i, d)) if d <= pitch / 4.0 => {
                if of_record[i].is_some() {
                    return Err(DecomposeError::GapMatchedTwice {
                        height,
                        gap: i + 1,
                        tooth,
                    });
                }
                of_record[i] = Some(k);
            }
            _ => {
                return Err(DecomposeError::NoGapNear {
                    height,
                    tooth,
                    next_tooth,
                    gap_deg: m.table_deg,
                    nearest_deg: nearest.map(|(i, _)| gaps[i].table_deg),
                    pitch_deg: pitch,
                });
            }
        }
    }
    // z measured gaps matched one to one onto z record gaps: every one is matched.
    Ok((0..z).map(|i| of_record[i].unwrap_or(0)).collect())
}

/// `x` less its means over the heights (per gap) and over the gaps (per height), plus the
/// grand mean: the part no gap term and no height term explains.
fn double_centred(x: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let nh = x.len();
    let z = x.first().map_or(0, Vec::len);
    let gap_mean: Vec<f64> = (0..z)
        .map(|i| x.iter().map(|row| row[i]).sum::<f64>() / nh as f64)
        .collect();
    let grand = mean(&gap_mean);
    x.iter()
        .map(|row| {
            let height_mean = mean(row);
            row.iter()
                .zip(&gap_mean)
                .map(|(v, g)| v - g - height_mean + grand)
                .collect()
        })
        .collect()
}

/// Splits the measurements at one or more heights of a gear, against the cut's record of
/// those heights, into the table's repeatable error `E`, the hob's once-per-turn term `H`
/// (for `starts` >= 2, as far as the phases tell it) and what does not repeat. See the
/// module's documentation for the model, the conventions and the refusals.
pub fn decompose(heights: &[Height], starts: u32) -> Result<Decomposition, DecomposeError> {
    let first = heights.first().ok_or(DecomposeError::NoHeights)?;
    if starts == 0 {
        return Err(DecomposeError::Starts { starts });
    }
    let teeth = first.measurement.header.teeth;
    if !(TEETH_RANGE.0..=TEETH_RANGE.1).contains(&teeth) {
        return Err(DecomposeError::Teeth { height: 1, teeth });
    }
    let z = teeth as usize;
    let nh = heights.len();

    // y = m - c, the phases and the flanks' disagreement, per height in the record's order.
    let mut y = Vec::with_capacity(nh);
    let mut phase = Vec::with_capacity(nh);
    let mut controller = Vec::with_capacity(nh * z);
    let mut disagreement = Vec::with_capacity(nh * z);
    for (n, h) in heights.iter().enumerate() {
        let height = n + 1;
        let header = &h.measurement.header;
        if header.teeth != teeth {
            return Err(DecomposeError::TeethDisagree {
                height,
                teeth: header.teeth,
                first: teeth,
            });
        }
        if header.gear != first.measurement.header.gear {
            return Err(DecomposeError::GearDisagree {
                height,
                gear: header.gear.clone(),
                first: first.measurement.header.gear.clone(),
            });
        }
        check_record(h.gaps, first.gaps, height, teeth)?;
        let measured = measured_gaps(h.measurement, height)?;
        let matched = match_gaps(&measured, h.gaps, height, teeth)?;
        y.push(
            matched
                .iter()
                .zip(h.gaps)
                .map(|(&k, g)| measured[k].error_um - g.controller_um)
                .collect::<Vec<f64>>(),
        );
        phase.push(h.gaps.iter().map(|g| g.hob_phase_deg).collect::<Vec<f64>>());
        controller.extend(h.gaps.iter().map(|g| g.controller_um));
        disagreement.extend(measured.iter().map(|m| m.disagreement_um));
    }

    let hob = if starts == 1 {
        HobTerm {
            a_um: 0.0,
            b_um: 0.0,
            identified: Identified::None,
        }
    } else {
        fit_hob(&y, &phase)
    };
    let without_hob: Vec<Vec<f64>> = y
        .iter()
        .zip(&phase)
        .map(|(row, ph)| row.iter().zip(ph).map(|(v, p)| v - hob.um_at(*p)).collect())
        .collect();
    let gap_mean: Vec<f64> = (0..z)
        .map(|i| without_hob.iter().map(|row| row[i]).sum::<f64>() / nh as f64)
        .collect();
    let grand = mean(&gap_mean);
    let table_error_um: Vec<f64> = gap_mean.iter().map(|g| g - grand).collect();
    let height_offset_um: Vec<f64> = without_hob.iter().map(|row| mean(row)).collect();
    let residual_um: Vec<Vec<f64>> = without_hob
        .iter()
        .zip(&height_offset_um)
        .map(|(row, o)| row.iter().zip(&table_error_um).map(|(v, e)| v - e - o).collect())
        .collect();

    Ok(Decomposition {
        teeth,
        gap_table_deg: first.gaps.iter().map(|g| g.table_deg).collect(),
        hob_phase_deg: phase,
        residual_rms_um: rms(residual_um.iter().flatten()),
        table_error_um,
        hob,
        height_offset_um,
        residual_um,
        flank_disagreement_rms_um: rms(&disagreement),
        controller_rms_um: rms(&controller),
    })
}

/// `(a, b)` by least squares with the gap and the height terms eliminated, in the subspace
/// the phases identify (minimum norm).
fn fit_hob(y: &[Vec<f64>], phase: &[Vec<f64>]) -> HobTerm {
    let trig = |f: fn(f64) -> f64| -> Vec<Vec<f64>> {
        phase
            .iter()
            .map(|row| row.iter().map(|p| f(p.rem_euclid(360.0).to_radians())).collect())
            .collect()
    };
    let u = double_centred(&trig(f64::cos));
    let v = double_centred(&trig(f64::sin));
    let w = double_centred(y);
    let (mut uu, mut uv, mut vv, mut uw, mut vw) = (0.0, 0.0, 0.0, 0.0, 0.0);
    let mut data = 0usize;
    for ((ur, vr), wr) in u.iter().zip(&v).zip(&w) {
        for ((a, b), c) in ur.iter().zip(vr).zip(wr) {
            uu += a * a;
            uv += a * b;
            vv += b * b;
            uw += a * c;
            vw += b * c;
            data += 1;
        }
    }
    // The symmetric 2x2 [[uu, uv], [uv, vv]]: eigenvalues m +- d, the larger's direction at
    // angle t.
    let m = (uu + vv) / 2.0;
    let d = (((uu - vv) / 2.0).powi(2) + uv * uv).sqrt();
    let t = 0.5 * (2.0 * uv).atan2(uu - vv);
    let directions = [(m + d, (t.cos(), t.sin())), (m - d, (-t.sin(), t.cos()))];
    let floor = 1e-6 * data as f64;
    let (mut a, mut b) = (0.0, 0.0);
    let mut kept = 0;
    for (lambda, (ex, ey)) in directions {
        if lambda >= floor {
            let along = (ex * uw + ey * vw) / lambda;
            a += along * ex;
            b += along * ey;
            kept += 1;
        }
    }
    let identified = match kept {
        0 => Identified::None,
        1 => {
            // rem_euclid of a tiny negative number rounds up to the divisor itself.
            let phase = t.to_degrees().rem_euclid(180.0);
            Identified::Direction {
                phase_deg: if phase >= 180.0 { 0.0 } else { phase },
            }
        }
        _ => Identified::Full,
    };
    HobTerm {
        a_um: a,
        b_um: b,
        identified,
    }
}

#[cfg(test)]
mod tests;
