//! Appearance features (issue 5 item 7; [000] §V: "under 0.1 s" per map): the EM-PCA
//! features y = (σ²I + C_o C_oᵀ)⁻¹ C_o z_o of one new disparity map with d = 20 and
//! D = 19200 (160 × 120) with ~20 % missing, from a model fitted on N = 100 seeded low-rank
//! maps.

use atrium_localization::em_pca::{EmPca, EmPcaParams, ProjectionScratch};
use criterion::{criterion_group, criterion_main, Criterion};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;

const D: usize = 19200;
const N: usize = 100;
const K: usize = 20;

fn maps(rng: &mut ChaCha8Rng, n: usize, basis: &[f32]) -> Vec<Vec<f32>> {
    (0..n)
        .map(|_| {
            let y: Vec<f32> = (0..K).map(|_| rng.random_range(-1.0f32..1.0)).collect();
            (0..D)
                .map(|i| {
                    if rng.random::<f64>() < 0.2 {
                        f32::NAN
                    } else {
                        (0..K).map(|k| basis[i * K + k] * y[k]).sum::<f32>()
                            + 0.01 * rng.random_range(-1.0f32..1.0)
                    }
                })
                .collect()
        })
        .collect()
}

fn benches(c: &mut Criterion) {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let basis: Vec<f32> = (0..D * K).map(|_| rng.random_range(-1.0f32..1.0)).collect();
    let train = maps(&mut rng, N, &basis);
    let refs: Vec<&[f32]> = train.iter().map(|m| m.as_slice()).collect();
    let model = EmPca::fit(&refs, K, EmPcaParams::default()).expect("fits");
    let new_map = maps(&mut rng, 1, &basis).remove(0);
    let mut scratch = ProjectionScratch::new(K);
    let mut y = vec![0.0; K];
    let mut g = c.benchmark_group("appearance");
    g.sample_size(50);
    g.bench_function("empca_features_d20_D19200", |b| {
        b.iter(|| {
            model
                .project_into(black_box(&new_map), &mut scratch, &mut y)
                .expect("projects")
        })
    });
    g.finish();
}

criterion_group!(appearance, benches);
criterion_main!(appearance);
