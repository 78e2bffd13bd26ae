//! Filter configuration: IMU noise densities and limits, one struct per
//! aiding sensor (wheels, flow, floor, camera), the robot prior, the still detector. Checked once by [`FilterConfig::check`].

use core::fmt;

use crate::vibration::VibrationConfig;

use vslam_core::geometry::Extrinsics;
pub use vslam_core::robot::ImuNoise;
use vslam_core::robot::{FlowDescription, RobotDescription, RobotError, Steering};
use vslam_core::sensors::{FlowOptics, FlowOpticsError};

use crate::grip::GripParams;
use crate::plausibility::ImuPlausibility;
use crate::state::{Quat, Vec3};
use crate::wheel::skid::SkidConfig;

/// The robot's mechanical prior: where the wheels touch the floor seen from
/// the IMU, how the IMU is turned in the chassis, the wheel radii, and how
/// well each is known.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RobotPrior {
    /// Left wheel contact point in the IMU frame, m.
    pub p_bl: Vec3,
    /// Right wheel contact point in the IMU frame, m.
    pub p_br: Vec3,
    /// Rotation of IMU vectors into the robot frame.
    pub q_rb: Quat,
    /// Nominal wheel radius (both wheels), m.
    pub radius: f32,
    /// Standard deviation of each contact-point coordinate, m.
    pub contact_std: f32,
    /// Standard deviation of each body-to-robot rotation angle, rad.
    pub rotation_std: f32,
    /// Standard deviation of each wheel radius, m.
    pub radius_std: f32,
    /// Random walk of the wheel radii (wear, load), m/sqrt(s).
    pub radius_random_walk: f32,
    /// Random walk of the contact points (tyre deformation), m/sqrt(s).
    pub contact_random_walk: f32,
    /// Random walk of the body-to-robot rotation (mount flex), rad/sqrt(s).
    pub rotation_random_walk: f32,
}

impl Default for RobotPrior {
    /// A robot vacuum: 35 mm wheels, 230 mm track, IMU 60 mm above the floor on the axle.
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl RobotPrior {
    /// The defaults ([`Default::default`]) as a constant, for `const` construction.
    pub const DEFAULT: Self = RobotPrior {
        p_bl: Vec3::new(0.0, 0.115, -0.06),
        p_br: Vec3::new(0.0, -0.115, -0.06),
        q_rb: Quat::new_unchecked(nalgebra::Quaternion::new(1.0, 0.0, 0.0, 0.0)),
        radius: 0.035,
        contact_std: 0.003,
        rotation_std: 0.01,
        radius_std: 0.001,
        radius_random_walk: 1.0e-6,
        contact_random_walk: 1.0e-6,
        rotation_random_walk: 1.0e-6,
    };
}

impl RobotPrior {
    /// The prior of a described robot, seen from its IMU: the contact points
    /// `(0, ±track / 2, 0)` of the body frame (the kinematic track, see
    /// [`vslam_core::robot::Wheels::kinematic_track`]) in the IMU frame,
    /// `p_I = R_BS^T (p_B - t_BS)`; `q_rb = R_BS` (IMU vectors into the
    /// robot frame); the mean wheel radius; the uncertainties of
    /// [`RobotPrior::default`]. The description is assumed valid
    /// ([`RobotDescription::validate`]).
    pub fn from_robot(robot: &RobotDescription) -> Self {
        let mount = &robot.imu.mount;
        let half = 0.5 * robot.wheels.kinematic_track();
        let in_imu = |y: f32| mount.r_bs().inverse() * (Vec3::new(0.0, y, 0.0) - mount.t_bs());
        RobotPrior {
            p_bl: in_imu(half),
            p_br: in_imu(-half),
            q_rb: Quat::from_rotation_matrix(mount.r_bs()),
            radius: robot.wheels.mean_radius(),
            ..RobotPrior::default()
        }
    }
}

/// When the robot counts as still, and how zero-velocity updates are made.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ZuptConfig {
    /// Largest wheel rate, rad/s, that counts as stopped.
    pub max_wheel_rate: f32,
    /// Largest bias-corrected gyro norm, rad/s, that counts as still.
    pub max_gyro: f32,
    /// Largest deviation of the specific-force norm from gravity, m/s^2.
    pub max_accel_deviation: f32,
    /// IMU samples in a row that must look still before the robot is still.
    pub still_samples: u16,
    /// A zero-velocity update every this many IMU samples while still.
    pub every: u16,
    /// Velocity noise of the update, m/s.
    pub velocity_std: f32,
    /// Position noise of the pose-equals-clone update, m.
    pub position_std: f32,
    /// Attitude noise of the pose-equals-clone update, rad.
    pub attitude_std: f32,
}

impl Default for ZuptConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl ZuptConfig {
    /// The defaults ([`Default::default`]) as a constant, for `const` construction.
    pub const DEFAULT: Self = ZuptConfig {
        max_wheel_rate: 0.01,
        max_gyro: 0.02,
        max_accel_deviation: 0.3,
        still_samples: 50,
        every: 10,
        velocity_std: 0.005,
        position_std: 0.001,
        attitude_std: 0.001,
    };
}

/// The floor constraint ([`crate::floor`]): the robot origin stays on the
/// floor plane and does not climb faster than a gentle slope allows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FloorConfig {
    /// A floor update every this many IMU steps.
    pub every: u16,
    /// Noise of the height row, m: the floor's unevenness.
    pub height_std: f32,
    /// Innovations of the height row beyond this many standard deviations
    /// have their noise raised until they are at this many (a Huber-type
    /// weight): a bump pulls little, a drifted height is still pulled back.
    pub height_huber: f32,
    /// Noise of the vertical-velocity row on level ground, m/s.
    pub vertical_velocity_std: f32,
    /// Steepest floor allowed for, rise over run: adds `max_slope` times the
    /// horizontal speed to the vertical-velocity noise.
    pub max_slope: f32,
    /// Chi-square gate (1 degree of freedom) of the vertical-velocity row:
    /// a cable or strip under a wheel fails it.
    pub climb_gate: f32,
    /// A height this far from the floor, m, is another level (lifted, a
    /// ramp, a step) once it lasts [`FloorConfig::reanchor_after`] updates.
    pub level_change: f32,
    /// Updates in a row beyond [`FloorConfig::level_change`] after which the
    /// floor is re-anchored at the robot's height.
    pub reanchor_after: u16,
}

impl Default for FloorConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl FloorConfig {
    /// The defaults ([`Default::default`]) as a constant, for `const` construction.
    pub const DEFAULT: Self = FloorConfig {
        every: 25,
        height_std: 0.005,
        height_huber: 3.0,
        vertical_velocity_std: 0.01,
        max_slope: 0.05,
        // chi-square, 1 degree of freedom, 99.9 %.
        climb_gate: 10.83,
        level_change: 0.05,
        reanchor_after: 100,
    };
}

/// The camera's relative motions as pose measurements (see
/// [`crate::camera`]): the mounting, the noise of a frame pair and the gates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraConfig {
    /// Rotation of camera vectors into the IMU frame, `R_IC`.
    pub q_ic: Quat,
    /// Camera origin in the IMU frame, `t_IC`, m.
    pub t_ic: Vec3,
    /// Standard deviation of each rotation angle of a frame pair, rad.
    pub rotation_std: f32,
    /// Standard deviation of the translation's direction, as a fraction of
    /// its length (each axis), 1.
    pub translation_rel_std: f32,
    /// Standard deviation of each translation axis at any length, m.
    pub translation_std: f32,
    /// Chi-square gate of the rotation alone (3 degrees of freedom).
    pub rotation_gate: f32,
    /// Chi-square gate of rotation and translation (6 degrees of freedom).
    pub pose_gate: f32,
    /// Whether a pair with a metric scale also measures the translation
    /// (`false`: rotation only).
    pub translation: bool,
    /// How far behind the filter's time, ns, a frame may be and still be
    /// measured (at the filter's time); an older one is out of order.
    pub max_lag_ns: u64,
}

impl CameraConfig {
    /// The camera mounted by `T_BC` on a robot whose IMU is mounted by
    /// `T_BI` (both in the body frame `B`): `R_IC = R_BI^T R_BC`,
    /// `t_IC = R_BI^T (t_BC - t_BI)`; the noise and gates of
    /// [`CameraConfig::default`].
    pub fn from_mounts(imu: &Extrinsics, camera: &Extrinsics) -> Self {
        let r_ib = imu.r_bs().inverse();
        CameraConfig {
            q_ic: Quat::from_rotation_matrix(&(r_ib * camera.r_bs())),
            t_ic: r_ib * (camera.t_bs() - imu.t_bs()),
            ..CameraConfig::default()
        }
    }
}

impl Default for CameraConfig {
    /// A camera at the IMU; a homography from a textured ceiling.
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl CameraConfig {
    /// The defaults ([`Default::default`]) as a constant, for `const` construction.
    pub const DEFAULT: Self = CameraConfig {
        q_ic: Quat::new_unchecked(nalgebra::Quaternion::new(1.0, 0.0, 0.0, 0.0)),
        t_ic: Vec3::new(0.0, 0.0, 0.0),
        rotation_std: 5.0e-4,
        translation_rel_std: 0.02,
        translation_std: 0.0005,
        // chi-square, 99.9 %: 3 and 6 degrees of freedom.
        rotation_gate: 16.27,
        pose_gate: 22.46,
        translation: true,
        max_lag_ns: 20_000_000,
    };
}

/// Initialisation from the first still IMU samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InitConfig {
    /// Still samples averaged for the gravity direction and the gyro bias.
    pub samples: u16,
    /// Largest gyro norm, rad/s, of a sample that counts as still.
    pub max_gyro: f32,
    /// Largest deviation of the specific-force norm from gravity, m/s^2.
    pub max_accel_deviation: f32,
    /// Initial attitude standard deviation (roll, pitch), rad.
    pub tilt_std: f32,
    /// Initial yaw standard deviation, rad.
    pub yaw_std: f32,
    /// Initial velocity standard deviation, m/s.
    pub velocity_std: f32,
    /// Initial position standard deviation, m.
    pub position_std: f32,
    /// Initial accelerometer bias standard deviation, m/s^2.
    pub accel_bias_std: f32,
    /// Initial gyro bias standard deviation, rad/s.
    pub gyro_bias_std: f32,
    /// Initial standard deviation of the gyro's z scale-factor error
    /// (a fraction: 0.02 is 2 %).
    pub gyro_scale_std: f32,
    /// Initial gravity standard deviation, m/s^2.
    pub gravity_std: f32,
    /// Samples without a still start after which the filter starts moving
    /// (0: never; see [`crate::init`]).
    pub moving_samples: u16,
    /// Largest deviation of the moving samples' mean specific force from
    /// gravity for a moving start, m/s^2.
    pub moving_max_accel_deviation: f32,
    /// Initial attitude standard deviation (roll, pitch) of a moving start, rad.
    pub moving_tilt_std: f32,
    /// Initial velocity standard deviation of a moving start, m/s.
    pub moving_velocity_std: f32,
}

impl InitConfig {
    /// The initial uncertainty of a moving start: tilt and velocity from
    /// [`InitConfig::moving_tilt_std`] and [`InitConfig::moving_velocity_std`].
    pub fn moving(&self) -> InitConfig {
        InitConfig {
            tilt_std: self.moving_tilt_std,
            velocity_std: self.moving_velocity_std,
            ..*self
        }
    }
}

impl Default for InitConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl InitConfig {
    /// The defaults ([`Default::default`]) as a constant, for `const` construction.
    pub const DEFAULT: Self = InitConfig {
        samples: 50,
        max_gyro: 0.05,
        max_accel_deviation: 0.5,
        tilt_std: 0.01,
        yaw_std: 0.01,
        velocity_std: 0.01,
        position_std: 0.001,
        accel_bias_std: 0.05,
        gyro_bias_std: 0.005,
        // The sensitivity tolerance of consumer MEMS gyros (BMI088
        // datasheet, BST-BMI088-DS001, table 2: +-1 % typical).
        gyro_scale_std: 0.02,
        // Gravity's direction defines the world's z; only its size is
        // uncertain, and little.
        gravity_std: 0.001,
        // 0.5 s at 250 Hz; 3 degrees; up to 1 m/s.
        moving_samples: 125,
        moving_max_accel_deviation: 0.5,
        moving_tilt_std: 0.05,
        moving_velocity_std: 1.0,
    };
}

/// The wheel encoders' timing and how long a gated run lasts before the
/// filter re-examines its velocity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelConfig {
    /// Largest accepted step between wheel samples, ns.
    pub max_dt_ns: u64,
    /// Largest distance, ns, between a wheel sample's time and the filter's
    /// (latest IMU) time: an older sample measured a velocity the state no
    /// longer has ([`vslam_core::Reject::OutOfOrder`]), a newer one a
    /// velocity the state has not reached ([`vslam_core::Reject::NotReady`]).
    pub max_age_ns: u64,
    /// Consecutive gated forward wheel updates after which the filter
    /// re-examines its own velocity ([`crate::recovery`]; 0: never);
    /// re-examined again every as many gated updates while the run lasts.
    pub reexamine_after_gated: u16,
    /// A skid steer's effective track, learned online
    /// ([`crate::wheel::skid`]); `None` for a differential drive.
    pub skid: Option<SkidConfig>,
}

impl Default for WheelConfig {
    /// Steps up to 0.2 s, samples within 50 ms of the filter's time,
    /// re-examination after 25 gated updates (0.5 s at 50 Hz).
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl WheelConfig {
    /// The defaults ([`Default::default`]) as a constant, for `const` construction.
    pub const DEFAULT: Self = WheelConfig {
        max_dt_ns: 200_000_000,
        max_age_ns: 50_000_000,
        reexamine_after_gated: 25,
        skid: None,
    };
}

/// The optical-flow sensor: optics, noise model, gate and timing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlowConfig {
    /// Resolution, height and mounting `T_BS` in the robot frame.
    pub optics: FlowOptics,
    /// Velocity noise at good quality, m/s.
    pub base_std: f32,
    /// Relative velocity noise (height and resolution error), 1.
    pub relative_std: f32,
    /// SQUAL at and above which the quality adds no noise.
    pub squal_good: u8,
    /// Shutter at and below which the exposure adds no noise.
    pub shutter_good: u16,
    /// Chi-square gate of the 2-D velocity (99 % = 9.21).
    pub gate: f32,
    /// Largest step between flow reports, ns.
    pub max_dt_ns: u64,
    /// Oldest flow report, ns, that still counts as a recent witness; a
    /// report this far ahead of the filter's time is not fused yet.
    pub max_age_ns: u64,
    /// Window, ns, over which the flow's reports are averaged into a witness.
    pub window_ns: u64,
    /// Consecutive gated reports of valid quality after which the filter
    /// stops trusting its own velocity and resets it to the flow's (0: never).
    pub velocity_reset_after_gated: u16,
    /// Fastest flow-measured speed, m/s, the velocity may be reset to; a
    /// report claiming more is no ground truth to restart from.
    pub reset_max_speed: f32,
}

impl FlowConfig {
    /// Defaults for a PMW3901-class sensor with the given optics.
    pub fn new(optics: FlowOptics) -> Self {
        FlowConfig {
            optics,
            base_std: 0.01,
            relative_std: 0.03,
            squal_good: 100,
            shutter_good: 0x0400,
            gate: 9.21,
            max_dt_ns: 100_000_000,
            max_age_ns: 200_000_000,
            window_ns: 250_000_000,
            velocity_reset_after_gated: 25,
            reset_max_speed: 2.0,
        }
    }
}

impl FlowConfig {
    /// The configuration of a described flow sensor: its optics, mounting and
    /// noise, the other settings of [`FlowConfig::new`].
    pub fn from_robot(flow: &FlowDescription) -> Result<Self, RobotError> {
        let optics = FlowOptics::new(flow.counts_per_radian, flow.height, flow.mount).map_err(
            |e| match e {
                FlowOpticsError::BadResolution => RobotError::BadFlowResolution,
                FlowOpticsError::BadHeight => RobotError::FlowBelowFloor,
            },
        )?;
        Ok(FlowConfig {
            base_std: flow.base_std,
            relative_std: flow.relative_std,
            ..FlowConfig::new(optics)
        })
    }
}

/// How the filter gets out of a wheel lockout (see [`crate::recovery`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RecoveryConfig {
    /// Lowest grip at which the wheels themselves may be the reset source.
    pub wheel_min_grip: f32,
    /// Largest change of the forward wheel innovation, m/s, within one steady
    /// stretch of a gated run: wheels and IMU see the same accelerations, only
    /// an offset separates them.
    pub steady_tolerance: f32,
    /// A run whose first update follows this long, ns, without a fused
    /// forward wheel update started after silence (wheel or IMU gap): its
    /// onset says nothing about slip.
    pub silence_ns: u64,
    /// Largest standard deviation, m/s, of the flow's averaged velocity for
    /// it to be a witness at all: reports of a sensor that sees no floor
    /// (lifted robot, textureless floor) average to a vague zero that every
    /// speed "agrees" with.
    pub flow_witness_max_std: f32,
    /// Slowest wheel speed, m/s, at which a filter faster than the wheels
    /// (or against their direction) is taken to have drifted and is reset to
    /// them ([`crate::recovery::overruns`]); below it the wheels may be
    /// frozen or the robot pushed.
    pub overrun_min_speed: f32,
    /// Horizontal specific force, m/s^2, at which an IMU step is an impact
    /// (the robot hit something; see [`crate::impact`]); infinite: never.
    pub impact_accel: f32,
    /// How long, ns, either side of an impact the wheels are gated on their
    /// uninflated noise (ends early once they agree again).
    pub impact_hold_ns: u64,
}

impl Default for RecoveryConfig {
    /// Wheels trusted on floors of grip 0.85 and more (wood, tile),
    /// a steady stretch within 5 cm/s, silence after 0.5 s, a flow witness
    /// only when its mean is known to 0.2 m/s, a filter overrunning wheels
    /// that turn at 5 cm/s or more, an impact at 1 g held for up to 5 s.
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl RecoveryConfig {
    /// The defaults ([`Default::default`]) as a constant, for `const` construction.
    pub const DEFAULT: Self = RecoveryConfig {
        wheel_min_grip: 0.85,
        steady_tolerance: 0.05,
        silence_ns: 500_000_000,
        flow_witness_max_std: 0.2,
        overrun_min_speed: 0.05,
        impact_accel: 9.806_65,
        impact_hold_ns: 5_000_000_000,
    };
}

/// What the filter assumes about motion it did not measure (an IMU gap).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GapConfig {
    /// Density of the robot's unmeasured acceleration, m/s^2/sqrt(Hz)
    /// (white-noise-acceleration model over the gap).
    pub accel_density: f32,
    /// Largest plausible change of its yaw rate per second, rad/s^2: the
    /// turn a held rate may miss over a short gap (when the wheels cannot
    /// dead-reckon it; see [`crate::gap::constant_velocity`]).
    pub yaw_accel: f32,
    /// Largest plausible yaw rate, rad/s: bounds the turn a held rate may
    /// miss over a long gap.
    pub max_yaw_rate: f32,
    /// Whether wheel samples taken during the gap dead-reckon it (turns
    /// included, see [`crate::gap::odometry`]); otherwise, or when they do not
    /// cover it, the gap is bridged at constant velocity.
    pub wheels: bool,
    /// Largest plausible speed of one wheel's contact point, m/s; a gap
    /// sample above it is [`vslam_core::Reject::OutOfRange`].
    pub max_wheel_speed: f32,
}

impl Default for GapConfig {
    /// A robot vacuum: about 0.5 m/s^2 in one second; its yaw rate changing
    /// by 1 rad/s within 50 ms (20 rad/s^2: a turn's start or stop) and
    /// never beyond 2 rad/s; wheels dead-reckon gaps, up to 2 m/s per wheel.
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl GapConfig {
    /// The defaults ([`Default::default`]) as a constant, for `const` construction.
    pub const DEFAULT: Self = GapConfig {
        accel_density: 0.5,
        yaw_accel: 20.0,
        max_yaw_rate: 2.0,
        wheels: true,
        max_wheel_speed: 2.0,
    };
}

/// The IMU: its noise, its timing and its full scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuConfig {
    /// Noise densities and bias random walks.
    pub noise: ImuNoise,
    /// Largest accepted IMU step, ns (larger steps are [`vslam_core::Reject::Gap`]).
    pub max_dt_ns: u64,
    /// Full scale of the gyroscope, rad/s; a reading at or beyond it is
    /// [`vslam_core::Reject::Saturated`]
    /// ([`vslam_core::sensors::ImuSample::check_range`]).
    pub gyro_max: f32,
    /// Full scale of the accelerometer, m/s^2; a reading at or beyond it is
    /// [`vslam_core::Reject::Saturated`].
    pub accel_max: f32,
    /// Estimate the gyro's z scale-factor error (the state
    /// [`crate::state::KG`]): the propagation couples it to the attitude
    /// and the wheel rows carry its column, so the camera's rotation and
    /// the wheels' yaw rate correct it. `false` (the default) leaves it at
    /// zero, uncoupled: the rate is only bias-corrected, and every number
    /// is the one the filter gives without the state. Off by default: with
    /// wheels and IMU only (yaw unobservable) the filter with the state is
    /// overconfident (`tests/consistency.rs` with it on: position ANEES
    /// 3.41, 49 of 60 checkpoints inside the 95 % bounds, attitude 47/60).
    /// With the camera's frame pairs it is consistent
    /// (`tests/fused_consistency.rs`: gyro scale ANEES 0.80, 51 of 60
    /// inside, over 25 runs); without them the scale factor's prior makes
    /// the yaw uncertain enough for the filter's spurious yaw information
    /// (`tests/yaw_unobservable.rs`) to make it overconfident.
    pub estimate_gyro_scale: bool,
    /// Random walk of the gyro's z scale factor (temperature, ageing),
    /// 1/sqrt(s).
    pub gyro_scale_random_walk: f32,
    /// Keep the heading about gravity unobservable after updates
    /// ([`crate::observability`]: the observability-constrained EKF of
    /// Hesch et al. 2014): the transition after an update and the
    /// covariance after each update carry the heading direction from the
    /// estimate the update was blind to, and the zero-velocity update's
    /// rows are projected to be blind to it; the heading's standard
    /// deviation is held at [`ImuConfig::max_heading_std`]. On by default:
    /// the filter no longer learns its absolute heading from its own
    /// corrections (`tests/yaw_unobservable.rs`), and over an hour the
    /// heading drifts less (the measurements are in the module doc of
    /// [`crate::observability`]).
    pub constrain_heading: bool,
    /// With [`ImuConfig::constrain_heading`]: the largest standard
    /// deviation of the heading about gravity the covariance keeps, rad
    /// (the heading's direction is scaled back to it once its variance is
    /// [`crate::observability::HEADING_HOLD_SLACK`] times the bound's; infinite keeps any,
    /// up to [`crate::observability::MAX_REANCHOR_HEADING_VAR`]). Nothing
    /// measures the absolute heading, so its variance grows for as long as
    /// the robot drives, and with it, in `f32`, the rounding of the relative
    /// yaw and position the clone, the wheels and the camera measure (the
    /// difference of two large, nearly equal entries). Default 0.1 rad.
    pub max_heading_std: f32,
    /// Refuse readings the robot cannot have: a rate jump beyond its
    /// angular acceleration, an output frozen bit for bit
    /// ([`crate::plausibility`]); `None` integrates every reading within
    /// full scale.
    pub plausibility: Option<ImuPlausibility>,
}

impl Default for ImuConfig {
    /// A consumer MEMS IMU at up to 20 ms a step, +-2000 deg/s and +-16 g.
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl ImuConfig {
    /// The defaults ([`Default::default`]) as a constant, for `const` construction.
    pub const DEFAULT: Self = ImuConfig {
        noise: ImuNoise::DEFAULT,
        max_dt_ns: 20_000_000,
        gyro_max: 35.0,
        accel_max: 160.0,
        estimate_gyro_scale: false,
        gyro_scale_random_walk: 1.0e-5,
        constrain_heading: true,
        max_heading_std: 0.1,
        plausibility: Some(ImuPlausibility::DEFAULT),
    };
}

/// Everything the filter needs to know before the first sample: one config
/// struct per sensor, then the filter's own settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterConfig {
    /// The IMU.
    pub imu: ImuConfig,
    /// The wheel encoders.
    pub wheel: WheelConfig,
    /// Getting out of a wheel lockout.
    pub recovery: RecoveryConfig,
    /// Bridging an IMU gap.
    pub gap: GapConfig,
    /// Robot prior.
    pub robot: RobotPrior,
    /// Initialisation.
    pub init: InitConfig,
    /// Still detection and zero-velocity updates.
    pub zupt: ZuptConfig,
    /// The flow sensor, if the robot has one.
    pub flow: Option<FlowConfig>,
    /// The floor constraint, if the robot drives on a floor (`None`: the
    /// vertical position is left to the other aids).
    pub floor: Option<FloorConfig>,
    /// The camera's frame pairs, if the robot has a camera.
    pub camera: Option<CameraConfig>,
    /// Grip before the surface model says otherwise.
    pub grip: GripParams,
    /// Magnitude of gravity, m/s^2.
    pub gravity: f32,
    /// The ground's vibration, measured from the accelerometer and added to
    /// the velocity's process noise ([`crate::vibration`]; `None`: the
    /// sensor's noise density alone).
    pub vibration: Option<VibrationConfig>,
}

impl Default for FilterConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl FilterConfig {
    /// The defaults ([`Default::default`]) as a constant, for `const` construction.
    pub const DEFAULT: Self = FilterConfig {
        imu: ImuConfig::DEFAULT,
        wheel: WheelConfig::DEFAULT,
        recovery: RecoveryConfig::DEFAULT,
        gap: GapConfig::DEFAULT,
        robot: RobotPrior::DEFAULT,
        init: InitConfig::DEFAULT,
        zupt: ZuptConfig::DEFAULT,
        flow: None,
        floor: Some(FloorConfig::DEFAULT),
        camera: None,
        grip: GripParams::DEFAULT,
        gravity: crate::state::STANDARD_GRAVITY,
        vibration: Some(VibrationConfig::DEFAULT),
    };
}

/// IMU rate, Hz, that the defaults' sample counts are written for: 50 still
/// samples are 0.2 s, a ZUPT every 10 samples every 40 ms, a floor update
/// every 25 samples every 0.1 s ([`FilterConfig::with_imu_rate`]).
pub const NOMINAL_IMU_RATE_HZ: f32 = 250.0;

/// The wheel rate [`WheelConfig`]'s sample counts are written for, Hz
/// ([`FilterConfig::with_wheel_rate`]).
pub const NOMINAL_WHEEL_RATE_HZ: f32 = 50.0;

/// Smallest largest IMU step of [`FilterConfig::with_imu_rate`], ns (the
/// default [`ImuConfig::max_dt_ns`]).
pub const MIN_MAX_IMU_DT_NS: u64 = 20_000_000;

/// Sample periods in the largest IMU step of [`FilterConfig::with_imu_rate`]:
/// one lost sample is a step, two are a gap.
pub const MAX_IMU_DT_PERIODS: f32 = 2.5;

/// `n` samples at [`NOMINAL_IMU_RATE_HZ`] as samples at `rate_hz` (the same
/// duration, at least one sample).
fn samples_at(n: u16, rate_hz: f32) -> u16 {
    let x = libm::roundf(f32::from(n) * rate_hz / NOMINAL_IMU_RATE_HZ);
    // In range: clamped to [1, u16::MAX] before the cast.
    x.clamp(1.0, f32::from(u16::MAX)) as u16
}

impl FilterConfig {
    /// The configuration for wheels sampled at `rate_hz`, from one whose
    /// sample counts are written for [`NOMINAL_WHEEL_RATE_HZ`] (as
    /// [`FilterConfig::default`]'s are): the gated run after which the filter
    /// re-examines its velocity ([`WheelConfig::reexamine_after_gated`])
    /// keeps its duration (0.5 s; at least one sample; 0 stays 0). At 50 Hz
    /// nothing changes; a rate that is not finite and positive changes
    /// nothing either.
    pub fn with_wheel_rate(mut self, rate_hz: f32) -> Self {
        if !(rate_hz.is_finite() && rate_hz > 0.0) || self.wheel.reexamine_after_gated == 0 {
            return self;
        }
        let x = libm::roundf(
            f32::from(self.wheel.reexamine_after_gated) * rate_hz / NOMINAL_WHEEL_RATE_HZ,
        );
        // In range: clamped to [1, u16::MAX] before the cast.
        self.wheel.reexamine_after_gated = x.clamp(1.0, f32::from(u16::MAX)) as u16;
        self
    }

    /// The configuration for an IMU sampled at `rate_hz` (30 to 1000 Hz and
    /// beyond), from one whose sample counts are written for
    /// [`NOMINAL_IMU_RATE_HZ`] (as [`FilterConfig::default`]'s are): the
    /// still-sample initialisation ([`InitConfig::samples`]), the moving
    /// start's wait ([`InitConfig::moving_samples`]), the still
    /// detector ([`ZuptConfig::still_samples`]), the ZUPT and floor update
    /// intervals ([`ZuptConfig::every`], [`FloorConfig::every`]) keep their
    /// durations (at least one sample each), and the largest IMU step
    /// ([`ImuConfig::max_dt_ns`]) is the larger of 20 ms and 2.5 sample
    /// periods. At 250 Hz nothing changes. A rate that is not finite and
    /// positive changes nothing either.
    pub fn with_imu_rate(mut self, rate_hz: f32) -> Self {
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return self;
        }
        self.init.samples = samples_at(self.init.samples, rate_hz);
        if self.init.moving_samples > 0 {
            self.init.moving_samples = samples_at(self.init.moving_samples, rate_hz);
        }
        self.zupt.still_samples = samples_at(self.zupt.still_samples, rate_hz);
        self.zupt.every = samples_at(self.zupt.every, rate_hz);
        if let Some(f) = self.floor.as_mut() {
            f.every = samples_at(f.every, rate_hz);
        }
        let periods_ns = f64::from(MAX_IMU_DT_PERIODS) * 1.0e9 / f64::from(rate_hz);
        // Finite and positive; the cast saturates.
        self.imu.max_dt_ns = MIN_MAX_IMU_DT_NS.max(libm::ceil(periods_ns) as u64);
        self
    }

    /// The filter's configuration for a described robot: its IMU noise, its
    /// robot prior ([`RobotPrior::from_robot`]) and its flow sensor
    /// ([`FlowConfig::from_robot`]); a skid steer's effective track learned
    /// online ([`crate::wheel::skid::SkidConfig::new`] with the description's
    /// track and `track_factor`); every other setting of
    /// [`FilterConfig::default`]. Refuses an invalid description.
    pub fn from_robot(robot: &RobotDescription) -> Result<Self, RobotError> {
        robot.validate()?;
        Ok(FilterConfig {
            imu: ImuConfig {
                noise: robot.imu.noise,
                ..ImuConfig::default()
            },
            robot: RobotPrior::from_robot(robot),
            flow: robot
                .flow
                .as_ref()
                .map(FlowConfig::from_robot)
                .transpose()?,
            camera: robot
                .camera
                .as_ref()
                .map(|c| CameraConfig::from_mounts(&robot.imu.mount, c)),
            wheel: WheelConfig {
                skid: match robot.wheels.steering {
                    Steering::Skid => Some(SkidConfig::new(
                        robot.wheels.track,
                        robot.wheels.track_factor,
                    )),
                    Steering::Differential => None,
                },
                ..WheelConfig::DEFAULT
            },
            ..FilterConfig::default()
        })
    }
}

/// Why a configuration was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ConfigError {
    /// A noise density, standard deviation or random walk is not finite and positive.
    BadNoise,
    /// A wheel radius or gravity is not finite and positive, or a vector is not finite.
    BadGeometry,
    /// A step limit or a sample count is zero.
    BadLimit,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ConfigError::BadNoise => "noise parameters must be finite and positive",
            ConfigError::BadGeometry => "robot geometry and gravity must be finite (and positive)",
            ConfigError::BadLimit => "step limits and sample counts must be non-zero",
        })
    }
}

impl core::error::Error for ConfigError {}

fn positive(v: f32) -> bool {
    v.is_finite() && v > 0.0
}

impl FilterConfig {
    /// Checks every field once so the filter need not check again.
    pub fn check(&self) -> Result<(), ConfigError> {
        let n = &self.imu.noise;
        let i = &self.init;
        let z = &self.zupt;
        let r = &self.robot;
        let noise = [
            n.accel_density,
            n.gyro_density,
            n.accel_random_walk,
            n.gyro_random_walk,
            i.tilt_std,
            i.yaw_std,
            i.velocity_std,
            i.position_std,
            i.accel_bias_std,
            i.gyro_bias_std,
            i.gyro_scale_std,
            i.gravity_std,
            i.max_gyro,
            i.max_accel_deviation,
            z.max_wheel_rate,
            z.max_gyro,
            z.max_accel_deviation,
            z.velocity_std,
            z.position_std,
            z.attitude_std,
            r.contact_std,
            r.rotation_std,
            r.radius_std,
            r.radius_random_walk,
            r.contact_random_walk,
            r.rotation_random_walk,
            self.imu.gyro_max,
            self.imu.accel_max,
            self.imu.gyro_scale_random_walk,
            self.recovery.steady_tolerance,
            self.recovery.overrun_min_speed,
            self.gap.accel_density,
            self.gap.yaw_accel,
            self.gap.max_yaw_rate,
            self.gap.max_wheel_speed,
        ];
        let flow_noise = self
            .flow
            .map_or([1.0; 3], |f| [f.base_std, f.relative_std, f.gate]);
        let floor_noise = self.floor.map_or([1.0; 6], |f| {
            [
                f.height_std,
                f.height_huber,
                f.vertical_velocity_std,
                f.max_slope,
                f.climb_gate,
                f.level_change,
            ]
        });
        let camera_noise = self.camera.map_or([1.0; 5], |c| {
            [
                c.rotation_std,
                c.translation_rel_std,
                c.translation_std,
                c.rotation_gate,
                c.pose_gate,
            ]
        });
        let camera_mount_finite = self.camera.is_none_or(|c| {
            c.t_ic.iter().all(|v| v.is_finite()) && c.q_ic.coords.iter().all(|v| v.is_finite())
        });
        if self
            .floor
            .is_some_and(|f| f.every == 0 || f.reanchor_after == 0)
        {
            return Err(ConfigError::BadLimit);
        }
        if self
            .flow
            .is_some_and(|f| f.max_dt_ns == 0 || f.max_age_ns == 0 || f.window_ns == 0)
        {
            return Err(ConfigError::BadLimit);
        }
        // A minimum grip above every grip (or infinite) never trusts the wheels.
        let min_grip_ok = self.recovery.wheel_min_grip >= 0.0;
        // An infinite bound keeps any heading variance; NaN or zero none.
        if self.imu.max_heading_std.is_nan() || self.imu.max_heading_std <= 0.0 {
            return Err(ConfigError::BadNoise);
        }
        // NaN or a non-positive level would call every step an impact.
        if self.recovery.impact_accel.is_nan() || self.recovery.impact_accel <= 0.0 {
            return Err(ConfigError::BadLimit);
        }
        if self.wheel.skid.is_some_and(|s| !s.is_valid()) {
            return Err(ConfigError::BadNoise);
        }
        if self.vibration.is_some_and(|v| !v.is_valid()) {
            return Err(ConfigError::BadNoise);
        }
        if self.imu.plausibility.is_some_and(|p| !p.is_valid()) {
            return Err(ConfigError::BadLimit);
        }
        if !noise
            .iter()
            .chain(flow_noise.iter())
            .chain(floor_noise.iter())
            .chain(camera_noise.iter())
            .all(|v| positive(*v))
            || !min_grip_ok
        {
            return Err(ConfigError::BadNoise);
        }
        let vectors_finite = [&r.p_bl, &r.p_br]
            .iter()
            .all(|v| v.iter().all(|x| x.is_finite()))
            && r.q_rb.coords.iter().all(|x| x.is_finite());
        if !vectors_finite || !camera_mount_finite || !positive(r.radius) || !positive(self.gravity)
        {
            return Err(ConfigError::BadGeometry);
        }
        if self.imu.max_dt_ns == 0
            || self.wheel.max_dt_ns == 0
            || self.wheel.max_age_ns == 0
            || i.samples == 0
            || z.still_samples == 0
            || z.every == 0
        {
            return Err(ConfigError::BadLimit);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camera_mounting_is_seen_from_the_imu() {
        use vslam_core::geometry::Rot3;
        let imu = Extrinsics::new(
            Rot3::from_euler_angles(0.0, 0.0, 1.3),
            Vec3::new(0.05, 0.0, 0.08),
        )
        .unwrap();
        let camera = Extrinsics::new(
            Rot3::from_euler_angles(3.0, 0.1, -1.4),
            Vec3::new(0.0, 0.02, 0.10),
        )
        .unwrap();
        let c = CameraConfig::from_mounts(&imu, &camera);
        // A camera point seen through both mountings lands on the same
        // body point: R_BI (R_IC p + t_IC) + t_BI = R_BC p + t_BC.
        let p_c = Vec3::new(0.3, -0.2, 1.1);
        let via_imu = imu.point_to_body(&(c.q_ic * p_c + c.t_ic));
        let direct = camera.point_to_body(&p_c);
        assert!((via_imu - direct).norm() < 1e-5, "{via_imu} {direct}");
        let with = |c: CameraConfig| FilterConfig {
            camera: Some(c),
            ..FilterConfig::default()
        };
        assert_eq!(with(c).check(), Ok(()));
        let silent = CameraConfig {
            rotation_std: 0.0,
            ..c
        };
        assert_eq!(with(silent).check(), Err(ConfigError::BadNoise));
        let lost = CameraConfig {
            t_ic: Vec3::new(f32::NAN, 0.0, 0.0),
            ..c
        };
        assert_eq!(with(lost).check(), Err(ConfigError::BadGeometry));
    }

    #[test]
    fn a_heading_bound_must_leave_some_spread() {
        let with = |max_heading_std| FilterConfig {
            imu: ImuConfig {
                max_heading_std,
                ..ImuConfig::DEFAULT
            },
            ..FilterConfig::default()
        };
        assert_eq!(with(f32::INFINITY).check(), Ok(()));
        for bad in [0.0, -0.1, f32::NAN] {
            assert_eq!(with(bad).check(), Err(ConfigError::BadNoise), "{bad}");
        }
    }

    #[test]
    fn imu_rate_keeps_durations_and_bounds_the_step() {
        let d = FilterConfig::default();
        assert_eq!(d.with_wheel_rate(NOMINAL_WHEEL_RATE_HZ), d);
        assert_eq!(d.with_wheel_rate(f32::NAN), d);
        assert_eq!(d.with_wheel_rate(6.5).wheel.reexamine_after_gated, 3);
        assert_eq!(d.with_wheel_rate(0.1).wheel.reexamine_after_gated, 1);
        assert_eq!(d.with_wheel_rate(200.0).wheel.reexamine_after_gated, 100);
        assert_eq!(d.with_imu_rate(NOMINAL_IMU_RATE_HZ), d);
        assert_eq!(d.with_imu_rate(f32::NAN), d);
        assert_eq!(d.with_imu_rate(0.0), d);
        let c = d.with_imu_rate(30.0);
        assert_eq!(c.init.samples, 6, "0.2 s at 30 Hz");
        assert_eq!(c.zupt.still_samples, 6);
        assert_eq!(c.zupt.every, 1);
        assert_eq!(c.floor.map(|f| f.every), Some(3));
        assert_eq!(c.imu.max_dt_ns, 83_333_334, "2.5 periods of 33.3 ms");
        assert_eq!(c.check(), Ok(()));
        let c = d.with_imu_rate(100.0);
        assert_eq!((c.init.samples, c.zupt.every), (20, 4));
        assert_eq!(c.imu.max_dt_ns, 25_000_000);
        let c = d.with_imu_rate(1000.0);
        assert_eq!((c.init.samples, c.zupt.still_samples), (200, 200));
        assert_eq!(c.imu.max_dt_ns, MIN_MAX_IMU_DT_NS);
    }

    #[test]
    fn each_sensor_config_refuses_a_zero_time_limit() {
        let optics = FlowOptics::new(48.8, 0.03, Extrinsics::identity()).unwrap();
        let ok = FilterConfig {
            flow: Some(FlowConfig::new(optics)),
            ..FilterConfig::default()
        };
        assert_eq!(ok.check(), Ok(()));
        let zero: [&dyn Fn(&mut FilterConfig); 5] = [
            &|c| c.wheel.max_dt_ns = 0,
            &|c| c.wheel.max_age_ns = 0,
            &|c| c.flow.as_mut().unwrap().max_dt_ns = 0,
            &|c| c.flow.as_mut().unwrap().max_age_ns = 0,
            &|c| c.flow.as_mut().unwrap().window_ns = 0,
        ];
        for edit in zero {
            let mut c = ok;
            edit(&mut c);
            assert_eq!(c.check(), Err(ConfigError::BadLimit));
        }
    }
}
