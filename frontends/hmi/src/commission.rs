//! Commissioning from the panel (DIAGNOSTICS): four procedures of `hob_commission`, the
//! same as the CLI's, with the panel's press-and-hold key as their enable:
//!
//! - `delay`: the table drive's delay (`hob commission delay`): the table jogs one way and
//!   back;
//! - `encoder`: the spindle encoder's error told apart from a true once-per-turn swing
//!   (`hob commission encoder`): the hob spindle is held at six speeds up to the machine's
//!   largest in turn, a few minutes in all;
//! - `backlash`: the table drive's lost motion at a reversal against a gauge on the table
//!   (`hob commission backlash`): the table jogs slowly +, - and + again (some 17 s); refused
//!   when the machine file names no gauge;
//! - `response`: the table's frequency response through the worm (`hob commission
//!   response`): the table's target swings by about an arcsec at 32 frequencies while the
//!   table creeps + at 36 deg/min (a minute or two); the drive's gains proposed with their
//!   margins, and the Bode plot ([`hob_commission::response::bode::svg`]) with the proposal;
//!   refused when the machine file has no `[table.drive_model]` or the drive reported no
//!   gains at boot.
//!
//! A press starts the procedure of its key; the page renews the hold every 100 ms while the
//! finger is on the key (a renewal never starts another); the procedure asks before every
//! renewal of its jog or spindle hold whether the last renewal is younger than
//! [`ENABLE_S`], so lifting the finger, hiding the page or losing the socket stops the table
//! or the spindle (and the loop's own dead-man stops it if this server dies).
//!
//! One procedure runs at a time: a press on the same key while it runs only holds its
//! enable; a press on another key is refused in words (nothing starts, and the press does
//! not hold the running one's enable: its renewals, as every renewal, never revive an enable
//! let go, and letting go of it drops the enable as letting go of the running key does:
//! the enable stays exactly as strict as with one key). The proposal of whichever
//! ran last (its fit, its words, the diff of the machine file) goes with every view while
//! it is held; WRITE writes it only at the builder's level, as the CLI's `--yes`, the old
//! file kept. Starting any procedure drops it.
//!
//! Measuring needs the level that may command the machine; writing the one that may edit
//! machine data. The procedures' words are English (the catalogue does not hold them yet).

use crate::app::App;
use hob_commission::Stop;
use hob_commission::backlash::{self, BacklashOptions};
use hob_commission::delay::{self, DelayOptions};
use hob_commission::encoder::{self, EncoderOptions};
use hob_commission::response::model::Stability;
use hob_commission::response::{self, ResponseOptions};
use hob_ipc::gateway::Action;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tokio::sync::mpsc;

/// The enable holds this long after the page's last renewal (the page renews every 100 ms).
pub const ENABLE_S: f64 = 0.3;

/// A procedure the panel runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Procedure {
    /// The table drive's delay (`hob_commission::delay`).
    Delay,
    /// The spindle encoder's error (`hob_commission::encoder`).
    Encoder,
    /// The table drive's lost motion against a gauge (`hob_commission::backlash`).
    Backlash,
    /// The table's frequency response and the drive's gains (`hob_commission::response`).
    Response,
}

impl Procedure {
    pub const ALL: [Procedure; 4] = [
        Procedure::Delay,
        Procedure::Encoder,
        Procedure::Backlash,
        Procedure::Response,
    ];

    /// The procedure a page names (`delay`, `encoder`, `backlash`, `response`).
    pub fn named(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == name)
    }

    /// Its name in the protocol.
    pub fn name(self) -> &'static str {
        match self {
            Procedure::Delay => "delay",
            Procedure::Encoder => "encoder",
            Procedure::Backlash => "backlash",
            Procedure::Response => "response",
        }
    }

    /// Its name in words.
    pub fn title(self) -> &'static str {
        match self {
            Procedure::Delay => "the table drive's delay",
            Procedure::Encoder => "the spindle encoder",
            Procedure::Backlash => "the table's backlash",
            Procedure::Response => "the table's frequency response",
        }
    }
}

/// The proposal as the page shows it, whichever procedure made it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ProposalView {
    /// `delay`, `encoder`, `backlash` or `response`.
    pub procedure: &'static str,
    /// The machine file WRITE writes.
    pub file: PathBuf,
    /// The fit in words.
    pub report: String,
    /// The lines that change (`-`/`+` with their line numbers).
    pub diff: String,
    /// The proposal and the diff as the CLI prints them.
    pub text: String,
    pub utc: String,
    /// The Bode plot of the points and the fitted model, SVG (the response's only).
    pub bode: Option<String>,
}

impl ProposalView {
    fn of(procedure: Procedure, file: &Path, report: &str, diff: &str, utc: &str, text: String) -> Self {
        Self {
            procedure: procedure.name(),
            file: file.to_path_buf(),
            report: report.to_string(),
            diff: diff.to_string(),
            text,
            utc: utc.to_string(),
            bode: None,
        }
    }

    /// With its Bode plot.
    fn with_bode(self, svg: String) -> Self {
        Self {
            bode: Some(svg),
            ..self
        }
    }
}

/// A measured proposal, held for WRITE.
#[derive(Debug, Clone)]
enum Held {
    Delay(delay::Proposal),
    Encoder(encoder::Proposal),
    Backlash(backlash::Proposal),
    /// Boxed: its analysis (points, fit, margins) is many times the others' size.
    Response(Box<response::Proposal>),
}

impl Held {
    /// The procedure that made it.
    fn procedure(&self) -> Procedure {
        match self {
            Held::Delay(_) => Procedure::Delay,
            Held::Encoder(_) => Procedure::Encoder,
            Held::Backlash(_) => Procedure::Backlash,
            Held::Response(_) => Procedure::Response,
        }
    }

    fn view(&self) -> ProposalView {
        match self {
            Held::Delay(p) => {
                ProposalView::of(Procedure::Delay, &p.file, &p.report, &p.diff, &p.utc, p.text())
            }
            Held::Encoder(p) => {
                ProposalView::of(Procedure::Encoder, &p.file, &p.report, &p.diff, &p.utc, p.text())
            }
            Held::Backlash(p) => {
                ProposalView::of(Procedure::Backlash, &p.file, &p.report, &p.diff, &p.utc, p.text())
            }
            Held::Response(p) => {
                ProposalView::of(Procedure::Response, &p.file, &p.report, &p.diff, &p.utc, p.text())
                    .with_bode(response::bode::svg(&p.measured))
            }
        }
    }

    /// What the page's state line says of it.
    fn summary(&self) -> String {
        match self {
            Held::Delay(p) => format!(
                "found {:.1} us; the machine file has {} us",
                p.measured.found_us, p.measured.assumed_us
            ),
            Held::Encoder(p) => format!(
                "the encoder's error found: {:.1} arcsec once per turn (+- {:.1}); proposed as \
                 [commissioning.spindle_encoder], the fits and the diff below",
                p.measured.separation.encoder[0].amplitude_arcsec(),
                p.measured.separation.error_uncertainty_arcsec
            ),
            Held::Backlash(p) => format!(
                "the table drive's lost motion found: {:.2} arcsec (+- {:.2}); proposed as \
                 [commissioning.table_backlash], the fit and the diff below",
                p.measured.arcsec, p.measured.uncertainty_arcsec
            ),
            Held::Response(p) => response_summary(&p.measured),
        }
    }

    fn write(&self) -> Result<PathBuf, Stop> {
        match self {
            Held::Delay(p) => p.write(),
            Held::Encoder(p) => p.write(),
            Held::Backlash(p) => p.write(),
            Held::Response(p) => p.write(),
        }
    }

    fn file(&self) -> &Path {
        match self {
            Held::Delay(p) => &p.file,
            Held::Encoder(p) => &p.file,
            Held::Backlash(p) => &p.file,
            Held::Response(p) => &p.file,
        }
    }
}

/// What the page shows of the procedure.
#[derive(Debug, Clone, Serialize)]
pub struct View {
    /// The hold or write that this answers.
    pub id: u64,
    /// The procedure it is about (`delay`, `encoder`, `backlash`, `response`; a refused
    /// unknown name as the page sent it).
    pub procedure: String,
    /// `running`, `proposal`, `stopped`, `refused` or `written`.
    pub state: &'static str,
    /// The step under way, the reason it stopped, or where the file was written.
    pub text: String,
    /// The proposal WRITE would write (the last procedure's, while it is held).
    pub proposal: Option<ProposalView>,
}

/// One socket's commissioning.
#[derive(Debug)]
pub struct CommissionSession {
    /// The page's last renewal of its hold (`None`: let go).
    enable: Arc<Mutex<Option<Instant>>>,
    /// The procedure under way.
    running: Arc<Mutex<Option<Procedure>>>,
    proposal: Arc<Mutex<Option<Held>>>,
    tx: mpsc::UnboundedSender<View>,
}

impl CommissionSession {
    /// A session whose views go to `tx` (the socket's loop sends them to the page).
    pub fn new(tx: mpsc::UnboundedSender<View>) -> Self {
        Self {
            enable: Arc::new(Mutex::new(None)),
            running: Arc::new(Mutex::new(None)),
            proposal: Arc::new(Mutex::new(None)),
            tx,
        }
    }

    fn send(&self, id: u64, procedure: &str, state: &'static str, text: String) {
        let _ = self.tx.send(View {
            id,
            procedure: procedure.to_string(),
            state,
            text,
            proposal: lock(&self.proposal).as_ref().map(Held::view),
        });
    }

    /// The finger on a procedure's key: starts it, its enable held (a press on its key
    /// while it runs only holds it; on another key, refused).
    pub fn hold(&self, id: u64, procedure: &str, app: &Arc<App>) {
        self.hold_as(
            id,
            procedure,
            app.not_allowed(Action::Command),
            app.machine_file.clone(),
        );
    }

    /// [`Self::hold`] with the level's refusal (`None`: it may command) and the machine file.
    fn hold_as(&self, id: u64, procedure: &str, not_allowed: Option<String>, file: PathBuf) {
        let Some(which) = Procedure::named(procedure) else {
            self.send(
                id,
                procedure,
                "refused",
                format!(
                    "no commissioning procedure {procedure:?} on this panel (it has {}): nothing runs",
                    Procedure::ALL.map(Procedure::name).join(", ")
                ),
            );
            return;
        };
        {
            let mut running = lock(&self.running);
            match *running {
                Some(r) if r == which => {
                    *lock(&self.enable) = Some(Instant::now());
                    return;
                }
                Some(r) => {
                    drop(running);
                    self.send(
                        id,
                        which.name(),
                        "refused",
                        format!(
                            "{} is being measured: one procedure at a time; let go of its key \
                             and wait for its result, then press this one",
                            r.title()
                        ),
                    );
                    return;
                }
                None => {}
            }
            if let Some(refused) = not_allowed {
                drop(running);
                self.send(id, which.name(), "refused", refused);
                return;
            }
            *lock(&self.enable) = Some(Instant::now());
            *running = Some(which);
        }
        *lock(&self.proposal) = None;
        let (enable, running, proposal, tx) = (
            self.enable.clone(),
            self.running.clone(),
            self.proposal.clone(),
            self.tx.clone(),
        );
        let spawned = std::thread::Builder::new()
            .name(format!("commission-{}", which.name()))
            .spawn(move || {
                let (view, held) = measure(which, id, &file, &enable, &tx);
                if let Some(held) = held {
                    *lock(&proposal) = Some(held);
                }
                *lock(&running) = None;
                let _ = tx.send(view);
            });
        if let Err(e) = spawned {
            *lock(&self.running) = None;
            self.send(
                id,
                which.name(),
                "stopped",
                format!("the measurement could not start: {e}"),
            );
        }
    }

    /// The finger still on the key: the enable renewed (never a new measurement: one that
    /// ended stays ended until the key is pressed again).
    pub fn renew(&self) {
        let mut enable = lock(&self.enable);
        if enable.is_some() {
            *enable = Some(Instant::now());
        }
    }

    /// The finger off the key, the page hidden or the socket gone: the enable drops.
    pub fn release(&self) {
        *lock(&self.enable) = None;
    }

    /// WRITE: the proposal of the procedure that ran last into the machine file (the
    /// builder's level), the old file kept.
    pub fn write(&self, id: u64, app: &Arc<App>) {
        let procedure = |held: Option<&Held>| held.map_or(Procedure::Delay, Held::procedure).name();
        if let Some(refused) = app.not_allowed(Action::EditMachineData) {
            let which = procedure(lock(&self.proposal).as_ref());
            self.send(id, which, "refused", refused);
            return;
        }
        let Some(p) = lock(&self.proposal).take() else {
            let which = lock(&self.running).unwrap_or(Procedure::Delay).name();
            self.send(id, which, "refused", "nothing measured to write".into());
            return;
        };
        let which = procedure(Some(&p));
        match p.write() {
            Ok(kept) => self.send(
                id,
                which,
                "written",
                format!(
                    "written: {} (the old file kept as {}); restart hob-rt for it to take effect",
                    p.file().display(),
                    kept.display()
                ),
            ),
            Err(e) => self.send(id, which, "refused", e.to_string()),
        }
    }
}

impl Drop for CommissionSession {
    fn drop(&mut self) {
        self.release();
    }
}

/// Runs `which` on `file` with the panel's key as its enable (held while `enable` was
/// renewed within [`ENABLE_S`]), each step sent to the page; the view of its end, and the
/// proposal it made.
fn measure(
    which: Procedure,
    id: u64,
    file: &Path,
    enable: &Mutex<Option<Instant>>,
    tx: &mpsc::UnboundedSender<View>,
) -> (View, Option<Held>) {
    let enabled = || lock(enable).is_some_and(|t| t.elapsed() < Duration::from_secs_f64(ENABLE_S));
    let mut say = |step: &str| {
        let _ = tx.send(View {
            id,
            procedure: which.name().to_string(),
            state: "running",
            text: step.to_string(),
            proposal: None,
        });
    };
    let result = match which {
        Procedure::Delay => delay::run(file, &DelayOptions::default(), &enabled, &mut say).map(Held::Delay),
        Procedure::Encoder => {
            encoder::run(file, &EncoderOptions::default(), &enabled, &mut say).map(Held::Encoder)
        }
        Procedure::Backlash => {
            backlash::run(file, &BacklashOptions::default(), &enabled, &mut say).map(Held::Backlash)
        }
        Procedure::Response => response::run(file, &ResponseOptions::default(), &enabled, &mut say)
            .map(|p| Held::Response(Box::new(p))),
    };
    match result {
        Ok(held) => (
            View {
                id,
                procedure: which.name().to_string(),
                state: "proposal",
                text: held.summary(),
                proposal: Some(held.view()),
            },
            Some(held),
        ),
        Err(e) => (
            View {
                id,
                procedure: which.name().to_string(),
                state: if matches!(e, Stop::Refused(_)) {
                    "refused"
                } else {
                    "stopped"
                },
                text: e.to_string(),
                proposal: None,
            },
            None,
        ),
    }
}

/// What the page's state line says of a frequency response: the mesh's frequencies, the
/// present tuning's stability, the gains proposed and their margins (the report below the
/// plot has every figure).
fn response_summary(a: &response::analysis::Analysis) -> String {
    let g = response::analysis::gains_of(&a.proposed.loops);
    let present = match &a.present_stability {
        Stability::Stable { cascade, .. } => format!(
            "stable (cascade GM {:.1} dB, PM {:.1} deg)",
            cascade.gain_margin_db, cascade.phase_margin_deg
        ),
        Stability::Unstable { near_hz, .. } => {
            format!("UNSTABLE (the drive would oscillate near {near_hz:.0} Hz)")
        }
    };
    format!(
        "{} points; the mesh's anti-resonance {:.1} Hz, resonance {:.1} Hz; the present tuning \
         {present}; proposed kp {:.3} Nm s/rad, Ti {:.2} ms, kv {:.1} 1/s with cascade GM {:.1} \
         dB, PM {:.1} deg, as [commissioning.table_drive_gains]: the Bode plot, the fit and the \
         diff below",
        a.points.len(),
        a.modes_hz.0,
        a.modes_hz.1,
        g.velocity_kp_nm_s_per_rad,
        g.velocity_integral_time_ms,
        g.position_kv_per_s,
        a.proposed.cascade.gain_margin_db,
        a.proposed.cascade.phase_margin_deg,
    )
}

/// A poisoned lock is a panic elsewhere: its value is still the last one written.
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn session() -> (CommissionSession, mpsc::UnboundedReceiver<View>) {
        let (tx, rx) = mpsc::unbounded_channel();
        (CommissionSession::new(tx), rx)
    }

    fn file() -> PathBuf {
        PathBuf::from("/nonexistent/machine.toml")
    }

    #[test]
    fn procedures_are_named_as_the_page_names_them() {
        assert_eq!(Procedure::named("delay"), Some(Procedure::Delay));
        assert_eq!(Procedure::named("encoder"), Some(Procedure::Encoder));
        assert_eq!(Procedure::named("backlash"), Some(Procedure::Backlash));
        assert_eq!(Procedure::named("response"), Some(Procedure::Response));
        assert_eq!(Procedure::named("table_response"), None);
        assert_eq!(Procedure::named("table_backlash"), None);
        assert_eq!(Procedure::named("Encoder"), None);
        assert_eq!(Procedure::named(""), None);
    }

    #[test]
    fn an_unknown_procedure_is_refused_and_nothing_runs() {
        let (s, mut rx) = session();
        s.hold_as(7, "spindle", None, file());
        let v = rx.try_recv().expect("a view");
        assert_eq!((v.id, v.state, v.procedure.as_str()), (7, "refused", "spindle"));
        assert!(
            v.text.contains("\"spindle\"") && v.text.contains("delay, encoder, backlash, response"),
            "{}",
            v.text
        );
        assert!(v.text.contains("nothing runs"), "{}", v.text);
        assert_eq!(*lock(&s.running), None, "a procedure runs");
        assert_eq!(*lock(&s.enable), None, "the enable is held");
        assert!(rx.try_recv().is_err(), "more views: nothing should run");
    }

    #[test]
    fn a_panel_that_may_not_command_starts_nothing() {
        let (s, mut rx) = session();
        s.hold_as(
            3,
            "encoder",
            Some("a viewer's panel may not command".into()),
            file(),
        );
        let v = rx.try_recv().expect("a view");
        assert_eq!((v.state, v.procedure.as_str()), ("refused", "encoder"));
        assert_eq!(v.text, "a viewer's panel may not command");
        assert_eq!(*lock(&s.running), None);
        assert_eq!(*lock(&s.enable), None, "the enable is held");
    }

    #[test]
    fn the_other_key_while_one_runs_is_refused_and_never_holds_its_enable() {
        let (s, mut rx) = session();
        // The delay under way, its key let go (the procedure is about to stop): a press on
        // the encoder's key must not hold the delay's enable again.
        *lock(&s.running) = Some(Procedure::Delay);
        s.hold_as(9, "encoder", None, file());
        let v = rx.try_recv().expect("a view");
        assert_eq!((v.id, v.state, v.procedure.as_str()), (9, "refused", "encoder"));
        assert!(
            v.text.starts_with("the table drive's delay is being measured"),
            "{}",
            v.text
        );
        assert_eq!(
            *lock(&s.enable),
            None,
            "the other key held the running one's enable"
        );
        assert_eq!(*lock(&s.running), Some(Procedure::Delay));
        // Its renewals do not revive a let-go enable either.
        s.renew();
        assert_eq!(*lock(&s.enable), None);
        // A press on the running one's own key holds it (as before), nothing else starts.
        s.hold_as(10, "delay", None, file());
        assert!(
            lock(&s.enable).is_some(),
            "the running one's key does not hold it"
        );
        assert!(rx.try_recv().is_err(), "a press on the running key answered");
        s.release();
        assert_eq!(*lock(&s.enable), None);
    }

    /// With `running` under way, a press on `key` (view `id`) is refused in the running
    /// one's `words` and holds no enable; the running one stays.
    fn refused_beside(
        (s, rx): (&CommissionSession, &mut mpsc::UnboundedReceiver<View>),
        running: Procedure,
        (id, key): (u64, &str),
        words: &str,
    ) {
        *lock(&s.running) = Some(running);
        s.hold_as(id, key, None, file());
        let v = rx.try_recv().expect("a view");
        assert_eq!((v.id, v.state, v.procedure.as_str()), (id, "refused", key));
        assert!(v.text.starts_with(words), "{}", v.text);
        assert_eq!(*lock(&s.enable), None, "{key}'s key held {running:?}'s enable");
        assert_eq!(*lock(&s.running), Some(running));
    }

    /// With `running` under way, a press on its own key (view `id`) holds its enable and
    /// answers nothing; nothing else starts.
    fn own_key_holds(
        (s, rx): (&CommissionSession, &mut mpsc::UnboundedReceiver<View>),
        running: Procedure,
        (id, key): (u64, &str),
    ) {
        s.hold_as(id, key, None, file());
        assert!(
            lock(&s.enable).is_some(),
            "the running one's key does not hold it"
        );
        assert_eq!(*lock(&s.running), Some(running));
        assert!(rx.try_recv().is_err(), "a press on the running key answered");
    }

    #[test]
    fn the_backlash_key_is_refused_while_another_runs_and_refuses_the_others_while_it_runs() {
        let (s, mut rx) = session();
        // The encoder under way, its key let go: a press on TABLE BACKLASH is refused and
        // does not hold the encoder's enable.
        let encoder_words = "the spindle encoder is being measured: one procedure at a time";
        refused_beside((&s, &mut rx), Procedure::Encoder, (11, "backlash"), encoder_words);
        // The backlash under way: the delay's and the encoder's keys are refused in its words.
        for (id, other) in [(12, "delay"), (13, "encoder")] {
            let words = "the table's backlash is being measured";
            refused_beside((&s, &mut rx), Procedure::Backlash, (id, other), words);
        }
        own_key_holds((&s, &mut rx), Procedure::Backlash, (14, "backlash"));
    }

    #[test]
    fn the_backlash_on_a_machine_file_naming_no_gauge_is_refused_in_words() {
        // The shipped machine file names no table gauge: the procedure runs and refuses
        // before anything moves (it never reaches the loop), and nothing is held for WRITE.
        let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/machine.toml");
        let (s, mut rx) = session();
        s.hold_as(21, "backlash", None, shipped);
        let end = Instant::now() + Duration::from_secs(10);
        let v = loop {
            match rx.try_recv() {
                Ok(v) => break v,
                Err(_) if Instant::now() < end => std::thread::sleep(Duration::from_millis(10)),
                Err(e) => panic!("no view in 10 s: {e}"),
            }
        };
        assert_eq!((v.id, v.state, v.procedure.as_str()), (21, "refused", "backlash"));
        assert!(
            v.text
                .contains("names no table gauge (io.analog_inputs.table_gauge)")
                && v.text.contains("nothing measured"),
            "{}",
            v.text
        );
        assert!(v.proposal.is_none());
        let end = Instant::now() + Duration::from_secs(5);
        while lock(&s.running).is_some() && Instant::now() < end {
            std::thread::sleep(Duration::from_millis(10));
        }
        assert_eq!(*lock(&s.running), None, "the procedure still runs");
        assert!(lock(&s.proposal).is_none(), "a proposal is held");
    }

    #[test]
    fn the_response_key_is_refused_while_another_runs_and_refuses_the_others_while_it_runs() {
        let (s, mut rx) = session();
        // The backlash under way: a press on TABLE RESPONSE is refused in its words.
        let backlash_words = "the table's backlash is being measured: one procedure at a time";
        refused_beside(
            (&s, &mut rx),
            Procedure::Backlash,
            (31, "response"),
            backlash_words,
        );
        // The response under way: every other key is refused in its words.
        for (id, other) in [(32, "delay"), (33, "encoder"), (34, "backlash")] {
            let words = "the table's frequency response is being measured";
            refused_beside((&s, &mut rx), Procedure::Response, (id, other), words);
        }
        own_key_holds((&s, &mut rx), Procedure::Response, (35, "response"));
    }

    #[test]
    fn the_response_on_a_machine_file_without_the_drive_model_is_refused_in_words() {
        // The shipped machine file without its [table.drive_model]: the procedure refuses
        // before anything moves (it never reaches the loop), and nothing is held for WRITE.
        let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/machine.toml");
        let text = std::fs::read_to_string(&shipped).expect("the shipped machine file");
        let start = text
            .find("[table.drive_model]")
            .expect("the shipped file has the model");
        let end = start + text[start..].find("\n\n").expect("the block's end");
        let without = format!("{}{}", &text[..start], &text[end + 2..]);
        let dir = std::env::temp_dir().join(format!("hob-hmi-response-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("a temporary directory");
        let machine = dir.join("machine.toml");
        std::fs::write(&machine, &without).expect("the machine file written");
        let (s, mut rx) = session();
        s.hold_as(41, "response", None, machine.clone());
        let end = Instant::now() + Duration::from_secs(10);
        let v = loop {
            match rx.try_recv() {
                Ok(v) => break v,
                Err(_) if Instant::now() < end => std::thread::sleep(Duration::from_millis(10)),
                Err(e) => panic!("no view in 10 s: {e}"),
            }
        };
        assert_eq!((v.id, v.state, v.procedure.as_str()), (41, "refused", "response"));
        assert!(
            v.text.contains("has no [table.drive_model]") && v.text.contains("nothing measured"),
            "{}",
            v.text
        );
        assert!(v.proposal.is_none());
        let end = Instant::now() + Duration::from_secs(5);
        while lock(&s.running).is_some() && Instant::now() < end {
            std::thread::sleep(Duration::from_millis(10));
        }
        assert_eq!(*lock(&s.running), None, "the procedure still runs");
        assert!(lock(&s.proposal).is_none(), "a proposal is held");
        assert_eq!(
            std::fs::read_to_string(&machine).expect("the machine file"),
            without,
            "the machine file changed"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn the_view_of_a_response_proposal_carries_its_bode_plot() {
        // A response::Proposal is made only by a whole run on the machine; its view is made
        // of its report, diff and text() with the SVG of bode::svg, as here.
        let report = "table frequency response: 32 points from 2.0 to 250.0 Hz\nproposed: velocity loop GM 9.1 dB, PM 43.0 deg\n";
        let diff = "+ 262 [commissioning.table_drive_gains]\n+ 266 velocity_kp_nm_s_per_rad = 0.0740\n";
        let file = PathBuf::from("/etc/hob/machine.toml");
        let text = format!("{report}changes to {}:\n{diff}", file.display());
        let svg = r#"<svg xmlns="http://www.w3.org/2000/svg"><circle cx="1" cy="2" r="3.5"/></svg>"#;
        let p = ProposalView::of(
            Procedure::Response,
            &file,
            report,
            diff,
            "2026-11-29T09:00:00Z",
            text,
        )
        .with_bode(svg.into());
        let j = serde_json::to_value(&p).expect("json");
        assert_eq!(j["procedure"], "response");
        assert_eq!(j["report"], report);
        assert_eq!(j["diff"], diff);
        assert_eq!(j["bode"], svg);
        // The other procedures' views carry none.
        let b = ProposalView::of(Procedure::Backlash, &file, report, diff, "", String::new());
        assert!(serde_json::to_value(&b).expect("json")["bode"].is_null());
    }

    #[test]
    fn the_view_of_a_backlash_proposal_has_its_report_text_and_diff() {
        // A backlash::Proposal is made only by a whole run on the machine; the view is made
        // of its report, diff and text() as here.
        let report = "lost motion of the table drive: 10.18 +- 0.03 arcsec (each reversal: 10.17, 10.19), at 3.0 deg/min; 42 gauge readings, the motor 0.05 arcsec RMS off the fit\n";
        let diff = "+ 120 [commissioning.table_backlash]\n+ 122 lost_motion_arcsec = 10.18\n";
        let file = PathBuf::from("/etc/hob/machine.toml");
        let text = format!("{report}changes to {}:\n{diff}", file.display());
        let p = ProposalView::of(
            Procedure::Backlash,
            &file,
            report,
            diff,
            "2026-11-29T06:00:00Z",
            text,
        );
        let v = View {
            id: 5,
            procedure: Procedure::Backlash.name().into(),
            state: "proposal",
            text: "the table drive's lost motion found".into(),
            proposal: Some(p),
        };
        let j = serde_json::to_value(&v).expect("json");
        assert_eq!(j["procedure"], "backlash");
        assert_eq!(j["state"], "proposal");
        let p = &j["proposal"];
        assert_eq!(p["procedure"], "backlash");
        assert_eq!(p["report"], report);
        assert_eq!(p["diff"], diff);
        assert_eq!(p["file"], "/etc/hob/machine.toml");
        assert_eq!(p["utc"], "2026-11-29T06:00:00Z");
        let text = p["text"].as_str().expect("text");
        assert!(text.starts_with(report) && text.ends_with(diff), "{text}");
        assert!(text.contains("changes to /etc/hob/machine.toml:"), "{text}");
    }

    #[test]
    fn the_view_of_an_encoder_proposal_has_its_report_text_and_diff() {
        // An encoder::Proposal is made only by a whole run on the machine; the view is made
        // of its report, diff and text() as here.
        let report = "speed    once      twice     three times per turn (arcsec)   residual\n 60.0 rpm   12.00     1.00     0.50                           0.3 arcsec\n";
        let diff = "- 88 [commissioning.spindle_encoder]\n+ 88 [commissioning.spindle_encoder]\n+ 89 once_arcsec = 11.8\n";
        let file = PathBuf::from("/etc/hob/machine.toml");
        let text = format!("{report}changes to {}:\n{diff}", file.display());
        let p = ProposalView::of(
            Procedure::Encoder,
            &file,
            report,
            diff,
            "2026-11-29T02:00:00Z",
            text,
        );
        let v = View {
            id: 4,
            procedure: "encoder".into(),
            state: "proposal",
            text: "the encoder's error found".into(),
            proposal: Some(p),
        };
        let j = serde_json::to_value(&v).expect("json");
        assert_eq!(j["procedure"], "encoder");
        assert_eq!(j["state"], "proposal");
        let p = &j["proposal"];
        assert_eq!(p["procedure"], "encoder");
        assert_eq!(p["report"], report);
        assert_eq!(p["diff"], diff);
        assert_eq!(p["file"], "/etc/hob/machine.toml");
        let text = p["text"].as_str().expect("text");
        assert!(text.starts_with(report) && text.ends_with(diff), "{text}");
        assert!(text.contains("changes to /etc/hob/machine.toml:"), "{text}");
    }
}
