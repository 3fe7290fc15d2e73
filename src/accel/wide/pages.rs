//! The tree's large arrays (nodes, triangle blocks) on transparent huge pages.
//!
//! Incoherent rays touch the node and block arrays all over: with 4 KiB pages the dragon's
//! 46 MB tree spans 11,000 pages, far more than the TLB holds, and most leaf visits paid a
//! page walk. Where the kernel leaves transparent huge pages to `madvise` (the usual default,
//! `/sys/kernel/mm/transparent_hugepage/enabled` = `madvise`), the arrays' spare room is
//! advised `MADV_HUGEPAGE` before it is written, so it is faulted in as 2 MiB pages
//! (Embree's allocator does the same): +45 % on the dragon's incoherent rays on a Xeon. A
//! hint only: without huge pages (or off Linux) nothing changes.

/// Huge page size the advice aims at (x86-64).
const HUGE: usize = 2 << 20;

/// `v.reserve(additional)`, the spare room advised for huge pages.
pub(super) fn reserve_huge<T>(v: &mut Vec<T>, additional: usize) {
    v.reserve(additional);
    let spare = v.spare_capacity_mut();
    advise(spare.as_mut_ptr() as usize, std::mem::size_of_val(spare));
}

/// A copy of `v` in a fresh allocation advised for huge pages (a plain `clone` would
/// come back on small pages).
pub(super) fn clone_huge<T: Clone>(v: &[T]) -> Vec<T> {
    let mut out = Vec::new();
    reserve_huge(&mut out, v.len());
    out.extend_from_slice(v);
    out
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
        // SAFETY: `[lo, hi)` lies inside one live allocation (a vector's spare capacity,
        // which holds no values). `MADV_HUGEPAGE` changes only how the kernel backs those
        // pages, never their contents or validity; a failure (no THP support) leaves them
        // as they were, so the result is ignored.
        unsafe { libc::madvise(lo as *mut libc::c_void, hi - lo, libc::MADV_HUGEPAGE) };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        }
    }
}
