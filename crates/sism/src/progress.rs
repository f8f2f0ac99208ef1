//! Progress of long work, reported to whoever listens.
//!
//! The library draws nothing: long loops (reference rays, bench candidates, study points) count
//! their steps on a [`Bar`], which forwards to the [`Reporter`] installed with [`set_reporter`] (the
//! command line installs one that draws terminal bars; a Python binding could install one that
//! updates a notebook widget). With no reporter, or with `visible` false, a bar only counts.

use std::sync::{Arc, OnceLock, RwLock};

/// Draws progress: one [`ProgressSink`] per bar.
pub trait Reporter: Send + Sync {
    /// A new bar of `len` steps labelled `what`.
    fn bar(&self, len: u64, what: &str) -> Box<dyn ProgressSink>;
}

/// One bar's drawing.
pub trait ProgressSink: Send + Sync {
    /// The bar is at `pos` of its length.
    fn set_position(&self, pos: u64);
    /// What the bar is on now (a label beside it).
    fn set_message(&self, msg: &str);
    /// Runs `f` with the bar hidden (so that printed lines are not torn by it).
    fn suspend(&self, f: &mut dyn FnMut());
    /// The work is done: remove the bar.
    fn finish(&self);
}

fn reporter_slot() -> &'static RwLock<Option<Arc<dyn Reporter>>> {
    static SLOT: OnceLock<RwLock<Option<Arc<dyn Reporter>>>> = OnceLock::new();
    SLOT.get_or_init(|| RwLock::new(None))
}

/// Installs the process's progress reporter (replacing any earlier one).
pub fn set_reporter(reporter: Arc<dyn Reporter>) {
    *reporter_slot().write().unwrap_or_else(|e| e.into_inner()) = Some(reporter);
}

/// A counter of steps done, drawn by the installed [`Reporter`] when visible.
pub struct Bar {
    pos: std::sync::atomic::AtomicU64,
    sink: Option<Box<dyn ProgressSink>>,
}

impl Bar {
    /// Steps done so far.
    pub fn position(&self) -> u64 {
        self.pos.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// `n` more steps done.
    pub fn inc(&self, n: u64) {
        let p = self.pos.fetch_add(n, std::sync::atomic::Ordering::Relaxed) + n;
        if let Some(s) = &self.sink {
            s.set_position(p);
        }
    }

    /// `pos` steps done.
    pub fn set_position(&self, pos: u64) {
        self.pos.store(pos, std::sync::atomic::Ordering::Relaxed);
        if let Some(s) = &self.sink {
            s.set_position(pos);
        }
    }

    /// What the work is on now.
    pub fn set_message(&self, msg: impl AsRef<str>) {
        if let Some(s) = &self.sink {
            s.set_message(msg.as_ref());
        }
    }

    /// Runs `f` with the bar hidden, so that what `f` prints is not torn by it.
    pub fn suspend<R>(&self, f: impl FnOnce() -> R) -> R {
        match &self.sink {
            None => f(),
            Some(s) => {
                let mut f = Some(f);
                let mut out = None;
                s.suspend(&mut || out = f.take().map(|f| f()));
                out.expect("the sink runs the closure once")
            }
        }
    }

    /// The work is done: the bar is removed.
    pub fn finish_and_clear(&self) {
        if let Some(s) = &self.sink {
            s.finish();
        }
    }
}

/// A bar of `len` steps labelled `what`; drawn by the installed reporter when `visible`, else it
/// only counts.
pub fn bar(len: u64, what: &str, visible: bool) -> Bar {
    let sink = if visible {
        reporter_slot()
            .read()
            .unwrap_or_else(|e| e.into_inner())
            .as_ref()
            .map(|r| r.bar(len, what))
    } else {
        None
    };
    Bar {
        pos: std::sync::atomic::AtomicU64::new(0),
        sink,
    }
}
