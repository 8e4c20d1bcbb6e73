//! # hob-rt-core: the library of the hob gear-hobbing controller
//!
//! Layers, from the bottom:
//! - [`units`]: unit conversions (quantities carry their unit in their name);
//! - [`gearing`]: the gearing mathematics of hobbing (electronic-gearbox law, helical
//!   differential, cutting speeds, approach lengths, crowning and contour shapes), pure
//!   functions without allocation, usable from the real-time loop;
//! - [`config`]: the machine configuration (`config/machine.toml`), loaded with serde and
//!   validated completely, errors naming key and position;
//! - [`job`]: the operator's program (job) file;
//! - [`planner`]: turns a job on a machine into passes, positions, speeds and times, and
//!   refuses a job the machine cannot cut.
//!
//! ```
//! use hob_rt_core::gearing::cutting::spindle_rpm;
//! // The thesis: v_c = 30 m/min with an 80 mm hob gives 119.366 rpm.
//! assert!((spindle_rpm(30.0, 80.0) - 119.366).abs() < 1e-3);
//! ```

pub mod canopen;
pub mod config;
pub mod control;
pub mod gearing;
pub mod job;
pub mod planner;
pub mod service;
pub mod units;
