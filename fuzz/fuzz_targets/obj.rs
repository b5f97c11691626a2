//! OBJ text → raw positions and faces → `Mesh::new` → scale check → rest forms: must never
//! panic; a mesh that passes the scale check has finite, positive areas, and an accepted mesh
//! writes back out.
#![no_main]

use libfuzzer_sys::fuzz_target;
use thinshell_energy::{RestState, SffKind};
use thinshell_mesh::{Mesh, io};

fuzz_target!(|data: &[u8]| {
    let Ok((positions, faces)) = io::read_obj_raw(data) else {
        return;
    };
    let Ok(mesh) = Mesh::new(positions, faces) else {
        return;
    };
    let mut out = Vec::new();
    io::write_obj(&mesh, mesh.positions(), &mut out).expect("an accepted mesh writes");
    // Reading it back may legitimately fail (distinct vertices at bit-identical positions are
    // merged), but it must not panic.
    let _ = io::read_obj(out.as_slice());
    if thinshell_mesh::check_scale(&mesh, mesh.positions()).is_err() {
        return;
    }
    // Everything downstream divides by areas: after the scale check they are finite and > 0.
    for (f, a) in thinshell_mesh::face_areas(&mesh, mesh.positions())
        .iter()
        .enumerate()
    {
        assert!(a.is_finite() && *a > 0.0, "face {f}: area {a}");
    }
    // What a scene does next: rest forms of the mesh as given (errors are fine, panics not).
    let _ = RestState::from_mesh(&mesh, mesh.positions(), SffKind::MidEdgeAverage);
});
