//! Primary samples ξ of a render: white noise, blue noise and jittered blue noise, all from one
//! interface ([`NoiseSource`] → [`SampleStream`]) so that every renderer takes its ξ from the
//! same place.
//!
//! - **White**: the camera sample's own counter-based Philox stream
//!   ([`CounterRng::camera_sample`]): every pixel, pass and sample independent. This is the
//!   default and reproduces the renderer's numbers exactly.
//! - **Blue**: every dimension k of a camera sample reads one of 256 blue-noise dither arrays
//!   (64 slices × 4 channels of 64×64 RGBA, generated in-project by void-and-cluster, see
//!   [`void_and_cluster`]) at the pixel, toroidally shifted. Array, shift (ox, oy) and a 12-bit
//!   sub-rank offset u are random per (seed, pass, sample, k) and shared by all pixels, so the
//!   error pattern of one pass is blue in screen space, while at any one pixel
//!   ξ = (rank(x + ox, y + oy) + u/4096)/4096 is exactly uniform on the 24-bit grid across
//!   passes (a uniform shift visits every rank once) and independent across dimensions and
//!   samples: every pixel's estimator is unbiased, and its variance estimate from samples or
//!   passes is valid.
//! - **Blue, jittered** (the paper's "jittered uniform" stratification): dimension k of sample
//!   i of the N samples of a pass is (ξ₀ + i)/N with ξ₀ the blue-noise value of (pass, k),
//!   shared by the N samples. Each ξ_i is uniform on its stratum [i/N, (i+1)/N), so the mean of
//!   the N samples is unbiased for any one-dimensional integrand — which is what a light sample
//!   is. The film position (two dimensions, one integrand) is never jittered this way (the
//!   diagonal strata would bias it); it uses plain blue noise. Samples of one pass are then not
//!   independent: estimate the variance from passes (P > 1).
//!
//! The blue-noise table is generated at first use (~1.2 CPU-seconds, spread over the cores:
//! ~0.6 s on two idle cores; 2 MiB of memory),
//! not stored in the repository; it is deterministic (integer energies, no libm) and the same on
//! every platform.

pub mod spectrum;
pub mod void_and_cluster;

use crate::philox::{philox4x32_10, CounterRng};
use std::sync::OnceLock;
use void_and_cluster::{dither_array, SIDE, TEXELS};

/// Slices of the blue-noise table (the paper's texture array).
pub const SLICES: usize = 64;
/// Channels per slice (RGBA).
pub const CHANNELS: usize = 4;
/// Dither arrays of the table.
pub const ARRAYS: usize = SLICES * CHANNELS;

/// Where the ξ of a render come from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Noise {
    /// Independent uniform numbers (counter-based Philox streams).
    #[default]
    White,
    /// Blue noise, a random toroidal shift per pass, sample and dimension.
    Blue,
    /// Blue noise stratified over the samples of a pass: (ξ₀ + i)/N.
    BlueJittered,
}

impl Noise {
    pub const ALL: [Noise; 3] = [Noise::White, Noise::Blue, Noise::BlueJittered];

    /// Name on the command line and in image metadata.
    pub fn name(self) -> &'static str {
        match self {
            Noise::White => "white",
            Noise::Blue => "blue",
            Noise::BlueJittered => "blue-jittered",
        }
    }
}

impl std::fmt::Display for Noise {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Noise {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|n| n.name() == s)
            .ok_or_else(|| {
                format!("unknown noise '{s}' (expected one of: white, blue, blue-jittered)")
            })
    }
}

/// 256 blue-noise dither arrays of 64×64 ranks (0…4095).
pub struct BlueNoiseTable {
    ranks: Vec<u16>,
}

impl BlueNoiseTable {
    /// Generate the table (deterministic; the arrays are spread over the available threads).
    pub fn generate() -> Self {
        let threads = std::thread::available_parallelism()
            .map_or(1, |n| n.get())
            .min(ARRAYS);
        let mut ranks = vec![0u16; ARRAYS * TEXELS];
        std::thread::scope(|scope| {
            for (t, chunk) in ranks
                .chunks_mut(TEXELS * ARRAYS.div_ceil(threads))
                .enumerate()
            {
                scope.spawn(move || {
                    let first = t * ARRAYS.div_ceil(threads);
                    for (i, array) in chunk.chunks_mut(TEXELS).enumerate() {
                        array.copy_from_slice(&dither_array(array_seed(first + i)));
                    }
                });
            }
        });
        Self { ranks }
    }

    /// Rank of texel (x, y) (taken modulo 64) of array `array`.
    #[inline]
    pub fn rank(&self, array: usize, x: u32, y: u32) -> u16 {
        let (x, y) = (x as usize % SIDE, y as usize % SIDE);
        self.ranks[array * TEXELS + y * SIDE + x]
    }

    /// The ranks of one array, row-major.
    pub fn array(&self, array: usize) -> &[u16] {
        &self.ranks[array * TEXELS..(array + 1) * TEXELS]
    }
}

/// Seed of dither array `i` of the table.
fn array_seed(i: usize) -> u64 {
    0x626c_7565_0000_0000 | i as u64 // "blue"
}

/// The table, generated once per process.
pub fn blue_noise_table() -> &'static BlueNoiseTable {
    static TABLE: OnceLock<BlueNoiseTable> = OnceLock::new();
    TABLE.get_or_init(BlueNoiseTable::generate)
}

/// Tags of the counters of the per-dimension randomisation (distinct from the camera streams,
/// whose fourth counter word is a pass index, by a different key).
const TAG_SAMPLE: u32 = 0x7368_6966; // "shif"
const TAG_PASS: u32 = 0x6a69_7474; // "jitt"
/// Key offset of the randomisation (so that its numbers are not the white stream's).
const KEY_SALT: u64 = 0x9e37_79b9_7f4a_7c15;

/// The source of the ξ of one render pass layout: noise kind, seed and the samples per pixel of
/// a pass (the strata of jittered noise).
#[derive(Clone, Copy)]
pub struct NoiseSource {
    noise: Noise,
    seed: u64,
    spp: u32,
    table: Option<&'static BlueNoiseTable>,
}

impl std::fmt::Debug for NoiseSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NoiseSource")
            .field("noise", &self.noise)
            .field("seed", &self.seed)
            .field("spp", &self.spp)
            .finish()
    }
}

impl NoiseSource {
    /// `spp_per_pass` ≥ 1: samples per pixel in one pass. Blue noise generates the table on
    /// first use.
    pub fn new(noise: Noise, seed: u64, spp_per_pass: u32) -> Self {
        debug_assert!(spp_per_pass >= 1);
        Self {
            noise,
            seed,
            spp: spp_per_pass.max(1),
            table: (noise != Noise::White).then(blue_noise_table),
        }
    }

    pub fn noise(&self) -> Noise {
        self.noise
    }

    /// The numbers of camera sample `sample` (of the pass) of pixel (x, y) (full-film
    /// coordinates; `pixel_index` = y · film width + x) in pass `pass`.
    #[inline]
    pub fn stream(
        &self,
        x: u32,
        y: u32,
        pixel_index: u32,
        pass: u32,
        sample: u32,
    ) -> SampleStream<'_> {
        SampleStream {
            white: CounterRng::camera_sample(self.seed, pass, pixel_index, sample),
            source: self,
            x,
            y,
            pass,
            sample,
            dim: 0,
        }
    }

    /// The blue-noise value of dimension `dim` at pixel (x, y) for the randomisation counter
    /// `counter`: a 24-bit integer, uniform on 0 … 2²⁴ − 1 over the randomisation.
    #[inline]
    fn blue24(&self, table: &BlueNoiseTable, x: u32, y: u32, counter: [u32; 4]) -> u32 {
        let key = self.seed ^ KEY_SALT;
        let [w0, w1, _, _] = philox4x32_10(counter, [key as u32, (key >> 32) as u32]);
        let array = (w0 & 0xff) as usize;
        let (ox, oy) = ((w0 >> 8) & 63, (w0 >> 14) & 63);
        let rank = table.rank(array, x.wrapping_add(ox), y.wrapping_add(oy)) as u32;
        rank << 12 | w1 >> 20
    }
}

/// A source of the uniform numbers of one camera sample, one light-sampling dimension per call:
/// the white stream ([`CounterRng`]) or a noise-shaped one ([`SampleStream`]). The shading code
/// draws through it, so every noise reaches every sampling method.
pub trait Uniforms {
    /// The next dimension, uniform in [0, 1).
    fn next_f32(&mut self) -> f32;
}

impl Uniforms for CounterRng {
    #[inline]
    fn next_f32(&mut self) -> f32 {
        CounterRng::next_f32(self)
    }
}

impl Uniforms for SampleStream<'_> {
    #[inline]
    fn next_f32(&mut self) -> f32 {
        SampleStream::next_f32(self)
    }
}

/// The uniform numbers of one camera sample, dimension by dimension.
pub struct SampleStream<'a> {
    white: CounterRng,
    source: &'a NoiseSource,
    x: u32,
    y: u32,
    pass: u32,
    sample: u32,
    /// Next dimension (blue noise).
    dim: u32,
}

const UNIT_24: f32 = 1.0 / 16_777_216.0;

impl SampleStream<'_> {
    /// The film position inside the pixel (the first two dimensions): white or blue noise,
    /// never stratified across the samples of a pass.
    #[inline]
    pub fn film_position(&mut self) -> (f32, f32) {
        // u before v: a tuple's operands are evaluated left to right.
        (self.next_f32_unstratified(), self.next_f32_unstratified())
    }

    /// The next dimension: the primary sample of a one-dimensional estimator that the caller
    /// sums linearly (one light sample), uniform in [0, 1). Jittered noise stratifies it over
    /// the samples of the pass.
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        match (self.source.noise, self.source.table) {
            (Noise::White, _) | (_, None) => self.white.next_f32(),
            (Noise::Blue, Some(table)) => self.blue(table, false),
            (Noise::BlueJittered, Some(table)) => self.blue(table, true),
        }
    }

    /// The next dimension, uniform in [0, 1) and never stratified across the samples of a
    /// pass (white, or plain blue noise): for a discrete choice whose outcome's own numbers are
    /// stratified (one light per light sample), which jittering both would bias.
    #[inline]
    pub fn next_f32_unstratified(&mut self) -> f32 {
        match (self.source.noise, self.source.table) {
            (Noise::White, _) | (_, None) => self.white.next_f32(),
            (_, Some(table)) => self.blue(table, false),
        }
    }

    /// A white number in [0, 1) with 53 bits, for auxiliary choices that are not stratified
    /// (the estimate of a line the camera sees).
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        self.white.next_f64()
    }

    #[inline]
    fn blue(&mut self, table: &BlueNoiseTable, jittered: bool) -> f32 {
        let dim = self.dim;
        self.dim += 1;
        if jittered {
            let v = self
                .source
                .blue24(table, self.x, self.y, [dim, 0, self.pass, TAG_PASS]);
            // ⌊(v + i·2²⁴)/N⌋ on the 24-bit grid: stratum i of N, never 1.0.
            let n = self.source.spp as u64;
            let i = (self.sample as u64).min(n - 1);
            let j = ((v as u64 + (i << 24)) / n) as u32;
            j as f32 * UNIT_24
        } else {
            let v = self.source.blue24(
                table,
                self.x,
                self.y,
                [dim, self.sample, self.pass, TAG_SAMPLE],
            );
            v as f32 * UNIT_24
        }
    }
}

#[cfg(test)]
mod tests;
