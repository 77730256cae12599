//! Combining independent mean + variance images of one scene into one (`linlight merge`,
//! `linlight render --time`), so that several runs or machines reach a reference's precision.
//!
//! Every image of the shared format is the mean of n independent *units* with the variance of
//! that mean estimated from their spread (dof = n − 1): the P pass means of a render with P > 1
//! passes (units of spp/P samples), or the spp samples of a single-pass render (units of one
//! sample). When all inputs have units of the same size, the merged image is exactly the image
//! of the union of their units: with N = Σ nᵢ,
//!
//!   mean = Σ nᵢ·mᵢ / N,   SS = Σ [(nᵢ − 1)·nᵢ·vᵢ + nᵢ·(mᵢ − mean)²],   v = SS / ((N − 1)·N),
//!   dof = N − 1,
//!
//! since nᵢ·vᵢ is the sample variance of image i's units. The between-image term makes the
//! variance honest when the inputs disagree more than their own variances say.
//!
//! Otherwise (units of different sizes, or headers that do not say how many units an image
//! has), the images are weighted by their sample counts, wᵢ = sppᵢ / Σ spp (unbiased whatever
//! the variances; inverse-variance weights would correlate with the noise and bias the mean):
//! mean = Σ wᵢ·mᵢ, v = Σ wᵢ²·vᵢ, and dof is the smallest Welch–Satterthwaite
//! ν = v² / Σ (wᵢ²·vᵢ)²/νᵢ over the pixel channels with v > 0 (conservative: one number
//! for the whole image, as the format has).
//!
//! Images that cannot be combined are refused: different sizes, scenes (`scene_sha256`),
//! renderers, methods (technique, MIS heuristic and v, light samples and selection), overrides, Mitsuba
//! variants, radii or K; and images that are not
//! independent (the same seed, or identical pixels).

use linlight_imagefile::{Image, Metadata};
use std::collections::BTreeMap;

/// Header keys that must agree between merged images (when any image has them).
pub const MUST_AGREE: [&str; 9] = [
    "technique",
    "mis",
    "mis_v",
    "light_samples",
    "light_selection",
    "overrides",
    "variant",
    "radius",
    "K",
];

/// Header keys that identify a random stream: equal values mean the images are not independent.
const SEED_KEYS: [&str; 2] = ["seed", "seeds"];

/// Units of an image: (count n, samples per unit), when the header says so consistently.
pub fn units(img: &Image) -> Option<(u64, f64)> {
    let m = &img.meta;
    if m.passes > 1 && m.dof == (m.passes - 1) as f64 && m.spp >= m.passes {
        Some((m.passes, m.spp as f64 / m.passes as f64))
    } else if m.passes <= 1 && m.spp >= 1 && m.dof == (m.spp - 1) as f64 {
        Some((m.spp, 1.0))
    } else {
        None
    }
}

/// Refuses images that cannot be merged; `names` label them in messages.
pub fn check_compatible(images: &[&Image], names: &[String]) -> Result<(), String> {
    if images.len() < 2 {
        return Err("merging needs at least two images".into());
    }
    let (a, an) = (images[0], &names[0]);
    for (b, bn) in images.iter().zip(names).skip(1) {
        if (a.width, a.height) != (b.width, b.height) {
            return Err(format!(
                "{an} is {}×{} but {bn} is {}×{}",
                a.width, a.height, b.width, b.height
            ));
        }
        let differ = |what: &str, x: &str, y: &str| {
            Err(format!(
                "{an} and {bn} have different {what} ('{x}' and '{y}'): they are not images of \
                 the same quantity"
            ))
        };
        if a.meta.scene_sha256 != b.meta.scene_sha256 {
            return differ(
                "scenes (scene_sha256)",
                &a.meta.scene_sha256,
                &b.meta.scene_sha256,
            );
        }
        if a.meta.renderer != b.meta.renderer {
            return differ("renderers", &a.meta.renderer, &b.meta.renderer);
        }
        for key in MUST_AGREE {
            let (x, y) = (a.meta.extra.get(key), b.meta.extra.get(key));
            if x != y {
                return differ(
                    key,
                    x.map_or("(none)", String::as_str),
                    y.map_or("(none)", String::as_str),
                );
            }
        }
    }
    for (i, a) in images.iter().enumerate() {
        for (j, b) in images.iter().enumerate().skip(i + 1) {
            for key in SEED_KEYS {
                if let (Some(x), Some(y)) = (a.meta.extra.get(key), b.meta.extra.get(key)) {
                    if x == y {
                        return Err(format!(
                            "{} and {} were rendered with the same {key} ({x}): they are the \
                             same random numbers, not independent estimates (render again with \
                             another --seed)",
                            names[i], names[j]
                        ));
                    }
                }
            }
            if a.mean == b.mean && a.var == b.var {
                return Err(format!(
                    "{} and {} have identical pixels: they are not independent estimates",
                    names[i], names[j]
                ));
            }
        }
    }
    Ok(())
}

/// The merged header: sums of spp and passes, agreeing extras kept, seeds listed, wall times
/// summed, anything else that differs dropped.
fn merged_meta(images: &[&Image], dof: f64, passes: u64) -> Metadata {
    let first = &images[0].meta;
    let mut extra = BTreeMap::new();
    for (k, v) in &first.extra {
        let values: Vec<Option<&String>> = images.iter().map(|i| i.meta.extra.get(k)).collect();
        if values.iter().all(|x| *x == Some(v)) {
            extra.insert(k.clone(), v.clone());
        } else if SEED_KEYS.contains(&k.as_str()) {
            let list: Vec<&str> = values
                .iter()
                .map(|x| x.map_or("?", |s| s.as_str()))
                .collect();
            extra.insert(k.clone(), list.join(";"));
        } else if k == "wall_time_s" || k == "nonfinite_dropped" {
            let sum: f64 = values
                .iter()
                .filter_map(|x| x.and_then(|s| s.parse::<f64>().ok()))
                .sum();
            extra.insert(k.clone(), sum.to_string());
        }
    }
    if images.iter().any(|i| i.meta.passes <= 1) {
        // Single-pass inputs: their spp_per_pass is not the size of the merged units.
        extra.remove("spp_per_pass");
    }
    extra.insert("merged_images".into(), images.len().to_string());
    Metadata {
        dof,
        spp: images.iter().map(|i| i.meta.spp).sum(),
        passes,
        renderer: first.renderer.clone(),
        scene_sha256: first.scene_sha256.clone(),
        extra,
    }
}

/// Merges compatible independent images (call [`check_compatible`] first for the user-facing
/// checks; this only needs equal sizes).
pub fn merge(images: &[&Image]) -> Result<Image, String> {
    let Some(first) = images.first() else {
        return Err("no image to merge".into());
    };
    if images
        .iter()
        .any(|i| (i.width, i.height) != (first.width, first.height))
    {
        return Err("images of different sizes cannot be merged".into());
    }
    let u: Option<Vec<(u64, f64)>> = images.iter().map(|i| units(i)).collect();
    let same_units = u.as_ref().filter(|u| {
        let s = u[0].1;
        u.iter().all(|&(_, x)| (x - s).abs() <= 1e-9 * s)
    });
    match same_units {
        Some(u) => Ok(merge_units(images, u)),
        None => merge_by_spp(images),
    }
}

/// Images whose units (passes, or samples of single-pass images) hold the same spp: the
/// pooled mean and the variance of the mean over all `Σ n` units (dof Σ n − 1).
fn merge_units(images: &[&Image], u: &[(u64, f64)]) -> Image {
    let mut out = Image::new(images[0].width, images[0].height);
    let n: Vec<f64> = u.iter().map(|&(n, _)| n as f64).collect();
    let total: f64 = n.iter().sum();
    for p in 0..out.mean.len() {
        for c in 0..3 {
            let mean = images
                .iter()
                .zip(&n)
                .map(|(i, ni)| ni * i.mean[p][c] as f64)
                .sum::<f64>()
                / total;
            let ss: f64 = images
                .iter()
                .zip(&n)
                .map(|(i, ni)| {
                    let d = i.mean[p][c] as f64 - mean;
                    (ni - 1.0) * ni * i.var[p][c] as f64 + ni * d * d
                })
                .sum();
            out.mean[p][c] = mean as f32;
            out.var[p][c] = if total > 1.0 {
                (ss / ((total - 1.0) * total)) as f32
            } else {
                0.0
            };
        }
    }
    let unit_spp = u[0].1;
    let passes = if unit_spp == 1.0 && images.iter().all(|i| i.meta.passes <= 1) {
        1
    } else {
        total as u64
    };
    out.meta = merged_meta(images, total - 1.0, passes);
    out
}

/// Images of different unit sizes: the means weighted by spp, the variance of that weighted
/// mean, and its dof by Welch–Satterthwaite (the smallest over pixels and channels).
fn merge_by_spp(images: &[&Image]) -> Result<Image, String> {
    if let Some(i) = images.iter().find(|i| !(i.meta.dof > 0.0)) {
        return Err(format!(
            "an image with dof {} has no variance estimate to merge",
            i.meta.dof
        ));
    }
    let spp_total: f64 = images.iter().map(|i| i.meta.spp as f64).sum();
    if !(spp_total > 0.0) {
        return Err("the images do not record their spp".into());
    }
    let w: Vec<f64> = images
        .iter()
        .map(|i| i.meta.spp as f64 / spp_total)
        .collect();
    let mut out = Image::new(images[0].width, images[0].height);
    let mut dof = f64::INFINITY;
    for p in 0..out.mean.len() {
        for c in 0..3 {
            let mut mean = 0.0;
            let mut var = 0.0;
            let mut ws = 0.0;
            for (i, wi) in images.iter().zip(&w) {
                let t = wi * wi * i.var[p][c] as f64;
                mean += wi * i.mean[p][c] as f64;
                var += t;
                ws += t * t / i.meta.dof;
            }
            out.mean[p][c] = mean as f32;
            out.var[p][c] = var as f32;
            if var > 0.0 && ws > 0.0 {
                dof = dof.min(var * var / ws);
            }
        }
    }
    if !dof.is_finite() {
        dof = images.iter().map(|i| i.meta.dof).sum();
    }
    let passes = images.iter().map(|i| i.meta.passes.max(1)).sum();
    out.meta = merged_meta(images, dof, passes);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use linlight_sampling::rng::Pcg32;

    /// `n` single-sample values per pixel → a single-pass image of n samples, or the pass means
    /// of `passes` groups.
    fn image_of(samples: &[Vec<f64>], passes: usize, seed: &str) -> Image {
        let mut img = Image::new(samples.len(), 1);
        for (p, s) in samples.iter().enumerate() {
            let groups: Vec<f64> = if passes > 1 {
                s.chunks(s.len() / passes)
                    .map(|g| g.iter().sum::<f64>() / g.len() as f64)
                    .collect()
            } else {
                s.clone()
            };
            let k = groups.len() as f64;
            let m = groups.iter().sum::<f64>() / k;
            let var = groups.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (k - 1.0) / k;
            img.mean[p] = [m as f32; 3];
            img.var[p] = [var as f32; 3];
        }
        img.meta.spp = samples[0].len() as u64;
        img.meta.passes = passes as u64;
        img.meta.dof = if passes > 1 {
            passes as f64 - 1.0
        } else {
            samples[0].len() as f64 - 1.0
        };
        img.meta.extra.insert("seed".into(), seed.into());
        img
    }

    fn draws(seed: u64, pixels: usize, n: usize) -> Vec<Vec<f64>> {
        let mut rng = Pcg32::new(seed, 1);
        (0..pixels)
            .map(|p| (0..n).map(|_| rng.next_f64() * (1.0 + p as f64)).collect())
            .collect()
    }

    fn close(a: f32, b: f32) -> bool {
        (a - b).abs() <= 2e-5 * b.abs().max(1e-12)
    }

    /// Merging equals rendering the union: pass means of equal-size passes, or samples.
    #[test]
    fn equal_units_merge_to_the_union() {
        // (passes of a, passes of b): single-pass images of 64 and 128 samples, or passes of
        // 16 samples each (4 and 8 of them).
        for (pa, pb) in [(1usize, 1usize), (4, 8)] {
            let (a, b) = (draws(1, 3, 64), draws(2, 3, 128));
            let union: Vec<Vec<f64>> = a
                .iter()
                .zip(&b)
                .map(|(x, y)| [&x[..], &y[..]].concat())
                .collect();
            let (ia, ib) = (image_of(&a, pa, "1"), image_of(&b, pb, "2"));
            let want = image_of(&union, if pa == 1 { 1 } else { pa + pb }, "x");
            check_compatible(&[&ia, &ib], &["a".into(), "b".into()]).unwrap();
            let m = merge(&[&ia, &ib]).unwrap();
            assert_eq!(m.meta.dof, want.meta.dof, "passes {pa}");
            assert_eq!((m.meta.spp, m.meta.passes), (192, want.meta.passes));
            for p in 0..3 {
                assert!(
                    close(m.mean[p][0], want.mean[p][0]),
                    "{pa}: {:?} {:?}",
                    m.mean[p],
                    want.mean[p]
                );
                assert!(
                    close(m.var[p][0], want.var[p][0]),
                    "{pa}: {:?} {:?}",
                    m.var[p],
                    want.var[p]
                );
            }
            assert_eq!(m.meta.extra["seed"], "1;2");
        }
    }

    #[test]
    fn unequal_units_weight_by_samples() {
        let ia = image_of(&draws(1, 2, 64), 4, "1"); // units of 16
        let ib = image_of(&draws(2, 2, 64), 1, "2"); // units of 1
        let m = merge(&[&ia, &ib]).unwrap();
        for p in 0..2 {
            let want = 0.5 * (ia.mean[p][0] + ib.mean[p][0]);
            assert!(close(m.mean[p][0], want));
            assert!(close(m.var[p][0], 0.25 * (ia.var[p][0] + ib.var[p][0])));
        }
        // Welch–Satterthwaite lies between the smallest dof and the sum.
        assert!(m.meta.dof >= 3.0 && m.meta.dof <= 66.0, "{}", m.meta.dof);
    }

    #[test]
    fn incompatible_images_are_refused() {
        let a = image_of(&draws(1, 2, 8), 1, "1");
        let names = ["a".to_string(), "b".to_string()];
        let same_seed = image_of(&draws(2, 2, 8), 1, "1");
        assert!(check_compatible(&[&a, &same_seed], &names)
            .unwrap_err()
            .contains("same seed"));
        let mut other = image_of(&draws(3, 2, 8), 1, "3");
        other.meta.extra.insert("technique".into(), "area".into());
        assert!(check_compatible(&[&a, &other], &names)
            .unwrap_err()
            .contains("technique"));
        let mut copy = a.clone();
        copy.meta.extra.insert("seed".into(), "9".into());
        assert!(check_compatible(&[&a, &copy], &names)
            .unwrap_err()
            .contains("identical pixels"));
        let small = image_of(&draws(4, 1, 8), 1, "4");
        assert!(check_compatible(&[&a, &small], &names).is_err());
        assert!(check_compatible(&[&a], &names[..1]).is_err());
    }
}
