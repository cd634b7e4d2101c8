//! Transparent huge pages for the arrays a query reads.
//!
//! A query's loads are scattered over a mesh's vertices and boxes (160 MB for catmark_car at
//! rate 64): with 4 KiB pages nearly every load of an incoherent ray also misses the TLB. On
//! Linux with transparent huge pages in `madvise` mode (the common default), a range advised
//! `MADV_HUGEPAGE` before it is first written is faulted in 2 MiB pages, which the TLB covers
//! 512 times further. Embree advises its build memory so; glibc's `malloc` does not.
//!
//! [`advise`] is called on the grid core's arrays as they are allocated. Only they are
//! advised: every array of a build in huge pages (tried as a global allocator) made the
//! build's page faults dearer on the measured machine (a 2 MiB page is zeroed whole, from
//! memory the host had not yet mapped), for no gain in the rays.
//!
//! ```
//! let mut v: Vec<f32> = Vec::with_capacity(4 << 20);
//! limitray::huge_pages::advise(&mut v);
//! v.extend((0..4 << 20).map(|i| i as f32));
//! assert_eq!(v[12345], 12345.0);
//! ```

/// The size of a transparent huge page on x86-64 and AArch64 (4 KiB base pages).
#[cfg(target_os = "linux")]
const HUGE: usize = 2 << 20;

/// Advises the allocated capacity of `v` for transparent huge pages, before it is first
/// written: its whole 2 MiB pages are then faulted in one at a time. For the arrays a query
/// reads (a mesh's vertices and boxes): with huge pages their lookups miss the TLB less.
/// Only a hint: nothing happens off Linux, below 2 MiB, or where the kernel refuses.
pub fn advise<T>(v: &mut Vec<T>) {
    #[cfg(target_os = "linux")]
    {
        let start = v.as_mut_ptr() as usize;
        let end = start + v.capacity() * std::mem::size_of::<T>();
        let (a, b) = (start.next_multiple_of(HUGE), end / HUGE * HUGE);
        if a < b {
            // SAFETY: the range lies in the vector's allocation; advice changes no contents.
            unsafe { libc::madvise(a as *mut libc::c_void, b - a, libc::MADV_HUGEPAGE) };
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = v;
}

#[cfg(test)]
mod tests {
    /// Advice changes no contents, on empty, small, unaligned and large vectors, written
    /// before and after it.
    #[test]
    fn advice_keeps_contents() {
        for n in [0usize, 1, 1000, 3 << 20, 5 << 20] {
            let mut v: Vec<u32> = Vec::with_capacity(n);
            v.extend((0..n / 2).map(|i| i as u32 ^ 0x5A5A));
            super::advise(&mut v);
            v.extend((n / 2..n).map(|i| i as u32 ^ 0x5A5A));
            assert!(v.iter().enumerate().all(|(i, &x)| x == i as u32 ^ 0x5A5A));
        }
    }

    /// The kernel records the advice: the mapping holding a large vector's whole 2 MiB pages
    /// carries the `hg` flag (`VM_HUGEPAGE`) in `/proc/self/smaps`, where the kernel has
    /// transparent huge pages at all.
    #[cfg(target_os = "linux")]
    #[test]
    fn large_vectors_are_marked_for_huge_pages() {
        let thp = std::fs::read_to_string("/sys/kernel/mm/transparent_hugepage/enabled");
        if thp.map_or(true, |s| s.contains("[never]")) {
            eprintln!("note: no transparent huge pages on this kernel; advice not checked");
            return;
        }
        let mut v: Vec<u8> = Vec::with_capacity(9 << 20);
        super::advise(&mut v);
        let inside = (v.as_ptr() as usize).next_multiple_of(super::HUGE);
        let smaps = std::fs::read_to_string("/proc/self/smaps").unwrap();
        let mut holds = false;
        let mut flags = None;
        for line in smaps.lines() {
            let range = line
                .split_whitespace()
                .next()
                .and_then(|r| r.split_once('-'));
            if let Some((a, b)) = range.filter(|_| !line.starts_with("VmFlags")) {
                if let (Ok(a), Ok(b)) = (usize::from_str_radix(a, 16), usize::from_str_radix(b, 16))
                {
                    holds = (a..b).contains(&inside);
                    continue;
                }
            }
            if holds {
                if let Some(f) = line.strip_prefix("VmFlags:") {
                    flags = Some(f.split_whitespace().any(|f| f == "hg"));
                }
            }
        }
        assert_eq!(
            flags,
            Some(true),
            "the vector's mapping is advised for huge pages"
        );
        drop(v);
    }
}
