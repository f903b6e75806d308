//! The process's memory allocator on Linux: the system's, except that blocks of 128 KiB
//! and more are mapped on their own (and given back when freed), those of 2 MiB and more at
//! a 2 MiB boundary and offered to the kernel for transparent huge pages.
//!
//! The analysis of a large part touches a few large arrays (the welded mesh, the welding
//! tables, the edge table) at scattered places. On 4 KiB pages each first touch is a fault
//! and each scattered read may miss the address cache (the TLB); a 2 MiB page is one fault
//! and one TLB entry. On a 352k-triangle part this takes the process from about 7,700 page
//! faults to 2,600 and the whole command about a tenth faster (docs/performance.md).
//!
//! Only the whole 2 MiB pages inside a block are advised, so a block of 2 MiB or more never
//! holds more memory than its own size rounded up to 4 KiB. A block of 1 to 2 MiB is given
//! one whole huge page (at most twice its size): on the 352k-triangle part these are the
//! welding's tables and keys (1 and 1.5 MiB a run), probed at random, and the process goes
//! from about 6,100 page faults to 4,500 and about 2 % less CPU time, while they are held
//! only during the welding, below the peak, which comes with the edge table
//! (docs/performance.md, *Plain locate: the welding's blocks on huge pages*). When the
//! kernel has huge pages disabled, the advice is ignored and the blocks are ordinary
//! mappings.
//!
//! A mapped block that grows or shrinks to another mapped size is moved by the kernel
//! (`mremap`), which moves its pages instead of copying them into fresh ones: the trees'
//! node arrays grow by doubling, and each doubling would have copied and zeroed them anew
//! (`--strategy balanced` on the 352k-triangle part: 2.3 % less wall time, paired).
//!
//! Blocks between 128 KiB and 2 MiB are mapped here too rather than left to the system
//! allocator, which maps them as well but, once one is freed, raises its threshold for
//! mapping to that size and serves later blocks of up to that size from its heaps, where
//! freed memory is not given back: on the 352k-triangle part the welding tables (1 MiB)
//! left about 2 MiB more resident at the peak that way (docs/performance.md).

use std::alloc::{GlobalAlloc, Layout, System};

/// Blocks of at least this many bytes are mapped on their own (the system allocator's own
/// threshold before it adapts it).
const MAPPED: usize = 128 << 10;
/// The size and alignment of a transparent huge page on x86-64 and AArch64 (4 KiB base).
const HUGE_PAGE: usize = 2 << 20;
/// The base page size the mappings are rounded to.
const PAGE: usize = 4096;
/// Blocks from this size up to [`HUGE_PAGE`] are given a whole huge page of their own.
const HALF_HUGE_PAGE: usize = HUGE_PAGE / 2;

/// The system allocator, with blocks of [`MAPPED`] bytes and more on mappings of their own,
/// huge-page-aligned from [`HALF_HUGE_PAGE`] bytes.
pub struct Allocator;

/// Whether a block of this layout is mapped on its own (else the system allocator has it).
fn mapped(size: usize, align: usize) -> bool {
    size >= MAPPED && align <= PAGE
}

/// The length of the mapping that holds `size` bytes: whole 4 KiB pages, or one whole huge
/// page for a block of at least half of one ([`HALF_HUGE_PAGE`]).
fn mapped_len(size: usize) -> usize {
    let len = size.div_ceil(PAGE) * PAGE;
    if (HALF_HUGE_PAGE..HUGE_PAGE).contains(&len) {
        HUGE_PAGE
    } else {
        len
    }
}

// SAFETY: every block comes either from `System` or from `map`, and `dealloc` and
// `realloc` tell them apart by the same rule (`mapped`) on the same layout, so each block is
// returned to where it came from. Mapped blocks are page-aligned, which meets any alignment
// up to `PAGE`; larger alignments go to `System`.
unsafe impl GlobalAlloc for Allocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if mapped(layout.size(), layout.align()) {
            map(layout.size())
        } else {
            // SAFETY: the caller's layout contract is passed on unchanged.
            unsafe { System.alloc(layout) }
        }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if mapped(layout.size(), layout.align()) {
            // A fresh anonymous mapping reads as zeros.
            map(layout.size())
        } else {
            // SAFETY: as in `alloc`.
            unsafe { System.alloc_zeroed(layout) }
        }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        if mapped(layout.size(), layout.align()) {
            // SAFETY: `ptr` came from `map` with this size, so this is its whole mapping.
            unsafe { libc::munmap(ptr.cast(), mapped_len(layout.size())) };
        } else {
            // SAFETY: `ptr` came from `System` with this layout.
            unsafe { System.dealloc(ptr, layout) }
        }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let (was, will) = (
            mapped(layout.size(), layout.align()),
            mapped(new_size, layout.align()),
        );
        if !was && !will {
            // SAFETY: both blocks belong to `System`; the caller's contract is passed on.
            return unsafe { System.realloc(ptr, layout, new_size) };
        }
        if was && will {
            // SAFETY: `ptr` came from `map` with this size, so this is its whole mapping.
            let moved = unsafe { remap(ptr, layout.size(), new_size) };
            if !moved.is_null() {
                return moved;
            }
            // The kernel declined (a mapping whose huge-page advice split it in two parts
            // cannot grow in one call): a new block and a copy, as for any other.
        }
        // SAFETY: the caller guarantees that `new_size`, rounded up to the alignment, does
        // not overflow `isize`, which is all a layout needs.
        let new_layout = unsafe { Layout::from_size_align_unchecked(new_size, layout.align()) };
        // SAFETY: a non-zero size (at least one of the two sizes is MAPPED or more, and
        // `new_size` is non-zero by the caller's contract).
        let new = unsafe { self.alloc(new_layout) };
        if !new.is_null() {
            // SAFETY: both blocks are valid for the bytes copied and do not overlap; the old
            // block is returned by the rule it was allocated by.
            unsafe {
                std::ptr::copy_nonoverlapping(ptr, new, layout.size().min(new_size));
                self.dealloc(ptr, layout);
            }
        }
        new
    }
}

/// Moves or resizes the mapping of a block of `old_size` bytes (from [`map`]) to hold
/// `new_size` bytes, the kernel moving its pages rather than copying them (a growing vector
/// of a large part would otherwise copy itself and have fresh pages zeroed at each
/// doubling); null when the kernel declines, the old block then unchanged: a block whose
/// huge-page advice covers only part of it is two mappings to the kernel (advised and
/// not), which one call cannot grow, and the caller then copies it.
/// A block that grows to [`HUGE_PAGE`] or more is advised for huge pages on the whole 2 MiB
/// pages it holds (its start may no longer be on a boundary).
///
/// # Safety
///
/// `ptr` must be the start of the whole mapping that [`map`] made for `old_size` bytes.
unsafe fn remap(ptr: *mut u8, old_size: usize, new_size: usize) -> *mut u8 {
    let (old_len, new_len) = (mapped_len(old_size), mapped_len(new_size));
    if old_len == new_len {
        return ptr;
    }
    // SAFETY: `ptr..ptr + old_len` is one whole mapping of ours (the caller's contract).
    let raw = unsafe { libc::mremap(ptr.cast(), old_len, new_len, libc::MREMAP_MAYMOVE) };
    if raw == libc::MAP_FAILED {
        return std::ptr::null_mut();
    }
    if new_len >= HUGE_PAGE {
        let start = (raw as usize).div_ceil(HUGE_PAGE) * HUGE_PAGE;
        let end = (raw as usize + new_len) / HUGE_PAGE * HUGE_PAGE;
        if end > start {
            // SAFETY: advice only, on whole pages inside the mapping just made.
            unsafe { libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE) };
        }
    }
    raw.cast()
}

/// Maps `size` bytes, from [`HALF_HUGE_PAGE`] bytes on at a 2 MiB boundary with huge pages
/// advised on the whole 2 MiB pages of its mapping ([`mapped_len`]); null when the system
/// has no memory to give.
fn map(size: usize) -> *mut u8 {
    let len = mapped_len(size);
    if len < HUGE_PAGE {
        // SAFETY: a new private anonymous mapping; no existing memory is affected.
        let raw = unsafe {
            libc::mmap(
                std::ptr::null_mut(),
                len,
                libc::PROT_READ | libc::PROT_WRITE,
                libc::MAP_PRIVATE | libc::MAP_ANONYMOUS,
                -1,
                0,
            )
        };
        return if raw == libc::MAP_FAILED {
            std::ptr::null_mut()
        } else {
            raw.cast()
        };
    }
    // Over-map by a huge page, then unmap the ends so the block starts on a boundary.
    let Some(over) = len.checked_add(HUGE_PAGE) else {
        return std::ptr::null_mut();
    };
    // SAFETY: a new private anonymous mapping; no existing memory is affected.
    let raw = unsafe {
        libc::mmap(
            std::ptr::null_mut(),
            over,
            libc::PROT_READ | libc::PROT_WRITE,
            libc::MAP_PRIVATE | libc::MAP_ANONYMOUS,
            -1,
            0,
        )
    };
    if raw == libc::MAP_FAILED {
        return std::ptr::null_mut();
    }
    let start = raw as usize;
    let aligned = start.div_ceil(HUGE_PAGE) * HUGE_PAGE;
    let end = aligned + len;
    // SAFETY: the two ranges unmapped lie inside the mapping just made, before and after
    // the block kept; the advice covers only the block.
    unsafe {
        if aligned > start {
            libc::munmap(raw, aligned - start);
        }
        if start + over > end {
            libc::munmap(end as *mut libc::c_void, start + over - end);
        }
        let whole = len / HUGE_PAGE * HUGE_PAGE;
        // Advice only: where the kernel declines, the block keeps 4 KiB pages.
        libc::madvise(aligned as *mut libc::c_void, whole, libc::MADV_HUGEPAGE);
    }
    aligned as *mut u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn large_blocks_start_on_a_huge_page_boundary_and_keep_their_bytes() {
        let n = 3 * HUGE_PAGE + 12_345;
        let mut v: Vec<u8> = Vec::with_capacity(n);
        assert_eq!(v.as_ptr() as usize % HUGE_PAGE, 0);
        v.extend((0..n).map(|i| (i % 251) as u8));
        assert!(v.iter().enumerate().all(|(i, &b)| b == (i % 251) as u8));
    }

    #[test]
    fn blocks_of_half_a_huge_page_or_more_get_a_whole_one() {
        assert_eq!(mapped_len(HALF_HUGE_PAGE - PAGE), HALF_HUGE_PAGE - PAGE);
        assert_eq!(mapped_len(HALF_HUGE_PAGE - PAGE + 1), HUGE_PAGE);
        assert_eq!(mapped_len(HALF_HUGE_PAGE), HUGE_PAGE);
        assert_eq!(mapped_len(HUGE_PAGE - 1), HUGE_PAGE);
        assert_eq!(mapped_len(HUGE_PAGE), HUGE_PAGE);
        assert_eq!(mapped_len(HUGE_PAGE + 1), HUGE_PAGE + PAGE);
        // Such a block starts on a huge page, keeps its bytes, grows and shrinks.
        let n = HALF_HUGE_PAGE + 12_345;
        let mut v: Vec<u8> = Vec::with_capacity(n);
        assert_eq!(v.as_ptr() as usize % HUGE_PAGE, 0);
        v.extend((0..n).map(|i| (i % 251) as u8));
        v.reserve_exact(HUGE_PAGE - n - 7);
        assert!(v.iter().enumerate().all(|(i, &b)| b == (i % 251) as u8));
        v.truncate(HALF_HUGE_PAGE / 4);
        v.shrink_to_fit();
        assert!(v.iter().enumerate().all(|(i, &b)| b == (i % 251) as u8));
        let zeros = vec![0u32; HALF_HUGE_PAGE / 4 + 100];
        assert_eq!(zeros.as_ptr() as usize % HUGE_PAGE, 0);
        assert!(zeros.iter().all(|&x| x == 0));
    }

    #[test]
    fn a_block_advised_in_part_grows_and_keeps_its_bytes() {
        // 2 MiB and a page: the first 2 MiB advised, the page not, two mappings to the
        // kernel, which one remap cannot grow; the block is copied instead.
        for n in [HUGE_PAGE + PAGE, 3 * HUGE_PAGE + 5 * PAGE + 17, HUGE_PAGE] {
            let mut v: Vec<u8> = Vec::with_capacity(n);
            v.extend((0..n).map(|i| (i % 251) as u8));
            v.reserve_exact(n + 7);
            v.extend((n..2 * n + 7).map(|i| (i % 251) as u8));
            assert!(v.iter().enumerate().all(|(i, &b)| b == (i % 251) as u8));
            v.truncate(HALF_HUGE_PAGE / 2 + 3);
            v.shrink_to_fit();
            assert!(v.iter().enumerate().all(|(i, &b)| b == (i % 251) as u8));
        }
    }

    #[test]
    fn zeroed_large_blocks_read_as_zeros() {
        let v = vec![0u64; HUGE_PAGE / 8 + 1000];
        assert_eq!(v.as_ptr() as usize % HUGE_PAGE, 0);
        assert!(v.iter().all(|&x| x == 0));
    }

    #[test]
    fn growing_across_the_threshold_and_shrinking_back_keeps_the_contents() {
        // Small (system) -> large (mapped) -> larger (mapped) -> small (system).
        let mut v: Vec<u32> = (0..1000).collect();
        for target in [MAPPED / 4 + 10, HUGE_PAGE / 4 + 10, HUGE_PAGE / 2 + 77] {
            let from = v.len() as u32;
            v.extend(from..target as u32);
            assert!(v.iter().enumerate().all(|(i, &x)| x == i as u32));
        }
        assert!(mapped(v.capacity() * 4, 4));
        v.truncate(500);
        v.shrink_to_fit();
        assert!(!mapped(v.capacity() * 4, 4));
        assert!(v.iter().enumerate().all(|(i, &x)| x == i as u32));
    }

    #[test]
    fn alignments_above_a_page_go_to_the_system_allocator() {
        let layout = Layout::from_size_align(HUGE_PAGE, 2 * PAGE).unwrap();
        assert!(!mapped(layout.size(), layout.align()));
        // SAFETY: a valid non-zero layout, freed with the same layout.
        unsafe {
            let p = Allocator.alloc(layout);
            assert!(!p.is_null());
            assert_eq!(p as usize % (2 * PAGE), 0);
            p.write_bytes(7, layout.size());
            assert_eq!(*p.add(HUGE_PAGE - 1), 7);
            Allocator.dealloc(p, layout);
        }
    }
}
