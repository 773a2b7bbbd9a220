//! Where a tracker's screen point falls in the video's pixels (letterbox-aware).
use serde::Serialize;

/// How gaze coordinates (the tracker's screen) relate to the video's pixels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ScreenMapping {
    /// The tracker's screen width, px.
    pub screen_width_px: f64,
    /// The tracker's screen height, px.
    pub screen_height_px: f64,
    /// The video's width, px (shown letterboxed on that screen).
    pub video_width_px: u32,
    /// The video's height, px.
    pub video_height_px: u32,
}

impl ScreenMapping {
    /// The video scaled to fit the screen with its aspect ratio kept and centred, as players
    /// show it full screen: (scale, left, top) of the picture in screen pixels.
    pub fn picture(&self) -> (f64, f64, f64) {
        let s = (self.screen_width_px / self.video_width_px as f64)
            .min(self.screen_height_px / self.video_height_px as f64);
        let left = 0.5 * (self.screen_width_px - s * self.video_width_px as f64);
        let top = 0.5 * (self.screen_height_px - s * self.video_height_px as f64);
        (s, left, top)
    }

    /// Video pixel coordinates of a gaze point, None when it is not on the picture.
    pub fn to_video(&self, x: f64, y: f64) -> Option<(f64, f64)> {
        if !(x >= 0.0 && y >= 0.0 && x < self.screen_width_px && y < self.screen_height_px) {
            return None;
        }
        let (s, left, top) = self.picture();
        let (vx, vy) = ((x - left) / s, (y - top) / s);
        (vx >= 0.0
            && vy >= 0.0
            && vx < self.video_width_px as f64
            && vy < self.video_height_px as f64)
            .then_some((vx, vy))
    }

    /// Screen coordinates of a video pixel position.
    pub fn to_screen(&self, vx: f64, vy: f64) -> (f64, f64) {
        let (s, left, top) = self.picture();
        (left + s * vx, top + s * vy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn letterbox_maps_the_picture_centre_to_the_video_centre() {
        let m = ScreenMapping {
            screen_width_px: 1920.0,
            screen_height_px: 1080.0,
            video_width_px: 1680,
            video_height_px: 1050,
        };
        let (s, left, top) = m.picture();
        assert!((s - 1080.0 / 1050.0).abs() < 1e-12 && top == 0.0 && left > 0.0);
        let (vx, vy) = m.to_video(960.0, 540.0).unwrap();
        assert!((vx - 840.0).abs() < 1e-9 && (vy - 525.0).abs() < 1e-9);
        assert!(m.to_video(left - 1.0, 500.0).is_none(), "on the bar");
        assert!(m.to_video(-1.0, 500.0).is_none());
        let (sx, sy) = m.to_screen(vx, vy);
        assert!((sx - 960.0).abs() < 1e-9 && (sy - 540.0).abs() < 1e-9);
    }
}
