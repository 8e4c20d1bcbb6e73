//! The simulation's random numbers: xorshift64*, deterministic for a seed, so that a run
//! with the same plant file repeats exactly (power-on positions, SYNC timing, the worm
//! wheel's tooth errors).

/// The next uniform number in [0, 1) from `state` (never 0: seed it with `| 1`).
pub fn uniform(state: &mut u64) -> f64 {
    *state ^= *state >> 12;
    *state ^= *state << 25;
    *state ^= *state >> 27;
    (state.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
}
