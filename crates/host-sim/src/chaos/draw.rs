//! Drawing a chaos plan: faults of every kind at random times, at a seeded
//! rate, several at once at times.
//!
//! Arrivals are a Poisson process ([`ChaosConfig::per_minute`]); a third of
//! the faults are placed inside the window of the one before, so that
//! faults overlap. Each fault occupies the sensors its judgement depends on
//! ([`occupies`]) from half a second before its window to a second after;
//! two faults that occupy a common sensor at the same time are not drawn
//! together (the second is drawn again elsewhere), because the outcome each
//! spoiled sample must end in is defined for one fault on a stream: a NaN
//! in a sample that is also a duplicate has two right answers. Faults on
//! different sensors overlap freely: the camera blurred while the flow
//! chip browns out and the wheels lose SPI frames.
//!
//! Stuck and lifted windows fall only where the drive goes straight or
//! along an arc (a stuck robot turning on the spot would be a different
//! fault) and away from the scenario's slip episodes; a cable (`bump`)
//! only where the drive goes straight.

use crate::faults::{FaultKind, FaultPlan, FaultSpec, Sensor};
use crate::sim::scenario::Scenario;
use crate::sim::script::Segment;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// What a chaos run draws.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChaosConfig {
    /// Seed of the draw.
    pub seed: u64,
    /// Length of the run, seconds.
    pub duration_s: f64,
    /// Mean number of faults per minute.
    pub per_minute: f64,
}

/// Faults start no earlier than this (the filter initialises at rest first), s.
pub const FIRST_S: f64 = 5.0;
/// ... and end this long before the end of the run (the recovery is judged
/// 2 s after a fault), s.
pub const LAST_MARGIN_S: f64 = 6.0;
/// Share of faults placed inside the previous fault's window.
pub const OVERLAP_SHARE: f64 = 1.0 / 3.0;

/// The sensors a fault's judgement depends on, as a bit set (IMU 1, wheels
/// 2, flow 4, camera 8, segmentation 16). A silent or saturated IMU
/// changes how the wheels (dead reckoning of the gap) and the flow sensor
/// (refused when too far from the filter's time) are treated; a motion
/// fault is seen by every motion sensor.
pub fn occupies(kind: FaultKind) -> u8 {
    use FaultKind::*;
    const IMU: u8 = 1;
    const WHEEL: u8 = 2;
    const FLOW: u8 = 4;
    const CAM: u8 = 8;
    const SEG: u8 = 16;
    let sensor = |s: Sensor| match s {
        Sensor::Imu => IMU,
        Sensor::Wheel => WHEEL,
        Sensor::Flow => FLOW,
    };
    match kind {
        Gap(Sensor::Imu) | ImuSaturated | Stuck | Lifted | Bump => IMU | WHEEL | FLOW,
        ImuNan | ImuInf | ImuOutlier | ImuStuck => IMU,
        WheelOutlier | WheelStuck | WheelSpi | WheelParity | WheelErrorFlag | WheelWrap => WHEEL,
        FlowOutlier | FlowStuck | FlowLimit | FlowLowSqual | FlowTextureless | FlowSpi
        | FlowBrownout => FLOW,
        Duplicate(s) | ZeroDt(s) | Late(s) | Gap(s) => sensor(s),
        CamBlack | CamSaturated | CamUniform | CamBlur | CamFrozen => CAM,
        SegNoGround | SegUnknown => SEG,
    }
}

/// Seconds a fault lasts: its window, or its samples (at most 10 at the
/// slowest stream's 10 Hz for a count fault).
pub fn span(f: &FaultSpec) -> f64 {
    if f.kind.has_window() {
        f.duration
    } else {
        0.1 * f.count as f64
    }
}

fn busy(f: &FaultSpec) -> (f64, f64) {
    (f.start - 0.5, f.start + span(f) + 1.0)
}

fn conflicts(a: &FaultSpec, b: &FaultSpec) -> bool {
    let (a0, a1) = busy(a);
    let (b0, b1) = busy(b);
    occupies(a.kind) & occupies(b.kind) != 0 && a0 < b1 && b0 < a1
}

/// One fault of `kind` at `start`, with a random window or count.
fn spec(rng: &mut ChaCha8Rng, kind: FaultKind, start: f64) -> FaultSpec {
    let s = FaultSpec::new(kind, (start * 1000.0).round() / 1000.0);
    if kind.has_window() {
        let d = kind.default_duration() * rng.random_range(0.5..2.0);
        s.lasting((d * 100.0).round().max(1.0) / 100.0)
    } else {
        s.times(rng.random_range(1..=5))
    }
}

/// Whether a motion fault may start at `f.start` in `sc`'s drive.
fn motion_fits(f: &FaultSpec, sc: &Scenario) -> bool {
    let script = &sc.script;
    let clear_of_episodes = script
        .episodes
        .iter()
        .all(|e| e.end + 1.0 < f.start || e.start > f.start + f.duration + 1.0);
    match f.kind {
        FaultKind::Stuck | FaultKind::Lifted => {
            clear_of_episodes && script.driving_through(f.start, f.duration)
        }
        FaultKind::Bump => script
            .segment_at(f.start)
            .is_some_and(|(i, _)| matches!(script.segments.get(i), Some(Segment::Straight { .. }))),
        _ => true,
    }
}

/// A chaos plan for `sc` (sorted by start time).
pub fn draw(cfg: &ChaosConfig, sc: &Scenario) -> FaultPlan {
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    let mut faults: Vec<FaultSpec> = Vec::new();
    // Motion faults pause the drive: each later one is placed in the script
    // with the earlier pauses in it.
    let mut paused = sc.clone();
    let last = cfg.duration_s - LAST_MARGIN_S;
    let mean_gap = 60.0 / cfg.per_minute.max(1e-3);
    let mut t = FIRST_S;
    let mut previous: Option<FaultSpec> = None;
    while t < last {
        let u: f64 = rng.random_range(f64::EPSILON..1.0);
        t += -mean_gap * u.ln();
        // Up to a few tries for a fault that fits.
        for _ in 0..8 {
            let overlap = previous.filter(|_| rng.random_bool(OVERLAP_SHARE));
            let start = match overlap {
                Some(p) => p.start + rng.random_range(0.0..span(&p).max(0.1)),
                None => t,
            };
            let kind = FaultKind::ALL[rng.random_range(0..FaultKind::ALL.len())];
            let f = spec(&mut rng, kind, start);
            if start < FIRST_S
                || start + span(&f) > last
                || faults.iter().any(|g| conflicts(g, &f))
                || !motion_fits(&f, &paused)
            {
                continue;
            }
            if matches!(f.kind, FaultKind::Stuck | FaultKind::Lifted)
                && sc.pauses_keep_path
                && let Some(s) = paused.script.with_pause(f.start, f.duration)
            {
                paused.script = s;
            }
            faults.push(f);
            previous = Some(f);
            break;
        }
    }
    faults.sort_by(|a, b| a.start.total_cmp(&b.start));
    FaultPlan { faults }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shuttle(seconds: f64) -> Scenario {
        Scenario::by_name("shuttle").unwrap().with_duration(seconds)
    }

    #[test]
    fn a_plan_is_seeded_rated_overlapping_and_free_of_conflicts() {
        let sc = shuttle(3600.0);
        let cfg = ChaosConfig {
            seed: 7,
            duration_s: 3600.0,
            per_minute: 6.0,
        };
        let plan = draw(&cfg, &sc);
        assert_eq!(plan, draw(&cfg, &sc), "the same seed draws the same plan");
        assert_ne!(plan, draw(&ChaosConfig { seed: 8, ..cfg }, &sc));
        let n = plan.faults.len() as f64;
        assert!(
            (300.0..420.0).contains(&n),
            "{n} faults at 6 a minute for an hour"
        );
        for f in &plan.faults {
            assert!(
                f.start >= FIRST_S && f.start + span(f) <= 3600.0 - LAST_MARGIN_S,
                "{f}"
            );
        }
        for (i, a) in plan.faults.iter().enumerate() {
            for b in &plan.faults[i + 1..] {
                assert!(!conflicts(a, b), "{a} and {b}");
            }
        }
        let overlapping = plan
            .faults
            .windows(2)
            .filter(|w| w[1].start < w[0].start + span(&w[0]))
            .count();
        assert!(
            overlapping > 30,
            "{overlapping} faults start inside the one before"
        );
        let kinds: std::collections::BTreeSet<String> =
            plan.faults.iter().map(|f| f.kind.name()).collect();
        assert_eq!(
            kinds.len(),
            FaultKind::ALL.len(),
            "every kind in an hour: {kinds:?}"
        );
    }

    #[test]
    fn motion_faults_fall_where_the_drive_goes_straight_or_along_an_arc() {
        let sc = shuttle(1200.0);
        let plan = draw(
            &ChaosConfig {
                seed: 3,
                duration_s: 1200.0,
                per_minute: 12.0,
            },
            &sc,
        );
        let mut paused = sc.clone();
        let mut motion = 0;
        for f in plan
            .faults
            .iter()
            .filter(|f| matches!(f.kind, FaultKind::Stuck | FaultKind::Lifted))
        {
            motion += 1;
            assert!(paused.script.driving_through(f.start, f.duration), "{f}");
            paused.script = paused.script.with_pause(f.start, f.duration).unwrap();
        }
        assert!(motion > 0);
    }

    #[test]
    fn same_sensor_faults_conflict_and_different_ones_overlap() {
        let a = FaultSpec::new(FaultKind::WheelSpi, 10.0).times(3);
        let b = FaultSpec::new(FaultKind::WheelOutlier, 10.5);
        let c = FaultSpec::new(FaultKind::CamBlur, 10.2).times(2);
        let d = FaultSpec::new(FaultKind::Gap(Sensor::Imu), 10.4).lasting(0.5);
        assert!(conflicts(&a, &b));
        assert!(!conflicts(&a, &c));
        assert!(
            conflicts(&a, &d),
            "a silent IMU changes how wheel samples are treated"
        );
        assert!(!conflicts(
            &a,
            &FaultSpec::new(FaultKind::WheelOutlier, 20.0)
        ));
    }
}
