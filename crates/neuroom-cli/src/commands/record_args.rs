//! `--record FILE` and `--label TEXT`: the options of the commands whose figures the README's tables
//! show (`bench locate`, `bench baseline`, `demo`; `bench train` for the training table).

use std::path::PathBuf;

use neuroom::figures::{FigureRecord, LocateFigures, Record, invocation};

/// Where to keep the figures a command measured, as a row of one of the README's tables.
#[derive(clap::Args)]
pub struct RecordArgs {
    /// Also write the figures as a record for the README's tables (`bench/figures/*.json`, for
    /// `bench train` `bench/training/*.json`; `neuroom bench table` turns the records into the
    /// tables), with this command line beside them.
    #[arg(long, value_name = "FILE")]
    pub record: Option<PathBuf>,
    /// The record's row label (default: what was measured).
    #[arg(long, requires = "record")]
    pub label: Option<String>,
}

impl RecordArgs {
    /// A record of `figures` measured by this process, labelled `default_label` (`--label` replaces it
    /// when the record is written).
    pub fn record(&self, default_label: &str, figures: LocateFigures) -> FigureRecord {
        FigureRecord::measured_now(default_label, invocation(), figures)
    }

    /// Writes `record` where `--record` says, with `--label` when given; nothing without `--record`.
    pub fn write(&self, mut record: impl Record) -> anyhow::Result<()> {
        let Some(path) = &self.record else {
            return Ok(());
        };
        if let Some(label) = &self.label {
            record.relabel(label.clone());
        }
        record.write(path)?;
        eprintln!("wrote the figure record {}", path.display());
        Ok(())
    }
}
