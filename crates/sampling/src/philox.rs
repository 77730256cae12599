//! Counter-based random numbers: Philox4x32-10 (J. K. Salmon, M. A. Moraes, R. O. Dror,
//! D. E. Shaw, *Parallel Random Numbers: As Easy as 1, 2, 3*, SC 2011; the Random123 generator,
//! also `std::philox4x32` of C++26).
//!
//! A random number is a keyed bijection of its *counter*, not the next state of a sequence: the
//! 128-bit counter names the number (which stream, which position in it) and the 64-bit key is
//! the user's seed. Every (seed, stream, position) therefore gives an independent number without
//! any state shared between streams, and any number can be looked up directly. This replaces
//! seeding one PCG per pixel with the same state and a different stream increment, whose streams
//! are known to be correlated (Mitsuba scrambles (seed, lane) with TEA before seeding its PCG for
//! the same reason); Philox4x32-10 passes TestU01's BigCrush for every key and counter pattern its
//! authors tried, including the sequential counters used here.
//!
//! Layout of the counter: `[block, id₀, id₁, id₂]`. A stream is the key (seed) and the three id
//! words; its numbers are the four words of block 0, then of block 1, … (2³⁴ numbers per
//! stream). The renderer's stream of one camera sample is id = (sample, pixel, pass)
//! ([`CounterRng::camera_sample`]): every pixel, pass and sample has its own stream, and the
//! numbers inside it are the sample's dimensions — the "white noise" of a figure is
//! [`CounterRng::at`] of (pixel, sample, dimension).

/// Multipliers and Weyl key increments of Philox4x32 (Salmon et al. 2011, Table 2).
const M0: u64 = 0xD251_1F53;
const M1: u64 = 0xCD9E_8D57;
const W0: u32 = 0x9E37_79B9;
const W1: u32 = 0xBB67_AE85;

/// Philox4x32 with 10 rounds: a bijection of `counter` for every `key`. The renderer's
/// packets compute the same numbers sixteen lanes at once with [`philox4x32_10_pairs`].
#[inline]
pub fn philox4x32_10(counter: [u32; 4], key: [u32; 2]) -> [u32; 4] {
    let [mut x0, mut x1, mut x2, mut x3] = counter;
    let [mut k0, mut k1] = key;
    for round in 0..10 {
        if round > 0 {
            k0 = k0.wrapping_add(W0);
            k1 = k1.wrapping_add(W1);
        }
        let p0 = M0 * x0 as u64;
        let p1 = M1 * x2 as u64;
        let (hi0, lo0) = ((p0 >> 32) as u32, p0 as u32);
        let (hi1, lo1) = ((p1 >> 32) as u32, p1 as u32);
        (x0, x1, x2, x3) = (hi1 ^ x1 ^ k0, lo1, hi0 ^ x3 ^ k1, lo0);
    }
    [x0, x1, x2, x3]
}

/// The high and low words of the 32×32 → 64-bit products `m`·a and `m`·b of the two words
/// a, b packed in `w` (whichever half each is in), packed the same way: (hi(m·a) | hi(m·b),
/// lo(m·a) | lo(m·b)) in the halves of a and b. Two 32×32 → 64 multiplications of one half each
/// (`vpmuludq` on x86 takes the low half of each 64-bit lane), a shift and a select per result:
/// no widening or narrowing of lanes. `m` < 2³² is meant to be opaque to the compiler (see
/// [`philox4x32_10_pairs`]).
#[inline(always)]
fn mul_hi_lo_pairs(w: u64, m: u64) -> (u64, u64) {
    const LO: u64 = 0xFFFF_FFFF;
    let low = (w & LO) * m;
    let high = (w >> 32) * m;
    ((low >> 32) | (high & !LO), (low & LO) | (high << 32))
}

/// [`philox4x32_10`] of 2·P counters, two lanes per 64-bit word: lane j of word i of
/// `counter[r]` (and of the result) is the lane in that half (the two halves are treated
/// alike, so any packing of two lanes into a word, e.g. a transmute of `[u32; 2P]`, works).
/// The same numbers as [`philox4x32_10`] lane by lane, with the products in vector registers.
#[inline(always)]
pub fn philox4x32_10_pairs<const P: usize>(counter: [[u64; P]; 4], key: [u32; 2]) -> [[u64; P]; 4] {
    let [mut x0, mut x1, mut x2, mut x3] = counter;
    let [mut k0, mut k1] = key;
    // The multipliers hidden from the optimiser: with constants LLVM folds the shift of
    // `mul_hi_lo_pairs`'s second product into it ((w >> 32)·(M << 32)), which AVX-512 computes
    // with a slow 64-bit `vpmullq` (3 µops, latency 15) instead of `vpmuludq` and a shift.
    let [m0, m1] = std::hint::black_box([M0 as u32, M1 as u32]).map(u64::from);
    for round in 0..10 {
        if round > 0 {
            k0 = k0.wrapping_add(W0);
            k1 = k1.wrapping_add(W1);
        }
        let (kk0, kk1) = (k0 as u64 * 0x1_0000_0001, k1 as u64 * 0x1_0000_0001);
        for i in 0..P {
            let (hi0, lo0) = mul_hi_lo_pairs(x0[i], m0);
            let (hi1, lo1) = mul_hi_lo_pairs(x2[i], m1);
            (x0[i], x1[i], x2[i], x3[i]) = (hi1 ^ x1[i] ^ kk0, lo1, hi0 ^ x3[i] ^ kk1, lo0);
        }
    }
    [x0, x1, x2, x3]
}

/// The key of a 64-bit seed: its low and high words.
#[inline]
fn key_of(seed: u64) -> [u32; 2] {
    [seed as u32, (seed >> 32) as u32]
}

/// One stream of uniform numbers: Philox of the counters (block, id) under the seed's key, for
/// block = 0, 1, 2, … Streams of different (seed, id) are independent.
#[derive(Clone, Debug)]
pub struct CounterRng {
    key: [u32; 2],
    id: [u32; 3],
    /// Block of `words`.
    block: u32,
    words: [u32; 4],
    /// Next unused word of `words` (4: compute the next block first).
    next: u8,
}

impl CounterRng {
    /// The stream `id` of `seed`.
    pub fn new(seed: u64, id: [u32; 3]) -> Self {
        Self {
            key: key_of(seed),
            id,
            block: 0,
            words: [0; 4],
            next: 4,
        }
    }

    /// The stream of one camera sample: sample index within its pass, full-film pixel index,
    /// pass. Its numbers are the sample's dimensions in the order they are drawn.
    pub fn camera_sample(seed: u64, pass: u32, pixel: u32, sample: u32) -> Self {
        Self::new(seed, [sample, pixel, pass])
    }

    /// Number `index` of stream `id` of `seed`, without drawing the ones before it: what
    /// [`Self::next_u32`] returns as the (index + 1)-th draw.
    pub fn at(seed: u64, id: [u32; 3], index: u64) -> u32 {
        debug_assert!(index < 1 << 34, "a stream has 2^34 numbers");
        let block = (index >> 2) as u32;
        philox4x32_10([block, id[0], id[1], id[2]], key_of(seed))[(index & 3) as usize]
    }

    /// Words 4·`block` … 4·`block` + 3 of the camera-sample streams
    /// [`Self::camera_sample`]`(seed, pass, pixel[i], sample[i])` for 16 lanes at once: word j
    /// of lane i is `out[j][i]`, what the lane's stream returns as its (4·block + j + 1)-th
    /// draw. Two lanes per 64-bit word ([`philox4x32_10_pairs`]), vectorised where the caller
    /// is compiled for SIMD.
    #[inline(always)]
    pub fn camera_sample_block(
        seed: u64,
        pass: u32,
        pixel: &[u32; 16],
        sample: &[u32; 16],
        block: u32,
    ) -> [[u32; 16]; 4] {
        // Which lane of a pair lands in which half of its word depends on the byte order and
        // does not matter (`philox4x32_10_pairs` treats both halves alike).
        // SAFETY: 64 bytes reinterpreted; every bit pattern is a valid [u64; 8].
        let pairs = |x: &[u32; 16]| -> [u64; 8] { unsafe { std::mem::transmute(*x) } };
        let out = Self::camera_sample_pairs(seed, pass, pairs(pixel), pairs(sample), block);
        // SAFETY: as above, back (every bit pattern is a valid [u32; 16]).
        out.map(|w| unsafe { std::mem::transmute::<[u64; 8], [u32; 16]>(w) })
    }

    /// [`Self::camera_sample_block`] for 2·P lanes, two per 64-bit word: the low and the high
    /// half of `pixel[i]` and `sample[i]` are two lanes' pixel and sample indices, and those
    /// halves of `out[j][i]` their word j (P/8 independent chains fill 512-bit vectors).
    #[inline(always)]
    pub fn camera_sample_pairs<const P: usize>(
        seed: u64,
        pass: u32,
        pixel: [u64; P],
        sample: [u64; P],
        block: u32,
    ) -> [[u64; P]; 4] {
        let splat = |c: u32| [c as u64 * 0x1_0000_0001; P];
        philox4x32_10_pairs([splat(block), sample, pixel, splat(pass)], key_of(seed))
    }

    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        if self.next >= 4 {
            let [a, b, c] = self.id;
            self.words = philox4x32_10([self.block, a, b, c], self.key);
            debug_assert!(self.block < u32::MAX, "a stream has 2^34 numbers");
            self.block = self.block.wrapping_add(1);
            self.next = 0;
        }
        let w = self.words[self.next as usize];
        self.next += 1;
        w
    }

    /// Uniform in [0, 1): 24 random mantissa bits, never 1.0.
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        unit_f32(self.next_u32())
    }

    /// Uniform in [0, 1) with 53 bits (two numbers of the stream).
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        let hi = (self.next_u32() as u64) << 21;
        let lo = (self.next_u32() >> 11) as u64;
        (hi | lo) as f64 * (1.0 / 9_007_199_254_740_992.0)
    }
}

/// The top 24 bits of a random word as a uniform number in [0, 1) (exactly representable).
#[inline]
pub fn unit_f32(word: u32) -> f32 {
    (word >> 8) as f32 * (1.0 / 16_777_216.0)
}

#[cfg(test)]
mod tests {
    //! Known answers, and a small battery of the statistical properties the renderer relies on
    //! (fixed seeds; each test at the level α_t = 1 − (1 − 0.01)^(1/m) for the m tests below,
    //! suite-wide α = 0.01): equidistribution in 1, 2 and 3 dimensions, serial correlation,
    //! per-bit frequency, and independence across neighbouring streams (pixels, passes,
    //! samples, seeds) — the property the pixel and tile tests of image comparison assume.
    use super::*;
    use statrs::distribution::{ChiSquared, ContinuousCDF, Normal};

    /// Statistical tests in this module (for the Šidák level).
    const TESTS: f64 = 3.0 + 8.0 + 32.0 + 2.0 * NEIGHBOUR_KINDS as f64;
    const NEIGHBOUR_KINDS: usize = 6;

    fn alpha_t() -> f64 {
        -((-0.01f64).ln_1p() / TESTS).exp_m1()
    }

    fn chi2_p(counts: &[u64], n: u64) -> f64 {
        let e = n as f64 / counts.len() as f64;
        let stat: f64 = counts.iter().map(|&o| (o as f64 - e).powi(2) / e).sum();
        ChiSquared::new(counts.len() as f64 - 1.0).unwrap().sf(stat)
    }

    fn two_sided_normal_p(z: f64) -> f64 {
        2.0 * Normal::new(0.0, 1.0).unwrap().sf(z.abs())
    }

    /// Pearson correlation of paired uniforms, as a z-score (√n · r; r ~ N(0, 1/n) under
    /// independence).
    fn correlation_z(pairs: impl Iterator<Item = (f64, f64)>) -> f64 {
        let (mut n, mut sxy, mut sx, mut sy, mut sxx, mut syy) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        for (x, y) in pairs {
            n += 1.0;
            sx += x;
            sy += y;
            sxy += x * y;
            sxx += x * x;
            syy += y * y;
        }
        let cov = sxy / n - sx / n * (sy / n);
        let r = cov / ((sxx / n - (sx / n).powi(2)) * (syy / n - (sy / n).powi(2))).sqrt();
        r * n.sqrt()
    }

    #[test]
    fn known_answers_of_random123() {
        // Random123's kat_vectors, "philox4x32 10".
        assert_eq!(
            philox4x32_10([0; 4], [0; 2]),
            [0x6627_e8d5, 0xe169_c58d, 0xbc57_ac4c, 0x9b00_dbd8]
        );
        assert_eq!(
            philox4x32_10([u32::MAX; 4], [u32::MAX; 2]),
            [0x408f_276d, 0x41c8_3b0e, 0xa20b_c7c6, 0x6d54_51fd]
        );
        assert_eq!(
            philox4x32_10(
                [0x243f_6a88, 0x85a3_08d3, 0x1319_8a2e, 0x0370_7344],
                [0xa409_3822, 0x299f_31d0]
            ),
            [0xd16c_fe09, 0x94fd_cceb, 0x5001_e420, 0x2412_6ea1]
        );
    }

    /// The lane form is the scalar function on every lane; camera-sample blocks are the
    /// streams' draws.
    #[test]
    fn lanes_equal_the_scalar_generator() {
        let pixel: [u32; 16] = std::array::from_fn(|i| 1000 + 7 * i as u32);
        let sample: [u32; 16] = std::array::from_fn(|i| (i as u32 * 5) % 3);
        for block in 0..3 {
            let words =
                CounterRng::camera_sample_block(0xDEAD_BEEF_0123, 4, &pixel, &sample, block);
            for i in 0..16 {
                let mut rng = CounterRng::camera_sample(0xDEAD_BEEF_0123, 4, pixel[i], sample[i]);
                for _ in 0..4 * block {
                    rng.next_u32();
                }
                for w in &words {
                    assert_eq!(w[i], rng.next_u32(), "block {block}, lane {i}");
                }
            }
            // Pairs: both halves of every word, 2·32 samples of one pixel.
            let pairs: [u64; 32] =
                std::array::from_fn(|i| (3 * i as u64) | (3 * i as u64 + 1) << 32);
            let pixel = [1234 * 0x1_0000_0001; 32];
            let words = CounterRng::camera_sample_pairs(0xDEAD_BEEF_0123, 4, pixel, pairs, block);
            for (i, &pair) in pairs.iter().enumerate() {
                for h in 0..2 {
                    let sample = (pair >> (32 * h)) as u32;
                    let mut rng = CounterRng::camera_sample(0xDEAD_BEEF_0123, 4, 1234, sample);
                    for _ in 0..4 * block {
                        rng.next_u32();
                    }
                    for w in &words {
                        let word = (w[i] >> (32 * h)) as u32;
                        assert_eq!(word, rng.next_u32(), "block {block}, sample {sample}");
                    }
                }
            }
        }
    }

    #[test]
    fn streams_are_deterministic_and_addressable() {
        let mut a = CounterRng::new(42, [7, 8, 9]);
        let mut b = CounterRng::new(42, [7, 8, 9]);
        let mut c = CounterRng::new(42, [7, 8, 10]);
        let mut differ = 0;
        for i in 0..1000u64 {
            let x = a.next_u32();
            assert_eq!(x, b.next_u32());
            assert_eq!(x, CounterRng::at(42, [7, 8, 9], i));
            differ += usize::from(x != c.next_u32());
        }
        assert!(differ > 990);
        let mut r = CounterRng::camera_sample(1, 2, 3, 4);
        for _ in 0..1000 {
            let (x, y) = (r.next_f32(), r.next_f64());
            assert!((0.0..1.0).contains(&x) && (0.0..1.0).contains(&y));
        }
        assert_eq!(unit_f32(u32::MAX), 1.0 - 1.0 / 16_777_216.0);
    }

    /// Equidistribution of one stream's consecutive k-tuples (k = 1, 2, 3): χ² of 4096 cells
    /// (4096, 64², 16³) from 2²¹ tuples.
    #[test]
    fn equidistribution_of_tuples() {
        let alpha = alpha_t();
        for (k, bits) in [(1usize, 12u32), (2, 6), (3, 4)] {
            let mut rng = CounterRng::new(0x5eed, [k as u32, 0, 0]);
            let tuples = 1u64 << 21;
            let mut counts = vec![0u64; 4096];
            for _ in 0..tuples {
                let mut cell = 0usize;
                for _ in 0..k {
                    cell = (cell << bits) | (rng.next_u32() >> (32 - bits)) as usize;
                }
                counts[cell] += 1;
            }
            let p = chi2_p(&counts, tuples);
            eprintln!("equidistribution k = {k}: p = {p:.3}");
            assert!(p >= alpha, "k = {k}: p = {p:e} < {alpha:e}");
        }
    }

    /// Serial correlation of one stream at lags 1…8 (2²⁰ numbers).
    #[test]
    fn serial_correlation() {
        let alpha = alpha_t();
        let mut rng = CounterRng::new(2021, [1, 2, 3]);
        let xs: Vec<f64> = (0..1 << 20).map(|_| rng.next_f64()).collect();
        for lag in 1..=8 {
            let z = correlation_z((0..xs.len() - lag).map(|i| (xs[i], xs[i + lag])));
            let p = two_sided_normal_p(z);
            eprintln!("serial correlation lag {lag}: z = {z:.2}");
            assert!(p >= alpha, "lag {lag}: z = {z}");
        }
    }

    /// Every bit of the output is 1 with probability ½ (binomial z-test per bit, 2²⁰ words
    /// spread over 2¹⁸ streams of 4 numbers, as a renderer uses them).
    #[test]
    fn bit_frequencies() {
        let alpha = alpha_t();
        let mut ones = [0u64; 32];
        let n = 1u64 << 20;
        for pixel in 0..(n / 4) as u32 {
            let mut r = CounterRng::camera_sample(77, 0, pixel, 0);
            for _ in 0..4 {
                let w = r.next_u32();
                for (b, o) in ones.iter_mut().enumerate() {
                    *o += u64::from(w >> b & 1);
                }
            }
        }
        for (b, &o) in ones.iter().enumerate() {
            let z = (o as f64 - n as f64 / 2.0) / (n as f64 / 4.0).sqrt();
            assert!(two_sided_normal_p(z) >= alpha, "bit {b}: z = {z}");
        }
    }

    /// Correlation z and pair-equidistribution p (64² cells) of the same dimension of two
    /// streams, over 2¹⁷ stream pairs × dimensions 0…3.
    fn pair_statistics(pair: impl Fn(u32) -> ([u32; 4], [u32; 4])) -> (f64, f64) {
        let mut xs = Vec::with_capacity(1 << 19);
        for i in 0..1u32 << 17 {
            let (a, b) = pair(i);
            xs.extend(a.into_iter().zip(b));
        }
        let z = correlation_z(
            xs.iter()
                .map(|&(a, b)| (unit_f32(a) as f64, unit_f32(b) as f64)),
        );
        let mut counts = vec![0u64; 4096];
        for &(a, b) in &xs {
            counts[((a >> 26) << 6 | b >> 26) as usize] += 1;
        }
        (z, chi2_p(&counts, xs.len() as u64))
    }

    fn first_four(mut r: CounterRng) -> [u32; 4] {
        [r.next_u32(), r.next_u32(), r.next_u32(), r.next_u32()]
    }

    /// Independence across neighbouring streams: the same dimension of streams that differ in
    /// the pixel (by 1, by 2, by a film row of 1024), the pass, the sample index or the seed.
    #[test]
    fn neighbouring_streams_are_independent() {
        let alpha = alpha_t();
        let s = |seed: u64, pass: u32, pixel: u32, sample: u32| {
            first_four(CounterRng::camera_sample(seed, pass, pixel, sample))
        };
        type Pair = Box<dyn Fn(u32) -> ([u32; 4], [u32; 4])>;
        let kinds: [(&str, Pair); NEIGHBOUR_KINDS] = [
            (
                "pixel+1",
                Box::new(move |i| (s(9, 3, i, 5), s(9, 3, i + 1, 5))),
            ),
            (
                "pixel+2",
                Box::new(move |i| (s(9, 3, i, 5), s(9, 3, i + 2, 5))),
            ),
            (
                "pixel+1024",
                Box::new(move |i| (s(9, 3, i, 5), s(9, 3, i + 1024, 5))),
            ),
            (
                "pass+1",
                Box::new(move |i| (s(9, i, 1000, 5), s(9, i + 1, 1000, 5))),
            ),
            (
                "sample+1",
                Box::new(move |i| (s(9, 3, 1000, i), s(9, 3, 1000, i + 1))),
            ),
            (
                "seed+1",
                Box::new(move |i| (s(i as u64, 3, 1000, 5), s(i as u64 + 1, 3, 1000, 5))),
            ),
        ];
        for (name, pair) in kinds {
            let (z, p) = pair_statistics(pair);
            eprintln!("neighbouring {name}: correlation z = {z:.2}, pair χ² p = {p:.3}");
            assert!(two_sided_normal_p(z) >= alpha, "{name}: z = {z}");
            assert!(p >= alpha, "{name}: p = {p:e}");
        }
    }

    /// Power of the battery: a per-pixel scheme with correlated streams — one PCG32 per pixel, all with the
    /// same state (seed and pass hashed by SplitMix64) and the pixel index as stream increment —
    /// fails the pair test for pixels two apart (χ² ≈ 19 000 on 4095 dof).
    #[test]
    fn same_seed_pcg_streams_fail_the_pair_test() {
        use crate::rng::Pcg32;
        fn splitmix(mut z: u64) -> u64 {
            z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }
        let state = splitmix(9 ^ splitmix(3));
        let pcg = |pixel: u32| {
            let mut r = Pcg32::new(state, pixel as u64);
            [r.next_u32(), r.next_u32(), r.next_u32(), r.next_u32()]
        };
        let (z, p) = pair_statistics(|i| (pcg(i), pcg(i + 2)));
        eprintln!("same-seed PCG, pixels two apart: z = {z:.2}, pair χ² p = {p:e}");
        assert!(p < alpha_t(), "p = {p:e}");
    }
}
