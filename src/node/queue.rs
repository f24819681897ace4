//! A bounded queue between the DDS readers and the processing task: when input comes faster
//! than it is served, the oldest message is dropped and counted, so memory stays flat and the
//! node keeps working on the newest data.

use std::collections::VecDeque;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use tokio::sync::Notify;

pub struct DropOldest<T> {
    items: Mutex<VecDeque<T>>,
    capacity: usize,
    dropped: AtomicU64,
    notify: Notify,
}

impl<T> DropOldest<T> {
    pub fn new(capacity: usize) -> Self {
        DropOldest {
            items: Mutex::new(VecDeque::with_capacity(capacity.min(65_536))),
            capacity: capacity.max(1),
            dropped: AtomicU64::new(0),
            notify: Notify::new(),
        }
    }

    /// Adds `item`; if the queue is full the oldest item is dropped and counted.
    pub fn push(&self, item: T) {
        {
            let mut q = self.items.lock().unwrap_or_else(|p| p.into_inner());
            if q.len() >= self.capacity {
                q.pop_front();
                self.dropped.fetch_add(1, Ordering::Relaxed);
            }
            q.push_back(item);
        }
        self.notify.notify_one();
    }

    /// Takes everything queued, waiting until there is something.
    pub async fn drain(&self, into: &mut Vec<T>) {
        loop {
            {
                let mut q = self.items.lock().unwrap_or_else(|p| p.into_inner());
                if !q.is_empty() {
                    into.extend(q.drain(..));
                    return;
                }
            }
            self.notify.notified().await;
        }
    }

    /// Messages dropped so far because the queue was full.
    pub fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }

    /// Counts messages lost before they reached the queue (e.g. gaps in DDS sequence numbers).
    pub fn count_lost(&self, n: u64) {
        self.dropped.fetch_add(n, Ordering::Relaxed);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn drops_the_oldest_and_counts() {
        let q = DropOldest::new(3);
        for i in 0..5 {
            q.push(i);
        }
        let mut v = Vec::new();
        q.drain(&mut v).await;
        assert_eq!(v, vec![2, 3, 4]);
        assert_eq!(q.dropped(), 2);
    }
}
