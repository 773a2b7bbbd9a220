//! The 3D viewer (`meshgaze view`, src/report/viewer.*): the page is one offline file, and in
//! a real headless Chromium it loads without an error, draws the mesh where the renderer's own
//! triangle-id image of the same video frame has it, changes colours with the map, and a hold
//! view shows what the timeline says the subjects saw.
//!
//! The browser tests need Chromium (MESHGAZE_CHROMIUM, or chromium on PATH): without it they
//! are compiled as ignored with that reason (build.rs), never passed; `.ci/run` installs it.
mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use image::RgbImage;
use meshgaze::mesh::mean_curvature::mean_curvature;
use meshgaze::projection::table::ProjectedRow;
use meshgaze::report::viewer::{viewer_page, ViewerInput, ViewerLimits};
use meshgaze::stimulus::camera::CameraPlan;
use meshgaze::stimulus::raster::{Rasterizer, BACKGROUND_ID};
use meshgaze::Protocol;

const WIDTH: u32 = 640;
const HEIGHT: u32 = 400;
const BACKGROUND: [u8; 3] = [250, 250, 250];

/// The paper's protocol (12 views, 48 s at 30 fps) on a 640x400 display.
fn protocol() -> Protocol {
    let text = std::fs::read_to_string(common::repo_root().join("protocols/hu2020.toml"))
        .unwrap()
        .replace("width_px = 1680", &format!("width_px = {WIDTH}"))
        .replace("height_px = 1050", &format!("height_px = {HEIGHT}"));
    Protocol::from_toml(&text, "hu2020-640.toml").unwrap()
}

/// Fixations of 4 subjects on every 97th vertex, as projected.csv rows would give them.
fn fixations(mesh: &meshgaze::Mesh) -> Vec<ProjectedRow> {
    (0..mesh.positions.len())
        .step_by(97)
        .enumerate()
        .map(|(i, v)| {
            let p = mesh.positions[v];
            ProjectedRow {
                subject: format!("s{:02}", i % 4 + 1),
                fixation: i / 4,
                start_ms: 500.0 + 400.0 * i as f64,
                duration_ms: 250.0,
                screen_x: 0.0,
                screen_y: 0.0,
                camera_time_s: Some(0.6 + 0.4 * i as f64),
                phase: Some("hold".into()),
                viewpoint: Some(0),
                triangle: Some(0),
                vertex: Some(v),
                x: Some(p.x),
                y: Some(p.y),
                z: Some(p.z),
                snap_px: None,
                fate: if i % 5 == 0 { "snapped" } else { "hit" }.into(),
            }
        })
        .collect()
}

struct Page {
    mesh: meshgaze::Mesh,
    plan: CameraPlan,
    fps: u32,
    html: String,
}

fn bunny_page(limits: &ViewerLimits) -> Page {
    let mesh = common::bunny();
    let protocol = protocol();
    let plan = CameraPlan::new(&mesh, &protocol).unwrap();
    let mc: Vec<f64> = mean_curvature(&mesh).0.iter().map(|h| h.abs()).collect();
    let height: Vec<f64> = mesh.positions.iter().map(|p| p.y).collect();
    let mut rows = fixations(&mesh);
    rows.push(ProjectedRow {
        fate: "background".into(),
        x: None,
        y: None,
        z: None,
        vertex: None,
        ..rows[0].clone()
    });
    let input = ViewerInput {
        title: "bunny".into(),
        mesh: &mesh,
        maps: vec![("mc".into(), mc), ("height".into(), height)],
        truth_density: None,
        fixations: rows,
        stimulus: Some((&plan, protocol.video.fps)),
    };
    let html = viewer_page(&input, limits).unwrap();
    Page {
        fps: protocol.video.fps,
        mesh,
        plan,
        html,
    }
}

#[test]
fn the_page_is_one_file_with_no_network_reference() {
    let page = bunny_page(&ViewerLimits::default());
    let lower = page.html.to_lowercase();
    for needle in [
        "http://", "https://", "src=", "href=", "@import", "url(", "//cdn",
    ] {
        assert!(!lower.contains(needle), "the page contains `{needle}`");
    }
    // 8,171 vertices, two maps, 1,440 frames of cameras: well under a megabyte per map.
    assert!(page.html.len() < 2_500_000, "{} bytes", page.html.len());
    assert!(page.html.contains("\"vertices\":8171"));
    assert!(page.html.contains("\"decimated_from\":null"));
    // One fixation without a surface point is counted, not drawn and not lost.
    assert!(page.html.contains("\"not_on_mesh\":{\"background\":1}"));
}

#[test]
fn a_large_mesh_is_shown_simplified_and_says_so() {
    let page = bunny_page(&ViewerLimits {
        max_triangles: 4000,
    });
    assert!(page.html.contains("\"decimated_from\":8171"));
    let data = data_of(&page.html);
    let shown = data["vertices"].as_u64().unwrap();
    assert!(shown < 3000 && shown > 1000, "{shown} vertices shown");
    assert!(data["triangles"].as_u64().unwrap() <= 4000);
    assert!(page.html.contains("Shown simplified"));
}

#[test]
fn text_that_would_close_the_script_is_escaped() {
    let mesh = common::bunny_res3();
    let mut rows = fixations(&mesh);
    rows[0].subject = "</script><b>x".into();
    let input = ViewerInput {
        title: "<b>t</b>".into(),
        mesh: &mesh,
        maps: vec![],
        truth_density: None,
        fixations: rows,
        stimulus: None,
    };
    let html = viewer_page(&input, &ViewerLimits::default()).unwrap();
    assert!(!html.contains("</script><b>"));
    assert!(html.contains("<title>&lt;b&gt;t&lt;/b&gt;"));
    let bad = ViewerInput {
        maps: vec![("short".into(), vec![0.0; 3])],
        ..input
    };
    let e = viewer_page(&bad, &ViewerLimits::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("short") && e.contains("1889"), "{e}");
}

fn data_of(html: &str) -> serde_json::Value {
    let start = html.find("class=\"mgv-data\">").unwrap() + "class=\"mgv-data\">".len();
    let end = start + html[start..].find("</script>").unwrap();
    serde_json::from_str(&html[start..end].replace("<\\/", "</")).unwrap()
}

fn chromium() -> PathBuf {
    if let Some(p) = std::env::var_os("MESHGAZE_CHROMIUM") {
        return p.into();
    }
    let path = std::env::var_os("PATH").unwrap_or_default();
    std::env::split_paths(&path)
        .flat_map(|d| {
            ["chromium", "chromium-browser", "google-chrome"]
                .into_iter()
                .map(move |n| d.join(n))
        })
        .find(|p| p.is_file())
        .expect(
            "no chromium on PATH (or MESHGAZE_CHROMIUM): the viewer's browser tests need it; \
             without it they are compiled as ignored, unless CI is set",
        )
}

fn browser(args: &[&str], url: &str) -> std::process::Output {
    // One profile folder per call: the tests run side by side, and two browsers sharing a
    // profile (named by the URL's length before) hand the page to each other and print
    // nothing, an empty status seen under load.
    static CALLS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let profile =
        std::env::temp_dir().join(format!("meshgaze-chromium-{}-{call}", std::process::id()));
    let mut cmd = Command::new(chromium());
    cmd.args([
        "--headless",
        "--no-sandbox",
        "--enable-unsafe-swiftshader",
        "--use-angle=swiftshader",
        "--hide-scrollbars",
        "--force-device-scale-factor=1",
        "--disable-background-networking",
        "--disable-component-update",
        "--no-first-run",
        "--window-size=800,600",
        "--virtual-time-budget=10000",
    ])
    .arg(format!("--user-data-dir={}", profile.display()))
    .args(args)
    .arg(url);
    let out = cmd.output().expect("chromium runs");
    std::fs::remove_dir_all(&profile).ok();
    out
}

fn write_page(page: &Page, name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("meshgaze-viewer-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, &page.html).unwrap();
    path
}

fn url(path: &Path, hash: &str) -> String {
    format!("file://{}#{hash}", path.display())
}

/// The page's status once it has drawn a frame. A headless browser on a loaded machine can
/// dump the page before its first animation frame (the status then says `drawn: false`);
/// that is the harness's timing, not the viewer's behaviour, so the page is read again, at
/// most three times, and the last status is returned whatever it says.
fn status(path: &Path, hash: &str) -> serde_json::Value {
    let mut s = status_once(path, hash);
    for attempt in 1..=3 {
        if s["drawn"] == true || s["ready"] == false {
            break;
        }
        eprintln!("{hash}: no frame drawn yet ({s}); reading the page again ({attempt}/3)");
        s = status_once(path, hash);
    }
    s
}

fn status_once(path: &Path, hash: &str) -> serde_json::Value {
    let out = browser(&["--dump-dom"], &url(path, hash));
    let dom = String::from_utf8_lossy(&out.stdout);
    let start = dom
        .find("<pre class=\"mgv-status\">")
        .unwrap_or_else(|| panic!("no viewer status in the page (the script did not run):\n{dom}"))
        + "<pre class=\"mgv-status\">".len();
    let end = start + dom[start..].find("</pre>").unwrap();
    let text = dom[start..end]
        .replace("&quot;", "\"")
        .replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&amp;", "&");
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("status `{text}`: {e}"))
}

fn screenshot(path: &Path, hash: &str, name: &str) -> RgbImage {
    let png = path.with_file_name(name);
    let out = browser(
        &[&format!("--screenshot={}", png.display())],
        &url(path, hash),
    );
    let img = image::open(&png)
        .unwrap_or_else(|e| {
            panic!(
                "no screenshot {}: {e}\n{}",
                png.display(),
                String::from_utf8_lossy(&out.stderr)
            )
        })
        .to_rgb8();
    // The drawing area is the video's pixels at the top left (size=video).
    image::imageops::crop_imm(&img, 0, 0, WIDTH, HEIGHT).to_image()
}

fn is_object(p: &image::Rgb<u8>) -> bool {
    p.0.iter()
        .zip(BACKGROUND)
        .any(|(&a, b)| (a as i32 - b as i32).abs() > 12)
}

fn hue_bin(p: &image::Rgb<u8>) -> Option<usize> {
    let [r, g, b] = p.0.map(|c| c as f64 / 255.0);
    let (max, min) = (r.max(g).max(b), r.min(g).min(b));
    if max <= 0.0 || (max - min) / max < 0.25 {
        return None;
    }
    let d = max - min;
    let h = if max == r {
        ((g - b) / d).rem_euclid(6.0)
    } else if max == g {
        (b - r) / d + 2.0
    } else {
        (r - g) / d + 4.0
    };
    Some(((h * 60.0 / 45.0) as usize).min(7))
}

#[test]
#[cfg_attr(no_chromium, ignore = "needs chromium (MESHGAZE_CHROMIUM or PATH)")]
fn in_chromium_the_page_loads_without_an_error_with_its_panel() {
    let page = bunny_page(&ViewerLimits::default());
    let path = write_page(&page, "panel.html");
    let s = status(&path, "");
    assert_eq!(s["ready"], true, "{s}");
    assert_eq!(s["drawn"], true, "{s}");
    assert_eq!(s["errors"], serde_json::json!([]), "{s}");
    assert_eq!(s["layer"], "mc");
    // The first hold view of the video is the starting camera.
    assert_eq!(s["mode"], "frame");
    assert_eq!(s["frame"], 0);
    // Every fixation with a surface point is a dot.
    assert_eq!(s["dots"], fixations(&page.mesh).len());
    // Replay at 4.55 s: the video's frame of that instant, and only the fixation made then
    // (fixation i runs from 500 + 400 i ms for 250 ms: i = 10).
    let s = status(&path, "t=4.55");
    assert_eq!(s["mode"], "frame", "{s}");
    assert_eq!(s["frame"], 136, "{s}");
    assert_eq!(s["dots"], 1, "{s}");
    let s = status(&path, "map=nope");
    assert_eq!(s["errors"], serde_json::json!(["no map named nope"]), "{s}");
}

#[test]
#[cfg_attr(no_chromium, ignore = "needs chromium (MESHGAZE_CHROMIUM or PATH)")]
fn in_chromium_a_hold_view_draws_the_mesh_where_the_renderer_does() {
    let page = bunny_page(&ViewerLimits::default());
    let path = write_page(&page, "hold.html");
    let raster = Rasterizer::new(&page.mesh);
    let iou_of = |img: &RgbImage, ids: &[u32]| {
        let (mut both, mut either) = (0usize, 0usize);
        for (i, p) in img.pixels().enumerate() {
            let (ours, theirs) = (is_object(p), ids[i] != BACKGROUND_ID);
            both += usize::from(ours && theirs);
            either += usize::from(ours || theirs);
        }
        both as f64 / either as f64
    };
    let mut previous: Option<Vec<u32>> = None;
    for view in [0usize, 4, 9] {
        // The button itself is clicked (its handler runs), panel shown, then the panel hidden
        // for the pixel comparison.
        let s = status(&path, &format!("press={view}&map=mc"));
        assert_eq!(s["view"], view, "{s}");
        let hash = format!("press={view}&ui=0&size=video&map=mc&dots=0");
        let s = status(&path, &hash);
        assert_eq!(s["errors"], serde_json::json!([]), "{s}");
        assert_eq!(
            s["viewport"],
            serde_json::json!([0, 0, WIDTH, HEIGHT]),
            "{s}"
        );
        let frame = s["frame"].as_u64().unwrap() as f64;
        let cam = page.plan.at(frame / page.fps as f64);
        assert_eq!(
            cam.viewpoint, view,
            "the button's frame holds its viewpoint"
        );
        let ids = raster.triangle_ids(&cam);
        let img = screenshot(&path, &hash, &format!("hold{view}.png"));
        let shown = img.pixels().filter(|p| is_object(p)).count();
        let iou = iou_of(&img, &ids);
        eprintln!("view {view} (frame {frame}): IoU with the renderer {iou:.4}");
        assert!(
            iou > 0.95,
            "view {view}: the drawn silhouette and the renderer's overlap by IoU {iou:.3}"
        );
        // The check tells views apart: another hold's silhouette does not match.
        if let Some(other) = &previous {
            let wrong = iou_of(&img, other);
            eprintln!("view {view} against the previous view's image: IoU {wrong:.4}");
            assert!(
                wrong < 0.9,
                "view {view} matches another view too (IoU {wrong:.3})"
            );
        }
        previous = Some(ids);
        let share = shown as f64 / (WIDTH * HEIGHT) as f64;
        assert!(
            share > 0.05,
            "view {view}: object pixels {share:.3} of the canvas"
        );
    }
}

#[test]
#[cfg_attr(no_chromium, ignore = "needs chromium (MESHGAZE_CHROMIUM or PATH)")]
fn in_chromium_switching_the_map_changes_the_colours() {
    let page = bunny_page(&ViewerLimits::default());
    let path = write_page(&page, "maps.html");
    let shot = |map: &str| {
        screenshot(
            &path,
            &format!("view=2&ui=0&size=video&dots=0&map={map}"),
            &format!("map-{map}.png"),
        )
    };
    let (mc, height, plain) = (shot("mc"), shot("height"), shot("plain"));
    let bins = |img: &RgbImage| {
        let mut used = [0usize; 8];
        for p in img.pixels().filter(|p| is_object(p)) {
            if let Some(b) = hue_bin(p) {
                used[b] += 1;
            }
        }
        used
    };
    let objects = mc.pixels().filter(|p| is_object(p)).count();
    let used = |counts: [usize; 8]| counts.iter().filter(|&&c| c * 200 > objects).count();
    // The height map runs through the whole ramp over the bunny: blue to red.
    assert!(
        used(bins(&height)) >= 5,
        "height: hue bins {:?}",
        bins(&height)
    );
    assert!(used(bins(&mc)) >= 3, "mc: hue bins {:?}", bins(&mc));
    assert_eq!(used(bins(&plain)), 0, "plain is grey: {:?}", bins(&plain));
    let differ = mc
        .pixels()
        .zip(height.pixels())
        .filter(|(a, b)| is_object(a) && a.0.iter().zip(b.0).any(|(x, y)| x.abs_diff(y) > 40))
        .count();
    assert!(
        differ * 4 > objects,
        "mc and height differ on {differ} of {objects} object pixels"
    );
}

#[test]
#[cfg_attr(no_chromium, ignore = "needs chromium (MESHGAZE_CHROMIUM or PATH)")]
fn in_chromium_the_demo_report_opens_offline_with_its_viewer() {
    let dir = std::env::temp_dir().join(format!("meshgaze-demo-view-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let out = Command::new(env!("CARGO_BIN_EXE_meshgaze"))
        .args(["demo", "--quiet", "--subjects", "4", "-o"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report = dir.join("report.html");
    let html = std::fs::read_to_string(&report).unwrap();
    assert!(html.contains("<h2>In 3D</h2>") && html.contains("class=\"mgv-data\""));
    let lower = html.to_lowercase();
    assert!(!lower.contains("http://") && !lower.contains("https://"));
    let s = status(&report, "");
    std::fs::remove_dir_all(&dir).ok();
    assert_eq!(s["ready"], true, "{s}");
    assert_eq!(s["drawn"], true, "{s}");
    assert_eq!(s["errors"], serde_json::json!([]), "{s}");
    // The demo's first map, with the observers' fixations on the surface.
    assert_eq!(s["layer"], "sms", "{s}");
    assert!(s["dots"].as_u64().unwrap() > 20, "{s}");
}
