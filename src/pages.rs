//! Large lookup tables on transparent huge pages.
//!
//! An environment map's texels and sampling tables (6 MB each for a 1k map, 4× that for
//! 2k) are read at random places, one or two cache lines per sample: with 4 KiB pages
//! nearly every such read also misses the TLB and pays a page walk. Where the kernel leaves
//! transparent huge pages to `madvise` (the usual default), room reserved here is advised
//! `MADV_HUGEPAGE` before it is written, so it is faulted in as 2 MiB pages. A hint only:
//! without huge pages (or off Linux) nothing changes. (`accel::wide` keeps its own copy
//! of these few lines for the BVH's arrays.)

/// Huge page size the advice aims at (x86-64).
const HUGE: usize = 2 << 20;

/// `v.reserve(additional)`, the spare room advised for huge pages.
pub(crate) fn reserve_huge<T>(v: &mut Vec<T>, additional: usize) {
    v.reserve(additional);
    let spare = v.spare_capacity_mut();
    advise(spare.as_mut_ptr() as usize, std::mem::size_of_val(spare));
}

/// The items of `it` (exactly `len` of them expected) in a vector advised for huge pages.
pub(crate) fn collect_huge<T>(len: usize, it: impl IntoIterator<Item = T>) -> Vec<T> {
    let mut v = Vec::new();
    reserve_huge(&mut v, len);
    v.extend(it);
    v
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

    /// Advised vectors hold what is written to them, whatever their size, also when
    /// more room is advised after they hold values (the advice covers only spare room).
    #[test]
    fn advised_vectors_keep_their_contents() {
        let value = |i: usize| (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        for n in [0usize, 1, 1000, 3 << 20] {
            let mut v = collect_huge(n, (0..n).map(value));
            assert_eq!(v.len(), n);
            reserve_huge(&mut v, 2 * n + (4 << 20));
            v.extend((n..2 * n).map(value));
            assert!(v.iter().enumerate().all(|(i, &x)| x == value(i)), "{n} values lost");
        }
    }
}
