//! First-hit ray casting against a mesh: an obvhs BVH for traversal, and a watertight
//! ray–triangle test (Woop, Benthin, Wald 2013) in double precision for the hits.
//!
//! The Möller–Trumbore test that obvhs ships lets about 5 rays per million slip through the
//! edge shared by two triangles and hit the far side of a closed mesh; for fixation
//! projection that would send a fixation to the back of the object. Woop's test computes each
//! edge function from the edge's two vertices only, in a ray-aligned shear frame, so two
//! triangles sharing an edge evaluate it identically and every ray hits one of them.
use glam::{DVec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::builder::build_bvh2;
use obvhs::bvh2::Bvh2;
use obvhs::ray::{Ray, RayHit};
use obvhs::BvhBuildParams;

use crate::mesh::Mesh;

/// The first surface point along a ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// The triangle hit.
    pub triangle: usize,
    /// Distance along the (unit) ray direction.
    pub t: f64,
    /// The point hit.
    pub point: DVec3,
    /// Barycentric weights of the triangle's three corners.
    pub barycentric: [f64; 3],
}

/// First hits of rays on a mesh, through a BVH with a watertight triangle test.
pub struct RayCaster<'a> {
    mesh: &'a Mesh,
    bvh: Bvh2,
}

impl<'a> RayCaster<'a> {
    /// Builds the BVH (single-threaded, so the tree and every hit are deterministic).
    pub fn new(mesh: &'a Mesh) -> RayCaster<'a> {
        // Boxes are single precision; pad them so a ray the exact test hits exactly on a
        // corner or edge is never culled by a box it grazes in f32.
        let extent = mesh
            .positions
            .iter()
            .fold(0.0f64, |m, p| m.max(p.abs().max_element()));
        let pad = (extent * 1e-5).max(f64::MIN_POSITIVE) as f32;
        let boxes: Vec<Aabb> = mesh
            .triangles
            .iter()
            .map(|t| {
                let p = t.map(|i| {
                    let v = mesh.positions[i as usize];
                    Vec3A::new(v.x as f32, v.y as f32, v.z as f32)
                });
                let b = Aabb::from_points(&p);
                Aabb::new(b.min - Vec3A::splat(pad), b.max + Vec3A::splat(pad))
            })
            .collect();
        let mut build_time = std::time::Duration::default();
        let bvh = build_bvh2(&boxes, BvhBuildParams::fast_build(), &mut build_time);
        RayCaster { mesh, bvh }
    }

    /// The mesh it casts on.
    pub fn mesh(&self) -> &Mesh {
        self.mesh
    }

    /// The nearest hit along `origin + t·direction`, t > 0 (both faces count).
    pub fn first_hit(&self, origin: DVec3, direction: DVec3) -> Option<Hit> {
        let dir = direction.normalize();
        let prepared = WatertightRay::new(origin, dir);
        let ray = Ray::new(
            Vec3A::new(origin.x as f32, origin.y as f32, origin.z as f32),
            Vec3A::new(dir.x as f32, dir.y as f32, dir.z as f32),
            0.0,
            f32::INFINITY,
        );
        let mut hit = RayHit::none();
        let mut best: Option<Hit> = None;
        let found = self.bvh.ray_traverse(ray, &mut hit, |_ray, prim| {
            let tri = self.bvh.primitive_indices[prim] as usize;
            let corners = self.mesh.triangle(tri);
            match prepared.intersect(corners, best.map_or(f64::INFINITY, |b| b.t)) {
                Some((t, bary)) => {
                    best = Some(Hit {
                        triangle: tri,
                        t,
                        point: origin + dir * t,
                        barycentric: bary,
                    });
                    // obvhs shrinks its f32 tmax to this; round up so a slightly farther
                    // candidate in double precision is still visited and compared exactly.
                    next_up(t as f32)
                }
                None => f32::INFINITY,
            }
        });
        if found {
            best
        } else {
            None
        }
    }

    /// Whether the point `p` (on the surface) is the first thing seen from `eye`.
    pub fn visible_from(&self, eye: DVec3, p: DVec3, tolerance: f64) -> bool {
        let d = p - eye;
        let dist = d.length();
        match self.first_hit(eye, d / dist) {
            Some(h) => h.t >= dist - tolerance,
            None => false,
        }
    }
}

fn next_up(x: f32) -> f32 {
    if x.is_finite() {
        f32::from_bits(x.to_bits() + 1)
    } else {
        x
    }
}

/// A ray prepared for Woop et al.'s watertight test.
struct WatertightRay {
    origin: DVec3,
    kx: usize,
    ky: usize,
    kz: usize,
    shear: [f64; 3],
}

impl WatertightRay {
    fn new(origin: DVec3, dir: DVec3) -> WatertightRay {
        let a = dir.abs().to_array();
        let kz = if a[0] >= a[1] && a[0] >= a[2] {
            0
        } else if a[1] >= a[2] {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        let d = dir.to_array();
        // Keep the winding: swap when the dominant axis points backwards.
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        WatertightRay {
            origin,
            kx,
            ky,
            kz,
            shear: [d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]],
        }
    }

    /// Distance and barycentrics of a hit closer than `t_max`, either face.
    fn intersect(&self, corners: [DVec3; 3], t_max: f64) -> Option<(f64, [f64; 3])> {
        let [sx, sy, sz] = self.shear;
        let rel = corners.map(|c| (c - self.origin).to_array());
        let (a, b, c) = (rel[0], rel[1], rel[2]);
        let ax = a[self.kx] - sx * a[self.kz];
        let ay = a[self.ky] - sy * a[self.kz];
        let bx = b[self.kx] - sx * b[self.kz];
        let by = b[self.ky] - sy * b[self.kz];
        let cx = c[self.kx] - sx * c[self.kz];
        let cy = c[self.ky] - sy * c[self.kz];
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 {
            return None;
        }
        let az = sz * a[self.kz];
        let bz = sz * b[self.kz];
        let cz = sz * c[self.kz];
        let t_scaled = u * az + v * bz + w * cz;
        let t = t_scaled / det;
        if !(t > 0.0 && t < t_max) {
            return None;
        }
        Some((t, [u / det, v / det, w / det]))
    }
}

/// The corner of `triangle` nearest to `point` (the paper's fixation-to-vertex rule).
pub fn nearest_corner(mesh: &Mesh, triangle: usize, point: DVec3) -> usize {
    let idx = mesh.triangles[triangle];
    let mut best = idx[0] as usize;
    let mut best_d = f64::INFINITY;
    for &i in &idx {
        let d = mesh.positions[i as usize].distance_squared(point);
        if d < best_d {
            best_d = d;
            best = i as usize;
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::test_meshes::icosphere;

    #[test]
    fn hits_the_near_side_of_a_sphere() {
        let mesh = icosphere(1.0, 3);
        let caster = RayCaster::new(&mesh);
        let h = caster
            .first_hit(DVec3::new(0.1, 0.2, 5.0), DVec3::new(0.0, 0.0, -1.0))
            .expect("hit");
        assert!(h.point.z > 0.9, "{:?}", h.point);
        assert!((h.barycentric.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        assert!(caster
            .first_hit(DVec3::new(3.0, 0.0, 5.0), DVec3::new(0.0, 0.0, -1.0))
            .is_none());
    }

    /// Rays aimed exactly at shared edges and vertices of a closed mesh never pass through.
    #[test]
    fn no_ray_slips_through_shared_edges() {
        let mesh = icosphere(1.0, 3);
        let caster = RayCaster::new(&mesh);
        let eye = DVec3::new(0.3, -0.2, 4.0);
        let mut aimed = 0;
        for t in &mesh.triangles {
            let p = t.map(|i| mesh.positions[i as usize]);
            for (a, b) in [(p[0], p[1]), (p[1], p[2]), (p[2], p[0])] {
                for target in [a, 0.5 * (a + b), 0.25 * a + 0.75 * b] {
                    // Front-facing points only: at a silhouette, a ray through a vertex may
                    // rightly graze past the surface.
                    if (target - eye).normalize().dot(target.normalize()) >= -0.3 {
                        continue;
                    }
                    aimed += 1;
                    let d = (target - eye).normalize();
                    let h = caster.first_hit(eye, d).expect("an edge ray must hit");
                    let expected = (target - eye).length();
                    assert!(
                        (h.t - expected).abs() < 1e-9,
                        "slipped: {} vs {}",
                        h.t,
                        expected
                    );
                }
            }
        }
        assert!(aimed > 1000);
    }
}
