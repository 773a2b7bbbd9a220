#![no_main]
use libfuzzer_sys::fuzz_target;
use meshgaze::mesh::{parse_mesh_bytes, MeshFormat};

fuzz_target!(|data: &[u8]| {
    for f in [MeshFormat::Obj, MeshFormat::Ply, MeshFormat::Off] {
        if let Ok((mesh, report)) = parse_mesh_bytes(data, "fuzz".as_ref(), f) {
            assert_eq!(mesh.positions.len(), report.vertices);
            assert!(mesh
                .triangles
                .iter()
                .flatten()
                .all(|&i| (i as usize) < mesh.positions.len()));
        }
    }
});
