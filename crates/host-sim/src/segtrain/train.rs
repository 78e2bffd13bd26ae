//! Trains the floor model's perceptron: softmax cross-entropy, class-weighted
//! (inverse square root of each class's frequency, within 0.2-5), minibatch
//! Adam (Kingma & Ba, "Adam: a method for stochastic optimization", ICLR
//! 2015), seeded, so the same views give the same weights bit for bit.

use super::views::View;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use traction::ego_ekf::surface::floor_model::{
    CLASSES, FEATURES, HIDDEN, MlpWeights, cell_features,
};

/// How a training run samples and optimises.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrainConfig {
    /// Views rendered from the training photographs.
    pub train_views: usize,
    /// Views rendered from the held-out photographs.
    pub eval_views: usize,
    /// Cells drawn per training view (besides every wall, strip and cable cell).
    pub cells_per_view: usize,
    /// Passes over the samples.
    pub epochs: usize,
    /// Samples per Adam step.
    pub batch: usize,
    /// Adam's step size.
    pub learning_rate: f32,
    /// Seed of views, sampling and initialisation.
    pub seed: u64,
}

impl Default for TrainConfig {
    /// The configuration of the generated reference weights.
    fn default() -> Self {
        TrainConfig {
            train_views: 320,
            eval_views: 160,
            cells_per_view: 400,
            epochs: 12,
            batch: 128,
            learning_rate: 3e-3,
            seed: 0x5e9_0004,
        }
    }
}

/// Feature vectors with their class ids.
pub struct Samples {
    /// One feature vector per sample.
    pub x: Vec<[f32; FEATURES]>,
    /// The class id of each.
    pub y: Vec<u8>,
}

/// Draws cells from `views`: `per_view` at random and every cell whose class
/// is not one of the four floors (rare classes are all kept).
pub fn sample_cells(views: &[View], per_view: usize, rng: &mut ChaCha8Rng) -> Samples {
    let mut s = Samples {
        x: Vec::new(),
        y: Vec::new(),
    };
    for v in views {
        let Ok(img) = v.image.view() else { continue };
        let (w, h) = (v.labels.width, v.labels.height);
        let mut take = |i: usize| {
            let (cx, cy) = (i % w, i / w);
            s.x.push(cell_features(&img, cx, cy));
            s.y.push(v.labels.data[i]);
        };
        for _ in 0..per_view {
            take(rng.random_range(0..w * h));
        }
        for i in 0..w * h {
            if !(2..=5).contains(&v.labels.data[i]) {
                take(i);
            }
        }
    }
    s
}

/// Trains on `samples`.
pub fn train(samples: &Samples, cfg: &TrainConfig) -> MlpWeights {
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed ^ 0x7261_696e);
    let n = samples.x.len().max(1) as f64;
    let mut mean = [0.0f32; FEATURES];
    let mut scale = [1.0f32; FEATURES];
    for j in 0..FEATURES {
        let m = samples.x.iter().map(|f| f64::from(f[j])).sum::<f64>() / n;
        let var = samples
            .x
            .iter()
            .map(|f| (f64::from(f[j]) - m).powi(2))
            .sum::<f64>()
            / n;
        mean[j] = m as f32;
        scale[j] = if var > 1e-12 {
            (1.0 / var.sqrt()) as f32
        } else {
            1.0
        };
    }
    let mut counts = [0usize; CLASSES];
    for &c in &samples.y {
        counts[usize::from(c).min(CLASSES - 1)] += 1;
    }
    let class_weight: [f32; CLASSES] = std::array::from_fn(|k| {
        if counts[k] == 0 {
            0.0
        } else {
            ((n / (CLASSES as f64 * counts[k] as f64)).sqrt() as f32).clamp(0.2, 5.0)
        }
    });
    let mut init = |fan_in: usize| {
        let a = (6.0 / fan_in as f32).sqrt();
        rng.random_range(-a..a)
    };
    let mut w = MlpWeights {
        mean,
        scale,
        w1: [[0.0; FEATURES]; HIDDEN],
        b1: [0.0; HIDDEN],
        w2: [[0.0; HIDDEN]; CLASSES],
        b2: [0.0; CLASSES],
    };
    for row in &mut w.w1 {
        for v in row.iter_mut() {
            *v = init(FEATURES);
        }
    }
    for row in &mut w.w2 {
        for v in row.iter_mut() {
            *v = init(HIDDEN);
        }
    }
    let mut adam = Adam::new(cfg.learning_rate);
    let mut order: Vec<usize> = (0..samples.x.len()).collect();
    for epoch in 0..cfg.epochs {
        order.shuffle(&mut rng);
        adam.rate = cfg.learning_rate * 0.5f32.powf(epoch as f32 / 4.0);
        for chunk in order.chunks(cfg.batch.max(1)) {
            let mut g = Grad::default();
            for &i in chunk {
                g.add(&w, &samples.x[i], samples.y[i], &class_weight);
            }
            adam.step(&mut w, &g, 1.0 / chunk.len() as f32);
        }
    }
    w
}

/// Summed gradients of a minibatch.
struct Grad {
    w1: [[f32; FEATURES]; HIDDEN],
    b1: [f32; HIDDEN],
    w2: [[f32; HIDDEN]; CLASSES],
    b2: [f32; CLASSES],
}

impl Default for Grad {
    fn default() -> Self {
        Grad {
            w1: [[0.0; FEATURES]; HIDDEN],
            b1: [0.0; HIDDEN],
            w2: [[0.0; HIDDEN]; CLASSES],
            b2: [0.0; CLASSES],
        }
    }
}

impl Grad {
    #[allow(clippy::needless_range_loop)] // the backward pass indexes several arrays in step
    fn add(&mut self, w: &MlpWeights, f: &[f32; FEATURES], y: u8, cw: &[f32; CLASSES]) {
        let x: [f32; FEATURES] = std::array::from_fn(|j| (f[j] - w.mean[j]) * w.scale[j]);
        let pre: [f32; HIDDEN] = std::array::from_fn(|h| {
            w.w1[h].iter().zip(&x).map(|(a, b)| a * b).sum::<f32>() + w.b1[h]
        });
        let hid = pre.map(|a| a.max(0.0));
        let out: [f32; CLASSES] = std::array::from_fn(|k| {
            w.w2[k].iter().zip(&hid).map(|(a, b)| a * b).sum::<f32>() + w.b2[k]
        });
        let top = out.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        let e = out.map(|o| (o - top).exp());
        let z: f32 = e.iter().sum();
        let y = usize::from(y).min(CLASSES - 1);
        let weight = cw[y];
        let mut d_hid = [0.0f32; HIDDEN];
        for k in 0..CLASSES {
            let d = weight * (e[k] / z - if k == y { 1.0 } else { 0.0 });
            self.b2[k] += d;
            for h in 0..HIDDEN {
                self.w2[k][h] += d * hid[h];
                d_hid[h] += d * w.w2[k][h];
            }
        }
        for h in 0..HIDDEN {
            if pre[h] <= 0.0 {
                continue;
            }
            self.b1[h] += d_hid[h];
            for j in 0..FEATURES {
                self.w1[h][j] += d_hid[h] * x[j];
            }
        }
    }
}

/// Adam's moment estimates, flattened in the order of [`params`].
struct Adam {
    rate: f32,
    t: i32,
    m: Vec<f32>,
    v: Vec<f32>,
}

fn params(w: &mut MlpWeights) -> Vec<&mut f32> {
    let mut p: Vec<&mut f32> = Vec::new();
    p.extend(w.w1.iter_mut().flatten());
    p.extend(w.b1.iter_mut());
    p.extend(w.w2.iter_mut().flatten());
    p.extend(w.b2.iter_mut());
    p
}

fn grads(g: &Grad) -> Vec<f32> {
    let mut v: Vec<f32> = Vec::new();
    v.extend(g.w1.iter().flatten());
    v.extend(g.b1.iter());
    v.extend(g.w2.iter().flatten());
    v.extend(g.b2.iter());
    v
}

impl Adam {
    fn new(rate: f32) -> Self {
        let n = HIDDEN * FEATURES + HIDDEN + CLASSES * HIDDEN + CLASSES;
        Adam {
            rate,
            t: 0,
            m: vec![0.0; n],
            v: vec![0.0; n],
        }
    }

    fn step(&mut self, w: &mut MlpWeights, g: &Grad, norm: f32) {
        const B1: f32 = 0.9;
        const B2: f32 = 0.999;
        self.t += 1;
        let (c1, c2) = (1.0 - B1.powi(self.t), 1.0 - B2.powi(self.t));
        for (((p, gi), m), v) in params(w)
            .into_iter()
            .zip(grads(g))
            .zip(&mut self.m)
            .zip(&mut self.v)
        {
            let gi = gi * norm;
            *m = B1 * *m + (1.0 - B1) * gi;
            *v = B2 * *v + (1.0 - B2) * gi * gi;
            *p -= self.rate * (*m / c1) / ((*v / c2).sqrt() + 1e-8);
        }
    }
}
