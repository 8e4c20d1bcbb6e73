//! `#[repr(C)]`, fixed-size message types. Flags are `u8`/`u32` and enums are codes, so
//! the layout is the same in every process built from this crate.

use iceoryx2_bb_derive_macros::ZeroCopySend;
use iceoryx2_bb_elementary_traits::zero_copy_send::ZeroCopySend;
use serde::{Deserialize, Serialize};

/// Capacity of the text of a command request (a program file's TOML).
pub const REQUEST_TEXT_BYTES: usize = 16 * 1024;
/// Capacity of the text of a command response (the reasons of a refusal).
pub const RESPONSE_TEXT_BYTES: usize = 4 * 1024;
/// Capacity of an event's message text.
pub const EVENT_TEXT_BYTES: usize = 120;

/// A table of codes declared once: each code's constant, its word, and every code in
/// order (`ALL`); `name` gives the word of a code (`None`: one this build does not know).
macro_rules! code_table {
    (
        $(#[$doc:meta])*
        pub mod $table:ident: $ty:ty {
            $( $(#[$cdoc:meta])* $name:ident = $code:literal, $word:literal; )*
        }
    ) => {
        $(#[$doc])*
        pub mod $table {
            $( $(#[$cdoc])* pub const $name: $ty = $code; )*

            /// Every code, in code order.
            pub const ALL: [$ty; [$(stringify!($name)),*].len()] = [$($name),*];

            /// The code's word (`None`: a code this build does not know).
            pub const fn name(code: $ty) -> Option<&'static str> {
                match code {
                    $( $code => Some($word), )*
                    _ => None,
                }
            }
        }
    };
}

/// Copies `s` into `buf` (cut at a character boundary if too long); returns the length.
pub fn write_text(buf: &mut [u8], s: &str) -> u32 {
    let mut n = s.len().min(buf.len());
    while !s.is_char_boundary(n) {
        n -= 1;
    }
    buf[..n].copy_from_slice(&s.as_bytes()[..n]);
    n as u32
}

/// The text of `buf[..len]` (lossy: bad bytes from a foreign writer become U+FFFD).
pub fn read_text(buf: &[u8], len: u32) -> String {
    let n = (len as usize).min(buf.len());
    String::from_utf8_lossy(&buf[..n]).into_owned()
}

/// One axis: actual and commanded position (mm, or deg for B).
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Serialize, Deserialize)]
#[repr(C)]
pub struct AxisSample {
    pub actual: f64,
    pub command: f64,
}

/// An alarm: code 0 is none; axis/end/values depend on the code.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Serialize, Deserialize)]
#[repr(C)]
pub struct AlarmCode {
    pub code: u32,
    /// 0 none, 1 B, 2 X, 3 Y.
    pub axis: u8,
    /// 0 none, 1 min, 2 max.
    pub end: u8,
    /// Where the fault met the machine ([`crate::vocab::situation`]): what its reaction did.
    pub situation: u8,
    pub _pad: [u8; 1],
    pub value_a: f64,
    pub value_b: f64,
}

/// One sample per control cycle.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Serialize, Deserialize)]
#[repr(C)]
pub struct StateSample {
    /// The loop's cycle counter (consecutive: a gap is a lost sample).
    pub cycle: u64,
    /// CLOCK_MONOTONIC when this cycle's SYNC went out, ns.
    pub sync_time_ns: u64,
    /// Sequencer state code.
    pub state: u32,
    pub hold: u8,
    /// A program is loaded.
    pub program_loaded: u8,
    /// Drives reporting "operation enabled", bit 0 B, 1 X, 2 Y.
    pub drives_enabled: u8,
    /// Drives whose feedback is missing, same bits.
    pub drives_silent: u8,
    /// 1-based pass, 0 outside a cycle.
    pub pass: u32,
    /// Passes of the loaded program.
    pub passes_total: u32,
    pub tooth: u32,
    /// Gearbox coupling code.
    pub coupling: u32,
    pub table_deg: AxisSample,
    pub x_mm: AxisSample,
    pub y_mm: AxisSample,
    pub spindle_deg: f64,
    pub spindle_rpm: f64,
    pub spindle_set_rpm: f64,
    pub sync_error_arcsec: f64,
    pub ccc_arcsec: f64,
    /// The latched alarm (code 0: none).
    pub alarm: AlarmCode,
    /// Raw I/O image of the coupler.
    pub digital_inputs: u32,
    pub digital_outputs: u32,
    /// The coupler's input image is current.
    pub io_valid: u8,
    pub _pad: [u8; 3],
    /// This cycle's wake-up latency (after its deadline) and compute time, ns.
    pub wake_latency_ns: u32,
    pub compute_ns: u32,
    /// Cycles whose deadline had already passed when the previous one ended (since start).
    pub overruns: u64,
    /// Events overwritten in the loop's ring before they were published (since start).
    pub events_lost: u64,
    /// The loaded gear's pitch radius and normal module (0 without a program): errors at
    /// the pitch circle and the ISO 1328 tolerance follow from them.
    pub pitch_radius_mm: f64,
    pub normal_module_mm: f64,
    /// Referenced axes, bit 1 X, bit 2 Y; bit 0: the table's position is whole (its
    /// tooth phase can be trusted).
    pub referenced: u8,
    /// Referencing or jogging under way: 0 none, else the axis code.
    pub moving_axis: u8,
    /// The pitch compensation: a [`crate::vocab::pitch_compensation`] code (a byte that was
    /// padding: the layout is unchanged).
    pub pitch_compensation: u8,
    pub _pad2: u8,
    /// The pass "continue" would start from (1-based; 0: nothing to continue).
    pub continue_pass: u32,
    /// Overrides in percent.
    pub feed_override_percent: f64,
    pub spindle_override_percent: f64,
    /// Work offsets (touch-off), mm.
    pub x_offset_mm: f64,
    pub y_offset_mm: f64,
    /// The Y where "continue" re-enters the cut of pass `continue_pass`; NaN: at the
    /// pass's start.
    pub continue_from_y_mm: f64,
    /// [`program_hash`] of the program text the loop loaded (0 without a program): a
    /// frontend tells whether the program it loaded is still the loop's.
    pub program_hash: u64,
    /// Each drive's CiA 402 statusword (0x6041) as last received, B, X, Y.
    pub drive_statusword: [u16; 3],
    /// Each node's NMT state from its last heartbeat ([`NMT_NOT_HEARD`]: none yet), in the
    /// bus plan's order: B, X, Y drives, then the I/O coupler.
    pub nmt_state: [u8; 4],
    pub _pad3: [u8; 2],
    /// Cycles since each node's last heartbeat (same order), saturating.
    pub heartbeat_age_cycles: [u32; 4],
    /// Each node's last EMCY error code (same order; 0: none, or its error reset):
    /// what a drive reported about its own fault (`hob_wire::bus::emcy_text`).
    pub last_emcy_code: [u16; 4],
    /// The spindle encoder's reading as latched, continuous, before the loop's once-per-turn
    /// correction (deg): `spindle_deg` is the observer's estimate from the corrected
    /// reading. Commissioning fits the encoder's error from this (`hob commission encoder`).
    pub spindle_reading_deg: f64,
    /// The table gauge's analog input (CiA 401 counts, -32768 .. 32767) when one was
    /// latched at this cycle's SYNC with the table drive's position, NaN otherwise (none
    /// mounted, or not this cycle): `hob commission backlash` compares it with `table_deg`.
    pub table_gauge_counts: f64,
}

/// [`StateSample::nmt_state`] of a node not heard from yet.
pub const NMT_NOT_HEARD: u8 = 0xFF;

/// The hash of a program text the loop publishes ([`StateSample::program_hash`]): 64-bit
/// FNV-1a of its bytes, never 0 (0 is "no program").
pub fn program_hash(text: &str) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in text.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h.max(1)
}

code_table! {
    /// Event kinds ([`EventSample::kind`]).
    pub mod event_kind: u32 {
        STATE_CHANGED = 1, "state-changed";
        ALARM = 2, "alarm";
        ALARM_CLEARED = 3, "alarm-cleared";
        PASS_STARTED = 4, "pass-started";
        PHASE_RECORDED = 5, "phase-recorded";
        /// `a`: the command's code; `b`: its `single | axis << 8 | direction << 16 |
        /// confirm << 24`; `value`: its value.
        ACCEPTED = 6, "accepted";
        /// `a`: the command's code; `b`: the refusal's code; `value`: the command's value.
        REFUSED = 7, "refused";
        PROGRAM_LOADED = 8, "program-loaded";
        CYCLE_DONE = 9, "cycle-done";
        /// A message of the service (start-up, privileges, shutdown).
        MESSAGE = 10, "message";
        /// The service's CANopen master saw something: `b` is a [`super::bus_event`] code.
        BUS = 11, "bus";
        /// An axis is referenced: `a` its axis code.
        REFERENCED = 12, "referenced";
        /// A continuous jog was stopped by its dead-man: `a` the axis code (0: the hob spindle
        /// C of a `SPINDLE_HOLD`).
        DEAD_MAN_STOP = 13, "dead-man-stop";
        /// A touch-off set a work offset: `a` the axis code, `value` the offset (mm).
        OFFSET_CHANGED = 14, "offset-changed";
        /// A flank of a cut gap touched: `a` the [`super::direction`] the table turned,
        /// `value` the tooth phase there (deg).
        FLANK_TOUCHED = 15, "flank-touched";
        /// Both flanks touched: `value` the part's tooth phase (deg), `a` the play between
        /// the flanks in micro-degrees.
        PHASE_ALIGNED = 16, "phase-aligned";
    }
}

code_table! {
    /// What a [`event_kind::BUS`] event's `b` says happened; `a` is the node (in its low byte
    /// for [`bus_event::TPDO_MISSING`]), `value` the code, count or OS error that goes with it.
    pub mod bus_event: u32 {
        /// An emergency message: `value` is its error code.
        EMCY = 1, "emcy";
        HEARTBEAT_LOST = 2, "heartbeat-lost";
        /// The node's synchronous TPDO late or lost in `value` cycles since its last report;
        /// `a`: the node in its low byte, the longest run of them in a row above it.
        TPDO_MISSING = 3, "tpdo-missing";
        /// A frame could not be sent: `a` is a [`super::send_error`] code, `value` the errno.
        SEND_FAILED = 4, "send-failed";
    }
}

/// Why a frame could not be sent ([`bus_event::SEND_FAILED`]).
pub mod send_error {
    pub const QUEUE_FULL: u32 = 1;
    pub const INTERFACE_DOWN: u32 = 2;
    pub const OS: u32 = 3;
}

/// Which CAN bus the loop's frames are on ([`StatsSample::bus_kind`]).
pub mod bus_kind {
    pub const SOCKETCAN: u8 = 0;
    pub const SHARED_MEMORY: u8 = 1;
}

/// An event of the loop. `a`, `b`, `value` depend on `kind`.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend, Serialize, Deserialize)]
#[repr(C)]
pub struct EventSample {
    /// Consecutive event number (a gap is a lost event).
    pub seq: u64,
    /// The cycle it happened in.
    pub cycle: u64,
    pub kind: u32,
    pub a: u32,
    pub b: u32,
    pub text_len: u32,
    pub alarm: AlarmCode,
    pub value: f64,
    #[serde(with = "crate::frame::fixed_bytes")]
    pub text: [u8; EVENT_TEXT_BYTES],
}

impl Default for EventSample {
    fn default() -> Self {
        Self {
            seq: 0,
            cycle: 0,
            kind: 0,
            a: 0,
            b: 0,
            text_len: 0,
            alarm: AlarmCode::default(),
            value: 0.0,
            text: [0; EVENT_TEXT_BYTES],
        }
    }
}

impl EventSample {
    pub fn text(&self) -> String {
        read_text(&self.text, self.text_len)
    }
}

/// A latency distribution summary, ns.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Serialize, Deserialize)]
#[repr(C)]
pub struct Percentiles {
    pub count: u64,
    pub min_ns: u64,
    pub p50_ns: u64,
    pub p90_ns: u64,
    pub p99_ns: u64,
    pub p999_ns: u64,
    pub p9999_ns: u64,
    pub max_ns: u64,
}

/// Buckets of [`Log2Histogram`]: up to 2^32 ns (4.3 s).
pub const LOG2_BUCKETS: usize = 32;

/// A whole distribution in powers of two: `counts[i]` values in [2^i, 2^(i+1)) ns (bucket 0
/// also holds 0, the last everything above).
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend, Serialize, Deserialize)]
#[repr(C)]
pub struct Log2Histogram {
    pub counts: [u64; LOG2_BUCKETS],
}

impl Default for Log2Histogram {
    fn default() -> Self {
        Self {
            counts: [0; LOG2_BUCKETS],
        }
    }
}

impl Log2Histogram {
    /// The bucket of a value in ns.
    pub fn bucket(ns: u64) -> usize {
        (ns.max(1).ilog2() as usize).min(LOG2_BUCKETS - 1)
    }

    /// Adds `count` values of `ns`.
    pub fn add(&mut self, ns: u64, count: u64) {
        let b = &mut self.counts[Self::bucket(ns)];
        *b = b.saturating_add(count);
    }
}

/// The recorder's health, published by `hob-logger` (its service's only publisher) every
/// 200 ms: whether it can write, and what it received but could not write (disk full, a
/// write failed). `hob status` and the HMI show it; the loop never waits for it.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Serialize, Deserialize)]
#[repr(C)]
pub struct RecorderSample {
    pub seq: u64,
    /// The logger's CLOCK_MONOTONIC when published, ns (a reader's own clock tells how old
    /// the report is: a silent logger is shown as such).
    pub time_ns: u64,
    pub samples_written: u64,
    /// Samples received but not written since the logger started (they are missing from
    /// the log; `gaps.log` says which).
    pub samples_unwritten: u64,
    pub events_unwritten: u64,
    /// Samples the logger missed on the bus (the target is 0).
    pub samples_lost: u64,
    /// CLOCK_MONOTONIC when writing began to fail, ns (0: writing).
    pub failing_since_ns: u64,
    /// The operating system's error number of the last failed write (0: none).
    pub last_errno: i32,
    /// 1: everything received is being written.
    pub writing: u8,
    pub _pad: [u8; 3],
}

/// The loop's own timing since it started, published by `hob-rt` twice a second.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Serialize, Deserialize)]
#[repr(C)]
pub struct StatsSample {
    pub cycle: u64,
    pub period_ns: u64,
    pub overruns: u64,
    pub wake_latency: Percentiles,
    pub compute: Percentiles,
    /// Allocations and frees on the system heap inside cycles (the target is 0; u64::MAX:
    /// not counted).
    pub system_allocations_in_cycle: u64,
    /// Small blocks taken from the loop's preallocated pool inside cycles (iceoryx2 takes
    /// one per published sample).
    pub pool_allocations_in_cycle: u64,
    /// Real-time set-up that took effect: SCHED_FIFO priority (0: not), pinned core (-1: not).
    pub fifo_priority: i32,
    pub core: i32,
    pub memory_locked: u8,
    /// Frames on the CAN bus: a [`bus_kind`] code.
    pub bus_kind: u8,
    pub _pad: [u8; 2],
    /// The idle-state exit latency the loop holds the CPUs to, us (-1: not held).
    pub cpu_dma_latency_us: i32,
    /// Frames the loop could not send (queue full, interface down).
    pub tx_errors: u64,
    /// The whole distributions of the wake-up latency and the compute time.
    pub wake_histogram: Log2Histogram,
    pub compute_histogram: Log2Histogram,
}

code_table! {
    /// Command codes ([`CommandRequest::command`]).
    pub mod command: u32 {
        LOAD_PROGRAM = 1, "load";
        START = 2, "start";
        FEED_HOLD = 3, "hold";
        RESUME = 4, "resume";
        STOP = 5, "stop";
        RESET = 6, "reset";
        JOG = 7, "jog";
        SPINDLE_ON = 8, "spindle on";
        SPINDLE_OFF = 9, "spindle off";
        NEW_BLANK = 10, "new blank";
        /// `axis`: 0 X then Y, 2 X, 3 Y.
        HOME = 11, "home";
        /// `axis`, `direction`, `value`: speed (mm/min, deg/min for B); renews a running one.
        JOG_CONTINUOUS = 12, "jog continuous";
        JOG_RELEASE = 13, "jog release";
        /// `value`: percent.
        FEED_OVERRIDE = 14, "feed override";
        /// `value`: percent.
        SPINDLE_OVERRIDE = 15, "spindle override";
        /// `axis` (X or Y), `value`: the gauge's diameter (X) or height (Y), mm; `confirm`:
        /// 1 when the operator confirmed the offset the loop asked about.
        TOUCH_OFF = 16, "touch-off";
        /// Continue the interrupted program from its interrupted pass.
        CONTINUE = 17, "continue";
        /// `value`: rpm. The hob spindle turns while this is renewed (a press-and-hold with a
        /// dead-man, as `JOG_CONTINUOUS`); `SPINDLE_OFF` stops it at once.
        SPINDLE_HOLD = 18, "spindle hold";
        /// Write the flight recorder's last seconds to disk (`hob record`).
        FLIGHT_RECORD = 19, "record";
        /// `direction`: the way the table was turned until a flank of the cut gap touched the
        /// hob's tooth (aligning to a part whose gaps are cut).
        TOUCH_FLANK = 20, "touch flank";
        /// What the nodes on the bus told about themselves at boot (answered by `hob-rt`'s
        /// command thread, not the loop): one line per node in the answer's text,
        /// `AXIS NODE VENDOR PRODUCT REVISION SERIAL VELOCITY_KP VELOCITY_TI_MS POSITION_KV`
        /// (identity hex), AXIS `B`, `X`, `Y` or `IO`; the drive's loop gains read at boot
        /// (N m s/rad, ms, 1/s; the table drive's) or `-` each when unknown. Written and
        /// read by `crate::nodes` only.
        NODES = 21, "nodes";
        /// `value`: Hz, `direction`: the way the table creeps meanwhile. The table's target
        /// swings, a sine with the amplitude the table's acceleration allows, while this is
        /// renewed (a dead-man, as `JOG_CONTINUOUS`); `JOG_RELEASE` fades it out.
        /// Commissioning's frequency response.
        EXCITE_TABLE = 22, "excite table";
        /// `value`: 1 on, 0 off. The pitch compensation `hob-rt` loaded at start (the
        /// machine's worm set's, from `hob compensate`) applied to the table or not; only
        /// outside a cycle with the gearbox out.
        PITCH_COMPENSATION = 23, "pitch compensation";
    }
}

/// Directions of a continuous jog ([`CommandRequest::direction`]).
pub mod direction {
    pub const POSITIVE: u8 = 1;
    pub const NEGATIVE: u8 = 2;
}

/// A request from a frontend.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend, Serialize, Deserialize)]
#[repr(C)]
pub struct CommandRequest {
    pub command: u32,
    /// START: 1 for single mode.
    pub single: u8,
    /// JOG, JOG_CONTINUOUS, TOUCH_OFF: 1 B, 2 X, 3 Y; HOME: 0 both, 2 X, 3 Y.
    pub axis: u8,
    /// JOG_CONTINUOUS, TOUCH_FLANK: a [`direction`] code.
    pub direction: u8,
    /// TOUCH_OFF: 1 when the operator confirmed the new offset after the loop refused it
    /// as `OffsetNeedsConfirmation` (the byte that was padding: the layout is unchanged).
    pub confirm: u8,
    /// JOG: distance (mm, or deg for B); SPINDLE_ON: rpm.
    pub value: f64,
    /// START, CONTINUE: the [`program_hash`] of the program the sender means to cut, as
    /// its text is now; the loop refuses (`program-changed`) when its loaded program is
    /// another. 0: whichever program is loaded.
    pub program_hash: u64,
    /// LOAD_PROGRAM: the program file's name (for messages) and its TOML text.
    pub name_len: u32,
    pub text_len: u32,
    #[serde(with = "crate::frame::fixed_bytes")]
    pub name: [u8; 256],
    #[serde(with = "crate::frame::fixed_bytes")]
    pub text: [u8; REQUEST_TEXT_BYTES],
}

impl CommandRequest {
    pub fn new(command: u32) -> Self {
        Self {
            command,
            single: 0,
            axis: 0,
            direction: 0,
            confirm: 0,
            value: 0.0,
            program_hash: 0,
            name_len: 0,
            text_len: 0,
            name: [0; 256],
            text: [0; REQUEST_TEXT_BYTES],
        }
    }

    /// A LOAD_PROGRAM request; refuses a text that does not fit.
    pub fn load_program(name: &str, toml: &str) -> Result<Self, crate::error::Error> {
        if toml.len() > REQUEST_TEXT_BYTES {
            return Err(crate::error::Error::ProgramTooLong {
                name: name.to_string(),
                bytes: toml.len(),
                max: REQUEST_TEXT_BYTES,
            });
        }
        let mut r = Self::new(command::LOAD_PROGRAM);
        r.name_len = write_text(&mut r.name, name);
        r.text_len = write_text(&mut r.text, toml);
        Ok(r)
    }

    pub fn name(&self) -> String {
        read_text(&self.name, self.name_len)
    }

    pub fn text(&self) -> String {
        read_text(&self.text, self.text_len)
    }
}

/// The loop's answer.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend, Serialize, Deserialize)]
#[repr(C)]
pub struct CommandResponse {
    pub accepted: u8,
    pub _pad: [u8; 3],
    /// Refusal code when refused (0 when the request itself was malformed).
    pub refusal: u32,
    pub text_len: u32,
    #[serde(with = "crate::frame::fixed_bytes")]
    pub text: [u8; RESPONSE_TEXT_BYTES],
}

impl CommandResponse {
    pub fn new(accepted: bool, refusal: u32, text: &str) -> Self {
        let mut r = Self {
            accepted: accepted as u8,
            _pad: [0; 3],
            refusal,
            text_len: 0,
            text: [0; RESPONSE_TEXT_BYTES],
        };
        r.text_len = write_text(&mut r.text, text);
        r
    }

    pub fn text(&self) -> String {
        read_text(&self.text, self.text_len)
    }
}

/// A CAN frame on the shared-memory virtual CAN bus.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
pub struct CanFrameSample {
    /// The endpoint that sent it (endpoints skip their own frames, as a CAN controller does).
    pub origin: u64,
    /// CLOCK_MONOTONIC when sent, ns.
    pub time_ns: u64,
    pub id: u16,
    pub len: u8,
    pub _pad: [u8; 5],
    pub data: [u8; 8],
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_program_hash_is_fnv1a_and_never_the_no_program_zero() {
        // The FNV-1a 64 reference values (draft-eastlake-fnv: "" and "a").
        assert_eq!(program_hash(""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(program_hash("a"), 0xaf63_dc4c_8601_ec8c);
        assert_ne!(
            program_hash("[workpiece]\nteeth = 17\n"),
            program_hash("[workpiece]\nteeth = 18\n")
        );
    }

    #[test]
    fn log2_buckets_hold_each_power_of_two() {
        assert_eq!(Log2Histogram::bucket(0), 0);
        assert_eq!(Log2Histogram::bucket(1), 0);
        assert_eq!(Log2Histogram::bucket(2), 1);
        assert_eq!(Log2Histogram::bucket(1023), 9);
        assert_eq!(Log2Histogram::bucket(1024), 10);
        assert_eq!(Log2Histogram::bucket(u64::MAX), LOG2_BUCKETS - 1);
        let mut h = Log2Histogram::default();
        h.add(1500, 3);
        h.add(1500, u64::MAX);
        assert_eq!(h.counts[10], u64::MAX, "saturates");
    }

    #[test]
    fn text_is_cut_at_a_character_boundary() {
        let mut buf = [0u8; 4];
        let n = write_text(&mut buf, "abcé");
        assert_eq!(n, 3);
        assert_eq!(read_text(&buf, n), "abc");
    }

    #[test]
    fn a_program_too_long_is_refused() {
        let long = "x".repeat(REQUEST_TEXT_BYTES + 1);
        assert!(CommandRequest::load_program("p.toml", &long).is_err());
        let r = CommandRequest::load_program("p.toml", "[gear]").unwrap();
        assert_eq!(r.text(), "[gear]");
        assert_eq!(r.name(), "p.toml");
    }

    #[test]
    fn read_text_never_reads_past_the_buffer() {
        let buf = [b'a'; 4];
        assert_eq!(read_text(&buf, 99), "aaaa");
    }
}
