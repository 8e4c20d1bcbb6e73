//! Faults and refusals on the real-time path: `Copy` enums with fields, no strings. They
//! are the wire's vocabulary ([`hob_wire::vocab`]), declared once for the control core and
//! every process that reads the loop.

pub use hob_wire::vocab::{Axis, End, Fault, HomingFailure, Refusal};
