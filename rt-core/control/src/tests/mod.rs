use super::io::{Inputs, Outputs};
use super::*;

fn shipped() -> MachineConfig {
    hob_setup::config::machine::shipped_for_tests()
}

#[test]
fn prediction_horizon_is_one_cycle_plus_the_drive_delay() {
    // Run the controller on a spindle turning at a constant 120 rpm (20 counts of 10 000
    // per 1 ms cycle) until the observer has settled: the angle the gearbox follows must
    // lead the observed angle by the speed times one cycle plus the drive delay, both as
    // the machine file states them.
    let m = shipped();
    let p = ControlParams::from_machine(&m);
    let mut c = Controller::new(p);
    let counts_per_cycle = 20;
    let mut input = CycleInputs {
        digital_inputs: p.io.encode_inputs(&Inputs {
            safety_chain_closed: true,
            ..Inputs::default()
        }),
        io_valid: true,
        ..CycleInputs::default()
    };
    input.table.fresh = true;
    input.x.fresh = true;
    input.y.fresh = true;
    for k in 0..3000 {
        input.spindle_counts = k * counts_per_cycle;
        c.step(&input);
    }
    let cycle_s = f64::from(m.control.cycle_period_us) * 1e-6;
    let horizon_s = cycle_s + f64::from(m.control.drive_delay_us) * 1e-6;
    let counts_per_deg = f64::from(m.spindle.encoder_counts_per_rev) / 360.0;
    let speed_deg_s =
        m.spindle.encoder_polarity.sign() * f64::from(counts_per_cycle) / counts_per_deg / cycle_s;
    let lead = c.measured.spindle_for_gearbox_deg - c.measured.spindle_deg;
    assert!(
        (lead - speed_deg_s * horizon_s).abs() < 1e-6,
        "the gearbox follows {lead} deg ahead, expected {} deg ({speed_deg_s} deg/s x {horizon_s} s)",
        speed_deg_s * horizon_s
    );
    // Following the last measured angle there is no lead.
    c.set_angle_source(SpindleAngleSource::LastMeasured);
    input.spindle_counts = 3000 * counts_per_cycle;
    c.step(&input);
    let measured = m.spindle.encoder_polarity.sign() * f64::from(input.spindle_counts) / counts_per_deg;
    assert!((c.measured.spindle_for_gearbox_deg - measured).abs() < 1.0 / counts_per_deg);
}

#[test]
fn counts_and_units_round_trip_with_polarity() {
    let p = ControlParams::from_machine(&shipped());
    // 3000 counts/mm; a reading is the middle of its count.
    assert_eq!(p.x.to_counts(10.0), 30_000);
    assert!((p.x.to_units(30_000) - (10.0 + 0.5 / 3000.0)).abs() < 1e-12);
    let inverted = AxisScale {
        counts_per_unit: 3000.0,
        sign: -1.0,
    };
    assert_eq!(inverted.to_counts(10.0), -30_000);
    // Table: 2^20 counts per motor turn, 75 motor turns per revolution; a target wraps at
    // 32 bits as the drive's counter does (27 revolutions and a bit).
    assert_eq!(p.table.to_counts(360.0), 78_643_200);
    assert_eq!(
        p.table.to_counts(30.0 * 360.0),
        30i64.wrapping_mul(78_643_200) as i32
    );
}

#[test]
fn io_images_apply_each_signals_polarity() {
    let p = ControlParams::from_machine(&shipped());
    let io = p.io;
    let inputs = Inputs {
        safety_chain_closed: true,
        lube_pressure_ok: true,
        ..Inputs::default()
    };
    let raw = io.encode_inputs(&inputs);
    // Active-low signals (limits, e-stop, VFD fault, cycle stop) read high when inactive.
    assert_eq!(raw & 0b10, 0b10, "e-stop NC contact closed");
    assert_eq!(io.decode(raw), inputs);
    let outputs = Outputs {
        pc_ok_relay: true,
        coolant_pump: true,
        ..Outputs::default()
    };
    let raw = io.encode(&outputs);
    assert_eq!(raw, 0b1001);
    assert_eq!(io.decode_outputs(raw), outputs);
}

#[test]
fn power_up_waits_for_lubrication_and_the_safety_chain() {
    let p = ControlParams::from_machine(&shipped());
    let mut c = Controller::new(p);
    let closed = p.io.encode_inputs(&Inputs {
        safety_chain_closed: true,
        ..Inputs::default()
    });
    let mut input = CycleInputs {
        digital_inputs: closed,
        io_valid: true,
        ..CycleInputs::default()
    };
    input.table.fresh = true;
    input.x.fresh = true;
    input.y.fresh = true;
    let out = c.step(&input);
    assert_eq!(c.status().state, State::Init);
    assert!(!out.drives_enabled, "no drive power before power-up is done");
    assert!(c.status().outputs.lube_pump, "lubrication at power-up");
    assert_eq!(
        c.command(Command::Start { single: false }),
        Err(fault::Refusal::NoProgram)
    );
    assert_eq!(
        c.command(Command::Jog {
            axis: fault::Axis::X,
            distance: 1.0
        }),
        Err(fault::Refusal::NotReady)
    );
}

#[test]
fn missing_feedback_is_counted_then_a_fault() {
    let p = ControlParams::from_machine(&shipped());
    let mut c = Controller::new(p);
    let input = CycleInputs {
        digital_inputs: p.io.encode_inputs(&Inputs {
            safety_chain_closed: true,
            ..Inputs::default()
        }),
        io_valid: true,
        ..CycleInputs::default()
    };
    for _ in 0..p.feedback_misses_to_fault - 1 {
        c.step(&input);
        assert_eq!(c.status().fault, None);
    }
    c.step(&input);
    assert_eq!(
        c.status().fault,
        Some(fault::Fault::FeedbackLost { axis: fault::Axis::B })
    );
}

mod setup_ops;
