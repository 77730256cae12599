//! Nelder–Mead downhill simplex minimisation (Lagarias et al. 1998 coefficients: reflection 1,
//! expansion 2, contraction ½, shrink ½), deterministic: ties between vertices are broken by
//! their index, and no randomness is involved.
//!
//! The objective may return +∞ for infeasible points; such vertices are simply the worst.

/// Outcome of [`minimise`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Minimum<const N: usize> {
    pub x: [f64; N],
    pub value: f64,
    pub evaluations: usize,
    /// Whether the tolerance was met before the evaluation budget ran out.
    pub converged: bool,
}

/// Stopping rule: every vertex lies within `x_tolerance[k]` of the best one in every coordinate
/// k, or the simplex's values agree to `f_relative` (relative to the best value); or
/// `max_evaluations` objective calls have been made.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tolerance<const N: usize> {
    pub x_tolerance: [f64; N],
    pub f_relative: f64,
    pub max_evaluations: usize,
}

/// Minimise `f` from `start` with the initial simplex `start`, `start + step[k]·e_k`.
pub fn minimise<const N: usize>(
    mut f: impl FnMut(&[f64; N]) -> f64,
    start: [f64; N],
    step: [f64; N],
    tolerance: &Tolerance<N>,
) -> Minimum<N> {
    let mut simplex: Vec<([f64; N], f64)> = Vec::with_capacity(N + 1);
    let mut evaluations = 0;
    let mut eval = |x: &[f64; N], evaluations: &mut usize| {
        *evaluations += 1;
        let v = f(x);
        if v.is_nan() {
            f64::INFINITY
        } else {
            v
        }
    };
    simplex.push((start, eval(&start, &mut evaluations)));
    for k in 0..N {
        let mut x = start;
        x[k] += step[k];
        simplex.push((x, eval(&x, &mut evaluations)));
    }
    let mut converged = false;
    loop {
        // Stable sort: equal values keep their order (deterministic).
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let (best, best_value) = simplex[0];
        let worst_value = simplex[N].1;
        let x_small = simplex[1..]
            .iter()
            .all(|(x, _)| (0..N).all(|k| (x[k] - best[k]).abs() <= tolerance.x_tolerance[k]));
        let f_small = worst_value.is_finite()
            && (worst_value - best_value) <= tolerance.f_relative * best_value.abs();
        if x_small || f_small {
            converged = true;
            break;
        }
        if evaluations >= tolerance.max_evaluations {
            break;
        }
        // Centroid of all but the worst vertex.
        let mut centroid = [0.0; N];
        for (x, _) in &simplex[..N] {
            for k in 0..N {
                centroid[k] += x[k] / N as f64;
            }
        }
        let worst = simplex[N].0;
        let along = |t: f64| {
            let mut x = [0.0; N];
            for k in 0..N {
                x[k] = centroid[k] + t * (worst[k] - centroid[k]);
            }
            x
        };
        let reflected = along(-1.0);
        let fr = eval(&reflected, &mut evaluations);
        if fr < best_value {
            let expanded = along(-2.0);
            let fe = eval(&expanded, &mut evaluations);
            simplex[N] = if fe < fr {
                (expanded, fe)
            } else {
                (reflected, fr)
            };
            continue;
        }
        if fr < simplex[N - 1].1 {
            simplex[N] = (reflected, fr);
            continue;
        }
        // Contraction: outside if the reflected point improved on the worst, else inside.
        let (contracted, fc) = if fr < worst_value {
            let x = along(-0.5);
            let v = eval(&x, &mut evaluations);
            (x, v)
        } else {
            let x = along(0.5);
            let v = eval(&x, &mut evaluations);
            (x, v)
        };
        if fc < fr.min(worst_value) {
            simplex[N] = (contracted, fc);
            continue;
        }
        // Shrink toward the best vertex.
        for vertex in simplex.iter_mut().skip(1) {
            let mut x = vertex.0;
            for k in 0..N {
                x[k] = best[k] + 0.5 * (x[k] - best[k]);
            }
            *vertex = (x, eval(&x, &mut evaluations));
        }
    }
    let (x, value) = simplex[0];
    Minimum {
        x,
        value,
        evaluations,
        converged,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_minimum_of_rosenbrock() {
        let rosen = |x: &[f64; 2]| (1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2);
        let tol = Tolerance {
            x_tolerance: [1e-9; 2],
            f_relative: 0.0,
            max_evaluations: 5000,
        };
        let m = minimise(rosen, [-1.2, 1.0], [0.1, 0.1], &tol);
        assert!(m.converged);
        assert!(
            (m.x[0] - 1.0).abs() < 1e-6 && (m.x[1] - 1.0).abs() < 1e-6,
            "{m:?}"
        );
    }

    #[test]
    fn infeasible_region_and_one_dimension() {
        // Minimum at the boundary side of an infeasible half-line: x > 0 only.
        let f = |x: &[f64; 1]| {
            if x[0] <= 0.0 {
                f64::INFINITY
            } else {
                (x[0].ln() - 0.5f64.ln()).powi(2)
            }
        };
        let tol = Tolerance {
            x_tolerance: [1e-10],
            f_relative: 0.0,
            max_evaluations: 1000,
        };
        let m = minimise(f, [3.0], [-2.9], &tol);
        assert!(m.converged && (m.x[0] - 0.5).abs() < 1e-8, "{m:?}");
        // Deterministic: the same call gives the same bits.
        assert_eq!(m, minimise(f, [3.0], [-2.9], &tol));
    }

    #[test]
    fn budget_is_respected() {
        let tol = Tolerance {
            x_tolerance: [0.0; 2],
            f_relative: 0.0,
            max_evaluations: 50,
        };
        let m = minimise(
            |x: &[f64; 2]| x[0].abs() + x[1].abs(),
            [1.0, 1.0],
            [0.5, 0.5],
            &tol,
        );
        assert!(!m.converged);
        // A step may use up to N + 1 evaluations (shrink) past the check.
        assert!(m.evaluations <= 50 + 2);
    }
}
