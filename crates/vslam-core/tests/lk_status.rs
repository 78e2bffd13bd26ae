//! Every status of the tracker has a case that produces it, and bad calls are errors.

use test_support::images::{Gray, shifted, texture};
use vslam_core::geometry::Vec2;
use vslam_core::lk::{
    Illumination, LkConfig, LkConfigError, LkError, LostReason, TrackResult, TrackStatus, Tracker,
};
use vslam_core::pyramid::{Pyramid, PyramidStorage};

/// `g` as the library's image view.
fn view(g: &Gray) -> vslam_core::image::ImageView<'_> {
    vslam_core::image::ImageView::packed(&g.data, g.width, g.height).unwrap()
}

type Storage = PyramidStorage<20_000>;

fn track(a: &Gray, b: &Gray, config: LkConfig, points: &[Vec2]) -> Vec<TrackResult> {
    let (mut sa, mut sb) = (Storage::new(), Storage::new());
    let (va, vb) = (view(a), view(b));
    let levels = config.levels.min(Pyramid::max_levels(a.width, a.height));
    let pa = Pyramid::build(&va, levels, &mut sa).unwrap();
    let pb = Pyramid::build(&vb, levels, &mut sb).unwrap();
    let mut out = vec![TrackResult::EMPTY; points.len()];
    let counts = Tracker::new(config)
        .unwrap()
        .track(&pa, &pb, points, &mut out)
        .unwrap();
    assert_eq!(counts.tracked + counts.lost_total(), points.len());
    out
}

fn lost(r: &TrackResult) -> Option<LostReason> {
    match r.status {
        TrackStatus::Tracked => None,
        TrackStatus::Lost(reason) => Some(reason),
    }
}

#[test]
fn a_textured_point_is_tracked_to_its_shift() {
    let a = texture(96, 96, 1);
    let b = shifted(&a, 1.3, -0.6);
    let r = track(&a, &b, LkConfig::default(), &[Vec2::new(48.0, 40.0)]);
    assert!(r[0].is_tracked(), "{r:?}");
    let err = (r[0].position - Vec2::new(49.3, 39.4)).norm();
    assert!(err < 0.05, "error {err} px");
    assert!(r[0].residual < 5.0, "{r:?}");
    assert_eq!(r[0].fb_error, None);
}

#[test]
fn a_window_leaving_the_image_is_out_of_bounds() {
    let a = texture(96, 96, 2);
    // Start too close to the edge for a 21x21 window.
    let r = track(
        &a,
        &a,
        LkConfig::default(),
        &[Vec2::new(5.0, 50.0), Vec2::new(50.0, 90.5)],
    );
    assert_eq!(lost(&r[0]), Some(LostReason::OutOfBounds));
    assert_eq!(lost(&r[1]), Some(LostReason::OutOfBounds));
    // Start inside, but the content moves out: the level-0 window leaves the image.
    let b = shifted(&a, -6.0, 0.0);
    let r = track(&a, &b, LkConfig::default(), &[Vec2::new(13.0, 50.0)]);
    assert_eq!(lost(&r[0]), Some(LostReason::OutOfBounds), "{r:?}");
    // Far away and huge coordinates.
    let r = track(
        &a,
        &a,
        LkConfig::default(),
        &[Vec2::new(-1e30, 3.0), Vec2::new(1e9, 1e9)],
    );
    assert!(
        r.iter().all(|r| lost(r) == Some(LostReason::OutOfBounds)),
        "{r:?}"
    );
}

#[test]
fn textureless_windows_have_a_low_eigenvalue() {
    let flat = Gray {
        data: vec![128; 64 * 64],
        width: 64,
        height: 64,
    };
    let r = track(&flat, &flat, LkConfig::default(), &[Vec2::new(32.0, 32.0)]);
    assert_eq!(lost(&r[0]), Some(LostReason::LowEigenvalue));
    // A single straight edge: one eigenvalue, the aperture problem.
    let edge = Gray {
        data: (0..64 * 64)
            .map(|i| if i % 64 < 32 { 40 } else { 200 })
            .collect(),
        width: 64,
        height: 64,
    };
    let r = track(&edge, &edge, LkConfig::default(), &[Vec2::new(32.0, 32.0)]);
    assert_eq!(lost(&r[0]), Some(LostReason::LowEigenvalue));
}

#[test]
fn non_finite_points_are_invalid_never_a_panic() {
    let a = texture(64, 64, 3);
    let pts = [
        Vec2::new(f32::NAN, 30.0),
        Vec2::new(30.0, f32::INFINITY),
        Vec2::new(f32::NEG_INFINITY, f32::NAN),
    ];
    let r = track(&a, &a, LkConfig::default(), &pts);
    assert!(
        r.iter().all(|r| lost(r) == Some(LostReason::InvalidPoint)),
        "{r:?}"
    );
    // A non-finite guess, too.
    let mut sa = Storage::new();
    let va = view(&a);
    let p = Pyramid::build(&va, 3, &mut sa).unwrap();
    let t = Tracker::new(LkConfig::default()).unwrap();
    let r = t
        .track_point(
            &p,
            &p,
            Vec2::new(30.0, 30.0),
            Some(Vec2::new(f32::NAN, 1.0)),
        )
        .unwrap();
    assert_eq!(lost(&r), Some(LostReason::InvalidPoint));
    // A good guess is used.
    let b = shifted(&a, 9.0, 0.0);
    let mut sb = Storage::new();
    let vb = view(&b);
    let pb = Pyramid::build(&vb, 1, &mut sb).unwrap();
    let p1 = Pyramid::build(&va, 1, &mut sa).unwrap();
    let guess = t
        .track_point(&p1, &pb, Vec2::new(30.0, 30.0), Some(Vec2::new(38.5, 30.0)))
        .unwrap();
    assert!(
        guess.is_tracked() && (guess.position.x - 39.0).abs() < 0.05,
        "{guess:?}"
    );
}

/// With constant brightness (the default); the gain-bias model tracks the
/// same pair (next test).
#[test]
fn a_brightness_change_gives_a_large_residual() {
    let a = texture(96, 96, 4);
    let mut b = shifted(&a, 0.5, 0.5);
    for v in &mut b.data {
        *v = v.saturating_add(50);
    }
    let r = track(&a, &b, LkConfig::default(), &[Vec2::new(48.0, 48.0)]);
    assert_eq!(lost(&r[0]), Some(LostReason::LargeResidual), "{r:?}");
    assert!(r[0].residual > 30.0);
    let lenient = LkConfig {
        max_residual: f32::INFINITY,
        ..LkConfig::default()
    };
    assert!(track(&a, &b, lenient, &[Vec2::new(48.0, 48.0)])[0].is_tracked());
}

fn gain_bias() -> LkConfig {
    LkConfig {
        illumination: Illumination::GAIN_BIAS,
        ..LkConfig::default()
    }
}

#[test]
fn the_gain_bias_model_tracks_through_a_brightness_change() {
    // The pair above, and the same scene at 0.6 of the contrast, 70 levels brighter.
    let a = texture(96, 96, 4);
    let mut b = shifted(&a, 0.5, 0.5);
    for v in &mut b.data {
        *v = v.saturating_add(50);
    }
    let mut c = shifted(&a, 0.5, 0.5);
    for v in &mut c.data {
        *v = (0.6 * f32::from(*v) + 70.0).round() as u8;
    }
    for relit in [&b, &c] {
        let r = track(&a, relit, gain_bias(), &[Vec2::new(48.0, 48.0)]);
        assert!(r[0].is_tracked(), "{r:?}");
        let err = (r[0].position - Vec2::new(48.5, 48.5)).norm();
        assert!(err < 0.05, "error {err} px");
        // The normalised residual sqrt(2 (1 - ZNCC)): near 0 for a match.
        assert!(r[0].residual < 0.2, "{r:?}");
    }
}

#[test]
fn the_gain_bias_model_rejects_flat_inverted_and_foreign_windows() {
    let a = texture(96, 96, 8);
    let p = [Vec2::new(48.0, 48.0)];
    // A saturated (flat) next frame: no gain maps it onto the template.
    for level in [0u8, 128, 255] {
        let flat = Gray {
            data: vec![level; 96 * 96],
            width: 96,
            height: 96,
        };
        let r = track(&a, &flat, gain_bias(), &p);
        assert_eq!(lost(&r[0]), Some(LostReason::LargeResidual), "{r:?}");
        assert!(!r[0].residual.is_nan(), "{r:?}");
        assert!(r[0].position.x.is_finite() && r[0].position.y.is_finite());
        // A flat template is textureless, as with constant brightness.
        let r = track(&flat, &a, gain_bias(), &p);
        assert_eq!(lost(&r[0]), Some(LostReason::LowEigenvalue), "{r:?}");
    }
    // A negative: the gain would have to be negative (the iteration wanders
    // off, or stops on a poor match).
    let inverted = Gray {
        data: a.data.iter().map(|v| 255 - v).collect(),
        width: 96,
        height: 96,
    };
    let r = track(&a, &inverted, gain_bias(), &p);
    assert!(!r[0].is_tracked(), "{r:?}");
    // Another texture altogether.
    let other = texture(96, 96, 9);
    let r = track(&a, &other, gain_bias(), &p);
    assert!(!r[0].is_tracked(), "{r:?}");
    // Any limit of 2 or more accepts every window that converges.
    let lenient = LkConfig {
        illumination: Illumination::GainBias { max_residual: 2.0 },
        ..LkConfig::default()
    };
    let r = track(&a, &a, lenient, &p);
    // The same image: residual 0 up to f32 rounding of 1 - ZNCC (about 1e-6,
    // so about 0.002 after the square root).
    assert!(r[0].is_tracked() && r[0].residual < 0.01, "{r:?}");
}

#[test]
fn too_few_iterations_do_not_converge() {
    let a = texture(96, 96, 5);
    let b = shifted(&a, 2.5, 1.5);
    let one = LkConfig {
        max_iterations: 1,
        levels: 1,
        ..LkConfig::default()
    };
    let r = track(&a, &b, one, &[Vec2::new(48.0, 48.0)]);
    assert_eq!(lost(&r[0]), Some(LostReason::NotConverged), "{r:?}");
    assert_eq!(r[0].iterations, 1);
}

#[test]
fn forward_backward_rejects_occluded_points() {
    let a = texture(128, 128, 6);
    let mut b = shifted(&a, 3.0, 2.0);
    // An occluder with its own texture covers the moved neighbourhood of (64, 64).
    let occluder = texture(128, 128, 99);
    for y in 45..90 {
        for x in 45..90 {
            b.data[y * 128 + x] = occluder.data[y * 128 + x];
        }
    }
    let mut points = Vec::new();
    for y in [58.0, 64.0, 70.0, 76.0] {
        for x in [58.0, 64.0, 70.0, 76.0] {
            points.push(Vec2::new(x, y));
        }
    }
    let loose = LkConfig {
        max_residual: f32::INFINITY,
        ..LkConfig::default()
    };
    let without = track(&a, &b, loose, &points);
    let with = track(
        &a,
        &b,
        LkConfig {
            fb_threshold: Some(0.5),
            ..loose
        },
        &points,
    );
    let wrong_but_tracked = without
        .iter()
        .zip(&points)
        .filter(|(r, p)| r.is_tracked() && (r.position - *p - Vec2::new(3.0, 2.0)).norm() > 1.0)
        .count();
    let fb_rejected = with
        .iter()
        .filter(|r| lost(r) == Some(LostReason::ForwardBackward))
        .count();
    println!(
        "occluded: {wrong_but_tracked} of {} wrongly tracked without the check, {fb_rejected} rejected by it",
        points.len()
    );
    assert!(
        wrong_but_tracked >= 4,
        "the case must fool the plain tracker"
    );
    assert!(
        fb_rejected >= wrong_but_tracked,
        "{fb_rejected} < {wrong_but_tracked}"
    );
    for (r, p) in with.iter().zip(&points) {
        let err = (r.position - *p - Vec2::new(3.0, 2.0)).norm();
        assert!(
            !r.is_tracked() || err < 1.0,
            "wrong point kept: {r:?} from {p:?}"
        );
    }
    // Unoccluded points pass the same check.
    let clear = [
        Vec2::new(20.0, 20.0),
        Vec2::new(100.0, 25.0),
        Vec2::new(25.0, 105.0),
    ];
    let r = track(
        &a,
        &b,
        LkConfig {
            fb_threshold: Some(0.5),
            ..loose
        },
        &clear,
    );
    for r in &r {
        assert!(r.is_tracked(), "{r:?}");
        assert!(r.fb_error.is_some_and(|e| e < 0.1), "{r:?}");
    }
}

#[test]
fn call_errors() {
    let a = texture(64, 64, 7);
    let small = texture(32, 64, 7);
    let (mut sa, mut sb) = (Storage::new(), Storage::new());
    let (va, vs) = (view(&a), view(&small));
    let pa = Pyramid::build(&va, 2, &mut sa).unwrap();
    let ps = Pyramid::build(&vs, 2, &mut sb).unwrap();
    let t = Tracker::new(LkConfig::default()).unwrap();
    let pts = [Vec2::new(30.0, 30.0); 3];
    let mut out = [TrackResult::EMPTY; 2];
    assert_eq!(
        t.track(&pa, &pa, &pts, &mut out),
        Err(LkError::OutputTooSmall {
            points: 3,
            results: 2
        })
    );
    assert_eq!(
        t.track(&pa, &ps, &pts[..2], &mut out),
        Err(LkError::SizeMismatch)
    );
    let bad = |c: LkConfig| Tracker::new(c).err();
    let d = LkConfig::default();
    assert_eq!(
        bad(LkConfig { window: 20, ..d }),
        Some(LkConfigError::Window)
    );
    assert_eq!(
        bad(LkConfig { window: 33, ..d }),
        Some(LkConfigError::Window)
    );
    assert_eq!(
        bad(LkConfig { window: 1, ..d }),
        Some(LkConfigError::Window)
    );
    assert_eq!(
        bad(LkConfig { levels: 0, ..d }),
        Some(LkConfigError::Levels)
    );
    assert_eq!(
        bad(LkConfig {
            max_iterations: 0,
            ..d
        }),
        Some(LkConfigError::Iterations)
    );
    assert_eq!(
        bad(LkConfig {
            epsilon: f32::NAN,
            ..d
        }),
        Some(LkConfigError::Epsilon)
    );
    for coarse in [0.0, -0.1, f32::NAN, f32::INFINITY] {
        assert_eq!(
            bad(LkConfig {
                coarse_epsilon: Some(coarse),
                ..d
            }),
            Some(LkConfigError::CoarseEpsilon),
            "{coarse}"
        );
    }
    assert_eq!(
        bad(LkConfig {
            min_eigenvalue: -1.0,
            ..d
        }),
        Some(LkConfigError::MinEigenvalue)
    );
    assert_eq!(
        bad(LkConfig {
            max_residual: 0.0,
            ..d
        }),
        Some(LkConfigError::MaxResidual)
    );
    assert_eq!(
        bad(LkConfig {
            fb_threshold: Some(f32::INFINITY),
            ..d
        }),
        Some(LkConfigError::FbThreshold)
    );
    for limit in [0.0, -0.5, f32::NAN, f32::INFINITY] {
        assert_eq!(
            bad(LkConfig {
                illumination: Illumination::GainBias {
                    max_residual: limit
                },
                ..d
            }),
            Some(LkConfigError::GainBiasResidual),
            "{limit}"
        );
    }
    assert_eq!(d.illumination, Illumination::Constant);
    assert!(
        Tracker::new(LkConfig {
            illumination: Illumination::GAIN_BIAS,
            ..d
        })
        .is_ok()
    );
    assert!(
        Tracker::new(LkConfig {
            window: 31,
            levels: 8,
            ..d
        })
        .is_ok()
    );
}
