//! Long calls off the interpreter: the work runs on a worker thread while the calling thread waits
//! for it with the interpreter released. The work never calls Python: it queues its progress, and
//! the calling thread hands each report to the Python callback and checks for signals, so Ctrl-C
//! interrupts any call and callbacks run on the thread that made the call (as `tqdm` bars and
//! notebooks expect). Work that can stop cleanly (training) is told to through a flag and waited
//! for; other work is left to finish in the background and its result dropped.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, channel};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use neuroom::train::TrainProgress;
use pyo3::exceptions::PyKeyboardInterrupt;
use pyo3::prelude::*;

use crate::error::{NeuroomError, to_py};

/// The longest the calling thread waits before it looks for signals again.
const SIGNAL_POLL: Duration = Duration::from_millis(100);

/// What a call does with its work when it is interrupted (Ctrl-C, or a callback that raises
/// `KeyboardInterrupt`).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum OnInterrupt {
    /// The work checks [`WorkProgress::interrupted`] and stops soon (training saves its
    /// checkpoint): set the flag and wait for it.
    WaitForStop,
    /// The work cannot stop: return at once and let it finish in the background.
    Abandon,
}

/// One progress report, queued by the work for the calling thread.
struct ProgressReport {
    stage: String,
    step: u64,
    total: u64,
}

/// What the work sends the calling thread.
enum WorkEvent {
    Progress(ProgressReport),
    /// The work has returned and its result is waiting.
    Ended,
}

/// The work's side of a long call: progress reports and the stop request. It never touches
/// Python, so it can be used from any thread (training's, the render's pool).
pub struct WorkProgress {
    events: Sender<WorkEvent>,
    stop: Arc<AtomicBool>,
    /// The stage (or model) [`report`](Self::report) names.
    stage: Mutex<String>,
}

impl WorkProgress {
    /// Reports `(stage, step, total)`, unless the call was stopped.
    pub fn tell(&self, stage: &str, step: u64, total: u64) {
        if self.interrupted() {
            return;
        }
        let report = ProgressReport {
            stage: stage.to_string(),
            step,
            total,
        };
        // The calling thread has returned when the receiver is gone: nobody is listening.
        let _ = self.events.send(WorkEvent::Progress(report));
    }

    /// Reports `(step, total)` of the current stage.
    pub fn report(&self, step: u64, total: u64) {
        let stage = self.stage.lock().unwrap_or_else(|e| e.into_inner()).clone();
        self.tell(&stage, step, total);
    }

    /// Whether the call asks the work to stop (Ctrl-C, or the callback raised).
    pub fn interrupted(&self) -> bool {
        self.stop.load(Ordering::SeqCst)
    }
}

impl TrainProgress for WorkProgress {
    fn start(&self, model: &str, done: u64, total: u64) {
        *self.stage.lock().unwrap_or_else(|e| e.into_inner()) = model.to_string();
        self.tell(model, done, total);
    }

    fn step(&self, model: &str, step: u64, total: u64, _: &neuroom::train::LossParts) {
        self.tell(model, step, total);
    }

    fn finish(&self, _: &str, _: &str) {}

    fn note(&self, stage: &str, position: u64, total: u64, _: &str) {
        self.tell(stage, position, total);
    }

    fn interrupted(&self) -> bool {
        WorkProgress::interrupted(self)
    }
}

/// The calling thread's side of a long call: the Python callback and the queue it is fed from.
pub struct LongCall {
    callback: Option<Py<PyAny>>,
    events: Receiver<WorkEvent>,
    ended: Sender<WorkEvent>,
    stop: Arc<AtomicBool>,
    on_interrupt: OnInterrupt,
}

impl LongCall {
    /// A call reporting to `progress` (a callable `(stage, step, total)` or a `tqdm` bar, made a
    /// callable by `neuroom._progress.as_callback`), and the progress its work reports to,
    /// starting at `stage`.
    pub fn new(
        py: Python<'_>,
        progress: Option<Py<PyAny>>,
        stage: &str,
        on_interrupt: OnInterrupt,
    ) -> PyResult<(Self, Arc<WorkProgress>)> {
        let callback = match progress {
            Some(p) => {
                let adapt = py.import("neuroom._progress")?.getattr("as_callback")?;
                Some(adapt.call1((p,))?.unbind())
            }
            None => None,
        };
        let (sender, events) = channel();
        let stop = Arc::new(AtomicBool::new(false));
        let work = WorkProgress {
            events: sender.clone(),
            stop: stop.clone(),
            stage: Mutex::new(stage.to_string()),
        };
        let call = LongCall {
            callback,
            events,
            ended: sender,
            stop,
            on_interrupt,
        };
        Ok((call, Arc::new(work)))
    }

    /// Runs `work` on a worker thread and waits for it with the interpreter released, handing its
    /// reports to the callback. On a signal (Ctrl-C raises `KeyboardInterrupt`) it sets the stop
    /// flag and, as [`OnInterrupt`] says, waits for the work or returns at once. A callback that
    /// raises is not called again; its exception is the call's once the work has ended (training
    /// stops at its next step, other work runs to its end).
    pub fn run<T: Send + 'static>(
        self,
        py: Python<'_>,
        work: impl FnOnce() -> anyhow::Result<T> + Send + 'static,
    ) -> PyResult<T> {
        let LongCall {
            callback,
            mut events,
            ended,
            stop,
            on_interrupt,
        } = self;
        let (result_sender, result) = channel();
        let handle = std::thread::Builder::new()
            .name("neuroom".into())
            .spawn(move || {
                let _ = result_sender.send(work());
                let _ = ended.send(WorkEvent::Ended);
            })
            .map_err(|e| NeuroomError::new_err(format!("cannot start a worker thread: {e}")))?;
        let mut raised: Option<PyErr> = None;
        loop {
            // The receiver goes to the detached closure and back: it may be moved, not shared.
            let (got, back) = py.detach(move || (events.recv_timeout(SIGNAL_POLL), events));
            events = back;
            match got {
                Ok(WorkEvent::Progress(report)) => {
                    if raised.is_none()
                        && let Some(callback) = &callback
                        && let Err(e) =
                            callback.call1(py, (report.stage, report.step, report.total))
                    {
                        stop.store(true, Ordering::SeqCst);
                        raised = Some(e);
                    }
                }
                Ok(WorkEvent::Ended) => break,
                // A panicking worker never sends `Ended`.
                Err(RecvTimeoutError::Timeout) if handle.is_finished() => break,
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => break,
            }
            let interrupt = match py.check_signals() {
                Err(signal) => Some(signal),
                Ok(()) => raised.take_if(|e| e.is_instance_of::<PyKeyboardInterrupt>(py)),
            };
            if let Some(interrupt) = interrupt {
                stop.store(true, Ordering::SeqCst);
                if on_interrupt == OnInterrupt::WaitForStop {
                    let _ = py.detach(|| handle.join());
                }
                return Err(interrupt);
            }
        }
        let _ = py.detach(|| handle.join());
        if let Some(raised) = raised {
            return Err(raised);
        }
        match result.try_recv() {
            Ok(outcome) => outcome.map_err(to_py),
            Err(_) => Err(NeuroomError::new_err(
                "the worker thread stopped without a result (a bug: please report it)",
            )),
        }
    }
}
