//! A one-line progress bar on stderr for long runs: the parts of a batch, or the stages of
//! one part's study (fed by the library's progress hook).
//!
//! It is drawn only when stderr is a terminal, the caller allows it (`--quiet` does not), and
//! the run has lasted [`DELAY`]: short runs and redirected stderr never see it. A thread
//! redraws it every [`REDRAW`] and erases it when the run ends, so the table and the error
//! lines that follow start on a clean line.

use std::io::{IsTerminal, Write};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError, Sender};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How long a run lasts before the bar appears.
const DELAY: Duration = Duration::from_secs(1);
/// How often the bar is redrawn.
const REDRAW: Duration = Duration::from_millis(100);
/// Width of the bar in characters.
const WIDTH: usize = 30;

/// Steps of a study's bar (its fraction in thousandths).
const STUDY_STEPS: usize = 1000;

/// Counts finished parts (or a study's progress) and, for long runs on a terminal, shows
/// them.
pub struct Progress {
    done: Arc<AtomicUsize>,
    /// The stage under way, for a study's bar; empty for a batch.
    stage: Arc<Mutex<&'static str>>,
    stop: Option<Sender<()>>,
    thread: Option<JoinHandle<()>>,
}

impl Progress {
    /// Starts counting `total` parts; draws only if `allowed` and stderr is a terminal.
    pub fn start(total: usize, allowed: bool) -> Progress {
        Progress::start_with(total, allowed, "")
    }

    /// Starts the bar of one part's study; [`Progress::study`] moves it.
    pub fn start_study(allowed: bool) -> Progress {
        Progress::start_with(STUDY_STEPS, allowed, "load")
    }

    fn start_with(total: usize, allowed: bool, first: &'static str) -> Progress {
        let done = Arc::new(AtomicUsize::new(0));
        let stage = Arc::new(Mutex::new(first));
        if !allowed || !std::io::stderr().is_terminal() {
            return Progress {
                done,
                stage,
                stop: None,
                thread: None,
            };
        }
        let (stop, stopped) = mpsc::channel::<()>();
        let counter = Arc::clone(&done);
        let label = Arc::clone(&stage);
        let thread = std::thread::spawn(move || {
            let start = Instant::now();
            // Nothing is drawn if the run ends within DELAY.
            match stopped.recv_timeout(DELAY) {
                Err(RecvTimeoutError::Timeout) => {}
                _ => return,
            }
            loop {
                let stage = *label.lock().unwrap_or_else(|e| e.into_inner());
                draw(
                    counter.load(Ordering::Relaxed),
                    total,
                    stage,
                    start.elapsed(),
                );
                match stopped.recv_timeout(REDRAW) {
                    Err(RecvTimeoutError::Timeout) => continue,
                    _ => break,
                }
            }
            // Erase the line.
            let _ = write!(std::io::stderr(), "\r\x1b[2K");
        });
        Progress {
            done,
            stage,
            stop: Some(stop),
            thread: Some(thread),
        }
    }

    /// Where the study is (the library's progress hook).
    pub fn study(&self, p: moldgate::study::Progress) {
        let steps = (p.fraction.clamp(0.0, 1.0) * STUDY_STEPS as f64) as usize;
        self.done.store(steps, Ordering::Relaxed);
        *self.stage.lock().unwrap_or_else(|e| e.into_inner()) = p.stage.name();
    }

    /// One more part is finished.
    pub fn tick(&self) {
        self.done.fetch_add(1, Ordering::Relaxed);
    }

    /// Stops the bar and erases it.
    pub fn finish(mut self) {
        self.stop_thread();
    }

    fn stop_thread(&mut self) {
        drop(self.stop.take());
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.stop_thread();
    }
}

/// `\r[=========>          ] 7/18 parts, 1.4 s`, or for a study
/// `\r[=========>          ] fill, 1.4 s`.
fn draw(done: usize, total: usize, stage: &str, elapsed: Duration) {
    let what = if stage.is_empty() {
        format!("{done}/{total} parts")
    } else {
        stage.replace('_', " ")
    };
    let _ = write!(
        std::io::stderr(),
        "\r\x1b[2K{} {what}, {:.1} s",
        bar(done, total),
        elapsed.as_secs_f64()
    );
}

/// The bar itself, `[` + WIDTH characters + `]`.
fn bar(done: usize, total: usize) -> String {
    let filled = (done * WIDTH)
        .checked_div(total)
        .unwrap_or(WIDTH)
        .min(WIDTH);
    let mut s = String::with_capacity(WIDTH + 2);
    s.push('[');
    for i in 0..WIDTH {
        s.push(if i < filled {
            '='
        } else if i == filled {
            '>'
        } else {
            ' '
        });
    }
    s.push(']');
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bar_fills_in_proportion() {
        assert_eq!(bar(0, 4), format!("[>{}]", " ".repeat(WIDTH - 1)));
        assert_eq!(
            bar(2, 4),
            format!("[{}>{}]", "=".repeat(15), " ".repeat(14))
        );
        assert_eq!(bar(4, 4), format!("[{}]", "=".repeat(WIDTH)));
        assert_eq!(bar(0, 0), format!("[{}]", "=".repeat(WIDTH)));
    }

    #[test]
    fn counts_without_a_terminal() {
        let p = Progress::start(3, false);
        p.tick();
        p.tick();
        assert_eq!(p.done.load(Ordering::Relaxed), 2);
        assert!(p.thread.is_none());
        p.finish();
    }
}
