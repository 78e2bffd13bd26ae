//! The floor's expected slip: the grip table's prior, the floors where the
//! wheel radii are held, the blend with learned offsets, and the learner
//! (`surface::slip`) converging on a floor's true slip from innovations of
//! which the filter absorbs a part, with every refused sample counted.

use ego_ekf::surface::{
    GripTable, SlipConfig, SlipConfigError, SlipLearner, SurfaceKind, SurfaceMix, WheelType,
    lerp_params,
};
use vslam_core::Reject;

const W: WheelType = WheelType::SoftTreaded;

#[test]
fn the_prior_follows_the_lost_grip_and_low_grip_floors_hold_the_radii() {
    let t = GripTable::default();
    let gain = t.model().slip_gain;
    for k in SurfaceKind::ALL {
        let g = t.grip(k, W);
        assert!((t.slip_prior(k, W) - gain * (1.0 - g)).abs() < 1e-7);
        assert_eq!(t.params(k, W, 1.0).slip(), t.slip_prior(k, W));
        assert_eq!(t.holds_radius(k, W), g < t.model().radius_min_grip);
        assert_eq!(t.params(k, W, 1.0).learn_radius(), !t.holds_radius(k, W));
    }
    assert!(t.holds_radius(SurfaceKind::Carpet, W));
    assert!(!t.holds_radius(SurfaceKind::Wood, W));
    assert!(t.slip_prior(SurfaceKind::Carpet, W) > t.slip_prior(SurfaceKind::Wood, W));
}

#[test]
fn the_blend_adds_the_learned_offsets_and_any_carpet_holds_the_radii() {
    let t = GripTable::default();
    let ones = [1.0; SurfaceKind::COUNT];
    let mut offsets = [0.0; SurfaceKind::COUNT];
    offsets[SurfaceKind::Carpet.index()] = 0.02;
    let carpet = SurfaceMix::pure(SurfaceKind::Carpet);
    let p = t.blended_learned(&carpet, W, &ones, &offsets);
    assert!((p.slip() - (t.slip_prior(SurfaceKind::Carpet, W) + 0.02)).abs() < 1e-6);
    assert!(!p.learn_radius());
    let wood = SurfaceMix::pure(SurfaceKind::Wood);
    let p = t.blended_learned(&wood, W, &ones, &offsets);
    assert_eq!(p.slip(), t.slip_prior(SurfaceKind::Wood, W));
    assert!(p.learn_radius());
    // Without offsets the blend is the priors' blend.
    assert_eq!(
        t.blended(&wood, W, &ones),
        t.params(SurfaceKind::Wood, W, 1.0)
    );
    let mut w = [0.0; SurfaceKind::COUNT];
    w[SurfaceKind::Wood.index()] = 0.5;
    w[SurfaceKind::Carpet.index()] = 0.5;
    let half = SurfaceMix::from_weights(&w).unwrap();
    let p = t.blended_learned(&half, W, &ones, &offsets);
    let expect = 0.5 * (t.slip_prior(SurfaceKind::Wood, W) + t.slip_prior(SurfaceKind::Carpet, W))
        + 0.5 * 0.02;
    assert!((p.slip() - expect).abs() < 1e-6, "{} vs {expect}", p.slip());
    assert!(!p.learn_radius(), "half carpet holds the radii");
    // A non-finite offset counts as none.
    offsets[SurfaceKind::Carpet.index()] = f32::NAN;
    let p = t.blended_learned(&carpet, W, &ones, &offsets);
    assert_eq!(p.slip(), t.slip_prior(SurfaceKind::Carpet, W));
    // The blend towards the fallback keeps the radii held while either end
    // holds them, unless the other end has all the weight.
    let held = t.params(SurfaceKind::Carpet, W, 1.0);
    let free = t.params(SurfaceKind::Wood, W, 1.0);
    assert!(!lerp_params(&free, &held, 0.3).learn_radius());
    assert!(lerp_params(&free, &held, 0.0).learn_radius());
    assert!(!lerp_params(&free, &held, 1.0).learn_radius());
    assert!(lerp_params(&held, &free, 1.0).learn_radius());
}

/// A floor truly slipping `truth`, a filter that absorbs half of each
/// innovation, seeded uniform noise of 0.01 m/s (standard deviation) on the
/// innovation, wheels at 0.3 m/s. Gives the learned slip averaged over the
/// last quarter of the samples (the learner is an integrator: each noisy
/// sample moves it a little, its mean is what it found).
fn drive(learner: &mut SlipLearner, kind: SurfaceKind, truth: f32, samples: usize) -> f32 {
    let t = GripTable::default();
    let prior = t.slip_priors(W);
    let held = t.held_floors(W);
    let mix = SurfaceMix::pure(kind);
    let mut state = 0x1234_5678u32;
    let u = 0.3f32;
    let (mut sum, mut n) = (0.0f32, 0.0f32);
    for k in 0..samples {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        let noise = 0.01 * ((state >> 8) as f32 / (1u32 << 24) as f32 - 0.5) * 3.46;
        let s = prior[kind.index()] + learner.stats(kind).offset;
        let nu = 0.5 * (truth - s) * u + noise;
        let _ = learner.observe(&mix, nu, u, false, &prior, &held);
        if 4 * k >= 3 * samples {
            sum += prior[kind.index()] + learner.stats(kind).offset;
            n += 1.0;
        }
    }
    sum / n
}

#[test]
fn the_learner_finds_the_carpets_slip() {
    let mut l = SlipLearner::new(SlipConfig::default());
    let learned = drive(&mut l, SurfaceKind::Carpet, 0.0566, 4000);
    assert!((learned - 0.0566).abs() < 0.005, "learned {learned}");
    assert_eq!(l.counts().fused(), 4000);
    // The learning switched off keeps the prior.
    let mut off = SlipLearner::new(SlipConfig::off());
    let prior = GripTable::default().slip_prior(SurfaceKind::Carpet, W);
    assert!((drive(&mut off, SurfaceKind::Carpet, 0.0566, 1000) - prior).abs() < 1e-7);
}

#[test]
fn floors_that_learn_their_radii_do_not_learn_slip_and_refusals_are_counted() {
    let t = GripTable::default();
    let (prior, held) = (t.slip_priors(W), t.held_floors(W));
    let mut l = SlipLearner::new(SlipConfig::default());
    let wood = SurfaceMix::pure(SurfaceKind::Wood);
    let carpet = SurfaceMix::pure(SurfaceKind::Carpet);
    assert_eq!(
        l.observe(&wood, 0.05, 0.3, false, &prior, &held),
        Err(Reject::LowQuality)
    );
    assert_eq!(
        l.observe(&carpet, 0.05, 0.3, true, &prior, &held),
        Err(Reject::Gated)
    );
    assert_eq!(
        l.observe(&carpet, 0.05, 0.01, false, &prior, &held),
        Err(Reject::Degenerate)
    );
    assert_eq!(
        l.observe(&carpet, f32::NAN, 0.3, false, &prior, &held),
        Err(Reject::NonFinite)
    );
    assert_eq!(l.observe(&carpet, 0.05, 0.3, false, &prior, &held), Ok(()));
    assert_eq!(l.stats(SurfaceKind::Wood).offset, 0.0);
    assert!(l.stats(SurfaceKind::Carpet).offset > 0.0);
    let c = l.counts();
    assert_eq!(c.fused(), 1);
    assert_eq!(c.rejected(Reject::LowQuality), 1);
    assert_eq!(c.rejected(Reject::Gated), 1);
    assert_eq!(c.rejected(Reject::Degenerate), 1);
    assert_eq!(c.rejected(Reject::NonFinite), 1);
    // Huge innovations are capped, the slip stays in range.
    for _ in 0..10_000 {
        let _ = l.observe(&carpet, 10.0, 0.3, false, &prior, &held);
    }
    let s = prior[SurfaceKind::Carpet.index()] + l.stats(SurfaceKind::Carpet).offset;
    assert!((0.0..=0.5).contains(&s), "{s}");
    l.reset();
    assert_eq!(l.stats(SurfaceKind::Carpet).offset, 0.0);
}

#[test]
fn configurations_are_checked() {
    assert_eq!(
        SlipConfig::new(1.5, 0.05, 0.5, 0.2),
        Err(SlipConfigError::Rate)
    );
    assert_eq!(
        SlipConfig::new(f32::NAN, 0.05, 0.5, 0.2),
        Err(SlipConfigError::Rate)
    );
    assert_eq!(
        SlipConfig::new(0.01, 0.0, 0.5, 0.2),
        Err(SlipConfigError::Limits)
    );
    assert_eq!(
        SlipConfig::new(0.01, 0.05, 0.5, 1.5),
        Err(SlipConfigError::Limits)
    );
    assert!(SlipConfig::new(0.0, 0.05, 0.5, 0.2).is_ok());
}

#[test]
fn learned_slip_round_trips_and_corrupt_records_are_refused() {
    use ego_ekf::surface::{RecordError, SLIP_RECORD_LEN};
    let mut l = SlipLearner::new(SlipConfig::default());
    drive(&mut l, SurfaceKind::Carpet, 0.0566, 2000);
    let bytes = l.to_bytes(W);
    assert_eq!(bytes.len(), SLIP_RECORD_LEN);
    assert_eq!(&bytes[..4], b"TSLP");
    let fresh = SlipLearner::new(SlipConfig::default());
    let mut r = fresh;
    r.restore(&bytes, W).unwrap();
    for k in SurfaceKind::ALL {
        assert_eq!(r.stats(k), l.stats(k), "{k}");
    }
    assert!(r.stats(SurfaceKind::Carpet).offset > 0.01);
    // Every flipped bit is caught; the learner stays as it was.
    for i in 0..bytes.len() {
        for bit in 0..8 {
            let mut bad = bytes;
            bad[i] ^= 1 << bit;
            let mut r = fresh;
            let err = r.restore(&bad, W).unwrap_err();
            assert!(
                matches!(err, RecordError::Checksum | RecordError::Magic),
                "{i} {bit}"
            );
            assert_eq!(r, fresh);
        }
    }
    let mut r = fresh;
    assert_eq!(r.restore(&bytes[1..], W), Err(RecordError::Length));
    assert_eq!(
        r.restore(&bytes, WheelType::Omni),
        Err(RecordError::WheelMismatch)
    );
    let reseal = |mut b: [u8; SLIP_RECORD_LEN]| {
        let crc = crc32fast::hash(&b[..SLIP_RECORD_LEN - 4]);
        b[SLIP_RECORD_LEN - 4..].copy_from_slice(&crc.to_le_bytes());
        b
    };
    let mut b = bytes;
    b[4] = 9;
    assert_eq!(r.restore(&reseal(b), W), Err(RecordError::Version));
    let mut b = bytes;
    b[8..12].copy_from_slice(&f32::NAN.to_le_bytes());
    assert_eq!(r.restore(&reseal(b), W), Err(RecordError::Value));
    assert_eq!(r, fresh);
}
