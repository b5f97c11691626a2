//! The README's simple energy API (`Assembler::new` + `evaluate`) with the default bending form
//! (edge directors, which need edge angles): a clear error naming the way that works, never a
//! value at silently zero angles.
#![allow(clippy::unwrap_used)]

use thinshell_energy::{
    Assembler, DofMap, EnergyError, EvalOutput, Material, RestState, SffKind, ShellModel, Terms,
};

#[test]
fn default_form_through_the_simple_api_is_a_clear_error() {
    let mesh = thinshell_mesh::generators::icosphere(0.1, 2).unwrap();
    let sff = SffKind::default();
    let model = ShellModel {
        material: Material::paper(),
        terms: Terms::ELASTIC,
        sff,
    };
    let rest = RestState::for_model(&mesh, mesh.positions(), &model).unwrap();
    assert_eq!(rest.sff, Some(sff));
    let mut assembler =
        Assembler::new(&mesh, &DofMap::all_free(mesh.n_vertices()), Terms::ELASTIC).unwrap();
    let x: Vec<_> = mesh.positions().iter().map(|p| p * 1.01).collect();
    let err = assembler
        .evaluate(&model, &x, &rest, None, EvalOutput::default())
        .unwrap_err();
    assert!(
        matches!(err, EnergyError::EdgeUnknownsMismatch { .. }),
        "{err}"
    );
    let msg = err.to_string();
    for hint in [
        "Assembler::for_model",
        "evaluate_with_angles",
        "ShellSystem::energy",
    ] {
        assert!(msg.contains(hint), "{msg}");
    }
}
