//! LBVH build time on the GPU for 125, 32k, 262k and 1M random spheres, with the stage split
//! (GPU timestamps) and the wall time of the build submission. Criterion times the whole
//! build submission; the table gives medians of the stage split.

use criterion::{Criterion, criterion_group, criterion_main};
use drape::lbvh::GpuLbvh;
use drape::timing::median;
use drape::{Context, Validation};
use glam::Vec4;
use std::time::{Duration, Instant};

const SIZES: [u32; 4] = [125, 32_768, 262_144, 1_048_576];

fn spheres(n: u32) -> Vec<Vec4> {
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    (0..n).map(|_| Vec4::new(next(), next(), next(), 0.001 + 0.01 * next())).collect()
}

fn lbvh(c: &mut Criterion) {
    let ctx = Context::new(Validation::Off).expect("a Vulkan driver");
    println!("device: {} ({})", ctx.info().name, ctx.info().driver);
    let mut group = c.benchmark_group("lbvh build");
    group.sample_size(10).warm_up_time(Duration::from_millis(300)).measurement_time(Duration::from_secs(3));
    let mut table = Vec::new();
    for n in SIZES {
        let input = spheres(n);
        let mut lbvh = GpuLbvh::build(&ctx, &input, 0.0).expect("build");
        let mut untimed = lbvh.build_frame(false).expect("record");
        group.bench_function(format!("{n} leaves"), |b| b.iter(|| untimed.submit().expect("build")));
        // Stage split from timestamps, medians over 5 builds.
        let mut stages: Vec<(&'static str, Vec<f64>)> = Vec::new();
        let mut walls = Vec::new();
        let mut spans = Vec::new();
        for _ in 0..5 {
            let start = Instant::now();
            let t = lbvh.rebuild(true).expect("build");
            walls.push(start.elapsed().as_secs_f64() * 1e3);
            spans.extend(t.span_micros);
            for (label, _, micros) in t.by_label() {
                match stages.iter_mut().find(|(l, _)| *l == label) {
                    Some((_, v)) => v.push(micros),
                    None => stages.push((label, vec![micros])),
                }
            }
        }
        let stages = stages.into_iter().map(|(l, v)| (l, median(&v))).collect::<Vec<_>>();
        table.push((n, stages, median(&spans), median(&walls)));
    }
    group.finish();
    println!(
        "\nLBVH build, GPU ms per stage (timestamps, median of 5; span = first stage's start to last \
         stage's end, barriers included; wall includes recording):"
    );
    let labels: Vec<&str> = table[0].1.iter().map(|(l, _)| *l).collect();
    print!("{:>10}", "leaves");
    for l in &labels {
        print!(" {l:>14}");
    }
    println!(" {:>10} {:>10} {:>10}", "GPU total", "span", "wall");
    for (n, stages, span, wall) in &table {
        print!("{n:>10}");
        for (_, micros) in stages {
            print!(" {:>14.3}", micros / 1e3);
        }
        println!(" {:>10.3} {:>10.3} {:>10.3}", stages.iter().map(|(_, m)| m).sum::<f64>() / 1e3, span / 1e3, wall);
    }
}

criterion_group!(benches, lbvh);
criterion_main!(benches);
