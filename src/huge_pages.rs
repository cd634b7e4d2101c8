//! A global allocator for the build's large arrays: allocations of at least [`THRESHOLD`]
//! bytes are mappings of their own, aligned to 2 MiB and advised
//! (`madvise(MADV_HUGEPAGE)`) to be backed by transparent huge pages where the system leaves
//! that to the program (Linux with `transparent_hugepage/enabled` set to `madvise`); smaller
//! ones go to the system allocator.
//!
//! A cold build first touches tens of megabytes (refined points, stencils, diced points,
//! blocks, boxes). With 4 KiB pages that is one page fault per 4 KiB, a fifth of the car's
//! build at rate 16; with huge pages, one per 2 MiB. The advice has to come before the first
//! touch, which the system allocator does not allow: `calloc` clears reused memory and
//! `realloc` copies into fresh memory before returning. A mapping of its own is zero when
//! made (no clearing), grows and shrinks by `mremap` (no copy), and is advised at once.
//! Where huge pages are off, or the kernel refuses them, the mappings are ordinary memory.
//!
//! The command-line tool installs it; a program using the library may too:
//!
//! ```
//! #[global_allocator]
//! static ALLOC: limitray::huge_pages::HugePageAlloc = limitray::huge_pages::HugePageAlloc;
//! ```

use std::alloc::{GlobalAlloc, Layout, System};

/// Allocations at least this large (and aligned to at most a page) get mappings of their own.
pub const THRESHOLD: usize = 1 << 20;

/// Size and alignment of a huge page on x86-64 (and the usual aarch64 kernels).
const HUGE: usize = 2 << 20;

/// The page size mappings are rounded to.
const PAGE: usize = 4096;

/// The system allocator, with large allocations mapped on their own under huge pages.
pub struct HugePageAlloc;

/// Whether `layout` is served by a mapping of its own.
#[inline]
fn mapped(layout: Layout) -> bool {
    cfg!(target_os = "linux") && layout.size() >= THRESHOLD && layout.align() <= PAGE
}

// SAFETY: small layouts are forwarded to `System` unchanged. A large one is a private
// anonymous mapping of at least its size, page-aligned (its alignment is at most a page),
// owned by the caller until `dealloc` unmaps exactly it; `realloc` keeps the contents up to
// the smaller size and leaves the old block intact when it fails (`mremap` does both).
unsafe impl GlobalAlloc for HugePageAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if mapped(layout) {
            return map(layout.size());
        }
        // SAFETY: forwarded with the caller's guarantees.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if mapped(layout) {
            // A new anonymous mapping reads as zeros.
            return map(layout.size());
        }
        // SAFETY: forwarded with the caller's guarantees.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        if mapped(layout) {
            // SAFETY: `ptr` is the mapping `alloc` made for this layout's size.
            unsafe { unmap(ptr, layout.size()) };
            return;
        }
        // SAFETY: forwarded with the caller's guarantees.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: the caller guarantees that `new_size`, rounded to the alignment, does not
        // overflow `isize`.
        let new = unsafe { Layout::from_size_align_unchecked(new_size, layout.align()) };
        match (mapped(layout), mapped(new)) {
            // SAFETY: forwarded with the caller's guarantees.
            (false, false) => unsafe { System.realloc(ptr, layout, new_size) },
            // SAFETY: `ptr` is the mapping made for `layout.size()`.
            (true, true) => unsafe { remap(ptr, layout.size(), new_size) },
            _ => {
                // Across the threshold: a new block, the contents copied, the old one freed.
                // SAFETY: `new` has a non-zero size (the caller's guarantee).
                let p = unsafe { self.alloc(new) };
                if !p.is_null() {
                    // SAFETY: both blocks hold at least the smaller size and are distinct.
                    unsafe {
                        std::ptr::copy_nonoverlapping(ptr, p, layout.size().min(new_size));
                        self.dealloc(ptr, layout);
                    }
                }
                p
            }
        }
    }
}

/// `size` rounded up to whole pages.
#[inline]
fn pages(size: usize) -> usize {
    size.next_multiple_of(PAGE)
}

/// A new private anonymous mapping of `size` bytes (whole pages), its start aligned to
/// [`HUGE`] (mapped with room to spare, the rest unmapped) and advised huge pages; null when
/// the system has no room.
#[cfg(target_os = "linux")]
fn map(size: usize) -> *mut u8 {
    let len = pages(size);
    let Some(total) = len.checked_add(HUGE) else {
        return std::ptr::null_mut();
    };
    // SAFETY: a fresh anonymous mapping touches no existing memory.
    let p = unsafe {
        libc::mmap(
            std::ptr::null_mut(),
            total,
            libc::PROT_READ | libc::PROT_WRITE,
            libc::MAP_PRIVATE | libc::MAP_ANONYMOUS,
            -1,
            0,
        )
    };
    if p == libc::MAP_FAILED {
        return std::ptr::null_mut();
    }
    let base = p as usize;
    let start = base.next_multiple_of(HUGE);
    let (head, tail) = (start - base, base + total - (start + len));
    // SAFETY: the head and the tail are parts of the mapping just made, outside the block
    // handed out; the advice neither moves nor frees memory (its failure is harmless).
    unsafe {
        if head > 0 {
            libc::munmap(p, head);
        }
        if tail > 0 {
            libc::munmap((start + len) as *mut libc::c_void, tail);
        }
        libc::madvise(start as *mut libc::c_void, len, libc::MADV_HUGEPAGE);
    }
    start as *mut u8
}

/// Unmaps the block of `size` bytes at `ptr` made by [`map`] or [`remap`].
///
/// # Safety
/// `ptr` must be such a block, of that size, not used afterwards.
#[cfg(target_os = "linux")]
unsafe fn unmap(ptr: *mut u8, size: usize) {
    // SAFETY: the caller's guarantee.
    unsafe { libc::munmap(ptr as *mut libc::c_void, pages(size)) };
}

/// The block of `old` bytes at `ptr` resized to `new` bytes, moved by the kernel if it must
/// be (the contents kept, no copy); null, the old block intact, when the system has no room.
///
/// # Safety
/// `ptr` must be a block of `old` bytes made by [`map`] or [`remap`].
#[cfg(target_os = "linux")]
unsafe fn remap(ptr: *mut u8, old: usize, new: usize) -> *mut u8 {
    let (old, new) = (pages(old), pages(new));
    if old == new {
        return ptr;
    }
    // SAFETY: the caller's guarantee; `mremap` leaves the old mapping alone when it fails.
    let p = unsafe { libc::mremap(ptr as *mut libc::c_void, old, new, libc::MREMAP_MAYMOVE) };
    if p == libc::MAP_FAILED {
        return std::ptr::null_mut();
    }
    // A mapping moved keeps its advice; one grown in place may have gained a new area.
    // SAFETY: as in `map`.
    unsafe { libc::madvise(p, new, libc::MADV_HUGEPAGE) };
    p as *mut u8
}

#[cfg(not(target_os = "linux"))]
fn map(_: usize) -> *mut u8 {
    unreachable!("mappings of their own are made on Linux only")
}

#[cfg(not(target_os = "linux"))]
unsafe fn unmap(_: *mut u8, _: usize) {
    unreachable!("mappings of their own are made on Linux only")
}

#[cfg(not(target_os = "linux"))]
unsafe fn remap(_: *mut u8, _: usize, _: usize) -> *mut u8 {
    unreachable!("mappings of their own are made on Linux only")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Blocks below and above the threshold keep their contents through growth and
    /// shrinking in either direction across it, zeroed blocks read as zeros, and every
    /// block has its alignment.
    #[test]
    fn blocks_keep_contents_across_sizes() {
        let a = HugePageAlloc;
        for align in [1, 8, 64, 4096] {
            let sizes = [
                100,
                THRESHOLD - 1,
                THRESHOLD,
                THRESHOLD + 1,
                5 * HUGE + 17,
                300,
                3 * THRESHOLD,
                THRESHOLD / 2,
            ];
            let mut layout = Layout::from_size_align(sizes[0], align).unwrap();
            // SAFETY: non-zero sizes; every block is used within its size and freed once.
            unsafe {
                let mut p = a.alloc_zeroed(layout);
                assert!(!p.is_null());
                assert!(std::slice::from_raw_parts(p, layout.size())
                    .iter()
                    .all(|&b| b == 0));
                for i in 0..layout.size() {
                    *p.add(i) = (i % 251) as u8;
                }
                for &size in &sizes[1..] {
                    let kept = layout.size().min(size);
                    p = a.realloc(p, layout, size);
                    assert!(!p.is_null());
                    assert_eq!(p as usize % align, 0, "alignment {align}");
                    layout = Layout::from_size_align(size, align).unwrap();
                    for i in 0..kept {
                        assert_eq!(*p.add(i), (i % 251) as u8, "byte {i} of {size}");
                    }
                    for i in kept..size {
                        *p.add(i) = (i % 251) as u8;
                    }
                }
                a.dealloc(p, layout);
                let big = Layout::from_size_align(3 * HUGE, align).unwrap();
                let z = a.alloc_zeroed(big);
                assert!(std::slice::from_raw_parts(z, big.size())
                    .iter()
                    .all(|&b| b == 0));
                a.dealloc(z, big);
            }
        }
    }
}
