//! The robot description: the one place a robot's geometry, its sensors'
//! mountings and their noise are written down.
//!
//! Every configuration of the estimator that depends on the robot (the wheel
//! odometry, the EKF's robot prior and flow model, the scale pipeline's
//! mountings) is derived from one [`RobotDescription`], so a wheel radius or
//! a mounting exists once. Frames follow [`crate::geometry`]: the body `B` is
//! x forward, y left, z up, origin mid-axle on the floor; a sensor `S` is
//! mounted by `T_BS` (`p_B = R_BS p_S + t_BS`, ASL/EuRoC `sensor.yaml`).
//!
//! [`RobotDescription::validate`] refuses an inconsistent description with a
//! [`RobotError`]; [`RobotDescription::robot_vacuum`] is a typical robot
//! vacuum (35 mm wheels, 230 mm track, 14-bit encoders, a BMI088-class IMU,
//! a PAA5100JE flow sensor 30 mm above the floor, an upward camera).
//!
//! A new robot is one literal:
//!
//! ```
//! use vslam_core::geometry::{Extrinsics, Rot3, Vec3};
//! use vslam_core::robot::{
//!     ImuDescription, ImuNoise, RobotDescription, RobotError, Steering, Wheels,
//! };
//!
//! let robot = RobotDescription {
//!     wheels: Wheels {
//!         radius_left: 0.05,
//!         radius_right: 0.05,
//!         track: 0.30,
//!         track_factor: 1.0,
//!         steering: Steering::Differential,
//!         counts_per_revolution: 4096,
//!         max_rim_speed: 2.0,
//!         path_relative_std: 0.02,
//!     },
//!     imu: ImuDescription {
//!         // 5 cm ahead of the axle, 8 cm up, turned 90 degrees about z.
//!         mount: Extrinsics::new(
//!             Rot3::from_axis_angle(&Vec3::z_axis(), core::f32::consts::FRAC_PI_2),
//!             Vec3::new(0.05, 0.0, 0.08),
//!         )
//!         .unwrap(),
//!         noise: ImuNoise::default(),
//!     },
//!     flow: None,
//!     camera: None,
//! };
//! assert_eq!(robot.validate(), Ok(()));
//!
//! let mut broken = robot;
//! broken.wheels.radius_right = 0.0;
//! assert_eq!(broken.validate(), Err(RobotError::BadWheelRadius));
//! ```

use core::fmt;

use crate::geometry::{Extrinsics, Mat3};

/// IMU noise densities and bias random walks (continuous time), as in a
/// Kalibr / EuRoC `imu.yaml`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuNoise {
    /// Accelerometer white noise density, m/s^2/sqrt(Hz).
    pub accel_density: f32,
    /// Gyroscope white noise density, rad/s/sqrt(Hz).
    pub gyro_density: f32,
    /// Accelerometer bias random walk, m/s^3/sqrt(Hz).
    pub accel_random_walk: f32,
    /// Gyroscope bias random walk, rad/s^2/sqrt(Hz).
    pub gyro_random_walk: f32,
}

impl Default for ImuNoise {
    /// A consumer MEMS IMU (BMI088 / ICM-42688 class).
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl ImuNoise {
    /// The defaults ([`Default::default`]) as a constant, for `const` construction.
    pub const DEFAULT: Self = ImuNoise {
        accel_density: 2.0e-3,
        gyro_density: 2.0e-4,
        accel_random_walk: 3.0e-4,
        gyro_random_walk: 2.0e-5,
    };
}

/// How the robot steers with its two sides' wheels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Steering {
    /// A differential drive: two wheels that roll without scrubbing; the
    /// turn rate from the wheel speeds over the track holds on any floor.
    #[default]
    Differential,
    /// A skid steer (four or more wheels or tracks, as the Clearpath
    /// Husky): the wheels scrub sideways in a turn, so the robot turns as if
    /// its wheels were further apart than they are, by a factor that
    /// changes with the floor (Mandow et al., "Experimental kinematics for
    /// wheeled skid-steer mobile robots", IROS 2007: the expansion factor
    /// `chi`). [`Wheels::track_factor`] is its nominal value; the estimator
    /// learns the floor's.
    Skid,
}

impl Steering {
    /// Its name in a robot description file (`differential`, `skid`).
    pub const fn name(self) -> &'static str {
        match self {
            Steering::Differential => "differential",
            Steering::Skid => "skid",
        }
    }
}

/// The drive wheels of a differential-drive (or skid-steer) robot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wheels {
    /// Left wheel radius, m.
    pub radius_left: f32,
    /// Right wheel radius, m.
    pub radius_right: f32,
    /// Distance between the wheels' contact points, m; the contact points
    /// are at `(0, ±track / 2, 0)` in the body frame.
    pub track: f32,
    /// Effective track over geometric track, 1: 1 for a differential drive,
    /// above 1 for a skid steer whose wheels scrub in a turn (the turn rate
    /// from the wheel speeds is as if the wheels were this much further apart).
    pub track_factor: f32,
    /// Differential drive or skid steer.
    pub steering: Steering,
    /// Encoder counts per wheel revolution.
    pub counts_per_revolution: u32,
    /// Fastest possible wheel rim speed, m/s; faster steps are glitches.
    pub max_rim_speed: f32,
    /// Relative standard deviation of the wheel path without slip, 1.
    pub path_relative_std: f32,
}

impl Wheels {
    /// The track the wheel kinematics use: `track * track_factor`, m.
    pub fn kinematic_track(&self) -> f32 {
        self.track * self.track_factor
    }

    /// The mean of the two radii, m.
    pub fn mean_radius(&self) -> f32 {
        0.5 * (self.radius_left + self.radius_right)
    }
}

/// The IMU: its mounting and noise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuDescription {
    /// `T_BS` of the IMU.
    pub mount: Extrinsics,
    /// Noise densities and random walks.
    pub noise: ImuNoise,
}

/// A downward optical-flow sensor: mounting, optics and noise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlowDescription {
    /// `T_BS` of the sensor (its z axis looks at the floor).
    pub mount: Extrinsics,
    /// Height of the sensor's optics above the floor, m (usually `t_BS` z).
    pub height: f32,
    /// Counts per radian of angular flow.
    pub counts_per_radian: f32,
    /// Velocity noise at good image quality, m/s.
    pub base_std: f32,
    /// Relative velocity noise (height and resolution error), 1.
    pub relative_std: f32,
}

impl FlowDescription {
    /// The robot vacuum's flow sensor: a PAA5100JE 10 cm ahead of the axle,
    /// 30 mm above the floor, looking down (sensor x = body x, y = -y,
    /// z = -z), 48.8 counts per radian, 1 cm/s and 3 % velocity noise.
    pub fn robot_vacuum() -> Self {
        FlowDescription {
            mount: mount(&[
                1.0, 0.0, 0.0, 0.10, //
                0.0, -1.0, 0.0, 0.0, //
                0.0, 0.0, -1.0, 0.03, //
                0.0, 0.0, 0.0, 1.0,
            ]),
            height: 0.03,
            counts_per_radian: 48.8,
            base_std: 0.01,
            relative_std: 0.03,
        }
    }
}

/// Everything about a robot the estimator must know: wheels, sensor
/// mountings and sensor noise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RobotDescription {
    /// The drive wheels and their encoders.
    pub wheels: Wheels,
    /// The IMU.
    pub imu: ImuDescription,
    /// The downward flow sensor, if fitted.
    pub flow: Option<FlowDescription>,
    /// `T_BS` of the VSLAM camera, if fitted.
    pub camera: Option<Extrinsics>,
}

/// A mounted sensor, named in a [`RobotError`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MountedSensor {
    /// The IMU.
    Imu,
    /// The flow sensor.
    Flow,
    /// The camera.
    Camera,
}

impl MountedSensor {
    /// The sensor's name.
    pub const fn name(self) -> &'static str {
        match self {
            MountedSensor::Imu => "IMU",
            MountedSensor::Flow => "flow sensor",
            MountedSensor::Camera => "camera",
        }
    }
}

/// Why a robot description was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RobotError {
    /// A wheel radius is not finite and positive.
    BadWheelRadius,
    /// The track is not finite and positive.
    BadTrack,
    /// The effective-track factor is not finite and at least 1.
    BadTrackFactor,
    /// The encoder resolution is zero counts per revolution.
    BadEncoderResolution,
    /// The fastest wheel rim speed is not finite and positive.
    BadMaxRimSpeed,
    /// A mounting has a non-finite entry.
    NonFiniteMount(MountedSensor),
    /// A mounting's rotation is not a proper rotation (orthonormal, det +1).
    NotARotation(MountedSensor),
    /// The flow sensor's height is not finite and positive, or its origin is
    /// below the floor.
    FlowBelowFloor,
    /// The flow sensor's counts per radian are not finite and positive.
    BadFlowResolution,
    /// A noise density, random walk or standard deviation of this sensor is
    /// not finite and positive (`None`: the wheels).
    BadNoise(Option<MountedSensor>),
}

impl fmt::Display for RobotError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RobotError::BadWheelRadius => f.write_str("wheel radii must be finite and positive"),
            RobotError::BadTrack => f.write_str("the track must be finite and positive"),
            RobotError::BadTrackFactor => {
                f.write_str("the effective-track factor must be finite and at least 1")
            }
            RobotError::BadEncoderResolution => {
                f.write_str("encoder counts per revolution must be non-zero")
            }
            RobotError::BadMaxRimSpeed => {
                f.write_str("the fastest wheel rim speed must be finite and positive")
            }
            RobotError::NonFiniteMount(s) => write!(f, "the {} mounting is not finite", s.name()),
            RobotError::NotARotation(s) => {
                write!(f, "the {} mounting's rotation is not a rotation", s.name())
            }
            RobotError::FlowBelowFloor => {
                f.write_str("the flow sensor must be above the floor (positive height)")
            }
            RobotError::BadFlowResolution => {
                f.write_str("flow counts per radian must be finite and positive")
            }
            RobotError::BadNoise(s) => write!(
                f,
                "{} noise must be finite and positive",
                s.map_or("wheel", MountedSensor::name)
            ),
        }
    }
}

impl core::error::Error for RobotError {}

fn positive(v: f32) -> bool {
    v.is_finite() && v > 0.0
}

fn check_mount(mount: &Extrinsics, sensor: MountedSensor) -> Result<(), RobotError> {
    let m: &Mat3 = mount.r_bs().matrix();
    if !m.iter().chain(mount.t_bs().iter()).all(|v| v.is_finite()) {
        return Err(RobotError::NonFiniteMount(sensor));
    }
    let tol = Extrinsics::ROTATION_TOLERANCE;
    let err = (m.transpose() * m - Mat3::identity()).abs().max();
    if err > tol || libm::fabsf(m.determinant() - 1.0) > tol {
        return Err(RobotError::NotARotation(sensor));
    }
    Ok(())
}

/// A mounting from a row-major `T_BS` known to be rigid; identity if it were not
/// (the presets' tests check that it is).
fn mount(data: &[f32; 16]) -> Extrinsics {
    Extrinsics::from_row_major(data).unwrap_or_default()
}

impl RobotDescription {
    /// Checks the description: positive finite geometry and noise, proper
    /// rotations, a flow sensor above the floor.
    pub fn validate(&self) -> Result<(), RobotError> {
        let w = &self.wheels;
        if !(positive(w.radius_left) && positive(w.radius_right)) {
            return Err(RobotError::BadWheelRadius);
        }
        if !positive(w.track) {
            return Err(RobotError::BadTrack);
        }
        if !(w.track_factor.is_finite() && w.track_factor >= 1.0) {
            return Err(RobotError::BadTrackFactor);
        }
        if w.counts_per_revolution == 0 {
            return Err(RobotError::BadEncoderResolution);
        }
        if !positive(w.max_rim_speed) {
            return Err(RobotError::BadMaxRimSpeed);
        }
        if !positive(w.path_relative_std) {
            return Err(RobotError::BadNoise(None));
        }
        check_mount(&self.imu.mount, MountedSensor::Imu)?;
        let n = &self.imu.noise;
        if ![
            n.accel_density,
            n.gyro_density,
            n.accel_random_walk,
            n.gyro_random_walk,
        ]
        .iter()
        .all(|v| positive(*v))
        {
            return Err(RobotError::BadNoise(Some(MountedSensor::Imu)));
        }
        if let Some(flow) = &self.flow {
            check_mount(&flow.mount, MountedSensor::Flow)?;
            if !positive(flow.height) || flow.mount.t_bs().z < 0.0 {
                return Err(RobotError::FlowBelowFloor);
            }
            if !positive(flow.counts_per_radian) {
                return Err(RobotError::BadFlowResolution);
            }
            if !(positive(flow.base_std) && positive(flow.relative_std)) {
                return Err(RobotError::BadNoise(Some(MountedSensor::Flow)));
            }
        }
        if let Some(camera) = &self.camera {
            check_mount(camera, MountedSensor::Camera)?;
        }
        Ok(())
    }

    /// A typical robot vacuum, the robot host-sim simulates: 35 mm wheels,
    /// 230 mm track, AS5047P encoders (16 384 counts per revolution), rims
    /// up to 3 m/s; a BMI088-class IMU at the body origin; a PAA5100JE flow
    /// sensor 10 cm ahead of the axle, 30 mm above the floor, looking down
    /// (sensor x = body x, y = -y, z = -z); a ceiling camera 10 cm above the
    /// axle (camera x = body -y, y = body x, z = up).
    pub fn robot_vacuum() -> Self {
        RobotDescription {
            wheels: Wheels {
                radius_left: 0.035,
                radius_right: 0.035,
                track: 0.23,
                track_factor: 1.0,
                steering: Steering::Differential,
                counts_per_revolution: 16_384,
                max_rim_speed: 3.0,
                path_relative_std: 0.02,
            },
            imu: ImuDescription {
                mount: Extrinsics::identity(),
                noise: ImuNoise {
                    accel_density: 1.7e-3,
                    gyro_density: 2.4e-4,
                    accel_random_walk: 3.0e-4,
                    gyro_random_walk: 2.0e-5,
                },
            },
            flow: Some(FlowDescription::robot_vacuum()),
            camera: Some(mount(&[
                0.0, 1.0, 0.0, 0.0, //
                -1.0, 0.0, 0.0, 0.0, //
                0.0, 0.0, 1.0, 0.10, //
                0.0, 0.0, 0.0, 1.0,
            ])),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Rot3, Vec3};

    #[test]
    fn robot_vacuum_is_valid_and_its_mounts_are_not_the_fallback() {
        let r = RobotDescription::robot_vacuum();
        assert_eq!(r.validate(), Ok(()));
        let flow = r.flow.unwrap();
        assert_eq!(*flow.mount.t_bs(), Vec3::new(0.10, 0.0, 0.03));
        let down = flow.mount.vector_to_body(&Vec3::z());
        // `from_row_major` re-orthonormalises iteratively: close, not exact.
        assert!((down - Vec3::new(0.0, 0.0, -1.0)).norm() < 1e-5);
        let camera = r.camera.unwrap();
        assert_eq!(camera.t_bs().z, 0.10);
        let x_c = camera.vector_to_body(&Vec3::x());
        assert!((x_c - Vec3::new(0.0, -1.0, 0.0)).norm() < 1e-5);
        assert_eq!(r.wheels.kinematic_track(), 0.23);
        assert_eq!(r.wheels.mean_radius(), 0.035);
    }

    #[test]
    fn inconsistent_descriptions_are_refused_with_their_reason() {
        let ok = RobotDescription::robot_vacuum();
        let refused = |edit: &dyn Fn(&mut RobotDescription)| {
            let mut r = ok;
            edit(&mut r);
            r.validate().unwrap_err()
        };
        assert_eq!(
            refused(&|r| r.wheels.radius_left = 0.0),
            RobotError::BadWheelRadius
        );
        assert_eq!(
            refused(&|r| r.wheels.radius_right = f32::NAN),
            RobotError::BadWheelRadius
        );
        assert_eq!(refused(&|r| r.wheels.track = -0.2), RobotError::BadTrack);
        assert_eq!(
            refused(&|r| r.wheels.track = f32::INFINITY),
            RobotError::BadTrack
        );
        assert_eq!(
            refused(&|r| r.wheels.track_factor = 0.9),
            RobotError::BadTrackFactor
        );
        assert_eq!(
            refused(&|r| r.wheels.counts_per_revolution = 0),
            RobotError::BadEncoderResolution
        );
        assert_eq!(
            refused(&|r| r.wheels.max_rim_speed = 0.0),
            RobotError::BadMaxRimSpeed
        );
        assert_eq!(
            refused(&|r| r.imu.noise.gyro_density = 0.0),
            RobotError::BadNoise(Some(MountedSensor::Imu))
        );
        // A scaled matrix is no rotation, though nalgebra lets it be built.
        let squashed = Rot3::from_matrix_unchecked(Mat3::identity() * 1.1);
        let bad_mount = Extrinsics::new(squashed, Vec3::zeros()).unwrap();
        assert_eq!(
            refused(&|r| r.imu.mount = bad_mount),
            RobotError::NotARotation(MountedSensor::Imu)
        );
        let nan_rotation = Rot3::from_matrix_unchecked(Mat3::identity() * f32::NAN);
        assert_eq!(
            Extrinsics::new(nan_rotation, Vec3::zeros()),
            Err(crate::geometry::TransformError::NonFinite)
        );
        assert_eq!(
            refused(&|r| r.camera = Some(bad_mount)),
            RobotError::NotARotation(MountedSensor::Camera)
        );
        assert_eq!(
            refused(&|r| {
                let f = r.flow.as_mut().unwrap();
                f.mount = Extrinsics::new(*f.mount.r_bs(), Vec3::new(0.1, 0.0, -0.01)).unwrap();
            }),
            RobotError::FlowBelowFloor
        );
        assert_eq!(
            refused(&|r| r.flow.as_mut().unwrap().height = 0.0),
            RobotError::FlowBelowFloor
        );
        assert_eq!(
            refused(&|r| r.flow.as_mut().unwrap().counts_per_radian = f32::NAN),
            RobotError::BadFlowResolution
        );
        assert_eq!(
            refused(&|r| r.flow.as_mut().unwrap().relative_std = -0.1),
            RobotError::BadNoise(Some(MountedSensor::Flow))
        );
        // Without a flow sensor or camera there is nothing of theirs to refuse.
        let mut bare = ok;
        bare.flow = None;
        bare.camera = None;
        assert_eq!(bare.validate(), Ok(()));
    }

    #[test]
    fn errors_say_what_is_wrong() {
        extern crate std;
        use std::string::ToString;
        assert_eq!(
            RobotError::NotARotation(MountedSensor::Flow).to_string(),
            "the flow sensor mounting's rotation is not a rotation"
        );
        assert_eq!(
            RobotError::BadNoise(None).to_string(),
            "wheel noise must be finite and positive"
        );
    }
}
