//! `host-sim train-segmenter`: trains the library's reference floor model on
//! the training floor photographs, writes its weights as Rust source and
//! prints the confusion matrices on the training and held-out views
//! (`--check` scores the shipped weights instead, without training).

use super::write_stdout;
use crate::error::CliError;
use crate::segtrain::eval::Confusion;
use crate::segtrain::train::TrainConfig;
use crate::segtrain::{codegen, run, score_reference};
use clap::Args;
use std::path::PathBuf;

/// Arguments of `host-sim train-segmenter`.
#[derive(Debug, Args)]
#[command(
    about = "Train the reference floor segmenter and print its held-out confusion matrix",
    long_about = "Renders forward-camera views (cam1, 160x120) of the training floor photographs \
                  (data/floors, CC0), trains the floor model's perceptron on per-cell texture \
                  features, writes the weights as the Rust source of \
                  crates/ego-ekf/src/surface/floor_model/weights.rs (--out), and prints per-pixel \
                  accuracy and the confusion matrix on views of the held-out photographs. \
                  Deterministic: the same inputs give the same file."
)]
pub struct TrainSegmenterArgs {
    /// Write the generated weights here.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Score the shipped reference weights on the held-out views; no training.
    #[arg(long)]
    pub check: bool,
}

fn section(s: &mut String, name: &str, c: &Confusion) {
    outln!(
        s,
        "{name}: accuracy {:.1} % of pixels, {:.1} % of ground pixels (floors and strips)\n",
        100.0 * c.accuracy(),
        100.0 * c.ground_accuracy()
    );
    s.push_str(&c.markdown());
    s.push('\n');
}

/// Runs `train-segmenter`.
pub fn run_cmd(a: TrainSegmenterArgs) -> Result<(), CliError> {
    let cfg = TrainConfig::default();
    let mut s = String::new();
    if a.check {
        section(
            &mut s,
            "held-out views, shipped weights",
            &score_reference(&cfg),
        );
        return write_stdout(&s);
    }
    let t = run(&cfg);
    if let Some(path) = &a.out {
        std::fs::write(path, codegen::weights_source(&t.weights))
            .map_err(|e| CliError::file(path, format!("cannot write: {e}")))?;
    }
    outln!(
        s,
        "{} training samples from {} views; {} held-out views\n",
        t.samples,
        cfg.train_views,
        cfg.eval_views
    );
    section(&mut s, "training views", &t.train);
    section(&mut s, "held-out views", &t.held_out);
    write_stdout(&s)
}
