//! What a packet starts from: its camera samples (pixel, sample, film index per lane), the
//! Philox blocks of its lanes' numbers and its camera rays.

use super::Context;
use crate::bvh::RayLanes;
use linlight_sampling::philox::{unit_f32, CounterRng};
use linlight_simd::{Aligned, PACKET_LANES};
use std::mem::MaybeUninit;

/// The camera samples of a packet: lane k is sample `sample[k]` of the tile's pixel
/// `pixel[k]` at full-film (`fx[k]`, `fy[k]`), film index `index[k]`; lanes ≥ `len` repeat the
/// last sample and are ignored.
#[derive(Default)]
#[repr(C, align(64))] // the lane arrays first, each on its own cache line(s) ([`Aligned`])
pub(super) struct Packet {
    pub(super) pixel: [usize; PACKET_LANES],
    fx: [u32; PACKET_LANES],
    fy: [u32; PACKET_LANES],
    pub(super) index: [u32; PACKET_LANES],
    pub(super) sample: [u32; PACKET_LANES],
    pub(super) len: usize,
}

impl Packet {
    /// Camera samples `start` … `start + len − 1` of a tile pass over `pixels` at `spp`
    /// samples per pixel (sample j is sample j % spp of pixel j / spp); lanes ≥ `len` repeat
    /// the last one.
    #[inline(always)]
    pub(super) fn fill(
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

/// What a packet draws before anything else: the Philox blocks of its lanes' numbers (the
/// first `Context::kept_blocks`; the others uninitialised) and its camera rays.
#[repr(C, align(64))]
pub(super) struct Primary {
    pub(super) rays: RayLanes,
    pub(super) words: [MaybeUninit<[[u32; PACKET_LANES]; 4]>; MAX_BLOCKS],
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
pub(super) fn primary_kernel(ctx: &Context, packet: &Packet, pass: u32, out: &mut Primary) {
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
    // Two `map`s of single rows, not `block.map(…)`: an array's `map` over the four words
    // compiles to an out-of-line `try_map` call.
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
    pub(super) fn kept_blocks(&self) -> usize {
        let rs = self.rs;
        let numbers = rs.camera_sample_numbers(self.opts.lights, 1, Some(self.per_light));
        let blocks = numbers.div_ceil(4);
        blocks.min(MAX_BLOCKS)
    }
}

/// Blocks of four numbers per lane drawn together (2 + the lights' numbers ≤ 16); further
/// dimensions are drawn lane by lane.
const MAX_BLOCKS: usize = 4;
