//! What the simulator knows and a recorded log does not: the floor map
//! (rooms and their surfaces), threshold strips and cables, and the timed
//! slip, stuck and lift episodes. `simulate` writes it beside the dataset as
//! `DATASET/world.json`; `replay` reads it when it is there, and the plots
//! draw it as a background map and markers.

use crate::error::CliError;
use crate::sim::scenario::Scenario;
use crate::sim::script::EpisodeKind;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Largest distance of anything in a scene from the origin, metres.
pub const SCENE_LIMIT_M: f64 = 1.0e5;

/// File name of the scene, in the dataset folder (beside `mav0`).
pub const SCENE_FILE: &str = "world.json";

/// One room: an axis-aligned rectangle of one floor surface.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneRoom {
    /// Lower corner `[x, y]`, metres.
    pub min: [f64; 2],
    /// Upper corner `[x, y]`, metres.
    pub max: [f64; 2],
    /// Surface name (`wood`, `carpet`, `tile`, `concrete`).
    pub surface: String,
}

/// A raised line across the floor at `x = at`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneStrip {
    /// Position along x, metres.
    pub at: f64,
    /// Height, metres.
    pub height: f64,
    /// `true` for a threshold strip, `false` for a cable (an obstacle).
    pub threshold: bool,
}

/// A timed episode of the drive.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneEpisode {
    /// Start, nanoseconds (the simulator's logs start at 0).
    pub start_ns: u64,
    /// End, nanoseconds.
    pub end_ns: u64,
    /// `slip`, `stuck` or `lifted`.
    pub kind: String,
}

/// The simulated world and the drive's episodes.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Scene {
    /// Scenario name.
    pub scenario: String,
    /// Rooms.
    pub rooms: Vec<SceneRoom>,
    /// Threshold strips and cables.
    pub strips: Vec<SceneStrip>,
    /// Slip, stuck and lift episodes.
    pub episodes: Vec<SceneEpisode>,
}

fn ns(seconds: f64) -> u64 {
    (seconds.max(0.0) * 1e9).round() as u64
}

impl Scene {
    /// The scene of scenario `sc`.
    pub fn of(sc: &Scenario) -> Self {
        Scene {
            scenario: sc.name.to_string(),
            rooms: sc
                .world
                .rooms
                .iter()
                .map(|r| SceneRoom {
                    min: r.min,
                    max: r.max,
                    surface: r.surface.name().to_string(),
                })
                .collect(),
            strips: sc
                .world
                .strips
                .iter()
                .map(|s| SceneStrip {
                    at: s.at,
                    height: s.height,
                    threshold: s.threshold,
                })
                .collect(),
            episodes: sc
                .script
                .episodes
                .iter()
                .map(|e| SceneEpisode {
                    start_ns: ns(e.start),
                    end_ns: ns(e.end),
                    kind: match e.kind {
                        EpisodeKind::Spin(_) => "slip",
                        EpisodeKind::Stuck => "stuck",
                        EpisodeKind::Lifted => "lifted",
                    }
                    .to_string(),
                })
                .collect(),
        }
    }

    /// Writes `DATASET/world.json`.
    pub fn write(&self, dataset: &Path) -> Result<(), CliError> {
        let p = dataset.join(SCENE_FILE);
        let text =
            serde_json::to_string_pretty(self).map_err(|e| CliError::file(&p, e.to_string()))?;
        std::fs::write(&p, text).map_err(|e| CliError::file(&p, format!("cannot write: {e}")))
    }

    /// Reads `DATASET/world.json`; `Ok(None)` when the dataset has none (a
    /// recorded log).
    pub fn read(dataset: &Path) -> Result<Option<Self>, CliError> {
        let p = dataset.join(SCENE_FILE);
        if !p.exists() {
            return Ok(None);
        }
        let text = std::fs::read_to_string(&p)
            .map_err(|e| CliError::file(&p, format!("cannot read: {e}")))?;
        let scene: Scene = serde_json::from_str(&text)
            .map_err(|e| CliError::file(&p, format!("not a scene: {e}")))?;
        scene
            .check()
            .map(|()| Some(scene))
            .map_err(|e| CliError::file(&p, e))
    }

    /// Every position within [`SCENE_LIMIT_M`] of the origin, every room
    /// and episode with its end after its start, every room on a known
    /// surface.
    pub fn check(&self) -> Result<(), String> {
        let near = |v: &f64| v.is_finite() && v.abs() <= SCENE_LIMIT_M;
        for (i, r) in self.rooms.iter().enumerate() {
            let ok =
                r.min.iter().chain(&r.max).all(near) && r.min[0] < r.max[0] && r.min[1] < r.max[1];
            if !ok {
                return Err(format!(
                    "room {i}: corners within {SCENE_LIMIT_M} m, min below max"
                ));
            }
            if !["wood", "carpet", "tile", "concrete"].contains(&r.surface.as_str()) {
                return Err(format!("room {i}: unknown surface `{}`", r.surface));
            }
        }
        for (i, st) in self.strips.iter().enumerate() {
            if !(near(&st.at) && (0.0..=1.0).contains(&st.height)) {
                return Err(format!(
                    "strip {i}: position within {SCENE_LIMIT_M} m, height 0..1 m"
                ));
            }
        }
        for (i, e) in self.episodes.iter().enumerate() {
            if e.end_ns < e.start_ns {
                return Err(format!("episode {i}: ends before it starts"));
            }
            if !["slip", "stuck", "lifted"].contains(&e.kind.as_str()) {
                return Err(format!("episode {i}: unknown kind `{}`", e.kind));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_office_scene_round_trips_through_its_file() {
        let sc = Scenario::by_name("office").unwrap();
        let scene = Scene::of(&sc);
        assert!(scene.rooms.iter().any(|r| r.surface == "carpet"));
        assert!(scene.strips.iter().any(|s| !s.threshold), "the cable");
        assert!(scene.episodes.iter().any(|e| e.kind == "stuck"));
        let scratch = tempfile::tempdir().unwrap();
        let dir = scratch.path();
        scene.write(dir).unwrap();
        assert_eq!(Scene::read(dir).unwrap(), Some(scene));
        std::fs::write(dir.join(SCENE_FILE), "{").unwrap();
        assert!(Scene::read(dir).is_err());
        let mut bad = Scene::of(&sc);
        bad.rooms[0].max[0] = bad.rooms[0].min[0];
        bad.write(dir).unwrap();
        let e = Scene::read(dir).unwrap_err().to_string();
        assert!(e.contains("world.json") && e.contains("room 0"), "{e}");
        std::fs::remove_dir_all(dir).unwrap();
        assert_eq!(Scene::read(dir).unwrap(), None);
    }
}
