//! Grip table: lookups, monotonic relations, blending by fractions.

use ego_ekf::GripParams;
use ego_ekf::surface::{
    GripModel, GripTable, GripTableError, SurfaceKind, SurfaceMix, WheelType, lerp_params,
};

#[test]
fn defaults_rank_floors_as_expected() {
    let t = GripTable::default();
    for w in WheelType::ALL {
        let wood = t.grip(SurfaceKind::Wood, w);
        let tile = t.grip(SurfaceKind::Tile, w);
        let concrete = t.grip(SurfaceKind::Concrete, w);
        let carpet = t.grip(SurfaceKind::Carpet, w);
        assert!(wood >= 0.75 && tile >= 0.75 && concrete >= 0.75, "{w:?}");
        assert!(carpet < wood && carpet < tile && carpet < concrete, "{w:?}");
        // Carpet and threshold strips explain larger jolts than hard floors.
        let jolt = |k| t.params(k, w, 1.0).jolt_threshold();
        for hard in [SurfaceKind::Wood, SurfaceKind::Tile, SurfaceKind::Concrete] {
            assert!(jolt(SurfaceKind::Carpet) > jolt(hard));
            assert!(jolt(SurfaceKind::Threshold) > jolt(SurfaceKind::Carpet));
        }
    }
    // Treaded tyres grip better than hard rubber, omni rollers worse.
    for k in SurfaceKind::ALL {
        assert!(t.grip(k, WheelType::SoftTreaded) > t.grip(k, WheelType::HardRubber));
        assert!(t.grip(k, WheelType::Omni) < t.grip(k, WheelType::HardRubber));
    }
    // The documented model on one entry.
    let p = t.params(SurfaceKind::Carpet, WheelType::HardRubber, 1.0);
    assert_eq!(p.grip(), 0.60);
    assert!((p.forward_std() - 0.02 / 0.60).abs() < 1e-6);
    assert!((p.forward_gate() - 6.63 * (1.0 + 2.0 * 0.40)).abs() < 1e-4);
    assert!((p.jolt_threshold() - (0.8 + 3.0 * 1.5)).abs() < 1e-5);
}

#[test]
fn lower_grip_means_more_noise_and_a_wider_gate() {
    // Every pair of table entries, every wheel.
    let t = GripTable::default();
    let mut all: Vec<GripParams> = Vec::new();
    for k in SurfaceKind::ALL {
        for w in WheelType::ALL {
            all.push(t.params(k, w, 1.0));
        }
    }
    for a in &all {
        for b in &all {
            if a.grip() < b.grip() {
                assert!(a.forward_std() > b.forward_std());
                assert!(a.forward_gate() > b.forward_gate());
            }
        }
    }
    // And along a sweep of custom grips.
    let mut prev: Option<GripParams> = None;
    for i in 1..=20 {
        let g = i as f32 / 20.0;
        let table = GripTable::new([[g; 3]; 5], [0.5; 5], [1.0; 3], GripModel::default()).unwrap();
        let p = table.params(SurfaceKind::Wood, WheelType::HardRubber, 1.0);
        if let Some(q) = prev {
            assert!(p.forward_std() < q.forward_std());
            assert!(p.forward_gate() < q.forward_gate());
        }
        prev = Some(p);
    }
}

#[test]
fn learned_multiplier_scales_only_the_forward_noise() {
    let t = GripTable::default();
    let base = t.params(SurfaceKind::Tile, WheelType::HardRubber, 1.0);
    let up = t.params(SurfaceKind::Tile, WheelType::HardRubber, 2.0);
    assert!((up.forward_std() - 2.0 * base.forward_std()).abs() < 1e-6);
    assert_eq!(up.forward_gate(), base.forward_gate());
    assert_eq!(up.jolt_threshold(), base.jolt_threshold());
    // Nonsense multipliers count as 1.
    for m in [f32::NAN, -1.0, 0.0, f32::INFINITY] {
        assert_eq!(t.params(SurfaceKind::Tile, WheelType::HardRubber, m), base);
    }
}

#[test]
fn blended_params_are_the_fraction_weighted_mean() {
    let t = GripTable::default();
    let w = WheelType::HardRubber;
    let wood = t.params(SurfaceKind::Wood, w, 1.0);
    let carpet = t.params(SurfaceKind::Carpet, w, 1.0);
    let mut weights = [0.0; 5];
    weights[SurfaceKind::Wood.index()] = 3.0;
    weights[SurfaceKind::Carpet.index()] = 1.0;
    let mix = SurfaceMix::from_weights(&weights).unwrap();
    let b = t.blended(&mix, w, &[1.0; 5]);
    let mean = |x: f32, y: f32| 0.75 * x + 0.25 * y;
    assert!((b.grip() - mean(wood.grip(), carpet.grip())).abs() < 1e-6);
    assert!((b.forward_std() - mean(wood.forward_std(), carpet.forward_std())).abs() < 1e-6);
    assert!((b.forward_gate() - mean(wood.forward_gate(), carpet.forward_gate())).abs() < 1e-4);
    assert!(
        (b.jolt_threshold() - mean(wood.jolt_threshold(), carpet.jolt_threshold())).abs() < 1e-5
    );
    // A pure mix is the entry itself.
    assert_eq!(
        t.blended(&SurfaceMix::pure(SurfaceKind::Carpet), w, &[1.0; 5]),
        carpet
    );
    // lerp_params ends on its ends.
    assert_eq!(lerp_params(&wood, &carpet, 0.0), wood);
    assert_eq!(lerp_params(&wood, &carpet, 1.0), carpet);
    assert_eq!(lerp_params(&wood, &carpet, f32::NAN), wood);
}

#[test]
fn table_is_checked() {
    let ok = GripTable::new([[0.5; 3]; 5], [0.5; 5], [1.0; 3], GripModel::default());
    assert!(ok.is_ok());
    let mut g = [[0.5; 3]; 5];
    g[2][1] = 0.0;
    assert_eq!(
        GripTable::new(g, [0.5; 5], [1.0; 3], GripModel::default()),
        Err(GripTableError::Grip)
    );
    g[2][1] = f32::NAN;
    assert_eq!(
        GripTable::new(g, [0.5; 5], [1.0; 3], GripModel::default()),
        Err(GripTableError::Grip)
    );
    assert_eq!(
        GripTable::new([[0.5; 3]; 5], [-0.5; 5], [1.0; 3], GripModel::default()),
        Err(GripTableError::Vibration)
    );
    let model = GripModel {
        base_forward_std: 0.0,
        ..GripModel::default()
    };
    assert_eq!(
        GripTable::new([[0.5; 3]; 5], [0.5; 5], [1.0; 3], model),
        Err(GripTableError::Model)
    );
}

#[test]
fn a_mix_without_a_kind_is_the_others_renormalised() {
    let mix = SurfaceMix::from_weights(&[0.2, 0.3, 0.0, 0.0, 0.5]).unwrap();
    let beside = mix.without(SurfaceKind::Threshold).unwrap();
    assert!((beside.fraction(SurfaceKind::Wood) - 0.4).abs() < 1e-6);
    assert!((beside.fraction(SurfaceKind::Carpet) - 0.6).abs() < 1e-6);
    assert_eq!(beside.fraction(SurfaceKind::Threshold), 0.0);
    assert!(
        SurfaceMix::pure(SurfaceKind::Threshold)
            .without(SurfaceKind::Threshold)
            .is_none()
    );
}
