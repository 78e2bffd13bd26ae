//! Scores a segmenter against true label maps: the per-pixel confusion
//! matrix, overall accuracy and the accuracy on ground pixels (the four
//! floors and threshold strips, the pixels the surface model reads).

use super::views::View;
use traction::ego_ekf::surface::floor_model::{CLASS_NAMES, CLASSES};
use traction::vslam_core::segment::Segmenter;

/// Counts of (true class, predicted class) over map pixels.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Confusion {
    /// `counts[true][predicted]`.
    pub counts: [[u64; CLASSES]; CLASSES],
    /// Maps the model refused (image size or buffer).
    pub refused: u64,
}

impl Confusion {
    /// Adds one map against its truth; a map of another size is refused.
    pub fn add(&mut self, truth: &[u8], predicted: &[u8]) {
        if truth.len() != predicted.len() {
            self.refused += 1;
            return;
        }
        for (t, p) in truth.iter().zip(predicted) {
            let (t, p) = (usize::from(*t), usize::from(*p));
            if t < CLASSES && p < CLASSES {
                self.counts[t][p] += 1;
            }
        }
    }

    /// Right / all over the true classes `of`.
    pub fn accuracy_of(&self, of: &[usize]) -> f64 {
        let (mut right, mut all) = (0u64, 0u64);
        for &t in of {
            if let Some(row) = self.counts.get(t) {
                all += row.iter().sum::<u64>();
                right += row.get(t).copied().unwrap_or(0);
            }
        }
        if all == 0 {
            0.0
        } else {
            right as f64 / all as f64
        }
    }

    /// Accuracy over every pixel.
    pub fn accuracy(&self) -> f64 {
        self.accuracy_of(&(0..CLASSES).collect::<Vec<_>>())
    }

    /// Accuracy over ground pixels (classes 2-6).
    pub fn ground_accuracy(&self) -> f64 {
        self.accuracy_of(&[2, 3, 4, 5, 6])
    }

    /// The matrix as a Markdown table, rows true, columns predicted, with
    /// each row's recall.
    pub fn markdown(&self) -> String {
        let mut s = String::from("| true \\ predicted |");
        for n in CLASS_NAMES {
            s.push_str(&format!(" {n} |"));
        }
        s.push_str(" recall |\n|---|");
        s.push_str(&"---:|".repeat(CLASSES + 1));
        s.push('\n');
        for (t, row) in self.counts.iter().enumerate() {
            s.push_str(&format!("| {} |", CLASS_NAMES[t]));
            for c in row {
                s.push_str(&format!(" {c} |"));
            }
            let all: u64 = row.iter().sum();
            if all == 0 {
                s.push_str(" - |\n");
            } else {
                s.push_str(&format!(" {:.1} % |\n", 100.0 * row[t] as f64 / all as f64));
            }
        }
        s
    }
}

/// Runs `model` on every view and counts against the true labels.
pub fn score(model: &mut impl Segmenter, views: &[View]) -> Confusion {
    let mut c = Confusion::default();
    for v in views {
        let mut out = vec![0u8; v.labels.data.len()];
        match v.image.view() {
            Ok(img) if model.segment(&img, &mut out).is_ok() => c.add(&v.labels.data, &out),
            _ => c.refused += 1,
        }
    }
    c
}
