//! Run-time selection of a technique: names for the command line, preparation, dispatch.

use crate::area::Area;
use crate::baseline::Baseline;
use crate::geometry::{LineFrame, Segment};
use crate::hart::{HartLinear, HartQuadratic};
use crate::li2018::Li2018;
use crate::projected_solid_angle::ProjectedSolidAngle;
use crate::sampler::LineSampler;
use crate::solid_angle::SolidAngle;
use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Technique {
    Baseline,
    Area,
    SolidAngle,
    ClippedSolidAngle,
    HartLinear,
    HartQuadratic,
    Li2018,
    ProjectedSolidAngle,
}

impl Technique {
    pub const ALL: [Technique; 8] = [
        Technique::Baseline,
        Technique::Area,
        Technique::SolidAngle,
        Technique::ClippedSolidAngle,
        Technique::HartLinear,
        Technique::HartQuadratic,
        Technique::Li2018,
        Technique::ProjectedSolidAngle,
    ];

    /// Every technique whose density is exact (all but the baseline).
    pub const UNBIASED: [Technique; 7] = [
        Technique::Area,
        Technique::SolidAngle,
        Technique::ClippedSolidAngle,
        Technique::HartLinear,
        Technique::HartQuadratic,
        Technique::Li2018,
        Technique::ProjectedSolidAngle,
    ];

    /// Name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Technique::Baseline => "baseline",
            Technique::Area => "area",
            Technique::SolidAngle => "solid-angle",
            Technique::ClippedSolidAngle => "clipped-solid-angle",
            Technique::HartLinear => "hart-linear",
            Technique::HartQuadratic => "hart-quadratic",
            Technique::Li2018 => "li2018",
            Technique::ProjectedSolidAngle => "projected-solid-angle",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|t| t.name() == name)
    }

    /// Whether the support of the technique is clipped to the horizon (unclipped techniques put
    /// samples below the horizon, which contribute zero).
    pub fn clips_to_horizon(self) -> bool {
        !matches!(
            self,
            Technique::Baseline | Technique::Area | Technique::SolidAngle
        )
    }

    /// Prepare the technique for one light at shading point `x` with normal `n` (normalised
    /// here; zero or non-finite normals give `None`). `None`: the light contributes nothing.
    ///
    /// Use the result by reference (`.as_ref()`, `if let Some(p) = &…`), as the renderer does.
    /// Moving the sampler out of the `Option` (`if let Some(p) = technique.prepare(…)`) makes the
    /// caller copy the ~120-byte [`Prepared`] with 16-byte loads of fields that `prepare` has
    /// just stored with narrower stores: the loads cannot be forwarded from the store buffer and
    /// wait for those stores to retire, i.e. for the whole preparation, so the sample cannot
    /// start early (the techniques micro-benchmark shows the difference).
    pub fn prepare(self, segment: &Segment, x: Vec3, n: Vec3) -> Option<Prepared> {
        Some(match self {
            Technique::Baseline => Prepared::Baseline(Baseline::prepare(segment, x, n)?),
            Technique::Area => Prepared::Area(Area::prepare(segment, x, n)?),
            Technique::SolidAngle => Prepared::SolidAngle(SolidAngle::prepare(segment, x, n)?),
            Technique::ClippedSolidAngle => {
                Prepared::SolidAngle(SolidAngle::prepare_clipped(segment, x, n)?)
            }
            Technique::HartLinear => Prepared::HartLinear(HartLinear::prepare(segment, x, n)?),
            Technique::HartQuadratic => {
                Prepared::HartQuadratic(HartQuadratic::prepare(segment, x, n)?)
            }
            Technique::Li2018 => Prepared::Li2018(Li2018::prepare(segment, x, n)?),
            Technique::ProjectedSolidAngle => {
                Prepared::ProjectedSolidAngle(ProjectedSolidAngle::prepare(segment, x, n)?)
            }
        })
    }
}

impl std::fmt::Display for Technique {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Technique {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Self::from_name(s).ok_or_else(|| {
            let names: Vec<_> = Self::ALL.iter().map(|t| t.name()).collect();
            format!(
                "unknown technique '{s}' (expected one of: {})",
                names.join(", ")
            )
        })
    }
}

/// A prepared technique of any kind (static dispatch through a match).
#[derive(Clone, Copy, Debug)]
pub enum Prepared {
    Baseline(Baseline),
    Area(Area),
    SolidAngle(SolidAngle),
    HartLinear(HartLinear),
    HartQuadratic(HartQuadratic),
    Li2018(Li2018),
    ProjectedSolidAngle(ProjectedSolidAngle),
}

macro_rules! dispatch {
    ($self:ident, $s:ident => $e:expr) => {
        match $self {
            Prepared::Baseline($s) => $e,
            Prepared::Area($s) => $e,
            Prepared::SolidAngle($s) => $e,
            Prepared::HartLinear($s) => $e,
            Prepared::HartQuadratic($s) => $e,
            Prepared::Li2018($s) => $e,
            Prepared::ProjectedSolidAngle($s) => $e,
        }
    };
}

impl LineSampler for Prepared {
    #[inline]
    fn sample(&self, xi: f32) -> Vec3 {
        dispatch!(self, s => s.sample(xi))
    }
    #[inline]
    fn pdf(&self, dir: Vec3) -> f32 {
        dispatch!(self, s => s.pdf(dir))
    }
    #[inline]
    fn support(&self) -> &LineFrame {
        dispatch!(self, s => s.support())
    }
    #[inline]
    fn inverse(&self, dir: Vec3) -> Option<f32> {
        dispatch!(self, s => s.inverse(dir))
    }
    #[inline]
    fn sample_with_pdf(&self, xi: f32) -> (Vec3, f32) {
        dispatch!(self, s => s.sample_with_pdf(xi))
    }
}
