//! Training figures as artefacts: `neuroom bench train ROOM MODEL … --record FILE` keeps what one
//! model reached in how many steps as a [`TrainingFigureRecord`] under `bench/training/`, and
//! [`training_table`] makes the README's training table from those records, as
//! [`crate::figures`] does for the localization figures.

use std::path::Path;

use neuroom_train::TrainConfig;
use neuroom_train::bench::ModelBenchReport;
use serde::{Deserialize, Serialize};

use crate::figures::{Record, TableMarkers, check_format, read_json, record_paths, write_json};

/// The `format` of a training figure record.
pub const TRAINING_FIGURES_FORMAT: &str = "neuroom.training-figures/1";

/// Where the training table stands in the README.
pub const TRAINING_TABLE: TableMarkers = TableMarkers {
    begin: "<!-- training figures: generated from bench/training/*.json by `neuroom bench table --readme README.md` -->",
    end: "<!-- end of training figures -->",
};

/// What one model reached with its budget.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainingFigures {
    /// The room's name.
    pub room: String,
    /// The model: `background` or an object capture's name.
    pub model: String,
    /// Worker threads it trained on.
    pub threads: usize,
    /// Optimisation steps.
    pub steps: u64,
    /// Rays a step.
    pub batch_rays: usize,
    /// Wall-clock seconds of the steps (depends on the machine and its load; not compared).
    pub train_seconds: f64,
    /// Held-out PSNR, dB (`None` without held-out views).
    pub psnr_db: Option<f64>,
    /// Median depth error on the held-out views, mm.
    pub median_depth_error_mm: Option<f64>,
    /// Mean Chamfer distance to the ground-truth mesh, mm (`None` without one).
    pub chamfer_mm: Option<f64>,
}

impl TrainingFigures {
    /// The figures of `neuroom bench train`'s report of a model trained with `config`.
    pub fn from_report(report: &ModelBenchReport, config: &TrainConfig) -> Self {
        let batch_rays = config.budget(report.kind).batch_rays;
        Self {
            room: report.room.clone(),
            model: report.model.clone(),
            threads: report.threads,
            steps: report.steps,
            batch_rays,
            train_seconds: report.train_wall_seconds,
            psnr_db: report.held_out.as_ref().map(|e| e.psnr_db),
            median_depth_error_mm: report
                .held_out
                .as_ref()
                .map(|e| f64::from(e.median_depth_error_m) * 1e3),
            chamfer_mm: report.chamfer_m.as_ref().map(|c| f64::from(c.mean) * 1e3),
        }
    }

    /// The row label of a record without `--label`: the room and the model (the budget has its
    /// own column).
    pub fn default_label(&self) -> String {
        format!("{} {}", self.room, self.model)
    }
}

/// One row of the training table, as `neuroom bench train --record` wrote it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainingFigureRecord {
    /// [`TRAINING_FIGURES_FORMAT`].
    pub format: String,
    /// The row's label.
    pub label: String,
    /// The command that measured it, as typed.
    pub command: String,
    /// The date of the measurement (UTC, `YYYY-MM-DD`).
    pub measured: String,
    /// The figures.
    pub figures: TrainingFigures,
}

impl TrainingFigureRecord {
    /// A record of `figures` measured now by `command`, labelled by [`TrainingFigures::default_label`].
    pub fn measured_now(command: String, figures: TrainingFigures) -> Self {
        Self {
            format: TRAINING_FIGURES_FORMAT.into(),
            label: figures.default_label(),
            command,
            measured: jiff::Timestamp::now().strftime("%Y-%m-%d").to_string(),
            figures,
        }
    }

    /// Reads a record, naming the file when it is not one.
    pub fn read(path: &Path) -> anyhow::Result<Self> {
        let record: Self = read_json(path, "training figure record")?;
        check_format(path, &record.format, TRAINING_FIGURES_FORMAT)?;
        Ok(record)
    }
}

impl Record for TrainingFigureRecord {
    fn relabel(&mut self, label: String) {
        self.label = label;
    }

    fn write(&self, path: &Path) -> anyhow::Result<()> {
        write_json(path, self, "training figure record")
    }
}

/// The training records in `dir` (`*.json`), in file-name order.
pub fn read_training_records(dir: &Path) -> anyhow::Result<Vec<TrainingFigureRecord>> {
    record_paths(dir)?
        .iter()
        .map(|p| TrainingFigureRecord::read(p))
        .collect()
}

/// The training table of `records`, as Markdown: one row per record.
pub fn training_table(records: &[TrainingFigureRecord]) -> String {
    let mut lines = vec![
        "| | command | steps × rays | seconds of steps (threads) | held-out PSNR | median depth error | Chamfer | measured |".to_string(),
        "|---|---|---|---|---|---|---|---|".to_string(),
    ];
    let or_dash = |value: Option<f64>, unit: &str, digits: usize| {
        value.map_or("—".to_string(), |v| format!("{v:.digits$} {unit}"))
    };
    for r in records {
        let f = &r.figures;
        lines.push(format!(
            "| {} | `{}` | {} × {} | {:.0} s ({}) | {} | {} | {} | {} |",
            r.label,
            r.command,
            f.steps,
            f.batch_rays,
            f.train_seconds,
            f.threads,
            or_dash(f.psnr_db, "dB", 2),
            or_dash(f.median_depth_error_mm, "mm", 2),
            or_dash(f.chamfer_mm, "mm", 2),
            r.measured
        ));
    }
    lines.join("\n") + "\n"
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(model: &str, chamfer_mm: Option<f64>) -> TrainingFigureRecord {
        TrainingFigureRecord::measured_now(
            format!("neuroom bench train rooms/bedroom {model} --steps 100"),
            TrainingFigures {
                room: "bedroom".into(),
                model: model.into(),
                threads: 2,
                steps: 100,
                batch_rays: 512,
                train_seconds: 12.4,
                psnr_db: Some(30.123),
                median_depth_error_mm: Some(0.456),
                chamfer_mm,
            },
        )
    }

    #[test]
    fn the_training_table_has_a_row_per_record_and_a_dash_for_what_was_not_measured() {
        let table = training_table(&[record("bed", Some(1.5)), record("background", None)]);
        let rows: Vec<&str> = table.lines().collect();
        assert_eq!(rows.len(), 4, "{table}");
        assert!(
            rows[2].starts_with(
                "| bedroom bed | `neuroom bench train rooms/bedroom bed --steps 100` | 100 × 512 \
                 | 12 s (2) | 30.12 dB | 0.46 mm | 1.50 mm |"
            ),
            "{}",
            rows[2]
        );
        assert!(rows[3].contains("| 0.46 mm | — |"), "{}", rows[3]);
    }

    #[test]
    fn a_training_record_survives_a_round_trip_and_a_locate_record_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.json");
        let mut original = record("bed", Some(1.5));
        original.relabel("the bed".into());
        original.write(&path).unwrap();
        assert_eq!(TrainingFigureRecord::read(&path).unwrap(), original);
        let locate = crate::figures::FigureRecord::measured_now(
            "demo",
            "neuroom demo".into(),
            crate::figures::LocateFigures::default(),
        );
        locate.write(&path).unwrap();
        let error = format!("{:#}", TrainingFigureRecord::read(&path).unwrap_err());
        assert!(error.contains("t.json"), "{error}");
    }
}
