//! The bus schedule of this machine: which PDOs each node has, their configuration by
//! SDO at start-up, and the worst-case load they put on the bus.
//!
//! Per 1 ms cycle: SYNC; one RPDO per drive (target position, RPDO1, synchronous: applied
//! at the next SYNC); one TPDO per drive (actual position, TPDO1, sent on every SYNC; the
//! table drive's carries the spindle encoder too). Event-driven: controlword (RPDO2,
//! on change, spaced), statusword (TPDO2, on change, inhibit time), the I/O coupler's
//! inputs (TPDO1, on change, inhibit), outputs and analog outputs (RPDO1/2, on change,
//! spaced); heartbeats slow.

use hob_canopen::busload::{BusLoad, Traffic, bus_load};
use hob_canopen::cia402::{MODE_CSP, object};
use hob_canopen::frame::{rpdo_id, tpdo_id};
use hob_canopen::pdo::{Direction, MapEntry, Pdo, SdoWrite};
use hob_control::fault::Axis;
use hob_setup::config::machine::MachineConfig;

/// Node-ID of the master (its heartbeat COB-ID is 0x700 + this).
pub const MASTER_NODE: u8 = 0x7F;
/// CiA 401 objects of the I/O coupler.
pub const DIGITAL_INPUTS: u16 = 0x6000;
pub const DIGITAL_OUTPUTS: u16 = 0x6200;
pub const ANALOG_OUTPUTS: u16 = 0x6411;
/// Event timer of the event-driven TPDOs (statusword, inputs): sent again after this
/// long without a change, so a lost frame cannot leave the master with a stale state.
/// Below the inhibit-time rate, so the worst case per cycle stays 1 / inhibit time.
pub const EVENT_TIMER_MS: u16 = 100;
/// Device profile numbers in the low 16 bits of 0x1000.
pub const PROFILE_DRIVE: u32 = 402;
pub const PROFILE_IO: u32 = 401;

/// The PDOs of one drive.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DrivePdos {
    pub node: u8,
    pub axis: Axis,
    /// RPDO1: target position (and velocity offset if configured), synchronous.
    pub target: Pdo,
    /// RPDO2: controlword, event-driven.
    pub control: Pdo,
    /// TPDO1: position actual (and the spindle encoder on the table drive), every SYNC.
    pub actual: Pdo,
    /// TPDO2: statusword, on change with inhibit time, and again after [`EVENT_TIMER_MS`]
    /// without a change.
    pub status: Pdo,
}

/// The PDOs of the I/O coupler.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IoPdos {
    pub node: u8,
    /// TPDO1: 3 x 8 digital inputs, on change with inhibit time.
    pub inputs: Pdo,
    /// RPDO1: 2 x 8 digital outputs, on change.
    pub outputs: Pdo,
    /// RPDO2: 2 analog outputs (16-bit), on change.
    pub analog: Pdo,
}

/// The bus of this machine.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BusPlan {
    /// Table (B), X, Y.
    pub drives: [DrivePdos; 3],
    pub io: IoPdos,
    pub cycle_s: f64,
    pub bitrate_bit_s: u32,
    pub heartbeat_ms: u16,
    pub heartbeat_timeout_ms: u16,
    pub event_rpdo_spacing_ms: u16,
    pub tpdo_misses_to_fault: u32,
    pub velocity_feed_forward: bool,
    pub spindle_encoder: MapEntry,
    pub bus_load_limit: f64,
    /// Analog output channel of the spindle speed reference.
    pub spindle_analog_channel: u8,
    pub analog_full_scale_v: f64,
}

impl BusPlan {
    pub fn from_machine(m: &MachineConfig) -> Self {
        let c = &m.can;
        let spindle = MapEntry::new(c.spindle_encoder_index, c.spindle_encoder_subindex, 32);
        let drive = |node: u8, axis: Axis| {
            let mut target = vec![MapEntry::new(object::TARGET_POSITION, 0, 32)];
            if c.velocity_feed_forward_in_pdo {
                target.push(MapEntry::new(object::VELOCITY_OFFSET, 0, 32));
            }
            let mut actual = vec![MapEntry::new(object::POSITION_ACTUAL, 0, 32)];
            if axis == Axis::B {
                actual.push(spindle);
            }
            DrivePdos {
                node,
                axis,
                target: Pdo::new(Direction::Rpdo, 1, rpdo_id(1, node), 1, &target),
                control: Pdo::new(
                    Direction::Rpdo,
                    2,
                    rpdo_id(2, node),
                    255,
                    &[MapEntry::new(object::CONTROLWORD, 0, 16)],
                ),
                actual: Pdo::new(Direction::Tpdo, 1, tpdo_id(1, node), 1, &actual),
                status: Pdo::new(
                    Direction::Tpdo,
                    2,
                    tpdo_id(2, node),
                    255,
                    &[MapEntry::new(object::STATUSWORD, 0, 16)],
                )
                .with_inhibit_100us(c.statusword_inhibit_ms * 10)
                .with_event_timer_ms(EVENT_TIMER_MS),
            }
        };
        let io = m.io.can_node_id;
        Self {
            drives: [
                drive(m.table.can_node_id, Axis::B),
                drive(m.x.can_node_id, Axis::X),
                drive(m.y.can_node_id, Axis::Y),
            ],
            io: IoPdos {
                node: io,
                inputs: Pdo::new(
                    Direction::Tpdo,
                    1,
                    tpdo_id(1, io),
                    255,
                    &[
                        MapEntry::new(DIGITAL_INPUTS, 1, 8),
                        MapEntry::new(DIGITAL_INPUTS, 2, 8),
                        MapEntry::new(DIGITAL_INPUTS, 3, 8),
                    ],
                )
                .with_inhibit_100us(c.inputs_inhibit_ms * 10)
                .with_event_timer_ms(EVENT_TIMER_MS),
                outputs: Pdo::new(
                    Direction::Rpdo,
                    1,
                    rpdo_id(1, io),
                    255,
                    &[
                        MapEntry::new(DIGITAL_OUTPUTS, 1, 8),
                        MapEntry::new(DIGITAL_OUTPUTS, 2, 8),
                    ],
                ),
                analog: Pdo::new(
                    Direction::Rpdo,
                    2,
                    rpdo_id(2, io),
                    255,
                    &[
                        MapEntry::new(ANALOG_OUTPUTS, 1, 16),
                        MapEntry::new(ANALOG_OUTPUTS, 2, 16),
                    ],
                ),
            },
            cycle_s: f64::from(m.control.cycle_period_us) * 1e-6,
            bitrate_bit_s: c.bitrate_bit_s,
            heartbeat_ms: c.heartbeat_ms,
            heartbeat_timeout_ms: c.heartbeat_timeout_ms,
            event_rpdo_spacing_ms: c.event_rpdo_spacing_ms,
            tpdo_misses_to_fault: c.tpdo_misses_to_fault,
            velocity_feed_forward: c.velocity_feed_forward_in_pdo,
            spindle_encoder: spindle,
            bus_load_limit: c.bus_load_limit,
            spindle_analog_channel: m.io.analog_outputs.spindle_speed.channel,
            analog_full_scale_v: m.spindle.analog_full_scale_v,
        }
    }

    /// Every node-ID on the bus (drives, then the coupler).
    pub fn nodes(&self) -> [u8; 4] {
        [
            self.drives[0].node,
            self.drives[1].node,
            self.drives[2].node,
            self.io.node,
        ]
    }

    pub fn drive(&self, node: u8) -> Option<&DrivePdos> {
        self.drives.iter().find(|d| d.node == node)
    }

    /// The SDO writes that configure `node` at start-up (in pre-operational).
    pub fn node_configuration(&self, node: u8) -> Vec<SdoWrite> {
        let w = SdoWrite::new;
        let mut out = vec![
            // The SYNC period (us), for the nodes' own SYNC monitoring.
            w(0x1006, 0, (self.cycle_s * 1e6).round() as u32, 4),
            // Heartbeat producer, and consumer of the master's heartbeat.
            w(0x1017, 0, u32::from(self.heartbeat_ms), 2),
            w(
                0x1016,
                1,
                u32::from(MASTER_NODE) << 16 | u32::from(self.heartbeat_timeout_ms),
                4,
            ),
        ];
        let pdos: Vec<Pdo> = match self.drive(node) {
            Some(d) => {
                out.push(w(object::MODES_OF_OPERATION, 0, MODE_CSP as u8 as u32, 1));
                // Interpolation time period: 1 x 10^-3 s.
                let (mant, exp) = interpolation_period(self.cycle_s);
                out.push(w(object::INTERPOLATION_PERIOD, 1, u32::from(mant), 1));
                out.push(w(object::INTERPOLATION_PERIOD, 2, exp as u8 as u32, 1));
                vec![d.target, d.control, d.actual, d.status]
            }
            None if node == self.io.node => vec![self.io.inputs, self.io.outputs, self.io.analog],
            None => Vec::new(),
        };
        for p in pdos {
            out.extend(p.configuration());
        }
        out
    }

    /// Worst-case traffic of one cycle.
    pub fn traffic(&self) -> Vec<Traffic> {
        let cycle_ms = self.cycle_s * 1000.0;
        let per = |ms: f64| (cycle_ms / ms.max(cycle_ms)).min(1.0);
        let mut t = vec![Traffic {
            name: "SYNC".into(),
            bytes: 0,
            per_cycle: 1.0,
        }];
        for d in &self.drives {
            let a = d.axis.name();
            t.push(Traffic {
                name: format!("{a} RPDO1 target"),
                bytes: d.target.len_bytes(),
                per_cycle: 1.0,
            });
            t.push(Traffic {
                name: format!("{a} TPDO1 actual"),
                bytes: d.actual.len_bytes(),
                per_cycle: 1.0,
            });
            t.push(Traffic {
                name: format!("{a} RPDO2 controlword"),
                bytes: d.control.len_bytes(),
                per_cycle: per(f64::from(self.event_rpdo_spacing_ms)),
            });
            t.push(Traffic {
                name: format!("{a} TPDO2 statusword"),
                bytes: d.status.len_bytes(),
                per_cycle: per(f64::from(d.status.inhibit_100us) / 10.0),
            });
        }
        let io = &self.io;
        t.push(Traffic {
            name: "I/O TPDO1 inputs".into(),
            bytes: io.inputs.len_bytes(),
            per_cycle: per(f64::from(io.inputs.inhibit_100us) / 10.0),
        });
        for (name, p) in [("I/O RPDO1 outputs", io.outputs), ("I/O RPDO2 analog", io.analog)] {
            t.push(Traffic {
                name: name.into(),
                bytes: p.len_bytes(),
                per_cycle: per(f64::from(self.event_rpdo_spacing_ms)),
            });
        }
        t.push(Traffic {
            name: "heartbeats (4 nodes + master)".into(),
            bytes: 1,
            per_cycle: 5.0 * per(f64::from(self.heartbeat_ms)),
        });
        t
    }

    pub fn load(&self) -> BusLoad {
        bus_load(self.traffic(), self.bitrate_bit_s, self.cycle_s)
    }

    /// Analog output value (CiA 401 integer, full scale 0x7FFF) for a voltage.
    pub fn analog_counts(&self, volts: f64) -> i16 {
        (volts / self.analog_full_scale_v * 32767.0)
            .round()
            .clamp(0.0, 32767.0) as i16
    }
}

/// 0x60C2: the period as mantissa x 10^exponent seconds.
fn interpolation_period(cycle_s: f64) -> (u8, i8) {
    let mut exp = 0i8;
    let mut v = cycle_s;
    while (v - v.round()).abs() > 1e-9 && exp > -6 {
        v *= 10.0;
        exp -= 1;
    }
    while v > 255.0 && exp < 0 {
        v /= 10.0;
        exp += 1;
    }
    (v.round() as u8, exp)
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_machine_file_accepts_exactly_the_homing_methods_the_protocol_names() {
        // hob-setup keeps its own copy (it depends on no protocol crate).
        assert_eq!(
            hob_setup::config::machine::HOMING_METHODS,
            hob_canopen::cia402::HOMING_METHODS_SWITCH_AND_INDEX
        );
    }

    use super::*;

    fn shipped() -> MachineConfig {
        hob_setup::config::machine::shipped_for_tests()
    }

    /// Worst-case bits of a CAN 2.0A data frame with `n` data bytes, counted field by
    /// field (ISO 11898-1), not with the library's formula: SOF 1, identifier 11, RTR 1,
    /// IDE 1, r0 1, DLC 4, data 8n, CRC 15 are the 34 + 8n bits subject to stuffing (at
    /// worst one stuff bit after the first 5 and then after every 4 more:
    /// (34 + 8n - 1) / 4); CRC delimiter 1, ACK 2, EOF 7 and intermission 3 are not.
    fn worst_case_frame_bits(n: usize) -> f64 {
        let stuffed = 1 + 11 + 1 + 1 + 1 + 4 + 8 * n + 15;
        let fixed = 1 + 2 + 7 + 3;
        (stuffed + (stuffed - 1) / 4 + fixed) as f64
    }

    #[test]
    fn the_shipped_schedule_fits_under_the_limit() {
        let m = shipped();
        let plan = BusPlan::from_machine(&m);
        let load = plan.load();
        assert!(load.load <= plan.bus_load_limit, "{}", load.load);
        // The schedule derived from the machine file by hand. Cyclic: SYNC (0 bytes),
        // three target RPDOs (0x607A, 4 bytes), the table's TPDO (0x6064 + spindle
        // encoder, 8 bytes) and X's and Y's (0x6064, 4 bytes).
        let f = worst_case_frame_bits;
        let cyclic = f(0) + 3.0 * f(4) + f(8) + 2.0 * f(4);
        assert_eq!(cyclic, 665.0, "55 + 3 x 95 + 135 + 2 x 95 bits");
        let plan_cyclic: f64 = load
            .traffic
            .iter()
            .filter(|t| t.per_cycle == 1.0)
            .map(|t| t.bits_per_cycle())
            .sum();
        assert_eq!(plan_cyclic, cyclic, "{:#?}", load.traffic);
        // Event-driven, at most once per spacing or inhibit time (cycle / time per cycle):
        // three controlwords (2 bytes) and the outputs (2) and analog outputs (4) every
        // event_rpdo_spacing_ms; three statuswords (2) every statusword_inhibit_ms; the
        // inputs (3) every inputs_inhibit_ms; four nodes' and the master's heartbeats (1)
        // every heartbeat_ms.
        let cycle_ms = f64::from(m.control.cycle_period_us) / 1000.0;
        let every = |ms: u16| cycle_ms / f64::from(ms);
        let c = &m.can;
        let event = (3.0 * f(2) + f(2) + f(4)) * every(c.event_rpdo_spacing_ms)
            + 3.0 * f(2) * every(c.statusword_inhibit_ms)
            + f(3) * every(c.inputs_inhibit_ms)
            + 5.0 * f(1) * every(c.heartbeat_ms);
        let bits = cyclic + event;
        assert!(
            (load.bits_per_cycle - bits).abs() < 1e-9,
            "plan {} bits per cycle, derived {bits}: {:#?}",
            load.bits_per_cycle,
            load.traffic
        );
        let capacity = f64::from(c.bitrate_bit_s) * cycle_ms / 1000.0;
        assert!((load.load - bits / capacity).abs() < 1e-12, "{}", load.load);
    }

    #[test]
    fn velocity_feed_forward_in_the_pdo_is_over_the_limit() {
        let mut m = shipped();
        m.can.velocity_feed_forward_in_pdo = true;
        let plan = BusPlan::from_machine(&m);
        assert_eq!(plan.drives[0].target.len_bytes(), 8);
        assert!(plan.load().load > 0.70);
    }

    #[test]
    fn drive_configuration_sets_csp_and_the_interpolation_period() {
        let plan = BusPlan::from_machine(&shipped());
        let seq = plan.node_configuration(2);
        assert!(seq.iter().any(|w| w.index == 0x6060 && w.value == 8));
        assert!(
            seq.iter()
                .any(|w| w.index == 0x60C2 && w.sub == 1 && w.value == 1)
        );
        assert!(
            seq.iter()
                .any(|w| w.index == 0x60C2 && w.sub == 2 && w.value == 0xFD),
            "10^-3"
        );
        assert!(
            seq.iter()
                .any(|w| w.index == 0x1A00 && w.sub == 2 && w.value == 0x2112_0020),
            "spindle encoder on B"
        );
        assert!(!plan.node_configuration(3).iter().any(|w| w.value == 0x2112_0020));
        assert_eq!(interpolation_period(0.0005), (5, -4));
    }

    #[test]
    fn event_driven_tpdos_are_sent_again_without_a_change() {
        // A lost statusword or inputs frame would otherwise leave the master with a
        // stale state until the next change (a drive it never sees enabled).
        let plan = BusPlan::from_machine(&shipped());
        for node in plan.drives.map(|d| d.node) {
            let seq = plan.node_configuration(node);
            assert!(
                seq.iter()
                    .any(|w| w.index == 0x1801 && w.sub == 5 && w.value == u32::from(EVENT_TIMER_MS)),
                "statusword TPDO2 of node {node}: {seq:?}"
            );
        }
        let io = plan.node_configuration(plan.io.node);
        assert!(
            io.iter()
                .any(|w| w.index == 0x1800 && w.sub == 5 && w.value == u32::from(EVENT_TIMER_MS))
        );
    }

    #[test]
    fn analog_scaling() {
        let plan = BusPlan::from_machine(&shipped());
        assert_eq!(plan.analog_counts(10.0), 32767);
        assert_eq!(plan.analog_counts(5.0), 16384);
        assert_eq!(plan.analog_counts(-1.0), 0);
    }
}
