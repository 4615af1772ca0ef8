//! Recycled byte buffers for the big per-site rasters (occupancy grids).
//!
//! A new procedural site every reset allocates a few megabytes of grids and frees them again;
//! fresh pages from the OS cost a page fault each (about a third of a reset). Grids return
//! their buffers here when dropped and the next grid of the thread takes one back: same
//! contents as a fresh allocation (every byte is refilled), no page faults.

use std::cell::RefCell;

/// Buffers smaller than this are left to the allocator.
const MIN_BYTES: usize = 64 * 1024;
/// Buffers kept per thread.
const KEEP: usize = 6;

thread_local! {
    static POOL: RefCell<Vec<Vec<u8>>> = const { RefCell::new(Vec::new()) };
}

/// A buffer of `len` bytes, every one `fill`: a recycled one when the pool has one large
/// enough, else a new allocation.
pub(crate) fn take(len: usize, fill: u8) -> Vec<u8> {
    if len >= MIN_BYTES {
        let reused = POOL.with(|p| {
            let mut p = p.borrow_mut();
            // the smallest buffer that fits, so big ones stay for big grids
            let k = p.iter().enumerate().filter(|(_, b)| b.capacity() >= len).min_by_key(|(_, b)| b.capacity()).map(|(k, _)| k)?;
            Some(p.swap_remove(k))
        });
        if let Some(mut b) = reused {
            b.clear();
            b.resize(len, fill);
            return b;
        }
    }
    vec![fill; len]
}

/// Returns a buffer to the pool (dropped if small or the pool is full).
pub(crate) fn give(buffer: Vec<u8>) {
    if buffer.capacity() < MIN_BYTES {
        return;
    }
    // `try_with`: a grid dropped while the thread's pool is being torn down just frees
    let _ = POOL.try_with(|p| {
        let mut p = p.borrow_mut();
        if p.len() < KEEP {
            p.push(buffer);
        } else if let Some(k) = p.iter().enumerate().min_by_key(|(_, b)| b.capacity()).map(|(k, _)| k) {
            if p[k].capacity() < buffer.capacity() {
                p[k] = buffer;
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_returned_buffer_is_reused_and_refilled() {
        let mut a = take(100_000, 7);
        a[5] = 1;
        let ptr = a.as_ptr();
        give(a);
        let b = take(90_000, 3);
        assert_eq!(b.as_ptr(), ptr, "the pooled buffer came back");
        assert_eq!(b.len(), 90_000);
        assert!(b.iter().all(|&x| x == 3));
        let c = take(200_000, 0);
        assert_ne!(c.as_ptr(), ptr);
        assert!(c.iter().all(|&x| x == 0));
        give(b);
        let small = take(10, 9);
        assert_eq!(small, vec![9; 10]);
    }
}
