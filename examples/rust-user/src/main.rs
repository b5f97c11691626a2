//! Prints the sag of the cantilever of [`thinshell_rust_user::cantilever`].

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let sim = thinshell_rust_user::cantilever()?;
    println!(
        "cantilever: tip sag {:.6e} m, elastic energy {:.6e} J",
        thinshell_rust_user::sag(&sim),
        sim.energy().elastic()
    );
    Ok(())
}
