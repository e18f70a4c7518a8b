//! Compute pipelines built from the embedded SPIR-V, one per entry point (each from its own
//! module), each with the descriptor-set layout that its `KernelSpec` (the host's binding
//! table) declares.

use super::context::Context;
use crate::error::{Error, Result, VkContext};
use crate::graph::KernelSpec;
use ash::vk;
use std::ffi::CString;
use std::sync::Arc;

/// A shader module, alive while pipelines are created from it (they keep their own copy).
pub struct ShaderModule {
    ctx: Arc<Context>,
    pub(crate) handle: vk::ShaderModule,
}

impl ShaderModule {
    /// The embedded module of entry point `entry`.
    pub fn for_entry(ctx: &Arc<Context>, entry: &str) -> Result<Self> {
        let spirv = crate::kernel_module(entry).ok_or_else(|| Error::Kernel {
            kernel: entry.into(),
            problem: "no SPIR-V module has this entry point: rebuild drape (kernels/spirv/ is stale)".into(),
        })?;
        Self::new(ctx, spirv)
    }

    pub fn new(ctx: &Arc<Context>, spirv: &[u8]) -> Result<Self> {
        let code = ash::util::read_spv(&mut std::io::Cursor::new(spirv))
            .map_err(|e| Error::Kernel { kernel: "module".into(), problem: format!("bad SPIR-V: {e}") })?;
        let info = vk::ShaderModuleCreateInfo::default().code(&code);
        // SAFETY: valid device; code is a complete SPIR-V module.
        let handle = unsafe { ctx.device.create_shader_module(&info, None) }.vk("vkCreateShaderModule")?;
        Ok(ShaderModule { ctx: ctx.clone(), handle })
    }
}

impl Drop for ShaderModule {
    fn drop(&mut self) {
        // SAFETY: pipelines created from it keep their own copy of the code.
        unsafe { self.ctx.device.destroy_shader_module(self.handle, None) };
    }
}

/// A compute pipeline with its layouts.
pub struct Pipeline {
    ctx: Arc<Context>,
    pub spec: KernelSpec,
    pub(crate) set_layout: vk::DescriptorSetLayout,
    pub(crate) layout: vk::PipelineLayout,
    pub(crate) pipeline: vk::Pipeline,
}

impl Pipeline {
    pub fn new(ctx: &Arc<Context>, spec: KernelSpec) -> Result<Self> {
        let module = ShaderModule::for_entry(ctx, spec.entry)?;
        let bindings: Vec<_> = (0..spec.bindings.len() as u32)
            .map(|i| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(i)
                    .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                    .descriptor_count(1)
                    .stage_flags(vk::ShaderStageFlags::COMPUTE)
            })
            .collect();
        let set_info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
        let mut pipeline = Pipeline {
            ctx: ctx.clone(),
            spec,
            set_layout: vk::DescriptorSetLayout::null(),
            layout: vk::PipelineLayout::null(),
            pipeline: vk::Pipeline::null(),
        };
        // SAFETY (this block): valid device and create infos; each handle is stored in
        // `pipeline` at once, so an early return destroys what was made.
        unsafe {
            pipeline.set_layout =
                ctx.device.create_descriptor_set_layout(&set_info, None).vk("vkCreateDescriptorSetLayout")?;
            let ranges = [vk::PushConstantRange::default()
                .stage_flags(vk::ShaderStageFlags::COMPUTE)
                .offset(0)
                .size(spec.push_constant_size)];
            let set_layouts = [pipeline.set_layout];
            let mut layout_info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
            if spec.push_constant_size > 0 {
                layout_info = layout_info.push_constant_ranges(&ranges);
            }
            pipeline.layout = ctx.device.create_pipeline_layout(&layout_info, None).vk("vkCreatePipelineLayout")?;
            let entry = CString::new(spec.entry)
                .map_err(|_| Error::Kernel { kernel: spec.entry.into(), problem: "entry name contains NUL".into() })?;
            let stage = vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::COMPUTE)
                .module(module.handle)
                .name(&entry);
            let info = [vk::ComputePipelineCreateInfo::default().stage(stage).layout(pipeline.layout)];
            // The driver compiles the kernel here: the slowest call of a solver's setup on a
            // real GPU, and where a driver's compiler would fail.
            log::debug!("compiling kernel {}", spec.entry);
            let started = std::time::Instant::now();
            pipeline.pipeline = ctx
                .device
                .create_compute_pipelines(vk::PipelineCache::null(), &info, None)
                .map_err(|(_, result)| Error::Vulkan { call: "vkCreateComputePipelines", result })?[0];
            log::debug!("compiled kernel {} in {:.1} ms", spec.entry, started.elapsed().as_secs_f64() * 1e3);
        }
        ctx.name_object(pipeline.pipeline, spec.entry);
        Ok(pipeline)
    }
}

impl Drop for Pipeline {
    fn drop(&mut self) {
        // SAFETY: owners wait for submitted work before dropping pipelines; null handles are
        // ignored by vkDestroy*.
        unsafe {
            self.ctx.device.destroy_pipeline(self.pipeline, None);
            self.ctx.device.destroy_pipeline_layout(self.layout, None);
            self.ctx.device.destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}
