//! Feature points from saliency (paper §5.5, Fig. 9) and their evaluation against human
//! marks (Dutagaci et al. 2012), on geodesic distances.
pub mod evaluation_files;
pub mod feature_points;
pub(crate) mod geodesic;
pub(crate) mod interest_point_benchmark;
pub mod marks;

pub use feature_points::{feature_points, local_maxima, FeaturePoint};
pub use geodesic::GeodesicGraph;
pub use interest_point_benchmark::{evaluate, voted_ground_truth, Evaluation, TruthPoint};
