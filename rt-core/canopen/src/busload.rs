//! Worst-case bus load of a cycle: the bits of each frame with worst-case bit stuffing,
//! cyclic frames every cycle, event-driven frames at most once per inhibit time.

/// Worst-case bits on the wire of an 11-bit-identifier data frame with `n` data bytes,
/// stuffing included: `8n + 47 + floor((34 + 8n - 1) / 4)`.
pub fn frame_bits(n: usize) -> usize {
    8 * n + 47 + (34 + 8 * n - 1) / 4
}

/// One kind of frame on the bus.
#[derive(Debug, Clone, PartialEq)]
pub struct Traffic {
    pub name: String,
    pub bytes: usize,
    /// Frames of this kind per cycle, worst case (1 for cyclic; cycle / inhibit for
    /// event-driven).
    pub per_cycle: f64,
}

impl Traffic {
    pub fn bits_per_cycle(&self) -> f64 {
        frame_bits(self.bytes) as f64 * self.per_cycle
    }
}

/// The load of a set of traffic in one cycle.
#[derive(Debug, Clone, PartialEq)]
pub struct BusLoad {
    pub traffic: Vec<Traffic>,
    pub bits_per_cycle: f64,
    pub capacity_bits: f64,
    pub load: f64,
}

/// Load of `traffic` on a bus of `bitrate_bit_s` with cycle `cycle_s`.
pub fn bus_load(traffic: Vec<Traffic>, bitrate_bit_s: u32, cycle_s: f64) -> BusLoad {
    let bits: f64 = traffic.iter().map(Traffic::bits_per_cycle).sum();
    let capacity = f64::from(bitrate_bit_s) * cycle_s;
    BusLoad {
        traffic,
        bits_per_cycle: bits,
        capacity_bits: capacity,
        load: bits / capacity,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_bits_of_the_formula() {
        assert_eq!(frame_bits(0), 55);
        assert_eq!(frame_bits(4), 95);
        assert_eq!(frame_bits(8), 135);
        // At 1 Mbit/s a 1 ms cycle holds about 8 worst-case 8-byte frames.
        assert_eq!(1000 / frame_bits(8), 7);
    }

    #[test]
    fn load_adds_cyclic_and_event_traffic() {
        let t = vec![
            Traffic {
                name: "SYNC".into(),
                bytes: 0,
                per_cycle: 1.0,
            },
            Traffic {
                name: "status".into(),
                bytes: 2,
                per_cycle: 0.1,
            },
        ];
        let l = bus_load(t, 1_000_000, 0.001);
        assert!((l.bits_per_cycle - 62.5).abs() < 1e-12);
        assert!((l.load - 0.0625).abs() < 1e-12);
    }
}
