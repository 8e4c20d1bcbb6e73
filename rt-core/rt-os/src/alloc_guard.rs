//! `hob-rt`'s global allocator: counts every heap operation made inside a control cycle,
//! and serves the small ones from a preallocated, lock-free block pool instead of the
//! system heap.
//!
//! Why a pool: iceoryx2 0.10's `Publisher::loan_uninit` (and so `send_copy`) allocates a
//! small reference-counted block per sample and frees it when the sample is sent (measured
//! here with this allocator's trace). Inside the cycle such blocks come from the pool:
//! O(1)-bounded (a scan of at most [`POOL_WORDS`] bitmap words), no lock, no syscall, memory
//! locked at start-up. Anything the pool cannot serve (too large, pool exhausted, not yet
//! prepared) goes to the system heap and is counted as a *system* allocation in the cycle:
//! the target, checked by the multi-process tests, is zero.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};

/// Size and alignment of a pool block.
pub const BLOCK_BYTES: usize = 256;
/// Bitmap words; 64 blocks each.
pub const POOL_WORDS: usize = 16;
const BLOCKS: usize = POOL_WORDS * 64;

static SYSTEM_IN_CYCLE: AtomicU64 = AtomicU64::new(0);
static POOL_IN_CYCLE: AtomicU64 = AtomicU64::new(0);
static INSTALLED: AtomicBool = AtomicBool::new(false);
static POOL_BASE: AtomicUsize = AtomicUsize::new(0);
static POOL_USED: [AtomicU64; POOL_WORDS] = [const { AtomicU64::new(0) }; POOL_WORDS];

thread_local! {
    static IN_CYCLE: Cell<bool> = const { Cell::new(false) };
}

/// The system allocator, counting what a cycle does and serving it from the pool.
#[derive(Debug)]
pub struct CountingAllocator;

fn in_cycle_now() -> bool {
    IN_CYCLE.try_with(Cell::get).unwrap_or(false)
}

fn pool_take() -> Option<*mut u8> {
    let base = POOL_BASE.load(Ordering::Acquire);
    if base == 0 {
        return None;
    }
    for (w, word) in POOL_USED.iter().enumerate() {
        let mut cur = word.load(Ordering::Relaxed);
        while cur != u64::MAX {
            let bit = (!cur).trailing_zeros() as usize;
            match word.compare_exchange_weak(cur, cur | (1 << bit), Ordering::Acquire, Ordering::Relaxed) {
                Ok(_) => return Some((base + (w * 64 + bit) * BLOCK_BYTES) as *mut u8),
                Err(now) => cur = now,
            }
        }
    }
    None
}

/// Returns the block if `ptr` is in the pool.
fn pool_give(ptr: *mut u8) -> bool {
    let base = POOL_BASE.load(Ordering::Acquire);
    let p = ptr as usize;
    if base == 0 || p < base || p >= base + BLOCKS * BLOCK_BYTES {
        return false;
    }
    let i = (p - base) / BLOCK_BYTES;
    POOL_USED[i / 64].fetch_and(!(1 << (i % 64)), Ordering::Release);
    true
}

fn fits(layout: &Layout) -> bool {
    layout.size() <= BLOCK_BYTES && layout.align() <= BLOCK_BYTES
}

#[allow(unsafe_code)]
// SAFETY: forwards to the system allocator, or hands out disjoint blocks of a pool that
// lives for the whole process; every block is returned exactly once by `dealloc`.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        INSTALLED.store(true, Ordering::Relaxed);
        if in_cycle_now() {
            if fits(&layout)
                && let Some(p) = pool_take()
            {
                POOL_IN_CYCLE.fetch_add(1, Ordering::Relaxed);
                return p;
            }
            SYSTEM_IN_CYCLE.fetch_add(1, Ordering::Relaxed);
        }
        // SAFETY: the caller's contract is passed on unchanged.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        if pool_give(ptr) {
            return;
        }
        if in_cycle_now() {
            SYSTEM_IN_CYCLE.fetch_add(1, Ordering::Relaxed);
        }
        // SAFETY: not a pool block, so it came from the system allocator.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let base = POOL_BASE.load(Ordering::Acquire);
        let in_pool = base != 0 && (ptr as usize) >= base && (ptr as usize) < base + BLOCKS * BLOCK_BYTES;
        if in_pool {
            if new_size <= BLOCK_BYTES {
                return ptr;
            }
            // SAFETY: a fresh allocation of the new size; the old block is copied then freed.
            unsafe {
                let new = self.alloc(Layout::from_size_align_unchecked(new_size, layout.align()));
                if !new.is_null() {
                    std::ptr::copy_nonoverlapping(ptr, new, layout.size());
                    pool_give(ptr);
                }
                return new;
            }
        }
        if in_cycle_now() {
            SYSTEM_IN_CYCLE.fetch_add(1, Ordering::Relaxed);
        }
        // SAFETY: as above.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// Allocates the pool (start-up, before `mlockall`).
#[allow(unsafe_code)]
pub fn prepare_pool() {
    if POOL_BASE.load(Ordering::Acquire) != 0 {
        return;
    }
    let Ok(layout) = Layout::from_size_align(BLOCKS * BLOCK_BYTES, BLOCK_BYTES) else {
        return;
    };
    // SAFETY: a non-zero-size layout; the memory is never freed (it lives as long as the
    // process) and is touched here so it is resident.
    let p = unsafe { System.alloc_zeroed(layout) };
    if !p.is_null() {
        POOL_BASE.store(p as usize, Ordering::Release);
    }
}

/// The calling thread enters (true) or leaves (false) a cycle.
pub fn in_cycle(on: bool) {
    let _ = IN_CYCLE.try_with(|c| c.set(on));
}

/// Heap operations inside cycles: (system heap, pool). `None` when this allocator is not
/// the global one (nothing would be counted).
pub fn counts() -> Option<(u64, u64)> {
    INSTALLED.load(Ordering::Relaxed).then(|| {
        (
            SYSTEM_IN_CYCLE.load(Ordering::Relaxed),
            POOL_IN_CYCLE.load(Ordering::Relaxed),
        )
    })
}
