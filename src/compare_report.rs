//! The text around a comparison that `linlight compare` prints and writes into its JSON report
//! (notes on the inputs, the sample advice of an inconclusive verdict), shared by the command
//! and the Python package so that both report the same.

use linlight_imagefile::Image;
use linlight_verify::image_stats::{Comparison, PrecisionHint};

/// The JSON report of `linlight compare --json`: the comparison with its `notes` and, when
/// equivalence was not shown, its `precision_advice`.
pub fn report_json(cmp: &Comparison, a: &Image, b: &Image) -> Result<serde_json::Value, String> {
    let mut value =
        serde_json::to_value(cmp).map_err(|e| format!("cannot serialise the report: {e}"))?;
    if let Some(o) = value.as_object_mut() {
        let notes = notes(a, b, cmp.verdict.exit_code() == 1);
        o.insert("notes".into(), serde_json::json!(notes));
        if let Some(h) = &cmp.precision {
            o.insert(
                "precision_advice".into(),
                serde_json::json!(precision_advice(h, a, b)),
            );
        }
    }
    Ok(value)
}

/// "12.3 s", "4.5 min" or "2.1 h".
pub fn duration(seconds: f64) -> String {
    if seconds < 120.0 {
        format!("{seconds:.1} s")
    } else if seconds < 7200.0 {
        format!("{:.1} min", seconds / 60.0)
    } else {
        format!("{:.1} h", seconds / 3600.0)
    }
}

/// What the reader of a verdict must know about the inputs: checks skipped for want of a
/// header (images written by other tools), and where thin tubes may explain a difference.
pub fn notes(a: &Image, b: &Image, different: bool) -> Vec<String> {
    let mut out = Vec::new();
    for (name, img) in [("A", a), ("B", b)] {
        if img.meta.scene_sha256.is_empty() {
            out.push(format!(
                "{name} has no scene hash (scene_sha256): the same-scene check was skipped"
            ));
        }
        if img.meta.spp == 0 {
            out.push(format!(
                "{name} does not record its samples per pixel (spp): sample hints for {name} \
                 are given as factors only"
            ));
        }
    }
    if different {
        out.extend(thin_tube_notes(a, b));
    }
    out
}

/// More samples than this factor of an image's own count are not advice but a sign that the
/// other image limits the precision.
const MAX_HELPFUL_FACTOR: f64 = 16.0;

/// Seconds one sample per pixel of `img` took, from its header (`wall_time_s` / `spp`, which
/// the Mitsuba harness records; linlight's own images carry no times, so that their bytes
/// depend on their inputs only).
fn seconds_per_spp(img: &Image) -> Option<f64> {
    let s: f64 = img.meta.extra.get("wall_time_s")?.parse().ok()?;
    (img.meta.spp > 0 && s > 0.0).then(|| s / img.meta.spp as f64)
}

/// "≈ 4096 spp per pixel (4.0× its 1024; ≈ 3.2 min at its measured rate)" for `factor` more
/// samples of `img`, as much as the header allows.
fn samples_text(img: &Image, factor: f64) -> String {
    let f = factor.max(1.0);
    if img.meta.spp == 0 {
        return format!("≈ {f:.1}× its samples (its spp is not recorded)");
    }
    let spp = (img.meta.spp as f64 * f).ceil();
    let time = seconds_per_spp(img).map_or_else(String::new, |t| {
        format!("; ≈ {} at its measured rate", duration(t * spp))
    });
    format!(
        "≈ {spp:.0} spp per pixel ({f:.1}× its {}{time})",
        img.meta.spp
    )
}

/// The sample advice of an inconclusive comparison, capped at what can help: when the
/// reference B holds the larger share of the variance and A alone would need more than
/// MAX_HELPFUL_FACTOR× its samples (or cannot reach the precision at all), more samples of A
/// alone cannot decide and the advice is about the reference.
pub fn precision_advice(h: &PrecisionHint, a: &Image, b: &Image) -> String {
    let a_limits = h.limiting == "A";
    let a_helps = h.factor_a.filter(|&f| a_limits || f <= MAX_HELPFUL_FACTOR);
    let share = |of_a: bool| 100.0 * if of_a { h.share_a } else { 1.0 - h.share_a };
    if let Some(f) = a_helps {
        return format!(
            "{} ({:.0}% of the variance of channel {} comes from A): render A with {}",
            if a_limits {
                "A limits the precision"
            } else {
                "A can decide it"
            },
            share(true),
            h.channel,
            samples_text(a, f)
        );
    }
    let reference = match h.factor_b {
        Some(f) => format!("the reference alone would need {}", samples_text(b, f)),
        None => format!(
            "both need more: A {}, the reference {}",
            samples_text(a, h.factor_both),
            samples_text(b, h.factor_both)
        ),
    };
    let why = if a_limits {
        "the reference's own variance is already too large".to_string()
    } else {
        format!(
            "the reference limits the precision ({:.0}% of the variance of channel {} comes from \
             it)",
            share(false),
            h.channel
        )
    };
    format!("{why}: more samples of A alone cannot decide; {reference}")
}

/// The thin tubes of the images' header (`finite_radius_effect`, the first image that has
/// one): the one light with its R and the expected size of the finite-R effect, or, for several,
/// their count and the largest (printed when a comparison fails).
fn thin_tube_notes(a: &Image, b: &Image) -> Vec<String> {
    let Some(lights) = [a, b]
        .iter()
        .find_map(|i| i.meta.extra.get("finite_radius_effect"))
    else {
        return Vec::new();
    };
    let lights: Vec<&str> = lights.split(';').filter(|s| !s.is_empty()).collect();
    // The largest "up to X % per pixel" (an entry without one counts as 0; the first wins ties).
    let size = |s: &str| -> f64 {
        s.split_once("up to ")
            .and_then(|(_, rest)| rest.split_whitespace().next())
            .and_then(|x| x.parse().ok())
            .unwrap_or(0.0)
    };
    let Some(worst) = lights
        .iter()
        .copied()
        .reduce(|w, s| if size(s) > size(w) { s } else { w })
    else {
        return Vec::new();
    };
    let which = if lights.len() == 1 {
        worst.to_string()
    } else {
        format!("{} lights, the largest effect {worst}", lights.len())
    };
    vec![format!(
        "a difference where tubes are thin may be Mitsuba's finite radius, which linlight \
         renders in the limit R → 0: {which} (docs/oracle.md)"
    )]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(spp: u64, seconds: Option<f64>) -> Image {
        let mut i = Image::new(1, 1);
        i.meta.spp = spp;
        if let Some(s) = seconds {
            i.meta.extra.insert("wall_time_s".into(), s.to_string());
        }
        i
    }

    fn hint(
        limiting: &'static str,
        share_a: f64,
        fa: Option<f64>,
        fb: Option<f64>,
    ) -> PrecisionHint {
        PrecisionHint {
            channel: "R",
            limiting,
            share_a,
            factor_a: fa,
            factor_b: fb,
            factor_both: 2.0,
            spp_a: None,
            spp_b: None,
            text: String::new(),
        }
    }

    /// The absurd hint of a reference-limited comparison ("≈ 11442.7× the samples of A
    /// alone") becomes advice about the reference, in spp per pixel and minutes.
    #[test]
    fn advice_is_capped_at_what_helps() {
        let (a, b) = (image(1024, Some(60.0)), image(8192, None));
        let t = precision_advice(&hint("B", 0.1, Some(11442.7), Some(3.0)), &a, &b);
        assert!(t.contains("more samples of A alone cannot decide"), "{t}");
        assert!(
            t.contains("the reference alone would need ≈ 24576 spp per pixel (3.0× its 8192)"),
            "{t}"
        );
        assert!(!t.contains("11442"), "{t}");
        assert!(
            t.starts_with("the reference limits the precision (90% of the variance"),
            "{t}"
        );
        let t = precision_advice(&hint("A", 0.9, Some(4.0), None), &a, &b);
        assert_eq!(
            t,
            "A limits the precision (90% of the variance of channel R comes from A): render A \
             with ≈ 4096 spp per pixel (4.0× its 1024; ≈ 4.0 min at its measured rate)"
        );
        // When A limits, its factor is the advice however large.
        let t = precision_advice(&hint("A", 0.9, Some(240.0), None), &a, &b);
        assert!(t.contains("render A with ≈ 245760 spp per pixel"), "{t}");
        let t = precision_advice(&hint("B", 0.4, Some(40.0), None), &a, &image(0, None));
        assert!(t.contains("A alone cannot decide; both need more"), "{t}");
        assert!(t.contains("its spp is not recorded"), "{t}");
    }

    #[test]
    fn header_less_images_are_noted() {
        let (a, mut b) = (image(0, None), image(8, None));
        b.meta.scene_sha256 = "ab".into();
        let n = notes(&a, &b, false);
        assert_eq!(
            n,
            [
                "A has no scene hash (scene_sha256): the same-scene check was skipped",
                "A does not record its samples per pixel (spp): sample hints for A are given as \
                 factors only"
            ]
        );
        // A failed comparison names each thin tube of the header with its expected effect.
        b.meta.extra.insert(
            "finite_radius_effect".into(),
            "light at s.xml:3:1 (R = 0.001): up to 3.5% per pixel".into(),
        );
        let n = notes(&a, &b, true);
        assert!(
            n[2].contains("light at s.xml:3:1 (R = 0.001): up to 3.5% per pixel"),
            "{n:?}"
        );
        assert_eq!(notes(&a, &b, false).len(), 2);
        // Several thin tubes are one note: their count and the largest effect.
        b.meta.extra.insert(
            "finite_radius_effect".into(),
            "light at s.xml:3:1 (R = 0.001): up to 0.13 % per pixel;light at s.xml:4:1 (R = \
             0.001): up to 2.50 % per pixel (Mitsuba darker);light at s.xml:5:1 (R = 0.001): up \
             to 0.90 % per pixel;"
                .into(),
        );
        let n = notes(&a, &b, true);
        assert_eq!(n.len(), 3, "{n:?}");
        assert!(
            n[2].ends_with(
                "R → 0: 3 lights, the largest effect light at s.xml:4:1 (R = 0.001): up to \
                 2.50 % per pixel (Mitsuba darker) (docs/oracle.md)"
            ),
            "{n:?}"
        );
    }
}
