//! Rendering at a per-tile budget ([`super::budget::BudgetRule::plan`]): every cell of [`CELL`]²
//! pixels rendered once, as a crop window at its count (the budget's spp, or more where its
//! pixels need more), and pasted into an image whose header is the window's.
//!
//! The random stream of a pixel sample depends only on (seed, pass, full-film pixel index,
//! sample index), not on the spp or the window (`linlight_render::render`), so with white noise
//! a pasted pixel *is* the pixel of a full render at its count: its first samples are those of
//! the base render, and nothing of the base pixel is mixed in. (A blue-noise render's mask
//! depends on its spp; its pasted pixels are then an independent render of those pixels, which
//! is just as unbiased.) The image records the samples of every pixel ([`Image::pixel_spp`]);
//! its header keeps the base spp and dof, the smallest.

use linlight_imagefile::Image;
use linlight_render::scene::{CropWindow, Scene};
use linlight_render::{RenderError, RenderOptions};
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Side of the square cells rendered again. The comparison's tiles (16×16, and the grid
/// shifted by 8) are unions of 8×8 cells, so the budget's counts are constant on a cell.
pub const CELL: usize = 8;

/// How a subject renders windows of the scene: `render(crop, opts, progress)` renders the
/// scene's film cropped to `crop` (full-film pixels) with `opts`, as
/// [`linlight_render::Prepared::render`].
pub type RenderFn<'a> = dyn Fn(
        Option<CropWindow>,
        &RenderOptions,
        &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Image, RenderError>
    + Sync
    + 'a;

/// One crop to render again: a run of cells of one cell row that all need `spp`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Strip {
    x: usize,
    y: usize,
    width: usize,
    height: usize,
    spp: u32,
}

/// The strips of cells whose largest count exceeds `base`, in row-major order.
fn strips(pixel_spp: &[u32], width: usize, height: usize, base: u32) -> Vec<Strip> {
    all_strips(pixel_spp, width, height)
        .into_iter()
        .filter(|s| s.spp > base)
        .collect()
}

/// Every cell in a strip: runs of cells of one cell row with the same largest count, in
/// row-major order.
fn all_strips(pixel_spp: &[u32], width: usize, height: usize) -> Vec<Strip> {
    let mut out: Vec<Strip> = Vec::new();
    for cy in (0..height).step_by(CELL) {
        let ch = CELL.min(height - cy);
        let mut run: Option<Strip> = None;
        for cx in (0..width).step_by(CELL) {
            let cw = CELL.min(width - cx);
            let n = (cy..cy + ch)
                .flat_map(|y| pixel_spp[y * width + cx..y * width + cx + cw].iter())
                .copied()
                .max()
                .unwrap_or(0);
            match &mut run {
                Some(r) if r.spp == n && r.x + r.width == cx => r.width += cw,
                _ => {
                    out.extend(run.take());
                    run = Some(Strip {
                        x: cx,
                        y: cy,
                        width: cw,
                        height: ch,
                        spp: n,
                    });
                }
            }
        }
        out.extend(run);
    }
    out
}

/// The crop window of the strip `s` (window coordinates of `scene`'s own window).
fn crop_window(scene: &Scene, s: &Strip) -> CropWindow {
    let (x0, y0) = scene
        .sensor
        .film
        .crop
        .map_or((0, 0), |c| (c.offset_x, c.offset_y));
    CropWindow {
        offset_x: x0 + s.x as u32,
        offset_y: y0 + s.y as u32,
        width: s.width as u32,
        height: s.height as u32,
    }
}

/// Render `scene` with `render` at `opts.spp` (one pass), then the cells whose pixels need more of
/// `pixel_spp` (row-major over the scene's window; None: nothing more) at that count.
/// `progress(done, total)` counts camera samples of all of it.
pub fn render(
    render: &RenderFn,
    scene: &Scene,
    opts: &RenderOptions,
    pixel_spp: Option<&[u32]>,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Image, RenderError> {
    let Some(plan) = pixel_spp else {
        return render(scene.sensor.film.crop, opts, progress);
    };
    let film = &scene.sensor.film;
    let (w, h) = film
        .crop
        .map_or((film.width, film.height), |c| (c.width, c.height));
    let (w, h) = (w as usize, h as usize);
    if plan.len() != w * h {
        return Err(RenderError::Options(format!(
            "per-pixel budget of {} pixels for a {w}×{h} window",
            plan.len()
        )));
    }
    let base_spp = opts.spp;
    // Every cell at its count (at least the base): a pixel's samples are rendered once, in
    // the strip of its cell (rendering the whole window at the base first would render the
    // base samples of the cells rendered again a second time).
    let cells: Vec<Strip> = all_strips(plan, w, h)
        .into_iter()
        .map(|s| Strip {
            spp: s.spp.max(base_spp),
            ..s
        })
        .collect();
    if !cells.iter().any(|s| s.spp == base_spp) {
        return render_over_base(render, scene, opts, plan, (w, h), progress);
    }
    let unit = |spp: u32| spp as usize * opts.passes as usize;
    // The window's header (the contact pixels are in window coordinates) from a render of
    // the whole window at the fewest samples that have a variance.
    let header_opts = RenderOptions {
        spp: HEADER_SPP.min(base_spp),
        ..*opts
    };
    let total = w * h * unit(header_opts.spp)
        + cells
            .iter()
            .map(|s| s.width * s.height * unit(s.spp))
            .sum::<usize>();
    let done = AtomicUsize::new(0);
    // Each render reports its own running count; the sum goes to `progress`.
    let tracked = |last: &AtomicUsize, d: usize| {
        let step = d.saturating_sub(last.swap(d, Ordering::Relaxed));
        progress(done.fetch_add(step, Ordering::Relaxed) + step, total);
    };
    let last = AtomicUsize::new(0);
    let mut image = render(scene.sensor.film.crop, &header_opts, &|d, _| {
        tracked(&last, d)
    })?;
    let crops = render_strips(render, scene, opts, &cells, &tracked)?;
    // The header of a render at the base count, with the window's own entries.
    let base = crops
        .iter()
        .find(|(s, _)| s.spp == base_spp)
        .map(|(_, img)| &img.meta)
        .ok_or_else(|| RenderError::Options("no cell at the base count".into()))?;
    let window_keys = [linlight_imagefile::KEY_CONTACT_PIXELS, "contacts"];
    let mut meta = base.clone();
    meta.extra.retain(|k, _| !window_keys.contains(&k.as_str()));
    for key in window_keys {
        if let Some(v) = image.meta.extra.get(key) {
            meta.extra.insert(key.into(), v.clone());
        }
    }
    meta.extra.remove("nonfinite_dropped");
    image.meta = meta;
    let mut counts = vec![0u32; w * h];
    paste(&mut image, &mut counts, w, &crops, 0)?;
    debug_assert!(
        counts.iter().all(|&n| n >= base_spp),
        "every pixel rendered"
    );
    finish(image, counts)
}

/// Fewest samples of the whole-window render whose header [`render`] keeps.
const HEADER_SPP: u32 = 2;

/// A render's strips are split so that no crop holds more than this share of their pixel
/// samples: a crop's tiles are its smallest units of parallel work, and one 8×8 cell at a
/// count far above the others' would otherwise be the last tile running, on one core.
const PIECES: usize = 32;

/// `strips` with every strip of more than 1/[`PIECES`] of their pixel samples cut into bands of
/// rows, each at most that share (a band is at least one row), in order. A pixel's samples do
/// not depend on the window it is rendered in, so the pasted image is the same.
fn pieces(strips: &[Strip]) -> Vec<Strip> {
    let limit = strips
        .iter()
        .map(samples)
        .sum::<usize>()
        .div_ceil(PIECES)
        .max(1);
    let mut out = Vec::with_capacity(strips.len());
    for s in strips {
        let bands = samples(s).div_ceil(limit).clamp(1, s.height);
        let rows = s.height.div_ceil(bands);
        for y in (0..s.height).step_by(rows) {
            out.push(Strip {
                y: s.y + y,
                height: rows.min(s.height - y),
                ..*s
            });
        }
    }
    out
}

/// The strips `cells`, rendered as crop windows at their counts ([`pieces`] of them), in order.
/// Each piece is a job of its own, the largest first, so that the last job is a small one:
/// rayon runs a chunk of items that no thread stole on one thread.
fn render_strips(
    render: &RenderFn,
    scene: &Scene,
    opts: &RenderOptions,
    cells: &[Strip],
    tracked: &(dyn Fn(&AtomicUsize, usize) + Sync),
) -> Result<Vec<(Strip, Image)>, RenderError> {
    let pieces = pieces(cells);
    let mut order: Vec<usize> = (0..pieces.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse(samples(&pieces[i])));
    let mut rendered: Vec<(usize, Image)> = order
        .par_iter()
        .with_max_len(1)
        .map(|&i| {
            let s = &pieces[i];
            let last = AtomicUsize::new(0);
            let img = render(
                Some(crop_window(scene, s)),
                &RenderOptions {
                    spp: s.spp,
                    ..*opts
                },
                &|d, _| tracked(&last, d),
            )?;
            Ok((i, img))
        })
        .collect::<Result<_, RenderError>>()?;
    rendered.sort_unstable_by_key(|&(i, _)| i);
    Ok(rendered
        .into_iter()
        .map(|(i, img)| (pieces[i], img))
        .collect())
}

/// The pixel samples of a strip.
fn samples(s: &Strip) -> usize {
    s.width * s.height * s.spp as usize
}

/// Where no cell is at the base count: the whole window at the base, the cells pasted over it
/// (the header is the base render's).
fn render_over_base(
    render: &RenderFn,
    scene: &Scene,
    opts: &RenderOptions,
    plan: &[u32],
    (w, h): (usize, usize),
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Image, RenderError> {
    let base_spp = opts.spp;
    let strips = strips(plan, w, h, base_spp);
    let unit = |spp: u32| spp as usize * opts.passes as usize;
    let total = w * h * unit(base_spp)
        + strips
            .iter()
            .map(|s| s.width * s.height * unit(s.spp))
            .sum::<usize>();
    let done = AtomicUsize::new(0);
    let tracked = |last: &AtomicUsize, d: usize| {
        let step = d.saturating_sub(last.swap(d, Ordering::Relaxed));
        progress(done.fetch_add(step, Ordering::Relaxed) + step, total);
    };
    let last = AtomicUsize::new(0);
    let mut image = render(scene.sensor.film.crop, opts, &|d, _| tracked(&last, d))?;
    let crops = render_strips(render, scene, opts, &strips, &tracked)?;
    let mut counts = vec![image.meta.spp.min(u32::MAX as u64) as u32; w * h];
    let dropped = dropped_samples(&image);
    paste(&mut image, &mut counts, w, &crops, dropped)?;
    finish(image, counts)
}

/// Non-finite samples a render dropped (its header's `nonfinite_dropped`).
fn dropped_samples(img: &Image) -> u64 {
    img.meta
        .extra
        .get("nonfinite_dropped")
        .and_then(|v| v.parse().ok())
        .unwrap_or(0)
}

/// `crops` pasted over `image` (window width `w`), their counts into `counts`; the header's
/// `nonfinite_dropped` becomes `dropped` plus the crops'.
fn paste(
    image: &mut Image,
    counts: &mut [u32],
    w: usize,
    crops: &[(Strip, Image)],
    mut dropped: u64,
) -> Result<(), RenderError> {
    for (s, img) in crops {
        if (img.width, img.height) != (s.width, s.height) {
            return Err(RenderError::Options(format!(
                "a crop of {}×{} rendered {}×{} pixels",
                s.width, s.height, img.width, img.height
            )));
        }
        let n = img.meta.spp.min(u32::MAX as u64) as u32;
        for y in 0..s.height {
            for x in 0..s.width {
                let (i, k) = ((s.y + y) * w + s.x + x, y * s.width + x);
                image.mean[i] = img.mean[k];
                image.var[i] = img.var[k];
                if let (Some(t), Some(u)) = (&mut image.tail, &img.tail) {
                    t[i] = u[k];
                }
                counts[i] = n;
            }
        }
        dropped += dropped_samples(img);
    }
    if dropped > 0 {
        image
            .meta
            .extra
            .insert("nonfinite_dropped".into(), dropped.to_string());
    }
    Ok(())
}

/// The image with its per-pixel counts and their largest (`spp_max`).
fn finish(mut image: Image, counts: Vec<u32>) -> Result<Image, RenderError> {
    if let Some(max) = counts.iter().max() {
        image.meta.extra.insert("spp_max".into(), max.to_string());
    }
    image.pixel_spp = Some(counts);
    Ok(image)
}

#[cfg(test)]
mod tests {
    use super::*;
    use linlight_render::xml::load_scene;
    use linlight_sampling::Technique;

    /// A pasted pixel is the pixel of a uniform render at its count (same seed), the others
    /// those of the base render; the image records every pixel's count.
    #[test]
    fn pasted_cells_equal_a_uniform_render_at_their_count() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("references/scenes/cornell-tube.xml");
        let scene = load_scene(&path, &[("res".into(), "24".into())]).unwrap();
        let opts = RenderOptions {
            spp: 8,
            seed: 5,
            method: Technique::ProjectedSolidAngle.into(),
            ..Default::default()
        };
        let (w, h) = (24, 24);
        let mut plan = vec![8u32; w * h];
        for y in 8..16 {
            for x in 8..24 {
                plan[y * w + x] = 32;
            }
        }
        plan[20 * w + 3] = 16; // sets the cell (0, 16)
        let prepared = linlight_render::Prepared::new(&scene).unwrap();
        let render_fn =
            |c: Option<CropWindow>, o: &RenderOptions, p: &(dyn Fn(usize, usize) + Sync)| {
                prepared.render(c, o, p)
            };
        let last = std::sync::Mutex::new((0, 0));
        let img = render(&render_fn, &scene, &opts, Some(&plan), &|d, t| {
            *last.lock().unwrap() = (d, t);
        })
        .unwrap();
        let at = |spp| linlight_render::render(&scene, &RenderOptions { spp, ..opts }, &|_, _| {});
        let (u8_, u16_, u32_) = (at(8).unwrap(), at(16).unwrap(), at(32).unwrap());
        let counts = img.pixel_spp.as_ref().unwrap();
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let (want, n) = if (8..16).contains(&y) && x >= 8 {
                    (&u32_, 32)
                } else if y >= 16 && x < 8 {
                    (&u16_, 16)
                } else {
                    (&u8_, 8)
                };
                assert_eq!(counts[i], n, "({x}, {y})");
                assert_eq!(
                    (img.mean[i], img.var[i]),
                    (want.mean[i], want.var[i]),
                    "({x}, {y})"
                );
            }
        }
        assert_eq!((img.meta.spp, img.meta.dof), (8, 7.0));
        let (d, t) = *last.lock().unwrap();
        // The header's render at 2 spp, then every cell once at its count.
        let total = w * h * 2 + (w * h - 128 - 64) * 8 + 128 * 32 + 64 * 16;
        assert_eq!((d, t), (total, total));
        // The same image as the whole window at the base with the cells pasted over it,
        // header included.
        let over_base =
            render_over_base(&render_fn, &scene, &opts, &plan, (w, h), &|_, _| {}).unwrap();
        assert_eq!(img, over_base);
    }

    /// On the floor with a horizon-crossing light touching it, with a cell at more samples in
    /// every cell row: the image and its header (the window's entries included) are those of
    /// the whole window at the base with the cells pasted over it.
    #[test]
    fn the_header_is_the_windows() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("references/scenes/floor-crossing.xml");
        let scene = load_scene(&path, &[("res".into(), "24".into())]).unwrap();
        let opts = RenderOptions {
            spp: 4,
            seed: 3,
            method: Technique::SolidAngle.into(),
            ..Default::default()
        };
        let (w, h) = (24, 24);
        let mut plan = vec![4u32; w * h];
        for y in 0..h {
            plan[y * w + 20] = 8 + 4 * (y / 8) as u32;
        }
        let prepared = linlight_render::Prepared::new(&scene).unwrap();
        let render_fn =
            |c: Option<CropWindow>, o: &RenderOptions, p: &(dyn Fn(usize, usize) + Sync)| {
                prepared.render(c, o, p)
            };
        let img = render(&render_fn, &scene, &opts, Some(&plan), &|_, _| {}).unwrap();
        let over_base =
            render_over_base(&render_fn, &scene, &opts, &plan, (w, h), &|_, _| {}).unwrap();
        assert_eq!(img, over_base);
    }

    /// Pieces cover the strips' pixels once each, at their counts, and none holds more than
    /// 1/PIECES of the samples unless it is one row.
    #[test]
    fn pieces_cover_the_strips_and_bound_the_largest() {
        let (w, h) = (64, 64);
        let mut plan = vec![256u32; w * h];
        for y in 16..24 {
            for x in 40..48 {
                plan[y * w + x] = 65536;
            }
        }
        let strips = all_strips(&plan, w, h);
        let pieces = pieces(&strips);
        let total: usize = strips.iter().map(samples).sum();
        assert_eq!(pieces.iter().map(samples).sum::<usize>(), total);
        let mut seen = vec![0u32; w * h];
        for p in &pieces {
            assert!(
                p.height == 1 || samples(p) <= total.div_ceil(PIECES),
                "{p:?}"
            );
            for y in p.y..p.y + p.height {
                for x in p.x..p.x + p.width {
                    assert_eq!(seen[y * w + x], 0);
                    seen[y * w + x] = p.spp;
                }
            }
        }
        assert_eq!(seen, plan);
        assert!(pieces.len() > strips.len());
    }

    #[test]
    fn strips_join_equal_neighbouring_cells_above_the_base() {
        // 24×16: cells (0,0) (8,0) need 512, (16,0) 256 (base), second cell row: (8,8) 1024.
        let (w, h) = (24, 16);
        let mut plan = vec![256; w * h];
        for y in 0..8 {
            for x in 0..16 {
                plan[y * w + x] = 512;
            }
        }
        plan[12 * w + 9] = 1024; // one pixel sets its cell's count
        let s = strips(&plan, w, h, 256);
        assert_eq!(
            s,
            vec![
                Strip {
                    x: 0,
                    y: 0,
                    width: 16,
                    height: 8,
                    spp: 512
                },
                Strip {
                    x: 8,
                    y: 8,
                    width: 8,
                    height: 8,
                    spp: 1024
                },
            ]
        );
        // Partial cells at the right and bottom edges.
        let (w, h) = (20, 12);
        let s = strips(&vec![300; w * h], w, h, 256);
        assert_eq!(s.len(), 2);
        assert_eq!(
            (s[0].width, s[0].height, s[1].y, s[1].height),
            (20, 8, 8, 4)
        );
        assert!(strips(&vec![256; w * h], w, h, 256).is_empty());
    }
}
