//! Timers between the stages of a build, for `limitray bench-trace --stages`: where a build's
//! time goes, stage by stage, without an instrumented copy of the code.
//!
//! The build's orchestrating code calls [`mark`] as each stage ends; nothing is recorded
//! unless a [`Recording`] is alive on the calling thread (a thread-local check, a few
//! nanoseconds a mark, a few dozen marks a build). Marks made on other threads (rayon's
//! workers inside a parallel stage) are not recorded: every mark sits between stages, on the
//! thread that runs them in turn.
//!
//! ```
//! use limitray::stages::{mark, Recording};
//! let rec = Recording::start();
//! mark("first");
//! mark("second");
//! mark("first");
//! let stages = rec.finish();
//! assert_eq!(stages.iter().map(|s| s.0).collect::<Vec<_>>(), ["first", "second"]);
//! mark("after"); // not recorded
//! ```

use std::cell::RefCell;
use std::time::Instant;

/// The stages recorded on this thread: the last mark's time, and each stage's name with its
/// seconds, in the order first marked.
type Log = (Instant, Vec<(&'static str, f64)>);

thread_local! {
    static LOG: RefCell<Option<Log>> = const { RefCell::new(None) };
}

/// A recording of this thread's marks, from [`Recording::start`] to [`Recording::finish`] (or
/// until it is dropped).
pub struct Recording {
    _not_send: std::marker::PhantomData<*const ()>,
}

impl Recording {
    /// Starts recording this thread's marks; the first stage's time counts from here. A
    /// recording already alive on this thread starts over.
    pub fn start() -> Recording {
        LOG.with(|l| *l.borrow_mut() = Some((Instant::now(), Vec::new())));
        Recording {
            _not_send: std::marker::PhantomData,
        }
    }

    /// The stages marked since [`Self::start`], in the order first marked, each with its total
    /// seconds (a stage marked several times adds up).
    pub fn finish(self) -> Vec<(&'static str, f64)> {
        LOG.with(|l| l.borrow_mut().take())
            .map(|(_, stages)| stages)
            .unwrap_or_default()
    }
}

impl Drop for Recording {
    fn drop(&mut self) {
        LOG.with(|l| *l.borrow_mut() = None);
    }
}

/// Ends stage `name` on this thread: the time since the previous mark (or since the
/// recording began) is added to it. Nothing happens without a [`Recording`] on this thread.
#[inline]
pub fn mark(name: &'static str) {
    LOG.with(|l| {
        if let Some((last, stages)) = l.borrow_mut().as_mut() {
            let now = Instant::now();
            let secs = (now - *last).as_secs_f64();
            *last = now;
            match stages.iter_mut().find(|s| s.0 == name) {
                Some(s) => s.1 += secs,
                None => stages.push((name, secs)),
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Stages add up in the order first marked, only while a recording is alive and only on
    /// its thread; their times sum to the recording's span.
    #[test]
    fn marks_add_up_per_stage_on_the_recording_thread() {
        mark("before");
        let t0 = Instant::now();
        let rec = Recording::start();
        mark("a");
        std::thread::sleep(std::time::Duration::from_millis(5));
        mark("b");
        std::thread::spawn(|| mark("elsewhere")).join().unwrap();
        std::thread::sleep(std::time::Duration::from_millis(5));
        mark("a");
        let stages = rec.finish();
        let span = t0.elapsed().as_secs_f64();
        let names: Vec<&str> = stages.iter().map(|s| s.0).collect();
        assert_eq!(names, ["a", "b"]);
        // "b" holds the first sleep, "a" the second.
        assert!(stages.iter().all(|s| s.1 >= 0.004), "{stages:?}");
        let sum: f64 = stages.iter().map(|s| s.1).sum();
        assert!(sum <= span, "{sum} > {span}");
        mark("after");
        assert!(Recording::start().finish().is_empty());
    }
}
