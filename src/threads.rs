//! Worker pools of a requested size: the one cap on `--threads` everywhere, and an error
//! rather than a panic when the threads cannot be made.

use crate::error::{Error, ErrorKind, Result};

/// Most worker threads accepted (`--threads` of every command).
pub const MAX_THREADS: usize = 1024;

/// A rayon pool of `threads` workers (0: one per available core). More than
/// [`MAX_THREADS`], or a failure to start them, is an error naming `--threads`.
pub fn pool(threads: usize) -> Result<rayon::ThreadPool> {
    if threads > MAX_THREADS {
        return Err(Error::new(
            ErrorKind::Usage,
            format!("--threads {threads} is above the maximum of {MAX_THREADS}"),
        ));
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| {
            Error::new(
                ErrorKind::Usage,
                format!("cannot start {threads} worker threads ({e}); lower --threads"),
            )
        })
}

#[cfg(test)]
mod tests {
    #[test]
    fn caps() {
        let e = super::pool(5000).err().unwrap();
        assert_eq!(e.to_string(), "--threads 5000 is above the maximum of 1024");
        assert_eq!(super::pool(3).unwrap().current_num_threads(), 3);
        assert!(super::pool(0).unwrap().current_num_threads() >= 1);
    }
}
