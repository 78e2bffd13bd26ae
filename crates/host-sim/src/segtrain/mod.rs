//! Training and scoring the library's reference floor model
//! (`ego_ekf::surface::floor_model`) on floor photographs seen through the
//! simulated forward camera: [`views`] renders labelled views from the
//! training or the held-out photographs, [`train`] fits the perceptron,
//! [`eval`] counts the confusion matrix, [`codegen`] writes the weights as
//! the library's `weights.rs`.

pub mod codegen;
pub mod eval;
pub mod train;
pub mod views;

use eval::{Confusion, score};
use traction::ego_ekf::surface::floor_model::{FloorModel, MlpWeights};
use train::{TrainConfig, sample_cells, train};

/// What a training run gives.
pub struct Trained {
    /// The weights.
    pub weights: MlpWeights,
    /// Training samples used.
    pub samples: usize,
    /// The trained model on the training views.
    pub train: Confusion,
    /// The trained model on the held-out views.
    pub held_out: Confusion,
}

/// Renders the views of `cfg`, trains, and scores on both splits.
pub fn run(cfg: &TrainConfig) -> Trained {
    use rand::SeedableRng;
    let train_views = views::views(false, cfg.train_views, cfg.seed);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(cfg.seed ^ 0x5a4d);
    let samples = sample_cells(&train_views, cfg.cells_per_view, &mut rng);
    let weights = train(&samples, cfg);
    let mut model = FloorModel::with_weights(weights);
    let held = views::views(true, cfg.eval_views, cfg.seed ^ 0xe7a1);
    Trained {
        weights,
        samples: samples.y.len(),
        train: score(&mut model, &train_views),
        held_out: score(&mut model, &held),
    }
}

/// The shipped reference weights scored on the held-out views of `cfg`.
pub fn score_reference(cfg: &TrainConfig) -> Confusion {
    let held = views::views(true, cfg.eval_views, cfg.seed ^ 0xe7a1);
    score(&mut FloorModel::reference(), &held)
}
