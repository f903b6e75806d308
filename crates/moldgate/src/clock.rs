//! The clock of the report's `timings`.
//!
//! Everywhere but in the browser this is [`std::time::Instant`]. WebAssembly without an
//! operating system (`wasm32-unknown-unknown`) has no clock in its standard library, and
//! `std::time::Instant::now` panics there; so on that target [`Instant`] reads a clock that
//! the front end gives once with [`set_millisecond_clock`] (the browser's
//! `performance.now()`), and reads 0 until one is given. The library itself still does no
//! I/O: it only calls the function it was handed.

/// A moment, as [`std::time::Instant`].
#[cfg(not(all(target_arch = "wasm32", target_os = "unknown")))]
pub use std::time::Instant;

#[cfg(all(target_arch = "wasm32", target_os = "unknown"))]
pub use wasm::Instant;

/// Gives the clock that timings read on `wasm32-unknown-unknown`: a function returning
/// milliseconds from any fixed origin (the browser's `performance.now()`). Elsewhere the
/// operating system's clock is used and this does nothing.
pub fn set_millisecond_clock(clock: fn() -> f64) {
    #[cfg(all(target_arch = "wasm32", target_os = "unknown"))]
    wasm::set(clock);
    #[cfg(not(all(target_arch = "wasm32", target_os = "unknown")))]
    let _ = clock;
}

#[cfg(all(target_arch = "wasm32", target_os = "unknown"))]
mod wasm {
    use std::sync::OnceLock;
    use std::time::Duration;

    static CLOCK: OnceLock<fn() -> f64> = OnceLock::new();

    pub(super) fn set(clock: fn() -> f64) {
        let _ = CLOCK.set(clock);
    }

    fn now_ms() -> f64 {
        CLOCK.get().map_or(0.0, |c| c())
    }

    /// A moment in milliseconds of the clock given to
    /// [`set_millisecond_clock`](super::set_millisecond_clock).
    #[derive(Debug, Clone, Copy, PartialEq, PartialOrd)]
    pub struct Instant(f64);

    impl Instant {
        /// Now.
        pub fn now() -> Instant {
            Instant(now_ms())
        }

        /// The time since this moment (zero if the clock went backwards or is not set).
        pub fn elapsed(&self) -> Duration {
            let ms = now_ms() - self.0;
            if ms.is_finite() && ms > 0.0 {
                Duration::from_secs_f64(ms / 1000.0)
            } else {
                Duration::ZERO
            }
        }
    }
}
