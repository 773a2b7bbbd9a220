//! Tells the test suites whether the shared real data (`../shared/data`, see its SOURCES.md)
//! is beside the repo. Without it, the tests that need it are compiled as ignored, with the
//! reason, so `cargo test` reports them as not run instead of passing them. Under CI (`CI`
//! set) the data is always laid beside the clone, so the cfg is never set there and a missing
//! folder fails those tests. The same for the headless browser of the 3D viewer's tests
//! (`no_chromium`): `.ci/run` installs Chromium, so under CI a missing one fails.
use std::path::Path;

fn main() {
    println!("cargo::rustc-check-cfg=cfg(no_shared_data)");
    println!("cargo::rustc-check-cfg=cfg(no_chromium)");
    println!("cargo::rerun-if-env-changed=MESHGAZE_CHROMIUM");
    println!("cargo::rerun-if-env-changed=PATH");
    if chromium().is_none() && std::env::var_os("CI").is_none() {
        println!("cargo::rustc-cfg=no_chromium");
        println!(
            "cargo::warning=no chromium found (PATH or MESHGAZE_CHROMIUM): the 3D viewer's browser tests are reported as ignored"
        );
    }
    println!("cargo::rerun-if-env-changed=CI");
    let manifest = std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR");
    let data = Path::new(&manifest).join("../shared/data");
    // Watch the folder itself: cargo reruns this when it appears or goes.
    println!("cargo::rerun-if-changed={}", data.display());
    let present = data.join("meshes").is_dir();
    if !present && std::env::var_os("CI").is_none() {
        println!("cargo::rustc-cfg=no_shared_data");
        println!(
            "cargo::warning=../shared/data is missing: the tests that need it are reported as ignored"
        );
    }
}

/// The browser tests/viewer.rs drives: MESHGAZE_CHROMIUM, or chromium / chromium-browser /
/// google-chrome on PATH (the same search as tests/viewer.rs).
fn chromium() -> Option<std::path::PathBuf> {
    if let Some(p) = std::env::var_os("MESHGAZE_CHROMIUM") {
        return Some(p.into());
    }
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .flat_map(|d| {
            ["chromium", "chromium-browser", "google-chrome"]
                .into_iter()
                .map(move |n| d.join(n))
        })
        .find(|p| p.is_file())
}
