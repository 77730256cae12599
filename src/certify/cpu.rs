//! CPU time of certify's stages: each stage group runs on a thread pool of its own whose
//! threads' CPU clocks are summed, so a stage's CPU-s are its own even while another stage runs
//! on the same cores (the sampler suite runs alongside the renders).
//!
//! Measure: CPU-s = user + system time of the pool's threads (Linux
//! `pthread_getcpuclockid`); elsewhere the clocks read `None` and the report says CPU time was
//! not measured.

use std::sync::{Arc, Mutex};

/// The CPU clocks of one pool's threads.
#[derive(Default)]
struct Clocks {
    #[cfg(target_os = "linux")]
    ids: Mutex<Vec<libc::clockid_t>>,
    #[cfg(not(target_os = "linux"))]
    ids: Mutex<Vec<()>>,
}

impl Clocks {
    /// Registers the calling thread's CPU clock.
    fn register_current(&self) {
        #[cfg(target_os = "linux")]
        {
            let mut id: libc::clockid_t = 0;
            // SAFETY: `pthread_self` is the calling thread, alive during the call; `id` is a
            // valid out-pointer.
            let rc = unsafe { libc::pthread_getcpuclockid(libc::pthread_self(), &mut id) };
            if rc == 0 {
                if let Ok(mut ids) = self.ids.lock() {
                    ids.push(id);
                }
            }
        }
    }

    /// Sum of the registered threads' CPU time (s). Valid while those threads run: the pool's
    /// threads live as long as the pool.
    fn seconds(&self) -> Option<f64> {
        #[cfg(target_os = "linux")]
        {
            let ids = self.ids.lock().ok()?;
            let mut total = 0.0;
            for &id in ids.iter() {
                let mut t = libc::timespec {
                    tv_sec: 0,
                    tv_nsec: 0,
                };
                // SAFETY: `id` is the CPU clock of a thread of a live pool; `t` is a valid
                // out-pointer.
                if unsafe { libc::clock_gettime(id, &mut t) } != 0 {
                    return None;
                }
                total += t.tv_sec as f64 + 1e-9 * t.tv_nsec as f64;
            }
            Some(total)
        }
        #[cfg(not(target_os = "linux"))]
        {
            None
        }
    }
}

/// A rayon pool whose threads' CPU time can be read ([`ClockedPool::cpu_seconds`]).
pub struct ClockedPool {
    pool: rayon::ThreadPool,
    clocks: Arc<Clocks>,
}

impl ClockedPool {
    /// A pool of `threads` workers.
    pub fn new(threads: usize) -> Result<Self, String> {
        let clocks = Arc::new(Clocks::default());
        let registered = Arc::clone(&clocks);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads.max(1))
            .start_handler(move |_| registered.register_current())
            .build()
            .map_err(|e| format!("cannot start worker threads: {e}"))?;
        Ok(Self { pool, clocks })
    }

    /// Runs `f` on the pool (its parallel work stays on the pool's threads).
    pub fn install<R: Send>(&self, f: impl FnOnce() -> R + Send) -> R {
        self.pool.install(f)
    }

    /// CPU time of all the pool's threads since they started (s); `None` where not measurable.
    /// A thread not yet started has used none, so differences of two readings are the pool's
    /// CPU time in between.
    pub fn cpu_seconds(&self) -> Option<f64> {
        self.clocks.seconds()
    }

    /// `f` on the pool, and the pool's CPU-s while it ran (`None` where not measurable).
    /// Meaningful when nothing else runs on the pool meanwhile.
    pub fn timed<R: Send>(&self, f: impl FnOnce() -> R + Send) -> (R, Option<f64>) {
        let before = self.cpu_seconds();
        let r = self.install(f);
        let cpu = before
            .zip(self.cpu_seconds())
            .map(|(a, b)| (b - a).max(0.0));
        (r, cpu)
    }
}

/// CPU time of the whole process so far (user + system, s), `None` where not measurable.
pub fn process_seconds() -> Option<f64> {
    #[cfg(target_os = "linux")]
    {
        let mut t = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: a valid clock id and out-pointer.
        if unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut t) } != 0 {
            return None;
        }
        Some(t.tv_sec as f64 + 1e-9 * t.tv_nsec as f64)
    }
    #[cfg(not(target_os = "linux"))]
    {
        None
    }
}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    use super::*;

    /// The calling thread's own CPU time (s).
    fn thread_seconds() -> f64 {
        let mut t = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: a valid clock id and out-pointer.
        assert_eq!(
            unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut t) },
            0
        );
        t.tv_sec as f64 + 1e-9 * t.tv_nsec as f64
    }

    /// Busy work until the calling thread has used `seconds` of CPU (whatever the load).
    fn spin(seconds: f64) -> u64 {
        let start = thread_seconds();
        let mut x = 0u64;
        while thread_seconds() - start < seconds {
            for _ in 0..1000 {
                x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
            }
        }
        x
    }

    /// 0.1 CPU-s of work on each of two threads of the pool is counted on the pool's clock,
    /// and work on another thread is not.
    #[test]
    fn a_pools_clock_counts_its_own_threads_work() {
        let pool = ClockedPool::new(2).unwrap();
        let ((), cpu) = pool.timed(|| {
            rayon::join(|| spin(0.1), || spin(0.1));
        });
        // At least the work; at most the work plus the pool's idle spinning.
        let cpu = cpu.unwrap();
        assert!((0.2..0.5).contains(&cpu), "{cpu}");
        let before = pool.cpu_seconds().unwrap();
        spin(0.1); // on this thread, not the pool's
        let after = pool.cpu_seconds().unwrap();
        assert!(after - before < 0.05, "{}", after - before);
        assert!(process_seconds().unwrap() >= cpu + 0.1);
    }
}
