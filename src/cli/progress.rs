//! Progress for single long steps (an acceleration-structure or BVH build, a FLIP comparison):
//! a spinner on stderr that appears only when stderr is a terminal and only once the step has
//! run for a second, so short steps and redirected output print nothing.

use std::io::IsTerminal as _;
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressStyle};

/// How long a step runs before its spinner appears.
const DELAY: Duration = Duration::from_secs(1);

/// A delayed spinner; dropping it ends the step (and clears the spinner if it was shown).
pub struct Spinner {
    done: Arc<(Mutex<bool>, Condvar)>,
    thread: Option<JoinHandle<()>>,
}

impl Spinner {
    /// Starts timing a step described by `message`; shows a spinner after [`DELAY`].
    pub fn start(message: impl Into<String>) -> Self {
        let done = Arc::new((Mutex::new(false), Condvar::new()));
        if !std::io::stderr().is_terminal() {
            return Self { done, thread: None };
        }
        let message = message.into();
        let shared = Arc::clone(&done);
        let thread = std::thread::spawn(move || {
            let (lock, cvar) = &*shared;
            let Ok(guard) = lock.lock() else { return };
            let Ok((guard, _)) = cvar.wait_timeout_while(guard, DELAY, |done| !*done) else {
                return;
            };
            if *guard {
                return;
            }
            let bar = ProgressBar::new_spinner()
                .with_message(message)
                .with_elapsed(DELAY);
            bar.set_style(
                ProgressStyle::with_template("{spinner} {msg} {elapsed}")
                    .unwrap_or_else(|_| ProgressStyle::default_spinner()),
            );
            bar.enable_steady_tick(Duration::from_millis(120));
            // Released before clearing, so that `drop` is not kept waiting on the lock.
            drop(cvar.wait_while(guard, |done| !*done));
            bar.finish_and_clear();
        });
        Self {
            done,
            thread: Some(thread),
        }
    }
}

impl Drop for Spinner {
    fn drop(&mut self) {
        let (lock, cvar) = &*self.done;
        if let Ok(mut done) = lock.lock() {
            *done = true;
        }
        cvar.notify_all();
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// What [`rqr::render::Renderer::new`] spends its time on for `backend`.
pub fn build_message(backend: rqr::accel::Backend) -> &'static str {
    match backend {
        rqr::accel::Backend::Hw => "uploading the scene, building acceleration structures",
        rqr::accel::Backend::Bvh => "uploading the scene, building the BVH",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_spinner_ends_when_dropped() {
        // Under `cargo test` stderr is usually captured (not a terminal): no thread at all;
        // either way dropping must return promptly.
        let started = std::time::Instant::now();
        drop(Spinner::start("step"));
        assert!(started.elapsed() < DELAY);
    }
}
