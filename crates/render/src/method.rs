//! How the integrator estimates the light of each linear light at a shading point: the
//! *method* of a render (`linlight render --technique … --mis …`).
//!
//! | method | per light and iteration | weights |
//! |---|---|---|
//! | [`Method::Technique`] | one sample of the line technique, full BSDF | 1 |
//! | [`Method::Ltc`] | one LTC (specular) sample and one projected-solid-angle (PSA) sample | LTC sample: 1; PSA sample: 1 where the LTC density is 0, else 0 |
//! | [`Method::Mis`] | one PSA (diffuse) and one LTC (specular) sample | the heuristic's |
//!
//! Every method is unbiased for every BSDF. The techniques of [`Method::Technique`] sample
//! the line's part above the horizon (the clipped ones) or the whole line (area, solid angle,
//! where f·cos = 0 below the horizon). The LTC sampler's support is that part of the line
//! *and* (Aω)_z ≥ 0 — the cosine lobe's own hemisphere — which does not cover every direction
//! where the GGX lobe (and a diffuse part) is positive. [`Method::Ltc`] therefore covers the
//! rest with the PSA sample through support-indicator weights: w_s(ω) = 1[p_s(ω) > 0],
//! w_d(ω) = 1[p_s(ω) = 0]; they sum to 1 everywhere, so the estimator is unbiased, and the
//! PSA sample is shadow-traced only where the LTC cannot sample. [`Method::Mis`] weights
//! both samples by the heuristic (SPECULAR §3 of the design; `docs/mis.md`).
//!
//! Where no specular lobe exists (a Lambertian or otherwise non-glossy surface), or the lobe
//! is empty on the line in cosine space (clipped away at z = 0, or the table entry is too
//! ill-conditioned to sample), [`Method::Ltc`] and [`Method::Mis`] sample diffusely only: one
//! PSA sample with weight 1.

use linlight_sampling::mis::Heuristic;
use linlight_sampling::Technique;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Method {
    /// One sample of a line technique per light and iteration, weight 1.
    Technique(Technique),
    /// LTC, with the projected solid angle on the complement of the LTC's support.
    Ltc,
    /// Projected solid angle + LTC, combined by a heuristic (the paper's estimator).
    Mis(Heuristic),
}

impl Default for Method {
    /// The paper's estimator: MIS with clamped optimal weights, v = 0.5.
    fn default() -> Self {
        Method::Mis(Heuristic::default())
    }
}

impl From<Technique> for Method {
    fn from(t: Technique) -> Self {
        Method::Technique(t)
    }
}

impl Method {
    /// The `--technique` name: a technique's name, `ltc` or `mis`.
    pub fn technique_name(self) -> &'static str {
        match self {
            Method::Technique(t) => t.name(),
            Method::Ltc => "ltc",
            Method::Mis(_) => "mis",
        }
    }

    /// Every `--technique` name with a one-line description (for `--help`), the default first.
    pub fn technique_names() -> Vec<(&'static str, String)> {
        let mut v = vec![
            (
                "mis",
                "projected solid angle + LTC, combined by --mis (the paper's estimator; default)"
                    .to_string(),
            ),
            (
                "ltc",
                "LTC; projected solid angle where the LTC cannot sample".to_string(),
            ),
        ];
        for t in Technique::ALL {
            let what = if Technique::UNBIASED.contains(&t) {
                "one technique, full BSDF".to_string()
            } else {
                "biased by design (a timing floor)".to_string()
            };
            v.push((t.name(), what));
        }
        v
    }

    /// The method of `--technique NAME` (`mis` with the default heuristic).
    pub fn from_technique_name(name: &str) -> Result<Self, String> {
        match name {
            "mis" => Ok(Method::default()),
            "ltc" => Ok(Method::Ltc),
            _ => name
                .parse::<Technique>()
                .map(Method::Technique)
                .map_err(|_| {
                    let names: Vec<&str> = Self::technique_names().iter().map(|n| n.0).collect();
                    format!(
                        "unknown technique '{name}' (expected one of: {})",
                        names.join(", ")
                    )
                }),
        }
    }

    /// Whether the method's expectation is the rendered integral (all but the baseline).
    pub fn is_unbiased(self) -> bool {
        match self {
            Method::Technique(t) => Technique::UNBIASED.contains(&t),
            Method::Ltc | Method::Mis(_) => true,
        }
    }

    /// The method whose renders are this one's, bit for bit: MIS with the heuristic of
    /// [`Heuristic::same_weights_as`] (clamped optimal at v = 0 is balance, at v = 1 weighted);
    /// every other method is itself.
    pub fn same_renders_as(self) -> Method {
        match self {
            Method::Mis(h) => Method::Mis(h.same_weights_as()),
            m => m,
        }
    }

    /// Name for reports: `area`, `ltc`, `mis:balance`, `mis:clamped-optimal=0.5`.
    pub fn name(self) -> String {
        match self {
            Method::Mis(h) => format!("mis:{h}"),
            m => m.technique_name().to_string(),
        }
    }

    /// The image header entries that identify the method: `technique` (the `--technique`
    /// name), and for MIS `mis` (the heuristic's name) and, for clamped optimal, `mis_v`.
    pub fn header(self) -> Vec<(&'static str, String)> {
        let mut v = vec![("technique", self.technique_name().to_string())];
        if let Method::Mis(h) = self {
            v.push(("mis", h.name().to_string()));
            if let Some(x) = h.v() {
                v.push(("mis_v", x.to_string()));
            }
        }
        v
    }
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.name())
    }
}

impl std::str::FromStr for Method {
    type Err = String;
    /// The [`Method::name`] forms: a technique name, `ltc`, `mis` (default heuristic) or
    /// `mis:<heuristic>`.
    fn from_str(s: &str) -> Result<Self, String> {
        match s.split_once(':') {
            Some(("mis", h)) => h.parse().map(Method::Mis),
            Some(_) => Err(format!("unknown method '{s}'")),
            None => Self::from_technique_name(s),
        }
    }
}

/// The diffuse technique of a method on a Lambertian surface: the single technique, or the
/// projected solid angle (two-technique methods sample Lambertian surfaces diffusely only).
pub fn lambert_technique(method: Method) -> Technique {
    match method {
        Method::Technique(t) => t,
        Method::Ltc | Method::Mis(_) => Technique::ProjectedSolidAngle,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        let mut all: Vec<Method> = Technique::ALL.map(Method::Technique).to_vec();
        all.push(Method::Ltc);
        all.extend(Heuristic::ALL.map(Method::Mis));
        all.push(Method::Mis(Heuristic::ClampedOptimal(0.0)));
        all.push(Method::Mis(Heuristic::ClampedOptimal(1.0)));
        for m in all {
            assert_eq!(m.name().parse::<Method>(), Ok(m), "{m}");
            assert!(Method::from_technique_name(m.technique_name()).is_ok());
        }
        assert_eq!("mis".parse(), Ok(Method::default()));
        assert!("nope".parse::<Method>().is_err());
        assert!("mis:nope".parse::<Method>().is_err());
        let names: Vec<_> = Method::technique_names().into_iter().map(|n| n.0).collect();
        assert_eq!(names.len(), Technique::ALL.len() + 2);
        assert!(!Method::Technique(Technique::Baseline).is_unbiased());
        assert_eq!(
            Method::Mis(Heuristic::ClampedOptimal(0.25)).header(),
            vec![
                ("technique", "mis".to_string()),
                ("mis", "clamped-optimal".to_string()),
                ("mis_v", "0.25".to_string())
            ]
        );
    }
}
