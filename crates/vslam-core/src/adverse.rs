//! Adverse-event memory: where and when each sensor misbehaved, so that its
//! weight is lowered there before it misleads the estimate again (seed: the
//! semantic information extractor and the weighting-factor component).
//!
//! Events (slip, outlier, blank, stuck and saturated readings, collisions,
//! disagreement with the fused estimate) are recorded per sensor by position cell (`cell_size` metres; cells are
//! addressed by their signed integer column and row, so places far apart
//! never share a cell: at 0.25 m the address covers +-500,000 km) and time
//! slot. Each sensor has its own slot length ([`SlotLengths`], seed [0089]:
//! every extractor its own time-slot server): the time within the cycle
//! (`cycle_ns`, a day by default) divided by the sensor's slot length gives
//! its slot, at most `SLOTS` of them, so the wheels may keep one slot for the
//! whole day while the flow sensor and the camera, whose trouble comes with
//! the light, keep quarters of the day. The map is sparse: only cells with
//! events are kept, at most `CELLS` of them, in a fixed-capacity table (no
//! heap); recording into a new cell when the table is full evicts the least
//! recently used cell (the one whose latest event is oldest), counted in
//! [`AdverseMemory::evicted`]. Each cell keeps a decaying event level per
//! sensor and slot in fixed point (`1.0` event = 256); levels decay by
//! `decay_factor` per `decay_period_ns`. A sensor's weight in a cell is
//! `1 / (1 + weight_per_event * max(0, events - 1))`: a single event is
//! chance, repeated events lower the weight.
//!
//! The memory exports to and restores from a fixed-size, versioned,
//! little-endian byte record ending in a CRC-32 (IEEE); corrupt records are
//! typed errors.

use core::fmt;

use crate::geometry::Vec2;
use crate::stream::Stream;
use crate::time::Timestamp;

/// The sensors the memory tracks: the [`Stream`]s whose misbehaviour is
/// remembered by place. Its own slot order is part of the exported record
/// (the levels of sensor `k` are the `k`-th block), so it is not the
/// registry's order; [`SensorKind::stream`] and [`SensorKind::of`] map
/// between the two.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum SensorKind {
    /// Wheel odometry.
    Wheel = 0,
    /// Downward optical flow.
    Flow = 1,
    /// The upward camera.
    Camera = 2,
    /// The IMU.
    Imu = 3,
}

impl SensorKind {
    /// How many sensors.
    pub const COUNT: usize = 4;
    /// Every sensor, in slot order.
    pub const ALL: [SensorKind; 4] = [
        SensorKind::Wheel,
        SensorKind::Flow,
        SensorKind::Camera,
        SensorKind::Imu,
    ];

    /// The stream of this sensor's samples.
    pub const fn stream(self) -> Stream {
        match self {
            SensorKind::Wheel => Stream::Wheel,
            SensorKind::Flow => Stream::Flow,
            SensorKind::Camera => Stream::Camera,
            SensorKind::Imu => Stream::Imu,
        }
    }

    /// The sensor the memory tracks for `stream`, if it tracks one (tracking
    /// is opt-in: a new stream is not remembered until it gets a slot here).
    pub const fn of(stream: Stream) -> Option<SensorKind> {
        match stream {
            Stream::Wheel => Some(SensorKind::Wheel),
            Stream::Flow => Some(SensorKind::Flow),
            Stream::Camera => Some(SensorKind::Camera),
            Stream::Imu => Some(SensorKind::Imu),
            _ => None,
        }
    }

    /// The stream's report name (see [`Stream::name`]).
    pub const fn name(self) -> &'static str {
        self.stream().name()
    }
}

/// What went wrong.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum AdverseKind {
    /// The wheels slipped.
    Slip = 0,
    /// The reading was an outlier against the other sources.
    Outlier = 1,
    /// The sensor saw nothing (blank floor, no features).
    Blank = 2,
    /// The reading did not change while the robot moved.
    Stuck = 3,
    /// The robot ran into something (the jolt monitor's suspected obstacle):
    /// the wheels turned against it or were pushed.
    Collision = 4,
    /// The reading hit the sensor's full scale (a knock, a bump).
    Saturated = 5,
    /// The sensor's own motion over an interval disagreed with the fused
    /// estimate's motion over the same interval beyond what their
    /// covariances allow (see [`crate::disagree`]).
    Disagreement = 6,
}

impl AdverseKind {
    /// How many kinds.
    pub const COUNT: usize = 7;
}

/// Each sensor's time-slot length, nanoseconds: a slot is
/// `(t mod cycle) / length` ([`AdverseParams::cycle_ns`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SlotLengths {
    /// Wheels. Default 24 h, one slot a day: a slippery floor or a cable
    /// is the place's at any hour.
    pub wheel: u64,
    /// Flow sensor. Default 6 h, quarters of the day: its misreadings come
    /// with the light on the floor (sunlit patches, dark corners).
    pub flow: u64,
    /// Upward camera. Default 6 h, quarters of the day: the ceiling is lit
    /// by daylight or lamps or not at all.
    pub camera: u64,
    /// IMU. Default 24 h, one slot a day: bumps and thresholds are the
    /// place's at any hour.
    pub imu: u64,
}

impl SlotLengths {
    /// The same length for every sensor.
    pub const fn uniform(ns: u64) -> Self {
        SlotLengths {
            wheel: ns,
            flow: ns,
            camera: ns,
            imu: ns,
        }
    }

    /// The slot length of `sensor`.
    pub const fn of(&self, sensor: SensorKind) -> u64 {
        match sensor {
            SensorKind::Wheel => self.wheel,
            SensorKind::Flow => self.flow,
            SensorKind::Camera => self.camera,
            SensorKind::Imu => self.imu,
        }
    }

    /// The lengths in [`SensorKind::ALL`] order.
    pub const fn all(&self) -> [u64; SensorKind::COUNT] {
        [self.wheel, self.flow, self.camera, self.imu]
    }
}

impl Default for SlotLengths {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl SlotLengths {
    /// The defaults ([`Default::default`]) as a constant, for `const` construction.
    pub const DEFAULT: Self = SlotLengths {
        wheel: DAY_NS,
        flow: DAY_NS / 4,
        camera: DAY_NS / 4,
        imu: DAY_NS,
    };
}

/// A day, nanoseconds.
const DAY_NS: u64 = 24 * 3600 * 1_000_000_000;

/// Settings of the memory.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdverseParams {
    /// Side of a position cell, metres.
    pub cell_size: f32,
    /// Length of the cycle the time slots repeat in, nanoseconds (a day:
    /// with time stamps from midnight, a slot is a time of day).
    pub cycle_ns: u64,
    /// Each sensor's slot length; no longer than the cycle, and the cycle
    /// holds at most `SLOTS` of them (else [`AdverseError::BadParams`]).
    pub slot_ns: SlotLengths,
    /// Decay period, nanoseconds.
    pub decay_period_ns: u64,
    /// Level factor per decay period, `0..1`.
    pub decay_factor: f32,
    /// Weight loss per repeated event.
    pub weight_per_event: f32,
}

impl Default for AdverseParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl AdverseParams {
    /// The defaults ([`Default::default`]) as a constant, for `const` construction.
    pub const DEFAULT: Self = AdverseParams {
        cell_size: 0.5,
        cycle_ns: DAY_NS,
        slot_ns: SlotLengths::DEFAULT,
        decay_period_ns: DAY_NS,
        decay_factor: 0.5,
        weight_per_event: 0.5,
    };
}

impl AdverseParams {
    /// Whether the settings are usable with `slots` time slots: finite and
    /// positive, every slot length within the cycle and at most `slots`
    /// slots in it.
    fn is_valid(&self, slots: usize) -> bool {
        let slots_ok = self
            .slot_ns
            .all()
            .iter()
            .all(|&l| l > 0 && l <= self.cycle_ns && self.cycle_ns.div_ceil(l) <= slots as u64);
        self.cell_size.is_finite()
            && self.cell_size > 0.0
            && slots_ok
            && self.decay_period_ns > 0
            && self.decay_factor.is_finite()
            && (0.0..=1.0).contains(&self.decay_factor)
            && self.weight_per_event.is_finite()
            && self.weight_per_event >= 0.0
    }
}

/// Why the memory refused an operation or a record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AdverseError {
    /// The settings are not finite/positive.
    BadParams,
    /// The position is not finite.
    NonFinitePosition,
    /// The export buffer is shorter than the record.
    BufferTooSmall,
    /// The record is shorter than this memory's record.
    TooShort,
    /// The record does not start with the magic bytes.
    BadMagic,
    /// The record's version is not one this code reads.
    UnsupportedVersion(u8),
    /// The record's grid shape differs from this memory type's.
    ShapeMismatch,
    /// The checksum does not match the contents.
    BadChecksum,
    /// The record's cells are more than the capacity, or one cell twice.
    BadCells,
    /// The record is sound but was made with other settings (cell size,
    /// slots, decay, weight) than the memory it should replace.
    SettingsMismatch,
}

impl fmt::Display for AdverseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AdverseError::BadParams => f.write_str("adverse-memory settings out of range"),
            AdverseError::NonFinitePosition => f.write_str("position not finite"),
            AdverseError::BufferTooSmall => f.write_str("export buffer too small"),
            AdverseError::TooShort => f.write_str("record too short"),
            AdverseError::BadMagic => f.write_str("record magic mismatch"),
            AdverseError::UnsupportedVersion(v) => write!(f, "unsupported record version {v}"),
            AdverseError::ShapeMismatch => f.write_str("record grid shape mismatch"),
            AdverseError::BadChecksum => f.write_str("record checksum mismatch"),
            AdverseError::BadCells => f.write_str("record cells over capacity or repeated"),
            AdverseError::SettingsMismatch => {
                f.write_str("record made with other memory settings than the configured ones")
            }
        }
    }
}

impl core::error::Error for AdverseError {}

/// Magic bytes at the start of a record.
pub const MAGIC: [u8; 4] = *b"TRAM";
/// The record version this code writes and reads (4: the sparse map with
/// per-sensor slot lengths and seven event kinds, [`AdverseKind::Disagreement`]
/// the seventh). Records of an older version are refused as
/// [`AdverseError::UnsupportedVersion`]: their tally block has another length.
pub const VERSION: u8 = 4;
const HEADER_LEN: usize = 4 + 4 + 8 + 60 + 8 + 8;
const TALLY_LEN: usize = SensorKind::COUNT * AdverseKind::COUNT * 4;
const ONE_EVENT: f32 = 256.0;

/// One cell of the sparse map: its address, its levels per sensor and
/// slot, and the time of its latest event (for least-recently-used
/// eviction).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Cell<const SLOTS: usize> {
    ix: i32,
    iy: i32,
    last: Timestamp,
    levels: [[u16; SLOTS]; SensorKind::COUNT],
}

impl<const SLOTS: usize> Cell<SLOTS> {
    /// Bytes of one cell in the record.
    const RECORD_LEN: usize = 4 + 4 + 8 + 2 * SensorKind::COUNT * SLOTS;
}

/// Bounded per-sensor event memory: a sparse map of at most `CELLS` cells
/// with `SLOTS` time slots each.
#[derive(Clone, Debug, PartialEq)]
pub struct AdverseMemory<const CELLS: usize, const SLOTS: usize> {
    params: AdverseParams,
    cells: heapless::Vec<Cell<SLOTS>, CELLS>,
    evicted: u32,
    tallies: [[u32; AdverseKind::COUNT]; SensorKind::COUNT],
    decayed_to: Option<Timestamp>,
}

/// A cell and slot address.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CellSlot {
    /// Column (x): `floor(x / cell_size)`, saturated to `i32`.
    pub ix: i32,
    /// Row (y): `floor(y / cell_size)`, saturated to `i32`.
    pub iy: i32,
    /// Time slot of the sensor, `0..SLOTS`.
    pub slot: usize,
}

impl<const CELLS: usize, const SLOTS: usize> AdverseMemory<CELLS, SLOTS> {
    /// Bytes of the exported record.
    pub const RECORD_LEN: usize = HEADER_LEN + TALLY_LEN + CELLS * Cell::<SLOTS>::RECORD_LEN + 4;

    /// An empty memory.
    pub fn new(params: AdverseParams) -> Result<Self, AdverseError> {
        Self::check(&params)?;
        Ok(Self::empty(params))
    }

    /// An empty memory with `params` unchecked (a `const` value; see
    /// [`AdverseMemory::reset`]).
    pub const fn empty(params: AdverseParams) -> Self {
        AdverseMemory {
            params,
            cells: heapless::Vec::new(),
            evicted: 0,
            tallies: [[0; AdverseKind::COUNT]; SensorKind::COUNT],
            decayed_to: None,
        }
    }

    /// Empties the memory in place and takes `params`, as
    /// [`AdverseMemory::new`]; refused settings change nothing.
    pub fn reset(&mut self, params: AdverseParams) -> Result<(), AdverseError> {
        Self::check(&params)?;
        self.params = params;
        self.cells.clear();
        self.evicted = 0;
        self.tallies = [[0; AdverseKind::COUNT]; SensorKind::COUNT];
        self.decayed_to = None;
        Ok(())
    }

    fn check(params: &AdverseParams) -> Result<(), AdverseError> {
        if !params.is_valid(SLOTS) || CELLS == 0 || SLOTS == 0 || CELLS > u16::MAX as usize {
            return Err(AdverseError::BadParams);
        }
        Ok(())
    }

    /// The settings.
    pub fn params(&self) -> &AdverseParams {
        &self.params
    }

    /// Cells with events kept now (at most `CELLS`).
    pub fn cells(&self) -> usize {
        self.cells.len()
    }

    /// Cells evicted to make room for new ones, ever.
    pub fn evicted(&self) -> u32 {
        self.evicted
    }

    /// The cell of a position (metres, world) and the slot of `sensor` at time `t`.
    pub fn cell_slot(
        &self,
        sensor: SensorKind,
        p: &Vec2,
        t: Timestamp,
    ) -> Result<CellSlot, AdverseError> {
        if !(p.x.is_finite() && p.y.is_finite()) {
            return Err(AdverseError::NonFinitePosition);
        }
        // Saturating float-to-int casts: no wrap onto other cells.
        let ix = libm::floorf(p.x / self.params.cell_size) as i32;
        let iy = libm::floorf(p.y / self.params.cell_size) as i32;
        // Both divisors are positive (checked in `new`); the slot is below
        // SLOTS by the same check, and `get` refuses it otherwise.
        let within = t.0.checked_rem(self.params.cycle_ns).unwrap_or(0);
        let slot = within
            .checked_div(self.params.slot_ns.of(sensor))
            .unwrap_or(0) as usize;
        Ok(CellSlot { ix, iy, slot })
    }

    fn periods_since_decay(&self, now: Timestamp) -> u64 {
        self.decayed_to
            .and_then(|d| now.nanos_since(d))
            .map_or(0, |ns| ns / self.params.decay_period_ns)
    }

    /// Applies the decay up to `now` (earlier times change nothing).
    pub fn decay_to(&mut self, now: Timestamp) {
        let Some(d) = self.decayed_to else {
            self.decayed_to = Some(now);
            return;
        };
        let periods = self.periods_since_decay(now);
        if periods == 0 {
            return;
        }
        let f = libm::powf(self.params.decay_factor, periods.min(1 << 20) as f32);
        for c in self.cells.iter_mut() {
            for v in c.levels.iter_mut().flatten() {
                *v = (f32::from(*v) * f) as u16;
            }
        }
        let step = periods.saturating_mul(self.params.decay_period_ns);
        self.decayed_to = d.checked_add_nanos(step).or(Some(now));
    }

    fn find(&self, cs: CellSlot) -> Option<&Cell<SLOTS>> {
        self.cells.iter().find(|c| c.ix == cs.ix && c.iy == cs.iy)
    }

    /// The cell at `cs`, made (evicting the least recently used one when the
    /// table is full) if there is none.
    fn find_or_make(&mut self, cs: CellSlot, t: Timestamp) -> Option<&mut Cell<SLOTS>> {
        let at = match self
            .cells
            .iter()
            .position(|c| c.ix == cs.ix && c.iy == cs.iy)
        {
            Some(i) => i,
            None => {
                let fresh = Cell {
                    ix: cs.ix,
                    iy: cs.iy,
                    last: t,
                    levels: [[0; SLOTS]; SensorKind::COUNT],
                };
                match self.cells.push(fresh) {
                    Ok(()) => self.cells.len().checked_sub(1)?,
                    Err(fresh) => {
                        let oldest = self
                            .cells
                            .iter()
                            .enumerate()
                            .min_by_key(|(_, c)| c.last)
                            .map(|(i, _)| i)?;
                        *self.cells.get_mut(oldest)? = fresh;
                        self.evicted = self.evicted.saturating_add(1);
                        oldest
                    }
                }
            }
        };
        self.cells.get_mut(at)
    }

    /// Records one event of `kind` for `sensor` at position `p` (world, metres) and time `t`.
    pub fn record(
        &mut self,
        sensor: SensorKind,
        kind: AdverseKind,
        p: &Vec2,
        t: Timestamp,
    ) -> Result<(), AdverseError> {
        let cs = self.cell_slot(sensor, p, t)?;
        self.decay_to(t);
        if let Some(cell) = self.find_or_make(cs, t) {
            cell.last = cell.last.max(t);
            if let Some(v) = cell
                .levels
                .get_mut(sensor as usize)
                .and_then(|l| l.get_mut(cs.slot))
            {
                *v = v.saturating_add(ONE_EVENT as u16);
            }
        }
        if let Some(c) = self
            .tallies
            .get_mut(sensor as usize)
            .and_then(|r| r.get_mut(kind as usize))
        {
            *c = c.saturating_add(1);
        }
        Ok(())
    }

    /// Decayed event count of `sensor` at `p` and `t`.
    pub fn events(&self, sensor: SensorKind, p: &Vec2, t: Timestamp) -> f32 {
        let Ok(cs) = self.cell_slot(sensor, p, t) else {
            return 0.0;
        };
        let level = self
            .find(cs)
            .and_then(|c| c.levels.get(sensor as usize))
            .and_then(|l| l.get(cs.slot))
            .copied()
            .unwrap_or(0);
        let periods = self.periods_since_decay(t).min(1 << 20);
        f32::from(level) / ONE_EVENT * libm::powf(self.params.decay_factor, periods as f32)
    }

    /// The weight of `sensor` at `p` and `t`, `0..=1` (1 where nothing repeated).
    pub fn weight(&self, sensor: SensorKind, p: &Vec2, t: Timestamp) -> f32 {
        let n = self.events(sensor, p, t);
        let excess = (n - 1.0).max(0.0);
        1.0 / (1.0 + self.params.weight_per_event * excess)
    }

    /// Events ever recorded for `sensor` of `kind` (not decayed).
    pub fn tally(&self, sensor: SensorKind, kind: AdverseKind) -> u32 {
        self.tallies
            .get(sensor as usize)
            .and_then(|r| r.get(kind as usize))
            .copied()
            .unwrap_or(0)
    }

    /// Writes the record into `out` (at least [`Self::RECORD_LEN`] bytes);
    /// returns the bytes written. The cells are written in table order,
    /// the unused ones zero.
    pub fn export(&self, out: &mut [u8]) -> Result<usize, AdverseError> {
        let out = out
            .get_mut(..Self::RECORD_LEN)
            .ok_or(AdverseError::BufferTooSmall)?;
        out.fill(0);
        let mut w = Writer { buf: out, at: 0 };
        w.put(&MAGIC);
        w.put(&[
            VERSION,
            SensorKind::COUNT as u8,
            AdverseKind::COUNT as u8,
            0,
        ]);
        w.put(&(CELLS as u16).to_le_bytes());
        w.put(&(SLOTS as u16).to_le_bytes());
        w.put(&(self.cells.len() as u16).to_le_bytes());
        w.put(&0u16.to_le_bytes());
        w.put(&self.params.cell_size.to_le_bytes());
        w.put(&self.params.cycle_ns.to_le_bytes());
        for l in self.params.slot_ns.all() {
            w.put(&l.to_le_bytes());
        }
        w.put(&self.params.decay_period_ns.to_le_bytes());
        w.put(&self.params.decay_factor.to_le_bytes());
        w.put(&self.params.weight_per_event.to_le_bytes());
        w.put(&self.decayed_to.map_or(u64::MAX, |t| t.0).to_le_bytes());
        w.put(&u64::from(self.evicted).to_le_bytes());
        for c in self.tallies.iter().flatten() {
            w.put(&c.to_le_bytes());
        }
        for c in self.cells.iter() {
            w.put(&c.ix.to_le_bytes());
            w.put(&c.iy.to_le_bytes());
            w.put(&c.last.0.to_le_bytes());
            for v in c.levels.iter().flatten() {
                w.put(&v.to_le_bytes());
            }
        }
        let body_len = Self::RECORD_LEN - 4;
        let crc = crc32fast::hash(w.buf.get(..body_len).unwrap_or(&[]));
        w.at = body_len;
        w.put(&crc.to_le_bytes());
        Ok(w.at)
    }

    /// Rebuilds a memory from a record written by [`Self::export`]. The
    /// checks run in order: magic, version, shape (capacity, slots), length,
    /// checksum, settings, cells (count within the capacity, no cell twice).
    pub fn restore(bytes: &[u8]) -> Result<Self, AdverseError> {
        let mut r = Reader { buf: bytes, at: 0 };
        if r.take::<4>().ok_or(AdverseError::TooShort)? != MAGIC {
            return Err(AdverseError::BadMagic);
        }
        let [version, sensors, kinds, _] = r.take::<4>().ok_or(AdverseError::TooShort)?;
        if version != VERSION {
            return Err(AdverseError::UnsupportedVersion(version));
        }
        let capacity = r.u16().ok_or(AdverseError::TooShort)?;
        let slots = r.u16().ok_or(AdverseError::TooShort)?;
        let used = r.u16().ok_or(AdverseError::TooShort)?;
        let _ = r.u16().ok_or(AdverseError::TooShort)?;
        let shape_ok = usize::from(sensors) == SensorKind::COUNT
            && usize::from(kinds) == AdverseKind::COUNT
            && usize::from(capacity) == CELLS
            && usize::from(slots) == SLOTS;
        if !shape_ok {
            return Err(AdverseError::ShapeMismatch);
        }
        let rec = bytes
            .get(..Self::RECORD_LEN)
            .ok_or(AdverseError::TooShort)?;
        let (body, crc) = rec
            .split_at_checked(Self::RECORD_LEN - 4)
            .ok_or(AdverseError::TooShort)?;
        let crc_bytes: [u8; 4] = crc.try_into().map_err(|_| AdverseError::TooShort)?;
        if crc32fast::hash(body) != u32::from_le_bytes(crc_bytes) {
            return Err(AdverseError::BadChecksum);
        }
        let cell_size = r.f32().ok_or(AdverseError::TooShort)?;
        let cycle_ns = r.u64().ok_or(AdverseError::TooShort)?;
        let mut lengths = [0u64; SensorKind::COUNT];
        for l in lengths.iter_mut() {
            *l = r.u64().ok_or(AdverseError::TooShort)?;
        }
        let [wheel, flow, camera, imu] = lengths;
        let params = AdverseParams {
            cell_size,
            cycle_ns,
            slot_ns: SlotLengths {
                wheel,
                flow,
                camera,
                imu,
            },
            decay_period_ns: r.u64().ok_or(AdverseError::TooShort)?,
            decay_factor: r.f32().ok_or(AdverseError::TooShort)?,
            weight_per_event: r.f32().ok_or(AdverseError::TooShort)?,
        };
        let mut m = AdverseMemory::new(params)?;
        let decayed = r.u64().ok_or(AdverseError::TooShort)?;
        m.decayed_to = (decayed != u64::MAX).then_some(Timestamp(decayed));
        m.evicted = u32::try_from(r.u64().ok_or(AdverseError::TooShort)?).unwrap_or(u32::MAX);
        for c in m.tallies.iter_mut().flatten() {
            *c = r.u32().ok_or(AdverseError::TooShort)?;
        }
        if usize::from(used) > CELLS {
            return Err(AdverseError::BadCells);
        }
        for _ in 0..used {
            let ix = r.i32().ok_or(AdverseError::TooShort)?;
            let iy = r.i32().ok_or(AdverseError::TooShort)?;
            let last = Timestamp(r.u64().ok_or(AdverseError::TooShort)?);
            let mut levels = [[0u16; SLOTS]; SensorKind::COUNT];
            for v in levels.iter_mut().flatten() {
                *v = r.u16().ok_or(AdverseError::TooShort)?;
            }
            if m.cells.iter().any(|c| c.ix == ix && c.iy == iy) {
                return Err(AdverseError::BadCells);
            }
            m.cells
                .push(Cell {
                    ix,
                    iy,
                    last,
                    levels,
                })
                .map_err(|_| AdverseError::BadCells)?;
        }
        Ok(m)
    }
}

struct Writer<'a> {
    buf: &'a mut [u8],
    at: usize,
}

impl Writer<'_> {
    fn put(&mut self, bytes: &[u8]) {
        let end = self.at.saturating_add(bytes.len());
        if let Some(dst) = self.buf.get_mut(self.at..end) {
            dst.copy_from_slice(bytes);
            self.at = end;
        }
    }
}

struct Reader<'a> {
    buf: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take<const K: usize>(&mut self) -> Option<[u8; K]> {
        let end = self.at.checked_add(K)?;
        let b: [u8; K] = self.buf.get(self.at..end)?.try_into().ok()?;
        self.at = end;
        Some(b)
    }
    fn u16(&mut self) -> Option<u16> {
        self.take().map(u16::from_le_bytes)
    }
    fn u32(&mut self) -> Option<u32> {
        self.take().map(u32::from_le_bytes)
    }
    fn i32(&mut self) -> Option<i32> {
        self.take().map(i32::from_le_bytes)
    }
    fn u64(&mut self) -> Option<u64> {
        self.take().map(u64::from_le_bytes)
    }
    fn f32(&mut self) -> Option<f32> {
        self.take().map(f32::from_le_bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_version_3_record_is_refused_with_its_version() {
        // Version 3 had six event kinds; a record of it, resealed with a
        // valid checksum, is refused by version, and the reason reads so.
        type M = AdverseMemory<4, 4>;
        let mut m = M::new(AdverseParams::default()).unwrap();
        m.record(
            SensorKind::Camera,
            AdverseKind::Disagreement,
            &Vec2::new(1.0, 2.0),
            Timestamp(5),
        )
        .unwrap();
        let mut buf = [0u8; M::RECORD_LEN];
        m.export(&mut buf).unwrap();
        assert_eq!(M::restore(&buf).unwrap(), m);
        buf[4] = 3;
        buf[6] = 6;
        let crc = crc32fast::hash(&buf[..M::RECORD_LEN - 4]);
        buf[M::RECORD_LEN - 4..].copy_from_slice(&crc.to_le_bytes());
        let err = M::restore(&buf).unwrap_err();
        assert_eq!(err, AdverseError::UnsupportedVersion(3));
        extern crate std;
        use std::string::ToString;
        assert_eq!(err.to_string(), "unsupported record version 3");
    }

    #[test]
    fn sensors_map_to_streams_and_back() {
        for (i, k) in SensorKind::ALL.iter().enumerate() {
            assert_eq!(*k as usize, i);
            assert_eq!(SensorKind::of(k.stream()), Some(*k));
            assert_eq!(k.name(), k.stream().name());
        }
        let tracked = Stream::ALL
            .iter()
            .filter(|s| SensorKind::of(**s).is_some())
            .count();
        assert_eq!(tracked, SensorKind::COUNT);
    }
}
