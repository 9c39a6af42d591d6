//! Long calls off the interpreter: the work runs on a worker thread while the calling thread, with
//! the interpreter released, waits for it and checks for signals, so Ctrl-C interrupts any call. Work
//! that can stop cleanly (training) is told to through a flag and waited for; other work is left to
//! finish in the background and its result dropped.

use std::sync::Arc;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{RecvTimeoutError, channel};
use std::time::Duration;

use neuroom::train::TrainProgress;
use pyo3::prelude::*;

use crate::error::{NeuroomError, to_py};

/// How often the waiting thread looks for signals.
const SIGNAL_POLL: Duration = Duration::from_millis(100);

/// A stop request shared between the waiting thread and the work.
pub type StopFlag = Arc<AtomicBool>;

/// Runs `work` on a worker thread and waits for it with the interpreter released. On a signal
/// (Ctrl-C raises `KeyboardInterrupt`) with `stop` given, sets it and waits for the work to stop;
/// without, returns at once. `errors` holds an exception raised in a callback of the work, raised
/// in place of the work's result once the work has ended (training stops at its next step; other
/// work runs to its end without calling the callback again).
pub fn run<T: Send + 'static>(
    py: Python<'_>,
    stop: Option<StopFlag>,
    errors: Option<Arc<CallbackError>>,
    work: impl FnOnce() -> anyhow::Result<T> + Send + 'static,
) -> PyResult<T> {
    let (tx, rx) = channel();
    let handle = std::thread::Builder::new()
        .name("neuroom".into())
        .spawn(move || {
            let _ = tx.send(work());
        })
        .map_err(|e| NeuroomError::new_err(format!("cannot start a worker thread: {e}")))?;
    let mut rx = rx;
    loop {
        // The receiver goes to the detached closure and back: it may be moved, not shared.
        let (got, back) = py.detach(move || (rx.recv_timeout(SIGNAL_POLL), rx));
        rx = back;
        match got {
            Ok(result) => {
                let _ = py.detach(|| handle.join());
                if let Some(raised) = errors.as_ref().and_then(|e| e.take()) {
                    return Err(raised);
                }
                return result.map_err(to_py);
            }
            Err(RecvTimeoutError::Timeout) => {
                if let Err(signal) = py.check_signals() {
                    if let Some(stop) = &stop {
                        stop.store(true, Ordering::SeqCst);
                        let _ = py.detach(|| handle.join());
                    }
                    return Err(signal);
                }
            }
            Err(RecvTimeoutError::Disconnected) => {
                return Err(NeuroomError::new_err(
                    "the worker thread stopped without a result (a bug: please report it)",
                ));
            }
        }
    }
}

/// The first exception a Python callback raised during a call.
#[derive(Default)]
pub struct CallbackError(Mutex<Option<PyErr>>);

impl CallbackError {
    fn keep(&self, error: PyErr) {
        let mut slot = self.0.lock().unwrap_or_else(|e| e.into_inner());
        slot.get_or_insert(error);
    }

    fn take(&self) -> Option<PyErr> {
        self.0.lock().unwrap_or_else(|e| e.into_inner()).take()
    }
}

/// Training progress handed to a Python callable `callback(model, step, total)` (a `tqdm` bar is
/// turned into one by `neuroom._progress.as_callback`), and the stop request of [`run`]. A callback
/// that raises stops training, and its exception is the call's.
pub struct CallbackProgress {
    /// The callable, or `None` for no reports.
    pub callback: Option<Py<PyAny>>,
    /// Set by [`run`] on Ctrl-C, or here when the callback raised.
    pub stop: StopFlag,
    /// The callback's exception.
    pub errors: Arc<CallbackError>,
    /// The model training now.
    pub model: Mutex<String>,
}

impl CallbackProgress {
    /// Hands `(model, step, total)` to the callback, the model training now (or the stage the
    /// reporter was made for).
    pub fn report(&self, step: u64, total: u64) {
        let model = self.model.lock().unwrap_or_else(|e| e.into_inner()).clone();
        self.tell(&model, step, total);
    }

    /// Hands `(stage, step, total)` to the callback, unless an earlier call raised.
    pub fn tell(&self, stage: &str, step: u64, total: u64) {
        let Some(callback) = &self.callback else {
            return;
        };
        if self.stop.load(Ordering::SeqCst) {
            return;
        }
        Python::attach(|py| {
            if let Err(e) = callback.call1(py, (stage, step, total)) {
                self.errors.keep(e);
                self.stop.store(true, Ordering::SeqCst);
            }
        });
    }
}

impl TrainProgress for CallbackProgress {
    fn start(&self, model: &str, done: u64, total: u64) {
        *self.model.lock().unwrap_or_else(|e| e.into_inner()) = model.to_string();
        self.report(done, total);
    }

    fn step(&self, step: u64, total: u64, _: &neuroom::train::LossParts) {
        self.report(step, total);
    }

    fn finish(&self, _: &str) {}

    fn note(&self, position: u64, total: u64, _: &str) {
        self.report(position, total);
    }

    fn interrupted(&self) -> bool {
        self.stop.load(Ordering::SeqCst)
    }
}

/// A progress argument as a callable `(stage, step, total)`: `neuroom._progress.as_callback`
/// turns a `tqdm` bar into one and passes callables through.
pub fn progress_callback(
    py: Python<'_>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Option<Py<PyAny>>> {
    let Some(progress) = progress else {
        return Ok(None);
    };
    let adapt = py.import("neuroom._progress")?.getattr("as_callback")?;
    Ok(Some(adapt.call1((progress,))?.unbind()))
}

/// A fresh progress reporter around `callback`.
pub fn reporter(callback: Option<Py<PyAny>>, stage: &str) -> Arc<CallbackProgress> {
    Arc::new(CallbackProgress {
        callback,
        stop: Arc::new(AtomicBool::new(false)),
        errors: Arc::new(CallbackError::default()),
        model: Mutex::new(stage.to_string()),
    })
}
