//! One sub-goal prediction on one thread: the shipped default model (small CNN) and the paper's
//! EfficientNet-B0 encoder with the same decoder (seeded random weights: the timing does not
//! depend on the values). The paper reports 9.03 ms per inference.
//!
//! `cargo bench -p subgoal-infer --bench inference`

use criterion::{criterion_group, criterion_main, Criterion};
use subgoal_infer::grid::{Costmap, LETHAL};
use subgoal_infer::model::{Arch, EfficientNetConfig};
use subgoal_infer::SubgoalModel;

fn costmap() -> Vec<u8> {
    let mut map = Costmap::ddpen([0.0, 0.0]);
    for i in 0..40 {
        let t = i as f64 / 40.0;
        map.mark([2.0, -1.0 + 2.0 * t], LETHAL);
        map.mark([-1.5 + t, 2.5], LETHAL);
    }
    map.cells().to_vec()
}

fn inference(c: &mut Criterion) {
    let cells = costmap();
    let default = SubgoalModel::default_model().expect("the shipped model loads");
    let mut b0_config = default.config().clone();
    b0_config.arch = Arch::Efficientnet;
    b0_config.cnn = None;
    b0_config.efficientnet = Some(EfficientNetConfig::b0());
    let b0 = SubgoalModel::with_random_weights(b0_config, 0).expect("B0 builds");
    let mut group = c.benchmark_group("subgoal_inference");
    group.bench_function("default_cnn", |b| {
        b.iter(|| default.predict(&cells, [4.5, 0.5]).unwrap())
    });
    group.sample_size(20);
    group.bench_function("efficientnet_b0", |b| {
        b.iter(|| b0.predict(&cells, [4.5, 0.5]).unwrap())
    });
    group.finish();
}

criterion_group!(benches, inference);
criterion_main!(benches);
