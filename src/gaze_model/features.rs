//! The gaze model's per-point features. None needs human input or connectivity: they come
//! from positions, normals and the protocol (its up axis, its first view as "front", its
//! hold views), so point-only objects can be training data and any mesh can be predicted.
use crate::gaze_model::FeatureError;
use glam::DVec3;

use super::local_shape::local_shape;
use super::shape_contrast::{centre_surround, curvature_ranks, descriptor_rarity};
use super::surface_points::SurfacePoints;
use super::view_visibility::{bounds, view_exposure};
use crate::protocol::Protocol;

/// Ball radii of the local-shape features, as fractions of the object's radius.
pub const SHAPE_RADII: [f64; 4] = [0.04, 0.08, 0.16, 0.32];

/// Feature names in column order; a model stores them and refuses a different list.
pub fn feature_names() -> Vec<String> {
    let mut names: Vec<String> = [
        "height",
        "height_rank",
        "front",
        "side_distance",
        "axis_distance",
        "centre_distance",
        "normal_up",
        "normal_front",
        "normal_outward",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    for r in SHAPE_RADII {
        for what in ["variation", "convexity", "normal_agreement"] {
            names.push(format!("{what}_r{r}"));
        }
    }
    for name in ["seen_fraction", "centre_closeness", "facing", "openness"] {
        names.push(name.to_string());
    }
    for r in SHAPE_RADII {
        names.push(format!("curvature_rank_r{r}"));
    }
    names.push("centre_surround".to_string());
    names.push("shape_rarity".to_string());
    names
}

/// The feature groups, for ablations and for saying what each costs: where a point sits
/// (along up, front, side), which way its normal points, its local shape at four scales,
/// what the hold views show of it, and the classical methods' ingredients as per-object
/// ranks.
pub const FEATURE_GROUPS: [&str; 5] = ["placement", "orientation", "shape", "views", "classical"];

/// The group of a feature name of `feature_names()`.
pub fn feature_group(name: &str) -> &'static str {
    let shape = ["variation_r", "convexity_r", "normal_agreement_r"];
    if shape.iter().any(|p| name.starts_with(p)) {
        "shape"
    } else if ["seen_fraction", "centre_closeness", "facing", "openness"].contains(&name) {
        "views"
    } else if name.starts_with("curvature_rank_r")
        || name == "centre_surround"
        || name == "shape_rarity"
    {
        "classical"
    } else if name.starts_with("normal_") {
        "orientation"
    } else {
        "placement"
    }
}

/// Column-major feature matrix: `columns[f][i]` is feature f of point i.
#[derive(Debug, Clone, PartialEq)]
pub struct FeatureMatrix {
    /// Feature names, one per column.
    pub names: Vec<String>,
    /// The columns.
    pub columns: Vec<Vec<f64>>,
}

impl FeatureMatrix {
    /// Points (rows).
    pub fn rows(&self) -> usize {
        self.columns.first().map_or(0, Vec::len)
    }

    /// The column called `name`.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        let i = self.names.iter().position(|n| n == name)?;
        Some(&self.columns[i])
    }
}

/// The protocol's up axis and its "front" (the first view's direction made perpendicular to
/// up), both unit.
pub fn up_and_front(protocol: &Protocol) -> (DVec3, DVec3) {
    let up = DVec3::from_array(protocol.viewpoints.up).normalize_or(DVec3::Y);
    let first = DVec3::from_array(protocol.viewpoints.first);
    let front = (first - up * first.dot(up)).normalize_or(up.any_orthonormal_vector());
    (up, front)
}

/// Every feature of every point.
pub fn point_features(
    points: &SurfacePoints,
    protocol: &Protocol,
) -> Result<FeatureMatrix, FeatureError> {
    point_features_timed(points, protocol, &mut |_, _| {})
}

/// `point_features`, telling `spent(group, seconds)` what each feature group cost (placement
/// and orientation are timed together: they share one pass).
pub fn point_features_timed(
    points: &SurfacePoints,
    protocol: &Protocol,
    spent: &mut dyn FnMut(&'static str, f64),
) -> Result<FeatureMatrix, FeatureError> {
    let (center, radius) = bounds(points).ok_or(FeatureError::NoPoints)?;
    if radius <= 0.0 || !radius.is_finite() {
        return Err(FeatureError::NoExtent);
    }
    let n = points.len();
    let clock = std::time::Instant::now();
    let mut columns = placement_and_orientation(points, protocol, center, radius);
    spent("placement+orientation", clock.elapsed().as_secs_f64());
    let clock = std::time::Instant::now();
    let radii: Vec<f64> = SHAPE_RADII.iter().map(|f| f * radius).collect();
    let mut shape: Vec<Vec<f64>> = Vec::new();
    for scale in local_shape(points, &radii) {
        shape.push(scale.iter().map(|s| s.variation).collect());
        shape.push(scale.iter().map(|s| s.convexity).collect());
        shape.push(scale.iter().map(|s| s.normal_agreement).collect());
    }
    spent("shape", clock.elapsed().as_secs_f64());
    let clock = std::time::Instant::now();
    let views = view_exposure(points, protocol)?;
    spent("views", clock.elapsed().as_secs_f64());
    let clock = std::time::Instant::now();
    let classical = classical_stand_ins(&shape);
    spent("classical", clock.elapsed().as_secs_f64());
    columns.extend(shape);
    columns.push(views.seen_fraction);
    columns.push(views.centre_closeness);
    columns.push(views.facing);
    columns.push(views.openness);
    columns.extend(classical);
    debug_assert!(columns.iter().all(|c| c.len() == n));
    Ok(FeatureMatrix {
        names: feature_names(),
        columns,
    })
}

/// The placement columns (height, its rank, front, side and axis distance, centre distance)
/// then the orientation columns (normal along up, front, outward), the object centred on
/// `center` and scaled by `radius`.
fn placement_and_orientation(
    points: &SurfacePoints,
    protocol: &Protocol,
    center: DVec3,
    radius: f64,
) -> Vec<Vec<f64>> {
    let (up, front) = up_and_front(protocol);
    let side = up.cross(front);
    let rel: Vec<DVec3> = points
        .positions
        .iter()
        .map(|&p| (p - center) / radius)
        .collect();
    let height: Vec<f64> = rel.iter().map(|q| q.dot(up)).collect();
    vec![
        height.clone(),
        ranks(&height),
        rel.iter().map(|q| q.dot(front)).collect(),
        rel.iter().map(|q| q.dot(side).abs()).collect(),
        rel.iter().map(|q| (*q - up * q.dot(up)).length()).collect(),
        rel.iter().map(|q| q.length()).collect(),
        points.normals.iter().map(|m| m.dot(up)).collect(),
        points.normals.iter().map(|m| m.dot(front)).collect(),
        rel.iter()
            .zip(&points.normals)
            .map(|(q, m)| m.dot(q.normalize_or_zero()))
            .collect(),
    ]
}

/// The classical group from the shape columns (variation, convexity, normal agreement per
/// scale, in that order): curvature ranks per scale, centre-surround, shape rarity.
fn classical_stand_ins(shape: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let convexity: Vec<&[f64]> = shape.iter().skip(1).step_by(3).map(Vec::as_slice).collect();
    let mut out = curvature_ranks(&convexity);
    out.push(centre_surround(&convexity));
    let all: Vec<&[f64]> = shape.iter().map(Vec::as_slice).collect();
    out.push(descriptor_rarity(&all));
    out
}

/// Fractional ranks in [0, 1] (ties share their mean rank): a per-object, scale-free version
/// of a value.
pub fn ranks(values: &[f64]) -> Vec<f64> {
    let n = values.len();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
    let mut out = vec![0.0; n];
    let mut i = 0;
    while i < n {
        let mut j = i;
        while j + 1 < n && values[order[j + 1]] == values[order[i]] {
            j += 1;
        }
        let rank = if n > 1 {
            0.5 * (i + j) as f64 / (n - 1) as f64
        } else {
            0.5
        };
        for &k in &order[i..=j] {
            out[k] = rank;
        }
        i = j + 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_feature_is_in_one_named_group() {
        let names = feature_names();
        let count = |g: &str| names.iter().filter(|n| feature_group(n) == g).count();
        assert_eq!(
            FEATURE_GROUPS.map(count),
            [6, 3, 12, 4, 6],
            "placement, orientation, shape, views, classical"
        );
        assert_eq!(FEATURE_GROUPS.map(count).iter().sum::<usize>(), names.len());
    }
}
