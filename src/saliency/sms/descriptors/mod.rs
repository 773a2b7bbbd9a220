//! Shape descriptors of local surface regions.
pub mod gaussian_distance_field;
pub mod harmonic_shape_descriptor;
pub mod spherical_harmonics;

pub use gaussian_distance_field::{ExactField, GaussianField, GridField, GridParams};
pub use harmonic_shape_descriptor::{
    compute_descriptors, DescriptorNormalization, DescriptorParams, Descriptors, QuadratureRule,
    ShellWeight,
};
