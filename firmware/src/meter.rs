//! The firmware's [`Probe`]: every call of the loop is timed with SysTick
//! (converted to instructions, measurement overhead subtracted) and run on
//! a painted stack (peak stack per call).

use crate::replay::{Probe, Step};
use crate::{stack, systick};

/// Most measurements kept per step (the run has fewer).
pub const CAPACITY: usize = 6144;

/// The measurements of one step, in instructions.
pub struct Samples {
    values: [u32; CAPACITY],
    len: usize,
    /// Measurements that did not fit.
    pub dropped: u32,
}

/// Summary statistics of one step, in instructions.
#[derive(Clone, Copy, Debug, Default)]
pub struct Spread {
    /// Measurements.
    pub n: usize,
    /// Smallest.
    pub min: u32,
    /// Median (upper median for an even count).
    pub median: u32,
    /// Largest.
    pub max: u32,
    /// Mean.
    pub mean: u32,
}

impl Samples {
    /// No measurements.
    pub const fn new() -> Self {
        Samples {
            values: [0; CAPACITY],
            len: 0,
            dropped: 0,
        }
    }

    /// Adds one.
    pub fn push(&mut self, v: u32) {
        match self.values.get_mut(self.len) {
            Some(slot) => {
                *slot = v;
                self.len += 1;
            }
            None => self.dropped = self.dropped.saturating_add(1),
        }
    }

    /// Sorts and summarises.
    pub fn spread(&mut self) -> Spread {
        let v = self.values.get_mut(..self.len).unwrap_or(&mut []);
        v.sort_unstable();
        let sum: u64 = v.iter().map(|&x| u64::from(x)).sum();
        Spread {
            n: v.len(),
            min: v.first().copied().unwrap_or(0),
            median: v.get(v.len() / 2).copied().unwrap_or(0),
            max: v.last().copied().unwrap_or(0),
            mean: if v.is_empty() {
                0
            } else {
                (sum / v.len() as u64) as u32
            },
        }
    }
}

impl Default for Samples {
    fn default() -> Self {
        Self::new()
    }
}

/// Instruction counts and stack peaks of every step of a run.
pub struct Meter {
    /// Instructions per SysTick tick (see [`systick::calibrate`]).
    pub instructions_per_tick: f32,
    /// Instructions a measurement of an empty call costs (subtracted).
    pub overhead: f32,
    /// Per step, instructions of the calls that returned `Ok`.
    pub steps: [Samples; Step::ALL.len()],
    /// Per step, `(calls that returned Err, most instructions of one)`:
    /// early refusals (not initialised, first sample, out of order) and
    /// gated measurements.
    pub refused: [(u32, u32); Step::ALL.len()],
    /// One propagation plus the wheel update after it, instructions.
    pub propagate_and_wheel: Samples,
    /// Peak stack per step, bytes.
    pub stack: [usize; Step::ALL.len()],
    /// Lowest stack address any measured call reached; 0 before the first.
    lowest: usize,
    /// Bytes painted below the stack pointer before each call.
    pub depth: usize,
    /// Stack limit of a `traction::Estimator` call, bytes: the painted
    /// words below it are the canary checked after each such call.
    pub estimator_limit: usize,
    /// The first estimator call that went past the limit and its bytes
    /// (0: none).
    overflow: (Step, usize),
    last_propagate: Option<u32>,
}

/// Ticks and stack bytes of one call of `f`.
#[inline(always)]
fn timed<R>(depth: usize, f: impl FnOnce() -> R) -> (R, u32, usize, usize) {
    let top = stack::paint_depth(depth);
    let t0 = systick::now();
    let r = stack::call(f);
    let t1 = systick::now();
    (
        r,
        systick::elapsed(t0, t1),
        stack::used_depth(top, depth),
        top,
    )
}

impl Meter {
    /// No measurements, not calibrated: a `const` value of zero bytes, so
    /// that the meter (hundreds of KB) is a static in `.bss`, neither a value
    /// passed through `main`'s stack nor an image in flash.
    pub const fn empty() -> Self {
        Meter {
            instructions_per_tick: 0.0,
            overhead: 0.0,
            steps: [const { Samples::new() }; Step::ALL.len()],
            propagate_and_wheel: Samples::new(),
            refused: [(0, 0); Step::ALL.len()],
            stack: [0; Step::ALL.len()],
            lowest: 0,
            depth: 0,
            estimator_limit: 0,
            overflow: (Step::Propagate, 0),
            last_propagate: None,
        }
    }

    /// Lowest stack address any measured call reached (`usize::MAX` before
    /// the first).
    pub fn lowest(&self) -> usize {
        if self.lowest == 0 {
            usize::MAX
        } else {
            self.lowest
        }
    }

    /// The first estimator call past [`Meter::estimator_limit`]: `(step, bytes)`.
    pub fn overflow(&self) -> Option<(Step, usize)> {
        (self.overflow.1 > 0).then_some(self.overflow)
    }

    /// Calibrates (instructions per tick, the measurement overhead) and sets
    /// the painted depth and the estimator's stack limit.
    pub fn calibrate(&mut self) {
        self.depth = stack::DEPTH;
        self.estimator_limit = stack::ESTIMATOR_LIMIT;
        let instructions_per_tick = systick::calibrate();
        // The overhead is below one tick: average many empty measurements.
        const EMPTY: u32 = 1024;
        let mut ticks = 0u32;
        for _ in 0..EMPTY {
            let ((), t, _, _) = timed(stack::DEPTH, || core::hint::black_box(()));
            ticks += t;
        }
        self.instructions_per_tick = instructions_per_tick;
        self.overhead = ticks as f32 / EMPTY as f32 * instructions_per_tick;
    }

    fn instructions(&self, ticks: u32, calls: f32) -> u32 {
        let v = ticks as f32 * self.instructions_per_tick - calls * self.overhead;
        if v > 0.0 { v as u32 } else { 0 }
    }
}

impl Default for Meter {
    fn default() -> Self {
        Self::empty()
    }
}

impl Probe for Meter {
    fn measure<T, E>(&mut self, step: Step, f: impl FnOnce() -> Result<T, E>) -> Result<T, E> {
        let (r, ticks, used, top) = timed(self.depth, f);
        self.lowest = self.lowest().min(top - used);
        let i = step.index();
        if step.is_estimator() && used > self.estimator_limit && self.overflow().is_none() {
            self.overflow = (step, used);
        }
        if let Some(s) = self.stack.get_mut(i) {
            *s = (*s).max(used);
        }
        let n = self.instructions(ticks, 1.0);
        if r.is_err() {
            if let Some((count, max)) = self.refused.get_mut(i) {
                *count += 1;
                *max = (*max).max(n);
            }
            if step == Step::Propagate {
                self.last_propagate = None;
            }
            return r;
        }
        if let Some(s) = self.steps.get_mut(i) {
            s.push(n);
        }
        match step {
            Step::Propagate => self.last_propagate = Some(ticks),
            Step::FuseWheel => {
                if let Some(p) = self.last_propagate.take() {
                    let pair = self.instructions(p + ticks, 2.0);
                    self.propagate_and_wheel.push(pair);
                }
            }
            _ => {}
        }
        r
    }
}
