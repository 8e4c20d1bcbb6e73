//! # hob-gearing: units and the gearing mathematics of hobbing
//!
//! The bottom layer of hob (docs/domain.md, the gearbox law and the process). Pure
//! functions and small `Copy` types: no allocation, no I/O, so the real-time loop can call
//! them every cycle and the planner at start-up.
//!
//! - [`units`]: unit conversions (quantities carry their unit in their name);
//! - [`gearbox`]: the electronic-gearbox law, the helical differential, the helix lead;
//! - [`cutting`]: cutting speed to spindle rpm, table rpm, axial feed;
//! - [`approach`]: approach length of the hob at depth;
//! - [`shapes`]: crowning and contour of the X axis;
//! - [`signs`]: every sign of the set-up from named inputs;
//! - [`iso1328`]: tolerances, to state errors in the user's terms.
//!
//! ```
//! use hob_gearing::cutting::spindle_rpm;
//! // The thesis: v_c = 30 m/min with an 80 mm hob gives 119.366 rpm.
//! assert!((spindle_rpm(30.0, 80.0) - 119.366).abs() < 1e-3);
//! ```

pub mod approach;
pub mod cutting;
pub mod gearbox;
pub mod iso1328;
pub mod serde_arrays;
pub mod shapes;
pub mod signs;
pub mod span;
pub mod units;
