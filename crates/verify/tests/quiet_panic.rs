//! `catch_quietly` silences only the panics of its own closure: a panic of another thread that
//! runs at the same time (certify renders while the sampler suite runs) still reaches the hook
//! installed before. Its own process: the panic hook is process-wide.

use linlight_verify::quiet_panic::catch_quietly;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Barrier};

static REPORTED: AtomicUsize = AtomicUsize::new(0);

#[test]
fn only_the_closures_panics_are_silent() {
    std::panic::set_hook(Box::new(|_| {
        REPORTED.fetch_add(1, Ordering::SeqCst);
    }));
    // Inside: caught and silent.
    assert_eq!(
        catch_quietly(|| -> () { panic!("inside") }),
        Err("inside".into())
    );
    assert_eq!(REPORTED.load(Ordering::SeqCst), 0);

    // A quiet closure on one thread while another thread panics outside of any: the other
    // thread's panic is reported, the closure's is not.
    let barrier = Arc::new(Barrier::new(2));
    let quiet = {
        let barrier = barrier.clone();
        std::thread::spawn(move || {
            catch_quietly(|| -> () {
                barrier.wait(); // both threads are now inside their work
                barrier.wait(); // the other thread has panicked
                panic!("suite")
            })
        })
    };
    let loud = std::thread::spawn(move || {
        barrier.wait();
        let r = std::panic::catch_unwind(|| -> () { panic!("render") });
        barrier.wait();
        r.is_err()
    });
    assert!(loud.join().unwrap());
    assert_eq!(quiet.join().unwrap(), Err("suite".into()));
    assert_eq!(
        REPORTED.load(Ordering::SeqCst),
        1,
        "the render's panic only"
    );

    // Outside on this thread: reported.
    let _ = std::panic::catch_unwind(|| -> () { panic!("after") });
    assert_eq!(REPORTED.load(Ordering::SeqCst), 2);
}
