//! Pictures of per-vertex maps: the mesh painted with a map under one of the protocol's hold
//! viewpoints.
use image::{Rgb, RgbImage};

use crate::mesh::{ColorRamp, ColorScale, Mesh};
use crate::protocol::Protocol;
use crate::stimulus::camera::CameraPlan;
use crate::stimulus::raster::Rasterizer;

/// Renders `mesh` painted with a map under the camera of hold `viewpoint` of `plan`, coloured
/// by [`ColorScale`] (1st to 99th percentile, blue to red), with a colour bar along the bottom.
pub fn render_map(
    mesh: &Mesh,
    plan: &CameraPlan,
    protocol: &Protocol,
    values: &[f64],
    viewpoint: usize,
) -> RgbImage {
    let colors = ColorScale::of(values).colors(values);
    let mut r = Rasterizer::new(mesh);
    r.set_vertex_colors(Some(colors));
    let t = &protocol.timing;
    let cam = plan.at(viewpoint as f64 * (t.hold_s + t.move_s) + 0.5 * t.hold_s);
    let rgb = r.render(&cam, &protocol.rendering);
    let mut img = RgbImage::from_raw(cam.width_px, cam.height_px, rgb).expect("render size");
    draw_color_bar(&mut img);
    img
}

/// The ramp from low (left) to high (right) in a strip along the bottom of `img`.
fn draw_color_bar(img: &mut RgbImage) {
    let (w, h) = img.dimensions();
    let bar_h = (h / 40).max(4);
    let margin = (w / 20).max(2);
    let (x0, x1) = (margin, w.saturating_sub(margin));
    let y0 = h.saturating_sub(2 * bar_h);
    for x in x0..x1 {
        let c = ColorRamp.rgb((x - x0) as f64 / (x1 - x0).max(1) as f64);
        for y in y0..(y0 + bar_h).min(h) {
            img.put_pixel(x, y, Rgb(c));
        }
    }
}
