//! What GR and MR both start from: the simplified working copy, every working vertex's
//! Zernike height-map descriptor and the geodesic patches. With the defaults both ask for the
//! same ones (10,000 vertices, radii 0.05 / 0.1 / 0.2, order 8, 500 patches, seed 1), so a
//! caller computing both maps of a mesh builds them once.
use super::working_copy::WorkingCopy;
use super::zernike_height_map::zernike_descriptors;
use crate::mesh::over_segmentation::{over_segment, Patches};
use crate::mesh::Mesh;
use crate::saliency::SaliencyError;

/// The parameters the shared inputs depend on.
#[derive(Debug, Clone, PartialEq)]
pub struct ZernikePatchesParams {
    /// Vertices of the simplified working copy.
    pub vertices: usize,
    /// Height-map radii (normalized units).
    pub radii: Vec<f64>,
    /// Highest Zernike order.
    pub order: usize,
    /// Patches of the over-segmentation.
    pub patches: usize,
    /// Seed of the over-segmentation's first patch centre.
    pub seed: u64,
}

/// The working copy, its descriptors (one row per working vertex, radii concatenated) and
/// its patches, with the parameters they were built with.
pub struct ZernikePatches {
    work: WorkingCopy,
    descriptors: Vec<Vec<f64>>,
    patches: Patches,
    params: ZernikePatchesParams,
}

impl ZernikePatches {
    /// Simplifies `mesh`, describes every working vertex and over-segments the copy.
    pub fn new(mesh: &Mesh, params: &ZernikePatchesParams) -> Result<Self, SaliencyError> {
        let work = WorkingCopy::new(mesh, params.vertices).map_err(SaliencyError::Compute)?;
        let descriptors = zernike_descriptors(&work, &params.radii, params.order);
        let patches = over_segment(&work.mesh, &work.graph, params.patches, params.seed);
        Ok(ZernikePatches {
            work,
            descriptors,
            patches,
            params: params.clone(),
        })
    }

    /// The parameters these were built with.
    pub fn params(&self) -> &ZernikePatchesParams {
        &self.params
    }

    /// The working copy, descriptors and patches, or an error unless they were built with
    /// `wanted` (a method given another's inputs).
    pub(crate) fn built_with(
        &self,
        wanted: &ZernikePatchesParams,
        method: &str,
    ) -> Result<(&WorkingCopy, &[Vec<f64>], &Patches), SaliencyError> {
        if &self.params == wanted {
            Ok((&self.work, &self.descriptors, &self.patches))
        } else {
            Err(SaliencyError::Invalid(format!(
                "{method}: the shared working copy, descriptors and patches were built with {:?}, \
                 not with this method's {:?}",
                self.params, wanted
            )))
        }
    }
}
