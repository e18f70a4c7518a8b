//! Decoding a SPIR-V module's words and instructions, for the checks that read the kernels'
//! SPIR-V without a GPU (`reflect`, `portability`).

pub const OP_NAME: u32 = 5;
pub const OP_ENTRY_POINT: u32 = 15;
pub const OP_VARIABLE: u32 = 59;

/// Decodes a literal string starting at `words[0]`; returns it and the words it used.
pub fn literal_string(words: &[u32]) -> (String, usize) {
    let mut bytes = Vec::new();
    for (i, w) in words.iter().enumerate() {
        for b in w.to_le_bytes() {
            if b == 0 {
                return (String::from_utf8_lossy(&bytes).into_owned(), i + 1);
            }
            bytes.push(b);
        }
    }
    (String::from_utf8_lossy(&bytes).into_owned(), words.len())
}

/// The words of a SPIR-V module, checked for its magic number.
pub fn module_words(spirv: &[u8]) -> Result<Vec<u32>, String> {
    if !spirv.len().is_multiple_of(4) || spirv.len() < 20 {
        return Err("not a SPIR-V module (length)".into());
    }
    let words: Vec<u32> =
        spirv.as_chunks::<4>().0.iter().map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    if words[0] != 0x0723_0203 {
        return Err("not a SPIR-V module (magic)".into());
    }
    Ok(words)
}

/// The instructions of a module's words (after the 5-word header): opcode and operands.
pub fn instructions(words: &[u32]) -> Result<Vec<(u32, &[u32])>, String> {
    let mut out = Vec::new();
    let mut at = 5;
    while at < words.len() {
        let count = (words[at] >> 16) as usize;
        if count == 0 || at + count > words.len() {
            return Err(format!("malformed instruction at word {at}"));
        }
        out.push((words[at] & 0xffff, &words[at + 1..at + count]));
        at += count;
    }
    Ok(out)
}
