//! Criterion benchmarks of one model evaluation: `cargo bench --bench model`.

use criterion::{Criterion, black_box, criterion_group, criterion_main};
use terzaghi::model::{
    FittingWidth, Medium, Plate, RftCoefficients, RftFit, RftModel, TerzaghiModel,
};

fn models(c: &mut Criterion) {
    let plate = Plate::new(0.25, 0.06, 0.15).unwrap();
    let improved = TerzaghiModel::new(
        plate,
        Medium::new(16170.0, 32.0, 19.0).unwrap(),
        FittingWidth::new(2.0, 1.5).unwrap(),
    );
    let rft = RftModel::new(plate, RftCoefficients::Fit(RftFit::POPPY_LP), 100).unwrap();
    let beta = 70f64.to_radians();
    c.bench_function("improved_terzaghi_evaluate", |b| {
        b.iter(|| improved.evaluate(black_box(beta)).unwrap().drag_n)
    });
    c.bench_function("rft_100_elements_evaluate", |b| {
        b.iter(|| rft.evaluate(black_box(beta)).unwrap().drag_n)
    });
}

criterion_group!(benches, models);
criterion_main!(benches);
