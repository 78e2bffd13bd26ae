//! The firmware's measurement: every call the run makes ([`Measure`]) and
//! every part the estimator calls inside it ([`Probe`], `traction`'s hook)
//! is timed with SysTick (converted to instructions, measurement overhead
//! subtracted) on a painted stack (peak stack per call).
//!
//! The measurements live in one static, [`METER`], borrowed only for the
//! moment of a record ([`with`]): the estimator's probe ([`Metered`], zero
//! bytes) is inside the estimator, and a measured `poll` runs parts that
//! the probe measures on their own. A call's count has its parts' own
//! bookkeeping (painting, scanning, calibrated residual) taken out, so
//! `estimator.poll` counts the estimator's work; a part's stack peak counts
//! for the call around it too.

use crate::replay::{Measure, Step};
use crate::{stack, systick};
use traction::estimator::{Part, Probe};

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
    /// Instructions a part's measurement of nothing costs (subtracted).
    pub part_overhead: f32,
    /// Instructions one part's probe costs the call around it besides the
    /// painting and scanning it times itself (subtracted from the call).
    pub part_residual: f32,
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
    /// Lowest stack address a part reached since the call around it began.
    nested_lowest: usize,
    /// Bytes painted below the stack pointer before each call.
    pub depth: usize,
    /// Stack limit of a `traction::Estimator` call, bytes: the painted
    /// words below it are the canary checked after each such call.
    pub estimator_limit: usize,
    /// The first estimator call that went past the limit and its bytes
    /// (0: none).
    overflow: (Step, usize),
    last_propagate: Option<u32>,
    /// The part being measured, if `open.open`.
    open: OpenPart,
    /// Ticks the parts' probes spent painting and scanning, in all.
    probe_ticks: u32,
    /// Parts measured, in all.
    parts: u32,
    /// Calibration: the parts' ticks are summed here, not recorded.
    calibrating: Option<u32>,
}

/// The part being measured (no `Option`: its `None` would be a nonzero
/// niche of `Part`, and the meter's initial image would go to `.data`).
#[derive(Clone, Copy)]
struct OpenPart {
    /// Whether a part is being measured.
    open: bool,
    part: Part,
    /// Tick before painting.
    before: u32,
    /// Tick at entry.
    t0: u32,
    /// Stack top and painted depth.
    top: usize,
    depth: usize,
}

impl OpenPart {
    const NONE: OpenPart = OpenPart {
        open: false,
        part: Part::Propagate,
        before: 0,
        t0: 0,
        top: 0,
        depth: 0,
    };
}

/// The measurements (a static: hundreds of KB, in `.bss`).
pub static mut METER: Meter = Meter::empty();

/// Runs `f` on [`METER`].
#[inline(always)]
pub fn with<R>(f: impl FnOnce(&mut Meter) -> R) -> R {
    // SAFETY: one thread and no interrupts; every borrow of the static is
    // made here and ends with `f`, which never calls back into the meter.
    f(unsafe { &mut *core::ptr::addr_of_mut!(METER) })
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

/// Bytes painted below a part: the front end needs more.
const fn part_depth(part: Part) -> usize {
    match part {
        Part::FrontEnd => stack::FRONTEND_PAINT,
        _ => stack::DEPTH,
    }
}

impl Meter {
    /// No measurements, not calibrated: a `const` value of zero bytes, so
    /// that the meter (hundreds of KB) is a static in `.bss`, neither a value
    /// passed through `main`'s stack nor an image in flash.
    pub const fn empty() -> Self {
        Meter {
            instructions_per_tick: 0.0,
            overhead: 0.0,
            part_overhead: 0.0,
            part_residual: 0.0,
            steps: [const { Samples::new() }; Step::ALL.len()],
            propagate_and_wheel: Samples::new(),
            refused: [(0, 0); Step::ALL.len()],
            stack: [0; Step::ALL.len()],
            lowest: 0,
            nested_lowest: 0,
            depth: 0,
            estimator_limit: 0,
            overflow: (Step::Propagate, 0),
            last_propagate: None,
            open: OpenPart::NONE,
            probe_ticks: 0,
            parts: 0,
            calibrating: None,
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

    fn instructions(&self, ticks: u32, overhead: f32) -> u32 {
        let v = ticks as f32 * self.instructions_per_tick - overhead;
        if v > 0.0 { v as u32 } else { 0 }
    }

    /// Records one measured call or part.
    fn record(&mut self, step: Step, done: bool, ticks: u32, n: u32, used: usize, top: usize) {
        self.lowest = self.lowest().min(top - used);
        self.nested_lowest = self.nested_lowest.min(top - used);
        let i = step.index();
        if step.is_estimator() && used > self.estimator_limit && self.overflow().is_none() {
            self.overflow = (step, used);
        }
        if let Some(s) = self.stack.get_mut(i) {
            *s = (*s).max(used);
        }
        if !done {
            if let Some((count, max)) = self.refused.get_mut(i) {
                *count += 1;
                *max = (*max).max(n);
            }
            if step == Step::Propagate {
                self.last_propagate = None;
            }
            return;
        }
        if let Some(s) = self.steps.get_mut(i) {
            s.push(n);
        }
        match step {
            Step::Propagate => self.last_propagate = Some(ticks),
            Step::FuseWheel => {
                if let Some(p) = self.last_propagate.take() {
                    let pair = self.instructions(p + ticks, 2.0 * self.part_overhead);
                    self.propagate_and_wheel.push(pair);
                }
            }
            _ => {}
        }
    }
}

/// Calibrates the meter (instructions per tick, the overheads of a
/// measured call and of a part's probe) and sets the painted depth and the
/// estimator's stack limit.
pub fn calibrate() {
    let ipt = systick::calibrate();
    with(|m| {
        m.depth = stack::DEPTH;
        m.estimator_limit = stack::ESTIMATOR_LIMIT;
        m.instructions_per_tick = ipt;
    });
    // The overheads are below one tick: average many empty measurements.
    const EMPTY: u32 = 1024;
    let mut ticks = 0u32;
    for _ in 0..EMPTY {
        let ((), t, _, _) = timed(stack::DEPTH, || core::hint::black_box(()));
        ticks += t;
    }
    let overhead = ticks as f32 / EMPTY as f32 * ipt;
    with(|m| m.calibrating = Some(0));
    let (probe0, mut outer) = (with(|m| m.probe_ticks), 0u32);
    for _ in 0..EMPTY {
        let ((), t, _, _) = timed(stack::DEPTH, || {
            let mut p = Metered;
            p.enter(Part::Odometry);
            core::hint::black_box(());
            p.leave(Part::Odometry, true);
        });
        outer += t;
    }
    with(|m| {
        let inner = m.calibrating.take().unwrap_or(0);
        let painting = m.probe_ticks - probe0;
        m.probe_ticks = 0;
        m.parts = 0;
        m.overhead = overhead;
        m.part_overhead = inner as f32 / EMPTY as f32 * ipt;
        let residual = (outer.saturating_sub(painting)) as f32 / EMPTY as f32 * ipt - overhead;
        m.part_residual = residual.max(0.0);
    });
}

impl Default for Meter {
    fn default() -> Self {
        Self::empty()
    }
}

/// The firmware's measurement of the run's calls and of the estimator's
/// parts, on [`METER`]; zero bytes.
#[derive(Clone, Copy, Debug, Default)]
pub struct Metered;

impl Measure for Metered {
    fn measure<T, E>(&mut self, step: Step, f: impl FnOnce() -> Result<T, E>) -> Result<T, E> {
        let (depth, probe0, parts0) = with(|m| {
            m.nested_lowest = usize::MAX;
            (m.depth, m.probe_ticks, m.parts)
        });
        let (r, ticks, used, top) = timed(depth, f);
        with(|m| {
            // The parts' painting and scanning are not the call's work.
            let ticks = ticks.saturating_sub(m.probe_ticks - probe0);
            let parts = (m.parts - parts0) as f32;
            let n = m.instructions(ticks, m.overhead + parts * m.part_residual);
            let used = used.max(top.saturating_sub(m.nested_lowest));
            m.record(step, r.is_ok(), ticks, n, used, top);
        });
        r
    }
}

impl Probe for Metered {
    #[inline(always)]
    fn enter(&mut self, part: Part) {
        let a = systick::now();
        let depth = part_depth(part);
        let top = stack::paint_depth(depth);
        let t0 = systick::now();
        with(|m| {
            m.open = OpenPart {
                open: true,
                part,
                before: a,
                t0,
                top,
                depth,
            }
        });
    }

    #[inline(always)]
    fn leave(&mut self, part: Part, done: bool) {
        let t1 = systick::now();
        let o = with(|m| core::mem::replace(&mut m.open, OpenPart::NONE));
        if !o.open {
            return;
        }
        let (open, a, t0, top, depth) = (o.part, o.before, o.t0, o.top, o.depth);
        let used = stack::used_depth(top, depth);
        let b = systick::now();
        with(|m| {
            m.probe_ticks += systick::elapsed(a, t0) + systick::elapsed(t1, b);
            m.parts += 1;
            let ticks = systick::elapsed(t0, t1);
            if let Some(sum) = m.calibrating.as_mut() {
                *sum += ticks;
                return;
            }
            if open == part {
                let n = m.instructions(ticks, m.part_overhead);
                m.record(Step::of(part), done, ticks, n, used, top);
            }
        });
    }
}
