//! Stimulus rendering: protocol files, the camera timeline, the rasterizer's id buffer against
//! the timeline's matrices, and the video decoded back.
mod common;

use meshgaze::progress::Silent;
use meshgaze::protocol::{Protocol, ProtocolError};
use meshgaze::stimulus::raster::{Rasterizer, BACKGROUND_ID};
use meshgaze::stimulus::{render_stimulus, CameraPlan, FrameImages, Phase, StimulusOptions};

fn hu2020() -> (Protocol, String) {
    Protocol::load(&common::repo_root().join("protocols/hu2020.toml")).expect("hu2020 protocol")
}

#[test]
fn the_paper_protocol_is_48_seconds_of_12_viewpoints() {
    let (p, _) = hu2020();
    assert_eq!(p.viewpoints.count, 12);
    assert_eq!(p.duration_s(), 48.0);
    assert_eq!(p.frame_count(), 1440);
    assert_eq!((p.display.width_px, p.display.height_px), (1680, 1050));
    assert_eq!(
        (
            p.fixations.drop_first,
            p.fixations.drop_last,
            p.fixations.keep_longest
        ),
        (2, 2, 15)
    );
}

#[test]
fn protocol_errors_say_where_and_what() {
    let (_, text) = hu2020();
    let typo = text.replace("hold_s = 3.0", "hold_seconds = 3.0");
    let err = Protocol::from_toml(&typo, "typo.toml").unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, ProtocolError::Parse { .. }));
    assert!(
        msg.contains("typo.toml") && msg.contains("line") && msg.contains("hold_seconds"),
        "{msg}"
    );
    let bad = text.replace("fps = 30", "fps = 0");
    let msg = Protocol::from_toml(&bad, "bad.toml")
        .unwrap_err()
        .to_string();
    assert!(msg.contains("video.fps"), "{msg}");
    let odd = text.replace("width_px = 1680", "width_px = 1681");
    assert!(Protocol::from_toml(&odd, "odd.toml")
        .unwrap_err()
        .to_string()
        .contains("even"));
}

#[test]
fn timeline_holds_each_view_for_exactly_three_seconds_and_moves_continuously() {
    let (p, _) = hu2020();
    let mesh = common::bunny();
    let plan = CameraPlan::new(&mesh, &p).unwrap();
    let fps = p.video.fps as f64;
    let cams: Vec<_> = (0..p.frame_count())
        .map(|i| plan.at(i as f64 / fps))
        .collect();
    assert_eq!(cams.len(), 1440);
    for v in 0..12 {
        let hold: Vec<_> = cams
            .iter()
            .filter(|c| c.phase == Phase::Hold && c.viewpoint == v)
            .collect();
        assert_eq!(
            hold.len(),
            90,
            "viewpoint {v} is held for {} frames",
            hold.len()
        );
        assert!(hold
            .iter()
            .all(|c| c.eye == hold[0].eye && c.view == hold[0].view));
        // The hold is one contiguous run starting at 4 s × v.
        assert!((hold[0].time_s - 4.0 * v as f64).abs() < 1e-9);
    }
    assert_eq!(cams.iter().filter(|c| c.phase == Phase::Move).count(), 360);
    // No jump larger than the peak angular speed allows (arc length ≥ chord).
    let max_step = plan.peak_angular_speed() * plan.distance / fps;
    let mut largest: f64 = 0.0;
    for w in cams.windows(2) {
        let step = (w[1].eye - w[0].eye).length();
        largest = largest.max(step);
        assert!(
            step <= max_step * (1.0 + 1e-9),
            "camera jumped {step} > {max_step} at t = {}",
            w[1].time_s
        );
    }
    assert!(
        largest > 0.5 * max_step,
        "moves should approach the peak speed"
    );
    // The last move returns to the first viewpoint: the camera at 48 s equals the one at 0 s.
    let end = plan.at(48.0 - 1e-9);
    assert!((end.eye - cams[0].eye).length() < 1e-6 * plan.distance);
    assert_eq!(plan.at(48.0).phase, Phase::Ended);
}

#[test]
fn vertices_project_onto_pixels_of_their_own_triangles() {
    let (mut p, _) = hu2020();
    p.display.width_px = 840;
    p.display.height_px = 526;
    let mesh = common::bunny_res3();
    let plan = CameraPlan::new(&mesh, &p).unwrap();
    let raster = Rasterizer::new(&mesh);
    let (mut checked, mut agree) = (0usize, 0usize);
    for v in 0..p.viewpoints.count {
        let cam = plan.at(4.0 * v as f64 + 1.0);
        assert_eq!(cam.phase, Phase::Hold);
        let ids = raster.triangle_ids(&cam);
        let w = cam.width_px as usize;
        for (vi, pos) in mesh.positions.iter().enumerate() {
            let Some((x, y, _)) = cam.project(*pos) else {
                continue;
            };
            let (px, py) = (x.floor() as usize, y.floor() as usize);
            if px >= w || py >= cam.height_px as usize {
                continue;
            }
            let t = ids[py * w + px];
            if t == BACKGROUND_ID {
                continue;
            }
            // Visible: the triangle under the pixel is (nearly) at the vertex's depth: the
            // vertex is one of its corners or lies on its plane in front of everything else.
            let tri = mesh.triangles[t as usize];
            let (o, d) = cam.ray(x, y);
            let plane_hit = {
                let [a, b, c] = tri.map(|i| mesh.positions[i as usize]);
                let n = (b - a).cross(c - a);
                n.dot(a - o) / n.dot(d)
            };
            let vertex_t = (*pos - o).length();
            if (plane_hit - vertex_t).abs() > 1e-3 * plan.distance {
                continue; // the vertex is hidden behind this triangle
            }
            checked += 1;
            if tri.contains(&(vi as u32)) {
                agree += 1;
            } else {
                // A vertex exactly on a pixel boundary may fall in a neighbour of its fan.
                let adjacent = mesh.triangles[t as usize].iter().any(|&k| {
                    mesh.triangles
                        .iter()
                        .any(|tr| tr.contains(&k) && tr.contains(&(vi as u32)))
                });
                if adjacent {
                    agree += 1;
                }
            }
        }
    }
    let rate = agree as f64 / checked as f64;
    eprintln!("id-buffer check: {agree} of {checked} visible vertex projections land on a triangle that has them as a corner ({:.3}%)", 100.0 * rate);
    assert!(checked > 5000, "only {checked} visible vertices checked");
    assert!(rate >= 0.99, "agreement {rate}");
}

#[test]
fn a_short_stimulus_decodes_back_to_what_was_rendered_and_repeats_byte_for_byte() {
    let short = common::short_protocol_text();
    let protocol = Protocol::from_toml(&short, "short.toml").unwrap();
    assert_eq!(protocol.frame_count(), 54);
    let dir = std::env::temp_dir().join(format!("meshgaze-stim-{}", std::process::id()));
    let protocol_path = dir.join("short.toml");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(&protocol_path, &short).unwrap();
    let mesh_path = common::repo_root().join("stimuli/meshes/bun_zipper_res3.ply");
    let mesh = meshgaze::mesh::load_mesh(&mesh_path).unwrap().0;
    let options = StimulusOptions {
        frames: FrameImages::Keyframes,
        id_buffer: true,
        verify: true,
    };
    let run = |sub: &str| {
        let out = dir.join(sub);
        let m = render_stimulus(
            &mesh_path,
            &mesh,
            &protocol,
            &short,
            &protocol_path.display().to_string(),
            &out,
            &options,
            &Silent,
        )
        .unwrap();
        (
            m,
            std::fs::read(out.join("stimulus.mp4")).unwrap(),
            std::fs::read(out.join("timeline.csv")).unwrap(),
        )
    };
    let (m, video, timeline) = run("a");
    let v = m.verify.as_ref().unwrap();
    eprintln!(
        "decoded back: {} frames, lowest PSNR {:.1} dB, {} outlier values",
        v.frames_decoded, v.min_psnr_db, v.outlier_values
    );
    assert_eq!(m.video.frames, 54);
    assert_eq!(v.frames_decoded, 54);
    assert!(v.min_psnr_db > 35.0, "PSNR {}", v.min_psnr_db);
    // No speckles: no channel value off by more than 48 anywhere (background detection off).
    assert_eq!(v.outlier_values, 0);
    assert_eq!(&video[4..8], b"ftyp");
    let moov = video.windows(4).position(|w| w == b"moov").unwrap();
    let mdat = video.windows(4).position(|w| w == b"mdat").unwrap();
    assert!(moov < mdat, "fast start: the index comes first");
    assert_eq!(m.video.sha256, meshgaze::provenance::sha256_hex(&video));
    assert_eq!(
        m.timeline.sha256,
        meshgaze::provenance::sha256_hex(&timeline)
    );
    let text = String::from_utf8(timeline.clone()).unwrap();
    assert_eq!(text.lines().count(), 55);
    assert!(text
        .lines()
        .next()
        .unwrap()
        .starts_with("frame,time_ms,phase,viewpoint"));
    assert_eq!(std::fs::read_dir(dir.join("a/frames")).unwrap().count(), 6); // 3 keyframes + 3 id images
    let (_, video2, timeline2) = run("b");
    assert!(
        video == video2,
        "same inputs should give the same video bytes"
    );
    assert_eq!(timeline, timeline2);

    // Sync aids: a photodiode patch, white during holds; a burned-in counter. Their hard
    // black/white edges ring a little through 4:2:0 chroma subsampling (measured, reported).
    let with_sync = short
        .replace("photodiode = false", "photodiode = true")
        .replace("frame_counter = false", "frame_counter = true");
    let protocol = Protocol::from_toml(&with_sync, "sync.toml").unwrap();
    std::fs::write(&protocol_path, &with_sync).unwrap();
    let out = dir.join("sync");
    let m = render_stimulus(
        &mesh_path,
        &mesh,
        &protocol,
        &with_sync,
        &protocol_path.display().to_string(),
        &out,
        &options,
        &Silent,
    )
    .unwrap();
    let v = m.verify.unwrap();
    eprintln!(
        "with sync overlays: lowest PSNR {:.1} dB, {} channel values off by > 48 (overlay edges)",
        v.min_psnr_db, v.outlier_values
    );
    let key = image::open(out.join("frames/frame_00000.png"))
        .unwrap()
        .to_rgb8();
    assert_eq!(
        key.get_pixel(319, 199).0,
        [255, 255, 255],
        "photodiode patch white in a hold"
    );
    assert_eq!(key.get_pixel(280, 160).0, [255, 255, 255]);
    assert_eq!(key.get_pixel(2, 2).0, [0, 0, 0], "counter background");
}

#[test]
fn detector_settings_live_in_the_protocol_and_convert_degrees_to_pixels() {
    let (p, text) = hu2020();
    assert_eq!(
        (
            p.fixations.idt_max_dispersion_px,
            p.fixations.min_duration_ms,
            p.fixations.ivt_max_velocity_deg_s
        ),
        (100.0, 80.0, 40.0)
    );
    // 1680 px over 473.8 mm seen from 1025 mm: 17.89 mm, i.e. 63.4 px, per degree.
    let ppd = p.display.pixels_per_degree();
    assert!((ppd - 63.44).abs() < 0.05, "{ppd}");
    // Older protocol files without the detector keys still read, with SMI's defaults.
    let old: String = text
        .lines()
        .filter(|l| {
            !l.starts_with("idt_") && !l.starts_with("min_duration") && !l.starts_with("ivt_")
        })
        .map(|l| format!("{l}\n"))
        .collect();
    let q = Protocol::from_toml(&old, "old.toml").unwrap();
    assert_eq!(q.fixations.idt_max_dispersion_px, 100.0);
}

/// The access units of an MP4's single H.264 track, in Annex B, parameter sets first: the
/// avcC box's SPS and PPS, then every length-prefixed NAL unit of mdat (enough of the format
/// for files this crate writes: one track, its samples back to back in one mdat).
fn annexb_of_mp4(mp4: &[u8]) -> Vec<u8> {
    let find = |tag: &[u8]| mp4.windows(4).position(|w| w == tag).expect("box") + 4;
    let c = find(b"avcC");
    let length_size = (mp4[c + 4] & 3) as usize + 1;
    let mut out = Vec::new();
    let mut put = |nal: &[u8]| {
        out.extend_from_slice(&[0, 0, 0, 1]);
        out.extend_from_slice(nal);
    };
    let mut at = c + 5;
    for _ in 0..2 {
        // SPS then PPS: a count, then (16-bit length, bytes) each.
        let count = (mp4[at] & 0x1f) as usize;
        at += 1;
        for _ in 0..count {
            let len = u16::from_be_bytes([mp4[at], mp4[at + 1]]) as usize;
            put(&mp4[at + 2..at + 2 + len]);
            at += 2 + len;
        }
    }
    let m = find(b"mdat");
    let end = u32::from_be_bytes(mp4[m - 8..m - 4].try_into().unwrap()) as usize + m - 8;
    let mut at = m;
    while at + length_size <= end {
        let len = mp4[at..at + length_size]
            .iter()
            .fold(0usize, |v, &b| (v << 8) | b as usize);
        put(&mp4[at + length_size..at + length_size + len]);
        at += length_size + len;
    }
    out
}

/// A keyframe interval of 20 cuts this 54-frame stimulus into two separately encoded
/// segments at frame 20, inside the second hold. The file must still be one stream: one
/// decoder, fed the MP4's samples in order, gives back all 54 frames; the second segment
/// redraws the hold it begins in without writing a second keyframe PNG for it.
#[test]
fn a_stimulus_encoded_in_two_segments_decodes_as_one_stream() {
    let short = common::short_protocol_text().replace(
        "keyframe_interval_frames = 60",
        "keyframe_interval_frames = 20",
    );
    let protocol = Protocol::from_toml(&short, "short.toml").unwrap();
    let dir = std::env::temp_dir().join(format!("meshgaze-segments-{}", std::process::id()));
    let mesh_path = common::repo_root().join("stimuli/meshes/bun_zipper_res3.ply");
    let mesh = meshgaze::mesh::load_mesh(&mesh_path).unwrap().0;
    let options = StimulusOptions {
        frames: FrameImages::Keyframes,
        id_buffer: false,
        verify: true,
    };
    let m = render_stimulus(
        &mesh_path,
        &mesh,
        &protocol,
        &short,
        "short.toml",
        &dir,
        &options,
        &Silent,
    )
    .unwrap();
    let v = m.verify.as_ref().unwrap();
    assert_eq!((m.video.frames, v.frames_decoded), (54, 54));
    assert!(v.min_psnr_db > 35.0, "PSNR {}", v.min_psnr_db);
    // 3 holds and 27 move frames, plus the second hold's image drawn again by the segment
    // that begins inside it; only the hold's first frame is a keyframe PNG.
    assert_eq!(m.timings.frames_rendered, 3 + 3 * 9 + 1);
    let pngs: Vec<String> = std::fs::read_dir(dir.join("frames"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(pngs.len(), 3, "{pngs:?}");
    assert!(!pngs.contains(&"frame_00020.png".to_string()), "{pngs:?}");

    let stream = annexb_of_mp4(&std::fs::read(dir.join("stimulus.mp4")).unwrap());
    let mut decoder = openh264::decoder::Decoder::new().unwrap();
    let mut decoded = 0;
    for nal in openh264::nal_units(&stream) {
        if decoder
            .decode(nal)
            .expect("the one stream decodes")
            .is_some()
        {
            decoded += 1;
        }
    }
    decoded += decoder.flush_remaining().unwrap().len();
    assert_eq!(decoded, 54);
    std::fs::remove_dir_all(&dir).ok();
}
