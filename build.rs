//! Tells the test suites whether the shared real data (`../shared/data`, see its SOURCES.md)
//! is beside the repo. Without it, the tests that need it are compiled as ignored, with the
//! reason, so `cargo test` reports them as not run instead of passing them. Under CI (`CI`
//! set) the data is always laid beside the clone, so the cfg is never set there and a missing
//! folder fails those tests.
use std::path::Path;

fn main() {
    println!("cargo::rustc-check-cfg=cfg(no_shared_data)");
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
