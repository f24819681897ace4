//! The node's recorder: a thread that owns the file, fed through a bounded channel, so that the
//! node never waits on the disk. A full channel drops the message and counts it; a write error
//! (full disk, file gone) stops recording and is reported, never a crash of the node.

use super::{OfferedQos, RecordOptions, SessionWriter};
use crate::msgs::{
    DiagnosticArray, Gap, JointState, LegForce, ModelParams, PoseStamped, TfMessage, WrenchStamped,
};
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, SyncSender, TrySendError, sync_channel};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

/// A message to record: its topic, QoS, receive time (`log`) and stamp (`publish`), in ns.
pub enum Record {
    Joints(Arc<str>, JointState, u64),
    Wrench(Arc<str>, WrenchStamped, u64),
    Prediction(Arc<str>, WrenchStamped, u64),
    Force(Arc<str>, LegForce, u64),
    Params(Arc<str>, ModelParams, u64),
    Diagnostics(Arc<str>, DiagnosticArray, u64),
    Gap(Arc<str>, Gap, u64),
    /// `/tf` or `/tf_static`, an input: published time is the first transform's stamp.
    Tf(Arc<str>, TfMessage, u64),
    /// The body's pose, an input.
    Pose(Arc<str>, PoseStamped, u64),
}

/// What the node reads of the recorder's state.
#[derive(Default)]
pub struct RecorderStatus {
    pub written: AtomicU64,
    pub dropped: AtomicU64,
    pub failed: AtomicBool,
    pub error: Mutex<Option<String>>,
}

pub struct Recorder {
    tx: Option<SyncSender<Record>>,
    /// Waits for room in the queue instead of dropping ([`Recorder::lossless`]).
    lossless: bool,
    thread: Option<JoinHandle<()>>,
    pub status: Arc<RecorderStatus>,
    pub path: PathBuf,
}

/// Now on the wall clock (ns since the Unix epoch): the log time of what is recorded.
pub fn now_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0)
}

impl Recorder {
    /// Creates the file and starts the thread. An unwritable path is an error here.
    pub fn start(
        path: &Path,
        opts: RecordOptions,
        capacity: usize,
    ) -> Result<Recorder, super::RecordError> {
        let file = File::create(path)?;
        let writer = SessionWriter::new(BufWriter::with_capacity(1 << 20, file), opts)?;
        let (tx, rx) = sync_channel(capacity.max(16));
        let status = Arc::new(RecorderStatus::default());
        let st = status.clone();
        let thread = std::thread::Builder::new()
            .name("terzaghi-recorder".into())
            .spawn(move || run(writer, rx, &st))?;
        Ok(Recorder {
            tx: Some(tx),
            lossless: false,
            thread: Some(thread),
            status,
            path: path.to_path_buf(),
        })
    }

    /// A recorder that waits for room in its queue rather than drop a message: for a simulated
    /// robot in memory, which can wait for the disk, where a node on a robot cannot.
    pub fn lossless(mut self) -> Recorder {
        self.lossless = true;
        self
    }

    /// Hands a message to the recorder. Never blocks, unless [`Recorder::lossless`]: a full
    /// queue then waits for the recorder thread instead of counting a drop.
    pub fn record(&self, r: Record) {
        if self.status.failed.load(Ordering::Relaxed) {
            return;
        }
        if let Some(tx) = &self.tx {
            if self.lossless {
                if tx.send(r).is_err() {
                    self.status.dropped.fetch_add(1, Ordering::Relaxed);
                }
                return;
            }
            match tx.try_send(r) {
                Ok(()) => {}
                Err(TrySendError::Full(_)) | Err(TrySendError::Disconnected(_)) => {
                    self.status.dropped.fetch_add(1, Ordering::Relaxed);
                }
            }
        }
    }

    /// Finishes the file (summary, statistics) and waits for the thread.
    pub fn finish(mut self) -> Option<String> {
        self.tx.take();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        self.status.error.lock().ok().and_then(|e| e.clone())
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        self.tx.take();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn run(mut w: SessionWriter<BufWriter<File>>, rx: Receiver<Record>, st: &RecorderStatus) {
    let fail = |e: String| {
        st.failed.store(true, Ordering::Relaxed);
        if let Ok(mut slot) = st.error.lock() {
            slot.get_or_insert(e);
        }
    };
    loop {
        let r = match rx.recv_timeout(Duration::from_millis(200)) {
            Ok(r) => r,
            Err(RecvTimeoutError::Timeout) => {
                // Quiet input: still close the chunk once a second of wall time has passed.
                if let Err(e) = w.maybe_flush(now_ns()) {
                    fail(e.to_string());
                    return;
                }
                continue;
            }
            Err(RecvTimeoutError::Disconnected) => break,
        };
        let be = OfferedQos::BEST_EFFORT;
        let rel = OfferedQos::RELIABLE;
        let res = match &r {
            Record::Joints(t, m, log) => {
                w.write(t, be, m, *log, m.header.stamp.to_nanos().max(0) as u64)
            }
            Record::Wrench(t, m, log) => {
                w.write(t, be, m, *log, m.header.stamp.to_nanos().max(0) as u64)
            }
            Record::Prediction(t, m, log) => {
                w.write_output(t, rel, m, *log, m.header.stamp.to_nanos().max(0) as u64)
            }
            Record::Force(t, m, log) => {
                w.write_output(t, rel, m, *log, m.header.stamp.to_nanos().max(0) as u64)
            }
            Record::Params(t, m, log) => {
                w.write_output(t, rel, m, *log, m.header.stamp.to_nanos().max(0) as u64)
            }
            Record::Diagnostics(t, m, log) => {
                w.write_output(t, rel, m, *log, m.header.stamp.to_nanos().max(0) as u64)
            }
            Record::Gap(t, m, log) => {
                w.write_output(t, rel, m, *log, m.header.stamp.to_nanos().max(0) as u64)
            }
            Record::Tf(t, m, log) => {
                let stamp = m
                    .transforms
                    .first()
                    .map_or(*log as i64, |x| x.header.stamp.to_nanos());
                w.write(t, rel, m, *log, stamp.max(0) as u64)
            }
            Record::Pose(t, m, log) => {
                w.write(t, be, m, *log, m.header.stamp.to_nanos().max(0) as u64)
            }
        };
        match res {
            Ok(()) => {
                st.written.fetch_add(1, Ordering::Relaxed);
            }
            Err(e) => {
                fail(e.to_string());
                return;
            }
        }
    }
    if let Err(e) = w.finish() {
        fail(e.to_string());
    }
}
