//! The packet renderer: the camera samples of a tile are rendered [`PACKET_LANES`] at a time, as
//! Mitsuba's LLVM variants do with their wavefronts — random numbers and camera rays of all
//! lanes, one packet walk of the BVH for their closest hits, the light samples of all lanes in
//! the batch kernels of `linlight_sampling::batch` (the packet's sixteen lanes at once), one
//! packet walk for their shadow rays, then the contributions: Lambertian lanes (f = ρ/π) on the lanes'
//! arrays, lanes on other surfaces (rough conductor, principled, blends) with the scalar path's
//! shading frame ([`shading_frame`](crate::shading::shading_frame)) for all lanes at once and its BSDF evaluation on all
//! sixteen lanes at once per BSDF ([`Bsdf::eval_lanes`](crate::scene::Bsdf::eval_lanes), f32 SIMD lanes: the scalar path's
//! `Bsdf::eval_f32` is its one-lane case) and [`single_contribution`](crate::shading::single_contribution)'s arithmetic; a packet
//! may mix both.
//!
//! Lanes that a batch kernel cannot sample — a technique without one (area, solid angle, Hart),
//! LTC and MIS on non-Lambertian surfaces — take their samples lane by lane with the scalar
//! code ([`single_sample`](crate::shading::single_sample),
//! [`TwoTechniqueLight::candidates`](crate::shading::TwoTechniqueLight::candidates)) and trace them in packet walks
//! (LTC and MIS: one for the diffuse, one for the specular samples).
//!
//! The lights: with `--lights every` one pass per light, every lane sampling that light; with
//! `--lights one` ([`crate::light_choice`], two or more lights) a single pass in which each
//! lane samples the light its ξ_c chose, with K/p — per-lane segments in the batch kernels for
//! the batch lanes, each lane's own light for the lanes sampled with the scalar code — so one
//! packet shadow walk per kind of sample and light sample (per culled shadow BVH of
//! [`crate::shadow_culling`] the lanes' lights use, and one of the full BVH for the lanes near
//! a culled plane).
//!
//! [`render_isa`] renders every scene and method with one light sample and white noise;
//! [`crate::render::render`] uses it where it pays ([`applies`]): the batch techniques on every
//! scene, the other methods on scenes with Lambertian surfaces. Everything else (several
//! light samples, blue noise, the methods without a batch kernel on all-glossy scenes) takes
//! the scalar path. Visible lines (`hide_emitters=false`) are added lane by lane with the
//! scalar code.
//!
//! Same estimator, same numbers, same image: lane k is camera sample (pixel, sample) of the
//! tile in the scalar path's order (or, on large scenes, a pixel's samples ranked by film
//! position, `packet::order`), draws the numbers of its own Philox stream in the scalar order
//! (film position, then one per light — two on non-Lambertian surfaces under LTC and MIS — or,
//! choosing one light per light sample, the choice ξ_c and the chosen light's one or two; then
//! the visible lines'), and every step is the scalar step's arithmetic (the batch kernels and
//! packet walks equal their scalar forms bit for bit, ties of the closest hit included; a
//! light's samples are summed per lane as the scalar estimator sums them), so an image equals
//! the one of the scalar reference path ([`crate::integrator::render_scalar`] with the same
//! method and light selection) bit for bit — tests below check it on every committed scene,
//! method and light selection. Pixels accumulate their samples in the same order, sample by
//! sample (Welford in f64), ranked or not.
//!
//! Two packets of a tile pass are in flight: while packet i is shaded, the numbers and camera
//! rays of packet i + 1 (`Primary`) are computed, so that their serial chains (Philox's
//! rounds, the rays' divisions and square roots) overlap packet i's work.
//!
//! Cost: `scripts/bench-render` (M samples/s against Mitsuba 3 on every committed scene);
//! instruction counts per sample with `valgrind --tool=callgrind` (see docs/performance.md).
//!
//! Memory: each tile writes its pixels into the image when it is done; no second full-size
//! buffer of tile results is held.

use crate::bvh::PACKET;
use crate::film::Welford;
use crate::frame::{metadata, pixel_entries, render_in_tiles};
use crate::light::LightRow;
use crate::method::Method;
use crate::options::{check_options, window, Cylinders, RenderError, RenderOptions, Window};
use crate::render_scene::RenderScene;
use crate::scene::Scene;
use crate::shading::{lambert_technique, Combination};
use crate::tube::Tubes;
use crate::visible_line::PixelLine;
use linlight_imagefile::Image;
use linlight_sampling::philox::{unit_f32, CounterRng};
use linlight_sampling::Technique;
use linlight_simd::{dispatch, get3, set3, Aligned, Isa, Kernel, PACKET_LANES};

use contributions::{glossy_contributions, lambert_contributions};
use lights::light_rows;
use order::SampleOrder;
use primary::{primary_kernel, Packet, Primary};
use shading::{shading_points, ShadingLanes};
use shadow::shadow_rays;

const _: () = assert!(
    PACKET_LANES == PACKET,
    "a packet's camera samples are one BVH ray packet"
);

/// Whether [`crate::render::render`] renders `scene` with `opts` by the packet renderer: one
/// light sample per camera sample, white noise, and either a technique with a batch kernel
/// (projected solid angle, Li et al., clipped solid angle) or a scene with Lambertian surfaces.
/// The other methods sample lane by lane with the scalar code, which pays in packets only
/// where Lambertian lanes share them (15–28 % less CPU time on cornell-tube and mesh-occluder,
/// half on glossy-cornell for MIS, but 5–20 % more on the scenes without a Lambertian surface;
/// see docs/performance.md). Every light selection takes the same decision.
/// [`render_isa`] renders any scene, method and light selection with one light sample and
/// white noise.
/// Under `--cylinders exact` with tubes: wherever every light is a tube (their samples are
/// scalar code per lane, `packet::tube`; the packets' walks pay on every scene), never otherwise.
pub fn applies(scene: &Scene, opts: &RenderOptions) -> bool {
    if let Some(all) = exact_tubes(scene, opts) {
        return renders(opts) && all;
    }
    let batch_kernel = matches!(opts.method, Method::Technique(t) if has_batch_kernel(t));
    renders(opts) && (batch_kernel || scene.shapes.iter().any(|s| s.bsdf.lambertian().is_some()))
}

/// Under `--cylinders exact` with some light a tube: whether every light is one (the packet
/// renderer renders exact tubes only then, [`tube`]); `None` when no light is a tube.
fn exact_tubes(scene: &Scene, opts: &RenderOptions) -> Option<bool> {
    let Cylinders::Exact(_) = opts.cylinders else {
        return None;
    };
    let tubes = Tubes::new(scene, opts.cylinders);
    tubes.any().then(|| tubes.tubes.iter().all(Option::is_some))
}

/// The techniques with a batch kernel in `linlight_sampling::batch`.
fn has_batch_kernel(technique: Technique) -> bool {
    matches!(
        technique,
        Technique::ProjectedSolidAngle | Technique::Li2018 | Technique::ClippedSolidAngle
    )
}

/// Whether the packet renderer can render with `opts` at all: one light sample per camera
/// sample and white noise (every scene and method).
fn renders(opts: &RenderOptions) -> bool {
    opts.light_samples == 1
        // Its lanes draw the white stream directly; blue noise takes the scalar path.
        && opts.noise == linlight_sampling::noise::Noise::White
}

/// Render `scene` with the packet renderer (see the module documentation); the same
/// contract as [`crate::render::render`]. An error with several light samples or blue noise.
pub fn render(
    scene: &Scene,
    opts: &RenderOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Image, RenderError> {
    render_isa(scene, opts, Isa::detect(), progress)
}

/// [`render`] with the kernels of `isa` (the baseline where the CPU does not run it).
pub fn render_isa(
    scene: &Scene,
    opts: &RenderOptions,
    isa: Isa,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Image, RenderError> {
    check(scene, opts)?;
    let rs = RenderScene::with_cylinders(scene, opts.cylinders)?;
    render_window(scene, &rs, window(scene)?, opts, isa, progress)
}

/// The options and scene errors of [`render_isa`].
fn check(scene: &Scene, opts: &RenderOptions) -> Result<(), RenderError> {
    check_options(opts)?;
    if !renders(opts) {
        return Err(RenderError::Options(format!(
            "the packet renderer needs one light sample and white noise (method {}, {} light \
             samples, {} noise)",
            opts.method,
            opts.light_samples,
            opts.noise.name()
        )));
    }
    if exact_tubes(scene, opts) == Some(false) {
        return Err(RenderError::Options(
            "the packet renderer draws exact tubes only when every light is one".into(),
        ));
    }
    Ok(())
}

/// [`render_isa`] of the pixels `(x0, y0, w, h)` of `scene`'s film (a valid window) with `rs`,
/// its render scene with `opts.cylinders` ([`RenderScene::sharing`]), for options that pass
/// [`check`].
pub(crate) fn render_window(
    scene: &Scene,
    rs: &RenderScene,
    (x0, y0, w, h): Window,
    opts: &RenderOptions,
    isa: Isa,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Image, RenderError> {
    debug_assert!(check(scene, opts).is_ok(), "{opts:?}");
    let tubes = rs.tubes.any();
    let technique = lambert_technique(opts.method);
    let combination = Combination::of(opts.method);
    let ctx = Context {
        rs,
        opts,
        isa: if isa.supported() { isa } else { Isa::Baseline },
        full_width: scene.sensor.film.width,
        technique,
        batch: has_batch_kernel(technique),
        combination,
        per_light: if tubes {
            // ξ₀ ξ₁ of the emitter sample, with MIS ξ₂ ξ₃ of the BSDF-side sample.
            if rs.tubes.sampling.mis {
                4
            } else {
                2
            }
        } else if combination.is_some() && rs.lambert.iter().any(Option::is_none) {
            2
        } else {
            1
        },
        tubes,
        light_rows: light_rows(rs, opts.lights),
        reorder: order::pays(&rs.bvh, u64::from(w) * u64::from(h)),
    };
    let mut image = render_in_tiles(
        rs,
        opts,
        (x0, y0, w, h),
        progress,
        |pixels, seen, pass, single| ctx.tile_pass(pixels, seen, pass, single),
    );
    image.meta = metadata(
        opts,
        scene,
        pixel_entries(scene, rs, (x0, y0, w, h)),
        Vec::new(),
    );
    Ok(image)
}

/// What every packet of a render shares.
struct Context<'a> {
    rs: &'a RenderScene,
    opts: &'a RenderOptions,
    isa: Isa,
    full_width: u32,
    /// The single technique, or the projected solid angle of LTC and MIS on Lambertian
    /// surfaces ([`lambert_technique`]).
    technique: Technique,
    /// Whether `technique` has a batch kernel ([`has_batch_kernel`]).
    batch: bool,
    /// LTC's and MIS's combination (two samples per light on non-Lambertian lanes); `None`
    /// for single techniques.
    combination: Option<Combination>,
    /// The most numbers a lane draws per light: 2 for LTC and MIS on a scene with
    /// non-Lambertian surfaces, else 1; for exact tubes 4 with MIS, else 2.
    per_light: usize,
    /// Every light is an exact tube ([`tube`]).
    tubes: bool,
    /// Per light j, what a lane that chooses it samples ([`light_rows`]).
    light_rows: Vec<LightRow>,
    /// Tile passes take a pixel's samples in film-position order ([`order`]).
    reorder: bool,
}

/// A 3-vector in each of the [`PACKET_LANES`] lanes of a packet.
type Lanes3 = linlight_simd::Lanes3<f32, PACKET_LANES>;

impl<'a> Context<'a> {
    /// One pass over the pixels of a tile (full-film coordinates): their camera samples pixel
    /// by pixel, a pixel's samples in index order or ranked by film position ([`order`]),
    /// `PACKET_LANES` at a time, pushed into `acc` in the scalar order (sample by sample).
    fn tile_pass(
        &self,
        pixels: &[(u32, u32)],
        seen: &[Vec<PixelLine>],
        pass: u32,
        acc: &mut [Welford],
    ) {
        let spp = self.opts.spp as usize;
        let total = pixels.len() * spp;
        // Most tiles see no line: then no lane has visible lines to add.
        let lines = seen.iter().any(|l| !l.is_empty());
        if total == 0 {
            return;
        }
        // Two packets in flight: the current one, and the next, filled and its `Primary`
        // computed by `run_packet` of the current one (see there); they swap after each packet.
        let (mut packets, mut primaries) = (
            [Packet::default(), Packet::default()],
            [Primary::default(), Primary::default()],
        );
        let [mut packet, mut next] = packets.each_mut();
        let [mut primary, mut next_primary] = primaries.each_mut();
        let mut order = if self.reorder {
            SampleOrder::new(spp)
        } else {
            None
        };
        let fill = |packet: &mut Packet, start: usize, order: &mut Option<SampleOrder>| {
            let len = PACKET_LANES.min(total - start);
            dispatch(
                self.isa,
                FillPacket {
                    packet,
                    pixels,
                    spp_width: (spp, self.full_width),
                    start_len: (start, len),
                    order: order.as_mut().map(|o| (o, self.opts.seed, pass)),
                },
            );
        };
        fill(packet, 0, &mut order);
        dispatch(
            self.isa,
            PrimaryRays {
                ctx: self,
                packet,
                pass,
                out: primary,
            },
        );
        let mut start = 0;
        while start < total {
            let next_start = start + packet.len;
            let more = next_start < total;
            if more {
                fill(next, next_start, &mut order);
            }
            let current = (&*packet, &*primary);
            let mut radiance = dispatch(
                self.isa,
                ShadePacket {
                    ctx: self,
                    current,
                    next: more.then_some(&*next),
                    next_primary,
                    pass,
                },
            );
            if lines {
                self.visible_lines(packet, seen, pass, &mut radiance);
            }
            dispatch(
                self.isa,
                Accumulate {
                    acc,
                    packet,
                    total: &radiance.total,
                    order: order.as_mut().map(|o| (o, start)),
                },
            );
            start = next_start;
            // The references, not the packets.
            std::mem::swap(&mut packet, &mut next);
            std::mem::swap(&mut primary, &mut next_primary);
        }
    }

    /// The lines the camera sees in a lane's pixel: drawn after the numbers the lane has used
    /// (film position, and the lights' when its ray reached a reflecting surface), lane by lane.
    fn visible_lines(
        &self,
        packet: &Packet,
        seen: &[Vec<PixelLine>],
        pass: u32,
        radiance: &mut Radiance,
    ) {
        let rs = self.rs;
        for k in 0..packet.len {
            let lines = &seen[packet.pixel[k]];
            if lines.is_empty() {
                continue;
            }
            let mut rng =
                CounterRng::camera_sample(self.opts.seed, pass, packet.index[k], packet.sample[k]);
            let shaded = radiance.shaded >> k & 1 == 1;
            let per_light = 1 + (radiance.two_per_light >> k & 1) as usize;
            let used = rs.camera_sample_numbers(self.opts.lights, 1, shaded.then_some(per_light));
            for _ in 0..used {
                rng.next_u32();
            }
            let mut t = get3(&radiance.total, k);
            rs.visible
                .add_estimate(lines, &rs.bvh, || rng.next_f64(), &mut t);
            set3(&mut radiance.total, k, t);
        }
    }
}

/// Radiance of each lane of a packet, the lanes whose camera ray reached a reflecting
/// surface (they used one number per light), and among them those that used two (LTC and MIS
/// on non-Lambertian surfaces).
#[repr(C, align(64))] // `total` on its own cache lines ([`Aligned`])
struct Radiance {
    total: Lanes3,
    shaded: u32,
    two_per_light: u32,
}

// The kernels, each compiled once per instruction set by `linlight_simd::dispatch`: a struct
// holds a kernel's arguments and its `Kernel::run` calls the kernel function.

/// [`packet_kernel`]: the radiance of the current packet.
struct ShadePacket<'a, 'c> {
    ctx: &'a Context<'c>,
    current: (&'a Packet, &'a Primary),
    next: Option<&'a Packet>,
    next_primary: &'a mut Primary,
    pass: u32,
}

impl Kernel for ShadePacket<'_, '_> {
    type Output = Radiance;
    #[inline(always)]
    fn run(self) -> Radiance {
        packet_kernel(
            self.ctx,
            self.current,
            self.next,
            self.next_primary,
            self.pass,
        )
    }
}

/// [`primary_kernel`]: the primary rays and hits of a packet.
struct PrimaryRays<'a, 'c> {
    ctx: &'a Context<'c>,
    packet: &'a Packet,
    pass: u32,
    out: &'a mut Primary,
}

impl Kernel for PrimaryRays<'_, '_> {
    type Output = ();
    #[inline(always)]
    fn run(self) {
        primary_kernel(self.ctx, self.packet, self.pass, self.out)
    }
}

/// [`accumulate_kernel`]: a packet's radiance into its pixels' accumulators.
struct Accumulate<'a> {
    acc: &'a mut [Welford],
    packet: &'a Packet,
    total: &'a Lanes3,
    /// The tile pass's sample order and the packet's first rank, if it reorders.
    order: Option<(&'a mut SampleOrder, usize)>,
}

impl Kernel for Accumulate<'_> {
    type Output = ();
    #[inline(always)]
    fn run(self) {
        match self.order {
            Some((order, start)) => order.accumulate(self.acc, self.packet, self.total, start),
            None => accumulate_kernel(self.acc, self.packet, self.total),
        }
    }
}

/// [`fill_kernel`]: the camera samples of a packet, in the tile pass's sample order.
struct FillPacket<'a> {
    packet: &'a mut Packet,
    pixels: &'a [(u32, u32)],
    spp_width: (usize, u32),
    start_len: (usize, usize),
    /// The tile pass's sample order, seed and pass, if it reorders.
    order: Option<(&'a mut SampleOrder, u64, u32)>,
}

impl Kernel for FillPacket<'_> {
    type Output = ();
    #[inline(always)]
    fn run(self) {
        fill_kernel(self.packet, self.pixels, self.spp_width, self.start_len);
        if let Some((order, seed, pass)) = self.order {
            order.apply(self.packet, seed, pass);
        }
    }
}

/// [`Packet::fill`], inlined into one function per instruction set.
#[inline(always)]
fn fill_kernel(
    packet: &mut Packet,
    pixels: &[(u32, u32)],
    (spp, full_width): (usize, u32),
    (start, len): (usize, usize),
) {
    packet.fill(pixels, spp, full_width, start, len);
}

/// Pushes the lanes' radiance into their pixels' accumulators in lane order (the scalar
/// path's order, so the same bits). A packet's lanes of one pixel are consecutive: the runs
/// are found at once (one compare of neighbouring lanes' pixels), each run is pushed into a
/// copy held in registers and stored once, instead of a load and a store of the accumulator
/// per sample (a store-to-load round trip in the serial chain of the running mean), and a
/// push is one 4-wide f64 update ([`Welford::push_quad`]). Inlined into one function per
/// instruction set.
#[inline(always)]
fn accumulate_kernel(acc: &mut [Welford], packet: &Packet, total: &Lanes3) {
    // Bit k: lane k starts a run of lanes of one pixel (found for all lanes at once).
    let mut starts = 1u32;
    for k in 1..PACKET_LANES {
        starts |= ((packet.pixel[k] != packet.pixel[k - 1]) as u32) << k;
    }
    let len = packet.len.min(PACKET_LANES);
    starts &= ((1u64 << len) - 1) as u32;
    while starts != 0 {
        let k = starts.trailing_zeros() as usize;
        starts &= starts - 1;
        let end = if starts != 0 {
            starts.trailing_zeros() as usize
        } else {
            len
        };
        let pixel = packet.pixel[k];
        let mut w = acc[pixel];
        for j in k..end {
            w.push_quad(radiance_quad(total, j).map(|c| c as f64));
        }
        acc[pixel] = w;
    }
}

/// Lane k's radiance as a quad for [`Welford::push_quad`], B again in the unused lane: one
/// 4-wide push has the bits of `push` of the three channels.
#[inline(always)]
fn radiance_quad(total: &Lanes3, k: usize) -> [f32; 4] {
    let b = total[2][k];
    [total[0][k], total[1][k], b, b]
}

/// Radiance of the camera samples of `packet` (see the module documentation) from its
/// `primary` (numbers and camera rays), every stage over all lanes; and, first, the
/// [`Primary`] of the `next` packet into `next_primary` (software pipelining: its serial
/// chains overlap this packet's work). Inlined into one function per instruction set.
#[inline(always)]
fn packet_kernel(
    ctx: &Context,
    (packet, primary): (&Packet, &Primary),
    next: Option<&Packet>,
    next_primary: &mut Primary,
    pass: u32,
) -> Radiance {
    let rs = ctx.rs;
    let lights = &rs.lights;
    let active = ((1u64 << packet.len) - 1) as u32;
    // The next packet's numbers and camera rays, computed once below (before this packet's
    // first batch of light samples, else at the end).
    let mut next = next;
    let one = rs.chooses_one(ctx.opts.lights);
    let kept = ctx.kept_blocks();
    let words = &primary.words;
    // More lights than the blocks kept: the last further block drawn, all lanes at once.
    let further = std::cell::Cell::new(None::<(usize, [[u32; PACKET_LANES]; 4])>);
    let number = |dim: usize| -> [f32; PACKET_LANES] {
        let b = dim / 4;
        if b < kept {
            // SAFETY: blocks below `kept` were written (`primary_kernel`).
            let block = unsafe { words[b].assume_init_ref() };
            return block[dim % 4].map(unit_f32);
        }
        let block = match further.get() {
            Some((held, block)) if held == b => block,
            _ => {
                let block = CounterRng::camera_sample_block(
                    ctx.opts.seed,
                    pass,
                    &packet.index,
                    &packet.sample,
                    b as u32,
                );
                further.set(Some((b, block)));
                block
            }
        };
        block[dim % 4].map(unit_f32)
    };
    let rays = &primary.rays;
    let hits = rs.bvh.intersect_lanes(rays, active);
    // Shading points for the lanes sampled with the scalar code; the batch kernels' lanes need
    // only the frames.
    let points = (ctx.tubes || ctx.combination.is_some() || !ctx.batch).then_some(ctx.opts.method);
    let mut shading = ShadingLanes::default();
    shading_points(rs, points, rays, &hits, &mut shading);
    if ctx.tubes {
        if let Some(next) = next {
            primary_kernel(ctx, next, pass, next_primary);
        }
        let mut total = Aligned([[0.0f32; PACKET_LANES]; 3]);
        let (shaded, dropped) =
            ctx.tube_lights(active, &number, (rays, &hits), &shading, &mut total);
        if dropped > 0 {
            rs.dropped
                .0
                .fetch_add(dropped, std::sync::atomic::Ordering::Relaxed);
        }
        return Radiance {
            total: total.0,
            shaded,
            two_per_light: 0,
        };
    }
    // Lanes sampled by a batch kernel, lanes sampled with the scalar code lane by lane (a
    // technique without a batch kernel; LTC and MIS on non-Lambertian surfaces).
    let (batch_lanes, scalar_lanes, two_per_light) = match (ctx.combination, ctx.batch) {
        (Some(_), _) => (
            shading.active & !shading.glossy_mask,
            shading.glossy_mask,
            shading.glossy_mask,
        ),
        (None, true) => (shading.active, 0, 0),
        (None, false) => (0, shading.active, 0),
    };

    let mut total = Aligned([[0.0f32; PACKET_LANES]; 3]);
    let mut dropped = 0u64;
    // One pass per light (`every`), or one with each lane's chosen light (`one`): the scalar
    // lanes' samples lane by lane, the batch lanes' in the batch kernels, one packet shadow
    // walk per kind of sample.
    for walk in 0..if one { 1 } else { lights.len() } {
        let light = ctx.light_lanes(
            walk,
            one,
            &number,
            &shading,
            batch_lanes != 0,
            scalar_lanes != 0,
        );
        if scalar_lanes != 0 {
            dropped += ctx.scalar_light(&shading, scalar_lanes, &light, &mut total);
        }
        if batch_lanes == 0 {
            continue;
        }
        // The next packet's Primary here: two serial chains (ten Philox rounds; the divisions
        // and square roots of the rays) that the core overlaps with this packet's batch and
        // shadow walk, instead of waiting on them at the start of the next packet.
        if let Some(next) = next.take() {
            primary_kernel(ctx, next, pass, next_primary);
        }
        let samples = ctx.light_samples(&light, &shading, batch_lanes);
        let (shadow, mask) = shadow_rays(&shading, &samples);
        let occluded =
            rs.shadows
                .occluded_lanes(&rs.bvh, &light.light, light.uniform, &shadow, mask);
        let lit = mask & !occluded;
        dropped += lambert_contributions(&shading, &samples, lit, light.k(), &mut total);
        dropped += glossy_contributions(&shading, &samples, lit, light.k(), &mut total);
    }
    // No batch lanes in this packet.
    if let Some(next) = next {
        primary_kernel(ctx, next, pass, next_primary);
    }
    if dropped > 0 {
        rs.dropped
            .0
            .fetch_add(dropped, std::sync::atomic::Ordering::Relaxed);
    }
    Radiance {
        total: total.0,
        shaded: shading.active,
        two_per_light,
    }
}

mod contributions;
mod lights;
mod order;
mod primary;
mod scalar;
mod shading;
mod shadow;
mod triangles;
mod tube;

#[cfg(test)]
mod tests;
