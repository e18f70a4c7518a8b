//! Shared test helpers: a validated Vulkan context and small comparisons.
#![allow(dead_code)]

use drape::{Context, Validation};
use glam::Vec4;
use std::cell::Cell;
use std::sync::{Arc, Mutex, MutexGuard};

/// The validation layer this project tests with (Debian 12's 1.3.239) keeps its instances and
/// devices in a process-wide map that every intercepted call reads and that creating or
/// destroying an instance or device changes, without a lock
/// (KhronosGroup/Vulkan-ValidationLayers#4391). Tests run on parallel threads, so one test's
/// new or dropped context could crash another's Vulkan calls: CI died of SIGSEGV in
/// `tests/collision.rs` once in 37 runs, and 8 threads making 300 validated contexts each
/// crashed in 2 of 9 runs (in 1 of 13 with drape's own loader lock). Each test therefore takes
/// its turn on Vulkan for as long as it holds a context; tests without one (the CPU twin's,
/// the CLI's subprocesses) still run beside it.
static VULKAN_TURN: Mutex<()> = Mutex::new(());

thread_local! {
    /// Turns this thread holds (a test may hold a context and a device of its own at once).
    static TURNS_HELD: Cell<u32> = const { Cell::new(0) };
}

/// This test's turn on Vulkan (`VULKAN_TURN`), taken by the first of a thread's holders.
pub struct VulkanTurn {
    _guard: Option<MutexGuard<'static, ()>>,
}

impl VulkanTurn {
    pub fn take() -> Self {
        let held = TURNS_HELD.get();
        TURNS_HELD.set(held + 1);
        // A test that failed while holding the turn poisons it; the next test is still valid.
        let guard = (held == 0).then(|| VULKAN_TURN.lock().unwrap_or_else(|e| e.into_inner()));
        VulkanTurn { _guard: guard }
    }
}

impl Drop for VulkanTurn {
    fn drop(&mut self) {
        TURNS_HELD.set(TURNS_HELD.get() - 1);
    }
}

/// A validated context and the test's turn on Vulkan, released after the context: declare
/// what uses the context after it, so it is dropped first.
pub struct TestContext {
    ctx: Arc<Context>,
    _turn: VulkanTurn,
}

impl std::ops::Deref for TestContext {
    type Target = Arc<Context>;
    fn deref(&self) -> &Arc<Context> {
        &self.ctx
    }
}

/// A context with the validation layer on; tests fail if it is missing or reports an error.
pub fn context() -> TestContext {
    let turn = VulkanTurn::take();
    let ctx = Context::new(Validation::Required).expect("Vulkan with VK_LAYER_KHRONOS_validation");
    assert!(ctx.validation_enabled());
    // Validation brings VK_EXT_debug_utils: every test also runs drape's names and labels.
    assert!(ctx.debug_names());
    TestContext { ctx, _turn: turn }
}

/// Fails the test if the validation layer reported any error.
pub fn assert_validation_clean(ctx: &Context) {
    let errors = ctx.take_validation_errors();
    assert!(errors.is_empty(), "validation errors:\n{}", errors.join("\n"));
}

/// Runs `frames` frames of `cloth` against `collider` three ways: candidate lists on the GPU
/// (the narrow phase inside the last integration stage), the LBVH walk on the GPU (cull,
/// detect and respond in passes of their own) and candidate lists on the CPU twin; asserts that
/// every frame's positions are equal bit for bit, and the GPU's velocities the CPU's. Returns
/// how many frames the first run reported contact in.
pub fn assert_fused_contact_equals_walk_and_cpu(
    ctx: &Arc<Context>,
    cloth: &drape::Cloth,
    collider: &drape::Collider,
    settings: drape::SimSettings,
    frames: u32,
) -> u32 {
    use drape::{ClothId, ContactSearch, CpuSolver, Model, Solver};
    let cloth_id = ClothId::new(0);
    let model =
        |search: ContactSearch| Model::single(cloth, &[collider.clone().with_search(search)], settings).unwrap();
    let mut fused = Solver::new(ctx, &model(ContactSearch::CandidateLists)).unwrap();
    let mut walk = Solver::new(ctx, &model(ContactSearch::TraverseEverySubstep)).unwrap();
    let mut cpu = CpuSolver::new(&model(ContactSearch::CandidateLists)).unwrap();
    let mut contact_frames = 0;
    for f in 1..=frames {
        let report = fused.step_report().unwrap();
        walk.step().unwrap();
        cpu.step().unwrap();
        contact_frames += (report.collision_ran > 0) as u32;
        let x = fused.positions(cloth_id).unwrap();
        assert_eq!(x, walk.positions(cloth_id).unwrap(), "frame {f}: fused != walk");
        assert_eq!(x, cpu.positions(cloth_id).unwrap(), "frame {f}: GPU != CPU");
        assert_eq!(fused.velocities(cloth_id).unwrap(), cpu.velocities(cloth_id).unwrap(), "frame {f}: GPU != CPU");
    }
    contact_frames
}

/// Largest distance between corresponding xyz.
pub fn max_distance(a: &[Vec4], b: &[Vec4]) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(p, q)| (p.truncate() - q.truncate()).length()).fold(0.0, f32::max)
}

/// Small deterministic PRNG (xorshift64*), so tests need no extra crate.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    pub fn next_u32(&mut self) -> u32 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 32) as u32
    }
    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * (self.next_u32() >> 8) as f32 / (1u32 << 24) as f32
    }
}

/// A closed box `size` (x, y, z) centred at the origin, outward-facing triangles.
pub fn slab(size: glam::Vec3) -> drape::Mesh {
    let h = size / 2.0;
    let corner = |i: u32| {
        glam::Vec3::new(
            if i & 1 != 0 { h.x } else { -h.x },
            if i & 2 != 0 { h.y } else { -h.y },
            if i & 4 != 0 { h.z } else { -h.z },
        )
    };
    let quads = [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]];
    let triangles = quads.iter().flat_map(|[a, b, c, d]| [[*a, *b, *c], [*a, *c, *d]]).collect();
    drape::Mesh { vertices: (0..8).map(corner).collect(), triangles }
}

/// A `width x depth` (m) sheet of `columns x rows` vertices in the XZ plane, its lowest corner at
/// `corner`, each cell cut along its diagonal.
pub fn sheet(columns: u32, rows: u32, (width, depth): (f32, f32), corner: glam::Vec3) -> drape::ClothMesh {
    let mut vertices = Vec::new();
    for r in 0..rows {
        for c in 0..columns {
            let (u, v) = (c as f32 / (columns - 1) as f32, r as f32 / (rows - 1) as f32);
            vertices.push(corner + glam::Vec3::new(u * width, 0.0, v * depth));
        }
    }
    let mut triangles = Vec::new();
    for r in 0..rows - 1 {
        for c in 0..columns - 1 {
            let a = r * columns + c;
            triangles.push([a, a + 1, a + columns + 1]);
            triangles.push([a, a + columns + 1, a + columns]);
        }
    }
    drape::ClothMesh::from_parts(vertices, triangles).unwrap()
}

/// A `size` m square sheet of `n x n` vertices centred over the origin at height `y`, as OBJ
/// text with UVs.
pub fn sheet_obj(n: u32, size: f32, y: f32) -> String {
    let mesh = sheet(n, n, (size, size), glam::Vec3::new(-0.5 * size, y, -0.5 * size));
    let mut text = String::new();
    for v in &mesh.vertices {
        text += &format!("v {} {} {}\nvt {} {}\n", v.x, v.y, v.z, 0.5 + v.x / size, 0.5 + v.z / size);
    }
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| i + 1);
        text += &format!("f {a}/{a} {b}/{b} {c}/{c}\n");
    }
    text
}
