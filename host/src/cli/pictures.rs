//! `--png-dir`: pictures of the run, drawn offscreen with Vulkan (`drape::render`): the cloth
//! straight from the solver's vertex buffers and the collider at its pose, seen by a fixed
//! camera that frames the scene at its start.

use drape::mesh::Mesh;
use drape::render::{CLOTH_COLOR, Camera, Draw, Renderer, SurfaceMesh, collider_color, scene_box};
use drape::{ClothId, Context, RigidPose, Solver};
use glam::Vec4;
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub(crate) struct Pictures {
    dir: PathBuf,
    /// Every n-th frame (and the last); None: the last frame only.
    every: Option<u32>,
    renderer: Renderer,
    camera: Camera,
    ctx: Arc<Context>,
    colliders: Vec<SurfaceMesh>,
    /// Each collider's triangles (a deforming one's surface is uploaded again with them).
    triangles: Vec<Vec<[u32; 3]>>,
    pub(crate) written: Vec<PathBuf>,
}

impl Pictures {
    /// A renderer of `size` pictures framing `cloth` (its initial positions) and `colliders`
    /// (at rest).
    pub(crate) fn new(
        ctx: &Arc<Context>,
        dir: &Path,
        every: Option<u32>,
        (width, height): (u32, u32),
        cloth: &[Vec4],
        colliders: &[&Mesh],
    ) -> drape::Result<Self> {
        let boxes: Vec<_> = colliders.iter().map(|m| m.bounds()).collect();
        let (lo, hi) = scene_box(cloth, &boxes);
        Ok(Pictures {
            dir: dir.to_path_buf(),
            every,
            renderer: Renderer::new(ctx, width, height)?,
            camera: Camera::framing(lo, hi, width as f32 / height as f32),
            colliders: colliders
                .iter()
                .map(|m| SurfaceMesh::new(ctx, &m.vertices, &m.triangles))
                .collect::<drape::Result<_>>()?,
            ctx: Arc::clone(ctx),
            triangles: colliders.iter().map(|m| m.triangles.clone()).collect(),
            written: Vec::new(),
        })
    }

    /// Draws and writes `frame_NNNNN.png` if `frame` is one to write (of `frames`), each
    /// collider at its pose in `collider_poses`; `deforming`: the colliders whose shape changes
    /// (index, its mesh now: the same triangles), drawn as it is.
    pub(crate) fn frame(
        &mut self,
        frame: u32,
        frames: u32,
        (solver, cloth): (&Solver, ClothId),
        collider_poses: &[RigidPose],
        deforming: &[(usize, &Mesh)],
    ) -> drape::Result<()> {
        // Every n-th frame and the last (a run shorter than n still gets its picture).
        let due = frame == frames || self.every.is_some_and(|n| frame.is_multiple_of(n));
        if !due {
            return Ok(());
        }
        // A deforming collider's surface is uploaded again only for a picture that shows it.
        for &(i, mesh) in deforming {
            self.colliders[i] = SurfaceMesh::new(&self.ctx, &mesh.vertices, &self.triangles[i])?;
        }
        let mut draws = vec![Draw::Cloth { solver, cloth, color: CLOTH_COLOR }];
        for (i, (mesh, &pose)) in self.colliders.iter().zip(collider_poses).enumerate() {
            draws.push(Draw::Mesh { mesh, pose, color: collider_color(i) });
        }
        let picture = self.renderer.render(&self.camera, &draws)?;
        let path = self.dir.join(format!("frame_{frame:05}.png"));
        picture.write_png(&path)?;
        self.written.push(path);
        Ok(())
    }
}
