//! The file as a checker writes it (the simulated machine's checker, and tests).

use crate::{COLUMNS, FORMAT_LINE, PitchMeasurement};
use std::fmt::Write as _;

impl PitchMeasurement {
    /// The measurement in its file: the header, the columns, one row per tooth, deviations
    /// to the nanometre.
    pub fn to_file(&self) -> String {
        let h = &self.header;
        let mut s = String::new();
        // Writing into a String cannot fail.
        let _ = writeln!(s, "{FORMAT_LINE}");
        let _ = writeln!(s, "# gear: {}", h.gear);
        let _ = writeln!(s, "# teeth: {}", h.teeth);
        let _ = writeln!(s, "# normal_module_mm: {}", h.normal_module_mm);
        let _ = writeln!(s, "# face_position_mm: {}", h.face_position_mm);
        let _ = writeln!(s, "# tooth_1_table_deg: {}", h.tooth_1_table_deg);
        let _ = writeln!(s, "# counting: {}", h.counting.word());
        let _ = writeln!(s, "# checker: {}", h.checker);
        let _ = writeln!(s, "# measured_at: {}", h.measured_at);
        let _ = writeln!(s, "{COLUMNS}");
        for k in 0..h.teeth as usize {
            let _ = writeln!(
                s,
                "{},{:.3},{:.3},{:.3},{:.3}",
                k + 1,
                self.left.single_um[k],
                self.right.single_um[k],
                self.left.cumulative_um[k],
                self.right.cumulative_um[k]
            );
        }
        s
    }
}
