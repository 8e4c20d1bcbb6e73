//! `hob commission`: the procedures of `hob_commission`, at the command line: the steps
//! said on stderr, the proposal and its diff on stdout, written on `--yes` or `yes` typed
//! at the question (on a terminal; otherwise nothing is written). Stopping the command
//! stops the table within the loop's dead-man time.

use crate::util::Failure;
use hob_commission::Stop;
use hob_commission::backlash::{self, BacklashOptions};
use hob_commission::delay::{self, DelayOptions};
use hob_commission::encoder::{self, EncoderOptions};
use hob_commission::response::{self, ResponseOptions};
use std::io::{BufRead, IsTerminal, Write};
use std::path::Path;

/// `hob commission delay`: measure, show, and write on confirmation.
pub fn delay(machine_file: &Path, o: &DelayOptions, yes: bool) -> Result<String, Failure> {
    let p = delay::run(machine_file, o, &|| true, &mut |step| {
        eprintln!("commission delay: {step}")
    })
    .map_err(stopped)?;
    confirm_and_write(machine_file, &p.text(), yes, || p.write())
}

/// `hob commission encoder`: measure, show, and write on confirmation.
pub fn encoder(machine_file: &Path, o: &EncoderOptions, yes: bool) -> Result<String, Failure> {
    let p = encoder::run(machine_file, o, &|| true, &mut |step| {
        eprintln!("commission encoder: {step}")
    })
    .map_err(stopped)?;
    confirm_and_write(machine_file, &p.text(), yes, || p.write())
}

/// `hob commission backlash`: measure, show, and write on confirmation.
pub fn backlash(machine_file: &Path, o: &BacklashOptions, yes: bool) -> Result<String, Failure> {
    let p = backlash::run(machine_file, o, &|| true, &mut |step| {
        eprintln!("commission backlash: {step}")
    })
    .map_err(stopped)?;
    confirm_and_write(machine_file, &p.text(), yes, || p.write())
}

/// `hob commission response`: measure, show (the Bode plot to `svg`), and write on
/// confirmation.
pub fn response(
    machine_file: &Path,
    o: &ResponseOptions,
    svg: Option<&Path>,
    yes: bool,
) -> Result<String, Failure> {
    let p = response::run(machine_file, o, &|| true, &mut |step| {
        eprintln!("commission response: {step}")
    })
    .map_err(stopped)?;
    if let Some(path) = svg {
        std::fs::write(path, response::bode::svg(&p.measured))
            .map_err(|e| Failure::Other(format!("{}: {e}", path.display())))?;
        eprintln!("commission response: the Bode plot: {}", path.display());
    }
    confirm_and_write(machine_file, &p.text(), yes, || p.write())
}

/// `hob commission report`: the machine file's records in words; the encoder's plot to
/// `svg` (refused when the file has no encoder record to plot).
pub fn report(machine_file: &Path, svg: Option<&Path>) -> Result<String, Failure> {
    let machine = hob_store::files::load_machine(machine_file).map_err(|e| {
        eprintln!("hob: refused: {e}");
        Failure::Exit(2)
    })?;
    let mut out = hob_commission::report::text(&machine);
    if let Some(path) = svg {
        let Some(e) = machine
            .commissioning
            .as_ref()
            .and_then(|c| c.spindle_encoder.as_ref())
        else {
            eprintln!(
                "hob: refused: --svg: {} has no [commissioning.spindle_encoder] to plot",
                machine_file.display()
            );
            return Err(Failure::Exit(2));
        };
        let plot = hob_commission::report::encoder_svg(e, machine.spindle.max_spindle_rpm);
        std::fs::write(path, plot).map_err(|e| Failure::Other(format!("{}: {e}", path.display())))?;
        out.push_str(&format!("the spindle encoder's plot: {}\n", path.display()));
    }
    Ok(out)
}

/// Shows a proposal, and writes it on `--yes` or a typed yes.
fn confirm_and_write(
    machine_file: &Path,
    proposal: &str,
    yes: bool,
    write: impl FnOnce() -> Result<std::path::PathBuf, Stop>,
) -> Result<String, Failure> {
    print!("{proposal}");
    let _ = std::io::stdout().flush();
    if !confirmed(yes)? {
        return Ok(format!(
            "not written: {} is unchanged (run again with --yes, or answer yes, to write it)\n",
            machine_file.display()
        ));
    }
    let kept = write().map_err(stopped)?;
    Ok(format!(
        "written: {} (the old file kept as {}); restart hob-rt for it to take effect\n",
        machine_file.display(),
        kept.display()
    ))
}

/// A refusal exits 2, anything else 1.
fn stopped(s: Stop) -> Failure {
    match s {
        Stop::Refused(text) => {
            eprintln!("hob: refused: {text}");
            Failure::Exit(2)
        }
        Stop::Failed(text) => Failure::Other(text),
    }
}

/// `--yes`, or `yes` typed at the question on a terminal.
fn confirmed(yes: bool) -> Result<bool, Failure> {
    if yes {
        return Ok(true);
    }
    if !std::io::stdin().is_terminal() {
        return Ok(false);
    }
    print!("write these changes? type yes to write: ");
    let _ = std::io::stdout().flush();
    let mut line = String::new();
    std::io::stdin()
        .lock()
        .read_line(&mut line)
        .map_err(|e| Failure::Other(format!("stdin: {e}")))?;
    Ok(line.trim() == "yes")
}
