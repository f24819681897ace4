//! Real-time habits of control nodes: a thread pinned to CPUs of its own, and the message
//! handling under SCHED_FIFO so that other threads do not preempt it.

use anyhow::{Result, bail};

/// Pins the calling thread, and the threads it starts afterwards, to `cpus`.
pub fn pin_to_cpus(cpus: &[usize]) -> Result<()> {
    #[cfg(target_os = "linux")]
    {
        let online = std::thread::available_parallelism().map_or(1, |n| n.get());
        // SAFETY: a zeroed cpu_set_t is a valid empty set; CPU_SET writes inside it (each cpu
        // is checked against CPU_SETSIZE); sched_setaffinity reads it and changes only this
        // thread.
        let rc = unsafe {
            let mut set: libc::cpu_set_t = std::mem::zeroed();
            for &cpu in cpus {
                if cpu >= libc::CPU_SETSIZE as usize {
                    bail!("CPU {cpu} does not exist (this machine has {online} CPUs online)");
                }
                libc::CPU_SET(cpu, &mut set);
            }
            libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set)
        };
        if rc != 0 {
            bail!(
                "cannot run on CPU {cpus:?}: {} (this machine has {online} CPUs online)",
                std::io::Error::last_os_error()
            );
        }
        Ok(())
    }
    #[cfg(not(target_os = "linux"))]
    {
        let _ = cpus;
        bail!("pinning to a CPU is supported on Linux only")
    }
}

/// Puts the calling thread (the one the node's messages are handled on) under SCHED_FIFO.
pub fn set_realtime(priority: i32) -> Result<()> {
    if !(1..=99).contains(&priority) {
        bail!("priority {priority}: must be from 1 to 99");
    }
    #[cfg(target_os = "linux")]
    {
        let param = libc::sched_param {
            sched_priority: priority,
        };
        // SAFETY: sched_setscheduler reads `param` and changes only this thread's policy.
        let rc = unsafe { libc::sched_setscheduler(0, libc::SCHED_FIFO, &param) };
        if rc != 0 {
            bail!(
                "cannot run under SCHED_FIFO priority {priority}: {} (needs CAP_SYS_NICE or root)",
                std::io::Error::last_os_error()
            );
        }
        Ok(())
    }
    #[cfg(not(target_os = "linux"))]
    {
        bail!("SCHED_FIFO is supported on Linux only")
    }
}

/// Makes the calling thread a background one, whatever the thread that started it was: on the
/// CPUs the node is not pinned to (all of them when it is pinned to none, or to every one), under
/// SCHED_IDLE (it gets a CPU only when nothing else wants it), so that it takes no time, and no
/// cache, from the message handling. Best effort: `Err` says what was refused.
pub fn set_background() -> Result<()> {
    #[cfg(target_os = "linux")]
    {
        let online = std::thread::available_parallelism().map_or(1, |n| n.get());
        let cpus = online.min(libc::CPU_SETSIZE as usize);
        // SAFETY: as in `pin_to_cpus` and `set_realtime`: zeroed sets, CPUs below CPU_SETSIZE,
        // and calls that read or change only this thread.
        let (affinity, policy) = unsafe {
            let mut inherited: libc::cpu_set_t = std::mem::zeroed();
            let got =
                libc::sched_getaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &mut inherited);
            let mut others: libc::cpu_set_t = std::mem::zeroed();
            let mut all: libc::cpu_set_t = std::mem::zeroed();
            let mut n_others = 0;
            for cpu in 0..cpus {
                libc::CPU_SET(cpu, &mut all);
                if got == 0 && !libc::CPU_ISSET(cpu, &inherited) {
                    libc::CPU_SET(cpu, &mut others);
                    n_others += 1;
                }
            }
            let set = if n_others > 0 { &others } else { &all };
            let a = libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), set);
            let param = libc::sched_param { sched_priority: 0 };
            let p = libc::sched_setscheduler(0, libc::SCHED_IDLE, &param);
            (a, p)
        };
        if affinity != 0 || policy != 0 {
            bail!(
                "cannot make the thread a background one: {}",
                std::io::Error::last_os_error()
            );
        }
        Ok(())
    }
    #[cfg(not(target_os = "linux"))]
    {
        Ok(())
    }
}
