//! Work spread over every thread of the current rayon pool, for the bulk loops of
//! brdfkit-models (`par`, `raw`) and brdfkit-merl (table reads, lookups).

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Runs `f(index, item)` for every item of `items`, spread over the threads of the
/// current rayon pool: items are handed out from an atomic counter to every worker,
/// which [`rayon::broadcast`] wakes up front. With `par_chunks_mut` a job of a few
/// milliseconds on a 2-thread pool was measured to run on one thread in about a third
/// of the repetitions (the second worker still asleep when the first had split and
/// taken all the work back; docs/performance.md); waking every worker up front removed
/// that bimodality.
pub fn spread<T: Send>(items: Vec<T>, f: impl Fn(usize, T) + Sync) {
    let next = AtomicUsize::new(0);
    let slots: Vec<Mutex<Option<T>>> = items.into_iter().map(|r| Mutex::new(Some(r))).collect();
    rayon::broadcast(|_| {
        loop {
            let i = next.fetch_add(1, Ordering::Relaxed);
            let Some(slot) = slots.get(i) else { break };
            // Each slot is taken once (the counter hands out each index once): the lock
            // is never contended, never poisoned by another item.
            let item = slot.lock().ok().and_then(|mut s| s.take());
            if let Some(item) = item {
                f(i, item);
            }
        }
    });
}
