//! Whether a model already on disk (finished, or a checkpoint to resume) was made with the budget a run
//! asks for, by training code that makes the same models. A folder of models kept from other budgets
//! or from an older build would otherwise be reused silently, and every figure measured on it would
//! describe a configuration the command did not ask for.

use crate::config::ModelBudget;
use crate::room::TrainError;
use neuroom_field::checkpoint;
use std::path::Path;

/// The revision of the training code: raised by every change that makes a run of the same
/// configuration train other bits (another order of the random draws, of a sum, another
/// initialisation). Models record the revision that trained them (`trainer.revision` in their
/// `config.json`; 0 where it is missing, the models of builds before it was recorded); a model of
/// another revision is not resumed or reused (`train_room` refuses it), and the validation suite's
/// cache keys its folders by it.
pub const TRAINING_REVISION: u32 = 0;

/// The revision of how captures that declare their depth noise (`depth_noise`, a phone's) train,
/// counted apart from [`TRAINING_REVISION`] because a change there leaves every exact-depth capture's
/// bits as they were: raised by every change that trains such a capture differently. The validation
/// suite's cache keys the folders of rooms with such captures by it, so their models train anew while
/// the rendered rooms' stay cached.
pub const NOISY_DEPTH_REVISION: u32 = 1;

/// The parts of a budget a saved model records: its hash table, finest resolution and step count,
/// and the training revision that made it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct SavedBudget {
    log2_table: u32,
    finest_resolution: usize,
    /// Steps of the schedule; `None` when the file does not say.
    steps: Option<u64>,
    /// [`TRAINING_REVISION`] of the build that trained it.
    revision: u32,
}

/// Refuses the model saved in `model_dir` (its `config.json`, or its checkpoint's) when it was trained
/// with another hash table, finest resolution or, for step budgets, another step count than `budget`
/// asks for, or by another [`TRAINING_REVISION`]; the error names the file and both values. A folder
/// without a saved model passes.
pub fn check_saved_budget(model_dir: &Path, budget: &ModelBudget) -> Result<(), TrainError> {
    for dir in [model_dir.to_path_buf(), model_dir.join("checkpoint")] {
        if !dir.join("config.json").exists() {
            continue;
        }
        let meta = checkpoint::read_meta(&dir)?;
        let saved = SavedBudget {
            log2_table: meta.field.hash.log2_table,
            finest_resolution: meta.field.hash.finest_resolution,
            steps: meta.trainer["state"]["total_steps"].as_u64(),
            revision: (meta.trainer["revision"].as_u64()).map_or(0, |r| r as u32),
        };
        if let Some(difference) = budget_difference(&saved, budget, TRAINING_REVISION) {
            return Err(TrainError::File {
                path: dir.join("config.json"),
                message: format!(
                    "trained with another budget or build ({difference}); remove the folder to \
                     train it again, or train into another folder"
                ),
            });
        }
    }
    Ok(())
}

/// What differs between a saved model's budget and `budget` trained by `revision`, as `name saved,
/// asked asked`.
fn budget_difference(saved: &SavedBudget, budget: &ModelBudget, revision: u32) -> Option<String> {
    let mut differences = Vec::new();
    if saved.revision != revision {
        differences.push(format!(
            "training revision {}, this build's {revision}",
            saved.revision
        ));
    }
    if saved.log2_table != budget.log2_table {
        differences.push(format!(
            "log2_table {}, asked {}",
            saved.log2_table, budget.log2_table
        ));
    }
    if saved.finest_resolution != budget.finest_resolution {
        differences.push(format!(
            "finest_resolution {}, asked {}",
            saved.finest_resolution, budget.finest_resolution
        ));
    }
    // A time budget fits the step count to the clock during the run, so only step budgets compare.
    let compared_steps = saved.steps.filter(|_| budget.time_budget_s.is_none());
    if let Some(steps) = compared_steps.filter(|&s| s != budget.steps) {
        differences.push(format!("steps {steps}, asked {}", budget.steps));
    }
    (!differences.is_empty()).then(|| differences.join("; "))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::TrainConfig;

    fn saved_like(budget: &ModelBudget) -> SavedBudget {
        SavedBudget {
            log2_table: budget.log2_table,
            finest_resolution: budget.finest_resolution,
            steps: Some(budget.steps),
            revision: TRAINING_REVISION,
        }
    }

    #[test]
    fn the_same_budget_passes_and_each_difference_is_named() {
        let budget = TrainConfig::default().object;
        assert_eq!(
            budget_difference(&saved_like(&budget), &budget, TRAINING_REVISION),
            None
        );
        let mut other = saved_like(&budget);
        other.log2_table -= 2;
        other.steps = Some(budget.steps + 1);
        let said = budget_difference(&other, &budget, TRAINING_REVISION).unwrap();
        assert!(
            said.contains("log2_table") && said.contains("steps"),
            "{said}"
        );
        assert!(!said.contains("finest_resolution"), "{said}");
    }

    #[test]
    fn a_model_of_another_training_revision_is_named() {
        let budget = TrainConfig::default().object;
        let saved = saved_like(&budget);
        let said = budget_difference(&saved, &budget, TRAINING_REVISION + 1).unwrap();
        assert!(said.contains("training revision"), "{said}");
    }

    #[test]
    fn a_time_budget_does_not_compare_steps() {
        let mut budget = TrainConfig::default().object;
        let mut saved = saved_like(&budget);
        saved.steps = Some(123);
        budget.time_budget_s = Some(60.0);
        assert_eq!(budget_difference(&saved, &budget, TRAINING_REVISION), None);
    }
}
