//! One process-wide lock around the Vulkan calls that walk or change the loader's list of every
//! device in the process: creating and destroying instances, messengers and devices (with the
//! device's function table, loaded through `vkGetDeviceProcAddr`), and naming objects.
//!
//! The Vulkan spec lets threads make these calls at once on different instances and devices.
//! Loaders before 1.4.345 (Debian 12's 1.3.239 among them) do not: `vkCreateDevice` and
//! `vkDestroyDevice` change each driver's device list under one lock while
//! `vkGetDeviceProcAddr` and the terminator of `vkSetDebugUtilsObjectNameEXT` walk it under
//! another, so a device destroyed on one thread can be read after it is freed on another, even
//! with an instance per thread (KhronosGroup/Vulkan-Loader#2018, read in the loader's source).
//! None of these calls is on a frame's path (a staging buffer that grows is created and named
//! under it).
//!
//! The validation layer has a race of its own that no lock of drape's can cover: its map of
//! every instance and device is read by every call it intercepts and changed, without a lock,
//! by creating and destroying them (KhronosGroup/Vulkan-ValidationLayers#4391). With the layer
//! on, make and drop contexts while no other thread uses Vulkan (drape's tests take turns).

use std::sync::{Mutex, MutexGuard};

static LOADER_LOCK: Mutex<()> = Mutex::new(());

/// The lock drape holds while it creates or destroys a Vulkan instance, debug messenger or
/// device, loads a device's functions, or names one of its objects. A caller whose other
/// threads do any of these (its own devices, `vkGetDeviceProcAddr`, object names, swapchains)
/// while drape may run takes it around them, bound to a named guard (`let _loader = ...`; `let _
/// = ...` releases it at once). Not reentrant: release it before calling into drape, e.g.
/// before `Context::import` or dropping the last `Solver` or `Arc<Context>`.
pub fn vulkan_loader_lock() -> MutexGuard<'static, ()> {
    // The guarded data is `()`: a thread that panicked while holding the lock left nothing
    // inconsistent.
    LOADER_LOCK.lock().unwrap_or_else(|e| e.into_inner())
}
