//! Shape descriptors of local surface regions.
pub(crate) mod gaussian_distance_field;
pub(crate) mod harmonic_shape_descriptor;
pub(crate) mod spherical_harmonics;

pub use gaussian_distance_field::{ExactField, GaussianField, GridField, GridParams};
pub use harmonic_shape_descriptor::{
    compute_descriptors, DescriptorNormalization, DescriptorParams, Descriptors, QuadratureRule,
    ShellWeight,
};
