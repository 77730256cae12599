//! The order in which a tile pass takes a pixel's camera samples: by film position, cells of a
//! grid over the pixel in Morton order, so that the sixteen lanes of a packet lie in a small
//! part of the pixel. Their camera rays then meet the same few subtrees of the BVH, and their
//! shadow rays start close together: where a pixel covers many triangles, the packet walks no
//! longer split into one-ray walks near the leaves.
//!
//! The order changes which samples share a packet, not the image: each lane still draws its
//! own sample's numbers (its Philox stream is the sample index's), and the radiance of a
//! pixel's samples is held until the pixel is done, then pushed into its accumulator in sample
//! order, as the scalar path pushes it — the same bits.

use super::primary::Packet;
use super::{radiance_quad, Lanes3};
use crate::bvh::Bvh;
use crate::film::Welford;
use linlight_sampling::philox::{unit_f32, CounterRng};
use linlight_simd::PACKET_LANES;

/// Fewest samples per pixel and pass that are reordered: at least two packets per pixel.
const MIN_SPP: usize = 2 * PACKET_LANES;

/// Most samples per pixel and pass that are reordered: the order's buffers take about 48 bytes
/// per sample (3 MiB per worker thread at 2¹⁶).
const MAX_SPP: usize = 1 << 16;

/// Fewest primitives per rendered pixel for which ranking pays ([`pays`]).
const PRIMITIVES_PER_PIXEL: u64 = 2;

/// Ways each cell's count is split (see `rank`).
const SPLIT: usize = 4;

/// Samples ranked at once: four independent Philox chains of sixteen lanes.
const CHUNK: usize = 4 * PACKET_LANES;

/// Samples per grid cell the grid is sized for (the cells are filled at random: a packet
/// spans a few neighbouring cells along the Morton curve).
const PER_CELL: usize = 4;

/// The grid, a pixel's samples by rank, and the radiance of the samples of the pixels whose
/// samples are in flight. Two slots (pixel parity): a packet spans at most two pixels (spp ≥
/// [`MIN_SPP`]), and packets are filled, then accumulated, in rank order.
pub(super) struct SampleOrder {
    spp: usize,
    /// Cells per side of the grid (a power of two).
    side: u32,
    /// The pixel (tile index) whose ranks each slot holds.
    ranked: [usize; 2],
    /// Slot s, rank r: the sample index at `s · spp + r`.
    samples: Vec<u32>,
    /// Slot s, sample i: its radiance quad (`radiance_quad`) at `s · spp + i`.
    held: Vec<[f32; 4]>,
    /// Scratch of `rank`: each sample's cell, and the cells' counts.
    cell: Vec<u32>,
    counts: Vec<u32>,
}

/// The bits of x (< 2¹⁶) spread to the even positions.
#[inline(always)]
fn spread(x: u32) -> u32 {
    let mut v = x & 0xffff;
    v = (v | (v << 8)) & 0x00ff_00ff;
    v = (v | (v << 4)) & 0x0f0f_0f0f;
    v = (v | (v << 2)) & 0x3333_3333;
    (v | (v << 1)) & 0x5555_5555
}

/// Whether ranking pays on a render of `pixels` pixels over `bvh`: a large tree
/// ([`Bvh::is_large`]) with at least [`PRIMITIVES_PER_PIXEL`] primitives per pixel, so that a
/// pixel's footprint holds enough triangles for its packets to split. Elsewhere a packet's
/// rays meet the same few leaves in any order, and ranking costs more than it saves.
pub(super) fn pays(bvh: &Bvh, pixels: u64) -> bool {
    #[cfg(test)]
    if ALWAYS.get() {
        return true;
    }
    bvh.is_large() && bvh.len() as u64 >= PRIMITIVES_PER_PIXEL * pixels
}

#[cfg(test)]
thread_local! {
    /// Tests: every render of this thread ranks, whatever [`pays`] says.
    pub(super) static ALWAYS: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

impl SampleOrder {
    /// The order for `spp` samples per pixel and pass, or `None` (samples in index order)
    /// outside [`MIN_SPP`] … [`MAX_SPP`].
    pub(super) fn new(spp: usize) -> Option<Self> {
        if !(MIN_SPP..=MAX_SPP).contains(&spp) {
            return None;
        }
        let mut side = 1u32;
        while (2 * side as usize).pow(2) * PER_CELL <= spp {
            side *= 2;
        }
        Some(Self {
            spp,
            side,
            ranked: [usize::MAX; 2],
            samples: vec![0; 2 * spp],
            held: vec![[0.0; 4]; 2 * spp],
            cell: vec![0; spp],
            counts: vec![0; SPLIT * (side * side) as usize + 1],
        })
    }

    /// Rank the samples of pixel `pixel` (tile index; `index` its full-film index) into its
    /// slot: by the Morton code of their film position's cell, then by sample index.
    #[inline(always)]
    fn rank(&mut self, pixel: usize, index: u32, seed: u64, pass: u32) {
        let (spp, side) = (self.spp, self.side as f32);
        let slot = pixel & 1;
        self.counts.fill(0);
        for start in (0..spp).step_by(CHUNK) {
            // Two samples per word, the last one repeated past the end.
            let mut pairs = [0u64; CHUNK / 2];
            for (i, pair) in pairs.iter_mut().enumerate() {
                let s = |k: usize| (start + k).min(spp - 1) as u64;
                *pair = s(2 * i) | s(2 * i + 1) << 32;
            }
            // Block 0, words 0 and 1: the film position (as `primary_kernel` draws it).
            let pixel = [u64::from(index) * 0x1_0000_0001; CHUNK / 2];
            let block = CounterRng::camera_sample_pairs(seed, pass, pixel, pairs, 0);
            let mut cells = [0u32; CHUNK];
            for (i, pair) in cells.chunks_exact_mut(2).enumerate() {
                for (h, cell) in pair.iter_mut().enumerate() {
                    let word = |j: usize| (block[j][i] >> (32 * h)) as u32;
                    let x = (unit_f32(word(0)) * side) as u32;
                    let y = (unit_f32(word(1)) * side) as u32;
                    *cell = spread(x) | spread(y) << 1;
                }
            }
            let n = CHUNK.min(spp - start);
            self.cell[start..start + n].copy_from_slice(&cells[..n]);
        }
        // A counting sort by cell, each cell's count split four ways by sample index (i mod
        // 4): neighbouring samples of one cell then update different counts, not one count
        // through memory back to back.
        for (i, &c) in self.cell.iter().enumerate() {
            self.counts[SPLIT * c as usize + i % SPLIT + 1] += 1;
        }
        for c in 1..self.counts.len() {
            self.counts[c] += self.counts[c - 1];
        }
        let samples = &mut self.samples[slot * spp..(slot + 1) * spp];
        for (i, &c) in self.cell.iter().enumerate() {
            let at = &mut self.counts[SPLIT * c as usize + i % SPLIT];
            samples[*at as usize] = i as u32;
            *at += 1;
        }
        self.ranked[slot] = pixel;
    }

    /// Turn the ranks that [`Packet::fill`] put into `packet.sample` into sample indices.
    #[inline(always)]
    pub(super) fn apply(&mut self, packet: &mut Packet, seed: u64, pass: u32) {
        for k in 0..PACKET_LANES {
            let pixel = packet.pixel[k];
            let slot = pixel & 1;
            if self.ranked[slot] != pixel {
                self.rank(pixel, packet.index[k], seed, pass);
            }
            let rank = packet.sample[k] as usize;
            debug_assert!(rank < self.spp, "rank {rank} of {} samples", self.spp);
            packet.sample[k] = self.samples[slot * self.spp + rank];
        }
    }

    /// Hold the radiance `total` of the packet's lanes, which covers ranks `start` … `start +
    /// packet.len − 1` of the tile pass, and push every pixel whose last rank it holds into
    /// `acc`, its samples in index order.
    #[inline(always)]
    pub(super) fn accumulate(
        &mut self,
        acc: &mut [Welford],
        packet: &Packet,
        total: &Lanes3,
        start: usize,
    ) {
        let spp = self.spp;
        for k in 0..packet.len {
            let at = (packet.pixel[k] & 1) * spp + packet.sample[k] as usize;
            self.held[at] = radiance_quad(total, k);
        }
        let done = start / spp..(start + packet.len) / spp;
        for (pixel, acc) in done.clone().zip(&mut acc[done]) {
            let slot = pixel & 1;
            let mut w = *acc;
            for x in &self.held[slot * spp..(slot + 1) * spp] {
                w.push_quad(x.map(|c| c as f64));
            }
            *acc = w;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every pixel's ranks are a permutation of its samples, and consecutive ranks are close
    /// on the film: a packet's sixteen samples span a small part of the pixel.
    #[test]
    fn ranks_permute_the_samples_and_group_them_by_position() {
        let spp = 1024;
        let mut order = SampleOrder::new(spp).expect("reordered");
        assert_eq!(order.side, 16);
        order.rank(5, 1234, 7, 2);
        let samples = &order.samples[spp..2 * spp];
        let mut sorted = samples.to_vec();
        sorted.sort_unstable();
        assert!(sorted.iter().enumerate().all(|(i, &s)| s == i as u32));
        let position = |s: u32| {
            let sample = [s; PACKET_LANES];
            let b = CounterRng::camera_sample_block(7, 2, &[1234; PACKET_LANES], &sample, 0);
            (unit_f32(b[0][0]), unit_f32(b[1][0]))
        };
        // Mean bounding-box area of a packet's positions: about (15/17)² ≈ 0.78 of the pixel
        // for sixteen uniform points (index order), here a few cells of 1/256.
        let packets = samples.chunks(PACKET_LANES);
        let area: f32 = packets
            .map(|p| {
                let (mut lo, mut hi) = ((1.0f32, 1.0f32), (0.0f32, 0.0f32));
                for &s in p {
                    let (u, v) = position(s);
                    (lo, hi) = ((lo.0.min(u), lo.1.min(v)), (hi.0.max(u), hi.1.max(v)));
                }
                (hi.0 - lo.0) * (hi.1 - lo.1)
            })
            .sum::<f32>()
            / (spp / PACKET_LANES) as f32;
        assert!(area < 0.05, "{area}");
        assert!(SampleOrder::new(MIN_SPP - 1).is_none());
        assert!(SampleOrder::new(MAX_SPP + 1).is_none());
    }

    /// Ranking pays on a large tree with at least two primitives per pixel, not on a small
    /// tree or a large one spread over more pixels.
    #[test]
    fn ranks_large_trees_of_many_primitives_per_pixel() {
        use crate::bvh::tests::occlusion_soup;
        let (large, small) = (occlusion_soup(3000, 0.05), occlusion_soup(300, 0.05));
        assert!(large.is_large() && !small.is_large());
        let per_pixel = large.len() as u64 / PRIMITIVES_PER_PIXEL;
        assert!(pays(&large, per_pixel));
        assert!(!pays(&large, per_pixel + 1));
        assert!(!pays(&small, 1));
    }
}
