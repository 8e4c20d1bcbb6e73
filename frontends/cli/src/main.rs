//! `hob`: the command-line frontend of the hob controller.
//!
//! Exit status: 0 done; 2 refused (an invalid program or machine configuration, or bad
//! arguments: the message names the file, position, key and limit); 1 anything else.

use clap::{Parser, Subcommand};
use hob_cli::library::{Action, Place};
use hob_cli::util::{Failure, emit, load_machine, machine_path, service_result};
use hob_cli::{can, compensate, cutter, doctor, lab, library, render, service};
use hob_store::library::Kind;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Debug, Parser)]
#[command(
    name = "hob",
    version,
    about = "hob: CNC for gear hobbing machines",
    after_help = "With the simulated machine (the sibling binary hob-lab): hob demo, hob simulate, hob can run; `hob-lab --help` for their options."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Is this PC ready for the 1 ms loop? RT kernel, core isolation, governor, limits,
    /// CAN interface, shared memory, clock source, a short cyclictest; the fix for each.
    Doctor {
        /// Machine configuration [default: config/machine.toml, then /etc/hob/machine.toml].
        #[arg(long, value_name = "FILE")]
        machine: Option<PathBuf>,
        /// Length of the cyclictest run (0: skip it).
        #[arg(long, default_value_t = 10)]
        cyclictest_seconds: u32,
        /// The findings as JSON.
        #[arg(long)]
        json: bool,
    },
    /// The running service's state, alarms, loop timing and recent events.
    Status {
        /// Keep printing a line every half second, and every event.
        #[arg(long)]
        watch: bool,
        #[arg(long)]
        json: bool,
    },
    /// Load a program into the running service (checked there against its machine); a
    /// library tool the program names is filled in first.
    Load {
        /// Program file (TOML).
        #[arg(required_unless_present = "lib", conflicts_with = "lib")]
        program: Option<PathBuf>,
        /// A program of the library instead of a file.
        #[arg(long, value_name = "NAME")]
        lib: Option<String>,
        /// Program library [default: $HOB_LIBRARY, then [library] dir of the machine file].
        #[arg(long, value_name = "DIR")]
        library: Option<PathBuf>,
        /// Machine configuration (for its [library] dir) [default: config/machine.toml, then /etc/hob/machine.toml].
        #[arg(long, value_name = "FILE")]
        machine: Option<PathBuf>,
    },
    /// The program and tool library: list, show, create, copy, rename, delete.
    Lib {
        #[command(subcommand)]
        command: LibCommand,
        /// Program library [default: $HOB_LIBRARY, then [library] dir of the machine file].
        #[arg(long, value_name = "DIR", global = true)]
        library: Option<PathBuf>,
        /// Machine configuration [default: config/machine.toml, then /etc/hob/machine.toml].
        #[arg(long, value_name = "FILE", global = true)]
        machine: Option<PathBuf>,
    },
    /// Start the loaded program.
    Start {
        /// Only the single-mode pass.
        #[arg(long)]
        single: bool,
    },
    /// Feed hold.
    Hold,
    /// Resume after feed hold.
    Resume,
    /// Cycle stop: out of the cut, gearbox out, spindle off.
    Stop,
    /// Clear a fault whose cause is gone.
    Reset,
    /// Move an axis by a distance (mm, or deg for B) while idle.
    Jog {
        axis: String,
        #[arg(allow_hyphen_values = true, value_parser = typed_number)]
        distance: f64,
    },
    /// Continuous jog with a dead-man: renewed every 100 ms for SECONDS (or until the
    /// process is stopped: killing it stops the axis within the dead-man time).
    JogHold {
        axis: String,
        /// `+` or `-`.
        #[arg(allow_hyphen_values = true)]
        direction: String,
        /// mm/min (deg/min for B); the loop limits it.
        #[arg(long, default_value_t = 300.0)]
        speed: f64,
        #[arg(long, default_value_t = 1.0)]
        seconds: f64,
        /// Stop renewing at the end instead of releasing (what a lost frontend does).
        #[arg(long)]
        no_release: bool,
    },
    /// Reference X and Y (or one of them) by the drives' homing.
    Home {
        /// x, y or all.
        #[arg(default_value = "all")]
        axes: String,
    },
    /// Feed or spindle speed override in percent of the program's.
    Override {
        /// feed or spindle.
        what: String,
        #[arg(value_parser = typed_number)]
        percent: f64,
    },
    /// Touch-off: the hob's tip touches a gauge; sets the work offset of X (the gauge's
    /// diameter) or Y (the height of its top face above the table face).
    TouchOff {
        axis: String,
        /// X: the gauge's diameter, mm (a decimal point or comma).
        #[arg(long, value_parser = typed_number)]
        diameter: Option<f64>,
        /// Y: the gauge's height above the table face, mm (a decimal point or comma).
        #[arg(long, value_parser = typed_number)]
        height: Option<f64>,
        /// Set the offset even though it does not fit the loaded blank, the previous
        /// offset or where the hob stands (the loop refuses such a touch-off first and
        /// names the offset it would set); never one beyond the loop's limits.
        #[arg(long)]
        confirm: bool,
    },
    /// Apply the pitch compensation hob-rt loaded for this machine's worm set (`on`) or
    /// not (`off`); outside a cycle, with the gearbox out (`hob compensate` stores one).
    PitchCompensation {
        /// on or off.
        switch: String,
    },
    /// Continue the interrupted program from the interrupted pass, on the same part.
    Continue,
    /// A new blank is on the table: forget the recorded tooth phase.
    NewBlank,
    /// Aligning to a part whose gaps are cut (its table lost its position, or a pre-cut
    /// part): with the spindle off and a hob tooth in a gap, the table turned `+` (or `-`)
    /// until a flank touches the tooth. After both flanks the part's tooth phase is their
    /// middle, and continue (or start) cuts those gaps.
    TouchFlank {
        /// `+` or `-`: the way the table was turned to the flank.
        #[arg(allow_hyphen_values = true)]
        turned: String,
    },
    /// Write the loop's flight record now: its last seconds of inputs, commands and outputs
    /// (hob-rt writes one by itself on a fault and at its stop).
    Record,
    /// Replay a flight record through this build's control core: every output compared
    /// with the recorded one, bit for bit (exit 1 when they part).
    Replay {
        /// The flight record (`flight-*.hobfr`, in hob-rt's --flight-dir).
        file: PathBuf,
        /// Replay a second time with the spindle observer's bandwidth changed, and compare.
        #[arg(long, value_name = "HZ")]
        observer_bandwidth_hz: Option<f64>,
    },
    /// Read recorded logs of hob-logger.
    Log {
        #[command(subcommand)]
        command: LogCommand,
    },
    /// Plan a program: gearbox ratio, differential, hob swivel, passes, speeds, times.
    Plan {
        /// Program file (TOML).
        program: PathBuf,
        /// Machine configuration [default: config/machine.toml, then /etc/hob/machine.toml].
        #[arg(long, value_name = "FILE")]
        machine: Option<PathBuf>,
        /// Print the plan as JSON.
        #[arg(long)]
        json: bool,
        /// Program library, for a program that names a library tool [default: $HOB_LIBRARY, then [library] dir of the machine file].
        #[arg(long, value_name = "DIR")]
        library: Option<PathBuf>,
    },
    /// Profile disk cutters for the tooth-by-tooth cycle.
    Cutter {
        #[command(subcommand)]
        command: CutterCommand,
    },
    /// Worst-case CAN bus load per cycle of the configured PDO set; refused above the limit.
    BusLoad {
        /// Machine configuration [default: config/machine.toml, then /etc/hob/machine.toml].
        #[arg(long, value_name = "FILE")]
        machine: Option<PathBuf>,
    },
    /// Commissioning: measure on the machine what the controller must know, and write it
    /// into the machine file on confirmation (the diff shown, the old file kept).
    Commission {
        #[command(subcommand)]
        command: CommissionCommand,
    },
    /// Measure the first gear, correct the second: the checker's files of a cut gear,
    /// matched to the cut's log, split into the table's and the hob's errors, and the
    /// compensation for the table's worm set shown (a diff against the current one) and
    /// stored beside the state file on --yes (the old one kept).
    Compensate {
        /// Machine configuration [default: config/machine.toml, then /etc/hob/machine.toml].
        #[arg(long, value_name = "FILE")]
        machine: Option<PathBuf>,
        /// The program the gear was cut with (TOML).
        #[arg(long, value_name = "FILE")]
        program: PathBuf,
        /// The log directory of the first cut (hob-logger's).
        #[arg(long, value_name = "DIR")]
        log: PathBuf,
        /// The cut's first and last cycle in the log (e.g. 1200..98000: the HMI's cut
        /// report gives them) [default: the newest run of hob-rt in the log, whole].
        #[arg(long, value_name = "FIRST..LAST")]
        cycles: Option<String>,
        /// A checker's file (docs/gear-measurement.md), one per height; repeat the option.
        #[arg(long, value_name = "FILE", required = true)]
        measurement: Vec<PathBuf>,
        /// A plot of the table's error per gap and the residual (SVG).
        #[arg(long, value_name = "FILE")]
        svg: Option<PathBuf>,
        /// Write the compensation (without it, nothing is written).
        #[arg(long)]
        yes: bool,
    },
    /// Commissioning tools for the CAN bus (scan, SDO, dump; `can run` is in hob-lab).
    Can {
        #[command(subcommand)]
        command: CanCommand,
        /// SocketCAN interface [default: can.interface of the machine configuration].
        #[arg(long, global = true)]
        iface: Option<String>,
        /// Machine configuration [default: config/machine.toml, then /etc/hob/machine.toml].
        #[arg(long, value_name = "FILE", global = true)]
        machine: Option<PathBuf>,
        /// SDO timeout per frame, ms.
        #[arg(long, default_value_t = 100, global = true)]
        timeout_ms: u64,
    },
    /// Validate a program against the machine (and the machine configuration itself).
    Check {
        /// Program file (TOML); without it only the machine configuration is checked.
        program: Option<PathBuf>,
        /// Machine configuration [default: config/machine.toml, then /etc/hob/machine.toml].
        #[arg(long, value_name = "FILE")]
        machine: Option<PathBuf>,
        /// Program library, for a program that names a library tool [default: $HOB_LIBRARY, then [library] dir of the machine file].
        #[arg(long, value_name = "DIR")]
        library: Option<PathBuf>,
    },
}

#[derive(Debug, Subcommand)]
enum CutterCommand {
    /// Design a disk cutter's profile for a gear's tooth space: each involute flank as
    /// circular arcs through three of its points (the fewest within the grade's ISO 1328-1
    /// profile form tolerance f_falpha, or --arcs), a tangent line and ISO 53's root fillet
    /// below the form circle, a flat tip; the deviation from the involute against f_falpha.
    Design {
        #[arg(long)]
        teeth: u32,
        /// Normal module.
        #[arg(long)]
        module_mm: f64,
        #[arg(long, default_value_t = 20.0)]
        pressure_angle_deg: f64,
        /// Profile shift coefficient x.
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        shift: f64,
        /// Helix angle: the space is taken in the normal plane (z / cos^3 beta teeth).
        #[arg(long, default_value_t = 0.0)]
        helix_deg: f64,
        /// The cutter's outside diameter.
        #[arg(long)]
        outside_diameter_mm: f64,
        /// The ISO 1328-1 grade the gear is to hold (1-11).
        #[arg(long, default_value_t = 7)]
        grade: u8,
        /// Arcs per flank (1-8) instead of the fewest within the grade.
        #[arg(long)]
        arcs: Option<u32>,
        /// Write the profile's primitives as TOML (`[[profile]]`, the tool library's form).
        #[arg(long, value_name = "FILE")]
        toml: Option<PathBuf>,
        /// Write a plot: the profile with its node points, and the arcs' deviation.
        #[arg(long, value_name = "FILE")]
        svg: Option<PathBuf>,
    },
    /// G-code to grind a cutter's teeth to a profile by 3+2-axis linear interpolation on a
    /// machining centre (seed 001): the edge on the rake face, the wheel's edge-rounding
    /// centre along the profile, the dividing head indexed per tooth; and a plot.
    Grind {
        /// The profile (`[[profile]]` primitives, as `hob cutter design --toml` writes them).
        profile: PathBuf,
        #[arg(long)]
        outside_diameter_mm: f64,
        /// The cutter's teeth (the dividing head's positions).
        #[arg(long)]
        teeth: u32,
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        rake_deg: f64,
        #[arg(long, default_value_t = 6.0)]
        clearance_deg: f64,
        #[arg(long)]
        wheel_radius_mm: f64,
        /// The wheel's edge rounding.
        #[arg(long)]
        wheel_edge_radius_mm: f64,
        /// Points along the cutter's axis at most this far apart.
        #[arg(long, default_value_t = 0.2)]
        spacing_mm: f64,
        /// On arcs, points closer still so that no chord leaves the arc by more.
        #[arg(long, default_value_t = 0.002)]
        chord_tolerance_mm: f64,
        #[arg(long, default_value_t = 200.0)]
        feed_mm_min: f64,
        /// The G-code program.
        #[arg(long, value_name = "FILE")]
        out: PathBuf,
        /// A plot: the profile, the edge and the wheel's path.
        #[arg(long, value_name = "FILE")]
        svg: Option<PathBuf>,
    },
    /// The cutter's dynamics and its side deflection in a cut (seed 003's model): stiffness,
    /// natural frequency and damping from its width, diameter, mass and material; the side
    /// force from the chip (Kienzle), its lag, the amplification at the tooth-passing
    /// frequency, the predicted profile error; a warning near resonance and the cutting
    /// speeds that keep the error within --limit-um.
    Dynamics {
        #[arg(long)]
        width_mm: f64,
        #[arg(long)]
        outside_diameter_mm: f64,
        /// The cutter unit's vibrating mass.
        #[arg(long)]
        mass_kg: f64,
        /// The cutter's teeth.
        #[arg(long)]
        teeth: u32,
        /// Young's modulus of the cutter (alloy steel, seed 003).
        #[arg(long, default_value_t = 2.1e5)]
        youngs_modulus_mpa: f64,
        /// Logarithmic decrement of its free vibration (seed 003; a tap test measures it).
        #[arg(long, default_value_t = 0.3)]
        log_decrement: f64,
        /// The bending stress the cutter's body may carry (an assumption unless its maker gives it).
        #[arg(long, default_value_t = hob_cutters::dynamics::DEFAULT_ALLOWABLE_BENDING_MPA)]
        allowable_bending_mpa: f64,
        /// The workpiece material's specific cutting force (domain.md section 8: 2600).
        #[arg(long)]
        kc11_n_mm2: f64,
        /// Its exponent (0.26).
        #[arg(long)]
        mc: f64,
        /// Chip thickness on the side edge.
        #[arg(long)]
        chip_thickness_mm: f64,
        /// The side edge's engaged length.
        #[arg(long)]
        chip_width_mm: f64,
        #[arg(long)]
        cutting_speed_m_min: f64,
        /// The profile error allowed (for example the grade's f_falpha), for the speed ranges.
        #[arg(long)]
        limit_um: Option<f64>,
    },
}

#[derive(Debug, Subcommand)]
enum LibCommand {
    /// Programs (`programs/NAME.toml`), each checked on the machine as `hob check` does.
    Programs {
        #[command(subcommand)]
        action: EntryAction,
    },
    /// Tools (`tools/NAME.toml`): a program's `[tool]` fields and the tool's usage.
    Tools {
        #[command(subcommand)]
        action: ToolAction,
    },
}

#[derive(Debug, Subcommand)]
enum EntryAction {
    /// Every entry, valid or with the reason it is not.
    List,
    /// The entry's file as stored.
    Show {
        name: String,
    },
    /// A new entry from FILE; refused (nothing written) unless it parses and checks.
    Create {
        name: String,
        file: PathBuf,
    },
    /// Copy under a new name (never over an existing entry).
    Copy {
        from: String,
        to: String,
    },
    /// Rename (never over an existing entry).
    Rename {
        from: String,
        to: String,
    },
    Delete {
        name: String,
    },
}

#[derive(Debug, Subcommand)]
enum ToolAction {
    #[command(flatten)]
    Entry(EntryAction),
    /// Add a recorded cut (a hob-logger directory) to the tool's usage: its passes and the
    /// Y travelled in the cut.
    RecordUsage {
        name: String,
        /// The recording of the cut (hob-logger's directory).
        #[arg(long, value_name = "DIR")]
        log: PathBuf,
        /// When it was cut, YYYY-MM-DDTHH:MM:SSZ [default: now].
        #[arg(long, value_name = "UTC")]
        when: Option<String>,
    },
    /// G-code to grind a library disk cutter's teeth to its profile (its `[tool.disk]`:
    /// profile, rake, clearance; its outside diameter and gashes), as `hob cutter grind`.
    Grind {
        name: String,
        #[arg(long)]
        wheel_radius_mm: f64,
        /// The wheel's edge rounding.
        #[arg(long)]
        wheel_edge_radius_mm: f64,
        #[arg(long, default_value_t = 0.2)]
        spacing_mm: f64,
        #[arg(long, default_value_t = 0.002)]
        chord_tolerance_mm: f64,
        #[arg(long, default_value_t = 200.0)]
        feed_mm_min: f64,
        #[arg(long, value_name = "FILE")]
        out: PathBuf,
        #[arg(long, value_name = "FILE")]
        svg: Option<PathBuf>,
    },
}

impl EntryAction {
    fn action(self) -> Action {
        match self {
            EntryAction::List => Action::List,
            EntryAction::Show { name } => Action::Show(name),
            EntryAction::Create { name, file } => Action::Create { name, file },
            EntryAction::Copy { from, to } => Action::Copy { from, to },
            EntryAction::Rename { from, to } => Action::Rename { from, to },
            EntryAction::Delete { name } => Action::Delete(name),
        }
    }
}

#[derive(Debug, Subcommand)]
enum CommissionCommand {
    /// The table drive's delay (control.drive_delay_us): the table jogged at a constant
    /// speed one way and back (hob-rt idle, the table clear), its position fitted against
    /// the command shifted in time. Restart hob-rt after writing.
    Delay {
        /// Machine configuration to measure for and write [default: config/machine.toml, then /etc/hob/machine.toml].
        #[arg(long, value_name = "FILE")]
        machine: Option<PathBuf>,
        /// The table's jog speed, deg/min.
        #[arg(long, default_value_t = 240.0)]
        speed: f64,
        /// How long each way, s.
        #[arg(long, default_value_t = 3.0)]
        seconds: f64,
        /// Write the changes without asking (the diff is still shown).
        #[arg(long)]
        yes: bool,
    },
    /// The spindle encoder's error (once, twice, three times per turn) told apart from a
    /// true once-per-turn swing of the spindle: the spindle held at several speeds (hob-rt
    /// idle, the hob clear of the work), each fitted. With the record the loop corrects only
    /// the encoder's error. Restart hob-rt after writing.
    Encoder {
        /// Machine configuration to measure for and write [default: config/machine.toml, then /etc/hob/machine.toml].
        #[arg(long, value_name = "FILE")]
        machine: Option<PathBuf>,
        /// The spindle's speeds, rpm, comma-separated (at least 3, spanning a factor 2)
        /// [default: 30, 45, 65 and 95 % of spindle.max_spindle_rpm].
        #[arg(long, value_delimiter = ',')]
        speeds: Vec<f64>,
        /// How long each speed is read, s.
        #[arg(long, default_value_t = 30.0)]
        seconds: f64,
        /// Write the changes without asking (the diff is still shown).
        #[arg(long)]
        yes: bool,
    },
    /// The table drive's lost motion at a reversal (the worm's backlash), against a gauge
    /// on the table's rim that the machine file names (io.analog_inputs.table_gauge): the
    /// table jogged slowly +, - and + (hob-rt idle, the table clear), the motor compared
    /// with the gauge. Recorded for the report; the loop does not use it.
    Backlash {
        /// Machine configuration to measure for and write [default: config/machine.toml, then /etc/hob/machine.toml].
        #[arg(long, value_name = "FILE")]
        machine: Option<PathBuf>,
        /// The table's jog speed, deg/min.
        #[arg(long, default_value_t = hob_commission::backlash::BacklashOptions::default().speed_deg_min)]
        speed: f64,
        /// How long each jog runs, s.
        #[arg(long, default_value_t = hob_commission::backlash::BacklashOptions::default().seconds)]
        seconds: f64,
        /// Write the changes without asking (the diff is still shown).
        #[arg(long)]
        yes: bool,
    },
    /// The table's frequency response through the worm: the table's target swung by about
    /// an arcsec at stepped frequencies while the table creeps + (hob-rt idle, the table
    /// clear and unclamped), a model of the drive's loops fitted (the gains the drive
    /// reported, [table.drive_model]); the mesh's frequencies, the present tuning's margins
    /// and gains proposed with margins. Restart hob-rt after writing: its boot writes them
    /// to the drive.
    Response {
        /// Machine configuration to measure for and write [default: config/machine.toml, then /etc/hob/machine.toml].
        #[arg(long, value_name = "FILE")]
        machine: Option<PathBuf>,
        /// The lowest frequency, Hz.
        #[arg(long, default_value_t = hob_commission::response::ResponseOptions::default().from_hz)]
        from: f64,
        /// The highest frequency, Hz (at most a quarter of the loop's rate).
        #[arg(long, default_value_t = hob_commission::response::ResponseOptions::default().to_hz)]
        to: f64,
        /// Frequencies of the first sweep (as many again are added about its deepest dip).
        #[arg(long, default_value_t = hob_commission::response::ResponseOptions::default().points)]
        points: usize,
        /// Write the Bode plot here (SVG).
        #[arg(long, value_name = "FILE")]
        svg: Option<PathBuf>,
        /// Write the changes without asking (the diff is still shown).
        #[arg(long)]
        yes: bool,
    },
    /// The commissioning report of the machine file: what was measured, when and on what,
    /// and what is not measured yet; with --svg, the spindle encoder's record over the
    /// spindle's speeds as a plot.
    Report {
        /// Machine configuration to report on [default: config/machine.toml, then /etc/hob/machine.toml].
        #[arg(long, value_name = "FILE")]
        machine: Option<PathBuf>,
        /// Write the spindle encoder's plot here (SVG).
        #[arg(long, value_name = "FILE")]
        svg: Option<PathBuf>,
    },
}

#[derive(Debug, Subcommand)]
enum CanCommand {
    /// The nodes that answer: NMT state, device type, identity, name, CSP support.
    Scan,
    /// SDO upload and download (expedited and segmented); aborts in words.
    Sdo {
        #[command(subcommand)]
        op: SdoOp,
    },
    /// Live decoded view of the bus, or of a `candump -L` file.
    Dump {
        /// Decode this capture instead of the live bus.
        #[arg(long, value_name = "FILE")]
        file: Option<PathBuf>,
        /// Stop after this many frames.
        #[arg(long)]
        count: Option<usize>,
    },
    /// Check a `candump -L` capture against the bus schedule (and, given the program that
    /// was cut, the gearbox law from its frames).
    CheckCapture {
        file: PathBuf,
        #[arg(long)]
        program: Option<PathBuf>,
    },
}

#[derive(Debug, Subcommand)]
enum LogCommand {
    /// Write a recorded log as CSV: the columns of `hob simulate`'s trace.csv up to
    /// sync_err_arcsec, then the cycle counter and the other recorded values, then the
    /// feed and spindle overrides in percent (trace.csv's last two columns).
    Export {
        dir: PathBuf,
        /// CSV (the only format; required for clarity).
        #[arg(long)]
        csv: bool,
        /// Output file [default: standard output].
        #[arg(long, value_name = "FILE")]
        out: Option<PathBuf>,
    },
    /// A recorded cut: its program, part, date (UTC), operator and alarms, then per pass
    /// its durations (cut, pass, stood), synchronisation error statistics and the feed
    /// and spindle override ranges in its cut.
    Report { dir: PathBuf },
    /// The table drive's delay identified from a recorded cut (the shift that best lines
    /// its measured angle up with its command), against the machine file's
    /// `control.drive_delay_us`.
    Delay {
        dir: PathBuf,
        /// Machine configuration [default: config/machine.toml].
        #[arg(long)]
        machine: Option<PathBuf>,
    },
}

#[derive(Debug, Subcommand)]
enum SdoOp {
    Read {
        node: u8,
        index: String,
        sub: String,
        #[arg(long = "type", value_enum, default_value = "hex")]
        ty: can::SdoType,
    },
    Write {
        node: u8,
        index: String,
        sub: String,
        value: String,
        #[arg(long = "type", value_enum, default_value = "u32")]
        ty: can::SdoType,
    },
}

/// A number the operator typed, read as the HMI reads it (`hob_ipc::number`: a decimal
/// point or comma).
fn typed_number(text: &str) -> Result<f64, String> {
    hob_ipc::number::decimal(text).ok_or_else(|| {
        format!("\"{text}\" is not a number (digits with one decimal point or comma: 94.94 or 94,94)")
    })
}

fn main() -> ExitCode {
    let args: Vec<std::ffi::OsString> = std::env::args_os().skip(1).collect();
    if lab::is_lab_command(&args) {
        eprintln!("hob: {}", lab::exec_lab(&args));
        return ExitCode::FAILURE;
    }
    let cli = Cli::parse();
    match run(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => f.report(),
    }
}

/// Each command to the function that does it.
/// `hob commission ...`.
/// `hob compensate`: a refusal exits 2, naming the file, line, key or field (`cycles`: the
/// `--cycles` text, refused here when malformed).
fn compensate(mut o: compensate::Options, cycles: Option<&str>) -> Result<(), Failure> {
    let run = match cycles.map(compensate::parse_cycles).transpose() {
        Ok(c) => {
            o.cycles = c;
            compensate::run(&o)
        }
        Err(e) => Err(e),
    };
    match run {
        Ok(outcome) => emit(&outcome.text),
        Err(compensate::CompensateError::Refused(text)) => {
            eprintln!("hob: refused: {text}");
            Err(Failure::Exit(2))
        }
        Err(e) => Err(Failure::other(e)),
    }
}

fn commission(command: CommissionCommand) -> Result<(), Failure> {
    match command {
        CommissionCommand::Delay {
            machine,
            speed,
            seconds,
            yes,
        } => {
            let file = machine_path(machine.as_deref())?;
            let o = hob_commission::delay::DelayOptions {
                speed_deg_min: speed,
                seconds,
            };
            emit(&hob_cli::commission::delay(&file, &o, yes)?)
        }
        CommissionCommand::Encoder {
            machine,
            speeds,
            seconds,
            yes,
        } => {
            let file = machine_path(machine.as_deref())?;
            let o = hob_commission::encoder::EncoderOptions {
                speeds_rpm: speeds,
                seconds,
            };
            emit(&hob_cli::commission::encoder(&file, &o, yes)?)
        }
        CommissionCommand::Backlash {
            machine,
            speed,
            seconds,
            yes,
        } => {
            let file = machine_path(machine.as_deref())?;
            let o = hob_commission::backlash::BacklashOptions {
                speed_deg_min: speed,
                seconds,
            };
            emit(&hob_cli::commission::backlash(&file, &o, yes)?)
        }
        CommissionCommand::Response {
            machine,
            from,
            to,
            points,
            svg,
            yes,
        } => {
            let file = machine_path(machine.as_deref())?;
            let o = hob_commission::response::ResponseOptions {
                from_hz: from,
                to_hz: to,
                points,
            };
            emit(&hob_cli::commission::response(&file, &o, svg.as_deref(), yes)?)
        }
        CommissionCommand::Report { machine, svg } => {
            let file = machine_path(machine.as_deref())?;
            emit(&hob_cli::commission::report(&file, svg.as_deref())?)
        }
    }
}

fn run(command: Command) -> Result<(), Failure> {
    use hob_ipc::command as code;
    match command {
        Command::Doctor {
            machine,
            cyclictest_seconds,
            json,
        } => doctor(machine, cyclictest_seconds, json),
        Command::Commission { command } => commission(command),
        Command::Compensate {
            machine,
            program,
            log,
            cycles,
            measurement,
            svg,
            yes,
        } => compensate(
            compensate::Options {
                machine: machine_path(machine.as_deref())?,
                program,
                log,
                measurements: measurement,
                cycles: None,
                svg,
                yes,
            },
            cycles.as_deref(),
        ),
        Command::Status { watch, json } => service_result(service::status(watch, json)),
        Command::Load {
            program,
            lib,
            library,
            machine,
        } => load(program, lib, Place { library, machine }),
        Command::Lib {
            command,
            library,
            machine,
        } => lib(command, &Place { library, machine }),
        Command::Start { single } => send(&service::start(single)),
        Command::Hold => send(&service::simple(code::FEED_HOLD)),
        Command::Resume => send(&service::simple(code::RESUME)),
        Command::Stop => send(&service::simple(code::STOP)),
        Command::Reset => send(&service::simple(code::RESET)),
        Command::Jog { axis, distance } => send_built(service::jog(&axis, distance)),
        Command::JogHold {
            axis,
            direction,
            speed,
            seconds,
            no_release,
        } => service_result(service::jog_hold(&axis, &direction, speed, seconds, !no_release)),
        Command::Home { axes } => send_built(service::home(&axes)),
        Command::Override { what, percent } => send_built(service::override_request(&what, percent)),
        Command::TouchOff {
            axis,
            diameter,
            height,
            confirm,
        } => service_result(
            service::touch_off(&axis, diameter, height, confirm)
                .and_then(|r| service::request(&r))
                .map_err(|e| e.with_confirm_hint(&service::touch_off_again(&axis, diameter, height))),
        ),
        Command::PitchCompensation { switch } => send_built(service::pitch_compensation(&switch)),
        Command::Continue => send(&service::simple(code::CONTINUE)),
        Command::Record => send(&service::simple(code::FLIGHT_RECORD)),
        Command::Replay {
            file,
            observer_bandwidth_hz,
        } => replay(&file, observer_bandwidth_hz),
        Command::NewBlank => send(&service::simple(code::NEW_BLANK)),
        Command::TouchFlank { turned } => send_built(service::touch_flank(&turned)),
        Command::Log { command } => log(command),
        Command::Plan {
            program,
            machine,
            json,
            library,
        } => plan(&program, &Place { library, machine }, json),
        Command::Cutter { command } => cutter(command),
        Command::BusLoad { machine } => bus_load(machine),
        Command::Can {
            command,
            iface,
            machine,
            timeout_ms,
        } => can(command, iface, machine, timeout_ms),
        Command::Check {
            program,
            machine,
            library,
        } => check(program, machine, library),
    }
}

/// A request to the running service, and its answer.
fn send(req: &hob_ipc::CommandRequest) -> Result<(), Failure> {
    service_result(service::request(req))
}

/// A request built from the arguments (refused when they are wrong), and its answer.
fn send_built(req: Result<hob_ipc::CommandRequest, service::ServiceError>) -> Result<(), Failure> {
    service_result(req.and_then(|r| service::request(&r)))
}

/// Prints a refusal of a command's arguments (exit 2).
fn refused(e: impl std::fmt::Display) -> Failure {
    eprintln!("hob: refused: {e}");
    Failure::Exit(2)
}

/// `hob doctor`: exit 1 when a check fails.
fn doctor(machine: Option<PathBuf>, cyclictest_seconds: u32, json: bool) -> Result<(), Failure> {
    let machine = load_machine(machine.as_deref())?;
    let findings = doctor::run(&machine, cyclictest_seconds);
    if json {
        emit(&(serde_json::to_string_pretty(&findings).map_err(Failure::other)? + "\n"))?;
    } else {
        emit(&doctor::text(&findings))?;
    }
    if findings.iter().any(|f| f.level == doctor::Level::Fail) {
        Err(Failure::Exit(1))
    } else {
        Ok(())
    }
}

/// `hob load PROGRAM` or `hob load --lib NAME`.
fn load(program: Option<PathBuf>, lib: Option<String>, place: Place) -> Result<(), Failure> {
    let (name, text) = library::load_text(program.as_deref(), lib.as_deref(), &place)?;
    service_result(service::load_text(&name, &text))
}

/// `hob lib programs|tools ...`.
fn lib(command: LibCommand, place: &Place) -> Result<(), Failure> {
    match command {
        LibCommand::Programs { action } => library::run(Kind::Program, action.action(), place),
        LibCommand::Tools { action } => match action {
            ToolAction::Entry(a) => library::run(Kind::Tool, a.action(), place),
            ToolAction::RecordUsage { name, log, when } => library::run(
                Kind::Tool,
                Action::RecordUsage {
                    name,
                    log,
                    when_utc: when,
                },
                place,
            ),
            ToolAction::Grind {
                name,
                wheel_radius_mm,
                wheel_edge_radius_mm,
                spacing_mm,
                chord_tolerance_mm,
                feed_mm_min,
                out,
                svg,
            } => {
                let wheel = Wheel {
                    wheel_radius_mm,
                    wheel_edge_radius_mm,
                    spacing_mm,
                    chord_tolerance_mm,
                    feed_mm_min,
                };
                grind_tool(&name, &wheel, &out, svg.as_deref(), place)
            }
        },
    }
}

/// The grinding wheel and how it is moved (`hob lib tools grind`, `hob cutter grind`).
#[derive(Debug, Clone, Copy)]
struct Wheel {
    wheel_radius_mm: f64,
    wheel_edge_radius_mm: f64,
    spacing_mm: f64,
    chord_tolerance_mm: f64,
    feed_mm_min: f64,
}

/// `hob lib tools grind NAME`: a library disk cutter ground to its profile.
fn grind_tool(
    name: &str,
    wheel: &Wheel,
    out: &std::path::Path,
    svg: Option<&std::path::Path>,
    place: &Place,
) -> Result<(), Failure> {
    let record = place.open(None)?.tool(name).map_err(library::refused)?;
    let t = &record.tool;
    let Some(disk) = &t.disk else {
        return Err(refused(format!(
            "tool {name:?} has no disk cutter's profile ([tool.disk])"
        )));
    };
    let g = hob_cutters::grind::Grinding {
        outside_radius_mm: 0.5 * t.outside_diameter_mm,
        rake_deg: disk.rake_deg,
        clearance_deg: disk.clearance_deg,
        wheel_radius_mm: wheel.wheel_radius_mm,
        wheel_edge_radius_mm: wheel.wheel_edge_radius_mm,
        cutter_teeth: u32::try_from(t.gashes).unwrap_or(0),
        spacing_mm: wheel.spacing_mm,
        chord_tolerance_mm: wheel.chord_tolerance_mm,
    };
    let text =
        cutter::grind_profile(name, &disk.profile, &g, wheel.feed_mm_min, out, svg).map_err(refused)?;
    emit(&text)
}

/// `hob replay FILE`: exit 1 when the outputs part (the report on stderr).
fn replay(file: &std::path::Path, observer_bandwidth_hz: Option<f64>) -> Result<(), Failure> {
    match hob_cli::replay::replay(file, observer_bandwidth_hz) {
        Ok(text) => emit(&text),
        Err(e) => {
            eprint!("{e}");
            Err(Failure::Exit(1))
        }
    }
}

/// `hob log export|report|delay`.
fn log(command: LogCommand) -> Result<(), Failure> {
    match command {
        LogCommand::Export { dir, csv, out } => {
            if !csv {
                return Err(refused("log export: give --csv (the only format)"));
            }
            let text = hob_logger::export::export_csv(&dir).map_err(Failure::other)?;
            match out {
                Some(f) => cutter::write(&f, &text).map_err(Failure::other),
                None => emit(&text),
            }
        }
        LogCommand::Report { dir } => {
            let r = hob_logger::export::report(&dir).map_err(Failure::other)?;
            emit(&hob_logger::export::report_text(&dir, &r))
        }
        LogCommand::Delay { dir, machine } => log_delay(&dir, machine),
    }
}

/// `hob log delay DIR`: the table drive's delay against the machine file's.
fn log_delay(dir: &std::path::Path, machine: Option<PathBuf>) -> Result<(), Failure> {
    let machine = load_machine(machine.as_deref())?;
    let assumed_s = f64::from(machine.control.drive_delay_us) * 1e-6;
    let (samples, period_s) = hob_logger::delay::from_log(dir).map_err(Failure::other)?;
    let d = hob_logger::delay::identify(&samples, period_s, assumed_s).ok_or_else(|| {
        Failure::Other(format!(
            "{}: less than a second of synchronised cut recorded: no delay to identify",
            dir.display()
        ))
    })?;
    emit(&hob_logger::delay::text(&d, assumed_s))
}

/// `hob plan PROGRAM`.
fn plan(program: &std::path::Path, place: &Place, json: bool) -> Result<(), Failure> {
    let machine = load_machine(place.machine.as_deref())?;
    let plan = library::plan_file(program, place, &machine)?;
    if json {
        let text = serde_json::to_string_pretty(&plan).map_err(Failure::other)?;
        emit(&format!("{text}\n"))
    } else {
        emit(&render::plan_text(program, &plan))
    }
}

/// `hob cutter design|dynamics|grind`: a wrong argument is refused (exit 2).
fn cutter(command: CutterCommand) -> Result<(), Failure> {
    match command {
        CutterCommand::Design {
            teeth,
            module_mm,
            pressure_angle_deg,
            shift,
            helix_deg,
            outside_diameter_mm,
            grade,
            arcs,
            toml,
            svg,
        } => {
            let args = cutter::DesignArgs {
                gear: hob_cutters::space::Gear {
                    teeth,
                    normal_module_mm: module_mm,
                    pressure_angle_deg,
                    profile_shift: shift,
                    helix_deg,
                },
                outside_diameter_mm,
                grade,
                arcs,
            };
            cutter_design(&args, toml, svg)
        }
        CutterCommand::Dynamics {
            width_mm,
            outside_diameter_mm,
            mass_kg,
            teeth,
            youngs_modulus_mpa,
            log_decrement,
            allowable_bending_mpa,
            kc11_n_mm2,
            mc,
            chip_thickness_mm,
            chip_width_mm,
            cutting_speed_m_min,
            limit_um,
        } => {
            use hob_cutters::dynamics::{CutterBody, Material, SideCut};
            let body = CutterBody {
                width_mm,
                outside_diameter_mm,
                mass_kg,
                youngs_modulus_mpa,
                log_decrement,
                teeth,
            };
            let material = Material { kc11_n_mm2, mc };
            let cut = SideCut {
                chip_thickness_mm,
                chip_width_mm,
                cutting_speed_m_min,
            };
            let text =
                cutter::dynamics(&body, &material, &cut, allowable_bending_mpa, limit_um).map_err(refused)?;
            emit(&text)
        }
        CutterCommand::Grind {
            profile,
            outside_diameter_mm,
            teeth,
            rake_deg,
            clearance_deg,
            wheel_radius_mm,
            wheel_edge_radius_mm,
            spacing_mm,
            chord_tolerance_mm,
            feed_mm_min,
            out,
            svg,
        } => {
            let g = hob_cutters::grind::Grinding {
                outside_radius_mm: 0.5 * outside_diameter_mm,
                rake_deg,
                clearance_deg,
                wheel_radius_mm,
                wheel_edge_radius_mm,
                cutter_teeth: teeth,
                spacing_mm,
                chord_tolerance_mm,
            };
            let text = cutter::grind(&profile, &g, feed_mm_min, &out, svg.as_deref()).map_err(refused)?;
            emit(&text)
        }
    }
}

/// `hob cutter design`: the report, the profile (`--toml`) and the plot (`--svg`) written.
fn cutter_design(
    args: &cutter::DesignArgs,
    toml: Option<PathBuf>,
    svg: Option<PathBuf>,
) -> Result<(), Failure> {
    let (mut text, design) = cutter::design_cutter(args).map_err(refused)?;
    if let Some(path) = toml {
        cutter::write(
            &path,
            &cutter::profile_toml(&design.profile).map_err(Failure::other)?,
        )
        .map_err(Failure::other)?;
        text.push_str(&format!("profile written to {}\n", path.display()));
    }
    if let Some(path) = svg {
        cutter::write(&path, &cutter::svg(&design)).map_err(Failure::other)?;
        text.push_str(&format!("plot written to {}\n", path.display()));
    }
    emit(&text)
}

/// `hob bus-load`: refused above the limit.
fn bus_load(machine: Option<PathBuf>) -> Result<(), Failure> {
    let machine = load_machine(machine.as_deref())?;
    let text = can::bus_load(&machine).map_err(refused)?;
    emit(&text)
}

/// `hob can scan|sdo|dump|check-capture`: what was found on stdout, the reason of a failure
/// (the report's last line) on stderr.
fn can(
    command: CanCommand,
    iface: Option<String>,
    machine: Option<PathBuf>,
    timeout_ms: u64,
) -> Result<(), Failure> {
    let machine = load_machine(machine.as_deref())?;
    let iface = iface.unwrap_or_else(|| machine.can.interface.clone());
    let timeout = std::time::Duration::from_millis(timeout_ms);
    let failed = service::ServiceError::Can;
    let result = match command {
        CanCommand::Scan => can::scan(&iface, timeout).map_err(failed),
        CanCommand::Sdo { op } => sdo(&iface, op, timeout),
        CanCommand::Dump { file, count } => {
            let live = file.is_none().then_some(iface.as_str());
            can::dump(&machine, live, file.as_deref(), count).map_err(failed)
        }
        CanCommand::CheckCapture { file, program } => {
            can::check_capture(&machine, &file, program.as_deref()).map_err(failed)
        }
    };
    match result {
        Ok(text) => emit(&text),
        Err(e) => {
            let text = e.to_string();
            let _ = emit(&text);
            eprintln!("hob: {}", text.lines().last().unwrap_or("failed"));
            Err(Failure::Exit(e.exit_code()))
        }
    }
}

/// `hob check [PROGRAM]`: the machine file, and the program on it.
fn check(
    program: Option<PathBuf>,
    machine: Option<PathBuf>,
    library: Option<PathBuf>,
) -> Result<(), Failure> {
    let machine_file = machine_path(machine.as_deref())?;
    let place = Place {
        library,
        machine: Some(machine_file.clone()),
    };
    let machine = hob_store::files::load_machine(&machine_file).map_err(Failure::Refused)?;
    let Some(program) = program else {
        return emit(&format!(
            "{}: ok ({})\n",
            machine_file.display(),
            machine.machine.name
        ));
    };
    let plan = library::plan_file(&program, &place, &machine)?;
    let mut text = format!(
        "{}: ok on {}: {} pass{}, {:.0} s\n",
        program.display(),
        machine_file.display(),
        plan.passes.len(),
        if plan.passes.len() == 1 { "" } else { "es" },
        plan.total_time_s
    );
    for w in &plan.warnings {
        text.push_str(&format!("  note: {w}\n"));
    }
    emit(&text)
}

fn sdo(iface: &str, op: SdoOp, timeout: std::time::Duration) -> Result<String, service::ServiceError> {
    let bad = service::ServiceError::Usage;
    let failed = service::ServiceError::Can;
    match op {
        SdoOp::Read { node, index, sub, ty } => {
            let (index, sub) = (
                can::parse_u16(&index).map_err(bad)?,
                can::parse_u16(&sub).map_err(bad)?,
            );
            can::sdo_read_cmd(iface, node, index, sub as u8, ty, timeout).map_err(failed)
        }
        SdoOp::Write {
            node,
            index,
            sub,
            value,
            ty,
        } => {
            let (index, sub) = (
                can::parse_u16(&index).map_err(bad)?,
                can::parse_u16(&sub).map_err(bad)?,
            );
            can::sdo_write_cmd(iface, node, index, sub as u8, &value, ty, timeout).map_err(failed)
        }
    }
}
