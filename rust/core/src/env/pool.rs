//! The batch's worker threads: `threads − 1` helpers kept for the batch's life, and the
//! calling thread working beside them. A call hands out item indices one at a time from one
//! atomic ticket; helpers spin for a short while between calls (a batch step is followed
//! within microseconds by the next one) and then sleep until woken.
//!
//! Rayon's `install` parks the caller while two pool threads work, so every batch step paid
//! two wake-ups and a hand-back, and one of the cores sat idle whenever the caller ran Python.

use std::cell::UnsafeCell;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::Thread;
use std::time::{Duration, Instant};

use crate::error::{Error, Result};

/// How long a helper spins for the next call before it sleeps.
const SPIN: Duration = Duration::from_micros(50);

/// The job of one call: runs item `i`. The lifetime is erased; [`Pool::run`] does not return
/// before every item it handed out has finished.
type Job = *const (dyn Fn(usize) + Sync);

struct Shared {
    /// `generation << 32 | items not yet handed out`. A claim decrements it and runs the item
    /// with the index it leaves; a claim only succeeds while its generation is current.
    ticket: AtomicU64,
    /// Items of the current call that have finished.
    done: AtomicUsize,
    /// The current call's job, written only while no item can be claimed.
    job: UnsafeCell<Option<Job>>,
    shutdown: AtomicBool,
    sleeping: Vec<AtomicBool>,
}

// SAFETY: `job` is written by the calling thread only between calls (no item claimable, every
// claimed item finished) and read by a helper only after it claimed an item of that call,
// whose acquire synchronises with the release that published the call.
unsafe impl Sync for Shared {}
unsafe impl Send for Shared {}

fn generation(t: u64) -> u64 {
    t >> 32
}

impl Shared {
    /// Claims and runs items of generation `gen` until none is left.
    fn work(&self, gen: u64) {
        let mut t = self.ticket.load(Ordering::Acquire);
        loop {
            if generation(t) != gen || t & 0xFFFF_FFFF == 0 {
                return;
            }
            match self.ticket.compare_exchange_weak(t, t - 1, Ordering::AcqRel, Ordering::Acquire) {
                Ok(_) => {
                    let i = ((t & 0xFFFF_FFFF) - 1) as usize;
                    // SAFETY: see `unsafe impl Sync for Shared`.
                    let job = unsafe { (*self.job.get()).expect("a claimable call has a job") };
                    unsafe { (*job)(i) };
                    self.done.fetch_add(1, Ordering::Release);
                    t = self.ticket.load(Ordering::Acquire);
                }
                Err(now) => t = now,
            }
        }
    }
}

/// A pool of `threads − 1` helper threads; the caller of [`Pool::run`] is the last worker.
pub(crate) struct Pool {
    shared: Arc<Shared>,
    /// The helpers (detached: see `Drop`).
    helpers: Vec<Thread>,
    /// Serialises calls (a `Batch` is `&mut` when it steps, but `Pool` stays `Sync`).
    call: Mutex<()>,
}

impl std::fmt::Debug for Pool {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Pool").field("threads", &(self.helpers.len() + 1)).finish()
    }
}

fn helper(shared: Arc<Shared>, k: usize) {
    let mut seen = 0;
    loop {
        let start = Instant::now();
        let mut spins = 0u32;
        let gen = loop {
            let g = generation(shared.ticket.load(Ordering::Acquire));
            if g != seen || shared.shutdown.load(Ordering::Acquire) {
                break g;
            }
            spins = spins.wrapping_add(1);
            if spins.is_multiple_of(64) && start.elapsed() > SPIN {
                shared.sleeping[k].store(true, Ordering::SeqCst);
                if generation(shared.ticket.load(Ordering::SeqCst)) == seen && !shared.shutdown.load(Ordering::SeqCst) {
                    std::thread::park();
                }
                shared.sleeping[k].store(false, Ordering::SeqCst);
            } else {
                std::hint::spin_loop();
            }
        };
        if shared.shutdown.load(Ordering::Acquire) {
            return;
        }
        seen = gen;
        shared.work(gen);
    }
}

/// Most worker threads of a pool (far beyond any machine's cores: a million aborted the
/// process).
pub const MAX_THREADS: usize = 1024;

impl Pool {
    /// Starts `threads − 1` helpers (none for one thread), at most [`MAX_THREADS`] in all.
    pub(crate) fn new(threads: usize) -> Result<Self> {
        if !(1..=MAX_THREADS).contains(&threads) {
            return Err(Error::invalid("threads", format!("must be from 1 to {MAX_THREADS}, got {threads}")));
        }
        let shared = Arc::new(Shared {
            ticket: AtomicU64::new(0),
            done: AtomicUsize::new(0),
            job: UnsafeCell::new(None),
            shutdown: AtomicBool::new(false),
            sleeping: (1..threads).map(|_| AtomicBool::new(false)).collect(),
        });
        // (the pool owns the helpers from the first: if one cannot start, dropping it stops
        // those already running)
        let mut pool = Self { shared, helpers: Vec::with_capacity(threads - 1), call: Mutex::new(()) };
        for k in 0..threads - 1 {
            let s = Arc::clone(&pool.shared);
            let handle = std::thread::Builder::new()
                .name(format!("shieldnav-batch-{k}"))
                .spawn(move || helper(s, k))
                .map_err(|e| Error::invalid("threads", format!("could not start {threads} worker threads: {e}")))?;
            pool.helpers.push(handle.thread().clone());
        }
        Ok(pool)
    }

    /// Runs `f(&mut items[i], i)` for every item, on the helpers and the calling thread. A
    /// panic in `f` becomes an error (the other items still run); of several errors the one
    /// of the lowest index is returned.
    pub(crate) fn run<T: Send, F>(&self, items: &mut [T], f: F) -> Result<()>
    where
        F: Fn(&mut T, usize) -> Result<()> + Sync,
    {
        let n = items.len();
        if n > u32::MAX as usize {
            return Err(Error::invalid("num_envs", format!("at most {} episodes per batch", u32::MAX)));
        }
        let first_error: Mutex<Option<(usize, Error)>> = Mutex::new(None);
        let base = SyncPtr(items.as_mut_ptr());
        let one = |i: usize| {
            // SAFETY: each index is handed out exactly once per call, so no two threads hold
            // the same item, and `items` outlives the call.
            let item = unsafe { &mut *base.get().add(i) };
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| f(item, i))).unwrap_or_else(|_| Err(Error::Solver(format!("episode {i} of the batch panicked"))));
            if let Err(e) = r {
                let mut slot = first_error.lock().unwrap_or_else(|p| p.into_inner());
                if slot.as_ref().is_none_or(|(j, _)| i < *j) {
                    *slot = Some((i, e));
                }
            }
        };
        if self.helpers.is_empty() || n < 2 {
            (0..n).for_each(one);
        } else {
            let _guard = self.call.lock().unwrap_or_else(|p| p.into_inner());
            let s = &*self.shared;
            let job: &(dyn Fn(usize) + Sync) = &one;
            // SAFETY: only the lifetime is erased; this call waits below until every item it
            // handed out has finished, so no helper reads `job` after it returns.
            let job: Job = unsafe { std::mem::transmute::<&(dyn Fn(usize) + Sync), Job>(job) };
            // (wraps after 2³² calls: `work` must see the same 32-bit generation the ticket holds)
            let gen = (generation(s.ticket.load(Ordering::Acquire)) + 1) & 0xFFFF_FFFF;
            s.done.store(0, Ordering::Relaxed);
            // SAFETY: no item is claimable (the last call's ticket is exhausted) and every
            // claimed one has finished.
            unsafe { *s.job.get() = Some(job) };
            s.ticket.store((gen << 32) | n as u64, Ordering::SeqCst);
            for (k, thread) in self.helpers.iter().enumerate() {
                if s.sleeping[k].load(Ordering::SeqCst) {
                    thread.unpark();
                }
            }
            s.work(gen);
            let mut spins = 0u32;
            while s.done.load(Ordering::Acquire) != n {
                spins = spins.wrapping_add(1);
                if spins.is_multiple_of(1024) {
                    std::thread::yield_now();
                } else {
                    std::hint::spin_loop();
                }
            }
            unsafe { *s.job.get() = None };
        }
        match first_error.into_inner().unwrap_or_else(|p| p.into_inner()) {
            Some((_, e)) => Err(e),
            None => Ok(()),
        }
    }
}

impl Drop for Pool {
    /// Tells the helpers to stop and lets them go without joining them (as rayon does): no
    /// call is running, and a copy of the pool in a forked child has no threads to join.
    fn drop(&mut self) {
        self.shared.shutdown.store(true, Ordering::SeqCst);
        for thread in &self.helpers {
            thread.unpark();
        }
    }
}

/// A raw pointer shared by the workers of one call.
struct SyncPtr<T>(*mut T);
// SAFETY: used only to reach disjoint items (see `Pool::run`).
unsafe impl<T: Send> Sync for SyncPtr<T> {}
impl<T> SyncPtr<T> {
    fn get(&self) -> *mut T {
        self.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_item_runs_once_over_many_calls_and_errors_name_the_lowest_index() {
        for threads in 1..=4 {
            let pool = Pool::new(threads).unwrap();
            for call in 0..300usize {
                let mut items: Vec<usize> = vec![0; call % 70];
                pool.run(&mut items, |x, i| {
                    *x += i + 1;
                    Ok(())
                })
                .unwrap();
                assert!(items.iter().enumerate().all(|(i, &x)| x == i + 1), "threads {threads} call {call}");
                if call % 50 == 0 {
                    std::thread::sleep(SPIN * 2); // the helpers park and must be woken
                }
            }
            let mut items = vec![0u8; 40];
            let e = pool
                .run(&mut items, |_, i| match i {
                    7 | 30 => Err(Error::invalid("item", format!("{i}"))),
                    12 => panic!("boom"),
                    _ => Ok(()),
                })
                .unwrap_err();
            assert!(e.to_string().contains('7'), "{e}");
            let mut items = vec![0u8; 40];
            let e = pool.run(&mut items, |_, i| if i == 12 { panic!("boom") } else { Ok(()) }).unwrap_err();
            assert!(e.to_string().contains("episode 12"), "{e}");
        }
        assert!(Pool::new(0).is_err());
    }

    /// Thread counts beyond the bound are errors naming them (a million aborted the process).
    #[test]
    fn thread_counts_are_bounded() {
        for threads in [0, MAX_THREADS + 1, 1_000_000] {
            let e = match Pool::new(threads) {
                Ok(_) => panic!("{threads} threads accepted"),
                Err(e) => e.to_string(),
            };
            assert!(e.contains("`threads`"), "{e}");
        }
    }

    #[test]
    fn the_generation_wraps_without_losing_a_call() {
        let pool = Pool::new(2).unwrap();
        pool.shared.ticket.store(0xFFFF_FFFE << 32, Ordering::SeqCst);
        let caller = std::thread::current().id();
        for call in 0..4 {
            // slow items: the calling thread takes its share unless it lost track of the call
            let mut items = vec![None; 20];
            pool.run(&mut items, |x, _| {
                std::thread::sleep(Duration::from_millis(1));
                *x = Some(std::thread::current().id());
                Ok(())
            })
            .unwrap();
            assert!(items.iter().all(|x| x.is_some()));
            assert!(items.contains(&Some(caller)), "call {call}: the caller ran none of its items");
        }
        assert_eq!(generation(pool.shared.ticket.load(Ordering::SeqCst)), 2);
    }

    #[test]
    fn dropped_pools_stop_their_helpers() {
        let shared = {
            let pool = Pool::new(3).unwrap();
            let mut items = vec![0u8; 10];
            pool.run(&mut items, |x, _| {
                *x = 1;
                Ok(())
            })
            .unwrap();
            Arc::clone(&pool.shared)
        };
        // the two helpers drop their handles to the shared state as they leave
        let start = Instant::now();
        while Arc::strong_count(&shared) > 1 {
            assert!(start.elapsed() < Duration::from_secs(10), "helpers still running");
            std::thread::sleep(Duration::from_millis(1));
        }
    }
}
