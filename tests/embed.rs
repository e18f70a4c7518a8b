//! The integrator's view: drape on a device the caller created, buffers a renderer binds, and
//! runtime changes without a rebuild.

mod common;

use ash::vk;
use common::{VulkanTurn, assert_validation_clean, context};
use drape::{ClothBuilder, ClothId, ColliderId, Context, ExternalDevice, Model, SimSettings, Solver};
use glam::{Vec3, Vec4};
use std::ffi::c_void;
use std::sync::Mutex;

/// The only cloth of the models here.
const CLOTH: ClothId = ClothId::new(0);

/// Validation errors seen by the test's own messenger (the caller owns validation here).
static CALLER_VALIDATION: Mutex<Vec<String>> = Mutex::new(Vec::new());

unsafe extern "system" fn caller_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    _user: *mut c_void,
) -> vk::Bool32 {
    if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
        let message = unsafe { data.as_ref().and_then(|d| d.message_as_c_str()) }
            .map(|m| m.to_string_lossy().into_owned())
            .unwrap_or_default();
        CALLER_VALIDATION.lock().unwrap().push(message);
    }
    vk::FALSE
}

/// What an engine creates itself: instance (validation on), device with the features drape
/// documents, one compute-capable queue.
struct CallerDevice {
    entry: ash::Entry,
    instance: ash::Instance,
    messenger: (ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT),
    physical: vk::PhysicalDevice,
    device: ash::Device,
    family: u32,
    /// Released after `Drop` destroys the device and instance (`common::VulkanTurn`).
    _turn: VulkanTurn,
}

impl CallerDevice {
    /// Made under drape's loader lock: other tests make and drop contexts on their threads
    /// meanwhile (`drape::vulkan_loader_lock`).
    fn new() -> Self {
        let turn = VulkanTurn::take();
        let _loader = drape::vulkan_loader_lock();
        unsafe {
            let entry = ash::Entry::load().expect("Vulkan loader");
            let app = vk::ApplicationInfo::default().api_version(vk::API_VERSION_1_2);
            let layers = [c"VK_LAYER_KHRONOS_validation".as_ptr()];
            let extensions = [ash::ext::debug_utils::NAME.as_ptr()];
            let info = vk::InstanceCreateInfo::default()
                .application_info(&app)
                .enabled_layer_names(&layers)
                .enabled_extension_names(&extensions);
            let instance = entry.create_instance(&info, None).expect("instance with validation");
            let utils = ash::ext::debug_utils::Instance::new(&entry, &instance);
            let messenger_info = vk::DebugUtilsMessengerCreateInfoEXT::default()
                .message_severity(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR)
                .message_type(
                    vk::DebugUtilsMessageTypeFlagsEXT::GENERAL | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION,
                )
                .pfn_user_callback(Some(caller_callback));
            let messenger = utils.create_debug_utils_messenger(&messenger_info, None).unwrap();
            let physical = instance.enumerate_physical_devices().unwrap()[0];
            let family = instance
                .get_physical_device_queue_family_properties(physical)
                .iter()
                .position(|f| f.queue_flags.contains(vk::QueueFlags::COMPUTE))
                .unwrap() as u32;
            let priorities = [1.0];
            let queues =
                [vk::DeviceQueueCreateInfo::default().queue_family_index(family).queue_priorities(&priorities)];
            let mut f12 = vk::PhysicalDeviceVulkan12Features::default()
                .vulkan_memory_model(true)
                .vulkan_memory_model_device_scope(true);
            let device_info = vk::DeviceCreateInfo::default().queue_create_infos(&queues).push_next(&mut f12);
            let device = instance.create_device(physical, &device_info, None).unwrap();
            CallerDevice { entry, instance, messenger: (utils, messenger), physical, device, family, _turn: turn }
        }
    }

    fn import(&self) -> std::sync::Arc<Context> {
        let external = ExternalDevice::new(
            self.entry.clone(),
            self.instance.clone(),
            self.physical,
            self.device.clone(),
            self.family,
            0,
        )
        // The caller's instance has VK_EXT_debug_utils: drape names its objects and labels its
        // passes inside the caller's command buffers (balanced labels are validated).
        .with_debug_utils(true);
        // SAFETY: handles from `CallerDevice::new`, destroyed only after the context is dropped.
        let ctx = unsafe { Context::import(external) }.expect("import");
        assert!(ctx.debug_names());
        ctx
    }
}

impl Drop for CallerDevice {
    fn drop(&mut self) {
        let _loader = drape::vulkan_loader_lock();
        unsafe {
            self.device.destroy_device(None);
            self.messenger.0.destroy_debug_utils_messenger(self.messenger.1, None);
            self.instance.destroy_instance(None);
        }
    }
}

fn cloth() -> drape::Cloth {
    ClothBuilder::new(12, 12).pin_top_corners().build().unwrap()
}

/// drape on the caller's device steps a cloth exactly as on its own device, and leaves the
/// caller's device alive and usable when dropped.
#[test]
fn an_imported_device_steps_a_cloth_and_survives_drape() {
    let caller = CallerDevice::new();
    let ctx = caller.import();
    assert!(!ctx.owns_device());
    let settings = SimSettings::default().with_substeps(Some(4));
    let mut sim = Solver::new(&ctx, &Model::single(&cloth(), &[], settings).unwrap()).unwrap();
    for _ in 0..10 {
        sim.step().unwrap();
    }
    let imported = sim.positions(CLOTH).unwrap();
    drop(sim);
    drop(ctx);

    let own = context();
    let mut reference = Solver::new(&own, &Model::single(&cloth(), &[], settings).unwrap()).unwrap();
    for _ in 0..10 {
        reference.step().unwrap();
    }
    assert_eq!(imported, reference.positions(CLOTH).unwrap(), "same driver, same kernels: same bits");
    assert_validation_clean(&own);

    // The caller's device still works: drape destroyed nothing of it.
    unsafe {
        let fence = caller.device.create_fence(&vk::FenceCreateInfo::default(), None).unwrap();
        caller.device.destroy_fence(fence, None);
        caller.device.device_wait_idle().unwrap();
    }
    let errors = std::mem::take(&mut *CALLER_VALIDATION.lock().unwrap());
    assert!(errors.is_empty(), "validation errors:\n{}", errors.join("\n"));
}

/// A queue family index the device does not have is an error naming it, not a crash.
#[test]
fn importing_a_wrong_queue_family_is_an_error() {
    let caller = CallerDevice::new();
    let external = ExternalDevice::new(
        caller.entry.clone(),
        caller.instance.clone(),
        caller.physical,
        caller.device.clone(),
        99,
        0,
    );
    let err = unsafe { Context::import(external) }.err().expect("family 99 must be refused");
    assert!(err.to_string().contains("queue_family"), "{err}");
}

/// Vertex buffers keep their handles across frames and describe the cloth's triangles.
#[test]
fn vertex_buffers_are_stable_and_describe_the_cloth() {
    let ctx = context();
    let mut sim = Solver::new(&ctx, &Model::single(&cloth(), &[], SimSettings::default()).unwrap()).unwrap();
    let before = sim.vertex_buffers(CLOTH).unwrap();
    sim.step().unwrap();
    assert_eq!(sim.vertex_buffers(CLOTH).unwrap(), before);
    assert_eq!(before.vertex_count, 144);
    assert_eq!(before.index_count, 6 * 11 * 11);
    assert_eq!((before.offset, before.stride, before.format), (0, 16, vk::Format::R32G32B32A32_SFLOAT));
    assert_ne!(before.positions, before.normals);
    assert_validation_clean(&ctx);
}

/// Gravity, wind and the state change between frames without a rebuild, and take effect.
#[test]
fn runtime_changes_take_effect() {
    let ctx = context();
    let free = ClothBuilder::new(8, 8).build().unwrap();
    let mut sim = Solver::new(&ctx, &Model::single(&free, &[], SimSettings::default()).unwrap()).unwrap();
    let start = sim.positions(CLOTH).unwrap();
    // No gravity, at rest: the cloth stays where it is.
    sim.set_gravity(Vec3::ZERO).unwrap();
    for _ in 0..5 {
        sim.step().unwrap();
    }
    let still = sim.positions(CLOTH).unwrap();
    assert!(common::max_distance(&start, &still) < 1e-5, "moved {}", common::max_distance(&start, &still));
    // Wind along +x: every particle moves +x.
    sim.set_external_force(Vec3::new(0.01, 0.0, 0.0)).unwrap();
    for _ in 0..5 {
        sim.step().unwrap();
    }
    let blown = sim.positions(CLOTH).unwrap();
    assert!(blown.iter().zip(&still).all(|(b, s)| b.x > s.x), "wind had no effect");
    // Teleport: positions and velocities are what was set.
    let moved: Vec<Vec3> = start.iter().map(|p| p.truncate() + Vec3::Y).collect();
    sim.teleport(CLOTH, &moved, &vec![Vec3::ZERO; moved.len()]).unwrap();
    assert_eq!(sim.positions(CLOTH).unwrap(), moved.iter().map(|p| p.extend(1.0)).collect::<Vec<Vec4>>());
    assert!(sim.velocities(CLOTH).unwrap().iter().all(|v| *v == Vec4::ZERO));
    // Bad values are refused.
    assert!(sim.set_gravity(Vec3::NAN).is_err());
    assert!(sim.teleport(CLOTH, &moved[1..], &[]).is_err());
    assert!(sim.set_contact(ColliderId::new(0), 0.01, 0.5).is_err(), "no collider");
    assert_validation_clean(&ctx);
}

/// 10,000 frames under validation with, every frame, a collider move, a gravity and a wind
/// change, and now and then a stiffness change (new substep count), a contact change, an
/// animated pin, a deformation (refit) and a teleport: the allocator's allocations and blocks
/// stay exactly as they were after the first frames.
#[test]
fn a_10000_frame_soak_with_motion_and_runtime_changes_allocates_nothing() {
    let ctx = context();
    let small = ClothBuilder::new(4, 4).pin_top_corners().build().unwrap();
    let spheres = vec![Vec4::new(0.0, 0.0, 0.0, 0.1), Vec4::new(0.3, 0.0, 0.0, 0.1)];
    let collider = drape::Collider::new(spheres.clone(), 0.005);
    let settings = SimSettings::default().with_timestamps(false);
    let mut sim =
        Solver::new(&ctx, &Model::single(&small, std::slice::from_ref(&collider), settings).unwrap()).unwrap();
    sim.step().unwrap();
    let start = sim.positions(CLOTH).unwrap();
    let rest: Vec<Vec3> = start.iter().map(|p| p.truncate()).collect();
    let zero = vec![Vec3::ZERO; rest.len()];
    sim.teleport(CLOTH, &rest, &zero).unwrap(); // first use of the staging pool
    let before = sim.memory_report();
    let mut substep_counts = std::collections::BTreeSet::new();
    for frame in 0..10_000u32 {
        let phase = frame as f32 * 0.01;
        let orbit = glam::Quat::from_rotation_y(phase);
        sim.set_collider_pose(ColliderId::new(0), orbit, Vec3::new(0.2 * phase.cos(), -0.3, 0.2 * phase.sin()))
            .unwrap();
        sim.set_gravity(Vec3::new(0.0, -9.81 + phase.sin(), 0.0)).unwrap();
        sim.set_external_force(Vec3::new(0.001 * phase.cos(), 0.0, 0.0)).unwrap();
        if frame % 500 == 0 {
            let k = if frame % 1000 == 0 { 40.0 } else { 160.0 };
            sim.set_stiffness(CLOTH, k, k / 4.0, k / 20.0).unwrap();
            sim.set_contact(ColliderId::new(0), 0.005 + 0.001 * (frame % 3) as f32, 0.2).unwrap();
            let swollen: Vec<Vec4> =
                spheres.iter().map(|s| s.truncate().extend(s.w * (1.0 + 0.1 * phase.sin()))).collect();
            sim.set_collider_spheres(ColliderId::new(0), &swollen).unwrap();
        }
        if frame % 100 == 0 {
            sim.teleport(CLOTH, &rest, &zero).unwrap();
        }
        sim.pin(CLOTH, 3, Some(rest[3] + Vec3::new(0.0, 0.05 * phase.sin(), 0.0))).unwrap();
        sim.step().unwrap();
        substep_counts.insert(sim.stability(CLOTH).unwrap().substeps);
    }
    assert_eq!(sim.memory_report(), before, "memory changed over the soak");
    assert!(substep_counts.len() >= 2, "the stiffness changes should change the substep count");
    assert!(sim.positions(CLOTH).unwrap().iter().all(|p| p.is_finite()));
    assert_validation_clean(&ctx);
}

/// The caller's side of frames in flight: a command pool on drape's queue family, one command
/// buffer and fence per frame slot, submissions to the caller's own queue handle.
struct CallerFrames<'a> {
    caller: &'a CallerDevice,
    pool: vk::CommandPool,
    slots: Vec<(vk::CommandBuffer, vk::Fence)>,
    queue: vk::Queue,
}

impl<'a> CallerFrames<'a> {
    fn new(caller: &'a CallerDevice, in_flight: u32) -> Self {
        unsafe {
            let d = &caller.device;
            let pool = d
                .create_command_pool(
                    &vk::CommandPoolCreateInfo::default()
                        .queue_family_index(caller.family)
                        .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER),
                    None,
                )
                .unwrap();
            let buffers = d
                .allocate_command_buffers(
                    &vk::CommandBufferAllocateInfo::default().command_pool(pool).command_buffer_count(in_flight),
                )
                .unwrap();
            let signalled = vk::FenceCreateInfo::default().flags(vk::FenceCreateFlags::SIGNALED);
            let slots = buffers.into_iter().map(|cb| (cb, d.create_fence(&signalled, None).unwrap())).collect();
            CallerFrames { caller, pool, slots, queue: d.get_device_queue(caller.family, 0) }
        }
    }

    /// Frame `frame`: waits for its slot's previous use, records `body` into the slot's command
    /// buffer and submits it (without waiting).
    fn run(&self, frame: usize, body: impl FnOnce(vk::CommandBuffer)) {
        let (cb, fence) = self.slots[frame % self.slots.len()];
        let d = &self.caller.device;
        unsafe {
            d.wait_for_fences(&[fence], true, u64::MAX).unwrap();
            d.reset_fences(&[fence]).unwrap();
            d.reset_command_buffer(cb, vk::CommandBufferResetFlags::empty()).unwrap();
            d.begin_command_buffer(cb, &vk::CommandBufferBeginInfo::default()).unwrap();
            body(cb);
            d.end_command_buffer(cb).unwrap();
            let cbs = [cb];
            d.queue_submit(self.queue, &[vk::SubmitInfo::default().command_buffers(&cbs)], fence).unwrap();
        }
    }

    fn wait_all(&self) {
        let fences: Vec<vk::Fence> = self.slots.iter().map(|s| s.1).collect();
        unsafe { self.caller.device.wait_for_fences(&fences, true, u64::MAX).unwrap() };
    }
}

impl Drop for CallerFrames<'_> {
    fn drop(&mut self) {
        self.wait_all();
        unsafe {
            for &(_, fence) in &self.slots {
                self.caller.device.destroy_fence(fence, None);
            }
            self.caller.device.destroy_command_pool(self.pool, None);
        }
    }
}

/// Frames recorded into the caller's command buffers (two in flight, submitted by the caller,
/// never waited for by drape) give exactly the positions of drape's own `step()`, and the
/// frames' status is read back one or more frames late without a stall.
#[test]
fn frames_recorded_into_a_callers_command_buffers_match_step() {
    let caller = CallerDevice::new();
    let ctx = caller.import();
    let settings = SimSettings::default().with_substeps(Some(4)).with_timestamps(false);
    let mut sim = Solver::new(&ctx, &Model::single(&cloth(), &[], settings).unwrap()).unwrap();
    let frames = CallerFrames::new(&caller, 2);
    // Frame 5 waits on the GPU for an event the host sets only after polling, so it provably
    // has not finished while `poll_status` runs: the poll must return (no stall) without it.
    let gate = unsafe { caller.device.create_event(&vk::EventCreateInfo::default(), None).unwrap() };
    const GATED: usize = 5;
    for frame in 0..20 {
        // A runtime change mid-run travels inside the caller's command buffer.
        if frame == 10 {
            sim.set_external_force(Vec3::new(0.02, 0.0, 0.0)).unwrap();
        }
        frames.run(frame, |cb| unsafe {
            if frame == GATED {
                caller.device.cmd_wait_events(
                    cb,
                    &[gate],
                    vk::PipelineStageFlags::HOST,
                    vk::PipelineStageFlags::TOP_OF_PIPE,
                    &[],
                    &[],
                    &[],
                );
            }
            sim.record(cb).unwrap();
        });
        sim.poll_status().unwrap();
        assert!(sim.frames_checked() <= sim.frames_done());
        if frame == GATED {
            assert!(sim.frames_checked() < sim.frames_done(), "a frame still running on the GPU is not read");
            assert!(sim.frames_in_flight() > 0);
            unsafe { caller.device.set_event(gate).unwrap() };
        }
    }
    assert_eq!(sim.frames_done(), 20);
    frames.wait_all();
    sim.poll_status().unwrap();
    assert_eq!(sim.frames_checked(), 20, "every frame's status is read");
    assert_eq!(sim.frames_in_flight(), 0);
    let recorded = sim.positions(CLOTH).unwrap();
    drop(frames);
    unsafe { caller.device.destroy_event(gate, None) };
    drop(sim);
    drop(ctx);

    let own = context();
    let mut reference = Solver::new(&own, &Model::single(&cloth(), &[], settings).unwrap()).unwrap();
    for frame in 0..20 {
        if frame == 10 {
            reference.set_external_force(Vec3::new(0.02, 0.0, 0.0)).unwrap();
        }
        reference.step().unwrap();
    }
    assert_eq!(recorded, reference.positions(CLOTH).unwrap(), "recorded frames == step()");
    assert_validation_clean(&own);
    let errors = std::mem::take(&mut *CALLER_VALIDATION.lock().unwrap());
    assert!(errors.is_empty(), "validation errors:\n{}", errors.join("\n"));
}

/// A blow-up in a frame recorded into the caller's command buffer surfaces as the same
/// `Error::Unstable` as with `step()`, from a later `record`/`poll_status`, naming its frame.
#[test]
fn a_blow_up_in_a_recorded_frame_is_reported_late_without_a_stall() {
    let caller = CallerDevice::new();
    let ctx = caller.import();
    // 1 substep of a very stiff cloth: far beyond the stability bound.
    let stiff = ClothBuilder::new(8, 8).pin_top_corners().stiffness(1e6, 1e6, 1e6).build().unwrap();
    let settings = SimSettings::default().with_substeps(Some(1)).with_timestamps(false);
    let mut sim = Solver::new(&ctx, &Model::single(&stiff, &[], settings).unwrap()).unwrap();
    assert!(sim.stability(CLOTH).unwrap().ratio > 10.0);
    let frames = CallerFrames::new(&caller, 2);
    let mut failure = None;
    for frame in 0..60 {
        let mut recorded = Ok(());
        frames.run(frame, |cb| recorded = unsafe { sim.record(cb) });
        if let Err(e) = recorded.and_then(|_| sim.poll_status().map(|_| ())) {
            failure = Some(e);
            break;
        }
    }
    frames.wait_all();
    match failure {
        Some(drape::Error::Unstable { frame, .. }) => assert!((1..60).contains(&frame), "frame {frame}"),
        other => panic!("expected Error::Unstable, got {other:?}"),
    }
    drop(frames);
    drop(sim);
    let errors = std::mem::take(&mut *CALLER_VALIDATION.lock().unwrap());
    assert!(errors.is_empty(), "validation errors:\n{}", errors.join("\n"));
}

/// An engine may make and drop contexts on several threads at once: drape takes its loader lock
/// around what the loader does not guard (`drape::vulkan_loader_lock`, Vulkan-Loader#2018).
/// It runs without validation: the validation layer races on its own map of instances and
/// devices (Vulkan-ValidationLayers#4391), which is why the other tests take turns. A stress
/// test to run by hand (about a minute on 2 cores; the race it guards against never showed in 16
/// such runs, with the lock or without):
/// `cargo test --release --features rebuild-kernels --test embed -- --ignored`.
#[test]
#[ignore = "stress test: about a minute on 2 cores"]
fn contexts_made_and_dropped_on_many_threads_at_once() {
    let threads: Vec<_> = (0..8)
        .map(|t| {
            std::thread::spawn(move || {
                for r in 0..300 {
                    // A context, an LBVH built on it (its pipelines and buffers named), dropped.
                    let ctx = Context::new(drape::Validation::Off).expect("a Vulkan driver");
                    let spheres: Vec<Vec4> = (0..64).map(|i| Vec4::new(i as f32, (t * r) as f32, 0.0, 0.5)).collect();
                    drop(drape::lbvh::GpuLbvh::build(&ctx, &spheres, 0.01).unwrap());
                }
            })
        })
        .collect();
    for thread in threads {
        thread.join().expect("a thread making contexts failed");
    }
}
