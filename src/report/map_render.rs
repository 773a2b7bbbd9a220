//! Pictures of per-vertex maps: the mesh painted with a map under one of the protocol's hold
//! viewpoints.
use image::RgbImage;

use crate::mesh::{ColorRamp, Mesh};
use crate::stimulus::camera::CameraPlan;
use crate::stimulus::raster::Rasterizer;
use crate::stimulus::Protocol;

/// Renders `mesh` painted with a map (min–max normalized, blue to red) under the camera of
/// hold `viewpoint` of `plan`.
pub fn render_map(
    mesh: &Mesh,
    plan: &CameraPlan,
    protocol: &Protocol,
    values: &[f64],
    viewpoint: usize,
) -> RgbImage {
    let (lo, hi) = values
        .iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let ramp = ColorRamp;
    let colors: Vec<[u8; 3]> = values
        .iter()
        .map(|&v| ramp.rgb(if hi > lo { (v - lo) / (hi - lo) } else { 0.0 }))
        .collect();
    let mut r = Rasterizer::new(mesh);
    r.set_vertex_colors(Some(colors));
    let t = &protocol.timing;
    let cam = plan.at(viewpoint as f64 * (t.hold_s + t.move_s) + 0.5 * t.hold_s);
    let rgb = r.render(&cam, &protocol.rendering);
    RgbImage::from_raw(cam.width_px, cam.height_px, rgb).expect("render size")
}
