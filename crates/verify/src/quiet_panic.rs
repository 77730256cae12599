//! Panics caught and reported as results, without the default hook's message.
//!
//! The sampler suite turns a technique's panic into a failing row ([`crate::suite`]); the
//! message would otherwise also reach the terminal through the process-wide panic hook.
//! Replacing that hook for the whole run would also silence panics of unrelated work running
//! at the same time — `linlight certify` renders images while the suite runs — and lose their
//! messages. [`catch_quietly`] silences only the panics raised
//! on the calling thread inside its closure; every other panic reaches the hook that was
//! installed before (the default one, or the caller's).

use std::cell::Cell;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::Once;

thread_local! {
    /// Depth of [`catch_quietly`] calls active on this thread.
    static QUIET: Cell<u32> = const { Cell::new(0) };
}

static INSTALL: Once = Once::new();

/// Install, once per process, a hook that stays silent while [`catch_quietly`] runs on the
/// panicking thread and otherwise forwards to the hook installed before it.
fn install() {
    INSTALL.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if QUIET.with(Cell::get) == 0 {
                previous(info);
            }
        }));
    });
}

/// `f()`, or the message of its panic; a panic raised on this thread inside `f` prints
/// nothing. Panics of other threads (and of this thread outside `f`) are reported as before.
pub fn catch_quietly<R>(f: impl FnOnce() -> R) -> Result<R, String> {
    install();
    QUIET.with(|q| q.set(q.get() + 1));
    let run = catch_unwind(AssertUnwindSafe(f));
    QUIET.with(|q| q.set(q.get() - 1));
    run.map_err(message)
}

/// The text of a panic payload (`panic!` with a literal or a formatted message).
pub fn message(payload: Box<dyn std::any::Any + Send>) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        s.to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "panic".to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn returns_the_value_or_the_message() {
        assert_eq!(catch_quietly(|| 7), Ok(7));
        assert_eq!(
            catch_quietly(|| -> u32 { panic!("bad {}", 3) }),
            Err("bad 3".to_string())
        );
        assert_eq!(
            catch_quietly(|| -> u32 { panic!("literal") }),
            Err("literal".into())
        );
        // The depth is restored after a panic: nested and later calls behave alike.
        assert_eq!(QUIET.with(Cell::get), 0);
        let nested = catch_quietly(|| catch_quietly(|| -> u32 { panic!("inner") }));
        assert_eq!(nested, Ok(Err("inner".to_string())));
        assert_eq!(QUIET.with(Cell::get), 0);
    }
}
