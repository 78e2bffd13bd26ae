//! Adverse-event memory: repeated events lower a sensor's weight in that
//! cell and time slot only, places far apart never share a cell, the least
//! recently used cell makes room when the map is full, levels decay, and the
//! byte record round-trips with typed errors for corrupt data.

use vslam_core::Timestamp;
use vslam_core::adverse::{
    AdverseError, AdverseKind, AdverseMemory, AdverseParams, SensorKind, SlotLengths,
};
use vslam_core::geometry::Vec2;

type M = AdverseMemory<16, 4>;
const HOUR: u64 = 3600 * 1_000_000_000;

fn params() -> AdverseParams {
    AdverseParams {
        cell_size: 0.5,
        cycle_ns: 24 * HOUR,
        slot_ns: SlotLengths::uniform(6 * HOUR),
        decay_period_ns: 24 * HOUR,
        decay_factor: 0.5,
        weight_per_event: 0.5,
    }
}

/// [`params`] with one day-long slot for every sensor.
fn one_slot() -> AdverseParams {
    AdverseParams {
        slot_ns: SlotLengths::uniform(24 * HOUR),
        ..params()
    }
}

#[test]
fn repeated_events_lower_the_weight_there_only() {
    let mut m = M::new(params()).unwrap();
    let carpet = Vec2::new(1.2, 0.7);
    let t = Timestamp(HOUR);
    m.record(SensorKind::Wheel, AdverseKind::Slip, &carpet, t)
        .unwrap();
    assert_eq!(
        m.weight(SensorKind::Wheel, &carpet, t),
        1.0,
        "a single event is chance"
    );
    for k in 1..4 {
        m.record(
            SensorKind::Wheel,
            AdverseKind::Slip,
            &carpet,
            Timestamp(HOUR + k),
        )
        .unwrap();
    }
    let w = m.weight(SensorKind::Wheel, &carpet, t);
    assert!((w - 1.0 / (1.0 + 0.5 * 3.0)).abs() < 1e-6, "{w}");
    // Same cell (0.5 m cells), another sensor, another cell, another slot: untouched.
    assert!(m.weight(SensorKind::Wheel, &Vec2::new(1.4, 0.9), t) < 1.0);
    assert_eq!(m.weight(SensorKind::Flow, &carpet, t), 1.0);
    assert_eq!(m.weight(SensorKind::Wheel, &Vec2::new(2.2, 0.7), t), 1.0);
    assert_eq!(
        m.weight(SensorKind::Wheel, &carpet, Timestamp(7 * HOUR)),
        1.0
    );
    assert_eq!(m.tally(SensorKind::Wheel, AdverseKind::Slip), 4);
    assert_eq!(m.tally(SensorKind::Wheel, AdverseKind::Stuck), 0);
    // Places far apart never share a cell (no wrap).
    assert_eq!(
        m.weight(SensorKind::Wheel, &Vec2::new(1.2 + 4.0, 0.7 - 8.0), t),
        1.0
    );
    assert_eq!(
        m.weight(SensorKind::Wheel, &Vec2::new(1.2 + 8.0, 0.7), t),
        1.0
    );
    assert_eq!(
        m.record(
            SensorKind::Wheel,
            AdverseKind::Slip,
            &Vec2::new(f32::NAN, 0.0),
            t
        ),
        Err(AdverseError::NonFinitePosition)
    );
}

#[test]
fn levels_decay_over_time() {
    let mut m = M::new(params()).unwrap();
    let p = Vec2::new(0.1, 0.1);
    for k in 0..5 {
        m.record(SensorKind::Flow, AdverseKind::Blank, &p, Timestamp(k))
            .unwrap();
    }
    assert!((m.events(SensorKind::Flow, &p, Timestamp(5)) - 5.0).abs() < 1e-3);
    // One day later (same slot of the day): half the level.
    let day = Timestamp(24 * HOUR + 5);
    assert!((m.events(SensorKind::Flow, &p, day) - 2.5).abs() < 1e-2);
    m.decay_to(day);
    assert!((m.events(SensorKind::Flow, &p, day) - 2.5).abs() < 1e-2);
    // Ten days later the weight is back to one.
    assert_eq!(
        m.weight(SensorKind::Flow, &p, Timestamp(240 * HOUR + 5)),
        1.0
    );
}

#[test]
fn record_round_trips_and_corruption_is_typed() {
    let mut m = M::new(params()).unwrap();
    m.record(
        SensorKind::Camera,
        AdverseKind::Blank,
        &Vec2::new(-3.0, 2.0),
        Timestamp(9),
    )
    .unwrap();
    m.record(
        SensorKind::Wheel,
        AdverseKind::Outlier,
        &Vec2::new(1.0, 1.0),
        Timestamp(10),
    )
    .unwrap();
    let mut buf = vec![0u8; M::RECORD_LEN + 7];
    assert_eq!(
        m.export(&mut buf[..M::RECORD_LEN - 1]),
        Err(AdverseError::BufferTooSmall)
    );
    let n = m.export(&mut buf).unwrap();
    assert_eq!(n, M::RECORD_LEN);
    assert_eq!(&buf[..4], b"TRAM");
    assert_eq!(buf[4], 4, "version");
    let back = M::restore(&buf[..n]).unwrap();
    assert_eq!(back, m);

    assert_eq!(M::restore(&buf[..n - 1]), Err(AdverseError::TooShort));
    assert_eq!(M::restore(&buf[..3]), Err(AdverseError::TooShort));
    let mut bad = buf.clone();
    bad[0] = b'X';
    assert_eq!(M::restore(&bad), Err(AdverseError::BadMagic));
    let mut bad = buf.clone();
    bad[4] = 1;
    assert_eq!(M::restore(&bad), Err(AdverseError::UnsupportedVersion(1)));
    let mut bad = buf.clone();
    bad[100] ^= 1;
    assert_eq!(M::restore(&bad), Err(AdverseError::BadChecksum));
    // Another shape is refused as such.
    assert_eq!(
        AdverseMemory::<16, 3>::restore(&buf),
        Err(AdverseError::ShapeMismatch)
    );
    assert_eq!(
        AdverseMemory::<8, 4>::restore(&buf),
        Err(AdverseError::ShapeMismatch)
    );
    // More cells than the capacity, resealed with a valid checksum: refused.
    let mut bad = buf.clone();
    bad[12..14].copy_from_slice(&17u16.to_le_bytes());
    let crc = crc32fast::hash(&bad[..M::RECORD_LEN - 4]);
    bad[M::RECORD_LEN - 4..M::RECORD_LEN].copy_from_slice(&crc.to_le_bytes());
    assert_eq!(M::restore(&bad), Err(AdverseError::BadCells));
}

/// Cell centres of a 30 m x 30 m home at 0.25 m cells, row by row.
fn home_cells() -> impl Iterator<Item = Vec2> {
    (0..120).flat_map(|iy| {
        (0..120).map(move |ix| Vec2::new(0.125 + 0.25 * ix as f32, 0.125 + 0.25 * iy as f32))
    })
}

#[test]
fn a_30_m_home_at_quarter_metre_cells_never_aliases() {
    // Two events in every one of the 14,400 cells, one cell at a time, into
    // a map with room for all of them: each cell then holds exactly its own
    // two events, none of a neighbour's or of a cell 8 m (or any) away.
    type Big = AdverseMemory<14_400, 1>;
    let params = AdverseParams {
        cell_size: 0.25,
        ..one_slot()
    };
    let mut m = Box::new(Big::new(params).unwrap());
    for (k, p) in home_cells().enumerate() {
        for _ in 0..2 {
            m.record(
                SensorKind::Wheel,
                AdverseKind::Slip,
                &p,
                Timestamp(k as u64),
            )
            .unwrap();
        }
    }
    assert_eq!(m.cells(), 14_400);
    assert_eq!(m.evicted(), 0);
    let t = Timestamp(14_400);
    for p in home_cells() {
        assert!(
            (m.events(SensorKind::Wheel, &p, t) - 2.0).abs() < 1e-3,
            "{p:?}"
        );
    }
    // Just outside the home: nothing.
    assert_eq!(m.events(SensorKind::Wheel, &Vec2::new(-0.1, 15.0), t), 0.0);
    assert_eq!(m.events(SensorKind::Wheel, &Vec2::new(30.1, 15.0), t), 0.0);
}

#[test]
fn a_full_map_evicts_the_least_recently_used_cell() {
    type Small = AdverseMemory<3, 1>;
    let mut m = Small::new(one_slot()).unwrap();
    let (a, b, c, d) = (
        Vec2::new(0.1, 0.1),
        Vec2::new(5.1, 0.1),
        Vec2::new(10.1, 0.1),
        Vec2::new(15.1, 0.1),
    );
    let ev = |m: &mut Small, p: &Vec2, t: u64| {
        m.record(SensorKind::Flow, AdverseKind::Blank, p, Timestamp(t))
            .unwrap();
    };
    ev(&mut m, &a, 1);
    ev(&mut m, &b, 2);
    ev(&mut m, &c, 3);
    // `a` is used again: `b` is now the least recently used.
    ev(&mut m, &a, 4);
    ev(&mut m, &d, 5);
    assert_eq!((m.cells(), m.evicted()), (3, 1));
    let t = Timestamp(6);
    let events = |m: &Small, p: &Vec2| m.events(SensorKind::Flow, p, t);
    assert!((events(&m, &a) - 2.0).abs() < 1e-3);
    assert_eq!(events(&m, &b), 0.0, "the least recently used cell is gone");
    assert!((events(&m, &c) - 1.0).abs() < 1e-3);
    assert!((events(&m, &d) - 1.0).abs() < 1e-3);
    // The tallies keep every event, evicted or not.
    assert_eq!(m.tally(SensorKind::Flow, AdverseKind::Blank), 5);
    // The record keeps the eviction count and the cells.
    let mut buf = vec![0u8; Small::RECORD_LEN];
    m.export(&mut buf).unwrap();
    assert_eq!(Small::restore(&buf).unwrap(), m);
}

#[test]
fn bad_settings_are_refused() {
    let bad = AdverseParams {
        cell_size: 0.0,
        ..params()
    };
    assert_eq!(M::new(bad), Err(AdverseError::BadParams));
    let bad = AdverseParams {
        decay_factor: 1.5,
        ..params()
    };
    assert_eq!(M::new(bad), Err(AdverseError::BadParams));
    let bad = AdverseParams {
        slot_ns: SlotLengths {
            camera: 0,
            ..SlotLengths::uniform(6 * HOUR)
        },
        ..params()
    };
    assert_eq!(M::new(bad), Err(AdverseError::BadParams));
    // A slot longer than the cycle, or more slots in the cycle than the memory has.
    let bad = AdverseParams {
        slot_ns: SlotLengths {
            imu: 25 * HOUR,
            ..SlotLengths::uniform(6 * HOUR)
        },
        ..params()
    };
    assert_eq!(M::new(bad), Err(AdverseError::BadParams));
    let bad = AdverseParams {
        slot_ns: SlotLengths {
            flow: 5 * HOUR,
            ..SlotLengths::uniform(6 * HOUR)
        },
        ..params()
    };
    assert_eq!(M::new(bad), Err(AdverseError::BadParams));
    assert_eq!(
        AdverseMemory::<16, 2>::new(params()),
        Err(AdverseError::BadParams),
        "four 6 h slots in a day, room for two"
    );
    let bad = AdverseParams {
        cycle_ns: 0,
        ..params()
    };
    assert_eq!(M::new(bad), Err(AdverseError::BadParams));
}

#[test]
fn each_sensor_has_its_own_slot_length() {
    // The defaults: wheels and IMU one slot a day, flow and camera quarters.
    let d = SlotLengths::default();
    assert_eq!((d.wheel, d.imu), (24 * HOUR, 24 * HOUR));
    assert_eq!((d.flow, d.camera), (6 * HOUR, 6 * HOUR));
    let params = AdverseParams {
        decay_factor: 1.0,
        ..AdverseParams::default()
    };
    assert_eq!(params.slot_ns, d);
    let mut m = M::new(params).unwrap();
    let p = Vec2::new(2.1, -0.4);
    let morning = Timestamp(HOUR);
    for k in 0..3 {
        for s in SensorKind::ALL {
            m.record(s, AdverseKind::Outlier, &p, Timestamp(HOUR + k))
                .unwrap();
        }
    }
    let at = |m: &M, s, hours: u64| m.weight(s, &p, Timestamp(hours * HOUR));
    let low = m.weight(SensorKind::Wheel, &p, morning);
    assert!(low < 1.0, "{low}");
    for s in SensorKind::ALL {
        assert_eq!(at(&m, s, 1), low, "{s:?} in the slot of its events");
    }
    // Evening: the wheels' and the IMU's day-long slot still holds the
    // events; the flow sensor's and the camera's evening slot does not.
    for s in [SensorKind::Wheel, SensorKind::Imu] {
        assert_eq!(at(&m, s, 19), low, "{s:?}");
        assert_eq!(
            m.cell_slot(s, &p, Timestamp(19 * HOUR)).unwrap().slot,
            0,
            "{s:?}"
        );
    }
    for s in [SensorKind::Flow, SensorKind::Camera] {
        assert_eq!(at(&m, s, 19), 1.0, "{s:?}");
        assert_eq!(m.cell_slot(s, &p, Timestamp(19 * HOUR)).unwrap().slot, 3);
        // The next morning is the same slot again (the cycle is a day).
        assert_eq!(at(&m, s, 25), low, "{s:?}");
    }
    // The lengths travel with the record.
    let mut buf = vec![0u8; M::RECORD_LEN];
    m.export(&mut buf).unwrap();
    let back = M::restore(&buf).unwrap();
    assert_eq!(back.params().slot_ns, d);
    assert_eq!(back, m);
}
