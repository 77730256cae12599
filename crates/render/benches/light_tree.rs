//! Cost of choosing a light per light sample on the many-tubes ceiling (64 tubes, 8 × 8):
//! ns per lane of `LightTree::sample_lanes` (the tree walk, `--lights tree`) against
//! `LightChoice::pick_lanes` (the uniform bucket lookup of `--lights one`), 16 lanes per call
//! compiled for the CPU's widest instruction set, shading points on the floor and desks below,
//! interleaved rounds, minimum and median.
//! `cargo bench -p linlight-render --bench light_tree`.

use glam::Vec3;
use linlight_render::light::Light;
use linlight_render::light_choice::LightChoice;
use linlight_render::light_tree::LightTree;
use linlight_sampling::rng::Pcg32;
use linlight_sampling::Segment;
use linlight_simd::{dispatch, Isa, Kernel};
use std::hint::black_box;
use std::time::Instant;

const L: usize = 16;
/// Packets per round and rounds.
const PACKETS: usize = 1 << 16;
const ROUNDS: usize = 9;

/// The packets' shading points, normals and ξ_c, lane-major per packet.
struct Packets {
    x: Vec<[[f32; L]; 3]>,
    n: Vec<[[f32; L]; 3]>,
    xi: Vec<[f32; L]>,
}

fn ceiling() -> Vec<Light> {
    (0..64)
        .map(|i| {
            let (a, b) = ((i % 8) as f32, (i / 8) as f32);
            let (x, y) = (-7.0 + 2.0 * a, -5.0 + 1.4 * b);
            let begin = Vec3::new(x - 0.6, y, 3.9);
            let end = Vec3::new(x + 0.6, y, 3.9);
            Light::new(Segment::new(begin, end), Vec3::splat(1.0 + (i % 3) as f32))
        })
        .collect()
}

/// Packets of 4 × 4 neighbouring floor points (a pixel tile), one in four on a desk top.
fn packets(rng: &mut Pcg32) -> Packets {
    let mut p = Packets {
        x: Vec::with_capacity(PACKETS),
        n: Vec::with_capacity(PACKETS),
        xi: Vec::with_capacity(PACKETS),
    };
    for _ in 0..PACKETS {
        let (cx, cy) = (16.0 * rng.next_f32() - 8.0, 12.0 * rng.next_f32() - 6.0);
        let z = if rng.next_f32() < 0.25 { 0.75 } else { 0.0 };
        let mut x = [[0.0; L]; 3];
        let mut xi = [0.0; L];
        for k in 0..L {
            x[0][k] = cx + 0.01 * (k % 4) as f32;
            x[1][k] = cy + 0.01 * (k / 4) as f32;
            x[2][k] = z;
            xi[k] = rng.next_f32();
        }
        p.x.push(x);
        p.n.push([[0.0; L], [0.0; L], [1.0; L]]);
        p.xi.push(xi);
    }
    p
}

struct Tree<'a>(&'a LightTree, &'a Packets);
impl Kernel for Tree<'_> {
    type Output = u64;
    #[inline(always)]
    fn run(self) -> u64 {
        let (tree, p) = (self.0, self.1);
        let mut sum = 0u64;
        for i in 0..PACKETS {
            let (j, pmf) = tree.sample_lanes(Isa::detect(), &p.x[i], &p.n[i], &p.xi[i]);
            sum = sum.wrapping_add(j.iter().map(|&j| j as u64).sum::<u64>());
            sum = sum.wrapping_add(pmf[0].to_bits() >> 60);
        }
        sum
    }
}

struct Uniform<'a>(&'a LightChoice, &'a Packets);
impl Kernel for Uniform<'_> {
    type Output = u64;
    #[inline(always)]
    fn run(self) -> u64 {
        let (choice, p) = (self.0, self.1);
        let mut sum = 0u64;
        for i in 0..PACKETS {
            let j = choice.pick_lanes(&p.xi[i]);
            sum = sum.wrapping_add(j.iter().map(|&j| j as u64).sum::<u64>());
        }
        sum
    }
}

fn ns_per_lane(run: impl FnOnce() -> u64) -> f64 {
    let start = Instant::now();
    black_box(run());
    start.elapsed().as_secs_f64() * 1e9 / (PACKETS * L) as f64
}

fn summary(v: &mut [f64]) -> (f64, f64) {
    v.sort_by(f64::total_cmp);
    (v[0], v[v.len() / 2])
}

fn main() {
    let isa = Isa::detect();
    let lights = ceiling();
    let tree = LightTree::new(&lights);
    let choice = LightChoice::new(&vec![1.0; lights.len()]);
    let p = packets(&mut Pcg32::new(1, 0));
    let (mut t, mut u) = (Vec::new(), Vec::new());
    for _ in 0..ROUNDS {
        t.push(ns_per_lane(|| dispatch(isa, Tree(black_box(&tree), &p))));
        u.push(ns_per_lane(|| {
            dispatch(isa, Uniform(black_box(&choice), &p))
        }));
    }
    let ((t_min, t_med), (u_min, u_med)) = (summary(&mut t), summary(&mut u));
    println!(
        "light choice on the 64-tube ceiling, {} lanes, {}:",
        L,
        isa.name()
    );
    println!("  tree     {t_min:6.2} / {t_med:6.2} ns per lane (min / median)");
    println!("  uniform  {u_min:6.2} / {u_med:6.2} ns per lane");
    println!("  tree / uniform {:.1} (medians)", t_med / u_med);
}
