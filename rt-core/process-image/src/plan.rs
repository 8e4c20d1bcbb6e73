//! The bus schedule of this machine: which PDOs each node has, their configuration by
//! SDO at start-up, and the worst-case load they put on the bus.
//!
//! Per 1 ms cycle: SYNC; one RPDO per drive (target position, RPDO1, synchronous: applied
//! at the next SYNC); one TPDO per drive (actual position, TPDO1, sent on every SYNC; the
//! table drive's carries the spindle encoder too). Event-driven: mode of operation and
//! controlword (RPDO2, on change, spaced), statusword and mode display (TPDO2, on change,
//! inhibit time), the I/O coupler's inputs (TPDO1, on change, inhibit), outputs and analog
//! outputs (RPDO1/2, on change, spaced); heartbeats slow.
//!
//! X and Y are referenced by the drives' own homing (CiA 402 mode 6): the loop switches
//! them between cyclic synchronous position and homing through RPDO2 and sees the mode
//! they are in through TPDO2, so no SDO is needed while the cycle runs; the homing
//! parameters ([`DriveHoming`]) are written by SDO at start-up.

use hob_canopen::busload::{BusLoad, Traffic, bus_load};
use hob_canopen::cia402::{MODE_CSP, object};
use hob_canopen::frame::{rpdo_id, tpdo_id};
use hob_canopen::pdo::{Direction, MapEntry, Pdo, SdoWrite};
use hob_config::machine::{LinearAxisConfig, MachineConfig, Polarity};
use hob_gearing::units::AxisScale;
use hob_wire::vocab::Axis;

/// Node-ID of the master (its heartbeat COB-ID is 0x700 + this).
pub const MASTER_NODE: u8 = 0x7F;
/// CiA 401 objects of the I/O coupler.
pub const DIGITAL_INPUTS: u16 = 0x6000;
pub const DIGITAL_OUTPUTS: u16 = 0x6200;
pub const ANALOG_OUTPUTS: u16 = 0x6411;
pub const ANALOG_INPUTS: u16 = 0x6401;
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
    /// RPDO2: mode of operation (0x6060, 8 bits) then controlword (0x6040, 16 bits),
    /// event-driven. The mode comes first: a drive that takes the mapped objects in order
    /// is in the new mode when it reads the controlword (whose bit 4 starts homing).
    pub control: Pdo,
    /// TPDO1: position actual (and the spindle encoder on the table drive), every SYNC.
    pub actual: Pdo,
    /// TPDO2: statusword (0x6041, 16 bits) then mode display (0x6061, 8 bits), on change
    /// with inhibit time, and again after [`EVENT_TIMER_MS`] without a change.
    pub status: Pdo,
    /// The homing parameters written at start-up (X and Y; none for the table, which
    /// stays in cyclic synchronous position).
    pub homing: Option<DriveHoming>,
}

/// A linear axis's homing parameters in the drive's own frame and units (counts), as
/// [`BusPlan::node_configuration`] writes them by SDO.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DriveHoming {
    /// 0x6098, in the drive's counting direction: the machine file's method, mirrored
    /// (3 <-> 5, 4 <-> 6) for an axis with inverted polarity ([`drive_homing_method`]).
    pub method: i8,
    /// 0x607C: the position actual value at the home position, counts
    /// (`home_position_mm` as [`AxisScale::to_counts`] converts a target).
    pub home_offset_counts: i32,
    /// 0x6099:1, searching the switch, counts/s.
    pub switch_speed_counts_s: u32,
    /// 0x6099:2, searching the index pulse, counts/s.
    pub zero_speed_counts_s: u32,
    /// 0x609A, counts/s^2.
    pub accel_counts_s2: u32,
}

impl DriveHoming {
    /// Converts `a.homing` with the axis's scale and polarity (the configuration was
    /// validated: positive speeds and acceleration, a method of 3 to 6).
    pub fn from_axis(a: &LinearAxisConfig) -> Self {
        let h = &a.homing;
        let cpm = a.counts_per_mm();
        let scale = AxisScale {
            counts_per_unit: cpm,
            sign: a.polarity.sign(),
        };
        // Rounded to whole counts; a speed below one count per second is still moving.
        let magnitude = |v: f64| (v * cpm).round().clamp(1.0, f64::from(u32::MAX)) as u32;
        Self {
            method: drive_homing_method(h.method, a.polarity),
            home_offset_counts: scale.to_counts(h.home_position_mm),
            switch_speed_counts_s: magnitude(h.switch_search_mm_min / 60.0),
            zero_speed_counts_s: magnitude(h.zero_search_mm_min / 60.0),
            accel_counts_s2: magnitude(h.accel_mm_s2),
        }
    }

    /// The SDO writes, in the order 0x6098, 0x6099:1, 0x6099:2, 0x609A, 0x607C.
    pub fn writes(&self) -> [SdoWrite; 5] {
        let w = SdoWrite::new;
        [
            w(object::HOMING_METHOD, 0, self.method as u8 as u32, 1),
            w(object::HOMING_SPEEDS, 1, self.switch_speed_counts_s, 4),
            w(object::HOMING_SPEEDS, 2, self.zero_speed_counts_s, 4),
            w(object::HOMING_ACCELERATION, 0, self.accel_counts_s2, 4),
            w(object::HOME_OFFSET, 0, self.home_offset_counts as u32, 4),
        ]
    }
}

/// The homing method as the drive must be told it: the machine file names the switch's
/// side in the machine's frame (3, 4: the switch is active on the positive side of its
/// edge; 5, 6: on the negative side; 3 and 5 take the index pulse outside the switch, 4
/// and 6 inside it). A drive with inverted polarity counts the other way, so the
/// machine's positive side is its negative side: 3 <-> 5 and 4 <-> 6, the index pulse on
/// the same side of the edge (outside stays outside). Other methods pass unchanged (the
/// configuration refuses them).
pub fn drive_homing_method(method: i8, polarity: Polarity) -> i8 {
    match (polarity, method) {
        (Polarity::Normal, m) => m,
        (Polarity::Inverted, 3) => 5,
        (Polarity::Inverted, 5) => 3,
        (Polarity::Inverted, 4) => 6,
        (Polarity::Inverted, 6) => 4,
        (Polarity::Inverted, m) => m,
    }
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
    /// TPDO2: the table gauge's analog input (16-bit), synchronous every
    /// [`TABLE_GAUGE_EVERY_SYNCS`] SYNCs; only while the machine file names a gauge
    /// (`io.analog_inputs.table_gauge`, for `hob commission backlash`).
    pub gauge: Option<Pdo>,
}

pub use hob_config::machine::TABLE_GAUGE_EVERY_SYNCS;

impl IoPdos {
    /// The coupler's PDOs for the machine file's node and signals.
    pub fn from_machine(m: &MachineConfig) -> Self {
        let c = &m.can;
        let io = m.io.can_node_id;
        Self {
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
            gauge: m.io.analog_inputs.table_gauge.map(|g| {
                Pdo::new(
                    Direction::Tpdo,
                    2,
                    tpdo_id(2, io),
                    TABLE_GAUGE_EVERY_SYNCS,
                    &[MapEntry::new(ANALOG_INPUTS, g.channel + 1, 16)],
                )
            }),
        }
    }

    /// The coupler's PDOs, the gauge's when it is named.
    pub fn pdos(&self) -> Vec<Pdo> {
        let mut p = vec![self.inputs, self.outputs, self.analog];
        p.extend(self.gauge);
        p
    }
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
    /// The machine file's commissioned gains of the table drive
    /// (`[commissioning.table_drive_gains]`), which the boot writes when they name the
    /// table drive on the bus.
    pub table_drive_gains: Option<crate::gains::CommissionedGains>,
}

impl BusPlan {
    pub fn from_machine(m: &MachineConfig) -> Self {
        let c = &m.can;
        let spindle = MapEntry::new(c.spindle_encoder_index, c.spindle_encoder_subindex, 32);
        let drive = |node: u8, axis: Axis, homing: Option<DriveHoming>| {
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
                    &[
                        MapEntry::new(object::MODES_OF_OPERATION, 0, 8),
                        MapEntry::new(object::CONTROLWORD, 0, 16),
                    ],
                ),
                actual: Pdo::new(Direction::Tpdo, 1, tpdo_id(1, node), 1, &actual),
                status: Pdo::new(
                    Direction::Tpdo,
                    2,
                    tpdo_id(2, node),
                    255,
                    &[
                        MapEntry::new(object::STATUSWORD, 0, 16),
                        MapEntry::new(object::MODES_DISPLAY, 0, 8),
                    ],
                )
                .with_inhibit_100us(c.statusword_inhibit_ms * 10)
                .with_event_timer_ms(EVENT_TIMER_MS),
                homing,
            }
        };
        Self {
            drives: [
                drive(m.table.can_node_id, Axis::B, None),
                drive(m.x.can_node_id, Axis::X, Some(DriveHoming::from_axis(&m.x))),
                drive(m.y.can_node_id, Axis::Y, Some(DriveHoming::from_axis(&m.y))),
            ],
            io: IoPdos::from_machine(m),
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
            table_drive_gains: m
                .commissioning
                .as_ref()
                .and_then(|c| c.table_drive_gains.as_ref())
                .and_then(crate::gains::CommissionedGains::from_record),
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
                if let Some(h) = d.homing {
                    out.extend(h.writes());
                }
                vec![d.target, d.control, d.actual, d.status]
            }
            None if node == self.io.node => self.io.pdos(),
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
                name: format!("{a} RPDO2 mode, controlword"),
                bytes: d.control.len_bytes(),
                per_cycle: per(f64::from(self.event_rpdo_spacing_ms)),
            });
            t.push(Traffic {
                name: format!("{a} TPDO2 statusword, mode"),
                bytes: d.status.len_bytes(),
                per_cycle: per(f64::from(d.status.inhibit_100us) / 10.0),
            });
        }
        let io = &self.io;
        if let Some(g) = io.gauge {
            t.push(Traffic {
                name: "I/O TPDO2 table gauge".into(),
                bytes: g.len_bytes(),
                per_cycle: 1.0 / f64::from(g.transmission_type),
            });
        }
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
            hob_config::machine::HOMING_METHODS,
            hob_canopen::cia402::HOMING_METHODS_SWITCH_AND_INDEX
        );
    }

    use super::*;
    use hob_control::ControlParams as ControlScale;

    fn shipped() -> MachineConfig {
        hob_config::machine::shipped_for_tests()
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
        // three modes of operation and controlwords (1 + 2 bytes) and the outputs (2) and
        // analog outputs (4) every event_rpdo_spacing_ms; three statuswords and mode
        // displays (2 + 1) every statusword_inhibit_ms; the inputs (3) every
        // inputs_inhibit_ms; four nodes' and the master's heartbeats (1) every heartbeat_ms.
        let cycle_ms = f64::from(m.control.cycle_period_us) / 1000.0;
        let every = |ms: u16| cycle_ms / f64::from(ms);
        let c = &m.can;
        assert_eq!((f(2), f(3)), (75.0, 85.0), "a third byte costs 10 bits");
        let event = (3.0 * f(3) + f(2) + f(4)) * every(c.event_rpdo_spacing_ms)
            + 3.0 * f(3) * every(c.statusword_inhibit_ms)
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
    fn a_named_table_gauge_is_mapped_every_50th_sync_and_stays_under_the_limit() {
        let mut m = shipped();
        let plan = BusPlan::from_machine(&m);
        assert_eq!(plan.io.gauge, None);
        assert_eq!(
            plan.node_configuration(m.io.can_node_id)
                .iter()
                .filter(|w| w.index == 0x1A01)
                .count(),
            0
        );
        let before = plan.load().bits_per_cycle;
        m.io.analog_inputs.table_gauge = Some(hob_config::machine::AnalogBinding { channel: 1 });
        let plan = BusPlan::from_machine(&m);
        let g = plan.io.gauge.expect("the gauge's TPDO");
        assert_eq!(
            (g.cob_id, g.transmission_type),
            (0x280 + u16::from(m.io.can_node_id), 50)
        );
        let writes = plan.node_configuration(m.io.can_node_id);
        // 0x1A01 sub 1: 0x6401 sub 2 (channel 1), 16 bits.
        assert!(
            writes
                .iter()
                .any(|w| w.index == 0x1A01 && w.sub == 1 && w.value == 0x6401_0210),
            "{writes:?}"
        );
        let load = plan.load();
        assert!((load.bits_per_cycle - before - worst_case_frame_bits(2) / 50.0).abs() < 1e-9);
        assert!(load.load <= plan.bus_load_limit, "{}", load.load);
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
    fn the_mode_travels_with_the_controlword_and_its_display_with_the_statusword() {
        let plan = BusPlan::from_machine(&shipped());
        for d in plan.drives {
            assert_eq!(
                d.control.entries(),
                [
                    MapEntry::new(object::MODES_OF_OPERATION, 0, 8),
                    MapEntry::new(object::CONTROLWORD, 0, 16)
                ]
            );
            assert_eq!(
                d.status.entries(),
                [
                    MapEntry::new(object::STATUSWORD, 0, 16),
                    MapEntry::new(object::MODES_DISPLAY, 0, 8)
                ]
            );
            let seq = plan.node_configuration(d.node);
            // The mappings as written by SDO: RPDO2 0x1601, TPDO2 0x1A01, two entries each.
            for (map, first, second) in [
                (0x1601, 0x6060_0008, 0x6040_0010),
                (0x1A01, 0x6041_0010, 0x6061_0008),
            ] {
                let subs: Vec<(u8, u32)> = seq
                    .iter()
                    .filter(|w| w.index == map)
                    .map(|w| (w.sub, w.value))
                    .collect();
                assert_eq!(subs, [(0, 0), (1, first), (2, second), (0, 2)], "{map:04X}");
            }
        }
    }

    #[test]
    fn homing_parameters_are_written_in_counts_for_x_and_y_only() {
        let m = shipped();
        let plan = BusPlan::from_machine(&m);
        assert_eq!(plan.drives[0].homing, None, "the table is not homed");
        assert!(
            !plan
                .node_configuration(m.table.can_node_id)
                .iter()
                .any(|w| { [0x6098, 0x6099, 0x609A, 0x607C].contains(&w.index) })
        );
        // Shipped: 3000 counts/mm, normal polarity; X home 240 mm, Y 440 mm; 600 and
        // 60 mm/min, 50 mm/s^2.
        assert_eq!(m.x.counts_per_mm(), 3000.0);
        for (node, home_counts) in [(m.x.can_node_id, 720_000i32), (m.y.can_node_id, 1_320_000)] {
            let seq = plan.node_configuration(node);
            let value = |index: u16, sub: u8| {
                let w: Vec<_> = seq.iter().filter(|w| w.index == index && w.sub == sub).collect();
                assert_eq!(w.len(), 1, "{index:04X}:{sub} of node {node}");
                (w[0].value, w[0].size)
            };
            assert_eq!(value(0x6098, 0), (3, 1));
            assert_eq!(value(0x6099, 1), (30_000, 4), "10 mm/s");
            assert_eq!(value(0x6099, 2), (3_000, 4), "1 mm/s");
            assert_eq!(value(0x609A, 0), (150_000, 4));
            assert_eq!(value(0x607C, 0), (home_counts as u32, 4));
        }
    }

    #[test]
    fn an_inverted_axis_gets_the_mirrored_method_and_a_negative_home_offset() {
        let mut m = shipped();
        m.x.polarity = Polarity::Inverted;
        m.x.homing.home_position_mm = 100.25;
        for (machine, drive) in [(3, 5), (4, 6), (5, 3), (6, 4)] {
            m.x.homing.method = machine;
            let h = BusPlan::from_machine(&m).drives[1].homing.expect("X is homed");
            assert_eq!(h.method, drive, "machine method {machine}");
            // The same counts as a target at 100.25 mm: the loop's own scale.
            assert_eq!(h.home_offset_counts, -300_750);
            assert_eq!(
                h.home_offset_counts,
                ControlScale::from_machine(&m).x.to_counts(100.25)
            );
            // Speeds are magnitudes: the polarity does not change them.
            assert_eq!((h.switch_speed_counts_s, h.zero_speed_counts_s), (30_000, 3_000));
            let w = h.writes();
            assert_eq!((w[0].index, w[0].value), (0x6098, drive as u8 as u32));
            assert_eq!((w[4].index, w[4].value), (0x607C, (-300_750i32) as u32));
            // Y, normal, keeps the machine's method.
            assert_eq!(
                BusPlan::from_machine(&m).drives[2].homing.map(|h| h.method),
                Some(3)
            );
        }
    }

    #[test]
    fn the_machine_files_homing_methods_are_the_protocols() {
        assert_eq!(
            hob_config::machine::HOMING_METHODS,
            hob_canopen::cia402::HOMING_METHODS_SWITCH_AND_INDEX
        );
        for m in hob_canopen::cia402::HOMING_METHODS_SWITCH_AND_INDEX {
            let mirrored = drive_homing_method(m, Polarity::Inverted);
            assert_ne!(mirrored, m);
            assert_eq!(drive_homing_method(mirrored, Polarity::Inverted), m);
            assert_eq!(drive_homing_method(m, Polarity::Normal), m);
        }
    }

    #[test]
    fn analog_scaling() {
        let plan = BusPlan::from_machine(&shipped());
        assert_eq!(plan.analog_counts(10.0), 32767);
        assert_eq!(plan.analog_counts(5.0), 16384);
        assert_eq!(plan.analog_counts(-1.0), 0);
    }
}
