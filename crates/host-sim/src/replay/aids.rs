//! Innovation and NIS statistics per aiding source over a replay, from the
//! filter's status records ([`traction::ego_ekf::aid_status`]): report.json
//! `aids`.
//!
//! For a consistent filter each component's normalised innovation squared
//! `nu^2 / S` has mean 1 (chi-square, 1 degree of freedom; Bar-Shalom, Li,
//! Kirubarajan, *Estimation with Applications to Tracking and Navigation*,
//! 2001, ch. 5.4), and the statistic an aid gates on has the mean of its
//! degrees of freedom: 9 for the zero-velocity update (velocity, position
//! and attitude against the clone), 2 for the flow, 1 for the floor (its
//! climb row). The wheels gate their forward and differential rows each on
//! its own (1 degree of freedom each) and record the larger: their
//! component means are the ones to read.

use serde_json::{Value, json};
use traction::ego_ekf::EgoEkf;
use traction::ego_ekf::aid_status::{AidOutcome, AidStatus, WheelStatus};
use traction::vslam_core::Timestamp;

/// Running sums of one aid's records.
#[derive(Clone, Debug)]
pub struct AidSums<const N: usize> {
    seen: u32,
    last_t: Option<Timestamp>,
    records: u32,
    fused: u32,
    gated: u32,
    reset: u32,
    rejected: u32,
    nis_n: u32,
    nis_sum: f64,
    comp_n: [u32; N],
    innovation_sum: [f64; N],
    innovation_sq: [f64; N],
    nis_comp_sum: [f64; N],
    var_sum: [f64; N],
}

impl<const N: usize> Default for AidSums<N> {
    fn default() -> Self {
        AidSums {
            seen: 0,
            last_t: None,
            records: 0,
            fused: 0,
            gated: 0,
            reset: 0,
            rejected: 0,
            nis_n: 0,
            nis_sum: 0.0,
            comp_n: [0; N],
            innovation_sum: [0.0; N],
            innovation_sq: [0.0; N],
            nis_comp_sum: [0.0; N],
            var_sum: [0.0; N],
        }
    }
}

impl<const N: usize> AidSums<N> {
    /// Takes `status` if the aid's count of samples `seen` grew since the
    /// last call and the record is of a new time; returns whether it did.
    fn take(&mut self, seen: u32, status: Option<&AidStatus<N>>) -> bool {
        let grew = seen > self.seen;
        self.seen = seen;
        let Some(s) = status.filter(|s| grew && Some(s.t) != self.last_t) else {
            return false;
        };
        self.last_t = Some(s.t);
        self.records += 1;
        match s.outcome {
            AidOutcome::Fused => self.fused += 1,
            AidOutcome::Gated => self.gated += 1,
            AidOutcome::Reset => self.reset += 1,
            AidOutcome::Rejected(_) => self.rejected += 1,
        }
        if s.nis.is_finite() {
            self.nis_n += 1;
            self.nis_sum += f64::from(s.nis);
        }
        for i in 0..N {
            let (nu, var) = (s.innovation[i], s.innovation_var[i]);
            if nu.is_finite() && var.is_finite() && var > 0.0 {
                let nu = f64::from(nu);
                self.comp_n[i] += 1;
                self.innovation_sum[i] += nu;
                self.innovation_sq[i] += nu * nu;
                self.nis_comp_sum[i] += nu * nu / f64::from(var);
                self.var_sum[i] += f64::from(var);
            }
        }
        true
    }

    /// The report entry: counts, the gated fraction of the records that
    /// formed a statistic, the mean statistic against `dof`, and per
    /// component (named by `names`) the innovation's mean and RMS and the
    /// mean 1-DOF NIS and predicted innovation variance (`H P H^T + R`).
    fn to_json(&self, dof: Option<u32>, names: [&str; N]) -> Value {
        let mean = |s: f64, n: u32| (n > 0).then(|| s / f64::from(n));
        let components: Vec<Value> = (0..N)
            .filter(|&i| self.comp_n[i] > 0)
            .map(|i| {
                let n = self.comp_n[i];
                json!({
                    "name": names[i],
                    "n": n,
                    "innovation_mean": mean(self.innovation_sum[i], n),
                    "innovation_rms": mean(self.innovation_sq[i], n).map(f64::sqrt),
                    "nis_mean": mean(self.nis_comp_sum[i], n),
                    "innovation_var_mean": mean(self.var_sum[i], n),
                })
            })
            .collect();
        json!({
            "records": self.records,
            "fused": self.fused,
            "gated": self.gated,
            "reset": self.reset,
            "rejected": self.rejected,
            "gated_fraction": (self.nis_n > 0).then(|| f64::from(self.gated) / f64::from(self.nis_n)),
            "nis_mean": mean(self.nis_sum, self.nis_n),
            "nis_dof": dof,
            "components": components,
        })
    }
}

/// The statistics of every aid over a run, and the wheels' records.
#[derive(Clone, Debug, Default)]
pub struct AidStats {
    /// Wheels: forward speed and differential rows.
    pub wheel: AidSums<2>,
    /// Optical flow: robot-frame horizontal velocity.
    pub flow: AidSums<2>,
    /// Zero-velocity update.
    pub zupt: AidSums<9>,
    /// Floor constraint: height and climb rows.
    pub floor: AidSums<2>,
    /// Camera frame pairs: rotation then translation rows.
    pub camera: AidSums<6>,
    /// Every wheel status record taken, in order.
    pub wheel_records: Vec<WheelStatus>,
}

impl AidStats {
    /// Takes the records the filter wrote since the last call.
    pub fn observe(&mut self, ekf: &EgoEkf) {
        if self
            .wheel
            .take(ekf.wheel_counts().seen(), ekf.wheel_status())
            && let Some(s) = ekf.wheel_status()
        {
            self.wheel_records.push(*s);
        }
        self.flow.take(ekf.flow_counts().seen(), ekf.flow_status());
        self.zupt.take(ekf.zupt_counts().seen(), ekf.zupt_status());
        self.floor
            .take(ekf.floor_counts().seen(), ekf.floor_status());
        self.camera
            .take(ekf.camera_counts().seen(), ekf.camera_status());
    }

    /// report.json `aids`.
    pub fn to_json(&self) -> Value {
        json!({
            "wheel": self.wheel.to_json(None, ["forward", "differential"]),
            "flow": self.flow.to_json(Some(2), ["vx", "vy"]),
            "zupt": self.zupt.to_json(Some(9), [
                "vx", "vy", "vz", "px", "py", "pz", "rx", "ry", "rz",
            ]),
            "floor": self.floor.to_json(Some(1), ["height", "climb"]),
            "camera": self.camera.to_json(None, ["rx", "ry", "rz", "tx", "ty", "tz"]),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn status(t: u64, nu: [f32; 2], var: [f32; 2], outcome: AidOutcome) -> AidStatus<2> {
        let mut s = AidStatus::<2>::new(Timestamp(t), outcome, None);
        s.innovation = nu;
        s.innovation_var = var;
        s.nis = (nu[0] * nu[0] / var[0]).max(nu[1] * nu[1] / var[1]);
        s
    }

    #[test]
    fn records_are_taken_once_and_summed() {
        let mut a = AidSums::<2>::default();
        let s1 = status(1, [0.1, 0.0], [0.01, 0.04], AidOutcome::Fused);
        assert!(a.take(1, Some(&s1)));
        assert!(!a.take(1, Some(&s1)), "no new sample: not taken again");
        let s2 = status(2, [-0.3, 0.2], [0.01, 0.04], AidOutcome::Gated);
        assert!(a.take(2, Some(&s2)));
        let j = a.to_json(None, ["f", "d"]);
        assert_eq!(j["records"], 2);
        assert_eq!(j["gated"], 1);
        assert_eq!(j["gated_fraction"], 0.5);
        let f = &j["components"][0];
        assert!((f["nis_mean"].as_f64().unwrap() - 5.0).abs() < 1e-4, "{f}");
        assert!(
            (f["innovation_mean"].as_f64().unwrap() + 0.1).abs() < 1e-6,
            "{f}"
        );
        let rejected = AidStatus::<2>::new(
            Timestamp(3),
            AidOutcome::Rejected(traction::vslam_core::Reject::NonFinite),
            None,
        );
        assert!(a.take(3, Some(&rejected)));
        let j = a.to_json(None, ["f", "d"]);
        assert_eq!(
            (j["records"].as_u64(), j["rejected"].as_u64()),
            (Some(3), Some(1))
        );
        assert_eq!(j["components"][0]["n"], 2, "NaN innovations are left out");
    }
}
