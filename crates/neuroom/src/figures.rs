//! Figures as artefacts. Every figure the README's results table shows is a [`FigureRecord`], a JSON
//! file under `bench/figures/` written by the benchmark that measured it (`--record FILE`), with the
//! command that reproduces it. [`results_table`] turns the records into the table and [`replace_table`]
//! puts it into the README between two markers, so no figure in the table is typed by hand; a test
//! checks the README's table against the records.

use std::path::{Path, PathBuf};

use anyhow::Context;
use serde::{Deserialize, Serialize};

use crate::eval::Evaluation;
use crate::locate::LocateMean;

/// The `format` of a figure record.
pub const FIGURES_FORMAT: &str = "neuroom.figures/1";

/// The two lines of the README between which a generated table stands.
#[derive(Clone, Copy, Debug)]
pub struct TableMarkers {
    /// The line before the table.
    pub begin: &'static str,
    /// The line after it.
    pub end: &'static str,
}

/// Where the results table stands in the README.
pub const RESULTS_TABLE: TableMarkers = TableMarkers {
    begin: "<!-- figures: generated from bench/figures/*.json by `neuroom bench table --readme README.md` -->",
    end: "<!-- end of figures -->",
};

/// A figure record as the benchmarks write it: `--label` may rename it before it is written.
pub trait Record {
    /// Replaces the row's label.
    fn relabel(&mut self, label: String);
    /// Writes the record as pretty JSON, atomically.
    fn write(&self, path: &Path) -> anyhow::Result<()>;
}

/// The localization figures of one row: means over the panoramas located.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LocateFigures {
    /// Panoramas located (0 for figures quoted from elsewhere).
    pub panoramas: usize,
    /// Mean 3D IoU, percent (a missed object counts 0).
    pub iou_percent: f64,
    /// Mean rotation error of the found objects, degrees.
    pub are_deg: f64,
    /// The same up to each shape's symmetry, degrees.
    pub are_up_to_symmetry_deg: Option<f64>,
    /// Mean position error of the found objects, cm.
    pub ape_cm: f64,
    /// Identification precision.
    pub precision: f64,
    /// Identification recall.
    pub recall: f64,
    /// Share of the true objects placed within 20 cm of where they stand.
    pub placed_share: Option<f64>,
    /// Mean camera position error, cm.
    pub camera_position_error_cm: Option<f64>,
    /// Mean camera rotation error, degrees.
    pub camera_rotation_error_deg: Option<f64>,
    /// Mean seconds per panorama (depends on the machine and its load; not compared).
    pub seconds_per_panorama: Option<f64>,
}

impl LocateFigures {
    /// The figures of `neuroom bench locate`'s mean.
    pub fn from_locate_mean(mean: &LocateMean) -> Self {
        Self {
            panoramas: mean.panoramas,
            iou_percent: mean.iou_percent,
            are_deg: mean.are_deg,
            are_up_to_symmetry_deg: Some(mean.are_up_to_symmetry_deg),
            ape_cm: mean.ape_cm,
            precision: mean.precision,
            recall: mean.recall,
            placed_share: Some(mean.placed_share),
            camera_position_error_cm: Some(mean.camera_position_error_cm),
            camera_rotation_error_deg: Some(mean.camera_rotation_error_deg),
            seconds_per_panorama: Some(mean.seconds),
        }
    }

    /// The figures of `neuroom eval` (and the demo's evaluation).
    pub fn from_evaluation(evaluation: &Evaluation) -> Self {
        let mean = &evaluation.mean;
        let rows = evaluation.rows.len().max(1) as f64;
        let placed = evaluation
            .rows
            .iter()
            .map(|r| r.objects.placed_share)
            .sum::<f64>();
        Self {
            panoramas: mean.arrangements,
            iou_percent: mean.iou_percent,
            are_deg: mean.are_deg.unwrap_or(f64::NAN),
            are_up_to_symmetry_deg: mean.are_up_to_symmetry_deg,
            ape_cm: mean.ape_cm.unwrap_or(f64::NAN),
            precision: mean.precision,
            recall: mean.recall,
            placed_share: Some(placed / rows),
            camera_position_error_cm: Some(mean.camera_position_error_cm),
            camera_rotation_error_deg: Some(mean.camera_rotation_error_deg),
            seconds_per_panorama: None,
        }
    }
}

/// The training figures of one model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelFigures {
    /// The model's name (`background` or an object capture's).
    pub name: String,
    /// Optimisation steps it trained.
    pub steps: u64,
    /// Held-out PSNR, dB.
    pub psnr_db: Option<f64>,
    /// Chamfer distance to the ground-truth mesh, mm.
    pub chamfer_mm: Option<f64>,
}

/// The worst room of a suite.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WorstRoom {
    /// The room's name.
    pub room: String,
    /// Its figures.
    pub figures: LocateFigures,
}

/// One row of the results table, as a benchmark recorded it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FigureRecord {
    /// [`FIGURES_FORMAT`].
    pub format: String,
    /// What was measured, as the table's first column shows it.
    pub label: String,
    /// The command that measured it, as typed (`None` for figures quoted from elsewhere).
    pub command: Option<String>,
    /// Where figures quoted from elsewhere come from (the paper).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
    /// The date of the measurement (UTC, `YYYY-MM-DD`).
    pub measured: Option<String>,
    /// The localization figures.
    pub figures: LocateFigures,
    /// A suite's worst room.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub worst_room: Option<WorstRoom>,
    /// The trained models' figures, where the benchmark trained them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub models: Vec<ModelFigures>,
}

impl FigureRecord {
    /// A record of figures measured now by `command`.
    pub fn measured_now(label: &str, command: String, figures: LocateFigures) -> Self {
        Self {
            format: FIGURES_FORMAT.into(),
            label: label.into(),
            command: Some(command),
            source: None,
            measured: Some(jiff::Timestamp::now().strftime("%Y-%m-%d").to_string()),
            figures,
            worst_room: None,
            models: Vec::new(),
        }
    }

    /// Reads a record, naming the file when it is not one.
    pub fn read(path: &Path) -> anyhow::Result<Self> {
        let record: Self = read_json(path, "figure record")?;
        check_format(path, &record.format, FIGURES_FORMAT)?;
        Ok(record)
    }
}

impl Record for FigureRecord {
    fn relabel(&mut self, label: String) {
        self.label = label;
    }

    fn write(&self, path: &Path) -> anyhow::Result<()> {
        write_json(path, self, "figure record")
    }
}

/// Writes `value` as pretty JSON to `path`, atomically; `what` names it in an error.
pub(crate) fn write_json<T: Serialize>(path: &Path, value: &T, what: &str) -> anyhow::Result<()> {
    let mut text = serde_json::to_string_pretty(value)?;
    text.push('\n');
    neuroom_core::formats::atomic_write(path, text.as_bytes())
        .with_context(|| format!("{}: cannot write the {what}", path.display()))
}

/// Reads `path` as JSON of `T`, naming the file (and `what` it should be) when it is not.
pub(crate) fn read_json<T: serde::de::DeserializeOwned>(
    path: &Path,
    what: &str,
) -> anyhow::Result<T> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{}: not a {what}", path.display()))
}

/// Fails, naming the file, when a record's `format` is not `expected`.
pub(crate) fn check_format(path: &Path, format: &str, expected: &str) -> anyhow::Result<()> {
    anyhow::ensure!(
        format == expected,
        "{}: format `{format}`, expected `{expected}`",
        path.display()
    );
    Ok(())
}

/// The command line of this process as a user would type it: `neuroom` and its arguments, quoted for
/// a POSIX shell where needed.
pub fn invocation() -> String {
    std::iter::once("neuroom".to_string())
        .chain(std::env::args().skip(1).map(|a| shell_quote(&a)))
        .collect::<Vec<_>>()
        .join(" ")
}

fn shell_quote(arg: &str) -> String {
    let plain = |c: char| c.is_ascii_alphanumeric() || "-_./=,:@+".contains(c);
    if !arg.is_empty() && arg.chars().all(plain) {
        arg.to_string()
    } else {
        format!("'{}'", arg.replace('\'', r"'\''"))
    }
}

/// The records in `dir` (`*.json`), in file-name order.
pub fn read_records(dir: &Path) -> anyhow::Result<Vec<FigureRecord>> {
    record_paths(dir)?
        .iter()
        .map(|p| FigureRecord::read(p))
        .collect()
}

/// The `*.json` files in `dir`, in file-name order; at least one.
pub(crate) fn record_paths(dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let entries =
        std::fs::read_dir(dir).with_context(|| format!("{}: cannot list", dir.display()))?;
    let mut paths: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    anyhow::ensure!(!paths.is_empty(), "{}: no figure records", dir.display());
    paths.sort();
    Ok(paths)
}

/// The results table of `records`, as Markdown: one row per record, and one more for a suite's worst
/// room.
pub fn results_table(records: &[FigureRecord]) -> String {
    let mut lines = vec![
        "| | command | IoU | ARE (up to symmetry) | APE | placed within 20 cm | precision / recall | camera | measured |".to_string(),
        "|---|---|---|---|---|---|---|---|---|".to_string(),
    ];
    for record in records {
        let origin = match (&record.command, &record.source) {
            (Some(command), _) => format!("`{command}`"),
            (None, Some(source)) => source.clone(),
            (None, None) => String::new(),
        };
        let date = record.measured.clone().unwrap_or_default();
        lines.push(table_row(&record.label, &origin, &record.figures, &date));
        if let Some(worst) = &record.worst_room {
            let label = format!("{}: worst room ({})", record.label, worst.room);
            lines.push(table_row(&label, "", &worst.figures, &date));
        }
    }
    lines.join("\n") + "\n"
}

fn table_row(label: &str, origin: &str, f: &LocateFigures, date: &str) -> String {
    let are = match f.are_up_to_symmetry_deg {
        Some(sym) => format!("{:.1}° ({sym:.1}°)", f.are_deg),
        None => format!("{:.1}°", f.are_deg),
    };
    let placed = f
        .placed_share
        .map_or("—".into(), |s| format!("{:.0} %", 100.0 * s));
    let camera = match (f.camera_position_error_cm, f.camera_rotation_error_deg) {
        (Some(cm), Some(deg)) => format!("{cm:.1} cm, {deg:.2}°"),
        _ => "—".into(),
    };
    format!(
        "| {label} | {origin} | {:.1} % | {are} | {:.1} cm | {placed} | {:.2} / {:.2} | {camera} | {date} |",
        f.iou_percent, f.ape_cm, f.precision, f.recall
    )
}

/// `readme` with the text between the two `markers` replaced by `table`.
pub fn replace_table(readme: &str, markers: &TableMarkers, table: &str) -> anyhow::Result<String> {
    let (begin, end) = (markers.begin, markers.end);
    let (before, rest) = readme
        .split_once(begin)
        .with_context(|| format!("no line `{begin}` to put the table after"))?;
    let (_, after) = rest
        .split_once(end)
        .with_context(|| format!("no line `{end}` after `{begin}`"))?;
    Ok(format!("{before}{begin}\n{table}{end}{after}"))
}

/// Puts each table between its markers into the README at `path` (see [`replace_table`]) and says
/// whether that changed it; with `write` false it only says so, changing nothing.
pub fn update_readme(
    path: &Path,
    tables: &[(TableMarkers, String)],
    write: bool,
) -> anyhow::Result<bool> {
    let readme = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let mut updated = readme.clone();
    for (markers, table) in tables {
        updated = replace_table(&updated, markers, table)
            .with_context(|| format!("{}", path.display()))?;
    }
    let changed = updated != readme;
    if changed && write {
        neuroom_core::formats::atomic_write(path, updated.as_bytes())?;
    }
    Ok(changed)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(label: &str, iou: f64) -> FigureRecord {
        FigureRecord {
            command: Some("neuroom bench locate a b".into()),
            measured: Some("2026-11-28".into()),
            ..FigureRecord::measured_now(
                label,
                String::new(),
                LocateFigures {
                    iou_percent: iou,
                    precision: 1.0,
                    recall: 0.5,
                    ..LocateFigures::default()
                },
            )
        }
    }

    #[test]
    fn the_table_has_a_row_per_record_and_one_for_the_worst_room() {
        let mut suite = record("suite", 60.0);
        suite.worst_room = Some(WorstRoom {
            room: "attic".into(),
            figures: LocateFigures {
                iou_percent: 40.0,
                ..LocateFigures::default()
            },
        });
        let table = results_table(&[record("demo", 74.0), suite]);
        let rows: Vec<&str> = table.lines().collect();
        assert_eq!(rows.len(), 5, "{table}");
        assert!(rows[2].starts_with("| demo | `neuroom bench locate a b` | 74.0 % |"));
        assert!(rows[2].contains("| 1.00 / 0.50 |"));
        assert!(rows[4].starts_with("| suite: worst room (attic) |  | 40.0 % |"));
    }

    #[test]
    fn the_table_replaces_only_the_text_between_the_markers() {
        let TableMarkers { begin, end } = RESULTS_TABLE;
        let readme = format!("intro\n{begin}\nold table\n{end}\nafter\n");
        let replaced = replace_table(&readme, &RESULTS_TABLE, "new table\n").unwrap();
        assert_eq!(
            replaced,
            format!("intro\n{begin}\nnew table\n{end}\nafter\n")
        );
        assert!(replace_table("no markers", &RESULTS_TABLE, "t").is_err());
    }

    #[test]
    fn arguments_are_quoted_for_a_shell_only_where_needed() {
        assert_eq!(shell_quote("rooms/bedroom"), "rooms/bedroom");
        assert_eq!(shell_quote("a b"), "'a b'");
        assert_eq!(shell_quote("it's"), r"'it'\''s'");
        assert_eq!(shell_quote(""), "''");
    }

    #[test]
    fn a_record_survives_a_round_trip_and_a_wrong_format_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.json");
        let original = record("demo", 74.0);
        original.write(&path).unwrap();
        assert_eq!(FigureRecord::read(&path).unwrap(), original);
        std::fs::write(&path, r#"{"format": "other"}"#).unwrap();
        let error = format!("{:#}", FigureRecord::read(&path).unwrap_err());
        assert!(error.contains("r.json"), "{error}");
    }
}
