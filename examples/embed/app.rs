//! The integrator's view of drape: an "engine" that owns its Vulkan instance, device, queue and
//! command buffers, imports them into drape, and each frame records drape's step and then a
//! graphics pass (`drape::render`: the cloth drawn straight from drape's vertex buffers, the
//! collider moving along a path) into one command buffer of its own.

use ash::vk;
use drape::render::{CLOTH_COLOR, COLLIDER_COLOR, Camera, RawDraw, Renderer, SurfaceMesh};
use drape::scenes::DrapeScene;
use drape::{Context, ExternalDevice, Model, SimSettings, Solver, rigid_pose};
use drape_types::RigidPose;
use glam::{Mat4, Quat, Vec3, Vec4};
use std::ffi::c_void;
use std::path::PathBuf;
use std::sync::Mutex;

/// What the example runs.
#[derive(Clone, Debug)]
pub struct Options {
    pub frames: u32,
    /// Where `frame_NNNN.png` goes (every `every`-th frame and the last); none: no files.
    pub out: Option<PathBuf>,
    pub every: u32,
    pub width: u32,
    pub height: u32,
    /// Cloth particles per side.
    pub grid: u32,
    /// Collider voxels per axis.
    pub voxels: u32,
}

impl Default for Options {
    fn default() -> Self {
        Options { frames: 60, out: None, every: 10, width: 640, height: 480, grid: 48, voxels: 16 }
    }
}

/// The last frame, as drawn and as simulated (the fields the binary does not print are what
/// `tests/example_embed.rs` checks the picture against).
#[allow(dead_code)]
pub struct Outcome {
    /// RGBA8, rows top to bottom.
    pub pixels: Vec<u8>,
    pub width: u32,
    pub height: u32,
    /// World -> clip (Vulkan: y down, depth 0..1), as the shaders used it.
    pub view_projection: Mat4,
    pub cloth_positions: Vec<Vec4>,
    pub cloth_triangles: Vec<[u32; 3]>,
    /// The collider's triangles in the world, at the last frame's pose.
    pub collider_triangles: Vec<[Vec3; 3]>,
    pub written: Vec<PathBuf>,
    /// Whether the validation layer watched the run (it is used when installed).
    pub validated: bool,
}

pub type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// Validation errors of the engine's messenger.
static VALIDATION_ERRORS: Mutex<Vec<String>> = Mutex::new(Vec::new());

unsafe extern "system" fn on_validation(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    _user: *mut c_void,
) -> vk::Bool32 {
    if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
        let message = unsafe { data.as_ref().and_then(|d| d.message_as_c_str()) }
            .map(|m| m.to_string_lossy().into_owned())
            .unwrap_or_default();
        if let Ok(mut errors) = VALIDATION_ERRORS.lock() {
            errors.push(message);
        }
    }
    vk::FALSE
}

/// The engine's Vulkan objects; destroyed in reverse order on drop.
struct Engine {
    entry: ash::Entry,
    instance: ash::Instance,
    messenger: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    physical: vk::PhysicalDevice,
    device: ash::Device,
    family: u32,
    queue: vk::Queue,
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
}

impl Engine {
    fn new() -> Result<Self> {
        let entry = unsafe { ash::Entry::load()? };
        let validation = c"VK_LAYER_KHRONOS_validation";
        let has_validation = unsafe { entry.enumerate_instance_layer_properties()? }
            .iter()
            .any(|l| l.layer_name_as_c_str() == Ok(validation));
        let layers = if has_validation { vec![validation.as_ptr()] } else { vec![] };
        let extensions = if has_validation { vec![ash::ext::debug_utils::NAME.as_ptr()] } else { vec![] };
        let app =
            vk::ApplicationInfo::default().application_name(c"drape embed example").api_version(vk::API_VERSION_1_3);
        let info = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layers)
            .enabled_extension_names(&extensions);
        let instance = unsafe { entry.create_instance(&info, None)? };
        let messenger = if has_validation {
            let utils = ash::ext::debug_utils::Instance::new(&entry, &instance);
            let info = vk::DebugUtilsMessengerCreateInfoEXT::default()
                .message_severity(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR)
                .message_type(
                    vk::DebugUtilsMessageTypeFlagsEXT::GENERAL | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION,
                )
                .pfn_user_callback(Some(on_validation));
            let messenger = unsafe { utils.create_debug_utils_messenger(&info, None)? };
            Some((utils, messenger))
        } else {
            None
        };
        // An engine's choice: a discrete GPU over an integrated one over anything else, with a
        // queue family that does graphics and compute.
        let rank = |t: vk::PhysicalDeviceType| match t {
            vk::PhysicalDeviceType::DISCRETE_GPU => 0,
            vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
            _ => 2,
        };
        let (physical, family) = unsafe { instance.enumerate_physical_devices()? }
            .into_iter()
            .filter_map(|pd| {
                let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
                let wanted = vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE;
                let family = families.iter().position(|f| f.queue_flags.contains(wanted))?;
                Some((pd, family as u32))
            })
            .min_by_key(|&(pd, _)| rank(unsafe { instance.get_physical_device_properties(pd) }.device_type))
            .ok_or("no Vulkan device with a graphics + compute queue (install a driver, e.g. mesa-vulkan-drivers)")?;
        let priorities = [1.0];
        let queues = [vk::DeviceQueueCreateInfo::default().queue_family_index(family).queue_priorities(&priorities)];
        // drape needs the Vulkan memory model (device scope); its renderer needs nothing more.
        let mut features12 = vk::PhysicalDeviceVulkan12Features::default()
            .vulkan_memory_model(true)
            .vulkan_memory_model_device_scope(true);
        let info = vk::DeviceCreateInfo::default().queue_create_infos(&queues).push_next(&mut features12);
        let device = unsafe { instance.create_device(physical, &info, None)? };
        let queue = unsafe { device.get_device_queue(family, 0) };
        let pool = unsafe {
            device.create_command_pool(
                &vk::CommandPoolCreateInfo::default()
                    .queue_family_index(family)
                    .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER),
                None,
            )?
        };
        let cmd = unsafe {
            device.allocate_command_buffers(
                &vk::CommandBufferAllocateInfo::default().command_pool(pool).command_buffer_count(1),
            )?[0]
        };
        let fence = unsafe { device.create_fence(&vk::FenceCreateInfo::default(), None)? };
        Ok(Engine { entry, instance, messenger, physical, device, family, queue, pool, cmd, fence })
    }

    /// Records `body` into the engine's command buffer, submits it and waits for it.
    fn submit(&self, body: impl FnOnce(vk::CommandBuffer) -> Result<()>) -> Result<()> {
        let d = &self.device;
        unsafe {
            d.reset_command_buffer(self.cmd, vk::CommandBufferResetFlags::empty())?;
            d.begin_command_buffer(
                self.cmd,
                &vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
            )?;
            body(self.cmd)?;
            d.end_command_buffer(self.cmd)?;
            let cmds = [self.cmd];
            d.queue_submit(self.queue, &[vk::SubmitInfo::default().command_buffers(&cmds)], self.fence)?;
            d.wait_for_fences(&[self.fence], true, u64::MAX)?;
            d.reset_fences(&[self.fence])?;
        }
        Ok(())
    }
}

impl Drop for Engine {
    fn drop(&mut self) {
        unsafe {
            let _ = self.device.device_wait_idle();
            self.device.destroy_fence(self.fence, None);
            self.device.destroy_command_pool(self.pool, None);
            self.device.destroy_device(None);
            if let Some((utils, messenger)) = self.messenger.take() {
                utils.destroy_debug_utils_messenger(messenger, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}

/// The collider's path: sways sideways and turns about the vertical, period 3 s.
pub fn collider_pose(time: f32) -> (Quat, Vec3) {
    let phase = std::f32::consts::TAU * time / 3.0;
    (Quat::from_rotation_y(0.5 * phase.sin()), Vec3::new(0.12 * phase.sin(), 0.0, 0.0))
}

/// The fixed camera: above and in front of the scene, looking at its middle.
pub fn camera(width: u32, height: u32) -> Camera {
    Camera::look_at(Vec3::new(0.0, 1.3, 1.8), Vec3::new(0.0, 0.45, 0.0), width as f32 / height as f32, 0.05, 20.0)
}

/// Runs the example: `options.frames` frames of the default drape scene with a moving collider.
pub fn run(options: &Options) -> Result<Outcome> {
    if options.frames == 0 || options.every == 0 || options.width == 0 || options.height == 0 {
        return Err("--frames, --every, --width and --height must be at least 1".into());
    }
    if let Some(out) = &options.out {
        std::fs::create_dir_all(out).map_err(|e| format!("output directory {}: {e}", out.display()))?;
    }
    VALIDATION_ERRORS.lock().map_err(|_| "validation log poisoned")?.clear();
    let engine = Engine::new()?;
    let outcome = simulate_and_draw(&engine, options)?;
    let errors = std::mem::take(&mut *VALIDATION_ERRORS.lock().map_err(|_| "validation log poisoned")?);
    if !errors.is_empty() {
        return Err(format!("validation errors:\n{}", errors.join("\n")).into());
    }
    Ok(Outcome { validated: engine.messenger.is_some(), ..outcome })
}

/// The frame loop. Everything drape made is dropped before the engine's device.
fn simulate_and_draw(engine: &Engine, options: &Options) -> Result<Outcome> {
    // SAFETY: the engine's handles are valid, come from one another, the device has the
    // features drape needs, and they outlive `ctx` (dropped at the end of this function);
    // only this thread uses the queue.
    let ctx = unsafe {
        Context::import(
            ExternalDevice::new(
                engine.entry.clone(),
                engine.instance.clone(),
                engine.physical,
                engine.device.clone(),
                engine.family,
                0,
            )
            // With validation the instance has VK_EXT_debug_utils: drape's passes show up labelled
            // in captures of the engine's command buffer.
            .with_debug_utils(engine.messenger.is_some()),
        )?
    };
    let scene = DrapeScene::standard(&drape::scenes::default_mesh(), options.grid);
    // The model: what is simulated, fixed once built; the solver advances its state.
    let mut model = Model::builder();
    let cloth = model.add_cloth(scene.cloth.build()?);
    let body = model.add_collider(scene.collider(options.voxels)?);
    let model = model.settings(SimSettings::default().with_timestamps(false)).build()?;
    let mut sim = Solver::new(&ctx, &model)?;
    let buffers = sim.vertex_buffers(cloth)?;
    let frame_dt = sim.settings().frame_dt;

    let mesh = &scene.mesh;
    // The collider's vertex buffers, drawn at its pose each frame.
    let collider_mesh = SurfaceMesh::new(&ctx, &mesh.vertices, &mesh.triangles)?;
    let renderer = Renderer::new(&ctx, options.width, options.height)?;
    let camera = camera(options.width, options.height);
    let mut written = Vec::new();
    let mut pose = RigidPose::IDENTITY;
    for frame in 1..=options.frames {
        let (rotation, translation) = collider_pose(frame as f32 * frame_dt);
        sim.set_collider_pose(body, rotation, translation)?;
        pose = rigid_pose(rotation, translation);
        let draws = [RawDraw::cloth(&buffers, CLOTH_COLOR), RawDraw::mesh(&collider_mesh, pose, COLLIDER_COLOR)];
        engine.submit(|cmd| {
            // SAFETY: `cmd` is recording on the device drape and the renderer were made on;
            // drape's frame ends with a barrier to vertex input, and every buffer drawn lives
            // until the submission is waited for.
            unsafe {
                sim.record(cmd)?;
                renderer.record(cmd, &camera, &draws);
            }
            Ok(())
        })?;
        // The frame is complete (waited for): its blow-up status is readable.
        sim.poll_status()?;
        if let Some(out) = &options.out
            && (frame % options.every == 0 || frame == options.frames)
        {
            let path = out.join(format!("frame_{frame:04}.png"));
            // SAFETY: the submission was waited for.
            unsafe { renderer.picture() }?.write_png(&path)?;
            written.push(path);
        }
    }
    // SAFETY: the last submission was waited for.
    let pixels = unsafe { renderer.picture() }?.rgba;
    let collider_triangles =
        mesh.triangles.iter().map(|t| t.map(|i| pose_point(&pose, mesh.vertices[i as usize]))).collect();
    Ok(Outcome {
        pixels,
        width: options.width,
        height: options.height,
        view_projection: camera.view_projection,
        cloth_positions: sim.positions(cloth)?,
        cloth_triangles: model.cloths()[cloth.index()].triangles(),
        collider_triangles,
        written,
        validated: false,
    })
}

fn pose_point(pose: &RigidPose, p: Vec3) -> Vec3 {
    Quat::from_vec4(pose.rotation) * p + pose.translation.truncate()
}
