//! The I/O coupler's process image as named signals (docs/domain.md section 6). Polarity is
//! applied by `DigitalBinding::is_active`/`set` (hob-setup, shared with the frontends): the
//! rest of the controller sees "active" or not.

use hob_setup::config::machine::{DigitalBinding, IoMap};

fn read(raw: u32, b: DigitalBinding) -> bool {
    b.is_active(raw)
}

fn write(raw: &mut u32, b: DigitalBinding, on: bool) {
    b.set(raw, on);
}

/// Digital inputs, active = true.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Inputs {
    pub safety_chain_closed: bool,
    pub estop_pressed: bool,
    pub x_limit_min: bool,
    pub x_limit_max: bool,
    pub y_limit_min: bool,
    pub y_limit_max: bool,
    pub vfd_fault: bool,
    pub vfd_ready: bool,
    pub lube_pressure_ok: bool,
    pub coolant_running: bool,
    pub x_clamp_closed: bool,
    pub reset_button: bool,
    pub cycle_start_button: bool,
    pub cycle_stop_button: bool,
    pub feed_hold_button: bool,
}

/// Digital outputs, on = true.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Outputs {
    pub pc_ok_relay: bool,
    pub pc_reset_relay: bool,
    pub lube_pump: bool,
    pub coolant_pump: bool,
    pub x_clamp: bool,
    pub spindle_run_forward: bool,
    pub spindle_run_reverse: bool,
    pub fault_lamp: bool,
}

/// The bit map, copied out of the configuration at start-up.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct IoBits {
    inputs: [DigitalBinding; 15],
    outputs: [DigitalBinding; 8],
}

impl IoBits {
    pub fn new(map: &IoMap) -> Self {
        Self {
            inputs: map.inputs.bindings().map(|(_, b)| b),
            outputs: map.outputs.bindings().map(|(_, b)| b),
        }
    }

    /// Named inputs from the raw input image.
    pub fn decode(&self, raw: u32) -> Inputs {
        let i = self.inputs.map(|b| read(raw, b));
        Inputs {
            safety_chain_closed: i[0],
            estop_pressed: i[1],
            x_limit_min: i[2],
            x_limit_max: i[3],
            y_limit_min: i[4],
            y_limit_max: i[5],
            vfd_fault: i[6],
            vfd_ready: i[7],
            lube_pressure_ok: i[8],
            coolant_running: i[9],
            x_clamp_closed: i[10],
            reset_button: i[11],
            cycle_start_button: i[12],
            cycle_stop_button: i[13],
            feed_hold_button: i[14],
        }
    }

    /// Raw input image for named inputs (the simulated machine's side).
    pub fn encode_inputs(&self, i: &Inputs) -> u32 {
        let values = [
            i.safety_chain_closed,
            i.estop_pressed,
            i.x_limit_min,
            i.x_limit_max,
            i.y_limit_min,
            i.y_limit_max,
            i.vfd_fault,
            i.vfd_ready,
            i.lube_pressure_ok,
            i.coolant_running,
            i.x_clamp_closed,
            i.reset_button,
            i.cycle_start_button,
            i.cycle_stop_button,
            i.feed_hold_button,
        ];
        let mut raw = 0;
        for (b, v) in self.inputs.iter().zip(values) {
            write(&mut raw, *b, v);
        }
        raw
    }

    /// Raw output image for named outputs.
    pub fn encode(&self, o: &Outputs) -> u32 {
        let values = [
            o.pc_ok_relay,
            o.pc_reset_relay,
            o.lube_pump,
            o.coolant_pump,
            o.x_clamp,
            o.spindle_run_forward,
            o.spindle_run_reverse,
            o.fault_lamp,
        ];
        let mut raw = 0;
        for (b, v) in self.outputs.iter().zip(values) {
            write(&mut raw, *b, v);
        }
        raw
    }

    /// Named outputs from the raw output image (the simulated machine's side).
    pub fn decode_outputs(&self, raw: u32) -> Outputs {
        let o = self.outputs.map(|b| read(raw, b));
        Outputs {
            pc_ok_relay: o[0],
            pc_reset_relay: o[1],
            lube_pump: o[2],
            coolant_pump: o[3],
            x_clamp: o[4],
            spindle_run_forward: o[5],
            spindle_run_reverse: o[6],
            fault_lamp: o[7],
        }
    }
}
