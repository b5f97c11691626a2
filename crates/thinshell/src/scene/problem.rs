//! [`Problem`]: one problem found in a scene (the key it concerns and what is wrong), shared by
//! the whole-file checks (`validate`) and the sections that check themselves (`path`).

/// One problem found in a scene: the key it concerns and what is wrong.
#[derive(Clone, Debug, PartialEq)]
pub struct Problem {
    /// Dotted key path, e.g. `material.poisson` or `boundary.pins[0].axes`.
    pub key: String,
    /// What is wrong, in one sentence.
    pub message: String,
}

pub(crate) fn problem(key: impl Into<String>, message: impl Into<String>) -> Problem {
    Problem {
        key: key.into(),
        message: message.into(),
    }
}
