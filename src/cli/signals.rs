//! Ctrl-C, SIGTERM and SIGHUP during `rdr render`. The first signal stops the render
//! and its finished passes are saved. Signals often come in pairs without a person
//! behind the second (`timeout` signals the process and then its group; a terminal
//! closing sends SIGHUP and SIGTERM), so a later signal is ignored unless the save has
//! begun and [`PERSON_DELAY`] has passed since the first: only then does it quit at
//! once, saying that the passes were not saved.

use rdr::integrator::StopToken;
use std::io::Write;
use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// A second signal sooner than this after the first is taken as part of the first.
pub const PERSON_DELAY: Duration = Duration::from_secs(1);

/// Where the render is, for what a signal does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Phase {
    Rendering = 0,
    /// Writing the output file.
    Saving = 1,
    /// The output is written.
    Saved = 2,
}

/// What one signal does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Response {
    /// The first: stop the render, save its finished passes.
    Stop,
    /// Another one that must not cost the finished passes.
    Ignore,
    /// Another one from a person, once the save has begun: quit without it.
    Quit,
}

/// The response to a signal arriving `since_first` after the first one (`None`: it is
/// the first) while the render is in `phase`.
pub fn respond(since_first: Option<Duration>, phase: Phase) -> Response {
    match since_first {
        None => Response::Stop,
        Some(d) if phase == Phase::Saving && d >= PERSON_DELAY => Response::Quit,
        Some(_) => Response::Ignore,
    }
}

/// The signal state of one render.
pub struct Interrupts {
    phase: AtomicU8,
    first: Mutex<Option<Instant>>,
}

impl Interrupts {
    /// Installs the handler: signals set `stop`; the output named in messages is `output`.
    pub fn install(stop: Arc<StopToken>, output: String) -> anyhow::Result<Arc<Interrupts>> {
        use anyhow::Context;
        let me = Arc::new(Interrupts {
            phase: AtomicU8::new(Phase::Rendering as u8),
            first: Mutex::new(None),
        });
        let state = me.clone();
        ctrlc::set_handler(move || {
            let since_first = {
                let mut first = state.first.lock().unwrap_or_else(|e| e.into_inner());
                let since = first.map(|t| t.elapsed());
                first.get_or_insert_with(Instant::now);
                since
            };
            match respond(since_first, state.phase()) {
                Response::Stop => {
                    stop.stop();
                    note!("\ninterrupted: saving the finished passes (once saving has begun, Ctrl-C again quits without them)");
                }
                Response::Ignore => {
                    if state.phase() != Phase::Saved {
                        note!("interrupted again: still saving the finished passes");
                    }
                }
                Response::Quit => {
                    note!("quit at once: the finished passes were not saved ({output} is as it was)");
                    std::process::exit(130);
                }
            }
        })
        .context("cannot install the Ctrl-C handler")?;
        Ok(me)
    }

    pub fn phase(&self) -> Phase {
        match self.phase.load(Ordering::SeqCst) {
            0 => Phase::Rendering,
            1 => Phase::Saving,
            _ => Phase::Saved,
        }
    }

    pub fn set_phase(&self, p: Phase) {
        self.phase.store(p as u8, Ordering::SeqCst);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_a_late_signal_during_the_save_quits() {
        let ms = Duration::from_millis;
        assert_eq!(respond(None, Phase::Rendering), Response::Stop);
        assert_eq!(respond(None, Phase::Saving), Response::Stop);
        // `timeout`'s pair, or a person's double press while the pass is being abandoned
        assert_eq!(respond(Some(ms(0)), Phase::Rendering), Response::Ignore);
        assert_eq!(respond(Some(ms(5000)), Phase::Rendering), Response::Ignore);
        assert_eq!(respond(Some(ms(2)), Phase::Saving), Response::Ignore);
        assert_eq!(respond(Some(PERSON_DELAY - ms(1)), Phase::Saving), Response::Ignore);
        // a person, after the save began and after the delay
        assert_eq!(respond(Some(PERSON_DELAY), Phase::Saving), Response::Quit);
        // once saved there is nothing left to abandon
        assert_eq!(respond(Some(ms(5000)), Phase::Saved), Response::Ignore);
    }
}
