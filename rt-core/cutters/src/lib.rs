//! Profile disk cutters for the tooth-by-tooth cycle (docs/domain.md section 5, issue 17).
//!
//! - [`profile`]: a cutter's profile in its axial plane as a chain of line and arc
//!   primitives (seed 001: Milutinovic et al., Tehnika 2022), validated, and discretised
//!   with the node points kept;
//! - [`space`]: the tooth space of a gear that the profile must cut (the involute flanks,
//!   the form circle, the root);
//! - [`design`]: a cutter profile designed for a gear, each flank's involute approximated by
//!   circular arcs, with the approximation's deviation against ISO 1328-1's profile form
//!   tolerance;
//! - [`dynamics`]: the cutter as seed 003's second-order link, its side deflection in the cut
//!   (the flank's profile error) and the cutting speeds that keep it within a limit;
//! - [`fit`]: how far a profile is from a gear's involute (a library cutter on a program's gear);
//! - [`grind`]: the edge on the rake face, the grinding wheel's path and its 3+2-axis G-code
//!   (seed 001).
//!
//! Pure geometry: no I/O, no allocation but the results' vectors.

pub mod design;
pub mod dynamics;
pub mod fit;
pub mod geometry;
pub mod grind;
pub mod profile;
pub mod space;
