//! Minimal SPIR-V reflection: for each entry point, its descriptor bindings (set, binding, name,
//! writable) and whether it uses push constants. Used to check the host's binding tables against
//! what the kernels really declare.

use super::spirv::{OP_ENTRY_POINT, OP_NAME, OP_VARIABLE, instructions, literal_string, module_words};
use std::collections::HashMap;

/// One storage-buffer binding as the SPIR-V declares it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ReflectedBinding {
    pub set: u32,
    pub binding: u32,
    pub name: String,
    pub writable: bool,
}

/// An entry point's resource interface.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ReflectedEntry {
    pub bindings: Vec<ReflectedBinding>,
    pub uses_push_constants: bool,
    /// `LocalSize` execution mode (threads per workgroup).
    pub workgroup_size: [u32; 3],
    /// The SPIR-V execution model (`EXECUTION_MODEL_GL_COMPUTE`, `_VERTEX`, `_FRAGMENT`).
    pub execution_model: u32,
}

pub const EXECUTION_MODEL_VERTEX: u32 = 0;
pub const EXECUTION_MODEL_FRAGMENT: u32 = 4;
pub const EXECUTION_MODEL_GL_COMPUTE: u32 = 5;

const OP_EXECUTION_MODE: u32 = 16;
const EXECUTION_MODE_LOCAL_SIZE: u32 = 17;
const OP_DECORATE: u32 = 71;
const DECORATION_NON_WRITABLE: u32 = 24;
const DECORATION_BINDING: u32 = 33;
const DECORATION_DESCRIPTOR_SET: u32 = 34;
const STORAGE_CLASS_PUSH_CONSTANT: u32 = 9;
const STORAGE_CLASS_STORAGE_BUFFER: u32 = 12;

/// Reflects every entry point of a SPIR-V module (SPIR-V >= 1.4: interfaces list all globals).
pub fn reflect(spirv: &[u8]) -> Result<HashMap<String, ReflectedEntry>, String> {
    let words = module_words(spirv)?;
    let mut names: HashMap<u32, String> = HashMap::new();
    let mut entries: Vec<(String, u32, u32, Vec<u32>)> = Vec::new();
    let mut local_size: HashMap<u32, [u32; 3]> = HashMap::new();
    let mut storage: HashMap<u32, u32> = HashMap::new();
    let mut binding: HashMap<u32, u32> = HashMap::new();
    let mut set: HashMap<u32, u32> = HashMap::new();
    let mut non_writable: HashMap<u32, bool> = HashMap::new();
    for (opcode, ops) in instructions(&words)? {
        match opcode {
            OP_NAME if ops.len() >= 2 => {
                names.insert(ops[0], literal_string(&ops[1..]).0);
            }
            OP_ENTRY_POINT if ops.len() >= 3 => {
                let (name, used) = literal_string(&ops[2..]);
                entries.push((name, ops[0], ops[1], ops[2 + used..].to_vec()));
            }
            OP_EXECUTION_MODE if ops.len() >= 5 && ops[1] == EXECUTION_MODE_LOCAL_SIZE => {
                local_size.insert(ops[0], [ops[2], ops[3], ops[4]]);
            }
            OP_VARIABLE if ops.len() >= 3 => {
                storage.insert(ops[1], ops[2]);
            }
            OP_DECORATE if ops.len() >= 2 => match ops[1] {
                DECORATION_BINDING if ops.len() >= 3 => {
                    binding.insert(ops[0], ops[2]);
                }
                DECORATION_DESCRIPTOR_SET if ops.len() >= 3 => {
                    set.insert(ops[0], ops[2]);
                }
                DECORATION_NON_WRITABLE => {
                    non_writable.insert(ops[0], true);
                }
                _ => {}
            },
            _ => {}
        }
    }
    let mut out = HashMap::new();
    for (name, execution_model, function, interface) in entries {
        let mut entry = ReflectedEntry {
            workgroup_size: local_size.get(&function).copied().unwrap_or_default(),
            execution_model,
            ..ReflectedEntry::default()
        };
        for id in interface {
            match storage.get(&id) {
                Some(&STORAGE_CLASS_STORAGE_BUFFER) => entry.bindings.push(ReflectedBinding {
                    set: set.get(&id).copied().unwrap_or(0),
                    binding: binding.get(&id).copied().unwrap_or(u32::MAX),
                    name: names.get(&id).cloned().unwrap_or_default(),
                    writable: !non_writable.contains_key(&id),
                }),
                Some(&STORAGE_CLASS_PUSH_CONSTANT) => entry.uses_push_constants = true,
                _ => {}
            }
        }
        entry.bindings.sort_by_key(|b| (b.set, b.binding));
        out.insert(name, entry);
    }
    Ok(out)
}
