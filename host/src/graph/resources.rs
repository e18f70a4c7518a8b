//! Typed buffer handles, created per simulation: a simulation (or a standalone LBVH) declares
//! the buffers it needs here, and an executor allocates them. Nothing is global, so one
//! simulation can hold any number of LBVHs, sorts or cloths.

use std::marker::PhantomData;

/// An untyped buffer handle: an index into the `Resources` that created it.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct BufferId(pub(crate) u32);

impl BufferId {
    /// Position in its `Resources`.
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// A buffer of `len` elements of `T` (a GPU struct from `drape-types`, `u32` or `Vec4`).
pub struct Handle<T> {
    id: BufferId,
    len: u32,
    _element: PhantomData<fn() -> T>,
}

// Manual impls: a handle is Copy whatever `T` is.
impl<T> Clone for Handle<T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for Handle<T> {}
impl<T> PartialEq for Handle<T> {
    fn eq(&self, other: &Self) -> bool {
        self.id == other.id && self.len == other.len
    }
}
impl<T> Eq for Handle<T> {}
impl<T> std::fmt::Debug for Handle<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Handle<{}>({}, len {})", std::any::type_name::<T>(), self.id.0, self.len)
    }
}

impl<T> Handle<T> {
    pub fn id(self) -> BufferId {
        self.id
    }
    /// Elements of `T` the buffer holds.
    pub fn len(self) -> u32 {
        self.len
    }
    pub fn is_empty(self) -> bool {
        self.len == 0
    }
}

/// Where a buffer lives.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Memory {
    /// Device-local: written and read by kernels, transferred through staging memory.
    Device,
    /// Host-visible and mapped: small status buffers the host reads after every frame.
    Readback,
}

/// One declared buffer.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BufferDesc {
    /// Debug name (Vulkan object name, memory report).
    pub name: String,
    pub bytes: u64,
    pub memory: Memory,
}

/// The buffers of one simulation, in creation order.
#[derive(Clone, Debug, Default)]
pub struct Resources {
    descs: Vec<BufferDesc>,
}

impl Resources {
    pub fn new() -> Self {
        Self::default()
    }

    /// Declares a buffer of `len` elements of `T` (at least 4 bytes are allocated).
    pub fn buffer<T: bytemuck::Pod>(&mut self, name: impl Into<String>, len: u32, memory: Memory) -> Handle<T> {
        let id = BufferId(self.descs.len() as u32);
        let bytes = (len as u64 * size_of::<T>() as u64).max(4);
        self.descs.push(BufferDesc { name: name.into(), bytes, memory });
        Handle { id, len, _element: PhantomData }
    }

    /// A device buffer of `len` elements.
    pub fn device<T: bytemuck::Pod>(&mut self, name: impl Into<String>, len: u32) -> Handle<T> {
        self.buffer(name, len, Memory::Device)
    }

    /// A mapped buffer holding one `T`, read by the host.
    pub fn readback<T: bytemuck::Pod>(&mut self, name: impl Into<String>) -> Handle<T> {
        self.buffer(name, 1, Memory::Readback)
    }

    pub fn get(&self, id: BufferId) -> Option<&BufferDesc> {
        self.descs.get(id.index())
    }

    pub fn descs(&self) -> &[BufferDesc] {
        &self.descs
    }

    pub fn len(&self) -> usize {
        self.descs.len()
    }

    pub fn is_empty(&self) -> bool {
        self.descs.is_empty()
    }

    /// Total bytes declared.
    pub fn total_bytes(&self) -> u64 {
        self.descs.iter().map(|d| d.bytes).sum()
    }
}

/// An executor whose buffers can be read back (the Vulkan and the CPU executor).
pub trait ReadBuffers {
    /// The first `count` elements of `buffer`.
    fn read<T: bytemuck::Pod>(&self, buffer: Handle<T>, count: usize) -> crate::Result<Vec<T>>;
}
