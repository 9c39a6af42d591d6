//! Progress reporting of training runs: a terminal progress bar (indicatif) with loss and PSNR, or nothing.

use crate::losses::LossParts;
use indicatif::{ProgressBar, ProgressStyle};
use std::sync::Mutex;

/// Receives the progress of training runs, one model at a time.
pub trait Progress: Sync {
    /// A model starts (or resumes) with `total` steps planned, `done` already taken.
    fn start(&self, model: &str, done: u64, total: u64);
    /// A step finished.
    fn step(&self, step: u64, total: u64, loss: &LossParts);
    /// The model finished; `message` sums it up.
    fn finish(&self, message: &str);
    /// Progress of a stage that is not a model's training (e.g. the identification network): `position`
    /// of `total` units, and what to show beside the bar.
    fn note(&self, _position: u64, _total: u64, _message: &str) {}
    /// Whether the caller asks the run to stop (e.g. Ctrl-C in a host program): checked after every
    /// step; the trainer then saves its checkpoint and returns [`TrainError::Interrupted`](crate::TrainError).
    fn interrupted(&self) -> bool {
        false
    }
}

/// Reports nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct Quiet;

impl Progress for Quiet {
    fn start(&self, _: &str, _: u64, _: u64) {}
    fn step(&self, _: u64, _: u64, _: &LossParts) {}
    fn finish(&self, _: &str) {}
}

/// A progress bar on standard error per model, showing the loss and the batch PSNR.
#[derive(Debug, Default)]
pub struct Bar {
    bar: Mutex<Option<ProgressBar>>,
}

impl Progress for Bar {
    fn start(&self, model: &str, done: u64, total: u64) {
        let bar = ProgressBar::new(total);
        let style = ProgressStyle::with_template(
            "{prefix:>18} [{bar:30}] {pos}/{len} {elapsed_precise} eta {eta} {msg}",
        )
        .map(|s| s.progress_chars("=> "))
        .unwrap_or_else(|_| ProgressStyle::default_bar());
        bar.set_style(style);
        bar.set_prefix(model.to_string());
        bar.set_position(done);
        *self.bar.lock().unwrap_or_else(|e| e.into_inner()) = Some(bar);
    }

    fn step(&self, step: u64, total: u64, loss: &LossParts) {
        if let Some(bar) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
            bar.set_length(total);
            bar.set_position(step);
            if step.is_multiple_of(10) || step == total {
                bar.set_message(format!(
                    "loss {:.4} psnr {:.2} dB",
                    loss.total(),
                    loss.psnr()
                ));
            }
        }
    }

    fn note(&self, position: u64, total: u64, message: &str) {
        if let Some(bar) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
            bar.set_length(total);
            bar.set_position(position.min(total));
            bar.set_message(message.to_string());
        }
    }

    fn finish(&self, message: &str) {
        if let Some(bar) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).take() {
            bar.finish_with_message(message.to_string());
        }
    }
}
