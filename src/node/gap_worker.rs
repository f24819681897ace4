//! The thread that runs the node's own diagnoses ([`GapJob`]s), off the message path: jobs go in
//! through a queue of one (a job that finds it full waits in the core, one per leg, a newer one
//! superseding it), reports come back through another, which the transport drains when it
//! publishes diagnostics. The thread runs in the background (SCHED_IDLE, off the CPUs the node is
//! pinned to): it takes no time from the message handling, and its memory is the windows of the
//! jobs in flight.

use super::core::GapJob;
use crate::diagnose::Report;
use std::sync::Mutex;
use std::sync::mpsc::{Receiver, SyncSender, TryRecvError, TrySendError, channel, sync_channel};
use std::thread::JoinHandle;

/// A diagnosis done: the job and what came of it.
pub type GapDone = (GapJob, Result<Report, String>);

pub struct GapWorker {
    tx: Option<SyncSender<GapJob>>,
    /// Behind a lock only so that the worker can be shared between the node's tasks.
    rx: Mutex<Receiver<GapDone>>,
    thread: Option<JoinHandle<()>>,
}

impl GapWorker {
    /// Starts the thread.
    pub fn start() -> std::io::Result<GapWorker> {
        let (tx, jobs) = sync_channel::<GapJob>(1);
        let (done, rx) = channel::<GapDone>();
        let thread = std::thread::Builder::new()
            .name("terzaghi-gap".into())
            .spawn(move || {
                // Best effort: where the policy cannot be changed, the thread still runs.
                let _ = super::realtime::set_background();
                for job in jobs {
                    let r = job.run();
                    if done.send((job, r)).is_err() {
                        break;
                    }
                }
            })?;
        Ok(GapWorker {
            tx: Some(tx),
            rx: Mutex::new(rx),
            thread: Some(thread),
        })
    }

    /// Hands a job to the thread; never blocks. The job back when the thread is busy with
    /// another (or gone), for the core to keep until the next try.
    pub fn submit(&self, job: GapJob) -> Result<(), Box<GapJob>> {
        let Some(tx) = &self.tx else {
            return Err(Box::new(job));
        };
        match tx.try_send(job) {
            Ok(()) => Ok(()),
            Err(TrySendError::Full(j) | TrySendError::Disconnected(j)) => Err(Box::new(j)),
        }
    }

    /// Offers `core`'s waiting diagnoses to the thread, as many as it takes; the others wait in
    /// the core.
    pub fn offer(&self, core: &mut super::core::NodeCore) {
        while let Some(job) = core.next_gap_job() {
            if let Err(job) = self.submit(job) {
                core.return_gap_job(*job);
                return;
            }
        }
    }

    /// The diagnoses done since the last call.
    pub fn done(&self, out: &mut Vec<GapDone>) {
        let rx = self.rx.lock().unwrap_or_else(|p| p.into_inner());
        loop {
            match rx.try_recv() {
                Ok(d) => out.push(d),
                Err(TryRecvError::Empty | TryRecvError::Disconnected) => return,
            }
        }
    }
}

impl GapWorker {
    /// How long dropping the worker waits for a diagnosis under way before leaving it.
    const STOP_WAIT: std::time::Duration = std::time::Duration::from_millis(500);
}

impl Drop for GapWorker {
    /// Stops the thread: it ends once its current diagnosis (if any) is done. That is waited
    /// for up to [`Self::STOP_WAIT`], no longer: the thread runs at the lowest priority, and on
    /// a busy machine a diagnosis under way could hold a node that was asked to stop for as
    /// long as the CPUs stay busy. Past the wait the thread is left to finish (or to end with
    /// the process); its result has nowhere to go.
    fn drop(&mut self) {
        self.tx = None;
        if let Some(t) = self.thread.take() {
            let until = std::time::Instant::now() + Self::STOP_WAIT;
            while !t.is_finished() && std::time::Instant::now() < until {
                std::thread::sleep(std::time::Duration::from_millis(5));
            }
            if t.is_finished() {
                let _ = t.join();
            }
        }
    }
}
