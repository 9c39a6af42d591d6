//! `neuroom train ROOM --out MODELS`: the offline stage.

use std::path::PathBuf;

use super::frame_corrections_arg::FrameCorrectionsArg;
use super::mlp_precision_arg::MlpPrecisionArg;
use neuroom::train::{TrainBar, TrainOptions};

/// Learn the neural models of a room (background and every object) from its captures.
///
/// Interrupt it any time: running it again resumes from the last checkpoint, and finished models are kept.
/// Example: `neuroom train rooms/bedroom --out models`
#[derive(clap::Args)]
pub struct Args {
    /// Room folder (holding room.json).
    room: PathBuf,
    /// Folder that receives `<room name>/` with one model per object capture and the background.
    #[arg(long)]
    out: PathBuf,
    /// Optimisation steps per object model (default 2000, the validation suite's budget: about 3
    /// minutes on one core while another model trains on the other); without `--object-seconds`,
    /// exactly this many, whatever the machine's load (reproducible).
    #[arg(long)]
    object_steps: Option<u64>,
    /// Optimisation steps of the background model (default 3000, the validation suite's budget:
    /// about 13 minutes on one core beside the objects); without `--background-seconds`, exactly
    /// this many.
    #[arg(long)]
    background_steps: Option<u64>,
    /// Time budget per object model, seconds, instead of steps (with `--object-steps`, whichever
    /// ends first). The models then depend on the machine's load.
    #[arg(long)]
    object_seconds: Option<f64>,
    /// Time budget of the background model, seconds, instead of steps.
    #[arg(long)]
    background_seconds: Option<f64>,
    /// Rays per step of an object model (default 2 048).
    #[arg(long, value_parser = clap::value_parser!(u32).range(16..=65_536))]
    object_batch_rays: Option<u32>,
    /// Rays per step of the background model (default 2 048).
    #[arg(long, value_parser = clap::value_parser!(u32).range(16..=65_536))]
    background_batch_rays: Option<u32>,
    /// Worker threads (0 = all cores). The models do not depend on it.
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// How many models train at once, each on its share of the threads (0 = one per thread while
    /// models are left; time budgets train one at a time). The models do not depend on it.
    #[arg(long, default_value_t = 0)]
    models_at_once: usize,
    /// Seed of sampling and initialisation.
    #[arg(long)]
    seed: Option<u64>,
    /// Count the time budgets in CPU seconds per worker thread instead of wall-clock seconds, so that
    /// other programs on a busy machine do not shrink the training.
    #[arg(long)]
    cpu_clock: bool,
    /// Time budget of the object identification network, seconds (trained after the models and the
    /// localization database; 0 = do not build it). By default it is not built: `neuroom locate`'s
    /// default detector does not use it (`--detector network` or `named` does).
    #[arg(long)]
    identify_seconds: Option<f64>,
    /// Train only this model (`background` or an object capture's name; repeat for several). Each
    /// model is an independent job: runs on other machines or processes may train the others into
    /// the same folder, and the manifest is complete once every model is there.
    #[arg(long = "only", value_name = "MODEL")]
    only: Vec<String>,
    /// Learn a colour gain and a pose correction per frame: `capture` where the capture says its
    /// camera auto-exposed or tracked its poses (a phone's), `always`, or `never`.
    #[arg(long, value_enum, default_value_t)]
    frame_corrections: FrameCorrectionsArg,
    /// Arithmetic of the networks' products: `bf16` rounds their operands to bfloat16 (sums stay
    /// `f32`) where the CPU has AVX-512 BF16, for faster steps; the model keeps it for rendering.
    #[arg(long, value_enum, default_value_t)]
    mlp_precision: MlpPrecisionArg,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    let options = TrainOptions {
        object_steps: args.object_steps,
        background_steps: args.background_steps,
        object_seconds: args.object_seconds,
        background_seconds: args.background_seconds,
        object_batch_rays: args.object_batch_rays.map(|rays| rays as usize),
        background_batch_rays: args.background_batch_rays.map(|rays| rays as usize),
        threads: args.threads,
        models_at_once: args.models_at_once,
        seed: args.seed,
        cpu_clock: args.cpu_clock,
        identify_seconds: args.identify_seconds,
        only: args.only,
        frame_corrections: args.frame_corrections.into(),
        mlp_precision: args.mlp_precision.into(),
    };
    let summary =
        neuroom::train::train_room(&args.room, &args.out, &options, &TrainBar::default())?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        println!(
            "models of `{}` in {} ({:.0} s)",
            summary.manifest.room,
            summary.dir.display(),
            summary.seconds
        );
        for m in &summary.manifest.models {
            println!("  {}", neuroom::train::describe_model(m));
        }
        if !summary.manifest.complete {
            println!("  the room's other models are not trained yet: the manifest is incomplete");
        }
        if let Some(network) = neuroom::identify::read_network(&summary.dir)? {
            println!(
                "  {:<14} {}",
                "identify",
                neuroom::train::describe_network(&network)
            );
        }
    }
    Ok(())
}
