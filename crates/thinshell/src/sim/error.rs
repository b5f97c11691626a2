//! [`BuildError`]: why a scene or a [`super::SimulationBuilder`]'s values could not be turned
//! into a simulation (shared by the builder and the sections it calls, such as path following).

use thinshell_energy::EnergyError;
use thinshell_growth::GrowthError;
use thinshell_mesh::MeshError;
use thinshell_solver::SolverError;

/// Why a scene could not be turned into a simulation.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BuildError {
    /// The mesh could not be loaded or generated.
    #[error("{origin}: mesh: {source}")]
    Mesh {
        /// The scene.
        origin: String,
        /// Why.
        source: MeshError,
    },
    /// The scene's OBJ file could not be read or is not a valid mesh.
    #[error("{origin}: mesh file {}: {source}", .path.display())]
    MeshFile {
        /// The scene.
        origin: String,
        /// The OBJ file, resolved against the scene's directory.
        path: std::path::PathBuf,
        /// Why.
        source: MeshError,
    },
    /// Rest state, material or assembly set-up failed.
    #[error("{origin}: {source}")]
    Energy {
        /// The scene.
        origin: String,
        /// Why.
        source: EnergyError,
    },
    /// Growth model or stimulus set-up failed.
    #[error("{origin}: growth: {source}")]
    Growth {
        /// The scene.
        origin: String,
        /// Why.
        source: GrowthError,
    },
    /// Solver settings rejected.
    #[error("{origin}: solver: {source}")]
    Solver {
        /// The scene.
        origin: String,
        /// Why.
        source: SolverError,
    },
    /// A value that only the built mesh can check (a vertex index out of range, no free
    /// unknowns, …), or an effect this version cannot simulate yet.
    #[error("{origin}: `{key}` {message}")]
    Invalid {
        /// The scene.
        origin: String,
        /// Dotted key.
        key: String,
        /// What is wrong.
        message: String,
    },
}
