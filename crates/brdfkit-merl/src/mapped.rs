//! Arrays of f64 read in place from a file's pages (Unix): the input of bulk lookups.
//!
//! `fit-brdf eval --dirs P.npy` reads 48 bytes per pair; reading them into a new
//! buffer costs the kernel a zeroed fresh page per 4 KiB (or per 2 MiB huge page) and a
//! copy, more time than the lookups themselves for a million pairs. A private read-only
//! mapping with `MAP_POPULATE` maps the page-cache pages the file already occupies.

/// A read-only private mapping of a whole file whose native-endian f64 values start at
/// byte `at` (a multiple of 8): for bulk lookups over pairs stored in a file.
#[derive(Debug)]
pub struct MappedF64 {
    ptr: *mut libc::c_void,
    bytes: usize,
    at: usize,
}

// SAFETY: the mapping is read-only and owned by this value alone (unmapped on drop).
unsafe impl Send for MappedF64 {}
// SAFETY: as above; shared references only read.
unsafe impl Sync for MappedF64 {}

impl MappedF64 {
    /// Maps `file` (`bytes` long, its values from byte `at`) with every page present
    /// (`MAP_POPULATE`): the values are read in place from the page cache, with no
    /// buffer to allocate, zero and fill (for 1.46 M pairs: 70 MB of fresh pages, which
    /// cost the kernel more time than the lookups take). `None` when `at` is not a
    /// multiple of 8 or past the end, the file is empty, or the system declines; the
    /// caller then reads the file.
    pub fn new(file: &std::fs::File, bytes: usize, at: usize) -> Option<MappedF64> {
        use std::os::unix::io::AsRawFd;
        if bytes == 0 || !at.is_multiple_of(8) || at > bytes {
            return None;
        }
        #[cfg(target_os = "linux")]
        let flags = libc::MAP_PRIVATE | libc::MAP_POPULATE;
        #[cfg(not(target_os = "linux"))]
        let flags = libc::MAP_PRIVATE;
        // SAFETY: a fresh read-only mapping of an open file; nothing else refers to the
        // address range, which is only read through `values` and unmapped on drop.
        let ptr = unsafe {
            libc::mmap(
                std::ptr::null_mut(),
                bytes,
                libc::PROT_READ,
                flags,
                file.as_raw_fd(),
                0,
            )
        };
        (ptr != libc::MAP_FAILED).then_some(MappedF64 { ptr, bytes, at })
    }

    /// The values from byte `at` to the end of the file (a trailing partial value
    /// excluded).
    pub fn values(&self) -> &[f64] {
        // SAFETY: the mapping is `bytes` long, page-aligned, and `at` is a multiple of 8
        // within it (checked in `new`), so the range holds (bytes − at) / 8 aligned f64
        // values for as long as `self` lives. A file truncated by another process while
        // mapped ends this one with SIGBUS on the next read of a lost page, as with
        // numpy's `np.load(mmap_mode="r")`.
        unsafe {
            std::slice::from_raw_parts(
                self.ptr.cast::<u8>().add(self.at).cast::<f64>(),
                (self.bytes - self.at) / 8,
            )
        }
    }
}

impl Drop for MappedF64 {
    fn drop(&mut self) {
        // SAFETY: the range mapped in `new`, no longer referenced (borrows end with self).
        unsafe {
            libc::munmap(self.ptr, self.bytes);
        }
    }
}
