//! The Vulkan context: loader, instance, optional validation messenger, device, compute queue and
//! memory allocator. Everything else holds an `Arc<Context>`, so the context outlives every
//! object created from it; `Drop` tears down allocator, device, messenger, instance in that order.

use super::loader_lock::vulkan_loader_lock;
use crate::error::{Error, Result, VkContext};
use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};
use std::ffi::{CStr, c_void};
use std::sync::{Arc, Mutex, MutexGuard};

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// Environment variable that switches the validation layer on (`1`, `true`, `on`).
pub const VALIDATION_ENV: &str = "DRAPE_VALIDATION";

/// Whether to load `VK_LAYER_KHRONOS_validation`.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Validation {
    /// No validation (fastest).
    Off,
    /// Validation when the layer is installed, silently off otherwise.
    IfAvailable,
    /// Validation, or an error when the layer is not installed (tests use this).
    Required,
}

impl Validation {
    /// `IfAvailable` when `DRAPE_VALIDATION` is set to a true value, `Off` otherwise.
    pub fn from_env() -> Self {
        match std::env::var(VALIDATION_ENV).as_deref() {
            Ok("1") | Ok("true") | Ok("on") | Ok("yes") => Validation::IfAvailable,
            _ => Validation::Off,
        }
    }
}

/// Messages the validation layer reported at error severity; shared with its callback.
type ValidationLog = Mutex<Vec<String>>;

/// Device properties the host needs.
#[derive(Clone, Debug)]
pub struct DeviceInfo {
    pub name: String,
    pub driver: String,
    /// Discrete, integrated, virtual GPU or CPU driver.
    pub device_type: vk::PhysicalDeviceType,
    /// Nanoseconds per timestamp tick.
    pub timestamp_period_ns: f32,
    /// Valid bits of the compute queue's timestamps (0 = no timestamps).
    pub timestamp_valid_bits: u32,
    pub max_workgroup_count_x: u32,
    /// The most invocations of a 1-D workgroup: the least of its limits along x and in all.
    pub max_workgroup_invocations: u32,
}

/// Instance, device, queue and allocator.
pub struct Context {
    _entry: ash::Entry,
    pub(crate) instance: ash::Instance,
    /// The physical device the logical one comes from (format queries of the renderer).
    pub(crate) physical_device: vk::PhysicalDevice,
    debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    /// Boxed so its address stays valid for the messenger callback.
    validation_log: Box<ValidationLog>,
    pub(crate) device: ash::Device,
    pub(crate) queue: Mutex<vk::Queue>,
    pub(crate) queue_family: u32,
    allocator: Mutex<Option<Allocator>>,
    info: DeviceInfo,
    /// Whether drape created the instance and device (and so destroys them); false for an
    /// imported device, which drape never destroys.
    owns_device: bool,
    /// `VK_EXT_debug_utils` on the device, when the instance has it: names on buffers and
    /// pipelines, labels on passes, for RenderDoc and Nsight captures.
    debug_names: Option<ash::ext::debug_utils::Device>,
}

/// The caller's Vulkan objects, handed to `Context::import`.
#[non_exhaustive]
pub struct ExternalDevice {
    pub entry: ash::Entry,
    pub instance: ash::Instance,
    pub physical_device: vk::PhysicalDevice,
    pub device: ash::Device,
    /// A queue family with compute support, and the index of the queue in it drape submits to.
    pub queue_family: u32,
    pub queue_index: u32,
    /// Whether the instance was created with `VK_EXT_debug_utils`: then drape names its buffers
    /// and pipelines and labels its passes in the caller's command buffers (captures in
    /// RenderDoc or Nsight show them). Off unless set with `with_debug_utils`.
    pub debug_utils: bool,
}

impl ExternalDevice {
    pub fn new(
        entry: ash::Entry,
        instance: ash::Instance,
        physical_device: vk::PhysicalDevice,
        device: ash::Device,
        queue_family: u32,
        queue_index: u32,
    ) -> Self {
        ExternalDevice { entry, instance, physical_device, device, queue_family, queue_index, debug_utils: false }
    }

    /// Declares that the instance has `VK_EXT_debug_utils` enabled (see `debug_utils`).
    pub fn with_debug_utils(mut self, enabled: bool) -> Self {
        self.debug_utils = enabled;
        self
    }
}

unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    // SAFETY: the layer passes valid callback data; `user` is the boxed log owned by the
    // Context, which destroys the messenger before dropping the box.
    let message = unsafe {
        data.as_ref().and_then(|d| d.message_as_c_str()).map(|m| m.to_string_lossy().into_owned()).unwrap_or_default()
    };
    if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
        log::error!(target: "drape::vulkan", "validation: {message}");
        if let Some(log) = unsafe { (user as *const ValidationLog).as_ref() }
            && let Ok(mut log) = log.lock()
        {
            log.push(message);
        }
    } else if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING) {
        log::warn!(target: "drape::vulkan", "validation: {message}");
    }
    vk::FALSE
}

impl Context {
    /// Opens the first Vulkan device with a compute queue.
    pub fn new(validation: Validation) -> Result<Arc<Self>> {
        // SAFETY: loading the Vulkan loader library; its initialisation has no preconditions.
        let entry = unsafe { ash::Entry::load() }.map_err(|e| Error::NoVulkanLoader(e.to_string()))?;
        let validation_log: Box<ValidationLog> = Box::default();

        let layer_available = || -> Result<bool> {
            // SAFETY: plain query on a loaded entry.
            let layers =
                unsafe { entry.enumerate_instance_layer_properties() }.vk("vkEnumerateInstanceLayerProperties")?;
            Ok(layers.iter().any(|l| l.layer_name_as_c_str().is_ok_and(|n| n == VALIDATION_LAYER)))
        };
        let validate = match validation {
            Validation::Off => false,
            Validation::IfAvailable => layer_available()?,
            Validation::Required => {
                if !layer_available()? {
                    return Err(Error::MissingFeature {
                        device: "Vulkan loader".into(),
                        feature: "VK_LAYER_KHRONOS_validation (install vulkan-validationlayers)",
                    });
                }
                true
            }
        };

        let app = vk::ApplicationInfo::default()
            .application_name(c"drape")
            .engine_name(c"drape")
            .api_version(vk::API_VERSION_1_2);
        let layers = if validate { vec![VALIDATION_LAYER.as_ptr()] } else { vec![] };
        // Debug utils whenever the loader offers it (or validation brings it): names and labels
        // cost nothing at run time and make captures readable.
        // SAFETY: plain query on a loaded entry.
        let debug_utils = validate
            || unsafe { entry.enumerate_instance_extension_properties(None) }
                .vk("vkEnumerateInstanceExtensionProperties")?
                .iter()
                .any(|e| e.extension_name_as_c_str().is_ok_and(|n| n == ash::ext::debug_utils::NAME));
        let extensions = if debug_utils { vec![ash::ext::debug_utils::NAME.as_ptr()] } else { vec![] };
        let mut messenger_info = vk::DebugUtilsMessengerCreateInfoEXT::default()
            .message_severity(
                vk::DebugUtilsMessageSeverityFlagsEXT::ERROR | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING,
            )
            .message_type(
                vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                    | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                    | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
            )
            .pfn_user_callback(Some(debug_callback))
            .user_data(&*validation_log as *const ValidationLog as *mut c_void);
        let mut instance_info = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layers)
            .enabled_extension_names(&extensions);
        if validate {
            // Also catches errors in vkCreateInstance / vkDestroyInstance themselves.
            instance_info = instance_info.push_next(&mut messenger_info);
        }
        // Instance, messenger and device (with its function tables) are made under the loader
        // lock (`super::loader_lock`); the allocator after them needs none.
        let lifecycle = vulkan_loader_lock();
        // SAFETY: create info and everything it points to live across the call.
        let instance = unsafe { entry.create_instance(&instance_info, None) }.map_err(|result| match result {
            vk::Result::ERROR_INCOMPATIBLE_DRIVER => Error::NoComputeDevice,
            result => Error::Vulkan { call: "vkCreateInstance", result },
        })?;

        // From here on, a failure must destroy what exists: build a partial Context.
        let mut partial = PartialContext { entry, instance, debug: None, device: None, lifecycle: Some(lifecycle) };
        if validate {
            let utils = ash::ext::debug_utils::Instance::new(&partial.entry, &partial.instance);
            // SAFETY: valid instance with debug_utils enabled.
            let messenger = unsafe { utils.create_debug_utils_messenger(&messenger_info, None) }
                .vk("vkCreateDebugUtilsMessengerEXT")?;
            partial.debug = Some((utils, messenger));
        }

        let (physical_device, queue_family, info) = pick_device(&partial.instance)?;
        let queue_priorities = [1.0];
        let queue_info =
            [vk::DeviceQueueCreateInfo::default().queue_family_index(queue_family).queue_priorities(&queue_priorities)];
        // rust-gpu always emits the Vulkan memory model; device-scope atomics need its flag.
        let mut features12 = vk::PhysicalDeviceVulkan12Features::default()
            .vulkan_memory_model(true)
            .vulkan_memory_model_device_scope(true);
        let device_info = vk::DeviceCreateInfo::default().queue_create_infos(&queue_info).push_next(&mut features12);
        // SAFETY: physical device from this instance; create info lives across the call.
        let device =
            unsafe { partial.instance.create_device(physical_device, &device_info, None) }.vk("vkCreateDevice")?;
        partial.device = Some(device.clone());
        // SAFETY: the family was created with one queue.
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        // The debug-utils device functions are loaded through vkGetDeviceProcAddr too.
        let debug_names = debug_utils.then(|| ash::ext::debug_utils::Device::new(&partial.instance, &device));
        partial.lifecycle = None;
        let allocator = new_allocator(&partial.instance, &device, physical_device)?;
        let (entry, instance, debug) = partial.into_parts();
        log::info!("drape device: {} ({:?}, {})", info.name, info.device_type, info.driver);
        Ok(Arc::new(Context {
            _entry: entry,
            instance,
            physical_device,
            debug,
            validation_log,
            device,
            queue: Mutex::new(queue),
            queue_family,
            allocator: Mutex::new(Some(allocator)),
            info,
            owns_device: true,
            debug_names,
        }))
    }

    /// drape on the caller's instance, physical device, device and queue. drape never destroys
    /// them; dropping the last `Arc<Context>` (after every simulation made from it) only frees
    /// drape's own memory. Errors name a missing feature or a queue family without compute.
    ///
    /// # Safety
    /// The handles must be valid and come from one another (the device from `physical_device`
    /// of `instance`, created with a queue `queue_index` in `queue_family` and with the Vulkan
    /// 1.2 features `vulkanMemoryModel` and `vulkanMemoryModelDeviceScope` enabled), and they
    /// must outlive the returned context and everything made from it. drape submits to the
    /// queue from the thread that calls `step()`; the caller must not use the same queue at the
    /// same time (Vulkan's external synchronization rule for queues).
    pub unsafe fn import(external: ExternalDevice) -> Result<Arc<Self>> {
        let ExternalDevice { entry, instance, physical_device, device, queue_family, queue_index, debug_utils } =
            external;
        // SAFETY (queries): the caller guarantees valid handles.
        let families = unsafe { instance.get_physical_device_queue_family_properties(physical_device) };
        let family = families.get(queue_family as usize).ok_or_else(|| Error::InvalidParameter {
            name: "queue_family",
            problem: format!("the device has {} queue families, got index {queue_family}", families.len()),
        })?;
        let info = device_info(&instance, physical_device, family.timestamp_valid_bits);
        if !family.queue_flags.contains(vk::QueueFlags::COMPUTE) {
            return Err(Error::MissingFeature {
                device: info.name,
                feature: "compute support in the given queue family (pick a family with VK_QUEUE_COMPUTE_BIT)",
            });
        }
        if queue_index >= family.queue_count {
            return Err(Error::InvalidParameter {
                name: "queue_index",
                problem: format!(
                    "queue family {queue_family} has {} queues, got index {queue_index}",
                    family.queue_count
                ),
            });
        }
        check_features(&instance, physical_device, &info.name)?;
        // SAFETY: the caller guarantees the queue exists (checked against the family above).
        let queue = unsafe { device.get_device_queue(queue_family, queue_index) };
        let allocator = new_allocator(&instance, &device, physical_device)?;
        log::info!("drape on an imported device: {} ({:?})", info.name, info.device_type);
        let debug_names = debug_utils.then(|| {
            let _lifecycle = vulkan_loader_lock();
            ash::ext::debug_utils::Device::new(&instance, &device)
        });
        Ok(Arc::new(Context {
            _entry: entry,
            instance,
            physical_device,
            debug: None,
            validation_log: Box::default(),
            device,
            queue: Mutex::new(queue),
            queue_family,
            allocator: Mutex::new(Some(allocator)),
            info,
            owns_device: false,
            debug_names,
        }))
    }

    /// What drape's memory allocator holds now.
    pub fn allocator_stats(&self) -> AllocatorStats {
        match self.allocator().as_ref() {
            Some(a) => {
                let r = a.generate_report();
                AllocatorStats {
                    allocations: r.allocations.len(),
                    blocks: r.blocks.len(),
                    capacity_bytes: r.total_capacity_bytes,
                    allocated_bytes: r.total_allocated_bytes,
                }
            }
            None => AllocatorStats::default(),
        }
    }

    /// Whether drape created (and will destroy) the instance and device.
    pub fn owns_device(&self) -> bool {
        self.owns_device
    }

    /// The device drape runs on (the caller's, when imported).
    pub fn device(&self) -> &ash::Device {
        &self.device
    }

    /// The queue family drape submits to.
    pub fn queue_family(&self) -> u32 {
        self.queue_family
    }

    /// What runs the kernels.
    pub fn info(&self) -> &DeviceInfo {
        &self.info
    }

    /// Whether the validation layer is loaded.
    pub fn validation_enabled(&self) -> bool {
        self.debug.is_some()
    }

    /// Validation errors reported so far; clears the log.
    pub fn take_validation_errors(&self) -> Vec<String> {
        self.validation_log.lock().map(|mut log| std::mem::take(&mut *log)).unwrap_or_default()
    }

    /// `Err(Error::Validation)` if the validation layer reported an error since the last check.
    pub fn check_validation(&self) -> Result<()> {
        let errors = self.take_validation_errors();
        if errors.is_empty() { Ok(()) } else { Err(Error::Validation(errors.join("\n"))) }
    }

    /// Memory for a resource named `name` with `requirements` in `location` (`linear`: a buffer
    /// or a linear image; false for an optimal-tiling image).
    pub(crate) fn allocate(
        &self,
        name: &str,
        requirements: vk::MemoryRequirements,
        location: gpu_allocator::MemoryLocation,
        linear: bool,
    ) -> Result<gpu_allocator::vulkan::Allocation> {
        let mut guard = self.allocator();
        let allocator = guard
            .as_mut()
            .ok_or_else(|| Error::Kernel { kernel: name.into(), problem: "allocator already destroyed".into() })?;
        Ok(allocator.allocate(&gpu_allocator::vulkan::AllocationCreateDesc {
            name,
            requirements,
            location,
            linear,
            allocation_scheme: gpu_allocator::vulkan::AllocationScheme::GpuAllocatorManaged,
        })?)
    }

    pub(crate) fn allocator(&self) -> MutexGuard<'_, Option<Allocator>> {
        // A poisoned lock only means another thread panicked mid-allocation; the allocator's
        // own state is still consistent, so keep going.
        self.allocator.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Whether drape names its Vulkan objects and labels its passes (`VK_EXT_debug_utils`).
    pub fn debug_names(&self) -> bool {
        self.debug_names.is_some()
    }

    /// The debug-utils device functions, when names and labels are on.
    pub(crate) fn debug_utils(&self) -> Option<&ash::ext::debug_utils::Device> {
        self.debug_names.as_ref()
    }

    /// Names `object` in captures and validation messages (`drape: <name>`); nothing when
    /// debug utils are off. A failure only loses the name.
    pub(crate) fn name_object(&self, object: impl vk::Handle, name: &str) {
        let Some(utils) = &self.debug_names else { return };
        let Ok(name) = std::ffi::CString::new(format!("drape: {name}")) else { return };
        let info = vk::DebugUtilsObjectNameInfoEXT::default().object_handle(object).object_name(&name);
        // The loader's terminator of this call walks every device of the process.
        let _loader = vulkan_loader_lock();
        // SAFETY: the object belongs to this device; the info lives across the call.
        if let Err(e) = unsafe { utils.set_debug_utils_object_name(&info) } {
            log::debug!("vkSetDebugUtilsObjectNameEXT({name:?}): {e}");
        }
    }

    pub(crate) fn queue(&self) -> MutexGuard<'_, vk::Queue> {
        self.queue.lock().unwrap_or_else(|e| e.into_inner())
    }
}

impl Drop for Context {
    fn drop(&mut self) {
        // SAFETY: every object created from this device holds an Arc<Context>, so none is left.
        unsafe {
            if self.owns_device {
                let _ = self.device.device_wait_idle();
            }
            // The allocator frees its memory blocks through the device: drop it first.
            self.allocator().take();
            if !self.owns_device {
                // The caller's instance and device: never destroyed here (drape's own
                // submissions were all waited on).
                return;
            }
            let _lifecycle = vulkan_loader_lock();
            self.device.destroy_device(None);
            if let Some((utils, messenger)) = self.debug.take() {
                utils.destroy_debug_utils_messenger(messenger, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}

/// Owns the instance (and maybe device) while `Context::new` is still failing part way.
struct PartialContext {
    entry: ash::Entry,
    instance: ash::Instance,
    debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    device: Option<ash::Device>,
    /// The loader lock while the messenger and device are being made (`super::loader_lock`).
    lifecycle: Option<MutexGuard<'static, ()>>,
}

type InstanceParts = (ash::Entry, ash::Instance, Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>);

impl PartialContext {
    fn into_parts(self) -> InstanceParts {
        let mut this = std::mem::ManuallyDrop::new(self);
        this.lifecycle = None;
        // SAFETY: fields are moved out exactly once and `this` is never dropped (`device` is a
        // function table with nothing to drop; the lock was released above).
        unsafe { (std::ptr::read(&this.entry), std::ptr::read(&this.instance), std::ptr::read(&this.debug)) }
    }
}

impl Drop for PartialContext {
    fn drop(&mut self) {
        // `Context::new` failing while it creates the messenger or device already holds the lock.
        let _lifecycle = self.lifecycle.take().unwrap_or_else(vulkan_loader_lock);
        // SAFETY: reverse creation order; nothing else refers to these handles yet.
        unsafe {
            if let Some(device) = self.device.take() {
                device.destroy_device(None);
            }
            if let Some((utils, messenger)) = self.debug.take() {
                utils.destroy_debug_utils_messenger(messenger, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}

/// Memory blocks start small (a 64^2 cloth with its collider needs a few MiB, not the
/// allocator's default 256 MiB block) and double as a simulation grows.
fn allocation_sizes() -> gpu_allocator::AllocationSizes {
    const MIB: u64 = 1024 * 1024;
    gpu_allocator::AllocationSizes::new(8 * MIB, 4 * MIB)
        .with_max_device_memblock_size(256 * MIB)
        .with_max_host_memblock_size(64 * MIB)
}

/// drape's memory allocator on a device.
fn new_allocator(
    instance: &ash::Instance,
    device: &ash::Device,
    physical_device: vk::PhysicalDevice,
) -> Result<Allocator> {
    Ok(Allocator::new(&AllocatorCreateDesc {
        instance: instance.clone(),
        device: device.clone(),
        physical_device,
        debug_settings: Default::default(),
        buffer_device_address: false,
        allocation_sizes: allocation_sizes(),
    })?)
}

/// What drape's allocator holds on a context.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
#[non_exhaustive]
pub struct AllocatorStats {
    /// Live allocations (buffers, staging).
    pub allocations: usize,
    /// Vulkan memory blocks, and their total size.
    pub blocks: usize,
    pub capacity_bytes: u64,
    /// Bytes used by live allocations.
    pub allocated_bytes: u64,
}

/// Preference of a device type when drape creates the device: a discrete GPU over an
/// integrated one over a virtual one over a CPU driver (lavapipe).
fn type_rank(t: vk::PhysicalDeviceType) -> u32 {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => 0,
        vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
        vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
        vk::PhysicalDeviceType::CPU => 3,
        _ => 4,
    }
}

/// The best physical device (see `type_rank`) with a compute queue and the Vulkan memory model
/// features.
fn pick_device(instance: &ash::Instance) -> Result<(vk::PhysicalDevice, u32, DeviceInfo)> {
    // SAFETY: plain queries on a valid instance.
    let devices = unsafe { instance.enumerate_physical_devices() }.vk("vkEnumeratePhysicalDevices")?;
    let mut missing: Option<Error> = None;
    let mut best: Option<(u32, vk::PhysicalDevice, u32, DeviceInfo)> = None;
    for pd in devices {
        match describe_device(instance, pd) {
            Ok((family, info, rank)) => {
                if best.as_ref().is_none_or(|(r, ..)| rank < *r) {
                    best = Some((rank, pd, family, info));
                }
            }
            Err(e @ Error::MissingFeature { .. }) => missing = Some(e),
            Err(_) => {}
        }
    }
    match best {
        Some((_, pd, family, info)) => Ok((pd, family, info)),
        None => Err(missing.unwrap_or(Error::NoComputeDevice)),
    }
}

/// A device's compute queue family, properties and type rank, or what it lacks.
pub(crate) fn describe_device(instance: &ash::Instance, pd: vk::PhysicalDevice) -> Result<(u32, DeviceInfo, u32)> {
    // SAFETY: plain queries on a valid instance and one of its physical devices.
    let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
    // A family that also draws, where there is one: the pictures (`crate::render`) need it.
    let graphics_and_compute = vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE;
    let (family, props) = families
        .iter()
        .enumerate()
        .find(|(_, f)| f.queue_flags.contains(graphics_and_compute))
        .or_else(|| families.iter().enumerate().find(|(_, f)| f.queue_flags.contains(vk::QueueFlags::COMPUTE)))
        .ok_or(Error::NoComputeDevice)?;
    let info = device_info(instance, pd, props.timestamp_valid_bits);
    check_features(instance, pd, &info.name)?;
    let rank = type_rank(info.device_type);
    Ok((family as u32, info, rank))
}

/// Properties of `pd` that the host needs.
pub(crate) fn device_info(instance: &ash::Instance, pd: vk::PhysicalDevice, timestamp_valid_bits: u32) -> DeviceInfo {
    let mut driver = vk::PhysicalDeviceDriverProperties::default();
    let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut driver);
    // SAFETY: plain query on a valid physical device.
    unsafe { instance.get_physical_device_properties2(pd, &mut props2) };
    let properties = props2.properties;
    DeviceInfo {
        name: properties.device_name_as_c_str().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
        driver: driver.driver_info_as_c_str().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
        device_type: properties.device_type,
        timestamp_period_ns: properties.limits.timestamp_period,
        timestamp_valid_bits,
        max_workgroup_count_x: properties.limits.max_compute_work_group_count[0],
        max_workgroup_invocations: properties
            .limits
            .max_compute_work_group_invocations
            .min(properties.limits.max_compute_work_group_size[0]),
    }
}

/// Errors naming the Vulkan 1.2 features the kernels need that `pd` does not support.
pub(crate) fn check_features(instance: &ash::Instance, pd: vk::PhysicalDevice, name: &str) -> Result<()> {
    let mut f12 = vk::PhysicalDeviceVulkan12Features::default();
    let mut f2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut f12);
    // SAFETY: plain query on a valid physical device.
    unsafe { instance.get_physical_device_features2(pd, &mut f2) };
    if f12.vulkan_memory_model == 0 || f12.vulkan_memory_model_device_scope == 0 {
        return Err(Error::MissingFeature {
            device: name.into(),
            feature: "vulkanMemoryModel + vulkanMemoryModelDeviceScope",
        });
    }
    Ok(())
}
