//! Commissioning from the panel (DIAGNOSTICS): the table drive's delay measured by
//! `hob_commission::delay`, the same procedure as `hob commission delay`, with the panel's
//! press-and-hold key as its enable. A press starts it; the page renews the hold every
//! 100 ms while the finger is on the key (a renewal never starts another); the procedure asks before every renewal of the table's jog whether the
//! last renewal is younger than [`ENABLE_S`], so lifting the finger, hiding the page or
//! losing the socket stops the table (and the loop's own dead-man stops it if this server
//! dies). The proposal (the delay, the fit, the diff of the machine file) is shown; WRITE
//! writes it only at the builder's level, as the CLI's `--yes`, the old file kept.
//!
//! Measuring needs the level that may command the machine; writing the one that may edit
//! machine data. The procedure's words are English (the catalogue does not hold them yet).

use crate::app::App;
use hob_commission::Stop;
use hob_commission::delay::{self, DelayOptions, Proposal};
use hob_ipc::gateway::Action;
use serde::Serialize;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tokio::sync::mpsc;

/// The enable holds this long after the page's last renewal (the page renews every 100 ms).
pub const ENABLE_S: f64 = 0.3;

/// What the page shows of the procedure.
#[derive(Debug, Clone, Serialize)]
pub struct View {
    /// The hold or write that this answers.
    pub id: u64,
    /// `running`, `proposal`, `stopped`, `refused` or `written`.
    pub state: &'static str,
    /// The step under way, the reason it stopped, or where the file was written.
    pub text: String,
    pub proposal: Option<Proposal>,
}

/// One socket's commissioning.
#[derive(Debug)]
pub struct CommissionSession {
    /// The page's last renewal of its hold (`None`: let go).
    enable: Arc<Mutex<Option<Instant>>>,
    /// A procedure is under way.
    running: Arc<Mutex<bool>>,
    proposal: Arc<Mutex<Option<Proposal>>>,
    tx: mpsc::UnboundedSender<View>,
}

impl CommissionSession {
    /// A session whose views go to `tx` (the socket's loop sends them to the page).
    pub fn new(tx: mpsc::UnboundedSender<View>) -> Self {
        Self {
            enable: Arc::new(Mutex::new(None)),
            running: Arc::new(Mutex::new(false)),
            proposal: Arc::new(Mutex::new(None)),
            tx,
        }
    }

    fn send(&self, id: u64, state: &'static str, text: String) {
        let _ = self.tx.send(View {
            id,
            state,
            text,
            proposal: None,
        });
    }

    /// The finger on the key: starts the measurement, its enable held (a press while one
    /// runs only holds it).
    pub fn hold(&self, id: u64, app: &Arc<App>) {
        *lock(&self.enable) = Some(Instant::now());
        {
            let mut running = lock(&self.running);
            if *running {
                return;
            }
            if let Some(refused) = app.not_allowed(Action::Command) {
                self.send(id, "refused", refused);
                return;
            }
            *running = true;
        }
        *lock(&self.proposal) = None;
        let (enable, running, proposal, tx) = (
            self.enable.clone(),
            self.running.clone(),
            self.proposal.clone(),
            self.tx.clone(),
        );
        let file = app.machine_file.clone();
        let spawned = std::thread::Builder::new()
            .name("commission".into())
            .spawn(move || {
                let enabled =
                    || lock(&enable).is_some_and(|t| t.elapsed() < Duration::from_secs_f64(ENABLE_S));
                let mut say = |step: &str| {
                    let _ = tx.send(View {
                        id,
                        state: "running",
                        text: step.to_string(),
                        proposal: None,
                    });
                };
                let view = match delay::run(&file, &DelayOptions::default(), &enabled, &mut say) {
                    Ok(p) => {
                        *lock(&proposal) = Some(p.clone());
                        View {
                            id,
                            state: "proposal",
                            text: format!(
                                "found {:.1} us; the machine file has {} us",
                                p.found_us, p.assumed_us
                            ),
                            proposal: Some(p),
                        }
                    }
                    Err(e) => View {
                        id,
                        state: if matches!(e, Stop::Refused(_)) {
                            "refused"
                        } else {
                            "stopped"
                        },
                        text: e.to_string(),
                        proposal: None,
                    },
                };
                *lock(&running) = false;
                let _ = tx.send(view);
            });
        if let Err(e) = spawned {
            *lock(&self.running) = false;
            self.send(id, "stopped", format!("the measurement could not start: {e}"));
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

    /// WRITE: the proposal into the machine file (the builder's level), the old file kept.
    pub fn write(&self, id: u64, app: &Arc<App>) {
        if let Some(refused) = app.not_allowed(Action::EditMachineData) {
            self.send(id, "refused", refused);
            return;
        }
        let Some(p) = lock(&self.proposal).take() else {
            self.send(id, "refused", "nothing measured to write".into());
            return;
        };
        match p.write() {
            Ok(kept) => self.send(
                id,
                "written",
                format!(
                    "written: {} (the old file kept as {}); restart hob-rt for it to take effect",
                    p.file.display(),
                    kept.display()
                ),
            ),
            Err(e) => self.send(id, "refused", e.to_string()),
        }
    }
}

impl Drop for CommissionSession {
    fn drop(&mut self) {
        self.release();
    }
}

/// A poisoned lock is a panic elsewhere: its value is still the last one written.
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}
