//! `<bsdf>` elements → [`Bsdf`], with Mitsuba 3.9.1's defaults. Supported: `diffuse`,
//! `roughconductor` (GGX, isotropic, `material="none"` or explicit `eta`/`k`), `principled`
//! (reflection lobes), `blendbsdf` of two of these, and `twosided` around any of them.
//! Everything the renderer would evaluate differently from Mitsuba is an error naming the
//! element and what is supported.

use super::build::{f32_of, plugin_type, rgb_of, Builder};
use super::tree::Elem;
use super::values::Props;
use super::{err, SceneError};
use crate::scene::SourceLocation;
use glam::DVec3;
use linlight_brdf::{Blend, Bsdf, ConductorFresnel, Principled, RoughConductor};

const BSDFS: &str = "diffuse, roughconductor, principled, blendbsdf, twosided";

/// Where a BSDF element sits: `twosided` is only supported as the outermost BSDF.
#[derive(Clone, Copy, PartialEq)]
enum Nesting {
    Top,
    InTwoSided,
    InBlend,
}

const PRINCIPLED_SUPPORTED: &str = "supported: base_color, roughness, metallic, specular or eta, \
     spec_tint, flatness; sheen, clearcoat, spec_trans and anisotropic must be 0";

/// The closest supported BSDF to an unsupported Mitsuba one, as advice after its refusal.
fn replacement(ty: &str) -> &'static str {
    match ty {
        "conductor" => {
            "; closest: roughconductor with <string name=\"distribution\" value=\"ggx\"/>, \
             the same eta and k, and a small alpha such as 0.01 — a smooth mirror reflects a \
             line light only along a curve of zero area, so its direct light is not defined here"
        }
        "dielectric" | "thindielectric" | "roughdielectric" => {
            "; closest: principled with metallic 0, a small roughness and the same eta — its \
             reflection without the transmission, which direct light through glass would need"
        }
        "plastic" | "roughplastic" => {
            "; closest: principled with metallic 0, the plastic's diffuse_reflectance as \
             base_color, its eta and (roughplastic) roughness = √alpha"
        }
        "bumpmap" | "normalmap" | "mask" => "; closest: the nested or underlying BSDF on its own",
        _ => "",
    }
}

impl Builder<'_> {
    /// The BSDF of a `<bsdf>` element (a shape's, or a top-level one).
    pub(super) fn bsdf(&mut self, e: &Elem) -> Result<Bsdf, SceneError> {
        self.bsdf_in(e, Nesting::Top)
    }

    fn bsdf_in(&mut self, e: &Elem, nesting: Nesting) -> Result<Bsdf, SceneError> {
        let ty = plugin_type(e)?;
        let p = self.props(e)?;
        let b = match ty {
            "diffuse" => Bsdf::Diffuse {
                reflectance: self.reflectance(&p, "reflectance", 0.5, &e.loc)?,
            },
            "roughconductor" => Bsdf::RoughConductor(self.roughconductor(&p, e)?),
            "principled" => Bsdf::Principled(self.principled(&p, e)?),
            "blendbsdf" => Bsdf::Blend(self.blend(&p, e)?),
            "twosided" => {
                match nesting {
                    Nesting::Top => {}
                    Nesting::InTwoSided => return err(&e.loc, "twosided BSDFs cannot be nested"),
                    Nesting::InBlend => {
                        return err(
                            &e.loc,
                            "twosided inside a blendbsdf is not supported (supported: twosided as \
                             the outermost BSDF, e.g. around the blendbsdf)",
                        )
                    }
                }
                let inner = p.objects("bsdf");
                match inner.as_slice() {
                    [(b, _)] => Bsdf::TwoSided(Box::new(self.bsdf_in(b, Nesting::InTwoSided)?)),
                    [] => return err(&e.loc, "twosided needs one nested bsdf"),
                    [_, (_, loc), ..] => {
                        return err(
                            loc,
                            "twosided with different front and back BSDFs is not supported",
                        )
                    }
                }
            }
            _ => {
                return err(
                    &e.loc,
                    format!(
                        "unsupported bsdf type '{ty}' (supported: {BSDFS}){}",
                        replacement(ty)
                    ),
                )
            }
        };
        p.finish()?;
        Ok(b)
    }

    /// A reflectance property (`default` when absent); warns about float/spectrum values
    /// outside [0, 1], which Mitsuba accepts (RGB ones are errors in [`Props::reflectance`]).
    fn reflectance(
        &mut self,
        p: &Props,
        name: &str,
        default: f64,
        loc: &SourceLocation,
    ) -> Result<[f32; 3], SceneError> {
        let c = match p.reflectance(name)? {
            None => DVec3::splat(default),
            Some((c, at)) => {
                if !(c.min_element() >= 0.0 && c.max_element() <= 1.0) {
                    self.warnings.push(format!(
                        "{at}: reflectance '{name}' of {} is outside [0, 1] ({}); Mitsuba accepts \
                         it for float and spectrum values, so it is rendered as given",
                        p.owner, c
                    ));
                }
                c
            }
        };
        rgb_of(c, loc, name)
    }

    fn roughconductor(&mut self, p: &Props, e: &Elem) -> Result<RoughConductor, SceneError> {
        match p.string("distribution")? {
            Some((d, _)) if d.eq_ignore_ascii_case("ggx") => {}
            Some((d, loc)) if d.eq_ignore_ascii_case("beckmann") => {
                return err(
                    &loc,
                    "roughconductor distribution 'beckmann' is not supported (supported: ggx)",
                )
            }
            Some((d, loc)) => {
                return err(
                    &loc,
                    format!(
                        "invalid roughconductor distribution '{d}' (Mitsuba knows beckmann and \
                         ggx; supported: ggx)"
                    ),
                )
            }
            None => {
                return err(
                    &e.loc,
                    "roughconductor without a 'distribution' is Beckmann in Mitsuba, which is not \
                     supported (supported: <string name=\"distribution\" value=\"ggx\"/>)",
                )
            }
        }
        let alpha = match (
            p.float("alpha")?,
            p.float_at("alpha_u")?,
            p.float_at("alpha_v")?,
        ) {
            (a, None, None) => a.unwrap_or(0.1),
            (None, Some((u, _)), Some((v, loc))) => {
                if u as f32 != v as f32 {
                    return err(
                        &loc,
                        format!(
                            "anisotropic roughness (alpha_u = {u} ≠ alpha_v = {v}) is not \
                             supported (supported: isotropic 'alpha', or equal alpha_u and alpha_v)"
                        ),
                    );
                }
                u
            }
            (None, Some((_, loc)), None) | (None, None, Some((_, loc))) => {
                return err(&loc, "both 'alpha_u' and 'alpha_v' must be specified")
            }
            (Some(_), Some((_, loc)), _) | (Some(_), None, Some((_, loc))) => {
                return err(&loc, "give either 'alpha' or 'alpha_u'/'alpha_v', not both")
            }
        };
        if !(alpha > linlight_brdf::microfacet::MIN_ALPHA) {
            self.warnings.push(format!(
                "{}: roughconductor alpha {alpha} is clamped to {} as in Mitsuba (a near-perfect \
                 mirror: light sampling converges very slowly on it)",
                e.loc,
                linlight_brdf::microfacet::MIN_ALPHA
            ));
        }
        if let Some((m, loc)) = p.string("material")? {
            if m != "none" {
                return err(
                    &loc,
                    format!(
                        "named conductor materials are not supported (got material '{m}'; \
                         supported: material 'none', or explicit rgb 'eta' and 'k')"
                    ),
                );
            }
        }
        let eta = p.color("eta")?;
        let k = p.color("k")?;
        let fresnel = if eta.is_none() && k.is_none() {
            // Mitsuba's material "none": η = 0, k = 1, whose conductor Fresnel is exactly 1.
            ConductorFresnel::One
        } else {
            ConductorFresnel::Complex {
                eta: rgb_of(eta.unwrap_or(DVec3::ZERO), &e.loc, "eta")?,
                k: rgb_of(k.unwrap_or(DVec3::ONE), &e.loc, "k")?,
            }
        };
        let specular_reflectance = self.reflectance(p, "specular_reflectance", 1.0, &e.loc)?;
        // Changes only Mitsuba's BSDF sampling, not the function.
        p.boolean("sample_visible")?;
        Ok(RoughConductor {
            alpha: f32_of(alpha, &e.loc, "alpha")?,
            fresnel,
            specular_reflectance,
        })
    }

    fn principled(&mut self, p: &Props, e: &Elem) -> Result<Principled, SceneError> {
        for name in ["sheen", "clearcoat", "spec_trans", "anisotropic"] {
            if let Some((v, loc)) = p.float_at(name)? {
                if v != 0.0 {
                    return err(
                        &loc,
                        format!(
                            "principled '{name}' = {v} is not supported ({PRINCIPLED_SUPPORTED})"
                        ),
                    );
                }
            }
        }
        // Without sheen and clearcoat these do not change the function; the sampling rates only
        // change Mitsuba's BSDF sampling.
        for name in [
            "sheen_tint",
            "clearcoat_gloss",
            "main_specular_sampling_rate",
            "clearcoat_sampling_rate",
            "diffuse_reflectance_sampling_rate",
        ] {
            p.float(name)?;
        }
        let float = |name: &str, default: f64| -> Result<f32, SceneError> {
            f32_of(p.float(name)?.unwrap_or(default), &e.loc, name)
        };
        let eta = match (p.float_at("specular")?, p.float_at("eta")?) {
            (Some(_), Some((_, loc))) => {
                return err(&loc, "give either 'specular' or 'eta', not both")
            }
            (Some((s, loc)), None) => {
                if !(0.0..12.5).contains(&s) {
                    return err(
                        &loc,
                        format!(
                            "principled 'specular' must lie in [0, 12.5) (got {s}; η = 2/(1 − \
                             √(0.08·specular)) − 1 must be finite)"
                        ),
                    );
                }
                Principled::eta_from_specular(s as f32)
            }
            (None, Some((eta, loc))) => {
                if !(eta > 0.0) {
                    return err(
                        &loc,
                        format!("principled 'eta' must be positive (got {eta})"),
                    );
                }
                f32_of(eta, &loc, "eta")?
            }
            (None, None) => Principled::eta_from_specular(0.5),
        };
        Ok(Principled {
            base_color: self.reflectance(p, "base_color", 0.5, &e.loc)?,
            roughness: float("roughness", 0.5)?,
            metallic: float("metallic", 0.0)?,
            eta,
            spec_tint: float("spec_tint", 0.0)?,
            flatness: float("flatness", 0.0)?,
        })
    }

    fn blend(&mut self, p: &Props, e: &Elem) -> Result<Blend, SceneError> {
        let Some((weight, wloc)) = p.float_at("weight")? else {
            return err(
                &e.loc,
                "blendbsdf needs a 'weight' (a float in [0, 1]: 0 selects the first nested \
                 BSDF, 1 the second)",
            );
        };
        if !(0.0..=1.0).contains(&weight) {
            self.warnings.push(format!(
                "{wloc}: blendbsdf weight {weight} is clipped to [0, 1], as Mitsuba does"
            ));
        }
        let children = p.objects("bsdf");
        let [(a, _), (b, _)] = children.as_slice() else {
            let at = children.get(2).map_or(&e.loc, |c| &c.1);
            return err(
                at,
                format!(
                    "blendbsdf needs exactly two nested BSDFs (got {})",
                    children.len()
                ),
            );
        };
        Ok(Blend {
            weight: f32_of(weight, &wloc, "weight")?,
            bsdfs: Box::new([
                self.bsdf_in(a, Nesting::InBlend)?,
                self.bsdf_in(b, Nesting::InBlend)?,
            ]),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{expect_error, load, wrap};
    use linlight_brdf::{Blend, Bsdf, ConductorFresnel, Principled, RoughConductor};

    /// The BSDF of the only shape of a one-line scene body.
    fn bsdf_of(name: &str, bsdf: &str) -> (Bsdf, Vec<String>) {
        let s = load(name, &format!("<shape type=\"rectangle\">{bsdf}</shape>"));
        (s.shapes[0].bsdf.clone(), s.warnings)
    }

    /// Loading a rectangle with `bsdf` fails at the first occurrence of `at` (line 4 of the
    /// wrapped scene) with a message containing `want`.
    fn fails(name: &str, bsdf: &str, at: &str, want: &str) {
        let body = format!("<shape type=\"rectangle\">{bsdf}</shape>");
        let col = body.find(at).unwrap_or_else(|| panic!("{name}: no '{at}'")) + 1;
        expect_error(name, &wrap(&body), &format!("4:{col}"), want);
    }

    const GGX: &str = r#"<string name="distribution" value="ggx"/>"#;

    fn rc(inner: &str) -> String {
        format!(r#"<bsdf type="roughconductor">{GGX}{inner}</bsdf>"#)
    }

    #[test]
    fn roughconductor_defaults_are_mitsubas() {
        let (b, w) = bsdf_of("rc-default", &rc(""));
        let want = RoughConductor {
            alpha: 0.1,
            fresnel: ConductorFresnel::One,
            specular_reflectance: [1.0; 3],
        };
        assert_eq!(b, Bsdf::RoughConductor(want.clone()));
        assert!(w.iter().all(|w| !w.contains("alpha")), "{w:?}");
        let (b, _) = bsdf_of(
            "rc-uv",
            &rc(
                r#"<float name="alpha_u" value="0.3"/><float name="alpha_v" value="0.3"/><string name="material" value="none"/><boolean name="sample_visible" value="false"/>"#,
            ),
        );
        assert_eq!(
            b,
            Bsdf::RoughConductor(RoughConductor {
                alpha: 0.3,
                ..want.clone()
            })
        );
        let (b, _) = bsdf_of(
            "rc-eta",
            &rc(
                r#"<float name="eta" value="2"/><rgb name="specular_reflectance" value="0.1, 0.2, 0.3"/>"#,
            ),
        );
        assert_eq!(
            b,
            Bsdf::RoughConductor(RoughConductor {
                alpha: 0.1,
                fresnel: ConductorFresnel::Complex {
                    eta: [2.0; 3],
                    k: [1.0; 3],
                },
                specular_reflectance: [0.1, 0.2, 0.3],
            })
        );
        // Mitsuba clamps α to 1e-4; loading says so.
        let (_, w) = bsdf_of("rc-alpha0", &rc(r#"<float name="alpha" value="0"/>"#));
        assert!(w.iter().any(|w| w.contains("clamped to 0.0001")), "{w:?}");
    }

    #[test]
    fn principled_blend_and_twosided() {
        let (b, _) = bsdf_of("pr-default", r#"<bsdf type="principled"/>"#);
        assert_eq!(b, Bsdf::Principled(Principled::new()));
        let (b, _) = bsdf_of(
            "pr-full",
            r#"<bsdf type="principled"><rgb name="base_color" value="0.1, 0.2, 0.3"/><float name="roughness" value="0.2"/><float name="metallic" value="0.7"/><float name="specular" value="0.3"/><float name="spec_tint" value="0.5"/><float name="flatness" value="0.25"/><float name="sheen" value="0"/><float name="sheen_tint" value="0.4"/><float name="clearcoat_gloss" value="0.5"/><float name="main_specular_sampling_rate" value="2"/></bsdf>"#,
        );
        assert_eq!(
            b,
            Bsdf::Principled(Principled {
                base_color: [0.1, 0.2, 0.3],
                roughness: 0.2,
                metallic: 0.7,
                eta: Principled::eta_from_specular(0.3),
                spec_tint: 0.5,
                flatness: 0.25,
            })
        );
        let (b, _) = bsdf_of(
            "pr-eta",
            r#"<bsdf type="principled"><float name="eta" value="1.33"/></bsdf>"#,
        );
        assert_eq!(
            b,
            Bsdf::Principled(Principled {
                eta: 1.33,
                ..Principled::new()
            })
        );
        // File order decides which BSDF the weight selects (Mitsuba's, whatever the names).
        let (b, w) = bsdf_of(
            "blend",
            r#"<bsdf type="twosided"><bsdf type="blendbsdf"><float name="weight" value="1.5"/><bsdf type="diffuse" name="z"/><bsdf type="principled" name="a"/></bsdf></bsdf>"#,
        );
        assert_eq!(
            b,
            Bsdf::TwoSided(Box::new(Bsdf::Blend(Blend {
                weight: 1.5,
                bsdfs: Box::new([
                    Bsdf::Diffuse {
                        reflectance: [0.5; 3]
                    },
                    Bsdf::Principled(Principled::new())
                ]),
            })))
        );
        assert!(w.iter().any(|w| w.contains("clipped to [0, 1]")), "{w:?}");
        // Float reflectances outside [0, 1] load (Mitsuba accepts them) with a warning.
        let (b, w) = bsdf_of(
            "diffuse-float",
            r#"<bsdf type="diffuse"><float name="reflectance" value="1.5"/></bsdf>"#,
        );
        assert_eq!(
            b,
            Bsdf::Diffuse {
                reflectance: [1.5; 3]
            }
        );
        assert!(w.iter().any(|w| w.contains("outside [0, 1]")), "{w:?}");
    }

    #[test]
    fn unsupported_bsdfs_are_errors_at_their_place() {
        let tex = r#"<texture type="bitmap" name="alpha"/>"#;
        let cases: Vec<(&str, String, &str, &str)> = vec![
            (
                "no-distribution",
                r#"<bsdf type="roughconductor"/>"#.into(),
                "<bsdf",
                "roughconductor without a 'distribution' is Beckmann in Mitsuba, which is not supported (supported: <string name=\"distribution\" value=\"ggx\"/>)",
            ),
            (
                "beckmann",
                r#"<bsdf type="roughconductor"><string name="distribution" value="beckmann"/></bsdf>"#.into(),
                "<string",
                "distribution 'beckmann' is not supported (supported: ggx)",
            ),
            (
                "phong",
                r#"<bsdf type="roughconductor"><string name="distribution" value="phong"/></bsdf>"#.into(),
                "<string",
                "invalid roughconductor distribution 'phong'",
            ),
            (
                "anisotropic",
                rc(r#"<float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.3"/>"#),
                "<float name=\"alpha_v\"",
                "anisotropic roughness (alpha_u = 0.1 ≠ alpha_v = 0.3) is not supported (supported: isotropic 'alpha'",
            ),
            (
                "alpha-u-only",
                rc(r#"<float name="alpha_u" value="0.1"/>"#),
                "<float",
                "both 'alpha_u' and 'alpha_v' must be specified",
            ),
            (
                "alpha-and-uv",
                rc(r#"<float name="alpha" value="0.1"/><float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.1"/>"#),
                "<float name=\"alpha_u\"",
                "either 'alpha' or 'alpha_u'/'alpha_v'",
            ),
            (
                "gold",
                rc(r#"<string name="material" value="Au"/>"#),
                "<string name=\"material\"",
                "named conductor materials are not supported (got material 'Au'; supported: material 'none', or explicit rgb 'eta' and 'k')",
            ),
            (
                "alpha-texture",
                rc(tex),
                "<texture",
                "property 'alpha' of bsdf 'roughconductor' must be a float (got texture 'bitmap')",
            ),
            (
                "eta-texture",
                rc(r#"<texture type="bitmap" name="eta"/>"#),
                "<texture",
                "unsupported texture type 'bitmap' for 'eta'",
            ),
            (
                "specular-reflectance-rgb",
                rc(r#"<rgb name="specular_reflectance" value="1.5, 1, 1"/>"#),
                "<rgb",
                "RGB reflectance 'specular_reflectance' of bsdf 'roughconductor' must lie in [0, 1]",
            ),
            (
                "unknown-property",
                rc(r#"<float name="alpha_x" value="0.1"/>"#),
                "<float",
                "unsupported property 'alpha_x' (float) on bsdf 'roughconductor'",
            ),
            (
                "diffuse-negative-rgb",
                r#"<bsdf type="diffuse"><rgb name="reflectance" value="-0.1, 0.5, 0.5"/></bsdf>"#.into(),
                "<rgb",
                "RGB reflectance 'reflectance' of bsdf 'diffuse' must lie in [0, 1]",
            ),
            (
                "base-color-rgb",
                r#"<bsdf type="principled"><rgb name="base_color" value="1.2, 0.5, 0.5"/></bsdf>"#.into(),
                "<rgb",
                "RGB reflectance 'base_color' of bsdf 'principled' must lie in [0, 1]",
            ),
            (
                "sheen",
                r#"<bsdf type="principled"><float name="sheen" value="0.5"/></bsdf>"#.into(),
                "<float",
                "principled 'sheen' = 0.5 is not supported (supported: base_color, roughness, metallic, specular or eta, spec_tint, flatness; sheen, clearcoat, spec_trans and anisotropic must be 0)",
            ),
            (
                "clearcoat",
                r#"<bsdf type="principled"><float name="clearcoat" value="1"/></bsdf>"#.into(),
                "<float",
                "principled 'clearcoat' = 1 is not supported",
            ),
            (
                "spec-trans",
                r#"<bsdf type="principled"><float name="spec_trans" value="0.3"/></bsdf>"#.into(),
                "<float",
                "principled 'spec_trans' = 0.3 is not supported",
            ),
            (
                "principled-anisotropic",
                r#"<bsdf type="principled"><float name="anisotropic" value="0.5"/></bsdf>"#.into(),
                "<float",
                "principled 'anisotropic' = 0.5 is not supported",
            ),
            (
                "specular-and-eta",
                r#"<bsdf type="principled"><float name="specular" value="0.5"/><float name="eta" value="1.5"/></bsdf>"#.into(),
                "<float name=\"eta\"",
                "give either 'specular' or 'eta', not both",
            ),
            (
                "negative-specular",
                r#"<bsdf type="principled"><float name="specular" value="-1"/></bsdf>"#.into(),
                "<float",
                "principled 'specular' must lie in [0, 12.5)",
            ),
            (
                "zero-eta",
                r#"<bsdf type="principled"><float name="eta" value="0"/></bsdf>"#.into(),
                "<float",
                "principled 'eta' must be positive",
            ),
            (
                "roughness-texture",
                r#"<bsdf type="principled"><texture type="bitmap" name="roughness"/></bsdf>"#.into(),
                "<texture",
                "property 'roughness' of bsdf 'principled' must be a float (got texture 'bitmap')",
            ),
            (
                "blend-no-weight",
                r#"<bsdf type="blendbsdf"><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf>"#.into(),
                "<bsdf",
                "blendbsdf needs a 'weight'",
            ),
            (
                "blend-one-child",
                r#"<bsdf type="blendbsdf"><float name="weight" value="0.5"/><bsdf type="diffuse"/></bsdf>"#.into(),
                "<bsdf",
                "blendbsdf needs exactly two nested BSDFs (got 1)",
            ),
            (
                "blend-three-children",
                r#"<bsdf type="blendbsdf"><float name="weight" value="0.5"/><bsdf type="diffuse"/><bsdf type="diffuse"/><bsdf type="principled"/></bsdf>"#.into(),
                "<bsdf type=\"principled\"",
                "blendbsdf needs exactly two nested BSDFs (got 3)",
            ),
            (
                "twosided-in-blend",
                r#"<bsdf type="blendbsdf"><float name="weight" value="0.5"/><bsdf type="twosided"><bsdf type="diffuse"/></bsdf><bsdf type="diffuse"/></bsdf>"#.into(),
                "<bsdf type=\"twosided\"",
                "twosided inside a blendbsdf is not supported (supported: twosided as the outermost BSDF",
            ),
            (
                "unsupported-in-blend",
                r#"<bsdf type="blendbsdf"><float name="weight" value="0.5"/><bsdf type="diffuse"/><bsdf type="plastic"/></bsdf>"#.into(),
                "<bsdf type=\"plastic\"",
                "unsupported bsdf type 'plastic'",
            ),
        ];
        for (name, bsdf, at, want) in &cases {
            fails(&format!("bsdf-{name}"), bsdf, at, want);
        }
    }
}
