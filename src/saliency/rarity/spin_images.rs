//! Spin images (Johnson & Hebert 1999), SRI's vertex descriptor: around a vertex p with normal
//! n, each surface point x within the support radius R lands at α = distance from the normal
//! line, β = signed height along n (both / R), and its area is spread bilinearly over an
//! `alpha_bins` × `beta_bins` grid on [0, 1] × [−1, 1]. The image is divided by the area
//! inside the support so it does not depend on the tessellation's density.
use glam::DVec3;
use rayon::prelude::*;

use super::working_copy::WorkingCopy;

pub fn spin_image(
    centre: DVec3,
    normal: DVec3,
    radius: f64,
    alpha_bins: usize,
    beta_bins: usize,
    points: impl Iterator<Item = (DVec3, f64)>,
) -> Vec<f64> {
    let mut image = vec![0.0; alpha_bins * beta_bins];
    let mut total = 0.0;
    for (x, a) in points {
        let d = (x - centre) / radius;
        let beta = d.dot(normal);
        let alpha = (d.length_squared() - beta * beta).max(0.0).sqrt();
        if alpha > 1.0 || beta.abs() > 1.0 {
            continue;
        }
        total += a;
        // Bin centres at (i + 0.5) / bins; outside the outer centres the weight clamps.
        let fa = (alpha * alpha_bins as f64 - 0.5).clamp(0.0, (alpha_bins - 1) as f64);
        let fb = ((beta + 1.0) * 0.5 * beta_bins as f64 - 0.5).clamp(0.0, (beta_bins - 1) as f64);
        let (ia, ib) = (fa.floor() as usize, fb.floor() as usize);
        let (wa, wb) = (fa - ia as f64, fb - ib as f64);
        let ia1 = (ia + 1).min(alpha_bins - 1);
        let ib1 = (ib + 1).min(beta_bins - 1);
        image[ia * beta_bins + ib] += a * (1.0 - wa) * (1.0 - wb);
        image[ia1 * beta_bins + ib] += a * wa * (1.0 - wb);
        image[ia * beta_bins + ib1] += a * (1.0 - wa) * wb;
        image[ia1 * beta_bins + ib1] += a * wa * wb;
    }
    if total > 0.0 {
        for v in &mut image {
            *v /= total;
        }
    }
    image
}

/// The spin image of every working vertex at support radius `radius`.
pub fn spin_images(
    work: &WorkingCopy,
    radius: f64,
    alpha_bins: usize,
    beta_bins: usize,
) -> Vec<Vec<f64>> {
    (0..work.len())
        .into_par_iter()
        .map(|v| {
            let c = work.mesh.positions[v];
            let near = work.within(c, radius);
            spin_image(
                c,
                work.normals[v],
                radius,
                alpha_bins,
                beta_bins,
                near.iter()
                    .map(|&u| (work.mesh.positions[u], work.areas[u])),
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flat_disc_fills_only_the_middle_height_row_and_sums_to_one() {
        let mut pts = Vec::new();
        for i in -20..=20 {
            for j in -20..=20 {
                pts.push((DVec3::new(i as f64 / 20.0, j as f64 / 20.0, 0.0), 1.0));
            }
        }
        let img = spin_image(DVec3::ZERO, DVec3::Z, 1.0, 4, 8, pts.into_iter());
        let sum: f64 = img.iter().sum();
        assert!((sum - 1.0).abs() < 1e-12);
        for a in 0..4 {
            for b in 0..8 {
                let v = img[a * 8 + b];
                if b != 3 && b != 4 {
                    assert_eq!(v, 0.0, "α bin {a}, β bin {b}");
                }
            }
        }
        // Farther rings hold more area: the outer α bins weigh more.
        assert!(img[3 * 8 + 3] > img[3]);
    }
}
