//! The outputs of `cargo xtask perf`: `perf.json` (every raw sample, the facts of the symbolic
//! analyses, the generated section with and without timings) and the generated section of the
//! docs file between [`BEGIN`] and [`END`].
//!
//! The section is built from blocks whose cells are either *stable* (sizes, flops, Newton
//! iterations, targets, the libshell figures) or *timings* (everything measured with a clock,
//! and what is derived from it: ratios, verdicts, the machine line). With the timings masked the
//! section is byte-identical between runs on one revision; the JSON carries that masked text so
//! that a test can check it.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, Result, bail};
use serde_json::json;

use super::facts::Run;
use super::measure::faces_at;
use crate::common::write_json;

mod format;
mod machine;
mod row;
mod sections;
mod sources;
mod why;

pub(crate) use format::grouped;
use machine::command;

/// Replaces the text between the markers of `docs` by `section`; errors if they are missing.
pub(crate) fn splice(docs: &str, section: &str) -> Result<String> {
    let (Some(a), Some(z)) = (docs.find(BEGIN), docs.find(END)) else {
        bail!("the docs file has no `{BEGIN}` … `{END}` markers to write between");
    };
    if z < a {
        bail!("`{END}` comes before `{BEGIN}` in the docs file");
    }
    let head = &docs[..a + BEGIN.len()];
    let tail = &docs[z..];
    Ok(format!("{head}\n{section}{tail}"))
}

/// Marker lines of the generated part of the docs file.
pub(crate) const BEGIN: &str = "<!-- perf:begin -->";
/// See [`BEGIN`].
pub(crate) const END: &str = "<!-- perf:end -->";

/// Writes the docs section into `docs` (the file's text) at `docs_path`, and the JSON to
/// `json_path`.
pub(crate) fn write(docs_path: &Path, json_path: &Path, run: &Run, docs: &str) -> Result<()> {
    let blocks = sections::blocks(run);
    let section = format::render(&blocks, false);
    let masked = format::render(&blocks, true);
    let new_docs = splice(docs, &section)?;
    std::fs::write(docs_path, new_docs)
        .with_context(|| format!("writing {}", docs_path.display()))?;

    let levels: BTreeMap<String, serde_json::Value> = run
        .facts
        .levels
        .iter()
        .map(|(l, f)| {
            (
                l.to_string(),
                json!({
                    "faces": f.faces, "unknowns": f.unknowns, "nnz_lower": f.nnz,
                    "ordering": f.ordering, "flops": f.flops, "factor_len": f.factor_len,
                    "memory_estimate": f.memory_estimate,
                }),
            )
        })
        .collect();
    let orderings: Vec<serde_json::Value> = run
        .facts
        .orderings
        .iter()
        .map(|o| {
            json!({
                "level": o.level, "faces": faces_at(o.level), "ordering": o.asked, "used": o.used,
                "flops": o.flops, "factor_len": o.factor_len,
                "memory_estimate": o.memory_estimate, "symbolic_s": o.symbolic_s,
            })
        })
        .collect();
    let big: Vec<serde_json::Value> = run
        .big_runs
        .iter()
        .map(|b| {
            json!({
                "level": b.level, "threads": b.threads, "faces": b.faces, "unknowns": b.unknowns,
                "ordering": b.ordering, "flops": b.flops, "memory_estimate": b.memory_estimate,
                "peak_rss": b.peak_rss, "setup_s": b.setup_s, "samples": b.samples,
                "wall_s": b.wall_s,
            })
        })
        .collect();
    let doc = json!({
        "command": command(run),
        "quick": run.quick,
        "rounds": run.rounds,
        "sizes": {
            "per_face_level": run.sizes.per_face,
            "factor_levels": run.sizes.factor,
            "newton_levels": run.sizes.newton,
            "big_level": run.sizes.big,
            "threads": run.sizes.threads,
        },
        "units": "seconds; per_face/* in seconds per face; newton_iterations a count",
        "samples": run.samples,
        "levels": levels,
        "orderings": orderings,
        "unknowns": run.facts.unknowns,
        "big": big,
        "total_s": run.total_s,
        "section": section,
        "section_masked": masked,
    });
    write_json(json_path, &doc)?;
    println!(
        "perf: wrote {} and {} ({:.0} s)",
        docs_path.display(),
        json_path.display(),
        run.total_s
    );
    print!("{section}");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::format::{flops, time};
    use super::machine::today;
    use super::row::Target;
    use super::*;

    #[test]
    fn splice_rewrites_only_between_the_markers() -> Result<()> {
        let docs = format!("# T\n\nintro\n\n{BEGIN}\nold\n{END}\n\n## history\n");
        let new = splice(&docs, "new\n")?;
        assert_eq!(
            new,
            format!("# T\n\nintro\n\n{BEGIN}\nnew\n{END}\n\n## history\n")
        );
        assert_eq!(splice(&new, "new\n")?, new);
        assert!(splice("# no markers\n", "x").is_err());
        assert!(splice(&format!("{END}\n{BEGIN}\n"), "x").is_err());
        Ok(())
    }

    #[test]
    fn numbers_are_formatted_as_in_the_issue() {
        assert_eq!(grouped(14_924), "14 924");
        assert_eq!(grouped(188), "188");
        assert_eq!(grouped(1_234_567), "1 234 567");
        assert_eq!(time(0.279), "279 ms");
        assert_eq!(time(2.031), "2.03 s");
        assert_eq!(flops(6.4e9), "6.40e9");
        assert_eq!(flops(9.996e10), "1.00e11");
        assert_eq!(flops(5.65e10), "5.65e10");
        assert_eq!(Target::AtLeast(1.5).verdict(1.6), "met");
        assert_eq!(Target::AtLeast(2.0).verdict(1.0), "gap: 2.00× short");
        assert_eq!(Target::AtMost(1.2).verdict(1.28), "gap: 0.08 over");
        assert!(today().len() == 10 && today().starts_with("20"));
    }
}
