//! What real GPU drivers' shader compilers crash on, found in a SPIR-V module without a GPU.
//!
//! NVIDIA's Vulkan driver (580 on an H100) crashes in `vkCreateComputePipelines` on a kernel
//! that holds a pointer as data: a phi or select whose value is, or holds, a pointer (rust-gpu
//! lowers a slice to a pointer and a length, so a struct of slices and counters that a loop
//! updates becomes a phi of pointers), or a function-local variable that holds one (a struct
//! of slices whose address was taken). Lavapipe compiles both, so only this check keeps them
//! out of the kernels. The kernels' side of the rule is in `drape_kernels::lbvh::TreeQuery`.

use super::spirv::{OP_ENTRY_POINT, OP_NAME, OP_VARIABLE, instructions, literal_string, module_words};
use std::collections::{HashMap, HashSet};

const OP_TYPE_ARRAY: u32 = 28;
const OP_TYPE_RUNTIME_ARRAY: u32 = 29;
const OP_TYPE_STRUCT: u32 = 30;
const OP_TYPE_POINTER: u32 = 32;
const OP_FUNCTION: u32 = 54;
const OP_SELECT: u32 = 169;
const OP_PHI: u32 = 245;
const STORAGE_CLASS_FUNCTION: u32 = 7;

/// One value that holds a pointer as data.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PointerValue {
    /// The function it is in: its entry point's name, else its debug name or id.
    pub function: String,
    /// What holds the pointer: `OpPhi`, `OpSelect` or `function variable`.
    pub kind: &'static str,
}

/// Every phi, select and function-local variable of `spirv` that is or holds a pointer.
pub fn pointer_values(spirv: &[u8]) -> Result<Vec<PointerValue>, String> {
    let words = module_words(spirv)?;
    let instructions = instructions(&words)?;
    // Types that are pointers or hold one (types are declared before use, so one pass).
    let mut pointer_types: HashSet<u32> = HashSet::new();
    let mut pointees: HashMap<u32, u32> = HashMap::new();
    let mut names: HashMap<u32, String> = HashMap::new();
    for &(opcode, ops) in &instructions {
        match opcode {
            OP_TYPE_POINTER if ops.len() >= 3 => {
                pointer_types.insert(ops[0]);
                pointees.insert(ops[0], ops[2]);
            }
            OP_TYPE_STRUCT if ops.iter().skip(1).any(|m| pointer_types.contains(m)) => {
                pointer_types.insert(ops[0]);
            }
            OP_TYPE_ARRAY | OP_TYPE_RUNTIME_ARRAY if ops.len() >= 2 && pointer_types.contains(&ops[1]) => {
                pointer_types.insert(ops[0]);
            }
            OP_NAME if ops.len() >= 2 => {
                names.insert(ops[0], literal_string(&ops[1..]).0);
            }
            OP_ENTRY_POINT if ops.len() >= 3 => {
                names.insert(ops[1], literal_string(&ops[2..]).0);
            }
            _ => {}
        }
    }
    let mut found = Vec::new();
    let mut function = String::new();
    for &(opcode, ops) in &instructions {
        let kind = match opcode {
            OP_FUNCTION if ops.len() >= 2 => {
                function = names.get(&ops[1]).cloned().unwrap_or_else(|| format!("%{}", ops[1]));
                None
            }
            OP_PHI if pointer_types.contains(&ops[0]) => Some("OpPhi"),
            OP_SELECT if pointer_types.contains(&ops[0]) => Some("OpSelect"),
            OP_VARIABLE
                if ops.len() >= 3
                    && ops[2] == STORAGE_CLASS_FUNCTION
                    && pointees.get(&ops[0]).is_some_and(|p| pointer_types.contains(p)) =>
            {
                Some("function variable")
            }
            _ => None,
        };
        if let Some(kind) = kind {
            found.push(PointerValue { function: function.clone(), kind });
        }
    }
    Ok(found)
}
