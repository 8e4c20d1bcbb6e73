//! The gearing mathematics of hobbing (domain.md sections 3 and 4).
//!
//! Pure functions and small `Copy` types: no allocation, no I/O, so the real-time loop
//! can call them every cycle.

pub mod approach;
pub mod cutting;
pub mod gearbox;
pub mod iso1328;
pub mod shapes;
pub mod signs;
