//! `--timeout`: a timer that cancels a study when its time is up.

use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use moldgate::cancel::Cancel;

/// Sets its token once `limit` has passed, unless it is dropped first (the study ended):
/// then its thread wakes and ends at once.
pub struct Deadline {
    token: Cancel,
    ended: Arc<(Mutex<bool>, Condvar)>,
    thread: Option<JoinHandle<()>>,
}

impl Deadline {
    /// Starts the timer.
    pub fn start(limit: Duration) -> Deadline {
        let token = Cancel::new();
        let ended = Arc::new((Mutex::new(false), Condvar::new()));
        let thread = {
            let (token, ended) = (token.clone(), ended.clone());
            std::thread::spawn(move || {
                let until = Instant::now() + limit;
                let (lock, wake) = &*ended;
                let mut done = lock.lock().unwrap_or_else(|e| e.into_inner());
                while !*done {
                    let left = until.saturating_duration_since(Instant::now());
                    if left.is_zero() {
                        token.cancel();
                        return;
                    }
                    done = wake
                        .wait_timeout(done, left)
                        .unwrap_or_else(|e| e.into_inner())
                        .0;
                }
            })
        };
        Deadline {
            token,
            ended,
            thread: Some(thread),
        }
    }

    /// The token the study reads.
    pub fn token(&self) -> &Cancel {
        &self.token
    }
}

impl Drop for Deadline {
    fn drop(&mut self) {
        let (lock, wake) = &*self.ended;
        *lock.lock().unwrap_or_else(|e| e.into_inner()) = true;
        wake.notify_one();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_token_is_set_when_the_time_is_up_and_not_before() {
        let d = Deadline::start(Duration::from_millis(50));
        assert!(!d.token().is_cancelled());
        std::thread::sleep(Duration::from_millis(300));
        assert!(d.token().is_cancelled());
        // Dropped early, the timer ends at once and never sets its token.
        let t = Instant::now();
        let d = Deadline::start(Duration::from_secs(3600));
        let token = d.token().clone();
        drop(d);
        assert!(t.elapsed() < Duration::from_secs(10));
        assert!(!token.is_cancelled());
    }
}
