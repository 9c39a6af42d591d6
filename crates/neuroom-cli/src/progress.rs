//! Progress display for long commands: one bar per stage, driven by the library's progress callbacks.

use indicatif::{ProgressBar, ProgressStyle};

/// A progress bar that switches to a new bar whenever the stage name changes.
pub struct StageBars {
    stage: String,
    bar: Option<ProgressBar>,
}

impl StageBars {
    /// No bar yet; the first update creates one.
    pub fn new() -> Self {
        Self {
            stage: String::new(),
            bar: None,
        }
    }

    /// Shows `done` of `total` for `stage`, finishing the previous stage's bar when the stage changes.
    pub fn update(&mut self, stage: &str, done: u64, total: u64) {
        if stage != self.stage || self.bar.is_none() {
            self.finish();
            let bar = ProgressBar::new(total);
            bar.set_style(
                ProgressStyle::with_template(
                    "{prefix:>24} [{bar:30}] {pos}/{len} {elapsed_precise} {msg}",
                )
                .expect("valid template")
                .progress_chars("=> "),
            );
            bar.set_prefix(stage.to_string());
            self.stage = stage.to_string();
            self.bar = Some(bar);
        }
        if let Some(bar) = &self.bar {
            bar.set_length(total);
            bar.set_position(done);
        }
    }

    /// Shows `message` after the current bar (what it is doing now).
    pub fn message(&self, message: &str) {
        if let Some(bar) = &self.bar {
            bar.set_message(message.to_string());
        }
    }

    /// Finishes the current bar, leaving it on screen.
    pub fn finish(&mut self) {
        if let Some(bar) = self.bar.take() {
            bar.finish();
        }
    }
}

impl Drop for StageBars {
    fn drop(&mut self) {
        self.finish();
    }
}
