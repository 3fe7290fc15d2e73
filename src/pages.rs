//! Large lookup tables on transparent huge pages.
//!
//! An environment map's texels and sampling tables (6–8 MB each for a 1k map, 4× that for
//! 2k) are read at random places, one or two cache lines per sample: with 4 KiB pages
//! nearly every such read also misses the TLB and pays a page walk. Where the kernel leaves
//! transparent huge pages to `madvise` (the usual default), a [`HugeBuf`] of 2 MiB or more
//! starts on a 2 MiB boundary, is rounded up to whole 2 MiB pages and is advised
//! `MADV_HUGEPAGE` before it is written, so all of it is faulted in as huge pages (advising
//! an ordinary vector covers only the whole huge pages that happen to lie inside it: about
//! half of these tables). A hint only: without huge pages (or off Linux) nothing changes.
//! [`reserve_huge`] and its kin advise ordinary vectors the same way (the BVH's node and
//! block arrays, the film's sums), which covers the whole huge pages inside them.
//!
//! The `rdr` binary also installs [`HugePageAllocator`] as its global allocator: every
//! allocation of 2 MiB or more is advised as it is made, so what is read and built once
//! (a mesh file's bytes, the parsed mesh, the BVH builder's arrays) faults in 2 MiB at a
//! time too. Embree does the same for its own large blocks (`os_malloc`: `MAP_HUGETLB`,
//! else `madvise(MADV_HUGEPAGE)`). Where page faults are dear, as in this project's VMs,
//! that takes a third off loading a large mesh (`docs/dev/acceleration.md`). Where the kernel compacts
//! memory for advised faults (`/sys/kernel/mm/transparent_hugepage/defrag` = `madvise`, the
//! usual default), a badly fragmented machine may spend time there instead; Embree makes
//! the same trade.

use std::alloc::{alloc, dealloc, handle_alloc_error, GlobalAlloc, Layout, System};
use std::ptr::NonNull;

/// Huge page size the advice aims at (x86-64).
const HUGE: usize = 2 << 20;

/// A fixed-length copy of a slice, on huge pages when it is large (see the module).
pub struct HugeBuf<T: Copy> {
    ptr: NonNull<T>,
    len: usize,
}

// SAFETY: a `HugeBuf` owns its elements as a `Box<[T]>` would; it hands out only shared
// references to them (`Deref`), so it is `Send`/`Sync` when `T` is.
unsafe impl<T: Copy + Send> Send for HugeBuf<T> {}
// SAFETY: as above.
unsafe impl<T: Copy + Sync> Sync for HugeBuf<T> {}

impl<T: Copy> HugeBuf<T> {
    /// The allocation for `len` elements: 2 MiB-aligned whole huge pages from 2 MiB on,
    /// else the elements' own alignment; `None` when nothing is to be allocated.
    fn layout(len: usize) -> Option<Layout> {
        let bytes = len.checked_mul(size_of::<T>())?;
        if bytes == 0 {
            return None;
        }
        let layout = if bytes >= HUGE {
            Layout::from_size_align(bytes.checked_next_multiple_of(HUGE)?, HUGE)
        } else {
            Layout::from_size_align(bytes, align_of::<T>())
        };
        Some(layout.expect("a slice's size is a valid layout"))
    }

    pub fn from_slice(s: &[T]) -> Self {
        let Some(layout) = Self::layout(s.len()) else {
            return HugeBuf {
                ptr: NonNull::dangling(),
                len: s.len(),
            };
        };
        // SAFETY: `layout` has a non-zero size.
        let p = unsafe { alloc(layout) }.cast::<T>();
        let Some(ptr) = NonNull::new(p) else { handle_alloc_error(layout) };
        if layout.align() == HUGE {
            advise(p as usize, layout.size());
        }
        // SAFETY: the fresh allocation holds `s.len()` elements of `T` (its size is at
        // least that, its alignment at least `T`'s) and cannot overlap `s`.
        unsafe { std::ptr::copy_nonoverlapping(s.as_ptr(), p, s.len()) };
        HugeBuf { ptr, len: s.len() }
    }
}

impl<T: Copy> std::ops::Deref for HugeBuf<T> {
    type Target = [T];
    #[inline]
    fn deref(&self) -> &[T] {
        // SAFETY: `ptr` holds `len` initialised elements (written in `from_slice`, never
        // changed), or is dangling and well aligned for an empty or zero-sized slice.
        unsafe { std::slice::from_raw_parts(self.ptr.as_ptr(), self.len) }
    }
}

impl<T: Copy> Drop for HugeBuf<T> {
    fn drop(&mut self) {
        if let Some(layout) = Self::layout(self.len) {
            // SAFETY: allocated in `from_slice` with this same layout (it depends on `len`
            // alone); `T: Copy` has no destructor to run.
            unsafe { dealloc(self.ptr.as_ptr().cast(), layout) };
        }
    }
}

impl<T: Copy> Clone for HugeBuf<T> {
    fn clone(&self) -> Self {
        HugeBuf::from_slice(self)
    }
}

impl<T: Copy + std::fmt::Debug> std::fmt::Debug for HugeBuf<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        (**self).fmt(f)
    }
}

/// `v.reserve(additional)`, the spare room's whole huge pages advised (an ordinary
/// vector, so only the huge pages that happen to lie inside it).
pub(crate) fn reserve_huge<T>(v: &mut Vec<T>, additional: usize) {
    v.reserve(additional);
    let spare = v.spare_capacity_mut();
    advise(spare.as_mut_ptr() as usize, std::mem::size_of_val(spare));
}

/// A copy of `v` in a fresh allocation advised for huge pages (a plain `clone` would
/// come back on small pages).
pub(crate) fn clone_huge<T: Clone>(v: &[T]) -> Vec<T> {
    let mut out = Vec::new();
    reserve_huge(&mut out, v.len());
    out.extend_from_slice(v);
    out
}

/// `vec![value; n]` advised for huge pages. Besides the TLB, this saves page faults: a
/// zeroed `vec!` comes from `calloc`, whose fresh pages fault twice when a sum is first
/// added to them (read: the shared zero page; write: a copy), 4 KiB at a time.
pub(crate) fn filled_huge<T: Clone>(n: usize, value: T) -> Vec<T> {
    let mut out = Vec::new();
    reserve_huge(&mut out, n);
    out.resize(n, value);
    out
}

/// The system allocator, with every block of [`HUGE`] bytes or more advised for huge
/// pages when it is allocated or grown (the whole huge pages inside it). Contents,
/// alignment and failures are the system allocator's; only how the kernel backs the
/// pages changes. For a binary's `#[global_allocator]`.
pub struct HugePageAllocator;

// SAFETY: every block comes from `System` and goes back to it with the layout it was
// made with, so `System` meets `GlobalAlloc`'s contract for them; the one call not handed
// on as it is, growth to a large block in `realloc`, does what `realloc` must (a block of
// the new size and the same alignment holding the old contents, the old one freed, or null
// and the old one kept). `advise` only tells the kernel how to back pages of a block it was
// given (see `advise`).
unsafe impl GlobalAlloc for HugePageAllocator {
    #[inline]
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's contract for `alloc` is `System.alloc`'s.
        let p = unsafe { System.alloc(layout) };
        if layout.size() >= HUGE && !p.is_null() {
            advise(p as usize, layout.size());
        }
        p
    }

    #[inline]
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: as in `alloc`. A large zeroed block is usually fresh mapped memory that
        // `calloc` did not touch, so the advice still applies to all of it.
        let p = unsafe { System.alloc_zeroed(layout) };
        if layout.size() >= HUGE && !p.is_null() {
            advise(p as usize, layout.size());
        }
        p
    }

    #[inline]
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from this allocator, that is from `System`, with `layout`.
        unsafe { System.dealloc(ptr, layout) }
    }

    #[inline]
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size < HUGE || new_size <= layout.size() {
            // SAFETY: as in `dealloc`; the caller's contract for `realloc` is `System`'s.
            return unsafe { System.realloc(ptr, layout, new_size) };
        }
        // Growing to a large block: a new block advised before the contents are copied
        // in. `System.realloc` often copies first (glibc: whenever the block is not a
        // mapping of its own), faulting the pages in 4 KiB at a time before the advice;
        // leaving large-to-large growth to it kept a third of the gain on the dragon OBJ.
        // The old and new blocks coexist during the copy, as in glibc's own copying path.
        // SAFETY: `layout.align()` is valid and `new_size`, non-zero, does not overflow
        // when rounded up to it (the caller's contract for `realloc`).
        let new_layout = unsafe { Layout::from_size_align_unchecked(new_size, layout.align()) };
        // SAFETY: a non-zero size.
        let p = unsafe { self.alloc(new_layout) };
        if !p.is_null() {
            // SAFETY: `ptr` holds `layout.size()` bytes, fewer than the new block's
            // `new_size`; the blocks are distinct; `ptr` is then freed as `dealloc` says.
            unsafe {
                std::ptr::copy_nonoverlapping(ptr, p, layout.size());
                self.dealloc(ptr, layout);
            }
        }
        p
    }
}

/// Advises the whole huge pages inside `[start, start + bytes)`.
fn advise(start: usize, bytes: usize) {
    let lo = start.next_multiple_of(HUGE);
    let hi = (start + bytes) / HUGE * HUGE;
    if hi <= lo {
        return;
    }
    #[cfg(target_os = "linux")]
    {
        // SAFETY: `[lo, hi)` lies inside one live allocation (a `HugeBuf`'s fresh
        // memory, a vector's spare capacity, a block `HugePageAllocator` hands out).
        // `MADV_HUGEPAGE` changes only how the kernel backs those pages, never their
        // contents or validity (pages already holding values keep them, and may later be
        // gathered into huge pages); a failure (no THP support) leaves them as they were,
        // so the result is ignored.
        unsafe { libc::madvise(lo as *mut libc::c_void, hi - lo, libc::MADV_HUGEPAGE) };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Copies hold the slice's values, whatever its size (empty, small, just below,
    /// at and above one huge page, several), and large ones start on a huge page;
    /// clones are equal; zero-sized elements work.
    #[test]
    fn copies_keep_their_contents() {
        let value = |i: usize| (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        for n in [0usize, 1, 1000, HUGE / 8 - 1, HUGE / 8, HUGE / 8 + 1, 3 * HUGE / 8 + 5] {
            let v: Vec<u64> = (0..n).map(value).collect();
            let h = HugeBuf::from_slice(&v);
            assert_eq!(&*h, &v[..], "{n} values");
            if n >= HUGE / 8 {
                assert_eq!(h.as_ptr() as usize % HUGE, 0, "{n} values not on a huge page");
            }
            let c = h.clone();
            drop(h);
            assert_eq!(&*c, &v[..]);
        }
        let z = HugeBuf::from_slice(&[(); 5]);
        assert_eq!(z.len(), 5);
        #[derive(Clone, Copy, Debug, PartialEq)]
        #[repr(align(16))]
        struct A(f32);
        let a = HugeBuf::from_slice(&[A(1.0), A(2.0)]);
        assert_eq!(a.as_ptr() as usize % 16, 0);
        assert_eq!(&*a, &[A(1.0), A(2.0)]);
    }

    /// Advised arrays hold what is written to them, whatever their size, also when more
    /// room is advised after they hold values (the advice covers only the spare room); a
    /// clone is equal.
    #[test]
    fn advised_arrays_keep_their_contents() {
        let value = |i: usize| (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        for n in [0usize, 1, 1000, 3 << 20] {
            let mut v: Vec<u64> = Vec::new();
            reserve_huge(&mut v, n);
            assert!(v.capacity() >= n);
            v.extend((0..n).map(value));
            // more room advised while the first half holds values
            reserve_huge(&mut v, 2 * n + (4 << 20));
            assert!(v.iter().enumerate().all(|(i, &x)| x == value(i)), "{n} values lost");
            v.extend((n..2 * n).map(value));
            let c = clone_huge(&v);
            assert_eq!(c, v);
            assert!(v.iter().enumerate().all(|(i, &x)| x == value(i)), "{n} values lost");
            // filled like `vec!`, whatever was in the memory before
            drop(c);
            assert_eq!(filled_huge(2 * n + 1, [0.5f64; 3]), vec![[0.5f64; 3]; 2 * n + 1], "{n} values");
            assert!(filled_huge(n, 0.0f64).iter().all(|&x| x.to_bits() == 0), "{n} zeros");
        }
    }

    /// Blocks from `HugePageAllocator` keep what is written to them through growing and
    /// shrinking across the 2 MiB threshold; zeroed ones are zero.
    #[test]
    fn allocator_blocks_keep_their_contents() {
        let a = HugePageAllocator;
        let value = |i: usize| (i as u8).wrapping_mul(31) ^ 0x5a;
        for (from, to) in [
            (64usize, 4096usize),
            (1000, HUGE + 3),
            (HUGE, 3 * HUGE),
            (3 * HUGE + 7, 100),
            (5 * HUGE, HUGE - 1),
        ] {
            let layout = Layout::from_size_align(from, 16).unwrap();
            // SAFETY: a non-zero size; the block is written and read within `from` bytes,
            // then within `min(from, to)` after the realloc, and freed with its new layout.
            unsafe {
                let p = a.alloc(layout);
                assert!(!p.is_null());
                for i in 0..from {
                    *p.add(i) = value(i);
                }
                let q = a.realloc(p, layout, to);
                assert!(!q.is_null());
                assert_eq!(q as usize % 16, 0);
                assert!((0..from.min(to)).all(|i| *q.add(i) == value(i)), "{from} -> {to} bytes");
                a.dealloc(q, Layout::from_size_align(to, 16).unwrap());
            }
        }
        for n in [1usize, HUGE - 1, 4 * HUGE + 1] {
            let layout = Layout::from_size_align(n, 64).unwrap();
            // SAFETY: a non-zero size, read within it, freed with the same layout.
            unsafe {
                let p = a.alloc_zeroed(layout);
                assert!(!p.is_null());
                assert_eq!(p as usize % 64, 0);
                assert!(std::slice::from_raw_parts(p, n).iter().all(|&b| b == 0), "{n} bytes");
                a.dealloc(p, layout);
            }
        }
    }

    /// Where the kernel gives huge pages on request (`madvise` mode), a large block from
    /// `HugePageAllocator` lies in a mapping eligible for them and one from the plain
    /// system allocator does not (so the check can tell).
    #[cfg(target_os = "linux")]
    #[test]
    fn allocator_advises_large_blocks() {
        let mode = std::fs::read_to_string("/sys/kernel/mm/transparent_hugepage/enabled").unwrap_or_default();
        if !mode.contains("[madvise]") {
            eprintln!("skipped: transparent huge pages are not in madvise mode here ({})", mode.trim());
            return;
        }
        // the `THPeligible` flag of the mapping holding `addr`
        let eligible = |addr: usize| -> Option<bool> {
            let maps = std::fs::read_to_string("/proc/self/smaps").ok()?;
            let mut inside = false;
            for line in maps.lines() {
                // a mapping's header starts with its address range, `lo-hi` in hex
                let range = line.split_whitespace().next().and_then(|r| r.split_once('-'));
                if let Some((Ok(lo), Ok(hi))) = range.map(|(lo, hi)| (usize::from_str_radix(lo, 16), usize::from_str_radix(hi, 16))) {
                    inside = lo <= addr && addr < hi;
                    continue;
                }
                if inside {
                    if let Some(v) = line.strip_prefix("THPeligible:") {
                        return Some(v.trim() == "1");
                    }
                }
            }
            None
        };
        // 64 MiB, above glibc's largest mmap threshold (32 MiB) and its arenas' heaps, so
        // the plain block is a fresh mapping: a 16 MiB one could reuse memory that a test
        // running beside this one had advised and freed, and failed so once in the suite
        let layout = Layout::from_size_align(32 * HUGE, 16).unwrap();
        // SAFETY: a non-zero size; nothing is read or written; freed with its layout.
        unsafe {
            let advised = HugePageAllocator.alloc(layout);
            let plain = System.alloc(layout);
            assert!(!advised.is_null() && !plain.is_null());
            // an address on a whole huge page inside each block
            let inner = |p: *mut u8| (p as usize).next_multiple_of(HUGE) + HUGE / 2;
            let (a, b) = (eligible(inner(advised)), eligible(inner(plain)));
            HugePageAllocator.dealloc(advised, layout);
            System.dealloc(plain, layout);
            match (a, b) {
                (Some(a), Some(b)) => {
                    assert!(a, "an advised 64 MiB block is not eligible for huge pages");
                    assert!(!b, "a plain block is eligible too: the check cannot tell");
                }
                _ => eprintln!("skipped: /proc/self/smaps has no THPeligible lines"),
            }
        }
    }
}
