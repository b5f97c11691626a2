//! `cargo xtask perf`: the issue #17 measurements as markdown sections (this branch: factor
//! reuse and the iterative fallback; the lead merges the other sections).

mod fallback;
mod reuse;

use anyhow::Result;

/// Prints every section.
pub fn run(quick: bool) -> Result<()> {
    println!("{}", reuse::section(quick)?);
    println!("{}", fallback::section(quick)?);
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn quick_sections_produce_tables() -> anyhow::Result<()> {
        let r = super::reuse::section(true)?;
        assert!(
            r.contains("## #17 factor reuse") && r.lines().count() > 6,
            "{r}"
        );
        let f = super::fallback::section(true)?;
        assert!(f.contains("CG + IC(0)") && !f.contains("failed"), "{f}");
        Ok(())
    }
}
