//! A cancellation token: a front end keeps one clone, a study hands others to the loops
//! that run long (the fill analysis's marches), and setting any clone stops them all.
//!
//! ```
//! use moldgate::cancel::Cancel;
//!
//! let token = Cancel::new();
//! let inside = token.clone();
//! assert!(!inside.is_cancelled());
//! token.cancel();
//! assert!(inside.is_cancelled());
//! ```

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// A flag shared by its clones: once set it stays set.
#[derive(Debug, Clone, Default)]
pub struct Cancel(Arc<AtomicBool>);

impl Cancel {
    /// A token not yet set.
    pub fn new() -> Cancel {
        Cancel::default()
    }

    /// Sets the token (from any thread, a timer or a signal handler's thread).
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    /// Whether the token, or any clone of it, was set.
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}

/// Whether `token` is given and set.
pub(crate) fn is_set(token: Option<&Cancel>) -> bool {
    token.is_some_and(Cancel::is_cancelled)
}
