//! The fault kinds: what each one does, which stream it hits, where it is
//! injected, and the outcome every sample it spoils must end in.

use traction::vslam_core::{Reject, Stream};

/// What a fault spoils: the samples of one stream of the registry, or the
/// robot's motion itself.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Target {
    /// The samples of one stream.
    Stream(Stream),
    /// The robot's motion itself (the truth changes; every sensor sees it).
    Motion,
}

impl Target {
    /// Name used in reports (`stream` of a fault in `report.json`): the
    /// stream's name, or `motion`.
    pub fn name(self) -> &'static str {
        match self {
            Target::Stream(s) => s.name(),
            Target::Motion => "motion",
        }
    }

    /// The stream, unless the fault changes the motion.
    pub fn stream(self) -> Option<Stream> {
        match self {
            Target::Stream(s) => Some(s),
            Target::Motion => None,
        }
    }
}

/// Where a fault is injected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Into the generated samples before the ASL log is written: replaying
    /// the written log reproduces it.
    Log,
    /// Into the sample stream between the log and the estimator: the ASL
    /// format cannot hold it (non-finite numbers, time stamps that do not
    /// strictly increase), so only `simulate` delivers it.
    Stream,
    /// Into a register-level chip simulator: the real driver sees it. Failed
    /// reads leave no row in the log; `simulate` hands them to the estimator.
    Chip,
    /// Into the rendered image files of the log.
    Image,
    /// Into the simulated world or the drive (the truth changes).
    Scenario,
}

impl Stage {
    /// Name used in reports.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Log => "log",
            Stage::Stream => "stream",
            Stage::Chip => "chip",
            Stage::Image => "image",
            Stage::Scenario => "scenario",
        }
    }
}

/// The outcome every spoiled sample must end in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Expected {
    /// Rejected, counted under this reason (`gated` included).
    Reject(Reject),
    /// Fused: the estimator cannot tell the value from a true one (a frozen
    /// camera frame is no motion seen), or it is low quality used as noise.
    Fused,
    /// Fused or gated: a plausible value the chi-square gate judges.
    FusedOrGated,
    /// Out of range, or gated when the spoiled value is still a possible
    /// one (a count increment a hundred times that of a robot starting
    /// from rest is a speed the wheels can have: the filter's gate
    /// refuses it).
    OutOfRangeOrGated,
    /// Out of range (a rate jump beyond the robot's angular acceleration),
    /// or saturated when the spoiled value is beyond the sensor's full
    /// scale (a hundredfold rate while the robot turns).
    OutOfRangeOrSaturated,
}

impl Expected {
    /// Name used in reports: a reason name, `fused` or `fused_or_gated`.
    pub fn name(self) -> &'static str {
        match self {
            Expected::Reject(r) => r.name(),
            Expected::Fused => "fused",
            Expected::FusedOrGated => "fused_or_gated",
            Expected::OutOfRangeOrGated => "out_of_range_or_gated",
            Expected::OutOfRangeOrSaturated => "out_of_range_or_saturated",
        }
    }

    /// Whether an observed outcome name (`fused` or a reason name) meets it.
    pub fn accepts(self, observed: &str) -> bool {
        match self {
            Expected::Reject(r) => observed == r.name(),
            Expected::Fused => observed == "fused",
            Expected::FusedOrGated => observed == "fused" || observed == "gated",
            Expected::OutOfRangeOrGated => {
                observed == Reject::OutOfRange.name() || observed == Reject::Gated.name()
            }
            Expected::OutOfRangeOrSaturated => {
                observed == Reject::OutOfRange.name() || observed == Reject::Saturated.name()
            }
        }
    }
}

/// The sensor a time fault applies to: the streams of the estimator's
/// ordering buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Sensor {
    /// The IMU.
    Imu,
    /// The wheel encoders.
    Wheel,
    /// The flow sensor.
    Flow,
}

impl Sensor {
    /// Its stream.
    pub const fn stream(self) -> Stream {
        match self {
            Sensor::Imu => Stream::Imu,
            Sensor::Wheel => Stream::Wheel,
            Sensor::Flow => Stream::Flow,
        }
    }
}

/// Every fault the injector knows. See [`FaultKind::ALL`] and
/// [`FaultKind::help`] for the command-line names and what each one does.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FaultKind {
    /// One IMU field (gyro x) NaN, in `count` samples.
    ImuNan,
    /// One IMU field (accel y) +infinity, in `count` samples.
    ImuInf,
    /// One IMU sample's gyro z multiplied by 100.
    ImuOutlier,
    /// Gyro z at the configured full scale for the whole window.
    ImuSaturated,
    /// The IMU repeats its last reading for the window.
    ImuStuck,
    /// One wheel sample's count increment multiplied by 100.
    WheelOutlier,
    /// The wheel counts stay at their last value for the window.
    WheelStuck,
    /// One flow report's counts multiplied by 100.
    FlowOutlier,
    /// The flow sensor repeats its last report for the window.
    FlowStuck,
    /// Flow counts at the 16-bit limit in `count` reports.
    FlowLimit,
    /// SQUAL 10..24 with a normal shutter for the window (valid per the datasheet: noise).
    FlowLowSqual,
    /// A textureless floor: zero motion, SQUAL 5, shutter at its top.
    FlowTextureless,
    /// A sample delivered twice (same time stamp, same values).
    Duplicate(Sensor),
    /// A sample stamped with the previous sample's time (dt = 0).
    ZeroDt(Sensor),
    /// A sample delivered 60 ms late, after the ordering window.
    Late(Sensor),
    /// The sensor silent for the window: its samples never arrive.
    Gap(Sensor),
    /// SPI errors on the left encoder's bus, `count` reads.
    WheelSpi,
    /// SPI errors on the flow chip's bus, `count` reads.
    FlowSpi,
    /// The flow chip browns out: it answers zeros (wrong product id) until reset.
    FlowBrownout,
    /// A parity error in the left encoder's answer, `count` reads.
    WheelParity,
    /// The left encoder reports a framing error (EF, ERRFL), `count` reads.
    WheelErrorFlag,
    /// The left wheel spins freely at 0.6 turns per read: the 14-bit angle aliases.
    WheelWrap,
    /// Black camera frames.
    CamBlack,
    /// Saturated (white) camera frames.
    CamSaturated,
    /// Uniform mid-grey camera frames.
    CamUniform,
    /// Heavily blurred camera frames (box blur, radius 8, three passes).
    CamBlur,
    /// A camera frame identical to the previous one.
    CamFrozen,
    /// Segmentation maps without any ground class (all wall).
    SegNoGround,
    /// Segmentation maps with only unknown labels.
    SegUnknown,
    /// Wheels turn, the robot is stuck.
    Stuck,
    /// The robot is lifted: wheels spin free, the flow sensor loses the floor.
    Lifted,
    /// A cable on the floor where the robot is at the start time.
    Bump,
}

impl FaultKind {
    /// Every kind, in help order.
    pub const ALL: [FaultKind; 40] = [
        FaultKind::ImuNan,
        FaultKind::ImuInf,
        FaultKind::ImuOutlier,
        FaultKind::ImuSaturated,
        FaultKind::ImuStuck,
        FaultKind::WheelOutlier,
        FaultKind::WheelStuck,
        FaultKind::FlowOutlier,
        FaultKind::FlowStuck,
        FaultKind::FlowLimit,
        FaultKind::FlowLowSqual,
        FaultKind::FlowTextureless,
        FaultKind::Duplicate(Sensor::Imu),
        FaultKind::Duplicate(Sensor::Wheel),
        FaultKind::Duplicate(Sensor::Flow),
        FaultKind::ZeroDt(Sensor::Imu),
        FaultKind::ZeroDt(Sensor::Wheel),
        FaultKind::ZeroDt(Sensor::Flow),
        FaultKind::Late(Sensor::Imu),
        FaultKind::Late(Sensor::Wheel),
        FaultKind::Late(Sensor::Flow),
        FaultKind::Gap(Sensor::Imu),
        FaultKind::Gap(Sensor::Wheel),
        FaultKind::Gap(Sensor::Flow),
        FaultKind::WheelSpi,
        FaultKind::FlowSpi,
        FaultKind::FlowBrownout,
        FaultKind::WheelParity,
        FaultKind::WheelErrorFlag,
        FaultKind::WheelWrap,
        FaultKind::CamBlack,
        FaultKind::CamSaturated,
        FaultKind::CamUniform,
        FaultKind::CamBlur,
        FaultKind::CamFrozen,
        FaultKind::SegNoGround,
        FaultKind::SegUnknown,
        FaultKind::Stuck,
        FaultKind::Lifted,
        FaultKind::Bump,
    ];

    /// The command-line name.
    pub fn name(self) -> String {
        let s = |x: Sensor| x.stream().name();
        match self {
            FaultKind::ImuNan => "imu-nan".into(),
            FaultKind::ImuInf => "imu-inf".into(),
            FaultKind::ImuOutlier => "imu-outlier".into(),
            FaultKind::ImuSaturated => "imu-saturated".into(),
            FaultKind::ImuStuck => "imu-stuck".into(),
            FaultKind::WheelOutlier => "wheel-outlier".into(),
            FaultKind::WheelStuck => "wheel-stuck".into(),
            FaultKind::FlowOutlier => "flow-outlier".into(),
            FaultKind::FlowStuck => "flow-stuck".into(),
            FaultKind::FlowLimit => "flow-limit".into(),
            FaultKind::FlowLowSqual => "flow-lowsqual".into(),
            FaultKind::FlowTextureless => "flow-textureless".into(),
            FaultKind::Duplicate(x) => format!("{}-dup", s(x)),
            FaultKind::ZeroDt(x) => format!("{}-dt0", s(x)),
            FaultKind::Late(x) => format!("{}-late", s(x)),
            FaultKind::Gap(x) => format!("{}-gap", s(x)),
            FaultKind::WheelSpi => "wheel-spi".into(),
            FaultKind::FlowSpi => "flow-spi".into(),
            FaultKind::FlowBrownout => "flow-brownout".into(),
            FaultKind::WheelParity => "wheel-parity".into(),
            FaultKind::WheelErrorFlag => "wheel-errflag".into(),
            FaultKind::WheelWrap => "wheel-wrap".into(),
            FaultKind::CamBlack => "cam-black".into(),
            FaultKind::CamSaturated => "cam-saturated".into(),
            FaultKind::CamUniform => "cam-uniform".into(),
            FaultKind::CamBlur => "cam-blur".into(),
            FaultKind::CamFrozen => "cam-frozen".into(),
            FaultKind::SegNoGround => "seg-noground".into(),
            FaultKind::SegUnknown => "seg-unknown".into(),
            FaultKind::Stuck => "stuck".into(),
            FaultKind::Lifted => "lifted".into(),
            FaultKind::Bump => "bump".into(),
        }
    }

    /// The kind called `name` on the command line.
    pub fn from_name(name: &str) -> Option<FaultKind> {
        FaultKind::ALL.iter().copied().find(|k| k.name() == name)
    }

    /// What it spoils.
    pub fn target(self) -> Target {
        use FaultKind::*;
        Target::Stream(match self {
            ImuNan | ImuInf | ImuOutlier | ImuSaturated | ImuStuck => Stream::Imu,
            WheelOutlier | WheelStuck | WheelSpi | WheelParity | WheelErrorFlag | WheelWrap => {
                Stream::Wheel
            }
            FlowOutlier | FlowStuck | FlowLimit | FlowLowSqual | FlowTextureless | FlowSpi
            | FlowBrownout => Stream::Flow,
            Duplicate(s) | ZeroDt(s) | Late(s) | Gap(s) => s.stream(),
            CamBlack | CamSaturated | CamUniform | CamBlur | CamFrozen => Stream::Camera,
            SegNoGround | SegUnknown => Stream::Segmentation,
            Stuck | Lifted | Bump => return Target::Motion,
        })
    }

    /// The stream it spoils (`None` for a fault of the motion).
    pub fn stream(self) -> Option<Stream> {
        self.target().stream()
    }

    /// Where it is injected.
    pub fn stage(self) -> Stage {
        use FaultKind::*;
        match self {
            ImuNan | ImuInf | Duplicate(_) | ZeroDt(_) | Late(_) => Stage::Stream,
            ImuOutlier | ImuSaturated | ImuStuck | WheelOutlier | WheelStuck | FlowOutlier
            | FlowStuck | FlowLimit | FlowLowSqual | FlowTextureless | Gap(_) => Stage::Log,
            WheelSpi | FlowSpi | FlowBrownout | WheelParity | WheelErrorFlag | WheelWrap => {
                Stage::Chip
            }
            CamBlack | CamSaturated | CamUniform | CamBlur | CamFrozen | SegNoGround
            | SegUnknown => Stage::Image,
            Stuck | Lifted | Bump => Stage::Scenario,
        }
    }

    /// What every spoiled sample must end in. Motion faults name the wheel
    /// samples of the window (see [`FaultKind::help`]).
    pub fn expected(self) -> Expected {
        use FaultKind::*;
        match self {
            ImuNan | ImuInf => Expected::Reject(Reject::NonFinite),
            ImuOutlier => Expected::OutOfRangeOrSaturated,
            ImuStuck => Expected::Reject(Reject::LowQuality),
            ImuSaturated | FlowLimit => Expected::Reject(Reject::Saturated),
            WheelOutlier => Expected::OutOfRangeOrGated,
            WheelWrap => Expected::Reject(Reject::OutOfRange),
            WheelStuck | FlowStuck | FlowLowSqual => Expected::FusedOrGated,
            FlowOutlier | Stuck => Expected::Reject(Reject::Gated),
            FlowTextureless | CamBlack | CamSaturated | CamUniform | CamBlur | SegNoGround
            | SegUnknown => Expected::Reject(Reject::LowQuality),
            CamFrozen => Expected::Fused,
            Duplicate(_) | ZeroDt(_) => Expected::Reject(Reject::Duplicate),
            Late(_) => Expected::Reject(Reject::OutOfOrder),
            Gap(_) => Expected::Reject(Reject::Gap),
            WheelSpi | FlowSpi => Expected::Reject(Reject::Bus),
            FlowBrownout | WheelParity | WheelErrorFlag => Expected::Reject(Reject::Integrity),
            Lifted => Expected::Reject(Reject::Gated),
            Bump => Expected::Fused,
        }
    }

    /// Default window, seconds (0: instantaneous, `count` samples).
    pub fn default_duration(self) -> f64 {
        use FaultKind::*;
        match self {
            ImuSaturated | ImuStuck | WheelStuck | FlowStuck | FlowLowSqual | FlowTextureless => {
                0.5
            }
            Gap(_) => 0.5,
            WheelWrap => 0.1,
            Stuck | Lifted => 2.0,
            _ => 0.0,
        }
    }

    /// One line of help.
    pub fn help(self) -> &'static str {
        use FaultKind::*;
        match self {
            ImuNan => "gyro x NaN in COUNT samples -> non_finite",
            ImuInf => "accel y +inf in COUNT samples -> non_finite",
            ImuOutlier => {
                "gyro z x100 in COUNT samples -> out_of_range (a rate or yaw-rate jump the robot cannot make; saturated beyond full scale; a spike within twice the allowed change is not judged)"
            }
            ImuSaturated => "gyro z at full scale for DUR (default 0.5 s) -> saturated",
            ImuStuck => {
                "IMU repeats its last reading for DUR (0.5 s) -> low_quality once 20 ms old (a frozen output; earlier repeats are not judged)"
            }
            WheelOutlier => {
                "count increment x100 in COUNT samples -> out_of_range (gated when still a possible speed)"
            }
            WheelStuck => "counts frozen for DUR (0.5 s) -> fused_or_gated",
            FlowOutlier => "counts x100 in COUNT reports -> gated",
            FlowStuck => "repeats its last report for DUR (0.5 s) -> fused_or_gated",
            FlowLimit => "dx at the 16-bit limit in COUNT reports -> saturated",
            FlowLowSqual => {
                "SQUAL 10..24, shutter normal, for DUR (0.5 s) -> fused_or_gated (noise)"
            }
            FlowTextureless => {
                "zero motion, SQUAL 5, shutter at its top for DUR (0.5 s) -> low_quality"
            }
            Duplicate(_) => "COUNT samples delivered twice -> duplicate",
            ZeroDt(_) => "COUNT samples stamped with the previous time (dt = 0) -> duplicate",
            Late(_) => "COUNT samples delivered 60 ms late -> out_of_order",
            Gap(_) => {
                "silent for DUR (default 0.5 s; 5 s for a long silence): the next sample -> gap"
            }
            WheelSpi => "SPI errors on COUNT left-encoder reads -> bus",
            FlowSpi => "SPI errors on COUNT flow reads -> bus",
            FlowBrownout => {
                "chip browns out (zeros, wrong product id) until the driver resets it -> integrity"
            }
            WheelParity => "parity error in COUNT left-encoder answers -> integrity",
            WheelErrorFlag => "framing error (EF, ERRFL) on COUNT left-encoder reads -> integrity",
            WheelWrap => {
                "left wheel spins free 0.6 turns per read for DUR (0.1 s): the driver's counter refuses the jump -> out_of_range"
            }
            CamBlack => {
                "COUNT black frames -> low_quality (the next good frame is measured against the last good one)"
            }
            CamSaturated => {
                "COUNT white frames -> low_quality (the next good frame is measured against the last good one)"
            }
            CamUniform => {
                "COUNT mid-grey frames -> low_quality (the next good frame is measured against the last good one)"
            }
            CamBlur => {
                "COUNT heavily blurred frames -> low_quality (the next good frame is measured against the last good one)"
            }
            CamFrozen => "COUNT frames identical to the previous one -> fused (no motion seen)",
            SegNoGround => "COUNT label maps with no ground class -> low_quality",
            SegUnknown => "COUNT label maps of unknown labels only -> low_quality",
            Stuck => "wheels turn, robot stuck for DUR (2 s): wheel samples -> gated",
            Lifted => "robot lifted for DUR (2 s), wheels spin free: wheel samples -> gated",
            Bump => "a cable (12 mm) under the robot at START -> fused (a jolt event)",
        }
    }

    /// Whether the kind takes a window (`+DUR`) rather than a count.
    pub fn has_window(self) -> bool {
        self.default_duration() > 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_fault_names_a_stream_of_the_registry_or_the_motion() {
        for k in FaultKind::ALL {
            match k.target() {
                Target::Stream(s) => {
                    assert_eq!(Stream::from_name(k.target().name()), Some(s));
                    assert_eq!(k.stream(), Some(s));
                }
                Target::Motion => {
                    assert_eq!(k.target().name(), "motion");
                    assert_eq!(k.stream(), None);
                }
            }
        }
        // Time faults hit the buffered streams, named as the registry names them.
        for x in [Sensor::Imu, Sensor::Wheel, Sensor::Flow] {
            let name = FaultKind::Late(x).name();
            assert_eq!(name, format!("{}-late", x.stream().name()));
            assert_eq!(FaultKind::from_name(&name), Some(FaultKind::Late(x)));
        }
    }
}
