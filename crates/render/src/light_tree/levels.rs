//! A small level of the tree as tables, so that 16 lanes at nodes of one level fetch their
//! children's fields by vector permutes (AVX-512) instead of loads lane by lane: the nodes of
//! the level (breadth-first, contiguous), field by field, padded to 16, 32 or 64 entries.

use super::{Children, LightTree, Node, NodeLanes, SegmentLanes};

/// Lanes of the permute lookups (one 512-bit register of f32).
pub(super) const LANES: usize = 16;
/// Most nodes of a level with tables.
pub(super) const MAX_NODES: usize = 64;

/// The fields of a level's nodes (those [`NodeLanes`] holds, and each node's left child),
/// entry i for its node start + i.
#[derive(Clone, Debug, PartialEq)]
#[repr(C, align(64))]
pub(super) struct Level {
    /// centre x, y, z, r², weight; a leaf's segment begin x, y, z, unit axis x, y, z, length,
    /// h² floor (unused for interior nodes).
    fields: [[f32; MAX_NODES]; FIELDS],
    /// The node's left child (its right one is next; a leaf's is itself).
    left: [u32; MAX_NODES],
    /// Index of the level's first node.
    start: u32,
    /// Entries used by the lookups: 16, 32 or 64 (≥ the level's nodes).
    entries: u32,
}

const FIELDS: usize = 13;

impl Level {
    /// The level of `nodes` (first at index `start`), or None if it has more than
    /// [`MAX_NODES`].
    pub(super) fn new(nodes: &[Node], start: u32) -> Option<Self> {
        if nodes.len() > MAX_NODES {
            return None;
        }
        let mut level = Level {
            fields: [[0.0; MAX_NODES]; FIELDS],
            left: [0; MAX_NODES],
            start,
            entries: nodes.len().next_power_of_two().max(LANES) as u32,
        };
        for (i, node) in nodes.iter().enumerate() {
            let s = &node.segment;
            let f = [
                node.centre[0],
                node.centre[1],
                node.centre[2],
                node.r2,
                node.weight,
                s.begin[0],
                s.begin[1],
                s.begin[2],
                s.unit_axis[0],
                s.unit_axis[1],
                s.unit_axis[2],
                s.length,
                s.h2_floor,
            ];
            for (column, v) in level.fields.iter_mut().zip(f) {
                column[i] = v;
            }
            level.left[i] = node.children[0];
        }
        Some(level)
    }
}

#[cfg(target_arch = "x86_64")]
pub(super) use avx512::sample;

#[cfg(target_arch = "x86_64")]
mod avx512 {
    use super::*;
    use std::arch::x86_64::*;

    /// Entry `index` (low 4, 5 or 6 bits per lane) of a table of `entries` values.
    #[inline(always)]
    unsafe fn lookup(table: &[f32; MAX_NODES], entries: u32, index: __m512i) -> __m512 {
        let t = table.as_ptr();
        let low = _mm512_load_ps(t);
        if entries <= 16 {
            return _mm512_permutexvar_ps(index, low);
        }
        let lo = _mm512_permutex2var_ps(low, index, _mm512_load_ps(t.add(16)));
        if entries <= 32 {
            return lo;
        }
        let hi =
            _mm512_permutex2var_ps(_mm512_load_ps(t.add(32)), index, _mm512_load_ps(t.add(48)));
        let upper = _mm512_test_epi32_mask(index, _mm512_set1_epi32(32));
        _mm512_mask_blend_ps(upper, lo, hi)
    }

    /// Field `f` of the nodes `index` (relative to the level's start) of `level`.
    #[inline(always)]
    unsafe fn field(level: &Level, f: usize, index: __m512i) -> [f32; LANES] {
        std::mem::transmute(lookup(&level.fields[f], level.entries, index))
    }

    /// The fields of the nodes `index` (relative to the level's start) of `level`.
    #[inline(always)]
    unsafe fn node_lanes(level: &Level, index: __m512i, leaves: bool) -> NodeLanes<LANES> {
        let segment = if leaves {
            Some(SegmentLanes {
                begin: [
                    field(level, 5, index),
                    field(level, 6, index),
                    field(level, 7, index),
                ],
                unit_axis: [
                    field(level, 8, index),
                    field(level, 9, index),
                    field(level, 10, index),
                ],
                length: field(level, 11, index),
                h2_floor: field(level, 12, index),
            })
        } else {
            None
        };
        NodeLanes {
            centre: [
                field(level, 0, index),
                field(level, 1, index),
                field(level, 2, index),
            ],
            r2: field(level, 3, index),
            weight: field(level, 4, index),
            segment,
        }
    }

    /// [`LightTree::sample_lanes`] on 16 lanes with the level tables where both a level and
    /// the next have them (lanes gathered lane by lane below).
    ///
    /// # Safety
    /// The CPU runs [`Isa::Avx512`](linlight_simd::Isa::Avx512) (`Isa::supported`).
    #[target_feature(enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
    pub(in super::super) unsafe fn sample(
        tree: &LightTree,
        x: &[[f32; LANES]; 3],
        n: &[[f32; LANES]; 3],
        xi: &[f32; LANES],
    ) -> ([u32; LANES], [f64; LANES]) {
        tree.walk(x, n, xi, |level, node, leaves| {
            match (tree.levels.get(level), tree.levels.get(level + 1)) {
                (Some(from), Some(to)) => children(from, to, node, leaves),
                _ => tree.gather_children(node, leaves),
            }
        })
    }

    /// The children of the lanes' nodes of level `from` (absolute indices; a lane whose node
    /// is not in it — it stopped at a leaf above — gets another node's children) and their
    /// fields from the next level, `to`.
    #[inline(always)]
    unsafe fn children(
        from: &Level,
        to: &Level,
        node: &[u32; LANES],
        leaves: bool,
    ) -> Children<LANES> {
        let node = _mm512_loadu_si512(node.as_ptr().cast());
        let here = _mm512_sub_epi32(node, _mm512_set1_epi32(from.start as i32));
        let table: &[f32; MAX_NODES] = &*(&from.left as *const [u32; MAX_NODES]).cast();
        let left = _mm512_castps_si512(lookup(table, from.entries, here));
        let right = _mm512_add_epi32(left, _mm512_set1_epi32(1));
        let l = _mm512_sub_epi32(left, _mm512_set1_epi32(to.start as i32));
        let r = _mm512_add_epi32(l, _mm512_set1_epi32(1));
        (
            std::mem::transmute::<__m512i, [u32; LANES]>(left),
            std::mem::transmute::<__m512i, [u32; LANES]>(right),
            node_lanes(to, l, leaves),
            node_lanes(to, r, leaves),
        )
    }
}
