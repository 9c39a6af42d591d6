//! Progress reporting of training runs: terminal progress bars (indicatif) with loss and PSNR, or nothing.

use crate::losses::LossParts;
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use std::collections::HashMap;
use std::sync::Mutex;

/// Receives the progress of training runs. Models training side by side report at the same time, from
/// their own threads, each under its name.
pub trait Progress: Sync {
    /// `model` starts (or resumes) with `total` steps planned, `done` already taken.
    fn start(&self, model: &str, done: u64, total: u64);
    /// A step of `model` finished.
    fn step(&self, model: &str, step: u64, total: u64, loss: &LossParts);
    /// `model` finished; `message` sums it up.
    fn finish(&self, model: &str, message: &str);
    /// Progress of a stage that is not a model's training (e.g. the identification network, started
    /// with [`Progress::start`] under its name): `position` of `total` units, and what to show beside
    /// the bar.
    fn note(&self, _stage: &str, _position: u64, _total: u64, _message: &str) {}
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
    fn step(&self, _: &str, _: u64, _: u64, _: &LossParts) {}
    fn finish(&self, _: &str, _: &str) {}
}

/// A progress bar on standard error per model or stage in progress, showing the loss and the batch
/// PSNR; bars of models training side by side stack.
#[derive(Debug, Default)]
pub struct Bar {
    bars: MultiProgress,
    running: Mutex<HashMap<String, ProgressBar>>,
}

impl Bar {
    /// Runs `f` on the bar of `model`, if it is running.
    fn with_bar(&self, model: &str, f: impl FnOnce(&ProgressBar)) {
        if let Some(bar) = self
            .running
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .get(model)
        {
            f(bar);
        }
    }
}

impl Progress for Bar {
    fn start(&self, model: &str, done: u64, total: u64) {
        let bar = self.bars.add(ProgressBar::new(total));
        let style = ProgressStyle::with_template(
            "{prefix:>18} [{bar:30}] {pos}/{len} {elapsed_precise} eta {eta} {msg}",
        )
        .map(|s| s.progress_chars("=> "))
        .unwrap_or_else(|_| ProgressStyle::default_bar());
        bar.set_style(style);
        bar.set_prefix(model.to_string());
        bar.set_position(done);
        self.running
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .insert(model.to_string(), bar);
    }

    fn step(&self, model: &str, step: u64, total: u64, loss: &LossParts) {
        self.with_bar(model, |bar| {
            bar.set_length(total);
            bar.set_position(step);
            if step.is_multiple_of(10) || step == total {
                bar.set_message(format!(
                    "loss {:.4} psnr {:.2} dB",
                    loss.total(),
                    loss.psnr()
                ));
            }
        });
    }

    fn note(&self, stage: &str, position: u64, total: u64, message: &str) {
        self.with_bar(stage, |bar| {
            bar.set_length(total);
            bar.set_position(position.min(total));
            bar.set_message(message.to_string());
        });
    }

    fn finish(&self, model: &str, message: &str) {
        let bar = self
            .running
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .remove(model);
        if let Some(bar) = bar {
            bar.finish_with_message(message.to_string());
        }
    }
}
