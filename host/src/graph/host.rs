//! Buffers as the CPU executor holds them, and what a kernel's CPU adapter gets: the bound
//! buffers in binding order, the push constants and the dispatch size.

use glam::Vec4;

/// A buffer in host memory. Stored as `Vec4`s so the bytes are 16-byte aligned and can be viewed
/// as any GPU struct (`Aabb`, `BvhNode`, `u32`, ...).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HostBuffer {
    storage: Vec<Vec4>,
    bytes: usize,
}

impl HostBuffer {
    /// `bytes` zero bytes.
    pub fn zeroed(bytes: u64) -> Self {
        let bytes = bytes as usize;
        HostBuffer { storage: vec![Vec4::ZERO; bytes.div_ceil(16)], bytes }
    }

    pub fn bytes(&self) -> &[u8] {
        &bytemuck::cast_slice(&self.storage)[..self.bytes]
    }

    pub fn bytes_mut(&mut self) -> &mut [u8] {
        &mut bytemuck::cast_slice_mut(&mut self.storage)[..self.bytes]
    }

    /// The buffer as whole elements of `T` (a trailing partial element is left out).
    pub fn slice<T: bytemuck::Pod>(&self) -> &[T] {
        let whole = self.bytes / size_of::<T>() * size_of::<T>();
        bytemuck::cast_slice(&self.bytes()[..whole])
    }

    pub fn slice_mut<T: bytemuck::Pod>(&mut self) -> &mut [T] {
        let whole = self.bytes / size_of::<T>() * size_of::<T>();
        bytemuck::cast_slice_mut(&mut self.bytes_mut()[..whole])
    }

    /// The first element (a parameter or status struct).
    pub fn first<T: bytemuck::Pod>(&self) -> Result<T, String> {
        self.slice::<T>().first().copied().ok_or_else(|| format!("buffer of {} bytes holds no element", self.bytes))
    }

    pub fn first_mut<T: bytemuck::Pod>(&mut self) -> Result<&mut T, String> {
        let bytes = self.bytes;
        self.slice_mut::<T>().first_mut().ok_or_else(|| format!("buffer of {bytes} bytes holds no element"))
    }

    /// Writes `data` at the start.
    pub fn write(&mut self, data: &[u8]) -> Result<(), String> {
        self.write_at(0, data)
    }

    /// Writes `data` from byte `offset` on.
    pub fn write_at(&mut self, offset: u64, data: &[u8]) -> Result<(), String> {
        let target = self.bytes_mut();
        let end = offset as usize + data.len();
        if end > target.len() {
            return Err(format!("{} bytes at offset {offset} into a {}-byte buffer", data.len(), target.len()));
        }
        target[offset as usize..end].copy_from_slice(data);
        Ok(())
    }

    /// Sets every 32-bit word to `value`.
    pub fn fill(&mut self, value: u32) {
        self.slice_mut::<u32>().fill(value);
    }
}

/// One dispatch as a CPU adapter sees it.
pub struct HostDispatch<'a> {
    /// Workgroups to run and threads per workgroup.
    pub workgroups: u32,
    pub workgroup_size: u32,
    /// Push constants (zero when the pass has none).
    pub push: [u32; 4],
    /// The bound buffers, binding i at [i].
    pub buffers: &'a mut [HostBuffer],
}

impl HostDispatch<'_> {
    /// Total invocations (`global_invocation_id.x` runs over `0..invocations()`).
    pub fn invocations(&self) -> u32 {
        self.workgroups * self.workgroup_size
    }

    /// All `N` bindings, mutably.
    pub fn bindings<const N: usize>(&mut self) -> Result<[&mut HostBuffer; N], String> {
        if self.buffers.len() != N {
            return Err(format!("{} buffers bound, the kernel declares {N}", self.buffers.len()));
        }
        let indices: [usize; N] = std::array::from_fn(|i| i);
        self.buffers.get_disjoint_mut(indices).map_err(|e| format!("bindings: {e}"))
    }

    /// The push constants as `T`.
    pub fn push_as<T: bytemuck::Pod>(&self) -> T {
        bytemuck::pod_read_unaligned(&bytemuck::bytes_of(&self.push)[..size_of::<T>()])
    }
}
