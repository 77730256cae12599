//! Answer sources: samplers under test that are not Rust [`LineSampler`](linlight_sampling::LineSampler)s — a program speaking
//! the external protocol (docs/external-protocol.md), shader kernels on a GPU — answer the
//! suite's queries in batches, and the suite judges the answers exactly as it judges a Rust
//! sampler's own samples.
//!
//! An [`AnswerSource`] claims to implement one reference technique (e.g. the projected solid
//! angle). For every configuration the suite draws the same stream of N primary samples ξ it
//! would give a Rust sampler (counter-based, [`crate::suite::Settings::seed`]), sends them as one
//! batch, and runs its checks on the answers against the reference technique's certified density
//! (the Rust sampler of that technique: its `pdf`, `support` and exact `inverse`):
//! - χ² (fine and coarse) of the returned directions against the reference density;
//! - `pdf-consistency`: each returned density against the reference `pdf` of its direction;
//! - `round-trip`: the reference's exact inverse CDF at the returned direction against ξ — the
//!   backward error of the sample, for every source;
//! - `reported-inverse`: where the source reports its own inverse ξ'(ω), ξ' against ξ;
//! - `integral`: the Monte Carlo estimate of ∫(n·ω)⁺ dΩ_R with the returned densities;
//! - `cross-density`: the source's own `pdf` at directions it did not sample (uniform in solid
//!   angle over the whole, unclipped line: what multiple importance sampling evaluates) against
//!   the reference `pdf`, 0 outside the support included;
//! - `answer`: NaN, infinite or negative densities and non-unit directions.
//!
//! Measure and conventions are the Rust samplers' (docs/measures.md): densities per radius (per
//! solid angle divided by the tube radius R, R → 0), directions as unit vectors from the shading
//! point in world space, f32.
//!
//! Errors: a source that cannot answer (its process crashed, hung, wrote something that is not
//! the protocol, answered the wrong count) returns a [`SourceError`]. The suite then stops
//! asking it (every later configuration ends `source-failed` with the same message, see
//! [`SharedSource`]); `linlight samplers` prints the message and exits 2. Answers that *are*
//! answers but wrong (NaN, negative, off the sphere, the wrong distribution) are the subject's
//! fault and fail checks: exit 1.

use crate::configs::Config;
use glam::Vec3;
use std::sync::Mutex;

/// The answers to one batch of N primary samples, in the order of the batch.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SampleAnswers {
    /// Unit directions from the shading point toward the line, world space.
    pub directions: Vec<Vec3>,
    /// Density per radius p_R of each direction, as the implementation computes it alongside
    /// the sample (what a renderer divides by).
    pub densities: Vec<f32>,
    /// The implementation's own inverse ξ'(ω) of each returned direction, if it has one.
    pub inverse: Option<Vec<f32>>,
}

impl SampleAnswers {
    /// Whether the answers have `count` entries in every array they hold.
    pub fn has_count(&self, count: usize) -> bool {
        self.directions.len() == count
            && self.densities.len() == count
            && self.inverse.as_ref().is_none_or(|v| v.len() == count)
    }
}

/// Why a source could not answer: one line, ready to print after "error: ".
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SourceError(pub String);

impl std::fmt::Display for SourceError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for SourceError {}

/// An implementation of a line-sampling technique that answers the suite in batches.
///
/// Both methods get one configuration per call (the suite's [`Config`]: segment, shading point,
/// normal, shading frame, LTC matrix) and must answer every entry of the batch, in order. They
/// are called from one thread at a time (the suite holds the source in a [`SharedSource`]), for
/// the configurations in an unspecified order; a source keeps no state between calls that the
/// answers depend on.
pub trait AnswerSource: Send {
    /// Sample the technique prepared for `config` at every primary sample of `xi` (each in
    /// [0, 1)): directions, their densities, and the inverse if the implementation has one.
    /// A configuration where the technique has nothing to sample (the line wholly below the
    /// horizon, or degenerate) is still answered: the suite only asks where the reference
    /// technique prepares a sampler.
    fn sample(&mut self, config: &Config, xi: &[f32]) -> Result<SampleAnswers, SourceError>;

    /// The technique's density per radius at each of `directions` (unit, toward the line of
    /// `config`, not necessarily inside the support: 0 there), as a renderer's multiple
    /// importance sampling evaluates it at another technique's sample.
    fn pdf(&mut self, config: &Config, directions: &[Vec3]) -> Result<Vec<f32>, SourceError>;

    /// Called once after the last batch: release what the source holds (an external program
    /// must exit with status 0). An error here is a failure of the source like any other.
    fn finish(&mut self) -> Result<(), SourceError> {
        Ok(())
    }
}

/// A source shared by the suite's worker threads: one batch at a time, and after the first
/// error every later request fails at once with that error (a dead process is not asked again).
pub struct SharedSource {
    inner: Mutex<SourceState>,
}

struct SourceState {
    source: Box<dyn AnswerSource>,
    failed: Option<SourceError>,
}

impl SharedSource {
    pub fn new(source: Box<dyn AnswerSource>) -> Self {
        Self {
            inner: Mutex::new(SourceState {
                source,
                failed: None,
            }),
        }
    }

    /// `f` on the source unless it has failed before; an error is kept for every later call.
    fn with<T>(
        &self,
        f: impl FnOnce(&mut dyn AnswerSource) -> Result<T, SourceError>,
    ) -> Result<T, SourceError> {
        let mut state = self.inner.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(e) = &state.failed {
            return Err(e.clone());
        }
        let result = f(state.source.as_mut());
        if let Err(e) = &result {
            state.failed = Some(e.clone());
        }
        result
    }

    /// [`AnswerSource::sample`], with the count of the answers checked.
    pub fn sample(&self, config: &Config, xi: &[f32]) -> Result<SampleAnswers, SourceError> {
        self.with(|s| {
            let answers = s.sample(config, xi)?;
            if !answers.has_count(xi.len()) {
                return Err(SourceError(format!(
                    "{}: {} primary samples answered with {} directions, {} densities{}",
                    config.name,
                    xi.len(),
                    answers.directions.len(),
                    answers.densities.len(),
                    answers
                        .inverse
                        .as_ref()
                        .map_or_else(String::new, |v| format!(", {} inverses", v.len()))
                )));
            }
            Ok(answers)
        })
    }

    /// [`AnswerSource::pdf`], with the count of the answers checked.
    pub fn pdf(&self, config: &Config, directions: &[Vec3]) -> Result<Vec<f32>, SourceError> {
        self.with(|s| {
            let p = s.pdf(config, directions)?;
            if p.len() != directions.len() {
                return Err(SourceError(format!(
                    "{}: {} directions answered with {} densities",
                    config.name,
                    directions.len(),
                    p.len()
                )));
            }
            Ok(p)
        })
    }

    /// [`AnswerSource::finish`] (once; nothing after an earlier error), then the error that
    /// stopped the source, if any.
    pub fn finish(&self) -> Result<(), SourceError> {
        self.with(|s| s.finish())
    }

    /// The error that stopped the source, if any.
    pub fn failure(&self) -> Option<SourceError> {
        let state = self.inner.lock().unwrap_or_else(|e| e.into_inner());
        state.failed.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Counting {
        calls: usize,
        short: bool,
    }

    impl AnswerSource for Counting {
        fn sample(&mut self, _: &Config, xi: &[f32]) -> Result<SampleAnswers, SourceError> {
            self.calls += 1;
            let n = xi.len() - usize::from(self.short);
            Ok(SampleAnswers {
                directions: vec![Vec3::Z; n],
                densities: vec![1.0; n],
                inverse: None,
            })
        }
        fn pdf(&mut self, _: &Config, d: &[Vec3]) -> Result<Vec<f32>, SourceError> {
            self.calls += 1;
            Ok(vec![1.0; d.len()])
        }
    }

    /// A short answer is an error, and after it the source is not asked again.
    #[test]
    fn a_short_answer_stops_the_source() {
        let c = crate::configs::paper_sanity();
        let ok = SharedSource::new(Box::new(Counting {
            calls: 0,
            short: false,
        }));
        assert_eq!(ok.sample(&c, &[0.5; 4]).unwrap().directions.len(), 4);
        assert!(ok.failure().is_none());
        let short = SharedSource::new(Box::new(Counting {
            calls: 0,
            short: true,
        }));
        let e = short.sample(&c, &[0.5; 4]).unwrap_err();
        assert!(
            e.0.contains("4 primary samples answered with 3 directions"),
            "{e}"
        );
        assert_eq!(short.pdf(&c, &[Vec3::Z]).unwrap_err(), e);
        assert_eq!(short.failure(), Some(e));
    }
}
