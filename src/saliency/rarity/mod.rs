//! The global-rarity competitors of the SMS paper: SRI (Leifman et al. 2012), GR (Wu et al.
//! 2013) and MR (Tao et al. 2015). They share a simplified, normalized working copy of the
//! mesh, geodesic patches and local shape descriptors; docs/baselines.md says where each
//! follows its paper and where it had to choose.
pub(crate) mod global_rarity;
pub(crate) mod manifold_ranking;
pub(crate) mod pca;
pub(crate) mod spin_images;
pub(crate) mod surface_regions_of_interest;
pub(crate) mod working_copy;
pub(crate) mod zernike_height_map;
pub(crate) mod zernike_patches;

pub use global_rarity::{global_rarity_saliency, global_rarity_saliency_from, GrParams};
pub use manifold_ranking::{manifold_ranking_saliency, manifold_ranking_saliency_from, MrParams};
pub use surface_regions_of_interest::{surface_regions_of_interest, SriParams};
pub use zernike_patches::{ZernikePatches, ZernikePatchesParams};
