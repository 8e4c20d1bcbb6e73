//! A gear checker's pitch measurement: per tooth, the left and the right flank's single
//! pitch deviation `fp` and cumulative pitch deviation `Fp` (ISO 1328-1), in the file a shop's
//! checker exports for hob (`docs/gear-measurement.md`): a documented CSV with a header of
//! `# key: value` lines. Read with a refusal that names the line and the field; written the
//! same way by the simulated machine's checker.
//!
//! Conventions (the file's and this crate's):
//! - Deviations in um at the reference circle, positive where the actual pitch is larger
//!   than the theoretical one (ISO 1328-1, each flank's pitches counted in the direction of
//!   the tooth numbers).
//! - `fp` of tooth k is the pitch from tooth k-1 to tooth k (tooth 0 is tooth z); `Fp` of
//!   tooth k is the position of tooth k's flank against its theoretical place. A common offset
//!   of a flank's `Fp` is the gear's rotation and carries no information: the file's `Fp`
//!   may have any, and consecutive `Fp` must differ by `fp` to within the file's rounding
//!   (half a unit of the last decimal written, of each of the three numbers).
//! - The tooth numbers are tied to the table by the header: tooth 1 stood at the hob with
//!   the table at `tooth_1_table_deg` (the operator's mark, made before unclamping), and the
//!   numbers run in the table's positive or negative direction (`counting`).
//! - [`mod@decompose`] splits a measurement into the table's and the hob's errors (issue 34).

pub mod decompose;
mod error;
mod parse;
mod write;

pub use decompose::{DecomposeError, Decomposition, GapRecord, Height, HobTerm, Identified, decompose};
pub use error::MeasurementError;
pub use parse::parse;

/// The file's first line: its format and version.
pub const FORMAT_LINE: &str = "# hob gear measurement 1";
/// The column header, exactly.
pub const COLUMNS: &str = "tooth,left_fp_um,right_fp_um,left_Fp_um,right_Fp_um";
/// The fewest and the most teeth a measurement may have.
pub const TEETH_RANGE: (u32, u32) = (3, 1000);
/// The largest deviation accepted, um: three times grade 11's F_p on the shipped 85 mm spur
/// (about 166 um, ISO 1328-1), so that a file in mm or nm is refused rather than read as um.
pub const MAX_DEVIATION_UM: f64 = 500.0;
/// Left or right flank, as seen from the gear's datum face (ISO 1328-1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Flank {
    Left,
    Right,
}

impl Flank {
    pub const BOTH: [Flank; 2] = [Flank::Left, Flank::Right];

    pub fn name(self) -> &'static str {
        match self {
            Flank::Left => "left",
            Flank::Right => "right",
        }
    }
}

/// Which way the tooth numbers run with the gear on the table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Counting {
    /// Tooth k+1 follows tooth k where the table turns positive.
    TablePositive,
    TableNegative,
}

impl Counting {
    pub fn word(self) -> &'static str {
        match self {
            Counting::TablePositive => "table_positive",
            Counting::TableNegative => "table_negative",
        }
    }
}

/// What the header says about the gear and the measurement.
#[derive(Debug, Clone, PartialEq)]
pub struct Header {
    /// The gear as the program names it (`[gear] name` of the program file).
    pub gear: String,
    pub teeth: u32,
    pub normal_module_mm: f64,
    /// The height of the measurement above the datum face, mm.
    pub face_position_mm: f64,
    /// The table's angle, deg, with tooth 1 at the hob (the mark).
    pub tooth_1_table_deg: f64,
    pub counting: Counting,
    /// The checker (maker, model, or the simulation), free text.
    pub checker: String,
    /// When it was measured, as the checker wrote it (ISO 8601 expected, not interpreted).
    pub measured_at: String,
}

/// One flank's deviations, tooth 1 first.
#[derive(Debug, Clone, PartialEq)]
pub struct FlankPitch {
    /// Single pitch deviations `fp`, um.
    pub single_um: Vec<f64>,
    /// Cumulative pitch deviations `Fp`, um (the file's offset kept).
    pub cumulative_um: Vec<f64>,
}

impl FlankPitch {
    /// From the flanks' positions against their theoretical places, um, tooth 1 first:
    /// `fp_k = p_k - p_(k-1)`, `Fp_k = p_k - p_z` (tooth z the reference, `Fp_z = 0`).
    pub fn from_positions(position_um: &[f64]) -> Self {
        let z = position_um.len();
        let Some(&last) = position_um.last() else {
            return Self {
                single_um: Vec::new(),
                cumulative_um: Vec::new(),
            };
        };
        Self {
            single_um: (0..z)
                .map(|k| position_um[k] - position_um[(k + z - 1) % z])
                .collect(),
            cumulative_um: position_um.iter().map(|p| p - last).collect(),
        }
    }

    /// The largest single pitch deviation in magnitude, um (ISO 1328-1's f_pt).
    pub fn single_pitch_um(&self) -> f64 {
        self.single_um.iter().fold(0.0, |m, v| m.max(v.abs()))
    }

    /// The range of the cumulative pitch deviations, um (ISO 1328-1's F_p).
    pub fn cumulative_pitch_um(&self) -> f64 {
        let max = self
            .cumulative_um
            .iter()
            .copied()
            .fold(f64::NEG_INFINITY, f64::max);
        let min = self.cumulative_um.iter().copied().fold(f64::INFINITY, f64::min);
        if max >= min { max - min } else { 0.0 }
    }
}

/// A gear checker's pitch measurement of one gear.
#[derive(Debug, Clone, PartialEq)]
pub struct PitchMeasurement {
    pub header: Header,
    pub left: FlankPitch,
    pub right: FlankPitch,
}

impl PitchMeasurement {
    pub fn flank(&self, flank: Flank) -> &FlankPitch {
        match flank {
            Flank::Left => &self.left,
            Flank::Right => &self.right,
        }
    }

    /// The gear's f_pt and F_p, um: the worse flank's each.
    pub fn figures_um(&self) -> (f64, f64) {
        let fpt = self.left.single_pitch_um().max(self.right.single_pitch_um());
        let fp = self
            .left
            .cumulative_pitch_um()
            .max(self.right.cumulative_pitch_um());
        (fpt, fp)
    }
}

#[cfg(test)]
mod tests;
