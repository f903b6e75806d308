//! Buffers handed from one parallel task to the next.
//!
//! Rayon starts a task (and so calls `map_init`'s constructor) for every piece of work it
//! splits off, a dozen or more per loop of the picture, while only as many run at once as
//! there are threads. Buffers taken from a [`Pool`] and given back when a task ends are
//! made once per running task rather than once per task: their pages (the band buffers
//! of the z-buffer, about 0.8 MB a task on a 1600x900 picture; a band of the PNG's
//! filtered rows, 0.3 MB) are mapped and zeroed once per thread, not a dozen times.

use std::ops::{Deref, DerefMut};
use std::sync::Mutex;

/// Values of `T` given back by the tasks that took them.
pub type Pool<T> = Mutex<Vec<T>>;

/// A value taken from a [`Pool`] (or made, when the pool is empty), given back when dropped.
pub struct Pooled<'p, T: Default> {
    value: T,
    pool: &'p Pool<T>,
}

impl<'p, T: Default> Pooled<'p, T> {
    /// A value from `pool`, or `T::default()` when none is free.
    pub fn take(pool: &'p Pool<T>) -> Pooled<'p, T> {
        let value = pool
            .lock()
            .map(|mut free| free.pop().unwrap_or_default())
            .unwrap_or_default();
        Pooled { value, pool }
    }
}

impl<T: Default> Deref for Pooled<'_, T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.value
    }
}

impl<T: Default> DerefMut for Pooled<'_, T> {
    fn deref_mut(&mut self) -> &mut T {
        &mut self.value
    }
}

impl<T: Default> Drop for Pooled<'_, T> {
    fn drop(&mut self) {
        if let Ok(mut free) = self.pool.lock() {
            free.push(std::mem::take(&mut self.value));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_value_given_back_is_taken_again() {
        let pool: Pool<Vec<u8>> = Mutex::new(Vec::new());
        {
            let mut a = Pooled::take(&pool);
            a.reserve(1000);
            a.push(7);
        }
        assert_eq!(pool.lock().unwrap().len(), 1);
        let b = Pooled::take(&pool);
        assert_eq!(*b, vec![7]);
        assert!(b.capacity() >= 1000);
        assert!(pool.lock().unwrap().is_empty());
        let c = Pooled::take(&pool);
        assert!(c.is_empty(), "an empty pool makes a new value");
    }
}
