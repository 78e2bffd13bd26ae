//! The loop's CPU budget: every periodic call at the rate a robot runs it,
//! from the instructions measured per call.
//!
//! A task is one sensor's work at its rate (the IMU's propagation at 250 Hz,
//! the camera's front end, scale push, disagreement check and EKF fusion at
//! 10 Hz, ...). Its cost
//! per call is the sum of its steps' **median** instructions over the calls
//! that did the work (the median, not the mean: the front end's first call
//! only detects corners and would pull a mean of three calls down), and its
//! cost per second is that times the rate. The share of a core assumes one
//! instruction per cycle, which a Cortex-M4F/M7 does not reach (FPU
//! operations, loads and taken branches take more than one cycle), so the
//! shares are lower bounds.
//!
//! Tasks whose steps this image does not run are listed as not measured and
//! left out of the total, which the report then names.

use crate::replay::Step;

/// A 168 MHz Cortex-M4F (e.g. STM32F407), cycles per second.
pub const M4_HZ: u64 = 168_000_000;
/// A 480 MHz Cortex-M7 (e.g. STM32H743), cycles per second.
pub const M7_HZ: u64 = 480_000_000;

/// One periodic task of the loop.
#[derive(Clone, Copy, Debug)]
pub struct Task {
    /// Name in reports.
    pub name: &'static str,
    /// Calls per second.
    pub rate_hz: u32,
    /// The calls one period makes; empty when this image does not run the task.
    pub steps: &'static [Step],
}

/// The traction loop's periodic tasks at the rates of the sample data
/// (`host-sim simulate`'s sensors) and of the segmentation the surface
/// model expects.
pub const LOOP: [Task; 6] = [
    Task {
        name: "imu_250hz",
        rate_hz: 250,
        steps: &[Step::Propagate, Step::ScaleImu],
    },
    Task {
        name: "wheels_50hz",
        rate_hz: 50,
        steps: &[Step::Odometry, Step::ScaleWheel, Step::FuseWheel],
    },
    Task {
        name: "navigate_50hz",
        rate_hz: 50,
        steps: &[Step::Navigate],
    },
    Task {
        name: "flow_100hz",
        rate_hz: 100,
        steps: &[Step::ScaleFlow, Step::FuseFlow],
    },
    Task {
        name: "camera_10hz_160x120",
        rate_hz: 10,
        steps: &[
            Step::FrontEnd,
            Step::ScaleCamera,
            Step::Disagreement,
            Step::FuseCamera,
        ],
    },
    Task {
        name: "segmentation_2hz_160x120",
        rate_hz: 2,
        steps: &[Step::Segment],
    },
];

/// A task the loop can run in place of one of [`LOOP`]'s: the same sensor
/// through another path.
#[derive(Clone, Copy, Debug)]
pub struct Alternative {
    /// The task.
    pub task: Task,
    /// Name of the [`LOOP`] task it takes the place of.
    pub replaces: &'static str,
}

/// The alternatives: the flow sensor's raw frames tracked on the MCU
/// (`FrameFlow`, one grab per flow report) instead of the chip's motion
/// counts fused by the EKF. The scale pipeline's robust combination of a
/// pair's features (`push_raw_flow`) is not in the image and so not in the
/// row.
pub const ALTERNATIVES: [Alternative; 1] = [Alternative {
    task: Task {
        name: "flow_frames_100hz",
        rate_hz: 100,
        steps: &[Step::FlowFrame],
    },
    replaces: "flow_100hz",
}];

/// One task's cost.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cost {
    /// Instructions per call (sum of the steps' medians).
    pub per_call: u64,
    /// Instructions per second at the task's rate.
    pub per_second: u64,
}

impl Cost {
    /// Share of a core of `hz` cycles per second at one instruction per
    /// cycle, in per cent.
    pub fn percent_of(&self, hz: u64) -> f32 {
        if hz == 0 {
            return 0.0;
        }
        (self.per_second as f64 * 100.0 / hz as f64) as f32
    }
}

/// The cost of `task` from the per-step medians (`median(step)`), `None`
/// when the image does not run it or a step has no completed call.
pub fn cost(task: &Task, median: impl Fn(Step) -> Option<u32>) -> Option<Cost> {
    if task.steps.is_empty() {
        return None;
    }
    let mut per_call = 0u64;
    for &s in task.steps {
        per_call += u64::from(median(s)?);
    }
    Some(Cost {
        per_call,
        per_second: per_call * u64::from(task.rate_hz),
    })
}

/// The whole loop: the sum over the tasks that were measured.
pub fn total(median: impl Fn(Step) -> Option<u32> + Copy) -> Cost {
    sum(LOOP.iter(), median)
}

/// The whole loop with `alt` in place of the task it replaces; `None` when
/// `alt` was not measured.
pub fn total_with(alt: &Alternative, median: impl Fn(Step) -> Option<u32> + Copy) -> Option<Cost> {
    cost(&alt.task, median)?;
    let tasks = LOOP
        .iter()
        .filter(|t| t.name != alt.replaces)
        .chain(core::iter::once(&alt.task));
    Some(sum(tasks, median))
}

fn sum<'a>(
    tasks: impl Iterator<Item = &'a Task>,
    median: impl Fn(Step) -> Option<u32> + Copy,
) -> Cost {
    let mut t = Cost {
        per_call: 0,
        per_second: 0,
    };
    for task in tasks {
        if let Some(c) = cost(task, median) {
            t.per_call += c.per_call;
            t.per_second += c.per_second;
        }
    }
    t
}
