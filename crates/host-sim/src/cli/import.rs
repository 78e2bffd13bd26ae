//! `host-sim import FORMAT ...`: a recorded log into an ASL dataset folder
//! that `host-sim replay` reads ([`crate::import`]).

use crate::error::CliError;
use crate::import;
use clap::{Args, Subcommand};
use std::path::PathBuf;

/// Arguments of `host-sim import`.
#[derive(Debug, Args)]
#[command(
    about = "Import a recorded log (OptiOdom, BorealTC, ROS 1 bag) as an ASL dataset",
    long_about = "Reads a log in its own format and writes an ASL dataset folder (mav0/...) that \
                  `host-sim replay` reads, with labels.yaml saying where it came from and what it \
                  lacks. Malformed input exits 2 naming the file and line; nothing is written then."
)]
pub struct ImportArgs {
    /// The log's format.
    #[command(subcommand)]
    pub format: ImportFormat,
}

/// The formats `import` reads.
#[derive(Debug, Subcommand)]
pub enum ImportFormat {
    /// OptiOdom run: per-cycle encoder ticks and OptiTrack ground truth of a
    /// differential drive, geometry from the session's metadata file.
    Optiodom {
        /// The run file, `<id>_run-NN.csv`.
        run: PathBuf,
        /// The metadata file (default: `<id>_metadata.csv` beside the run).
        #[arg(long, value_name = "FILE")]
        metadata: Option<PathBuf>,
        /// Output dataset folder.
        #[arg(long)]
        out: PathBuf,
    },
    /// BorealTC sequence (Husky): IMU and wheel speeds, with the terrain label.
    Borealtc {
        /// The IMU file, `imu_NN.csv`.
        imu: PathBuf,
        /// The wheel-speed file, `pro_NN.csv`.
        pro: PathBuf,
        /// Output dataset folder.
        #[arg(long)]
        out: PathBuf,
        /// Terrain label (default: the IMU file's folder name, e.g. ASPHALT).
        #[arg(long)]
        terrain: Option<String>,
        /// Wheel radius, m (wheel speeds are divided by it).
        #[arg(long, default_value_t = 0.13)]
        wheel_radius: f64,
        /// Physical track, m.
        #[arg(long, default_value_t = 0.555)]
        track: f64,
        /// Effective track of the skid steer, m (turn rate = (vR - vL) / this).
        #[arg(long, default_value_t = 1.0)]
        effective_track: f64,
    },
    /// ROS 1 bag (format 2.0, any compression): IMU, odometry twist as wheel
    /// rates, GPS fixes as an ENU reference, static transforms for T_BS.
    Rosbag {
        /// The `.bag` file.
        bag: PathBuf,
        /// Output dataset folder.
        #[arg(long)]
        out: PathBuf,
        /// sensor_msgs/Imu topic (default: the bag's only one).
        #[arg(long, value_name = "TOPIC")]
        imu_topic: Option<String>,
        /// nav_msgs/Odometry topic (default: the bag's only one).
        #[arg(long, value_name = "TOPIC")]
        odom_topic: Option<String>,
        /// sensor_msgs/NavSatFix topic (default: the bag's only one).
        #[arg(long, value_name = "TOPIC")]
        gps_topic: Option<String>,
        /// Wheel radius for the odometry's wheel rates, m (default: a Jackal's).
        #[arg(long, default_value_t = 0.098)]
        wheel_radius: f64,
        /// Track for the odometry's wheel rates, m (default: a Jackal's).
        #[arg(long, default_value_t = 0.37559)]
        track: f64,
    },
}

/// Runs `import`.
pub fn run(a: ImportArgs) -> Result<(), CliError> {
    let (ds, out) = match a.format {
        ImportFormat::Optiodom { run, metadata, out } => {
            (import::optiodom::read(&run, metadata.as_deref())?, out)
        }
        ImportFormat::Borealtc {
            imu,
            pro,
            out,
            terrain,
            wheel_radius,
            track,
            effective_track,
        } => {
            let g = import::borealtc::HuskyGeometry {
                wheel_radius,
                track,
                effective_track,
            };
            (
                import::borealtc::read(&imu, &pro, terrain.as_deref(), g)?,
                out,
            )
        }
        ImportFormat::Rosbag {
            bag,
            out,
            imu_topic,
            odom_topic,
            gps_topic,
            wheel_radius,
            track,
        } => {
            let o = import::rosbag::BagOptions {
                imu_topic,
                odom_topic,
                gps_topic,
                wheel_radius,
                track,
            };
            (import::rosbag::read(&bag, &o)?, out)
        }
    };
    import::write_imported(&out, &ds)?;
    let mut s = String::new();
    outln!(s, "wrote {}", out.display());
    let streams = [
        ("imu0", ds.imu.as_ref().map(|x| x.1.len())),
        ("wheel0", ds.wheel.as_ref().map(|x| x.1.len())),
        ("wheel0 (rates)", ds.wheel_rates.as_ref().map(|x| x.1.len())),
        (
            "state_groundtruth_estimate0",
            ds.groundtruth.as_ref().map(Vec::len),
        ),
    ];
    for (name, n) in streams {
        if let Some(n) = n {
            outln!(s, "  {name}: {n} rows");
        }
    }
    if let Some(l) = &ds.labels {
        for line in l.summary().lines() {
            outln!(s, "  {line}");
        }
    }
    super::write_stdout(&s)
}
