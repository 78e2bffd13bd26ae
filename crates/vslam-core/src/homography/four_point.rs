//! The exact homography through four correspondences, by the projective-basis
//! construction (Hartley & Zisserman, *Multiple View Geometry*, 2nd ed.,
//! sec. 2.3 and exercise 2.7.(x); Faugeras, *Three-Dimensional Computer
//! Vision*, 1993, sec. 2.4.4).
//!
//! Four points in general position are the images of the projective basis
//! `e1, e2, e3, (1,1,1)` under `B = A diag(lambda)`, `A = [p0 p1 p2]`,
//! `lambda = A^-1 p3`. The map between two such sets is `H = B2 B1^-1`. Written
//! with adjugates (`adj A = det(A) A^-1`, `c = adj(A) p3`):
//!
//! `H ~ A2 diag(c2 / c1) adj(A1)`.
//!
//! The entries of `c` and `det A` are twice the signed areas of the four
//! triangles the points make, so the collinearity test falls out of the
//! construction for free. No matrix is inverted and nothing iterates: this is
//! the fast path RANSAC uses for its minimal samples.

use super::normalize::Normalization;
use super::{Homography, HomographyError};
use crate::geometry::{Mat3, Vec2, Vec3};

/// Two points closer than this fraction of the sample's size coincide.
pub const DUPLICATE_TOLERANCE: f32 = 1e-5;

/// Three points whose doubled triangle area is below this fraction of the
/// sample's squared size are collinear.
pub const COLLINEAR_TOLERANCE: f32 = 1e-3;

/// Below this `|det H_n| / ||H_n||_F^3` (in normalised coordinates) an
/// estimate is rejected as near-singular. A similarity has `1/sqrt(27) = 0.19`.
pub(crate) const MIN_NORMALIZED_DET: f32 = 1e-6;

/// The exact homography `x2 ~ H x1` through four correspondences
/// (`points1[i] -> points2[i]`).
///
/// The points are Hartley-normalised per image first, so pixel coordinates of
/// any size keep `f32` precision.
///
/// # Errors
/// [`HomographyError::NonFinite`], [`HomographyError::DuplicatePoints`] or
/// [`HomographyError::Collinear`] (in either image),
/// [`HomographyError::NearSingular`].
pub fn from_four_points(
    points1: &[Vec2; 4],
    points2: &[Vec2; 4],
) -> Result<Homography, HomographyError> {
    for (index, (a, b)) in points1.iter().zip(points2.iter()).enumerate() {
        if !(a.x.is_finite() && a.y.is_finite() && b.x.is_finite() && b.y.is_finite()) {
            return Err(HomographyError::NonFinite { index });
        }
    }
    check_distinct(points1)?;
    check_distinct(points2)?;
    let t1 = Normalization::from_points(points1.iter())?;
    let t2 = Normalization::from_points(points2.iter())?;
    let n1 = points1.map(|p| t1.apply(&p));
    let n2 = points2.map(|p| t2.apply(&p));
    let hn = solve_normalized(&n1, &n2, false)?;
    Normalization::denormalize(&t1, &t2, &hn)
}

/// Fails with [`HomographyError::DuplicatePoints`] if two of the four points
/// coincide (relative to the sample's size).
fn check_distinct(p: &[Vec2; 4]) -> Result<(), HomographyError> {
    let [a, b, c, d] = p;
    let pairs = [(a, b), (a, c), (a, d), (b, c), (b, d), (c, d)];
    let d2 = pairs.map(|(u, v)| (u - v).norm_squared());
    let size2 = d2.iter().fold(0.0f32, |m, v| m.max(*v));
    let tol2 = DUPLICATE_TOLERANCE * DUPLICATE_TOLERANCE * size2;
    if !(size2 > 0.0) || d2.iter().any(|v| !(*v > tol2)) {
        return Err(HomographyError::DuplicatePoints);
    }
    Ok(())
}

/// `A = [p0 p1 p2]` (homogeneous columns), `adj A`, and `c = adj(A) p3`; checks
/// that no three points are collinear. Returns `(A, adj A, c, det A)`.
#[inline]
fn basis(p: &[Vec2; 4]) -> Result<(Mat3, Mat3, Vec3, f32), HomographyError> {
    let [p0, p1, p2, p3] = p;
    let a = Mat3::new(p0.x, p1.x, p2.x, p0.y, p1.y, p2.y, 1.0, 1.0, 1.0);
    // Adjugate by cofactors (transpose of the cofactor matrix).
    let adj = Mat3::new(
        p1.y - p2.y,
        p2.x - p1.x,
        p1.x * p2.y - p2.x * p1.y,
        p2.y - p0.y,
        p0.x - p2.x,
        p2.x * p0.y - p0.x * p2.y,
        p0.y - p1.y,
        p1.x - p0.x,
        p0.x * p1.y - p1.x * p0.y,
    );
    let det = (p1.x - p0.x) * (p2.y - p0.y) - (p2.x - p0.x) * (p1.y - p0.y);
    let c = adj * Vec3::new(p3.x, p3.y, 1.0);
    // Squared size of the sample: the largest squared distance to p0 or p3.
    let size2 = [
        (p1 - p0).norm_squared(),
        (p2 - p0).norm_squared(),
        (p3 - p0).norm_squared(),
        (p1 - p3).norm_squared(),
        (p2 - p3).norm_squared(),
        (p2 - p1).norm_squared(),
    ]
    .iter()
    .fold(0.0f32, |m, v| m.max(*v));
    let tol = COLLINEAR_TOLERANCE * size2;
    if !(libm::fabsf(det) > tol && c.iter().all(|v| libm::fabsf(*v) > tol)) {
        return Err(HomographyError::Collinear);
    }
    Ok((a, adj, c, det))
}

/// The homography between two normalised four-point sets, `b ~ H a`, checked
/// for conditioning. With `same_orientation` the four triangles must keep
/// their orientation (true for every plane seen from the front by both
/// cameras); RANSAC uses this to drop impossible samples before scoring.
#[inline]
pub(crate) fn solve_normalized(
    a: &[Vec2; 4],
    b: &[Vec2; 4],
    same_orientation: bool,
) -> Result<Mat3, HomographyError> {
    let (_, adj_a, c_a, det_a) = basis(a)?;
    let (m_b, _, c_b, det_b) = basis(b)?;
    if same_orientation
        && !(det_a * det_b > 0.0 && c_a.iter().zip(c_b.iter()).all(|(x, y)| x * y > 0.0))
    {
        return Err(HomographyError::Degenerate);
    }
    let ratio = Vec3::new(c_b.x / c_a.x, c_b.y / c_a.y, c_b.z / c_a.z);
    let h = m_b * Mat3::from_diagonal(&ratio) * adj_a;
    check_conditioning(&h)?;
    Ok(h)
}

/// [`HomographyError::NearSingular`] unless `|det H| / ||H||_F^3` is above
/// [`MIN_NORMALIZED_DET`] (for an `H` between normalised point sets).
#[inline]
pub(crate) fn check_conditioning(h: &Mat3) -> Result<(), HomographyError> {
    let norm = h.norm();
    if !(norm > 0.0) || !norm.is_finite() {
        return Err(HomographyError::NearSingular);
    }
    let unit = h / norm;
    let det = unit.determinant();
    if !(libm::fabsf(det) > MIN_NORMALIZED_DET) {
        return Err(HomographyError::NearSingular);
    }
    Ok(())
}
