//! # hob-plant: the simulated hobbing machine
//!
//! The physics the control core is closed against before any bus or process exists, and
//! reused later by the virtual machine on the CAN bus:
//! - [`spindle`]: VFD ramp, induction motor with slip, cutting torque at the gash frequency;
//! - [`servo`]: CSP drives (targets at SYNC, interpolation), P/PI cascade with velocity
//!   feed-forward, torque limit, encoder quantisation;
//! - [`drive`]: what a CiA 402 drive adds: its incremental position counter, the modes
//!   cyclic synchronous position and homing (methods 3 to 6 on the home switch and the
//!   index pulse), the fault at a hardware limit;
//! - [`worm`]: the table's worm drive: the wheel's pitch errors, the worm's runout, the
//!   mesh's compliance and backlash, which the motor encoder does not see;
//! - [`worklink`]: the work's torsional deflection under the cut (seed 003, about 20 Hz);
//! - [`machine`]: the whole machine with its I/O (limit switches, lube pressure switch,
//!   clamp, safety chain with a stop-category-1 delay) and fault injection;
//! - [`disturbance`]: the disturbance levels (none, nominal, heavy, measured SYNC) and
//!   the goal grade each is held to;
//! - [`sim`]: core against plant, faster than real time, with SYNC jitter; traces and
//!   the accuracy summary of `hob simulate`;
//! - [`checker`]: the gear checker that measures the finished gear's pitch and writes a
//!   shop checker's file.

pub mod checker;
pub mod config;
pub mod cutter;
pub mod disturbance;
pub mod drive;
pub mod plant;
pub mod rng;
pub mod servo;
pub mod sim;
pub mod spindle;
pub mod worklink;
pub mod worm;
