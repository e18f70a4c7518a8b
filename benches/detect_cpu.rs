//! The contact searches' cost per particle on the CPU (the kernels' own functions, one core):
//! the standard bunny and dragon scenes are run on the GPU to frames 30, 60 and 120, then the
//! same particle states are searched by the LBVH walk every substep, and by the broad phase once
//! plus the list search, timed over repetitions (fastest of 5). A steadier view than lavapipe's
//! timestamps of where detect's time goes; CPU and GPU run the same code.

use drape::lbvh::build_mesh_cpu;
use drape::scenes::{DrapeScene, shared_model};
use drape::{ClothId, Context, Mesh, Model, SimSettings, Solver, Validation};
use drape_kernels::candidates::{broad_phase_at, detect_candidates_at};
use drape_kernels::contact::{LeafKind, detect_at, local_motion};
use drape_kernels::lbvh::{self, TreeQuery};
use drape_kernels::pose::SubstepMotion;
use drape_kernels::triangles::Triangles;
use drape_types::{Aabb, ColliderPose, Contact, ContactQuery, MAX_CANDIDATES};
use glam::Vec4;
use std::time::Instant;

/// Counts what a contact walk visits: internal nodes entered, leaves handed to the narrow phase.
struct VisitCount {
    p0: glam::Vec3,
    p1: glam::Vec3,
    thickness: f32,
    entered: std::cell::Cell<u32>,
}

impl TreeQuery for VisitCount {
    type Found = (u32, u32);

    fn enters(&self, b: &Aabb) -> bool {
        let enters = Triangles::may_touch(b, self.p0, self.p1, self.thickness);
        self.entered.set(self.entered.get() + enters as u32);
        enters
    }

    fn leaf(&mut self, _leaf: u32, found: &mut (u32, u32)) -> bool {
        found.1 += 1;
        false
    }
}

fn fastest(mut f: impl FnMut()) -> f64 {
    (0..5)
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed().as_secs_f64() * 1e3
        })
        .fold(f64::INFINITY, f64::min)
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    let ctx = Context::new(Validation::Off).expect("a Vulkan driver");
    for (name, file) in [("bunny", "stanford-bunny.obj"), ("dragon", "stanford-dragon-res2.obj")] {
        let path = shared_model(file);
        let mesh = Mesh::load_obj(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let mut scene = DrapeScene::standard(&mesh, 64);
        scene.mesh = scene.mesh.close_small_holes().0;
        let collider = scene.triangle_collider();
        let cloth = scene.cloth.build().unwrap();
        let settings = SimSettings::default().with_timestamps(false);
        let mut sim =
            Solver::new(&ctx, &Model::single(&cloth, std::slice::from_ref(&collider), settings).unwrap()).unwrap();
        let params = *sim.params(ClothId::new(0)).unwrap();
        let m = &scene.mesh;
        let c = drape::lbvh::mesh_collider_params(&m.vertices, &m.triangles, collider.thickness, collider.friction)
            .unwrap();
        let tree = build_mesh_cpu(&m.vertices, &m.triangles, &c).unwrap();
        let n = params.particle_count as usize;
        let substeps = sim.stability(ClothId::new(0)).unwrap().substeps;
        let frame_time = params.substep * substeps as f32;
        let still = SubstepMotion::of(&ColliderPose::default(), 0.0, 1.0, frame_time);
        let step = SubstepMotion::of(&ColliderPose::default(), 0.0, 1.0, params.substep);
        let mut frame = 0;
        for target in [30, 60, 120] {
            while frame < target {
                sim.step().unwrap();
                frame += 1;
            }
            let x = sim.positions(ClothId::new(0)).unwrap();
            let v = sim.velocities(ClothId::new(0)).unwrap();
            // One substep back along the velocity: the substep motion ending at x.
            let x_prev: Vec<Vec4> =
                x.iter().zip(&v).map(|(x, v)| (x.truncate() - v.truncate() * params.substep).extend(x.w)).collect();
            let mut contacts = vec![Contact::NONE; n];
            let mut detect = |i: u32| {
                detect_at::<Triangles>(
                    i,
                    &c,
                    &step,
                    &tree.nodes,
                    &tree.aabbs,
                    &tree.triangles,
                    &x,
                    &x_prev,
                    &mut contacts,
                );
            };
            let walk = fastest(|| (0..n as u32).for_each(&mut detect));
            // Per particle (the fastest of 5, so a preempted call does not count): a GPU dispatch
            // lasts as long as its slowest thread.
            let mut per_particle: Vec<(f64, u32)> = (0..n as u32).map(|i| (fastest(|| detect(i)) * 1e3, i)).collect();
            per_particle.sort_by(|a, b| a.0.total_cmp(&b.0));
            let (slowest, who) = per_particle[n - 1];
            let motion = (x[who as usize] - x_prev[who as usize]).truncate().length();
            let visits = |i: u32| {
                let (p0, p1) = local_motion(i, &step, &x, &x_prev);
                let mut count = VisitCount { p0, p1, thickness: c.thickness, entered: Default::default() };
                let leaves = lbvh::walk(&tree.nodes, &tree.aabbs, c.leaf_count, &mut count, (0u32, 0u32)).1;
                (count.entered.get(), leaves) // the root's box is tested too
            };
            let (nodes_slowest, leaves_slowest) = visits(who);
            let (nodes_median, leaves_median) = visits(per_particle[n / 2].1);
            println!(
                "{name} frame {target:>3}: walk per particle: median {:.2} us ({nodes_median} nodes entered, \
                 {leaves_median} leaves tested), p99 {:.2} us, slowest {slowest:.2} us (particle {who}, moved {:.1} mm, \
                 {nodes_slowest} nodes entered, {leaves_slowest} leaves tested; next {:.2} / {:.2} us)",
                per_particle[n / 2].0,
                per_particle[n * 99 / 100].0,
                motion * 1e3,
                per_particle[n - 2].0,
                per_particle[n - 3].0,
            );
            let mut queries = vec![ContactQuery::default(); n];
            let mut lists = vec![0u32; n * MAX_CANDIDATES as usize];
            let broad = fastest(|| {
                for i in 0..n as u32 {
                    let t = (
                        tree.nodes.as_slice(),
                        tree.aabbs.as_slice(),
                        tree.leaf_bounds.as_slice(),
                        tree.triangles.as_slice(),
                    );
                    broad_phase_at::<Triangles>(i, &params, &c, &still, t, (&x_prev, &v), &mut queries, &mut lists);
                }
            });
            let mut fell = 0;
            let narrow = fastest(|| {
                fell = 0;
                for i in 0..n as u32 {
                    let o = detect_candidates_at::<Triangles>(
                        i,
                        &c,
                        &step,
                        (&tree.nodes, &tree.aabbs, &tree.triangles),
                        (&queries, &lists),
                        (&x, &x_prev),
                        &mut contacts,
                        (0, false),
                    );
                    fell += o.fell_back as u32;
                }
            });
            let counts: Vec<u32> = queries.iter().map(|q| q.count).filter(|&k| k != u32::MAX).collect();
            let mean = counts.iter().map(|&k| k as f64).sum::<f64>() / counts.len().max(1) as f64;
            let overflowed = n - counts.len();
            println!(
                "{name} frame {target:>3}: walk {walk:7.2} ms/substep, lists {narrow:7.2} ms/substep (+ broad {broad:7.2} ms/frame); \
                 mean list {mean:.1}, overflowed {overflowed}, fell back {fell}"
            );
        }
    }
}
