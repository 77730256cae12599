//! The checks of the sampler suite, as named in its reports (docs/sampler-suite.md). A module of
//! its own so that the subjects (which say which checks must reject a control) and the suite
//! (which runs them) both depend on it rather than on each other.

use serde::Serialize;

/// The kind of a failed check (report keys). The order is the order of the report's
/// `failures_by_check`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Check {
    Chi2,
    Chi2Coarse,
    Normalisation,
    Support,
    Direction,
    PdfConsistency,
    RoundTrip,
    Integral,
    ZeroContribution,
    CrossDensity,
    CrossBalance,
    Panic,
    /// Answers of an [`crate::answers::AnswerSource`] that are not numbers of the right kind: a
    /// density that is NaN, infinite or negative, a direction that is not finite or not of unit
    /// length.
    Answer,
    /// The inverse ξ' an answer source reports for its own sample differs from the ξ it was
    /// given (the round-trip tolerance).
    ReportedInverse,
    /// The answer source could not answer at all (its message).
    Source,
}

impl Check {
    pub fn name(self) -> &'static str {
        match self {
            Check::Chi2 => "chi2",
            Check::Chi2Coarse => "chi2-coarse",
            Check::Normalisation => "normalisation",
            Check::Support => "support",
            Check::Direction => "direction",
            Check::PdfConsistency => "pdf-consistency",
            Check::RoundTrip => "round-trip",
            Check::Integral => "integral",
            Check::ZeroContribution => "zero-contribution",
            Check::CrossDensity => "cross-density",
            Check::CrossBalance => "cross-balance",
            Check::Panic => "panic",
            Check::Answer => "answer",
            Check::ReportedInverse => "reported-inverse",
            Check::Source => "source",
        }
    }
}
