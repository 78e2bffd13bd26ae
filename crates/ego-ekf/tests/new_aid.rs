//! A worked example of adding an aiding sensor, written outside the crate
//! against ego-ekf's public API only: a planar body velocity from a 2-D scan
//! matcher (the robot origin's `vx`, `vy`, robot frame, with a variance).
//!
//! A new aid has the shape of the built-in ones (see `src/flow/`):
//!
//! - *the maths* ([`scan::measurement`], a real aid's `model.rs`): the
//!   measurement rows, `H` over the supporting columns named in the state
//!   table ([`ego_ekf::state::columns`]), the residual and the noise, as an
//!   [`ego_ekf::update::Measurement`];
//! - *when to fuse* ([`scan::ScanFusion`], a real aid's `fusion.rs`): the
//!   sample's checks (finite, variance, age against the filter's time), the
//!   shared gated update ([`EgoEkf::fuse_external`], which runs
//!   [`ego_ekf::update::gated_update`]: chi-square gate, update, injection,
//!   error reset), the counts and one [`AidStatus`] per sample.
//!
//! The files a real new aid touches, and what stands in for each here:
//!
//! | file | what it gets | here |
//! |---|---|---|
//! | `crates/vslam-core/src/stream.rs` | a `Stream` variant (reorder buffer, counts, report) | not needed: the test calls the filter directly |
//! | `crates/vslam-core/src/sensors.rs` | the validated sample type | [`scan::ScanVelocity`] |
//! | `crates/ego-ekf/src/<aid>/{mod,model,fusion}.rs` | the maths and the fusion status | module [`scan`] |
//! | `crates/ego-ekf/src/config.rs` | the aid's config (gate, noise floor, max age) | [`scan::ScanConfig`] |
//! | `src/reorder.rs` | the stream's slot in the reorder buffer | not needed: samples arrive in order |
//! | `src/estimator.rs` | offering the stream, dispatching it to the filter | the loop in [`run`] |
//!
//! Inside the crate the fusion calls `gated_update` on the filter's state
//! and covariance itself (`EgoEkf::fuse_flow` does); outside it,
//! [`EgoEkf::fuse_external`] is that call.
//!
//! The tests: the rows are the derivative of the prediction (central
//! differences through [`ego_ekf::state::NominalState::inject`], zero
//! outside the support); the aid corrects a velocity error that a run without it keeps
//! (so they fail if the update is not applied), and a grossly wrong sample
//! is gated by the Mahalanobis test, recorded as [`AidOutcome::Gated`],
//! and leaves the state unchanged.

use ego_ekf::{AidOutcome, AidStatus, EgoEkf, ExplicitStart, FilterConfig};
use nalgebra::{UnitQuaternion, Vector3};
use vslam_core::sensors::ImuSample;
use vslam_core::{Reject, Timestamp};

/// The new aid, as its module in `crates/ego-ekf/src/scan/` would read.
mod scan {
    use ego_ekf::aid_status::{innovation_covariance, innovation_variances, nis};
    use ego_ekf::covariance::skew;
    use ego_ekf::state::{DIM, NominalState, Vec3, columns, columns_len};
    use ego_ekf::update::{Measurement, UpdateReport};
    use ego_ekf::{AidOutcome, AidStatus, EgoEkf};
    use nalgebra::{Matrix3, SMatrix, SVector};
    use vslam_core::kinematics::add_lever_arm;
    use vslam_core::{Reject, SampleCounts, Timestamp};

    /// One scan-matcher velocity: the robot origin's horizontal velocity,
    /// robot frame, m/s, with the variance of each component, m^2/s^2.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct ScanVelocity {
        t: Timestamp,
        v: [f32; 2],
        var: f32,
    }

    impl ScanVelocity {
        /// A validated sample: finite, positive variance.
        pub fn new(t: Timestamp, vx: f32, vy: f32, var: f32) -> Result<Self, Reject> {
            if !(vx.is_finite() && vy.is_finite() && var.is_finite()) {
                return Err(Reject::NonFinite);
            }
            if var <= 0.0 {
                return Err(Reject::Degenerate);
            }
            Ok(ScanVelocity {
                t,
                v: [vx, vy],
                var,
            })
        }
    }

    /// The aid's configuration.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct ScanConfig {
        /// Chi-square gate on the 2-DOF NIS.
        pub gate: f32,
        /// Largest distance of a sample's time from the filter's, ns.
        pub max_age_ns: u64,
    }

    impl Default for ScanConfig {
        fn default() -> Self {
            // chi2(2 DOF) at 99.9 %.
            ScanConfig {
                gate: 13.8,
                max_age_ns: 20_000_000,
            }
        }
    }

    /// The blocks the measurement depends on, named in the state table.
    const BLOCKS: [&str; 6] = ["v_wb", "q_wb", "gyro_bias", "p_bl", "p_br", "q_rb"];
    /// Their error-state columns, three per block, in the order of `BLOCKS`.
    pub const SUPPORT: [usize; columns_len(&BLOCKS)] = columns(&BLOCKS);

    /// The measurement rows of a sample against the filter's state: the
    /// robot origin's velocity, robot frame, horizontal part,
    /// `h = [R_rb (R_wb^T v + w x p_mid)]_xy`, whose Jacobian is the flow's
    /// (`crates/ego-ekf/src/flow/model.rs`).
    pub fn measurement(ekf: &EgoEkf, s: &ScanVelocity) -> Measurement<2> {
        measurement_at(ekf.state(), &ekf.angular_velocity(), s)
    }

    /// [`measurement`] against the state `x` and the bias-corrected body
    /// rate `gyro`.
    pub fn measurement_at(x: &NominalState, gyro: &Vec3, s: &ScanVelocity) -> Measurement<2> {
        let gyro = *gyro;
        let r_rb = x.q_rb.to_rotation_matrix().into_inner();
        let r_wb = x.q_wb.to_rotation_matrix().into_inner();
        let v_b = r_wb.transpose() * x.v_wb;
        let p_mid = x.p_b_robot();
        let u_mid = add_lever_arm(&v_b, &gyro, &p_mid);
        let predicted = r_rb * u_mid;
        // d h / d(dx) per block, in the order of `BLOCKS`.
        let blocks: [Matrix3<f32>; 6] = [
            r_rb * r_wb.transpose(),
            r_rb * skew(&v_b),
            r_rb * skew(&p_mid),
            r_rb * skew(&gyro) * 0.5,
            r_rb * skew(&gyro) * 0.5,
            -r_rb * skew(&u_mid),
        ];
        let mut h = SMatrix::<f32, 2, DIM>::zeros();
        for (cols, d) in SUPPORT.chunks(3).zip(blocks.iter()) {
            for (k, &col) in cols.iter().enumerate() {
                h[(0, col)] = d[(0, k)];
                h[(1, col)] = d[(1, k)];
            }
        }
        Measurement {
            residual: SVector::<f32, 2>::new(s.v[0] - predicted.x, s.v[1] - predicted.y),
            h,
            noise: SMatrix::<f32, 2, 2>::identity() * s.var,
        }
    }

    /// The aid's fusion status: counts, gated run, latest [`AidStatus`].
    #[derive(Clone, Debug, Default)]
    pub struct ScanFusion {
        config: ScanConfig,
        counts: SampleCounts,
        gated_run: u16,
        status: Option<AidStatus<2>>,
    }

    impl ScanFusion {
        pub fn new(config: ScanConfig) -> Self {
            ScanFusion {
                config,
                ..ScanFusion::default()
            }
        }

        pub fn counts(&self) -> &SampleCounts {
            &self.counts
        }

        pub fn status(&self) -> Option<&AidStatus<2>> {
            self.status.as_ref()
        }

        /// Checks, gates and fuses one sample; keeps its status.
        pub fn fuse(&mut self, ekf: &mut EgoEkf, s: &ScanVelocity) -> Result<UpdateReport, Reject> {
            let out = self.fuse_inner(ekf, s);
            self.counts.record(out.map(|_| ()));
            out
        }

        fn fuse_inner(
            &mut self,
            ekf: &mut EgoEkf,
            s: &ScanVelocity,
        ) -> Result<UpdateReport, Reject> {
            let Some(now) = ekf.time() else {
                return Err(self.refuse(s.t, Reject::NotReady));
            };
            let age = s.t.nanos_since(now).or_else(|| now.nanos_since(s.t));
            if age.is_none_or(|a| a > self.config.max_age_ns) {
                return Err(self.refuse(s.t, Reject::OutOfOrder));
            }
            let m = measurement(ekf, s);
            // The status is of the prior: P H^T before the update.
            let pht = m.p_ht(ekf.covariance());
            let test = nis(&innovation_covariance(&m, &pht), &m.residual);
            let out = ekf.fuse_external(&m, Some(self.config.gate));
            self.gated_run = match out {
                Err(Reject::Gated) => self.gated_run.saturating_add(1),
                Ok(_) => 0,
                Err(_) => self.gated_run,
            };
            let status = AidStatus::new(s.t, AidOutcome::of(&out), self.status.as_ref())
                .with_gated_run(self.gated_run)
                .with_observation(s.v, [s.var; 2])
                .with_innovation([m.residual.x, m.residual.y], innovation_variances(&m, &pht))
                .with_test(test, Some(self.config.gate));
            self.status = Some(status);
            out
        }

        fn refuse(&mut self, t: Timestamp, reason: Reject) -> Reject {
            self.status = Some(
                AidStatus::new(t, AidOutcome::Rejected(reason), self.status.as_ref())
                    .with_gated_run(self.gated_run),
            );
            reason
        }
    }
}

use scan::{ScanConfig, ScanFusion, ScanVelocity};

const IMU_DT_NS: u64 = 4_000_000;
/// The scan matcher's standard deviation per component, m/s.
const SCAN_STD: f32 = 0.02;

/// A filter that believes it drives 0.3 m/s forward and 0.1 m/s left while
/// the robot stands still, and does not trust its velocity (0.5 m/s).
fn filter() -> EgoEkf {
    let mut config = FilterConfig::default();
    config.init.velocity_std = 0.5;
    let mut f = EgoEkf::new(config).unwrap();
    f.start(&ExplicitStart {
        v_wb: Vector3::new(0.3, 0.1, 0.0),
        ..ExplicitStart::at_rest(Timestamp(0))
    })
    .unwrap();
    f
}

/// Two seconds standing still: IMU at 250 Hz and, with `aid`, a scan
/// velocity of zero at 25 Hz.
fn run(f: &mut EgoEkf, mut aid: Option<&mut ScanFusion>) {
    for k in 1..=500u64 {
        let t = Timestamp(k * IMU_DT_NS);
        let imu = ImuSample::new(t, [0.0; 3], [0.0, 0.0, 9.806_65]).unwrap();
        f.propagate(&imu).unwrap();
        if let (Some(aid), true) = (aid.as_deref_mut(), k % 10 == 0) {
            let s = ScanVelocity::new(t, 0.0, 0.0, SCAN_STD * SCAN_STD).unwrap();
            aid.fuse(f, &s).unwrap();
        }
    }
}

#[test]
fn the_aid_corrects_a_velocity_error() {
    let mut without = filter();
    run(&mut without, None);
    let mut with = filter();
    let mut aid = ScanFusion::new(ScanConfig::default());
    run(&mut with, Some(&mut aid));

    // Without the aid nothing observes the velocity: the error stays.
    let v0 = without.robot_velocity();
    assert!(v0.xy().norm() > 0.25, "unaided {v0:?}");
    // With it the velocity is the scan matcher's, and known to about its
    // standard deviation.
    let v = with.robot_velocity();
    assert!(v.xy().norm() < 0.02, "aided {v:?}");
    assert!(with.velocity_std().x < 2.0 * SCAN_STD);
    assert!(with.velocity_std().x < 0.2 * without.velocity_std().x);

    assert_eq!(aid.counts().seen(), 50);
    assert_eq!(aid.counts().gated(), 0);
    let status = aid.status().unwrap();
    assert_eq!(status.outcome, AidOutcome::Fused);
    assert_eq!(status.last_fused, Some(Timestamp(500 * IMU_DT_NS)));
    assert!(status.test_ratio() < 1.0);
    assert!(status.innovation[0].abs() < 0.05);
    let p = with.covariance();
    assert!((p - p.transpose()).amax() < 1e-6);
    assert!(p.cholesky().is_some());
}

#[test]
fn a_grossly_wrong_sample_is_gated_and_recorded() {
    let mut f = filter();
    let mut aid = ScanFusion::new(ScanConfig::default());
    run(&mut f, Some(&mut aid));
    let (x, p) = (*f.state(), *f.covariance());
    let t = f.time().unwrap();

    // 3 m/s forward, against a velocity known to a few cm/s.
    let wrong = ScanVelocity::new(t, 3.0, 0.0, SCAN_STD * SCAN_STD).unwrap();
    assert_eq!(aid.fuse(&mut f, &wrong), Err(Reject::Gated));
    let status: AidStatus<2> = *aid.status().unwrap();
    assert_eq!(status.outcome, AidOutcome::Gated);
    assert_eq!(status.consecutive_gated, 1);
    assert!(status.test_ratio() > 1.0, "ratio {}", status.test_ratio());
    assert!((status.innovation[0] - 3.0).abs() < 0.05);
    assert_eq!(status.last_fused, Some(t));
    assert_eq!(aid.counts().gated(), 1);
    // Gated: the state and covariance are untouched.
    assert_eq!(*f.state(), x);
    assert_eq!(*f.covariance(), p);

    // The next good sample is fused again and ends the gated run.
    let good = ScanVelocity::new(t, 0.0, 0.0, SCAN_STD * SCAN_STD).unwrap();
    assert!(aid.fuse(&mut f, &good).is_ok());
    assert_eq!(aid.status().unwrap().consecutive_gated, 0);
}

#[test]
fn the_hook_refuses_rows_on_the_clone_and_an_unstarted_filter() {
    let mut f = EgoEkf::new(FilterConfig::default()).unwrap();
    let s = ScanVelocity::new(Timestamp(0), 0.0, 0.0, 1.0).unwrap();
    let m = scan::measurement(&f, &s);
    assert_eq!(f.fuse_external(&m, None), Err(Reject::NotReady));

    let mut f = filter();
    run(&mut f, None);
    let mut m = scan::measurement(&f, &s);
    m.h[(0, ego_ekf::state::CLONE.start)] = 1.0;
    let x = *f.state();
    assert_eq!(f.fuse_external(&m, None), Err(Reject::Degenerate));
    assert_eq!(*f.state(), x);
}

#[test]
fn the_rows_are_the_derivative_of_the_prediction() {
    // A moving, turning, tilted state, so that every block of H is nonzero.
    let mut x = *filter().state();
    x.v_wb = Vector3::new(0.4, -0.2, 0.05);
    x.q_wb = UnitQuaternion::from_euler_angles(0.05, -0.03, 0.7);
    x.q_rb = UnitQuaternion::from_euler_angles(0.02, 0.01, -0.04);
    // The raw rate: the measurement sees it less the (perturbed) bias.
    let raw_gyro = Vector3::new(0.1, -0.05, 0.8);
    let s = ScanVelocity::new(Timestamp(0), 0.0, 0.0, 1.0).unwrap();
    let at =
        |x: &ego_ekf::state::NominalState| scan::measurement_at(x, &(raw_gyro - x.gyro_bias), &s);
    let m = at(&x);
    let eps = 1e-3;
    for j in 0..ego_ekf::state::DIM {
        let moved = |sign: f32| {
            let mut dx = ego_ekf::state::ErrorState::zeros();
            dx[j] = sign * eps;
            let mut xp = x;
            xp.inject(&dx);
            at(&xp).residual
        };
        // residual = z - h(x): the prediction's change is minus the residual's.
        let numeric = -(moved(1.0) - moved(-1.0)) / (2.0 * eps);
        for r in 0..2 {
            let (a, n) = (m.h[(r, j)], numeric[r]);
            assert!(
                (a - n).abs() < 2e-3,
                "row {r} column {j}: H {a}, numeric {n}"
            );
        }
        if !scan::SUPPORT.contains(&j) {
            assert_eq!(m.h.column(j).amax(), 0.0, "column {j} outside the support");
        }
    }
}
