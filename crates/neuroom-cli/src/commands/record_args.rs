//! `--record FILE` and `--label TEXT`: the options of the commands whose figures the README's results
//! table shows (`bench locate`, `bench baseline`, `demo`).

use std::path::PathBuf;

use neuroom::figures::{FigureRecord, LocateFigures, invocation};

/// Where to keep the figures a command measured, as a row of the results table.
#[derive(clap::Args)]
pub struct RecordArgs {
    /// Also write the figures as a record for the README's results table (`bench/figures/*.json`;
    /// `neuroom bench table` turns the records into the table), with this command line beside them.
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
    pub fn write(&self, mut record: FigureRecord) -> anyhow::Result<()> {
        let Some(path) = &self.record else {
            return Ok(());
        };
        if let Some(label) = &self.label {
            record.label = label.clone();
        }
        record.write(path)?;
        eprintln!("wrote the figure record {}", path.display());
        Ok(())
    }
}
