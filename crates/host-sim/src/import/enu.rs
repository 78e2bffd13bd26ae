//! Geodetic (WGS 84 latitude, longitude, ellipsoidal height) to local
//! east-north-up metres about an origin: geodetic to Earth-centred
//! Earth-fixed, then rotated into the origin's tangent plane (the standard
//! conversion, e.g. Groves, "Principles of GNSS, Inertial, and Multisensor
//! Integrated Navigation Systems", 2nd ed., sections 2.4.2 and 2.3.3).

/// WGS 84 semi-major axis, m.
const A: f64 = 6_378_137.0;
/// WGS 84 flattening.
const F: f64 = 1.0 / 298.257_223_563;

/// Earth-centred Earth-fixed coordinates of a geodetic point (degrees, m).
pub fn ecef(lat_deg: f64, lon_deg: f64, h: f64) -> [f64; 3] {
    let e2 = F * (2.0 - F);
    let (sl, cl) = lat_deg.to_radians().sin_cos();
    let (so, co) = lon_deg.to_radians().sin_cos();
    let n = A / (1.0 - e2 * sl * sl).sqrt();
    [
        (n + h) * cl * co,
        (n + h) * cl * so,
        (n * (1.0 - e2) + h) * sl,
    ]
}

/// A local east-north-up frame at a geodetic origin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Enu {
    origin: [f64; 3],
    lat: f64,
    lon: f64,
}

impl Enu {
    /// The frame at `lat_deg`, `lon_deg`, `h`.
    pub fn at(lat_deg: f64, lon_deg: f64, h: f64) -> Self {
        Enu {
            origin: ecef(lat_deg, lon_deg, h),
            lat: lat_deg.to_radians(),
            lon: lon_deg.to_radians(),
        }
    }

    /// East, north, up of a geodetic point, m.
    pub fn of(&self, lat_deg: f64, lon_deg: f64, h: f64) -> [f64; 3] {
        let p = ecef(lat_deg, lon_deg, h);
        let d = [
            p[0] - self.origin[0],
            p[1] - self.origin[1],
            p[2] - self.origin[2],
        ];
        let (sl, cl) = self.lat.sin_cos();
        let (so, co) = self.lon.sin_cos();
        [
            -so * d[0] + co * d[1],
            -sl * co * d[0] - sl * so * d[1] + cl * d[2],
            cl * co * d[0] + cl * so * d[1] + sl * d[2],
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_steps_are_metres_east_north_and_up() {
        let lat = 46.78;
        let enu = Enu::at(lat, -71.27, 80.0);
        assert!(enu.of(lat, -71.27, 80.0).iter().all(|x| x.abs() < 1e-6));
        // One arc second of latitude is about 30.9 m here; of longitude,
        // 30.9 m * cos(latitude) less the ellipsoid's flattening (~21.2 m).
        let n = enu.of(lat + 1.0 / 3600.0, -71.27, 80.0);
        assert!((n[1] - 30.88).abs() < 0.05 && n[0].abs() < 1e-6, "{n:?}");
        let e = enu.of(lat, -71.27 + 1.0 / 3600.0, 80.0);
        assert!((e[0] - 21.22).abs() < 0.05 && e[1].abs() < 1e-3, "{e:?}");
        let u = enu.of(lat, -71.27, 90.0);
        assert!((u[2] - 10.0).abs() < 1e-6, "{u:?}");
        assert_eq!(ecef(0.0, 0.0, 0.0), [A, 0.0, 0.0]);
    }
}
