//! Deliberately wrong copies of the kernel source: the certification's negative controls, run
//! through the same backend as the kernels themselves. Each mutation replaces one exact piece of
//! the source (and fails loudly if the source no longer contains it).

/// A mutation of the kernel source.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mutation {
    /// One Halley step instead of two (projected solid angle, and LTC through it).
    OneHalleyStep,
    /// Every reported density × 1.01.
    PdfTimes1_01,
    /// The LTC sampler maps back with a wrong A⁻¹ (x scaled by 1.2 in cosine space) and its
    /// inverse uses the same wrong matrix: sample and inverse agree with each other, the density
    /// (of the true A) integrates to 1, only the distribution of the samples is wrong.
    LtcWrongInverse,
}

impl Mutation {
    pub const ALL: [Mutation; 3] = [
        Mutation::OneHalleyStep,
        Mutation::PdfTimes1_01,
        Mutation::LtcWrongInverse,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Mutation::OneHalleyStep => "one-halley-step",
            Mutation::PdfTimes1_01 => "pdf-x1.01",
            Mutation::LtcWrongInverse => "ltc-wrong-inverse",
        }
    }

    fn replacements(self) -> &'static [(&'static str, &'static str)] {
        match self {
            Mutation::OneHalleyStep => &[(
                "const LL_HALLEY_STEPS: u32 = 2u;",
                "const LL_HALLEY_STEPS: u32 = 1u;",
            )],
            Mutation::PdfTimes1_01 => &[(
                "const LL_PDF_SCALE: f32 = 1.0;",
                "const LL_PDF_SCALE: f32 = 1.01;",
            )],
            Mutation::LtcWrongInverse => &[
                (
                    "l.to_world = shading_frame * a_inv;",
                    "l.to_world = shading_frame * a_inv * mat3x3f(1.2, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0);",
                ),
                (
                    "let w_o = normalize(l.a * (l.to_shading * dir));",
                    "let w_o = normalize(mat3x3f(1.0 / 1.2, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0) * l.a * (l.to_shading * dir));",
                ),
            ],
        }
    }
}

/// The source with `mutation` applied. Panics if a piece to replace does not occur exactly once
/// (the control would silently test the unmutated kernels).
pub fn mutated(source: &str, mutation: Mutation) -> String {
    let mut out = source.to_string();
    for (from, to) in mutation.replacements() {
        assert_eq!(
            out.matches(from).count(),
            1,
            "mutation {}: {from:?} must occur exactly once in the kernel source",
            mutation.name()
        );
        out = out.replace(from, to);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_mutation_applies_and_validates() {
        for m in Mutation::ALL {
            let src = mutated(linlight_kernels::WGSL, m);
            assert_ne!(src, linlight_kernels::WGSL, "{}", m.name());
            linlight_kernels::parse_and_validate(&src).unwrap();
        }
    }
}
