//! 2D pose-graph optimisation: nodes are poses, edges relative-pose measurements with an
//! information matrix, and the poses that best explain the measurements minimise
//! χ² = Σ eᵢⱼᵀ Ωᵢⱼ eᵢⱼ ([Grisetti 2010]).
//!
//! The error of edge (i, j) with measurement zᵢⱼ (the motion from i to j in i's frame) is
//! eᵢⱼ = t2v(Zᵢⱼ⁻¹ (Xᵢ⁻¹ Xⱼ)), its heading part wrapped into (−π, π], with the Jacobians
//! Aᵢⱼ = ∂eᵢⱼ/∂xᵢ and Bᵢⱼ = ∂eᵢⱼ/∂xⱼ of [Grisetti 2010]'s 2D example. Each iteration builds
//! H = Σ JᵀΩJ and b = Σ JᵀΩe edge by edge and solves H Δx = −b with node 0 held fixed (its
//! rows and columns removed, which fixes the gauge), as a sparse LDLᵀ factorisation with an
//! approximate minimum degree ordering (QDLDL, from the `clarabel` crate the workspace
//! already uses); H keeps one 3 × 3 block per node and per pair of nodes joined by an edge,
//! and its sparsity pattern (so the ordering and the symbolic factorisation) is computed
//! once per call. Steps are Gauss–Newton, damped Levenberg–Marquardt style (H + λ diag H)
//! only after a step that raised χ² or a factorisation that failed.

use atrium_robots::{normalize_angle, Pose2};
use clarabel::algebra::CscMatrix;
use clarabel::qdldl::{QDLDLFactorisation, QDLDLSettings};

/// A 3 × 3 information matrix (x, y, θ), symmetric positive definite.
pub type Information = [[f64; 3]; 3];

/// The information matrix with weights `w` on its diagonal (1/σ² for independent errors).
pub fn diagonal_information(w: [f64; 3]) -> Information {
    [[w[0], 0.0, 0.0], [0.0, w[1], 0.0], [0.0, 0.0, w[2]]]
}

/// A relative-pose measurement between two nodes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Edge {
    pub i: usize,
    pub j: usize,
    /// Pose of node j in node i's frame.
    pub z: Pose2,
    pub information: Information,
}

/// What [`PoseGraph::optimize`] did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Summary {
    /// Linear systems solved (accepted and rejected steps).
    pub iterations: usize,
    pub initial_chi2: f64,
    pub final_chi2: f64,
    /// Whether the last step was below [`CONVERGED_STEP`] (else the iterations ran out or the
    /// damping could not find a step that lowers χ²).
    pub converged: bool,
}

/// The optimisation stops after a step whose largest component (metres or radians) is
/// below this.
pub const CONVERGED_STEP: f64 = 1e-9;

/// Why a graph cannot be optimised.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PoseGraphError {
    #[error("edge {edge}: node {node} is out of range (the graph has {nodes} nodes)")]
    NodeOutOfRange {
        edge: usize,
        node: usize,
        nodes: usize,
    },
    #[error("edge {edge}: joins node {node} to itself")]
    SelfLoop { edge: usize, node: usize },
    #[error("{what} is not finite")]
    NotFinite { what: String },
    #[error("edge {edge}: the information matrix is not symmetric positive definite: {reason}")]
    Information {
        edge: usize,
        reason: InformationDefect,
    },
    #[error("node {node} is not connected to node 0 by any chain of edges")]
    Disconnected { node: usize },
    #[error(
        "the linear system cannot be solved (numerically singular at damping {damping:e}): \
         {reason}"
    )]
    Singular { damping: f64, reason: String },
}

/// What is wrong with an edge's information matrix (the matrix is in the message).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InformationDefect {
    #[error("not finite: {0:?}")]
    NotFinite(Information),
    #[error("not symmetric: {0:?}")]
    NotSymmetric(Information),
    #[error("not positive definite: {0:?}")]
    NotPositiveDefinite(Information),
}

/// A pose graph: see the module documentation.
#[derive(Debug, Clone, Default)]
pub struct PoseGraph {
    poses: Vec<Pose2>,
    edges: Vec<Edge>,
}

impl PoseGraph {
    /// A graph of these nodes (initial guesses), without edges. Node 0 stays where it is.
    pub fn new(initial: Vec<Pose2>) -> Self {
        PoseGraph {
            poses: initial,
            edges: Vec::new(),
        }
    }

    /// Adds the measurement `z` of node j in node i's frame; returns the edge's index. It is
    /// checked by [`PoseGraph::optimize`].
    pub fn add_edge(&mut self, i: usize, j: usize, z: Pose2, information: Information) -> usize {
        self.edges.push(Edge {
            i,
            j,
            z,
            information,
        });
        self.edges.len() - 1
    }

    pub fn poses(&self) -> &[Pose2] {
        &self.poses
    }

    pub fn edges(&self) -> &[Edge] {
        &self.edges
    }

    /// χ² of the current poses (also for an invalid graph: edges with out-of-range nodes are
    /// skipped).
    pub fn chi2(&self) -> f64 {
        chi2(&self.poses, &self.edges)
    }

    /// Runs at most `max_iterations` iterations from the current poses, stopping at a step
    /// below [`CONVERGED_STEP`]. Node 0 is fixed. The poses are left unchanged on error.
    pub fn optimize(&mut self, max_iterations: usize) -> Result<Summary, PoseGraphError> {
        self.validate()?;
        let start = self.poses.clone();
        self.iterate(max_iterations)
            .inspect_err(|_| self.poses = start)
    }

    fn iterate(&mut self, max_iterations: usize) -> Result<Summary, PoseGraphError> {
        let initial_chi2 = self.chi2();
        let n = self.poses.len();
        if n <= 1 || self.edges.is_empty() {
            return Ok(Summary {
                iterations: 0,
                initial_chi2,
                final_chi2: initial_chi2,
                converged: true,
            });
        }
        let mut system = System::new(n, &self.edges);
        let mut chi2_now = initial_chi2;
        let mut lambda = 0.0;
        let mut iterations = 0;
        let mut converged = false;
        let mut candidate = self.poses.clone();
        let mut relinearise = true;
        while iterations < max_iterations {
            if relinearise {
                system.linearise(&self.poses, &self.edges);
                relinearise = false;
            }
            iterations += 1;
            let step = match system.solve(lambda) {
                Ok(step) => step,
                Err(reason) => {
                    // Damping makes H + λ diag H better conditioned: try that first.
                    if lambda < MAX_DAMPING {
                        lambda = next_damping(lambda);
                        continue;
                    }
                    return Err(PoseGraphError::Singular {
                        damping: lambda,
                        reason,
                    });
                }
            };
            let largest = step.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            if !largest.is_finite() {
                if lambda < MAX_DAMPING {
                    lambda = next_damping(lambda);
                    continue;
                }
                return Err(PoseGraphError::Singular {
                    damping: lambda,
                    reason: "the step is not finite".into(),
                });
            }
            for (k, p) in candidate.iter_mut().enumerate().skip(1) {
                let s = &step[3 * (k - 1)..3 * k];
                let base = self.poses[k];
                *p = Pose2::new(
                    base.x + s[0],
                    base.y + s[1],
                    normalize_angle(base.theta + s[2]),
                );
            }
            let chi2_new = chi2(&candidate, &self.edges);
            if largest < CONVERGED_STEP {
                // A step this small cannot be told from rounding: take it and stop.
                if chi2_new <= chi2_now {
                    std::mem::swap(&mut self.poses, &mut candidate);
                    chi2_now = chi2_new;
                }
                converged = true;
                break;
            }
            if chi2_new <= chi2_now {
                std::mem::swap(&mut self.poses, &mut candidate);
                chi2_now = chi2_new;
                lambda = if lambda <= MIN_DAMPING {
                    0.0
                } else {
                    lambda / 10.0
                };
                relinearise = true;
            } else if lambda < MAX_DAMPING {
                lambda = next_damping(lambda);
            } else {
                // No step of any damping lowers χ²: a (local) minimum to rounding.
                break;
            }
        }
        Ok(Summary {
            iterations,
            initial_chi2,
            final_chi2: chi2_now,
            converged,
        })
    }

    fn validate(&self) -> Result<(), PoseGraphError> {
        let n = self.poses.len();
        for (k, p) in self.poses.iter().enumerate() {
            if !p.is_finite() {
                return Err(PoseGraphError::NotFinite {
                    what: format!("node {k} ({p:?})"),
                });
            }
        }
        for (k, e) in self.edges.iter().enumerate() {
            for node in [e.i, e.j] {
                if node >= n {
                    return Err(PoseGraphError::NodeOutOfRange {
                        edge: k,
                        node,
                        nodes: n,
                    });
                }
            }
            if e.i == e.j {
                return Err(PoseGraphError::SelfLoop { edge: k, node: e.i });
            }
            if !e.z.is_finite() {
                return Err(PoseGraphError::NotFinite {
                    what: format!("edge {k}'s measurement ({:?})", e.z),
                });
            }
            check_information(&e.information)
                .map_err(|reason| PoseGraphError::Information { edge: k, reason })?;
        }
        // Every node must be tied to node 0 (union-find over the edges).
        let mut parent: Vec<usize> = (0..n).collect();
        fn root(parent: &mut [usize], mut a: usize) -> usize {
            while parent[a] != a {
                parent[a] = parent[parent[a]];
                a = parent[a];
            }
            a
        }
        for e in &self.edges {
            let (a, b) = (root(&mut parent, e.i), root(&mut parent, e.j));
            parent[a.max(b)] = a.min(b);
        }
        for node in 1..n {
            if root(&mut parent, node) != 0 {
                return Err(PoseGraphError::Disconnected { node });
            }
        }
        Ok(())
    }
}

const MIN_DAMPING: f64 = 1e-9;
const MAX_DAMPING: f64 = 1e12;

fn next_damping(lambda: f64) -> f64 {
    if lambda == 0.0 {
        1e-4
    } else {
        lambda * 10.0
    }
}

/// Finite, symmetric (to 1e-9 relative) and positive definite (Cholesky pivots > 0).
fn check_information(m: &Information) -> Result<(), InformationDefect> {
    if m.iter().flatten().any(|v| !v.is_finite()) {
        return Err(InformationDefect::NotFinite(*m));
    }
    let scale = m.iter().flatten().fold(0.0f64, |s, v| s.max(v.abs()));
    for r in 0..3 {
        for c in 0..r {
            if (m[r][c] - m[c][r]).abs() > 1e-9 * scale {
                return Err(InformationDefect::NotSymmetric(*m));
            }
        }
    }
    let mut l = [[0.0; 3]; 3];
    for r in 0..3 {
        for c in 0..=r {
            let s = m[r][c] - (0..c).map(|k| l[r][k] * l[c][k]).sum::<f64>();
            if r == c {
                if s.is_nan() || s <= 1e-12 * scale {
                    return Err(InformationDefect::NotPositiveDefinite(*m));
                }
                l[r][c] = s.sqrt();
            } else {
                l[r][c] = s / l[c][c];
            }
        }
    }
    Ok(())
}

/// eᵢⱼ and its Jacobians Aᵢⱼ = ∂e/∂xᵢ, Bᵢⱼ = ∂e/∂xⱼ ([Grisetti 2010]).
fn error_and_jacobians(
    xi: &Pose2,
    xj: &Pose2,
    z: &Pose2,
) -> ([f64; 3], [[f64; 3]; 3], [[f64; 3]; 3]) {
    let (si, ci) = xi.theta.sin_cos();
    let (sz, cz) = z.theta.sin_cos();
    let (dx, dy) = (xj.x - xi.x, xj.y - xi.y);
    // Rᵢᵀ (tⱼ − tᵢ), then Rzᵀ (· − tz).
    let (u, v) = (ci * dx + si * dy, -si * dx + ci * dy);
    let (u, v) = (u - z.x, v - z.y);
    let e = [
        cz * u + sz * v,
        -sz * u + cz * v,
        normalize_angle(xj.theta - xi.theta - z.theta),
    ];
    // RzᵀRᵢᵀ = R(θi + θz)ᵀ.
    let (s, c) = (xi.theta + z.theta).sin_cos();
    // Rzᵀ ∂Rᵢᵀ/∂θᵢ (tⱼ − tᵢ), with ∂Rᵢᵀ/∂θᵢ (dx, dy) = (−s dx + c dy, −c dx − s dy) for θᵢ.
    let (du, dv) = (-si * dx + ci * dy, -ci * dx - si * dy);
    let (gx, gy) = (cz * du + sz * dv, -sz * du + cz * dv);
    let a = [[-c, -s, gx], [s, -c, gy], [0.0, 0.0, -1.0]];
    let b = [[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]];
    (e, a, b)
}

fn chi2(poses: &[Pose2], edges: &[Edge]) -> f64 {
    edges
        .iter()
        .filter_map(|ed| {
            let (xi, xj) = (poses.get(ed.i)?, poses.get(ed.j)?);
            let (e, _, _) = error_and_jacobians(xi, xj, &ed.z);
            Some(quadratic(&ed.information, &e))
        })
        .sum()
}

fn quadratic(m: &Information, e: &[f64; 3]) -> f64 {
    let mut s = 0.0;
    for r in 0..3 {
        for c in 0..3 {
            s += e[r] * m[r][c] * e[c];
        }
    }
    s
}

/// `xᵀ M y` for 3 × 3 blocks: Xᵀ Ω Y.
fn at_m_b(x: &[[f64; 3]; 3], m: &Information, y: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut my = [[0.0; 3]; 3];
    for r in 0..3 {
        for c in 0..3 {
            my[r][c] = (0..3).map(|k| m[r][k] * y[k][c]).sum();
        }
    }
    let mut out = [[0.0; 3]; 3];
    for r in 0..3 {
        for c in 0..3 {
            out[r][c] = (0..3).map(|k| x[k][r] * my[k][c]).sum();
        }
    }
    out
}

fn at_m_v(x: &[[f64; 3]; 3], m: &Information, e: &[f64; 3]) -> [f64; 3] {
    let me: [f64; 3] = std::array::from_fn(|r| (0..3).map(|k| m[r][k] * e[k]).sum());
    std::array::from_fn(|r| (0..3).map(|k| x[k][r] * me[k]).sum())
}

/// The normal equations of the free nodes 1..n, their sparsity pattern and factorisation.
struct System {
    /// Unknowns: 3 per free node.
    dim: usize,
    /// Per edge: the H blocks it adds to (block of (i, i), (j, j), and of the pair, each
    /// `None` when it involves the fixed node 0) and whether the pair block is stored as
    /// (i, j) (i < j) or transposed.
    edge_blocks: Vec<[Option<usize>; 3]>,
    /// Per block: (block row, block column) with row ≤ column, and the position in `nz` of
    /// its entry (row 0, column c) for c = 0..3; rows follow contiguously (a diagonal block
    /// stores rows 0..=c only).
    blocks: Vec<(usize, usize, [usize; 3])>,
    values: Vec<[[f64; 3]; 3]>,
    rhs: Vec<f64>,
    pattern: CscMatrix<f64>,
    all: Vec<usize>,
    nz: Vec<f64>,
    factor: Option<QDLDLFactorisation<f64>>,
}

impl System {
    fn new(n: usize, edges: &[Edge]) -> System {
        let free = n - 1;
        let dim = 3 * free;
        // Block pairs (p, q), p < q, of free nodes (node k is free index k - 1).
        let mut pairs: Vec<(usize, usize)> = edges
            .iter()
            .filter(|e| e.i != 0 && e.j != 0)
            .map(|e| {
                let (p, q) = (e.i.min(e.j) - 1, e.i.max(e.j) - 1);
                (q, p)
            })
            .collect();
        pairs.sort_unstable();
        pairs.dedup();
        // Column-major over block columns q: off-diagonal blocks (p < q) by p, then (q, q).
        let mut blocks = Vec::with_capacity(free + pairs.len());
        let mut colptr = Vec::with_capacity(dim + 1);
        let mut rowval = Vec::new();
        let mut start = 0;
        let mut by_column: Vec<Vec<usize>> = vec![Vec::new(); free];
        for &(q, p) in &pairs {
            by_column[q].push(p);
        }
        let mut block_of_pair = std::collections::HashMap::with_capacity(pairs.len());
        let mut diagonal = vec![0; free];
        for q in 0..free {
            let rows = &by_column[q];
            let first_block = blocks.len();
            for &p in rows {
                block_of_pair.insert((p, q), blocks.len());
                blocks.push((p, q, [0; 3]));
            }
            diagonal[q] = blocks.len();
            blocks.push((q, q, [0; 3]));
            for c in 0..3 {
                colptr.push(start);
                for (b, &p) in rows.iter().enumerate() {
                    blocks[first_block + b].2[c] = start;
                    rowval.extend([3 * p, 3 * p + 1, 3 * p + 2]);
                    start += 3;
                }
                blocks[diagonal[q]].2[c] = start;
                rowval.extend((0..=c).map(|r| 3 * q + r));
                start += c + 1;
            }
        }
        colptr.push(start);
        let edge_blocks = edges
            .iter()
            .map(|e| {
                let di = (e.i != 0).then(|| diagonal[e.i - 1]);
                let dj = (e.j != 0).then(|| diagonal[e.j - 1]);
                let pair = (e.i != 0 && e.j != 0)
                    .then(|| {
                        let (p, q) = (e.i.min(e.j) - 1, e.i.max(e.j) - 1);
                        block_of_pair.get(&(p, q)).copied()
                    })
                    .flatten();
                [di, dj, pair]
            })
            .collect();
        let nnz = start;
        System {
            dim,
            edge_blocks,
            values: vec![[[0.0; 3]; 3]; blocks.len()],
            blocks,
            rhs: vec![0.0; dim],
            pattern: CscMatrix::new(dim, dim, colptr, rowval, vec![0.0; nnz]),
            all: (0..nnz).collect(),
            nz: vec![0.0; nnz],
            factor: None,
        }
    }

    /// H and b at `poses`: each edge adds AᵀΩA, AᵀΩB, BᵀΩB to H and AᵀΩe, BᵀΩe to b.
    fn linearise(&mut self, poses: &[Pose2], edges: &[Edge]) {
        self.values.fill([[0.0; 3]; 3]);
        self.rhs.fill(0.0);
        let add = |dst: &mut [[f64; 3]; 3], m: &[[f64; 3]; 3], transpose: bool| {
            for r in 0..3 {
                for c in 0..3 {
                    dst[r][c] += if transpose { m[c][r] } else { m[r][c] };
                }
            }
        };
        for (ed, blocks) in edges.iter().zip(&self.edge_blocks) {
            let (e, a, b) = error_and_jacobians(&poses[ed.i], &poses[ed.j], &ed.z);
            let om = &ed.information;
            if let Some(k) = blocks[0] {
                add(&mut self.values[k], &at_m_b(&a, om, &a), false);
                let g = at_m_v(&a, om, &e);
                let base = 3 * (ed.i - 1);
                for (dst, v) in self.rhs[base..base + 3].iter_mut().zip(g) {
                    *dst += v;
                }
            }
            if let Some(k) = blocks[1] {
                add(&mut self.values[k], &at_m_b(&b, om, &b), false);
                let g = at_m_v(&b, om, &e);
                let base = 3 * (ed.j - 1);
                for (dst, v) in self.rhs[base..base + 3].iter_mut().zip(g) {
                    *dst += v;
                }
            }
            if let Some(k) = blocks[2] {
                // Block (min, max): Aᵀ Ω B when i < j, its transpose Bᵀ Ω A otherwise.
                add(&mut self.values[k], &at_m_b(&a, om, &b), ed.i > ed.j);
            }
        }
    }

    /// Δx of (H + λ diag H) Δx = −b.
    fn solve(&mut self, lambda: f64) -> Result<Vec<f64>, String> {
        for (&(p, q, start), v) in self.blocks.iter().zip(&self.values) {
            for c in 0..3 {
                let rows = if p == q { c + 1 } else { 3 };
                for (r, row) in v.iter().enumerate().take(rows) {
                    let mut x = row[c];
                    if p == q && r == c {
                        x *= 1.0 + lambda;
                    }
                    self.nz[start[c] + r] = x;
                }
            }
        }
        if !self.nz.iter().all(|v| v.is_finite()) {
            return Err("the normal equations are not finite".into());
        }
        let factor = match &mut self.factor {
            Some(f) => {
                f.update_values(&self.all, &self.nz);
                f.refactor().map_err(|e| e.to_string())?;
                f
            }
            None => {
                self.pattern.nzval.copy_from_slice(&self.nz);
                let settings = QDLDLSettings {
                    regularize_enable: false,
                    ..Default::default()
                };
                let f = QDLDLFactorisation::new(&self.pattern, Some(settings))
                    .map_err(|e| e.to_string())?;
                self.factor.insert(f)
            }
        };
        if factor.positive_inertia() != self.dim {
            return Err(format!(
                "{} of {} pivots are positive",
                factor.positive_inertia(),
                self.dim
            ));
        }
        let mut x: Vec<f64> = self.rhs.iter().map(|v| -v).collect();
        factor.solve(&mut x);
        Ok(x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};
    use std::f64::consts::{FRAC_PI_2, PI};

    const EYE: Information = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

    fn max_pose_error(a: &[Pose2], b: &[Pose2]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(p, q)| p.distance(q).max(p.heading_error(q)))
            .fold(0.0, f64::max)
    }

    /// 16 poses around a 2 m square, 0.5 m apart, turning left at each corner.
    fn square() -> Vec<Pose2> {
        let mut poses = vec![Pose2::new(1.0, -2.0, 0.3)];
        for k in 1..16 {
            let step = if k % 4 == 0 {
                Pose2::new(0.5, 0.0, FRAC_PI_2)
            } else {
                Pose2::new(0.5, 0.0, 0.0)
            };
            let last = poses[k - 1];
            poses.push(last.compose(&step));
        }
        poses
    }

    #[test]
    fn jacobians_match_finite_differences() {
        let xi = Pose2::new(0.4, -1.2, 2.9);
        let xj = Pose2::new(-0.7, 0.5, -2.8);
        let z = Pose2::new(0.3, 0.9, 1.1);
        let (e0, a, b) = error_and_jacobians(&xi, &xj, &z);
        let h = 1e-6;
        for k in 0..3 {
            let bump = |p: &Pose2, s: f64| {
                let mut q = *p;
                match k {
                    0 => q.x += s,
                    1 => q.y += s,
                    _ => q.theta += s,
                }
                q
            };
            let (ep, _, _) = error_and_jacobians(&bump(&xi, h), &xj, &z);
            let (em, _, _) = error_and_jacobians(&bump(&xi, -h), &xj, &z);
            let (fp, _, _) = error_and_jacobians(&xi, &bump(&xj, h), &z);
            let (fm, _, _) = error_and_jacobians(&xi, &bump(&xj, -h), &z);
            for r in 0..3 {
                assert!(
                    ((ep[r] - em[r]) / (2.0 * h) - a[r][k]).abs() < 1e-7,
                    "A {r} {k}"
                );
                assert!(
                    ((fp[r] - fm[r]) / (2.0 * h) - b[r][k]).abs() < 1e-7,
                    "B {r} {k}"
                );
            }
        }
        // The error is that of Z⁻¹ (Xi⁻¹ Xj), the heading wrapped.
        let want = z.inverse().compose(&xi.between(&xj));
        assert!((e0[0] - want.x).abs() < 1e-12 && (e0[1] - want.y).abs() < 1e-12);
        assert!((e0[2] - want.theta).abs() < 1e-12);
    }

    #[test]
    fn square_loop_with_noisy_odometry_converges_to_the_square() {
        let truth = square();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let noise = Normal::new(0.0, 0.05).unwrap();
        // Initial guess: the odometry, each increment perturbed, composed from node 0.
        let mut initial = vec![truth[0]];
        for k in 1..truth.len() {
            let z = truth[k - 1].between(&truth[k]);
            let noisy = Pose2::new(
                z.x + noise.sample(&mut rng),
                z.y + noise.sample(&mut rng),
                z.theta + noise.sample(&mut rng),
            );
            let last = initial[k - 1];
            initial.push(last.compose(&noisy));
        }
        assert!(max_pose_error(&initial, &truth) > 0.2);
        let mut g = PoseGraph::new(initial);
        let info = [[20.0, 1.0, 0.5], [1.0, 30.0, 0.0], [0.5, 0.0, 100.0]];
        for k in 1..truth.len() {
            g.add_edge(k - 1, k, truth[k - 1].between(&truth[k]), info);
        }
        // The loop closure: the last pose seen from the first.
        let n = truth.len();
        g.add_edge(0, n - 1, truth[0].between(&truth[n - 1]), info);
        let s = g.optimize(50).unwrap();
        assert!(s.converged, "{s:?}");
        assert!(s.initial_chi2 > 1.0 && s.final_chi2 < 1e-20, "{s:?}");
        let err = max_pose_error(g.poses(), &truth);
        assert!(err < 1e-6, "{err}");
        assert_eq!(g.poses()[0], truth[0], "node 0 is fixed");
    }

    #[test]
    fn chain_with_exact_constraints_recovers_perturbed_poses() {
        let mut truth = vec![Pose2::new(-3.0, 4.0, -2.5)];
        for k in 1..60 {
            let step = Pose2::new(0.3 + 0.01 * k as f64, 0.05, 0.2 * (k as f64 * 0.7).sin());
            let last = truth[k - 1];
            truth.push(last.compose(&step));
        }
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let noise = Normal::new(0.0, 0.3).unwrap();
        let mut initial = truth.clone();
        for p in initial.iter_mut().skip(1) {
            p.x += noise.sample(&mut rng);
            p.y += noise.sample(&mut rng);
            p.theta = normalize_angle(p.theta + noise.sample(&mut rng));
        }
        let mut g = PoseGraph::new(initial);
        for k in 1..truth.len() {
            // Edges in both directions' conventions: some stored as (k, k - 1).
            if k % 3 == 0 {
                g.add_edge(k, k - 1, truth[k].between(&truth[k - 1]), EYE);
            } else {
                g.add_edge(k - 1, k, truth[k - 1].between(&truth[k]), EYE);
            }
        }
        let s = g.optimize(50).unwrap();
        assert!(s.converged && s.iterations < 50, "{s:?}");
        let err = max_pose_error(g.poses(), &truth);
        assert!(err < 1e-6, "{err}");
    }

    #[test]
    fn large_heading_errors_converge_with_damping() {
        // A ring of 8 poses whose initial headings are off by up to ±2.5 rad.
        let truth: Vec<Pose2> = (0..8)
            .map(|k| {
                let a = k as f64 * PI / 4.0;
                Pose2::new(3.0 * a.cos(), 3.0 * a.sin(), normalize_angle(a + FRAC_PI_2))
            })
            .collect();
        let mut initial = truth.clone();
        for (k, p) in initial.iter_mut().enumerate().skip(1) {
            p.theta = normalize_angle(p.theta + 2.5 * (k as f64 * 1.3).sin());
            p.x += 0.5;
        }
        let mut g = PoseGraph::new(initial);
        for k in 0..8 {
            let j = (k + 1) % 8;
            g.add_edge(k, j, truth[k].between(&truth[j]), EYE);
        }
        g.add_edge(0, 4, truth[0].between(&truth[4]), EYE);
        let s = g.optimize(100).unwrap();
        assert!(s.final_chi2 < 1e-18, "{s:?}");
        assert!(max_pose_error(g.poses(), &truth) < 1e-6);
    }

    #[test]
    fn invalid_graphs_are_errors_and_leave_the_poses() {
        let poses = vec![
            Pose2::default(),
            Pose2::new(1.0, 0.0, 0.0),
            Pose2::new(2.0, 0.0, 0.0),
        ];
        let z = Pose2::new(1.0, 0.0, 0.0);
        // Node 2 has no edge.
        let mut g = PoseGraph::new(poses.clone());
        g.add_edge(0, 1, z, EYE);
        assert_eq!(
            g.optimize(10),
            Err(PoseGraphError::Disconnected { node: 2 })
        );
        assert_eq!(g.poses(), &poses[..]);
        // Nodes 1 and 2 tied to each other but not to 0.
        let mut g = PoseGraph::new(poses.clone());
        g.add_edge(2, 1, z, EYE);
        assert_eq!(
            g.optimize(10),
            Err(PoseGraphError::Disconnected { node: 1 })
        );

        let mut g = PoseGraph::new(poses.clone());
        g.add_edge(0, 1, z, EYE);
        g.add_edge(1, 3, z, EYE);
        assert_eq!(
            g.optimize(10),
            Err(PoseGraphError::NodeOutOfRange {
                edge: 1,
                node: 3,
                nodes: 3
            })
        );
        let mut g = PoseGraph::new(poses.clone());
        g.add_edge(1, 1, z, EYE);
        assert_eq!(
            g.optimize(10),
            Err(PoseGraphError::SelfLoop { edge: 0, node: 1 })
        );

        let chain = |info: Information, z: Pose2, p1: Pose2| {
            let mut g = PoseGraph::new(vec![Pose2::default(), p1]);
            g.add_edge(0, 1, z, info);
            g.optimize(10)
        };
        let p1 = Pose2::new(1.0, 0.0, 0.0);
        let e = chain(EYE, Pose2::new(f64::NAN, 0.0, 0.0), p1).unwrap_err();
        assert!(matches!(e, PoseGraphError::NotFinite { .. }), "{e}");
        let e = chain(EYE, z, Pose2::new(1.0, f64::INFINITY, 0.0)).unwrap_err();
        assert!(e.to_string().contains("node 1"), "{e}");
        for bad in [
            diagonal_information([1.0, 0.0, 1.0]),
            diagonal_information([1.0, -1.0, 1.0]),
            [[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            [[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            diagonal_information([1.0, f64::NAN, 1.0]),
        ] {
            let e = chain(bad, z, p1).unwrap_err();
            assert!(
                matches!(e, PoseGraphError::Information { edge: 0, .. }),
                "{e}"
            );
        }
        // A one-node graph, or one without edges beyond node 0, has nothing to do.
        let mut g = PoseGraph::new(vec![Pose2::new(1.0, 2.0, 3.0)]);
        assert!(g.optimize(10).unwrap().converged);
        let mut g = PoseGraph::new(Vec::new());
        assert_eq!(g.optimize(10).unwrap().iterations, 0);
    }

    /// A Manhattan-world trajectory of `n` poses 1 m apart with noisy odometry and
    /// `closures` noisy loop closures between revisits of the same place.
    fn manhattan(n: usize, closures: usize, seed: u64) -> (Vec<Pose2>, PoseGraph) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut truth = vec![Pose2::default()];
        let mut heading = 0.0;
        for k in 1..n {
            // Turn ±90° now and then, staying in a 20 m box.
            let last = truth[k - 1];
            if k % 10 == 0 {
                let left = rand::Rng::random_bool(&mut rng, 0.5);
                heading = normalize_angle(heading + if left { FRAC_PI_2 } else { -FRAC_PI_2 });
            }
            let (s, c) = heading.sin_cos();
            if (last.x + c).abs() > 10.0 || (last.y + s).abs() > 10.0 {
                heading = normalize_angle(heading + PI);
            }
            let (s, c) = heading.sin_cos();
            truth.push(Pose2::new(last.x + c, last.y + s, heading));
        }
        let sd = [0.05, 0.05, 0.01];
        let noises: Vec<Normal<f64>> = sd.iter().map(|&s| Normal::new(0.0, s).unwrap()).collect();
        let info = diagonal_information(sd.map(|s| 1.0 / (s * s)));
        let noisy = |z: Pose2, rng: &mut ChaCha8Rng| {
            Pose2::new(
                z.x + noises[0].sample(rng),
                z.y + noises[1].sample(rng),
                z.theta + noises[2].sample(rng),
            )
        };
        let mut initial = vec![truth[0]];
        let mut edges = Vec::new();
        for k in 1..n {
            let z = noisy(truth[k - 1].between(&truth[k]), &mut rng);
            let last = initial[k - 1];
            initial.push(last.compose(&z));
            edges.push((k - 1, k, z));
        }
        // Every revisit (same place, at least 20 steps apart), thinned evenly to `closures`.
        let candidates: Vec<(usize, usize)> = (0..n)
            .flat_map(|j| (0..j.saturating_sub(20)).map(move |i| (i, j)))
            .filter(|&(i, j)| truth[i].distance(&truth[j]) < 0.5)
            .collect();
        assert!(candidates.len() >= closures, "{}", candidates.len());
        for k in 0..closures {
            let (i, j) = candidates[k * candidates.len() / closures];
            let z = noisy(truth[i].between(&truth[j]), &mut rng);
            edges.push((i, j, z));
        }
        let mut g = PoseGraph::new(initial);
        for (i, j, z) in edges {
            g.add_edge(i, j, z, info);
        }
        (truth, g)
    }

    #[test]
    fn two_thousand_nodes_three_thousand_edges() {
        let (truth, mut g) = manhattan(2000, 1001, 4);
        assert_eq!(g.edges().len(), 3000);
        let before = max_pose_error(g.poses(), &truth);
        let t = std::time::Instant::now();
        let s = g.optimize(50).unwrap();
        let dt = t.elapsed();
        let after = max_pose_error(g.poses(), &truth);
        println!(
            "2000 nodes, 3000 edges: {:.1} ms, {s:?}; largest pose error {before:.3} -> {after:.3}",
            dt.as_secs_f64() * 1e3
        );
        assert!(s.converged, "{s:?}");
        // χ² of a consistent graph is about its degrees of freedom: 3 x (3000 - 1999).
        assert!(s.final_chi2 < 2.0 * 3.0 * 1001.0, "{s:?}");
        assert!(after < 0.5 * before, "{before} -> {after}");
    }
}
