//! The camera of a stimulus at any instant. The renderer and the projection stage both call
//! [`CameraPlan::at`], so a fixation is projected with exactly the camera that was on screen.
//!
//! Keyframes: one camera per viewpoint, looking at the mesh's bounding-sphere centre from
//! `distance`, screen-up along the mesh's up axis. Moves interpolate the camera's orientation
//! by quaternion slerp with the protocol's easing, so the camera orbits at constant distance
//! and never flips at a pole.
use glam::{DMat3, DMat4, DQuat, DVec3, DVec4};
use serde::Serialize;

use crate::mesh::Mesh;
use crate::protocol::{Protocol, ViewpointGenerator};

/// What is on screen at an instant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Phase {
    /// The camera holds on a viewpoint.
    Hold,
    /// The camera moves between two viewpoints.
    Move,
    /// After the end of the video.
    Ended,
}

impl Phase {
    /// `hold`, `move` or `ended`, as the timeline and projected.csv write it.
    pub fn name(self) -> &'static str {
        match self {
            Phase::Hold => "hold",
            Phase::Move => "move",
            Phase::Ended => "ended",
        }
    }
}

/// The camera at one instant of the video.
#[derive(Debug, Clone, Copy)]
pub struct CameraState {
    /// Stimulus time, s.
    pub time_s: f64,
    /// Holding or moving.
    pub phase: Phase,
    /// The viewpoint held, or the one the move starts from (0-based, tour order).
    pub viewpoint: usize,
    /// The viewpoint a move goes to (= `viewpoint` during a hold).
    pub next_viewpoint: usize,
    /// Eased progress of a move in [0, 1] (0 during a hold).
    pub progress: f64,
    /// The eye (camera centre), world coordinates.
    pub eye: DVec3,
    /// The camera's rotation, world from camera.
    pub orientation: DQuat,
    /// World → camera.
    pub view: DMat4,
    /// Camera → clip (OpenGL convention, right-handed, depth −1..1).
    pub projection: DMat4,
    /// The picture's width, px.
    pub width_px: u32,
    /// The picture's height, px.
    pub height_px: u32,
}

impl CameraState {
    /// World → clip.
    pub fn view_projection(&self) -> DMat4 {
        self.projection * self.view
    }

    /// Screen position of a world point: pixel x, y (origin top-left, pixel centres at
    /// i + 0.5) and normalized depth in [−1, 1]; None behind the camera.
    pub fn project(&self, p: DVec3) -> Option<(f64, f64, f64)> {
        let c = self.view_projection() * DVec4::new(p.x, p.y, p.z, 1.0);
        if c.w <= 0.0 {
            return None;
        }
        let ndc = c.truncate() / c.w;
        Some((
            (ndc.x + 1.0) * 0.5 * self.width_px as f64,
            (1.0 - ndc.y) * 0.5 * self.height_px as f64,
            ndc.z,
        ))
    }

    /// The world-space ray through a screen point (pixel coordinates as in [`Self::project`]):
    /// origin at the eye, unit direction.
    pub fn ray(&self, x_px: f64, y_px: f64) -> (DVec3, DVec3) {
        let ndc_x = 2.0 * x_px / self.width_px as f64 - 1.0;
        let ndc_y = 1.0 - 2.0 * y_px / self.height_px as f64;
        let inv = self.view_projection().inverse();
        let far = inv * DVec4::new(ndc_x, ndc_y, 1.0, 1.0);
        let far = far.truncate() / far.w;
        (self.eye, (far - self.eye).normalize())
    }
}

/// Everything needed to place the camera at any time for one mesh and protocol.
#[derive(Debug, Clone, Serialize)]
pub struct CameraPlan {
    /// The point the camera looks at: the centre of the mesh's bounding box.
    pub center: [f64; 3],
    /// The mesh's bounding-sphere radius around `center`.
    pub radius: f64,
    /// The eye's distance from `center`, set so the sphere fills the protocol's `fill`.
    pub distance: f64,
    /// Near clipping plane distance.
    pub near: f64,
    /// Far clipping plane distance.
    pub far: f64,
    /// Vertical field of view, degrees.
    pub fov_y_deg: f64,
    /// Viewpoint directions (centre → camera) in tour order.
    pub directions: Vec<[f64; 3]>,
    #[serde(skip)]
    keyframes: Vec<DQuat>,
    hold_s: f64,
    move_s: f64,
    #[serde(skip)]
    easing: crate::protocol::Easing,
    return_to_first: bool,
    duration_s: f64,
    width_px: u32,
    height_px: u32,
}

/// The 12 unit vertex directions of a regular icosahedron.
pub fn icosahedron_directions() -> Vec<DVec3> {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v = Vec::new();
    for &(a, b) in &[(1.0, t), (-1.0, t), (1.0, -t), (-1.0, -t)] {
        v.push(DVec3::new(0.0, a, b));
        v.push(DVec3::new(a, b, 0.0));
        v.push(DVec3::new(b, 0.0, a));
    }
    v.into_iter().map(|d| d.normalize()).collect()
}

/// Orders directions as a tour: start closest to `first`, then always the nearest unvisited.
fn tour(mut dirs: Vec<DVec3>, first: DVec3) -> Vec<DVec3> {
    let mut out = Vec::with_capacity(dirs.len());
    let mut current = first.normalize();
    while !dirs.is_empty() {
        let k = (0..dirs.len())
            .max_by(|&a, &b| {
                dirs[a]
                    .dot(current)
                    .total_cmp(&dirs[b].dot(current))
                    .then(b.cmp(&a))
            })
            .expect("non-empty");
        current = dirs.remove(k);
        out.push(current);
    }
    out
}

/// Camera orientation looking from direction `d` (centre → camera) with screen-up near `up`.
fn keyframe_orientation(d: DVec3, up: DVec3) -> DQuat {
    let z = d.normalize();
    let mut up = up.normalize();
    if z.dot(up).abs() > 0.999 {
        // Looking along the up axis: any perpendicular will do; take the most stable one.
        up = if z.x.abs() < 0.9 { DVec3::X } else { DVec3::Z };
    }
    let x = up.cross(z).normalize();
    let y = z.cross(x);
    DQuat::from_mat3(&DMat3::from_cols(x, y, z)).normalize()
}

/// OpenGL-style perspective projection.
fn perspective(fov_y: f64, aspect: f64, near: f64, far: f64) -> DMat4 {
    let f = 1.0 / (0.5 * fov_y).tan();
    DMat4::from_cols(
        DVec4::new(f / aspect, 0.0, 0.0, 0.0),
        DVec4::new(0.0, f, 0.0, 0.0),
        DVec4::new(0.0, 0.0, (far + near) / (near - far), -1.0),
        DVec4::new(0.0, 0.0, 2.0 * far * near / (near - far), 0.0),
    )
}

/// Why no camera plan frames an object.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CameraError {
    /// The mesh has no triangle to frame.
    #[error("the mesh has no triangle")]
    NoTriangle,
    /// Every point of the object is at its centre (or a coordinate is not a number).
    #[error("the mesh has no extent")]
    NoExtent,
    /// A point set to frame is empty.
    #[error("no points to view")]
    NoPoints,
}

impl CameraPlan {
    /// The plan of `mesh` under `protocol`; an error for a mesh without triangles.
    pub fn new(mesh: &Mesh, protocol: &Protocol) -> Result<CameraPlan, CameraError> {
        let (lo, hi) = mesh.referenced_bounds().ok_or(CameraError::NoTriangle)?;
        let center = (lo + hi) * 0.5;
        let radius = mesh
            .triangles
            .iter()
            .flatten()
            .map(|&i| (mesh.positions[i as usize] - center).length())
            .fold(0.0, f64::max);
        CameraPlan::around(center, radius, protocol)
    }

    /// The plan for any object whose bounding-box centre and farthest point from it are
    /// known (a point cloud, say), framed exactly as a mesh with those bounds would be.
    pub fn around(
        center: DVec3,
        radius: f64,
        protocol: &Protocol,
    ) -> Result<CameraPlan, CameraError> {
        if radius.is_nan() || radius <= 0.0 {
            return Err(CameraError::NoExtent);
        }
        let r = &protocol.rendering;
        let fov = r.field_of_view_deg.to_radians();
        // The sphere's silhouette (half-angle asin(R/d)) spans `fill` of the screen height.
        let half_angle = (r.fill * (0.5 * fov).tan()).atan();
        let distance = radius / half_angle.sin();
        let v = &protocol.viewpoints;
        let up = DVec3::from_array(v.up);
        let dirs: Vec<DVec3> = match v.generator {
            ViewpointGenerator::Icosahedron => icosahedron_directions(),
            ViewpointGenerator::List => v
                .directions
                .iter()
                .map(|d| DVec3::from_array(*d).normalize())
                .collect(),
            ViewpointGenerator::Turntable => {
                let up_n = up.normalize();
                let front = DVec3::from_array(v.first);
                let front =
                    (front - up_n * front.dot(up_n)).normalize_or(up_n.any_orthonormal_vector());
                let side = up_n.cross(front);
                let el = v.elevation_deg.to_radians();
                (0..v.count)
                    .map(|k| {
                        let az = 2.0 * std::f64::consts::PI * k as f64 / v.count as f64;
                        (front * az.cos() + side * az.sin()) * el.cos() + up_n * el.sin()
                    })
                    .collect()
            }
        };
        let dirs = if v.generator == ViewpointGenerator::Turntable {
            dirs // already in turning order
        } else {
            tour(dirs, DVec3::from_array(v.first))
        };
        let keyframes = dirs.iter().map(|&d| keyframe_orientation(d, up)).collect();
        Ok(CameraPlan {
            center: center.to_array(),
            radius,
            distance,
            near: (distance - 1.5 * radius).max(0.01 * distance),
            far: distance + 1.5 * radius,
            fov_y_deg: r.field_of_view_deg,
            directions: dirs.iter().map(|d| d.to_array()).collect(),
            keyframes,
            hold_s: protocol.timing.hold_s,
            move_s: protocol.timing.move_s,
            easing: protocol.timing.easing,
            return_to_first: protocol.timing.return_to_first,
            duration_s: protocol.duration_s(),
            width_px: protocol.display.width_px,
            height_px: protocol.display.height_px,
        })
    }

    /// The video's length, s.
    pub fn duration_s(&self) -> f64 {
        self.duration_s
    }

    /// How many hold viewpoints the tour has.
    pub fn viewpoints(&self) -> usize {
        self.keyframes.len()
    }

    /// Largest angular speed of a move in radians per second (eased), over all moves.
    pub fn peak_angular_speed(&self) -> f64 {
        if self.move_s <= 0.0 {
            return 0.0;
        }
        let n = self.keyframes.len();
        (0..n)
            .map(|i| self.keyframes[i].angle_between(self.keyframes[(i + 1) % n]))
            .fold(0.0, f64::max)
            * self.easing.peak_rate()
            / self.move_s
    }

    /// The camera at `t_s` seconds after stimulus onset.
    pub fn at(&self, t_s: f64) -> CameraState {
        let n = self.keyframes.len();
        let period = self.hold_s + self.move_s;
        let (phase, viewpoint, next, progress) = if t_s.is_nan() || t_s >= self.duration_s {
            (Phase::Ended, n - 1, n - 1, 0.0)
        } else {
            let t = t_s.max(0.0);
            let k = ((t / period).floor() as usize).min(n - 1);
            let local = t - k as f64 * period;
            if local < self.hold_s || (k + 1 == n && !self.return_to_first) {
                (Phase::Hold, k, k, 0.0)
            } else {
                let s = ((local - self.hold_s) / self.move_s).clamp(0.0, 1.0);
                (Phase::Move, k, (k + 1) % n, self.easing.apply(s))
            }
        };
        let orientation = if phase == Phase::Move {
            self.keyframes[viewpoint]
                .slerp(self.keyframes[next], progress)
                .normalize()
        } else {
            self.keyframes[viewpoint]
        };
        let center = DVec3::from_array(self.center);
        let eye = center + orientation * DVec3::Z * self.distance;
        let view = (DMat4::from_translation(eye) * DMat4::from_quat(orientation)).inverse();
        let aspect = self.width_px as f64 / self.height_px as f64;
        CameraState {
            time_s: t_s,
            phase,
            viewpoint,
            next_viewpoint: next,
            progress,
            eye,
            orientation,
            view,
            projection: perspective(self.fov_y_deg.to_radians(), aspect, self.near, self.far),
            width_px: self.width_px,
            height_px: self.height_px,
        }
    }
}
