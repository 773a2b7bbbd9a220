//! Sync aids drawn on frames: a photodiode patch (white during holds, black during moves)
//! and a burned-in frame counter (seven-segment digits, no font needed).
use super::camera::Phase;
use crate::protocol::{Corner, Sync};

/// Fills the rectangle [x0, x1) × [y0, y1) with grey level `c`.
fn fill(rgb: &mut [u8], w: usize, h: usize, (x0, y0, x1, y1): (usize, usize, usize, usize), c: u8) {
    for y in y0.min(h)..y1.min(h) {
        for x in x0.min(w)..x1.min(w) {
            rgb[(y * w + x) * 3..(y * w + x) * 3 + 3].fill(c);
        }
    }
}

/// Segments a..g of the digits 0-9 (bit 0 = a, top; clockwise; g = middle).
const SEGMENTS: [u8; 10] = [0x3f, 0x06, 0x5b, 0x4f, 0x66, 0x6d, 0x7d, 0x07, 0x7f, 0x6f];

fn draw_number(rgb: &mut [u8], w: usize, h: usize, x0: usize, y0: usize, n: usize) {
    let (dw, dh, t) = (12usize, 22usize, 3usize); // digit width, height, stroke
    let text = format!("{n:05}");
    let box_ = (x0, y0, x0 + text.len() * (dw + 6) + 6, y0 + dh + 12);
    fill(rgb, w, h, box_, 0);
    for (k, ch) in text.bytes().enumerate() {
        let s = SEGMENTS[(ch - b'0') as usize];
        let (x, y) = (x0 + 6 + k * (dw + 6), y0 + 6);
        let half = dh / 2;
        let seg = [
            (x, y, x + dw, y + t),                               // a
            (x + dw - t, y, x + dw, y + half),                   // b
            (x + dw - t, y + half, x + dw, y + dh),              // c
            (x, y + dh - t, x + dw, y + dh),                     // d
            (x, y + half, x + t, y + dh),                        // e
            (x, y, x + t, y + half),                             // f
            (x, y + half - t / 2, x + dw, y + half + t - t / 2), // g
        ];
        for (i, r) in seg.iter().enumerate() {
            if s & (1 << i) != 0 {
                fill(rgb, w, h, *r, 255);
            }
        }
    }
}

pub fn apply(rgb: &mut [u8], w: usize, h: usize, frame: usize, phase: Phase, sync: &Sync) {
    if sync.photodiode {
        let s = sync.photodiode_size_px as usize;
        let (x0, y0) = match sync.photodiode_corner {
            Corner::TopLeft => (0, 0),
            Corner::TopRight => (w.saturating_sub(s), 0),
            Corner::BottomLeft => (0, h.saturating_sub(s)),
            Corner::BottomRight => (w.saturating_sub(s), h.saturating_sub(s)),
        };
        let c = if phase == Phase::Hold { 255 } else { 0 };
        fill(rgb, w, h, (x0, y0, x0 + s, y0 + s), c);
    }
    if sync.frame_counter {
        draw_number(rgb, w, h, 0, 0, frame);
    }
}
