//! The packet renderer: the camera samples of a tile are rendered [`PACKET_LANES`] at a time, as
//! Mitsuba's LLVM variants do with their wavefronts — random numbers and camera rays of all
//! lanes, one packet walk of the BVH for their closest hits, the light samples of all lanes in
//! the batch kernels of `linlight_sampling::batch` (the packet's sixteen lanes at once), one
//! packet walk for their shadow rays, then the contributions: Lambertian lanes (f = ρ/π) on the lanes'
//! arrays, lanes on other surfaces (rough conductor, principled, blends) with the scalar path's
//! shading frame ([`shading_frame`]) for all lanes at once and its BSDF evaluation on all
//! sixteen lanes at once per BSDF ([`Bsdf::eval_lanes`], f32 SIMD lanes: the scalar path's
//! `Bsdf::eval_f32` is its one-lane case) and [`single_contribution`]'s arithmetic; a packet
//! may mix both.
//!
//! Lanes that a batch kernel cannot sample — a technique without one (area, solid angle, Hart),
//! LTC and MIS on non-Lambertian surfaces — take their samples lane by lane with the scalar
//! code ([`single_sample`], [`TwoTechniqueLight::candidates`]) and trace them in packet walks
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
//! tile in the scalar path's order, draws the numbers of its own Philox stream in the scalar
//! order (film position, then one per light — two on non-Lambertian surfaces under LTC and
//! MIS — or, choosing one light per light sample, the choice ξ_c and the chosen light's one or
//! two; then the visible lines'), and every step is the scalar step's arithmetic (the batch
//! kernels and packet walks equal their scalar forms bit for bit, ties of the closest hit
//! included; a light's samples are summed per lane as the scalar estimator sums them), so an
//! image equals the one of the scalar reference path ([`crate::integrator::render_scalar`] with the
//! same method and light selection) bit for bit — tests below check it on every committed
//! scene, method and light selection. Pixels accumulate their samples in the same order
//! (Welford in f64).
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

use crate::bvh::{PacketHits, RayLanes, PACKET};
use crate::film::Welford;
use crate::frame::{metadata, pixel_entries, render_in_tiles};
use crate::hooks::{LightSampling, Ltc, SceneBsdf};
use crate::light_choice::LightSelection;
use crate::method::Method;
use crate::options::{check_options, window, RenderError, RenderOptions};
use crate::ray_offset::{offset_origin, SHADOW_EPSILON};
use crate::render_scene::{k_over_probability, reflecting_normal, RenderScene};
use crate::scene::{Bsdf, Scene};
use crate::shading::{
    contribution, lambert_technique, shading_frame, single_contribution, single_sample, to_local,
    Combination, ShadingPoint, TwoTechniqueLight,
};
use crate::shapes::{Primitive, Ray};
use crate::visible_line::PixelLine;
use glam::Vec3;
use linlight_imagefile::Image;
use linlight_sampling::batch::{self, LineProblems, LineSamples};
use linlight_sampling::philox::{unit_f32, CounterRng};
use linlight_sampling::{Segment, Technique};
use linlight_simd::{dispatch, get3, set3, splat3, Aligned, Isa, Kernel, PACKET_LANES};
use std::mem::MaybeUninit;

const _: () = assert!(
    PACKET_LANES == PACKET,
    "a packet's camera samples are one BVH ray packet"
);

/// Whether [`crate::render::render`] renders `scene` with `opts` by the packet renderer: one
/// light sample per camera sample, white noise, and either a technique with a batch kernel
/// (projected solid angle, Li et al., clipped solid angle) or a scene with Lambertian surfaces.
/// The other methods sample lane by lane with the scalar code, which pays in packets only
/// where Lambertian lanes share them (measured: 15–28 % less CPU time on cornell-tube and
/// mesh-occluder, half on glossy-cornell for MIS, but 5–20 % more on the scenes without a
/// Lambertian surface; see docs/performance.md). Both light selections (`every`, `one`) take the same decision.
/// [`render_isa`] renders any scene, method and light selection with one light sample and
/// white noise.
pub fn applies(scene: &Scene, opts: &RenderOptions) -> bool {
    let batch_kernel = matches!(opts.method, Method::Technique(t) if has_batch_kernel(t));
    renders(opts) && (batch_kernel || scene.shapes.iter().any(|s| s.bsdf.lambertian().is_some()))
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
    let (x0, y0, w, h) = window(scene)?;
    let rs = RenderScene::new(scene)?;
    let technique = lambert_technique(opts.method);
    let combination = Combination::of(opts.method);
    let ctx = Context {
        rs: &rs,
        opts,
        isa: if isa.supported() { isa } else { Isa::Baseline },
        full_width: scene.sensor.film.width,
        technique,
        batch: has_batch_kernel(technique),
        combination,
        per_light: if combination.is_some() && rs.lambert.iter().any(Option::is_none) {
            2
        } else {
            1
        },
        light_rows: light_rows(&rs),
    };
    let mut image = render_in_tiles(
        &rs,
        opts,
        (x0, y0, w, h),
        progress,
        |pixels, seen, pass, single| ctx.tile_pass(pixels, seen, pass, single),
    );
    image.meta = metadata(
        opts,
        scene,
        pixel_entries(scene, &rs, (x0, y0, w, h)),
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
    /// non-Lambertian surfaces, else 1.
    per_light: usize,
    /// Per light j, what a lane that chooses it (`--lights one`) samples: [`LightRow`].
    light_rows: Vec<LightRow>,
}

/// A light's values for the lanes that sample it: K (K_j/p_j when the lanes choose one light:
/// [`k_over_probability`], the scalar path's operation) at 0..3, its segment's begin at 3..6
/// and end at 6..9.
type LightRow = [f32; 9];

/// The [`LightRow`] of light j with K = `k`.
fn light_row(segment: &Segment, k: Vec3) -> LightRow {
    let mut row = [0.0; 9];
    for (c, v) in [k, segment.begin, segment.end].iter().enumerate() {
        row[3 * c..3 * c + 3].copy_from_slice(&v.to_array());
    }
    row
}

/// The [`LightRow`] of every light of `rs` chosen with its probability (K/p).
fn light_rows(rs: &RenderScene) -> Vec<LightRow> {
    (0..rs.lights.len())
        .map(|j| {
            light_row(
                &rs.lights[j].0,
                k_over_probability(&rs.lights, &rs.choice, j),
            )
        })
        .collect()
}

/// A 3-vector in each of the [`PACKET_LANES`] lanes of a packet.
type Lanes3 = linlight_simd::Lanes3<f32, PACKET_LANES>;

/// The shading points of a packet, lane k from camera sample k (structure of arrays). Lanes
/// outside `active` (no hit, or a surface that does not reflect toward the camera) hold zeros.
///
/// The lane arrays come first and the struct is aligned to 64 bytes, so that every array
/// starts a cache line (see [`Aligned`]).
#[repr(C, align(64))]
struct ShadingLanes<'a> {
    p: Lanes3,
    /// Geometric normal (offsets shadow-ray origins).
    ng: Lanes3,
    /// Normal of the side that reflects ([`reflecting_normal`]).
    n: Lanes3,
    /// f = ρ/π on Lambertian lanes (zero on the others and outside `active`).
    lambert: Lanes3,
    /// The shading frames of all lanes ([`shading_frame`], computed at once where
    /// `glossy_mask` ≠ 0): columns x̂, ŷ (n is `n`), and v = (v_x, 0, v_z) as [v_x, v_z].
    frame_x: Lanes3,
    frame_y: Lanes3,
    v: [[f32; PACKET_LANES]; 2],
    active: u32,
    /// The active lanes on non-Lambertian surfaces: `glossy[k]` is the scalar path's shading
    /// point of lane k there (its BSDF is evaluated lane by lane), `None` elsewhere and where
    /// the lanes sample in a batch kernel (they need only the frames below).
    glossy_mask: u32,
    glossy: [Option<ShadingPoint<'a>>; PACKET_LANES],
    /// The BSDF of the lanes in `glossy_mask` (`None` everywhere when `one_bsdf` is set).
    bsdf: [Option<&'a Bsdf>; PACKET_LANES],
    /// The BSDF of every lane in `glossy_mask`, when all hit lanes lie on one glossy shape
    /// (written with `glossy_mask` in one branch-free loop; lane by lane the stores of `n`
    /// stalled the frames' vector loads after them, store forwarding).
    one_bsdf: Option<&'a Bsdf>,
}

/// The light each lane samples in one pass over the lights: the light's index, its
/// [`LightRow`] in lanes (`rows[r][k]`: value r of lane k's light — K, divided by the lane's
/// choice probability when one light is chosen, and the segment) and the lane's numbers —
/// `xi` for the batch lanes (one per light), `scalar_xi` for the lanes sampled with the scalar
/// code (one, or two for LTC and MIS on non-Lambertian surfaces; the second is 0 otherwise);
/// `uniform`: the light of every lane, when they share one (`every`).
#[repr(C, align(64))] // the lane arrays first, each on its own cache line(s) ([`Aligned`])
struct LightLanes {
    rows: [[f32; PACKET_LANES]; 9],
    light: [u32; PACKET_LANES],
    xi: [f32; PACKET_LANES],
    scalar_xi: [[f32; PACKET_LANES]; 2],
    uniform: Option<usize>,
}

impl LightLanes {
    /// Lane k's light segment and K.
    #[inline(always)]
    fn of<'s>(&self, rs: &'s RenderScene, k: usize) -> (&'s Segment, Vec3) {
        (&rs.lights[self.light[k] as usize].0, get3(self.k(), k))
    }

    /// Each lane's K.
    #[inline(always)]
    fn k(&self) -> &Lanes3 {
        self.row3(0)
    }

    /// Rows 3·i … 3·i + 2 (0: K, 1: segment begin, 2: segment end).
    #[inline(always)]
    fn row3(&self, i: usize) -> &Lanes3 {
        // Three whole rows (i is a constant after inlining): the conversion cannot fail.
        self.rows[3 * i..3 * i + 3].try_into().expect("three rows")
    }
}

/// The light samples of a packet for one [`LightLanes`], as the packet kernels return them
/// (direction, density, distance to the line along the direction; `mask`: lanes with a
/// sample), on cache lines ([`Aligned`]).
type SampleLanes = Aligned<LineSamples<PACKET_LANES>>;

impl<'a> Context<'a> {
    /// One pass over the pixels of a tile (full-film coordinates): their camera samples in the
    /// scalar order (pixel by pixel, sample by sample), `PACKET_LANES` at a time, pushed into `acc`.
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
        let fill = |packet: &mut Packet, start: usize| {
            let len = PACKET_LANES.min(total - start);
            dispatch(
                self.isa,
                FillPacket {
                    packet,
                    pixels,
                    spp_width: (spp, self.full_width),
                    start_len: (start, len),
                },
            );
        };
        fill(packet, 0);
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
                fill(next, next_start);
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
            let used = 2 + if radiance.shaded >> k & 1 == 1 {
                let per_light = 1 + (radiance.two_per_light >> k & 1) as usize;
                rs.light_numbers(self.opts.lights, 1, per_light)
            } else {
                0
            };
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

/// The camera samples of a packet: lane k is sample `sample[k]` of the tile's pixel
/// `pixel[k]` at full-film (`fx[k]`, `fy[k]`), film index `index[k]`; lanes ≥ `len` repeat the
/// last sample and are ignored.
#[derive(Default)]
#[repr(C, align(64))] // the lane arrays first, each on its own cache line(s) ([`Aligned`])
struct Packet {
    pixel: [usize; PACKET_LANES],
    fx: [u32; PACKET_LANES],
    fy: [u32; PACKET_LANES],
    index: [u32; PACKET_LANES],
    sample: [u32; PACKET_LANES],
    len: usize,
}

impl Packet {
    /// Camera samples `start` … `start + len − 1` of a tile pass over `pixels` at `spp`
    /// samples per pixel (sample j is sample j % spp of pixel j / spp); lanes ≥ `len` repeat
    /// the last one.
    #[inline(always)]
    fn fill(
        &mut self,
        pixels: &[(u32, u32)],
        spp: usize,
        full_width: u32,
        start: usize,
        len: usize,
    ) {
        self.len = len;
        let (pixel, sample) = (start / spp, start % spp);
        // < 2^32: checked by `window`.
        let index = |(fx, fy): (u32, u32)| fy.wrapping_mul(full_width).wrapping_add(fx);
        if spp >= PACKET_LANES {
            // At most one step to the next pixel inside the packet: every lane at once.
            let (a, b) = (pixels[pixel], pixels[(pixel + 1).min(pixels.len() - 1)]);
            let (ia, ib) = (index(a), index(b));
            for k in 0..PACKET_LANES {
                let s = (sample + k.min(len - 1)) as u32;
                let next = s >= spp as u32;
                self.sample[k] = if next { s - spp as u32 } else { s };
                self.pixel[k] = pixel + next as usize;
                self.fx[k] = if next { b.0 } else { a.0 };
                self.fy[k] = if next { b.1 } else { a.1 };
                self.index[k] = if next { ib } else { ia };
            }
            return;
        }
        // Counting, one lane after the other.
        let (mut pixel, mut sample) = (pixel, sample as u32);
        for k in 0..PACKET_LANES {
            if k > 0 && k < len {
                sample += 1;
                if sample as usize == spp {
                    (pixel, sample) = (pixel + 1, 0);
                }
            }
            let (fx, fy) = pixels[pixel];
            self.pixel[k] = pixel;
            self.fx[k] = fx;
            self.fy[k] = fy;
            self.index[k] = index((fx, fy));
            self.sample[k] = sample;
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
}

impl Kernel for Accumulate<'_> {
    type Output = ();
    #[inline(always)]
    fn run(self) {
        accumulate_kernel(self.acc, self.packet, self.total)
    }
}

/// [`fill_kernel`]: the camera samples of a packet.
struct FillPacket<'a> {
    packet: &'a mut Packet,
    pixels: &'a [(u32, u32)],
    spp_width: (usize, u32),
    start_len: (usize, usize),
}

impl Kernel for FillPacket<'_> {
    type Output = ();
    #[inline(always)]
    fn run(self) {
        fill_kernel(self.packet, self.pixels, self.spp_width, self.start_len)
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
        #[allow(clippy::needless_range_loop)] // lane j of the three channel arrays
        for j in k..end {
            // One 4-wide push (B again in the unused lane): the bits of `push` of the three.
            let b = total[2][j];
            w.push_quad([total[0][j], total[1][j], b, b].map(|c| c as f64));
        }
        acc[pixel] = w;
    }
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
    let number = |dim: usize| -> [f32; PACKET_LANES] {
        if dim / 4 < kept {
            // SAFETY: blocks below `kept` were written (`primary_kernel`).
            let block = unsafe { words[dim / 4].assume_init_ref() };
            block[dim % 4].map(unit_f32)
        } else {
            // More lights than the blocks kept: this dimension lane by lane.
            std::array::from_fn(|k| {
                let id = [packet.sample[k], packet.index[k], pass];
                unit_f32(CounterRng::at(ctx.opts.seed, id, dim as u64))
            })
        }
    };
    let rays = &primary.rays;
    let hits = rs.bvh.intersect_lanes(rays, active);
    // Shading points for the lanes sampled with the scalar code; the batch kernels' lanes need
    // only the frames.
    let points = (ctx.combination.is_some() || !ctx.batch).then_some(ctx.opts.method);
    let shading = shading_points(rs, points, rays, &hits);
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
        // shadow walk, instead of waiting on them at the start of the next packet. (At the
        // start of this packet they overlapped its camera walk: cornell-tube 2-4 % slower.)
        if let Some(next) = next.take() {
            primary_kernel(ctx, next, pass, next_primary);
        }
        let samples = ctx.light_samples(&light, &shading, batch_lanes);
        let (shadow, mask) = shadow_rays(&shading, &samples);
        let occluded =
            rs.shadows
                .occluded_lanes(&rs.bvh, &light.light, light.uniform, &shadow, mask);
        let lit = mask & !occluded;
        // Lambertian lanes: K·f(v, ω)·cos θ/p(ω), p per radius (dΩ_R), and only finite
        // contributions (adding +0 elsewhere leaves a sum that starts at +0 bitwise unchanged).
        let lambert_lit = lit & !shading.glossy_mask;
        let mut lambert_dropped = 0u32;
        #[allow(clippy::needless_range_loop)] // lane k of every array: the loop that vectorises
        for k in 0..PACKET_LANES {
            // glam's k·f·(n·ω/p) written on the lanes: the same operations in the same order
            // (the dot product adds x, y, then z), so the same bits.
            let (n, dir, f) = (&shading.n, &samples.dir, &shading.lambert);
            let cos = n[0][k] * dir[0][k] + n[1][k] * dir[1][k] + n[2][k] * dir[2][k];
            let s = cos / samples.pdf[k];
            let c: [f32; 3] = std::array::from_fn(|a| light.k()[a][k] * f[a][k] * s);
            let finite = c.iter().all(|x| x.is_finite());
            let lambert = lambert_lit >> k & 1 == 1;
            let add = lambert & finite;
            lambert_dropped |= ((lambert & !finite) as u32) << k;
            for a in 0..3 {
                total[a][k] += if add { c[a] } else { 0.0 };
            }
        }
        dropped += lambert_dropped.count_ones() as u64;
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

/// What a packet draws before anything else: the Philox blocks of its lanes' numbers (the
/// first `Context::kept_blocks`; the others uninitialised) and its camera rays.
#[repr(C, align(64))]
struct Primary {
    rays: RayLanes,
    words: [MaybeUninit<[[u32; PACKET_LANES]; 4]>; MAX_BLOCKS],
}

impl Default for Primary {
    fn default() -> Self {
        Self {
            rays: RayLanes::default(),
            words: [MaybeUninit::uninit(); MAX_BLOCKS],
        }
    }
}

/// The [`Primary`] of `packet` into `out`: film position (2 numbers) and the lights' numbers
/// (one or two per light, or the choice ξ_c and the chosen light's one or two) from the
/// lanes' own streams, and the camera rays through the film positions. Only the blocks the
/// packet uses are computed (and only they are read); the others stay uninitialised rather
/// than zeroed per packet (a 1 KiB memset).
#[inline(always)]
fn primary_kernel(ctx: &Context, packet: &Packet, pass: u32, out: &mut Primary) {
    for (b, w) in out.words.iter_mut().enumerate().take(ctx.kept_blocks()) {
        w.write(CounterRng::camera_sample_block(
            ctx.opts.seed,
            pass,
            &packet.index,
            &packet.sample,
            b as u32,
        ));
    }
    // SAFETY: block 0 was written (`kept_blocks` ≥ 1).
    let block = unsafe { out.words[0].assume_init_ref() };
    // (Not `block.map(…)`: an array's `map` over the four words compiled to an out-of-line
    // `try_map` call, 1.1 % of the CPU time.)
    let (u, v) = (
        Aligned(block[0].map(unit_f32)),
        Aligned(block[1].map(unit_f32)),
    );
    let px: Aligned<[f32; PACKET_LANES]> =
        Aligned(std::array::from_fn(|k| packet.fx[k] as f32 + u[k]));
    let py: Aligned<[f32; PACKET_LANES]> =
        Aligned(std::array::from_fn(|k| packet.fy[k] as f32 + v[k]));
    ctx.rs.camera.ray_lanes(&px, &py, &mut out.rays);
}

impl Context<'_> {
    /// The Philox blocks of four numbers a packet draws at once: 2 (film position) + the
    /// lights' numbers, at most [`MAX_BLOCKS`] (≥ 1).
    #[inline(always)]
    fn kept_blocks(&self) -> usize {
        let rs = self.rs;
        let blocks = (2 + rs.light_numbers(self.opts.lights, 1, self.per_light)).div_ceil(4);
        blocks.min(MAX_BLOCKS)
    }
}

/// Blocks of four numbers per lane drawn together (2 + the lights' numbers ≤ 16); further
/// dimensions are drawn lane by lane.
const MAX_BLOCKS: usize = 4;

/// The shading points of the lanes that hit a surface reflecting toward the camera: the
/// scalar integrator's `surface_point` and `reflecting_normal`, the hit lanes taken one primitive
/// at a time (one index compare over the lanes per primitive). A glossy lane gets
/// the scalar path's [`ShadingPoint`] when `points` names the method (sampled lane by lane),
/// else its shading frame, which only [`glossy_contributions`] (batch kernels) reads.
#[inline(always)]
fn shading_points<'a>(
    rs: &'a RenderScene,
    points: Option<Method>,
    rays: &RayLanes,
    hits: &PacketHits,
) -> ShadingLanes<'a> {
    let mut out = ShadingLanes {
        active: 0,
        p: [[0.0; PACKET_LANES]; 3],
        ng: [[0.0; PACKET_LANES]; 3],
        n: [[0.0; PACKET_LANES]; 3],
        lambert: [[0.0; PACKET_LANES]; 3],
        glossy_mask: 0,
        glossy: [None; PACKET_LANES],
        bsdf: [None; PACKET_LANES],
        one_bsdf: None,
        frame_x: [[0.0; PACKET_LANES]; 3],
        frame_y: [[0.0; PACKET_LANES]; 3],
        v: [[0.0; PACKET_LANES]; 2],
    };
    // Surface points (p, ng, ns) of the hits: triangles gathered into lanes and computed for
    // all lanes at once below, other primitives with their own `surface_point`.
    let (mut p, mut ng, mut ns) = (
        Aligned([[0.0f32; PACKET_LANES]; 3]),
        Aligned([[0.0f32; PACKET_LANES]; 3]),
        Aligned([[0.0f32; PACKET_LANES]; 3]),
    );
    // The triangle lanes' arrays are locals of their own: as fields of `Triangles` built
    // uninitialised, LLVM merged them with its zeroed fields into a 1152-byte `memset`.
    let (mut tri_v, mut tri_n) = (
        Aligned(MaybeUninit::uninit()),
        Aligned(MaybeUninit::uninit()),
    );
    let mut tri = Triangles::new(&mut tri_v, &mut tri_n);
    // The hit lanes are taken a primitive at a time (a packet's sixteen samples of one or two
    // pixels hit few primitives): its lanes found by comparing the primitive index on all lanes
    // at once, its shape and triangle written into them by selects (lane by lane in groups
    // of at most SMALL_GROUP lanes). Lane-by-lane stores of every hit lane's vertices
    // stalled the first vector load after them (store forwarding).
    let mut shape_of = [0u32; PACKET_LANES];
    // The shape every hit lane lies on, if one.
    let (mut first_shape, mut one_shape) = (None, true);
    let mut m = hits.mask;
    while m != 0 {
        let i = hits.prim[m.trailing_zeros() as usize];
        let mut group = 0u32;
        #[allow(clippy::needless_range_loop)] // lane k of every array: the loop that vectorises
        for k in 0..PACKET_LANES {
            group |= ((hits.prim[k] == i) as u32) << k;
        }
        group &= m;
        m &= !group;
        let prim = rs.bvh.primitive(i);
        let shape = prim.shape();
        one_shape &= *first_shape.get_or_insert(shape) == shape;
        select_lanes(&mut shape_of, group, shape);
        let flip = rs.surfaces[shape as usize].1;
        match prim {
            Primitive::Triangle { v, n, .. } => tri.set(group, v, n.as_ref(), flip),
            _ => {
                let mut g = group;
                while g != 0 {
                    let k = g.trailing_zeros() as usize;
                    g &= g - 1;
                    let Some(hit) = hits.get(k) else { continue };
                    let sp = prim.surface_point(&rays.get(k), &hit, flip);
                    set3(&mut p, k, sp.p);
                    set3(&mut ng, k, sp.ng);
                    set3(&mut ns, k, sp.ns);
                }
            }
        }
    }
    if tri.mask != 0 {
        tri.surface_points(hits, &mut p, &mut ng, &mut ns);
    }
    // (One exit, and `out` borrowed field by field: an early return or `&mut out` copied the
    // whole ShadingLanes on return, +28 instructions per sample on glossy-principled.)
    // One shape under every hit lane: Lambertian, or glossy where the lanes need no scalar
    // ShadingPoint (`points` = None: batch techniques, which read the frames below).
    let uniform_shape = first_shape
        .filter(|&s| one_shape && (rs.lambert[s as usize].is_some() || points.is_none()));
    if let Some(shape) = uniform_shape {
        // `reflecting_normal` and the stores of the loop below on all lanes at once: lane k is
        // active where n_s·ω_i > 0 (n = n_s) or, on a two-sided BSDF, n_s·ω_i < 0 (n = −n_s),
        // with ω_i = −d and the dot product in glam's order (the same bits); the other lanes
        // keep their zeros (a glossy shape's lanes keep `lambert` at zero).
        let shape = shape as usize;
        let bsdf = &rs.surfaces[shape].0;
        let two_sided = bsdf.is_two_sided();
        let lambert = rs.lambert[shape];
        let f = lambert.unwrap_or(Vec3::ZERO).to_array();
        let mut active = 0u32;
        #[allow(clippy::needless_range_loop)] // lane k of every array: the loop that vectorises
        for k in 0..PACKET_LANES {
            let wi = [-rays.d[0][k], -rays.d[1][k], -rays.d[2][k]];
            let c = ns[0][k] * wi[0] + ns[1][k] * wi[1] + ns[2][k] * wi[2];
            let front = c > 0.0;
            let on = (hits.mask >> k & 1 == 1) & (front | ((c < 0.0) & two_sided));
            active |= (on as u32) << k;
            for a in 0..3 {
                let n = if front { ns[a][k] } else { -ns[a][k] };
                out.p[a][k] = if on { p[a][k] } else { 0.0 };
                out.ng[a][k] = if on { ng[a][k] } else { 0.0 };
                out.n[a][k] = if on { n } else { 0.0 };
                out.lambert[a][k] = if on { f[a] } else { 0.0 };
            }
        }
        out.active = active;
        if lambert.is_none() {
            out.glossy_mask = active;
            out.one_bsdf = Some(bsdf);
        }
    } else {
        let mut m = hits.mask;
        while m != 0 {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            let shape = shape_of[k] as usize;
            let wi = -get3(&rays.d, k);
            let bsdf = &rs.surfaces[shape].0;
            let Some(n) = reflecting_normal(bsdf, get3(&ns, k), wi) else {
                continue;
            };
            out.active |= 1 << k;
            let pk = get3(&p, k);
            set3(&mut out.p, k, pk);
            set3(&mut out.ng, k, get3(&ng, k));
            set3(&mut out.n, k, n);
            match rs.lambert[shape] {
                Some(f) => set3(&mut out.lambert, k, f),
                None => {
                    // The scalar integrator's shading point (its n() is `n`, bit for bit).
                    out.glossy_mask |= 1 << k;
                    out.bsdf[k] = Some(bsdf);
                    if let Some(method) = points {
                        out.glossy[k] = Some(glossy_point(method, bsdf, pk, n, wi));
                    }
                }
            }
        }
    }
    // With `points` the glossy lanes are sampled lane by lane (their ShadingPoint has the
    // frame) or not in a batch at all: the frames would not be read.
    if out.glossy_mask != 0 && points.is_none() {
        // The scalar path's frames (ShadingPoint::new), all lanes at once (branch-free).
        #[allow(clippy::needless_range_loop)] // lane k of every array: the loop that vectorises
        for k in 0..PACKET_LANES {
            let (frame, v) = shading_frame(get3(&out.n, k), -get3(&rays.d, k));
            set3(&mut out.frame_x, k, frame.x_axis);
            set3(&mut out.frame_y, k, frame.y_axis);
            // f32 values (dot products of f32 vectors), exactly.
            (out.v[0][k], out.v[1][k]) = (v.x as f32, v.z as f32);
        }
    }
    out
}

/// The scalar integrator's shading point; not inlined, as [`Context::scalar_samples`].
#[inline(never)]
fn glossy_point(method: Method, bsdf: &Bsdf, p: Vec3, n: Vec3, wi: Vec3) -> ShadingPoint<'_> {
    ShadingPoint::for_method(&SceneBsdf, method, bsdf, p, n, wi)
}

/// Adds the contributions of the lit lanes (`lit`) on non-Lambertian surfaces for their light
/// (lane k's K = `k_light[·][k]`) to `total`: the scalar single-technique contribution
/// ([`single_contribution`]), finite ones only; returns how many were dropped. The lanes that
/// share a BSDF are evaluated together, on all sixteen lanes of the packet
/// ([`Bsdf::eval_lanes`]: the scalar path's arithmetic per lane, the same bits, in f32 SIMD
/// lanes of the kernel's instruction set, into which this is inlined), then K·f·cos/p on all
/// lanes at once.
#[inline(always)]
fn glossy_contributions(
    shading: &ShadingLanes,
    samples: &SampleLanes,
    lit: u32,
    k_light: &Lanes3,
    total: &mut Lanes3,
) -> u64 {
    let glossy = lit & shading.glossy_mask;
    if glossy == 0 {
        return 0;
    }
    // ω in the shading frames (ShadingPoint::local), all lanes at once.
    let mut l = [[0.0f32; PACKET_LANES]; 3];
    #[allow(clippy::needless_range_loop)] // lane k of every array: the loop that vectorises
    for k in 0..PACKET_LANES {
        let (x, y, n) = (
            get3(&shading.frame_x, k),
            get3(&shading.frame_y, k),
            get3(&shading.n, k),
        );
        let lk = to_local(x, y, n, get3(&samples.dir, k));
        (l[0][k], l[1][k], l[2][k]) = (lk.x, lk.y, lk.z);
    }
    // f·cos of the lanes in `todo`, BSDF by BSDF, each on all sixteen lanes at once (f32: one
    // 512-bit register; the lanes outside its group are computed and not kept).
    let v = [shading.v[0], [0.0; PACKET_LANES], shading.v[1]];
    let mut f_cos = [[0.0f32; PACKET_LANES]; 3];
    let mut todo = glossy;
    while todo != 0 {
        let (bsdf, group) = if let Some(bsdf) = shading.one_bsdf {
            // Every glossy lane on one shape: one evaluation, no grouping.
            (bsdf, todo)
        } else {
            let Some(bsdf) = shading.bsdf[todo.trailing_zeros() as usize] else {
                todo &= todo - 1;
                continue;
            };
            // The lanes of `todo` whose surface has this BSDF (pointers compared on all lanes
            // at once).
            let mut group = 0u32;
            #[allow(clippy::needless_range_loop)] // lane k of every array: the loop that vectorises
            for k in 0..PACKET_LANES {
                let same = shading.bsdf[k].map_or(std::ptr::null(), |b| b as *const Bsdf);
                group |= (std::ptr::eq(same, bsdf) as u32) << k;
            }
            (bsdf, group & todo)
        };
        todo &= !group;
        let f = bsdf.eval_lanes(&v, &l);
        if group == glossy {
            // One BSDF on every glossy lit lane (the loop below reads no other lane).
            f_cos = f;
            break;
        }
        #[allow(clippy::needless_range_loop)] // lane k of every array: the loop that vectorises
        for k in 0..PACKET_LANES {
            let keep = group >> k & 1 == 1;
            for a in 0..3 {
                f_cos[a][k] = if keep { f[a][k] } else { f_cos[a][k] };
            }
        }
    }
    // K·(f·cos)/p (single_contribution's arithmetic) on all lanes, the finite ones of the lit
    // glossy lanes added (+0 elsewhere leaves the sums, which start at +0, bitwise unchanged).
    let mut dropped = 0u32;
    #[allow(clippy::needless_range_loop)] // lane k of every array: the loop that vectorises
    for k in 0..PACKET_LANES {
        let c = contribution(get3(k_light, k), get3(&f_cos, k), samples.pdf[k]);
        let finite = c.is_finite();
        let on = glossy >> k & 1 == 1;
        dropped |= ((on & !finite) as u32) << k;
        for (a, t) in total.iter_mut().enumerate() {
            t[k] += if on & finite { c[a] } else { 0.0 };
        }
    }
    dropped.count_ones() as u64
}

/// The triangles hit by the lanes of a packet (structure of arrays): vertices, vertex normals
/// (`normals`: lanes that have them), the sign of `flip_normals`. The lanes of one triangle are
/// written together ([`Triangles::set`]): the first triangle into every lane (so that all lanes
/// are initialised without zeroing the arrays first), the later ones by selects over the
/// lanes (lane by lane when a group has at most [`SMALL_GROUP`] lanes); the normals only once
/// a triangle has them (they are not read otherwise). Lanes outside `mask` (`normals`) hold
/// another triangle's values, computed on and not kept.
#[repr(C, align(64))] // `sign` on its own cache line ([`Aligned`])
struct Triangles<'t> {
    sign: [f32; PACKET_LANES],
    mask: u32,
    v: &'t mut MaybeUninit<[Lanes3; 3]>,
    n: &'t mut MaybeUninit<[Lanes3; 3]>,
    normals: u32,
}

impl<'t> Triangles<'t> {
    /// No lanes yet, the vertices and normals to be written into `v` and `n`.
    #[inline(always)]
    fn new(v: &'t mut MaybeUninit<[Lanes3; 3]>, n: &'t mut MaybeUninit<[Lanes3; 3]>) -> Self {
        Self {
            mask: 0,
            v,
            n,
            normals: 0,
            sign: [1.0; PACKET_LANES],
        }
    }
}

/// Groups of at most this many lanes are written lane by lane, larger ones by a select over
/// all sixteen lanes (nine selects cost about as much as the stores of five lanes).
const SMALL_GROUP: u32 = 4;

/// `x` in the lanes of `group` (bit k: lane k) of `lanes`. (The bit-mask select of
/// [`write_group`] here instead, shared by both through one helper: cornell-tube 629.0 →
/// 642.8 instructions per sample, floor-tube 450 → 456, callgrind, AVX2 kernels; and the
/// helper alone in `write_group` 629.0 → 638.9. So each keeps its own loop.)
#[inline(always)]
fn select_lanes<T: Copy>(lanes: &mut [T; PACKET_LANES], group: u32, x: T) {
    if group.count_ones() <= SMALL_GROUP {
        let mut g = group;
        while g != 0 {
            lanes[g.trailing_zeros() as usize] = x;
            g &= g - 1;
        }
        return;
    }
    for (k, l) in lanes.iter_mut().enumerate() {
        *l = if group >> k & 1 == 1 { x } else { *l };
    }
}

/// Writes the three vectors `v` into the lanes of `group` (bit k: lane k) of `lanes`, or into
/// every lane when `written` = 0 (`lanes` not yet initialised; afterwards it is).
///
/// The small-group and select loops are written out here rather than calling `select_lanes`
/// per component array: that tidier form measured +7 instructions per sample on mesh-occluder
/// (590.5 → 597.9, callgrind, AVX2 kernels), more than the 0.5 % a tidying may cost.
#[inline(always)]
fn write_group(lanes: &mut MaybeUninit<[Lanes3; 3]>, written: u32, group: u32, v: &[Vec3; 3]) {
    if written == 0 {
        // An array literal: `v.map(…)` compiled to an out-of-line `try_map` call whose result
        // came back through memory (a 576-byte `memcpy`). Writing the nine rows in place
        // through a pointer measured the same or worse (callgrind, with glossy-gap and acc-rng
        // merged, each of which had removed that copy its own way; instructions per sample,
        // pointer vs literal: cornell-tube 631.8 vs 632.3, floor-tube 453.7 vs 447.2,
        // glossy-principled 600.3 vs 596.6), so the safe form stays.
        let splat = |x: Vec3| {
            [
                [x.x; PACKET_LANES],
                [x.y; PACKET_LANES],
                [x.z; PACKET_LANES],
            ]
        };
        lanes.write([splat(v[0]), splat(v[1]), splat(v[2])]);
        return;
    }
    // SAFETY: `written` ≠ 0: a first call initialised every lane.
    let lanes = unsafe { lanes.assume_init_mut() };
    if group.count_ones() <= SMALL_GROUP {
        let mut g = group;
        while g != 0 {
            let k = g.trailing_zeros() as usize;
            g &= g - 1;
            for (lj, vj) in lanes.iter_mut().zip(v) {
                set3(lj, k, *vj);
            }
        }
        return;
    }
    // A select by bit masks: with `if` LLVM turned it into a store per lane behind a branch
    // (≈ 850 instructions of scalar code); this loads and stores every lane, in vectors.
    let masks: [u32; PACKET_LANES] = std::array::from_fn(|k| 0u32.wrapping_sub(group >> k & 1));
    for (lj, vj) in lanes.iter_mut().zip(v) {
        for (l, c) in lj.iter_mut().zip(vj.to_array()) {
            for (x, m) in l.iter_mut().zip(masks) {
                *x = f32::from_bits(c.to_bits() & m | x.to_bits() & !m);
            }
        }
    }
}

impl Triangles<'_> {
    /// Triangle `v` (vertex normals `n`) in the lanes of `group`.
    #[inline(always)]
    fn set(&mut self, group: u32, v: &[Vec3; 3], n: Option<&[Vec3; 3]>, flip: bool) {
        write_group(self.v, self.mask, group, v);
        self.mask |= group;
        if let Some(n) = n {
            write_group(self.n, self.normals, group, n);
            self.normals |= group;
        }
        select_lanes(&mut self.sign, group, if flip { -1.0 } else { 1.0 });
    }

    /// `Primitive::surface_point` of the triangle lanes, the same operations lane by lane (so
    /// the same bits), in one loop over all lanes that the compiler vectorises; other lanes
    /// are left as they are. Only with `mask` ≠ 0.
    #[inline(always)]
    fn surface_points(&self, hits: &PacketHits, p: &mut Lanes3, ng: &mut Lanes3, ns: &mut Lanes3) {
        debug_assert!(self.mask != 0);
        // SAFETY: `set` initialised every lane (mask ≠ 0).
        let v = unsafe { self.v.assume_init_ref() };
        if self.normals == 0 {
            // Zero normals, as the lanes without them: the shading normal is the geometric.
            self.lanes(v, None, hits, p, ng, ns);
            return;
        }
        // SAFETY: as above (normals ≠ 0).
        let n = unsafe { self.n.assume_init_ref() };
        self.lanes(v, Some(n), hits, p, ng, ns);
    }

    #[inline(always)]
    fn lanes(
        &self,
        v: &[Lanes3; 3],
        n: Option<&[Lanes3; 3]>,
        hits: &PacketHits,
        p: &mut Lanes3,
        ng: &mut Lanes3,
        ns: &mut Lanes3,
    ) {
        for k in 0..PACKET_LANES {
            let (b1, b2) = (hits.b1[k], hits.b2[k]);
            let b0 = 1.0 - b1 - b2;
            let [v0, v1, v2] = v.each_ref().map(|v| get3(v, k));
            let pk = b0 * v0 + b1 * v1 + b2 * v2;
            let ngk = (v1 - v0).cross(v2 - v0).normalize_or_zero();
            let nsk = match n {
                Some(n) => {
                    let [n0, n1, n2] = n.each_ref().map(|n| get3(n, k));
                    let nsk = (b0 * n0 + b1 * n1 + b2 * n2).normalize_or_zero();
                    if (self.normals >> k & 1 == 1) & (nsk != Vec3::ZERO) {
                        nsk
                    } else {
                        ngk
                    }
                }
                None => ngk,
            };
            if self.mask >> k & 1 == 1 {
                let sign = self.sign[k];
                set3(p, k, pk);
                set3(ng, k, sign * ngk);
                set3(ns, k, sign * nsk);
            }
        }
    }
}

/// Shadow rays of the lanes whose sample can contribute (the scalar integrator's tests:
/// positive finite density, n·ω > 0, a finite positive distance, a usable shadow ray), and
/// their mask.
#[inline(always)]
fn shadow_rays(shading: &ShadingLanes, samples: &SampleLanes) -> (RayLanes, u32) {
    let mut rays = RayLanes::default();
    let mut mask = 0u32;
    for k in 0..PACKET_LANES {
        let (p, ng, n) = (
            get3(&shading.p, k),
            get3(&shading.ng, k),
            get3(&shading.n, k),
        );
        let (dir, pdf, distance) = (get3(&samples.dir, k), samples.pdf[k], samples.distance[k]);
        let cos = n.dot(dir);
        // distance = d/t with d > 0: the scalar test "t > 0 and d/t finite".
        let usable =
            (pdf > 0.0) & pdf.is_finite() & (cos > 0.0) & (distance > 0.0) & distance.is_finite();
        let (ray, ok) = shadow_ray_lane(p, ng, p + distance * dir);
        rays.set(k, &ray);
        mask |= ((usable & ok & (samples.mask >> k & 1 == 1)) as u32) << k;
    }
    (rays, mask)
}

impl<'a> Context<'a> {
    /// The lights of pass `walk` over the lights and their numbers, `number(d)` being
    /// dimension d of the lanes (only the batch lanes' ξ when `batch`, the scalar lanes' when
    /// `scalar`): light `walk` in every lane, ξ of dimension 2 + `walk` for the batch lanes and
    /// 2 + `walk` or (2 + 2·`walk`, 3 + 2·`walk`) for the scalar lanes (`every`); or (`one`,
    /// `tree`) each lane's light chosen by its ξ_c (dimension 2; the scalar path's
    /// `choose_light` on the lanes, `tree` from the lane's shading point) with K/p, and its
    /// numbers from dimension 3 on.
    #[inline(always)]
    fn light_lanes(
        &self,
        walk: usize,
        one: bool,
        number: &impl Fn(usize) -> [f32; PACKET_LANES],
        shading: &ShadingLanes,
        batch: bool,
        scalar: bool,
    ) -> LightLanes {
        let rs = self.rs;
        // First dimension of the light's numbers, and how many a scalar lane draws per light.
        let (first, scalar_per_light) = match (one, self.combination) {
            (false, None) => (2 + walk, 1),
            (false, Some(_)) => (2 + 2 * walk, 2),
            (true, None) => (3, 1),
            (true, Some(_)) => (3, 2),
        };
        let zero = [0.0; PACKET_LANES];
        let scalar_xi = if !scalar {
            [zero; 2]
        } else if scalar_per_light == 1 {
            [number(first), zero]
        } else {
            [number(first), number(first + 1)]
        };
        // Batch lanes draw one number per light.
        let xi = if !batch {
            zero
        } else if one {
            number(3)
        } else {
            number(2 + walk)
        };
        if !one {
            let (segment, k) = &rs.lights[walk];
            return LightLanes {
                uniform: Some(walk),
                light: [walk as u32; PACKET_LANES],
                rows: light_row(segment, *k).map(|v| [v; PACKET_LANES]),
                xi,
                scalar_xi,
            };
        }
        if self.opts.lights == LightSelection::Tree {
            // Each shaded lane's light from its shading point, lane by lane (the scalar path's
            // `choose_light`); the other lanes sample nothing.
            let xi_c = number(2);
            let mut light = [0u32; PACKET_LANES];
            let mut rows = [[0.0f32; PACKET_LANES]; 9];
            let mut m = shading.active;
            while m != 0 {
                let k = m.trailing_zeros() as usize;
                m &= m - 1;
                let (j, kp) = rs.choose_light(
                    LightSelection::Tree,
                    get3(&shading.p, k),
                    get3(&shading.n, k),
                    xi_c[k],
                );
                light[k] = j as u32;
                for (r, v) in light_row(&rs.lights[j].0, kp).into_iter().enumerate() {
                    rows[r][k] = v;
                }
            }
            return LightLanes {
                uniform: None,
                light,
                rows,
                xi,
                scalar_xi,
            };
        }
        // Each lane's light, its K/p and segment, all lanes at once.
        let (light, rows) = rs.choice.pick_rows(&number(2), &self.light_rows);
        LightLanes {
            uniform: None,
            light,
            rows,
            xi,
            scalar_xi,
        }
    }

    /// The sampling problems of the packet's lanes for [`Self::light_samples`]'s packet kernels.
    /// Lanes without a shading point have a zero normal: no contribution.
    #[inline(always)]
    fn packet_input(
        &self,
        lights: &LightLanes,
        shading: &ShadingLanes,
    ) -> LineProblems<PACKET_LANES> {
        let (begin, end) = match lights.uniform {
            Some(j) => {
                let segment = &self.rs.lights[j].0;
                (splat3(segment.begin), splat3(segment.end))
            }
            None => (*lights.row3(1), *lights.row3(2)),
        };
        LineProblems {
            begin,
            end,
            x: shading.p,
            n: shading.n,
            xi: lights.xi,
        }
    }

    /// One sample of lane k's light `lights.light[k]` with ξ = `lights.xi[k]` for every lane
    /// with a shading point (the lanes of `lanes` and with a sample in the result's `mask`).
    #[inline(always)]
    fn light_samples(
        &self,
        lights: &LightLanes,
        shading: &ShadingLanes,
        lanes: u32,
    ) -> SampleLanes {
        let technique = self.technique;
        debug_assert!(self.batch, "{technique:?} has no batch kernel");
        let input = self.packet_input(lights, shading);
        let mut out = Aligned(match technique {
            Technique::ProjectedSolidAngle => {
                batch::sample_projected_solid_angle_packet(self.isa, &input)
            }
            Technique::ClippedSolidAngle => {
                batch::sample_clipped_solid_angle_packet(self.isa, &input)
            }
            Technique::Li2018 => batch::sample_li2018_with(self.isa, &input).0,
            _ => unreachable!("{technique:?} has no batch kernel (has_batch_kernel)"),
        });
        out.mask &= lanes;
        out
    }

    /// Each lane's light of `lights` at the lanes of `lanes`, sampled lane by lane
    /// with the scalar code — a single technique's sample ([`single_sample`]), or LTC's and
    /// MIS's diffuse and specular samples ([`TwoTechniqueLight::candidates`]) —, each kind of
    /// sample's shadow rays in one packet walk, the lanes' contributions of this light summed
    /// as the scalar path sums them, then added to `total`. Returns the number of non-finite
    /// contributions left out.
    #[inline(always)]
    fn scalar_light(
        &self,
        shading: &ShadingLanes,
        lanes: u32,
        lights: &LightLanes,
        total: &mut Lanes3,
    ) -> u64 {
        let samples = self.scalar_samples(shading, lanes, lights);
        let visible = samples
            .each_ref()
            .map(|s| s.visible(self.rs, shading, lights));
        let mut dropped = 0;
        let mut m = lanes;
        while m != 0 {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            // This light's estimate at lane k: its visible samples in the scalar order, summed
            // from +0 (a lane without one adds +0, which leaves the total's bits unchanged).
            let mut light = Vec3::ZERO;
            for (s, visible) in samples.iter().zip(visible) {
                if visible >> k & 1 == 1 {
                    let c = get3(&s.c, k);
                    if c.is_finite() {
                        light += c;
                    } else {
                        dropped += 1;
                    }
                }
            }
            set3(total, k, get3(total, k) + light);
        }
        dropped
    }

    /// The samples of [`Self::scalar_light`] before visibility, lane by lane; ξ of lane k:
    /// `lights.scalar_xi[0][k]` (single techniques) or both (LTC, MIS). Not inlined:
    /// scalar code, compiled once for the target's baseline rather than into every ISA's
    /// packet kernel.
    #[inline(never)]
    fn scalar_samples(
        &self,
        shading: &ShadingLanes,
        lanes: u32,
        lights: &LightLanes,
    ) -> [CandidateLanes; 2] {
        let xi = &lights.scalar_xi;
        let mut samples = [CandidateLanes::default(), CandidateLanes::default()];
        let mut m = lanes;
        match self.combination {
            None => {
                let xi = &xi[0];
                while m != 0 {
                    let k = m.trailing_zeros() as usize;
                    m &= m - 1;
                    let (segment, k_light) = lights.of(self.rs, k);
                    let (p, n) = (get3(&shading.p, k), get3(&shading.n, k));
                    let Some(sampler) = LightSampling::prepare(&self.technique, segment, p, n)
                    else {
                        continue;
                    };
                    let Some(s) = single_sample(&sampler, n, xi[k]) else {
                        continue;
                    };
                    // The integrator's contributions: full BSDF, or K·(ρ/π)·(cos θ/p).
                    let c = match &shading.glossy[k] {
                        Some(point) => single_contribution(&SceneBsdf, point, k_light, s.w, s.pdf),
                        None => k_light * get3(&shading.lambert, k) * (s.cos / s.pdf),
                    };
                    samples[0].set(k, s.w, s.dist, c);
                }
            }
            Some(combination) => {
                let [xi_d, xi_s] = xi;
                while m != 0 {
                    let k = m.trailing_zeros() as usize;
                    m &= m - 1;
                    let Some(point) = &shading.glossy[k] else {
                        continue;
                    };
                    let (segment, k_light) = lights.of(self.rs, k);
                    let Some(light) = TwoTechniqueLight::prepare(&Ltc, point, segment) else {
                        continue;
                    };
                    let eval = |w: Vec3| point.eval(&SceneBsdf, w);
                    let candidates =
                        light.candidates(combination, k_light, (xi_d[k], xi_s[k]), eval);
                    for (lanes, c) in samples.iter_mut().zip(candidates) {
                        if let Some(c) = c {
                            lanes.set(k, c.w, c.dist, c.c);
                        }
                    }
                }
            }
        }
        samples
    }
}

/// Samples found lane by lane with the scalar code: lane k (in `mask`) adds `c[k]` when the
/// line point along `dir[k]` at `distance[k]` is visible.
#[derive(Default)]
#[repr(C, align(64))] // the lane arrays first, each on its own cache line(s) ([`Aligned`])
struct CandidateLanes {
    dir: Lanes3,
    c: Lanes3,
    distance: [f32; PACKET_LANES],
    mask: u32,
}

impl CandidateLanes {
    #[inline(always)]
    fn set(&mut self, k: usize, dir: Vec3, distance: f32, c: Vec3) {
        self.mask |= 1 << k;
        set3(&mut self.dir, k, dir);
        self.distance[k] = distance;
        set3(&mut self.c, k, c);
    }

    /// The lanes whose line point is visible: the scalar integrator's shadow rays
    /// (`shadow_ray_to`) toward lane k's light `lights.light[k]`, in one packet walk per
    /// culled shadow BVH the lanes' lights use, plus one of the full BVH for the others
    /// ([`crate::shadow_culling`]).
    #[inline(always)]
    fn visible(&self, rs: &RenderScene, shading: &ShadingLanes, lights: &LightLanes) -> u32 {
        if self.mask == 0 {
            return 0;
        }
        let mut rays = RayLanes::default();
        let mut mask = 0u32;
        let mut m = self.mask;
        while m != 0 {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            let p = get3(&shading.p, k);
            let target = p + self.distance[k] * get3(&self.dir, k);
            let (ray, ok) = shadow_ray_lane(p, get3(&shading.ng, k), target);
            rays.set(k, &ray);
            mask |= (ok as u32) << k;
        }
        mask & !rs
            .shadows
            .occluded_lanes(&rs.bvh, &lights.light, lights.uniform, &rays, mask)
    }
}

/// [`shadow_ray_to`] without branches: the ray, and whether `shadow_ray_to` returns it.
#[inline(always)]
fn shadow_ray_lane(p: Vec3, ng: Vec3, target: Vec3) -> (Ray, bool) {
    let o = offset_origin(p, ng, target - p);
    let d = target - o;
    let dist = d.length();
    let ok = (dist > 0.0) & dist.is_finite();
    let ray = Ray {
        o,
        d: d / dist,
        t_min: 0.0,
        t_max: dist * (1.0 - SHADOW_EPSILON),
    };
    (ray, ok)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hooks::Hooks;
    use crate::integrator::render_scalar;
    use crate::light_choice::LightSelection;
    use crate::method::Method;
    use crate::xml;
    use linlight_sampling::mis::Heuristic;

    fn scene(name: &str, res: u32) -> Scene {
        let path = crate::test_scenes::dir().join(format!("{name}.xml"));
        xml::load_scene(&path, &[("res".into(), res.to_string())]).expect(name)
    }

    fn bits(img: &Image) -> Vec<u32> {
        img.mean
            .iter()
            .chain(&img.var)
            .chain(img.tail.iter().flatten())
            .flat_map(|p| p.map(f32::to_bits))
            .collect()
    }

    /// Every committed scene (Lambertian, glossy, mixed), every method, every kernel the CPU
    /// runs: the image equals the scalar path's bit for bit (means, variances, tail shares,
    /// header), with spp not a multiple of the packet (packets span pixels) and with passes.
    #[test]
    fn images_equal_the_scalar_path() {
        let names: Vec<String> = crate::test_scenes::committed()
            .iter()
            .filter_map(|p| p.file_stem()?.to_str().map(String::from))
            .collect();
        // Every method: the techniques with a batch kernel, those sampled lane by lane, LTC
        // and MIS with every heuristic.
        let methods: Vec<Method> = Technique::ALL
            .into_iter()
            .map(Method::from)
            .chain([Method::Ltc])
            .chain(Heuristic::ALL.map(Method::Mis))
            .collect();
        // The committed scenes hide the lights from the camera: also tests/scenes/visible-tube
        // (a sphere hides part of the visible line, so the lines' numbers, drawn after the
        // lights' one or two per light, matter), as is and with a rough conductor sphere.
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../tests/scenes/visible-tube.xml");
        let tube = xml::load_scene(&path, &[("res".into(), "24".into())]).unwrap();
        let mut glossy_tube = tube.clone();
        for shape in glossy_tube.shapes.iter_mut().skip(1) {
            shape.bsdf = crate::scene::Bsdf::RoughConductor(linlight_brdf::RoughConductor {
                alpha: 0.2,
                fresnel: linlight_brdf::ConductorFresnel::One,
                specular_reflectance: [1.0; 3],
            });
        }
        // Two lights on a surface that is not Lambertian: `one` with lanes sampled with the
        // scalar code (and LTC's and MIS's two numbers) choosing different lights.
        let mut glossy_two = scene("two-tubes", 24);
        assert_eq!(glossy_two.lights.len(), 2);
        for shape in glossy_two.shapes.iter_mut().step_by(2) {
            shape.bsdf = crate::scene::Bsdf::RoughConductor(linlight_brdf::RoughConductor {
                alpha: 0.3,
                fresnel: linlight_brdf::ConductorFresnel::One,
                specular_reflectance: [1.0; 3],
            });
        }
        // The floor seen from its back (flipped normals): one-sided, nothing reflects; two-sided,
        // the shading normal turns toward the camera (both on the packets' one-shape path).
        let mut back = scene("floor-tube", 24);
        for shape in back.shapes.iter_mut() {
            shape.flip_normals = true;
        }
        let mut two_sided_back = back.clone();
        for shape in two_sided_back.shapes.iter_mut() {
            shape.bsdf = crate::scene::Bsdf::TwoSided(Box::new(shape.bsdf.clone()));
        }
        let extra = [
            ("visible-tube".to_string(), tube),
            ("visible-tube, glossy sphere".to_string(), glossy_tube),
            ("two-tubes, glossy".to_string(), glossy_two),
            ("floor-tube, back".to_string(), back),
            ("floor-tube, two-sided back".to_string(), two_sided_back),
        ];
        let scenes = names
            .iter()
            .map(|name| (name.clone(), scene(name, 24)))
            .chain(extra);
        let mut two_light_renders = 0;
        for (name, scene) in scenes {
            for (technique, lights) in methods
                .iter()
                .flat_map(|&m| LightSelection::ALL.map(|l| (m, l)))
            {
                for (spp, passes) in [(5, 1), (16, 2)] {
                    let opts = RenderOptions {
                        spp,
                        passes,
                        seed: 3,
                        method: technique,
                        light_samples: 1,
                        lights,
                        noise: Default::default(),
                        cylinders: crate::options::Cylinders::Line,
                    };
                    let scalar = render_scalar(&scene, &opts, &Hooks::new(), &|_, _| {}).unwrap();
                    // Every kernel this CPU runs (the baseline always: CPUs without AVX).
                    for isa in Isa::ALL.into_iter().filter(|i| i.supported()) {
                        let batched = render_isa(&scene, &opts, isa, &|_, _| {}).unwrap();
                        assert!(
                            bits(&batched) == bits(&scalar),
                            "{name}, {technique}, {lights}, {isa:?}, {spp} spp × {passes}"
                        );
                        assert_eq!(batched.meta, scalar.meta, "{name}, {technique}");
                    }
                    if lights == LightSelection::One && scene.lights.len() == 2 {
                        two_light_renders += 1;
                    }
                }
            }
        }
        // Every scene, method and light selection, whether `render` takes the batched path or
        // not; the glossy scenes (rough conductor, principled, blend, glossy and Lambertian
        // shapes mixed) are among them, and those with two lights (two-tubes as is and glossy at
        // least) let the lanes choose different lights.
        assert!(names.iter().filter(|n| n.starts_with("glossy-")).count() >= 4);
        assert!(
            two_light_renders >= 2 * 2 * methods.len(),
            "{two_light_renders}"
        );
    }

    /// A scene with one light draws no choice number: `one` and `every` render the same pixels
    /// bit for bit, on the scalar path (glossy scenes, several light samples, the two-technique
    /// estimator) and the batched one; only the header's `light_selection` differs.
    #[test]
    fn one_light_scenes_render_the_same_image_under_both_selections() {
        for (name, light_samples) in [("cornell-tube", 1), ("glossy-conductor-rough", 3)] {
            let scene = scene(name, 16);
            assert_eq!(scene.lights.len(), 1);
            let opts = |lights| RenderOptions {
                spp: 4,
                seed: 7,
                light_samples,
                lights,
                ..Default::default()
            };
            let one = opts(LightSelection::One);
            let every = opts(LightSelection::Every);
            let (a, b) = (
                crate::render::render(&scene, &one, &|_, _| {}).unwrap(),
                crate::render::render(&scene, &every, &|_, _| {}).unwrap(),
            );
            assert!(bits(&a) == bits(&b), "{name}");
            assert_eq!(a.meta.extra["light_selection"], "one");
            assert_eq!(b.meta.extra["light_selection"], "every");
        }
    }

    /// Several light samples per camera sample and blue noise take the scalar path, and so do
    /// methods without a batch kernel on scenes without Lambertian surfaces.
    #[test]
    fn applies_only_where_it_can() {
        let opts = RenderOptions {
            spp: 1,
            passes: 1,
            seed: 0,
            method: Technique::Area.into(),
            light_samples: 1,
            lights: LightSelection::One,
            noise: Default::default(),
            cylinders: crate::options::Cylinders::Line,
        };
        let cornell = scene("cornell-tube", 8);
        let mixed = scene("glossy-cornell", 8);
        let glossy = scene("glossy-conductor-rough", 8);
        let psa = RenderOptions {
            method: Technique::ProjectedSolidAngle.into(),
            ..opts
        };
        // Without a Lambertian surface only the batch techniques pay in packets.
        assert!(applies(&glossy, &psa));
        for method in [Technique::Area.into(), Method::Ltc, Method::default()] {
            assert!(!applies(&glossy, &RenderOptions { method, ..opts }));
            assert!(applies(&mixed, &RenderOptions { method, ..opts }));
        }
        for scene in [&cornell, &mixed] {
            assert!(applies(scene, &opts));
            // Blue noise reaches the light samples through the scalar path only.
            let blue = RenderOptions {
                noise: linlight_sampling::noise::Noise::Blue,
                ..opts
            };
            assert!(!applies(scene, &blue));
            assert!(render(scene, &blue, &|_, _| {}).is_err());
            let two = RenderOptions {
                light_samples: 2,
                ..opts
            };
            assert!(!applies(scene, &two));
        }
    }
}
