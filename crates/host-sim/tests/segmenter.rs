//! The reference floor model: its generated weights are what the training
//! script produces today, and they label floors far better than chance.

use host_sim::segtrain::eval::score;
use host_sim::segtrain::train::TrainConfig;
use host_sim::segtrain::{codegen, run, views};
use traction::ego_ekf::surface::floor_model::FloorModel;

#[test]
fn generated_weights_are_up_to_date() {
    let t = run(&TrainConfig::default());
    let shipped = include_str!("../../ego-ekf/src/surface/floor_model/weights.rs");
    assert!(
        codegen::weights_source(&t.weights) == shipped,
        "weights.rs is stale: run `cargo run --release -p host-sim -- train-segmenter \
         --out crates/ego-ekf/src/surface/floor_model/weights.rs`"
    );
}

#[test]
fn reference_model_labels_training_floors_well_above_chance() {
    // Fresh views (another seed) of the training photographs: a model that
    // learned nothing labels every cell alike, 1 in 5 ground classes at best.
    let v = views::views(false, 24, 0xfeed);
    let c = score(&mut FloorModel::reference(), &v);
    assert_eq!(c.refused, 0);
    assert!(c.ground_accuracy() > 0.6, "{}", c.markdown());
    // Threshold strips and cables are told apart from the floor.
    assert!(c.accuracy_of(&[6]) > 0.8, "{}", c.markdown());
    assert!(c.accuracy_of(&[0]) > 0.6, "{}", c.markdown());
}
