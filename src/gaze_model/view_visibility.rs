//! Which points a camera sees, from points alone: every point is splatted as a small disc
//! into a depth buffer, and a point is seen when it faces the camera and nothing splatted
//! lies clearly in front of it. Works the same on a mesh's vertices and on a point cloud, so
//! the gaze model sees one kind of view feature at training and at prediction.
use glam::DVec3;

use super::surface_points::SurfacePoints;
use crate::protocol::Protocol;
use crate::stimulus::camera::{CameraError, CameraPlan, Phase};

/// Per point, what the protocol's hold views show of it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ViewExposure {
    /// Fraction of the hold views in which the point is seen.
    pub seen_fraction: Vec<f64>,
    /// Mean over the views that see the point of 1 − (distance from the screen centre /
    /// half the screen diagonal); 0 when no view sees it.
    pub centre_closeness: Vec<f64>,
    /// Mean over the views that see the point of the cosine between its normal and the
    /// direction to the eye; 0 when no view sees it.
    pub facing: Vec<f64>,
    /// Fraction of evenly spread directions from which the point is seen by an orthographic
    /// camera: 1 on the convex hull's open side, low in cavities (ambient openness).
    pub openness: Vec<f64>,
}

/// The resolution the depth buffers are drawn at, as a fraction of the display: coarse
/// enough that splats of about 20k points close up, fine enough to resolve a head or a paw.
const VIEW_SCALE: f64 = 0.25;
const OPENNESS_DIRECTIONS: usize = 32;
const OPENNESS_GRID: usize = 128;

/// What the protocol's hold views and `OPENNESS_DIRECTIONS` orthographic views see.
pub fn view_exposure(
    points: &SurfacePoints,
    protocol: &Protocol,
) -> Result<ViewExposure, CameraError> {
    let n = points.len();
    let (center, radius) = bounds(points).ok_or(CameraError::NoPoints)?;
    let plan = CameraPlan::around(center, radius, protocol)?;
    let spacing = mean_spacing(points.len(), radius);
    let width = ((protocol.display.width_px as f64 * VIEW_SCALE).round() as usize).max(16);
    let height = ((protocol.display.height_px as f64 * VIEW_SCALE).round() as usize).max(16);
    let period = protocol.timing.hold_s + protocol.timing.move_s;
    let mut seen = vec![0usize; n];
    let mut closeness = vec![0.0; n];
    let mut facing = vec![0.0; n];
    let focal = 0.5 * height as f64 / (0.5 * plan.fov_y_deg.to_radians()).tan();
    let half_diagonal = 0.5 * ((width * width + height * height) as f64).sqrt();
    for k in 0..plan.viewpoints() {
        let cam = plan.at(k as f64 * period);
        debug_assert_eq!(cam.phase, Phase::Hold);
        let forward = (center - cam.eye).normalize();
        let project = |p: DVec3| -> Option<(f64, f64, f64)> {
            let (x, y, _) = cam.project(p)?;
            let depth = (p - cam.eye).dot(forward);
            Some((
                x * width as f64 / cam.width_px as f64,
                y * height as f64 / cam.height_px as f64,
                depth,
            ))
        };
        let to_eye = |p: DVec3| (cam.eye - p).normalize();
        let visible = splat_visibility(
            points,
            width,
            height,
            spacing,
            |p| project(p).map(|(x, y, d)| (x, y, d, spacing * focal / d)),
            to_eye,
        );
        for i in 0..n {
            if let Some((x, y)) = visible[i] {
                seen[i] += 1;
                let r =
                    ((x - 0.5 * width as f64).powi(2) + (y - 0.5 * height as f64).powi(2)).sqrt();
                closeness[i] += 1.0 - r / half_diagonal;
                facing[i] += points.normals[i].dot(to_eye(points.positions[i]));
            }
        }
    }
    let views = plan.viewpoints().max(1) as f64;
    let mut out = ViewExposure {
        seen_fraction: seen.iter().map(|&s| s as f64 / views).collect(),
        centre_closeness: closeness
            .iter()
            .zip(&seen)
            .map(|(c, &s)| if s > 0 { c / s as f64 } else { 0.0 })
            .collect(),
        facing: facing
            .iter()
            .zip(&seen)
            .map(|(f, &s)| if s > 0 { f / s as f64 } else { 0.0 })
            .collect(),
        openness: vec![0.0; n],
    };
    let pixel = 2.2 * radius / OPENNESS_GRID as f64;
    let mut open = vec![0usize; n];
    for d in fibonacci_directions(OPENNESS_DIRECTIONS) {
        let u = d.any_orthonormal_vector();
        let v = d.cross(u);
        let g = OPENNESS_GRID as f64;
        let visible = splat_visibility(
            points,
            OPENNESS_GRID,
            OPENNESS_GRID,
            spacing,
            |p| {
                let q = p - center;
                Some((
                    0.5 * g + q.dot(u) / pixel,
                    0.5 * g + q.dot(v) / pixel,
                    radius * 2.0 - q.dot(d),
                    spacing / pixel,
                ))
            },
            |_| d,
        );
        for (o, v) in open.iter_mut().zip(&visible) {
            *o += v.is_some() as usize;
        }
    }
    out.openness = open
        .iter()
        .map(|&o| o as f64 / OPENNESS_DIRECTIONS as f64)
        .collect();
    Ok(out)
}

/// Per point, its pixel position when seen. `place` maps a point to (x, y, depth along the
/// view, splat radius in pixels); `to_eye` gives the unit direction from a point to the eye.
/// A point is seen when it faces the eye (or has no normal) and lies within
/// `2 × spacing / cos` of the nearest splat at its pixel (cos: normal · direction to eye).
fn splat_visibility(
    points: &SurfacePoints,
    width: usize,
    height: usize,
    spacing: f64,
    place: impl Fn(DVec3) -> Option<(f64, f64, f64, f64)>,
    to_eye: impl Fn(DVec3) -> DVec3,
) -> Vec<Option<(f64, f64)>> {
    let mut depth = vec![f64::INFINITY; width * height];
    let placed: Vec<Option<(f64, f64, f64, f64)>> =
        points.positions.iter().map(|&p| place(p)).collect();
    for &(x, y, d, r) in placed.iter().flatten() {
        let r = r.clamp(0.5, 8.0);
        let (x0, x1) = ((x - r).floor().max(0.0), (x + r).ceil().min(width as f64));
        let (y0, y1) = ((y - r).floor().max(0.0), (y + r).ceil().min(height as f64));
        if x0 >= x1 || y0 >= y1 {
            continue;
        }
        for py in y0 as usize..y1 as usize {
            for px in x0 as usize..x1 as usize {
                let (cx, cy) = (px as f64 + 0.5 - x, py as f64 + 0.5 - y);
                if cx * cx + cy * cy <= r * r {
                    let cell = &mut depth[py * width + px];
                    *cell = cell.min(d);
                }
            }
        }
    }
    placed
        .iter()
        .zip(points.positions.iter().zip(&points.normals))
        .map(|(placed, (&p, &normal))| {
            let (x, y, d, _) = (*placed)?;
            if x < 0.0 || y < 0.0 || x >= width as f64 || y >= height as f64 {
                return None;
            }
            let facing = if normal == DVec3::ZERO {
                1.0
            } else {
                normal.dot(to_eye(p))
            };
            if facing <= 0.0 {
                return None;
            }
            // Seen edge-on, a surface's depth changes fast across a splat: the tolerance
            // grows as the cosine falls, or silhouettes would hide themselves.
            let front = depth[y as usize * width + x as usize];
            (d <= front + 2.0 * spacing / facing.max(0.15)).then_some((x, y))
        })
        .collect()
}

/// Bounding-box centre and the farthest point's distance from it.
pub fn bounds(points: &SurfacePoints) -> Option<(DVec3, f64)> {
    let first = *points.positions.first()?;
    let (lo, hi) = points
        .positions
        .iter()
        .fold((first, first), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    let center = (lo + hi) * 0.5;
    let radius = points
        .positions
        .iter()
        .map(|p| (*p - center).length())
        .fold(0.0, f64::max);
    Some((center, radius))
}

/// The typical distance between neighbouring points of `n` points spread over a surface of
/// about the area of a sphere of `radius` (a closed object's surface is of that order).
pub fn mean_spacing(n: usize, radius: f64) -> f64 {
    (4.0 * std::f64::consts::PI * radius * radius / n.max(1) as f64).sqrt()
}

/// `n` unit directions spread evenly over the sphere (a Fibonacci lattice).
pub fn fibonacci_directions(n: usize) -> Vec<DVec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - y * y).sqrt();
            DVec3::new(
                r * (golden * i as f64).cos(),
                y,
                r * (golden * i as f64).sin(),
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sphere_is_open_everywhere_and_seen_from_about_half_the_views() {
        let dirs = fibonacci_directions(6000);
        let points = SurfacePoints {
            positions: dirs.clone(),
            normals: dirs,
        };
        let (protocol, _) = Protocol::builtin();
        let e = view_exposure(&points, &protocol).unwrap();
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        // Each point faces about half of the 32 directions.
        assert!(
            (mean(&e.openness) - 0.5).abs() < 0.06,
            "{}",
            mean(&e.openness)
        );
        // Perspective views from 2.x radii see a little less than a hemisphere.
        let seen = mean(&e.seen_fraction);
        assert!(seen > 0.3 && seen < 0.5, "{seen}");
        assert!(e.seen_fraction.iter().all(|&s| s > 0.0));
    }

    #[test]
    fn a_point_inside_a_closed_shell_is_never_seen() {
        let mut dirs = fibonacci_directions(6000);
        dirs.push(DVec3::new(0.0, 0.0, 0.5));
        let mut normals = dirs.clone();
        *normals.last_mut().unwrap() = DVec3::Z;
        let points = SurfacePoints {
            positions: dirs,
            normals,
        };
        let (protocol, _) = Protocol::builtin();
        let e = view_exposure(&points, &protocol).unwrap();
        assert_eq!(e.seen_fraction[6000], 0.0);
        assert_eq!(e.openness[6000], 0.0);
    }
}
